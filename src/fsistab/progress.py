"""Progress reporting and clean interruption of long computations (the command-line shell's side).

:class:`Reporter` shows a spinner on a terminal and, when the stream is not a terminal (a log file,
a pipe, a batch job), prints one plain line per step, ``[   12.3 s] message``, so that a long run
leaves a readable log. Library functions report progress through callbacks of various shapes;
:meth:`Reporter.step` and the small adapters (:meth:`Reporter.steady`, :meth:`Reporter.count`,
:meth:`Reporter.tracking`) turn them into messages.

:func:`interruptible` turns SIGINT and SIGTERM into an exception inside its block, then says how
long the run lasted, which files were saved and how to resume, and exits with the conventional
status ``128 + signal`` (130, 143). Nest the reporter inside, so that the spinner is gone before
the message is written::

    with interruptible(lambda: store_files(out), "rerun the same command to resume"), Reporter() as reporter:
        result = workflow(..., progress=reporter)
"""

from __future__ import annotations

import re
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TextIO

_ANSI = re.compile(r"\x1b\[[0-9;?]*[ -/]*[@-~]|\x1b\][^\x07]*\x07")
_SHOWN_FILES = 5


def one_line(message: str) -> str:
    """``message`` without control sequences or line breaks (a log line stays one line)."""
    return " ".join(_ANSI.sub("", str(message)).split())


def _is_terminal(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # no isatty, or a closed stream
        return False


class Reporter:
    """Progress of one long computation: a spinner on a terminal, plain timed lines otherwise.

    Use as a context manager; ``reporter.update(message)`` (or ``reporter(message)``, so the
    reporter itself is a ``progress=`` callback taking a string) replaces the spinner's text or,
    when ``stream`` is not a terminal, prints ``[elapsed s] message`` and flushes. A message equal
    to the previous one is printed once. ``label``, when given, prefixes every message.
    ``interactive`` forces (True) or suppresses (False) the spinner; by default it is shown when
    ``stream`` (default ``sys.stderr``) is a terminal.
    """

    def __init__(self, stream: TextIO | None = None, interactive: bool | None = None, label: str = ""):
        self._stream = stream
        self._interactive = interactive
        self._label = one_line(label)
        self._start: float | None = None
        self._last: str | None = None
        self._status = None
        self._console = None

    @property
    def stream(self) -> TextIO:
        # resolved late: sys.stderr may be replaced (pytest's capture) after construction
        return self._stream if self._stream is not None else sys.stderr

    @property
    def interactive(self) -> bool:
        return _is_terminal(self.stream) if self._interactive is None else bool(self._interactive)

    @property
    def elapsed(self) -> float:
        """Seconds since the reporter was entered (0 before)."""
        return 0.0 if self._start is None else time.monotonic() - self._start

    def __enter__(self) -> Reporter:
        self._start = time.monotonic()
        self._last = None
        if self.interactive:
            from rich.console import Console
            from rich.text import Text

            self._console = Console(file=self.stream, force_terminal=True)
            self._status = self._console.status(Text(self._label or "working"))
            self._status.start()
        return self

    def __exit__(self, *exc_info) -> None:
        self._stop_spinner()

    def _stop_spinner(self) -> None:
        if self._status is not None:
            self._status.stop()
            self._status = None

    def _text(self, message: str) -> str:
        message = one_line(message)
        return f"{self._label}: {message}" if self._label else message

    def _line(self, text: str) -> None:
        self.stream.write(f"[{self.elapsed:7.1f} s] {text}\n")
        self.stream.flush()

    def update(self, message: str) -> None:
        """Show ``message`` as the current step (printed once if it repeats the previous one)."""
        text = self._text(message)
        if text == self._last:
            return
        self._last = text
        if self._status is not None:
            from rich.text import Text

            self._status.update(Text(text))
        elif self._start is not None or not self.interactive:
            self._line(text)

    __call__ = update

    def done(self, message: str) -> None:
        """Final line: stops the spinner and prints ``message`` with the elapsed time."""
        text = self._text(message)
        if self._status is not None:
            self._stop_spinner()
            from rich.text import Text

            self._console.print(Text(f"{text} ({self.elapsed:.1f} s)"))
        else:
            self._line(text)
        self._last = text

    # adapters for the library's callbacks ------------------------------------------------------

    def step(self, fmt: str, **live: Callable[[], object]) -> Callable[..., None]:
        """A callback of any shape: its positional arguments fill ``fmt`` (``str.format``:
        ``{0}``, ``{1:.4g}``, ``{0.reynolds}``), and each keyword of ``live`` is a function called
        at each step, e.g. ``factorisations=lambda: counter.count`` for ``{factorisations}``."""

        def callback(*args) -> None:
            self.update(fmt.format(*args, **{name: value() for name, value in live.items()}))

        return callback

    def steady(self, flow, iterations: int) -> None:
        """Callback of :func:`fsistab.steady.solve_steady`: ``progress(step_flow, iterations)``."""
        self.update(
            f"continuation: Re = {flow.reynolds:.4g}, alpha0 = {flow.alpha0_deg:.3g} deg "
            f"converged in {iterations} Newton iterations"
        )

    def count(self, what: str) -> Callable[[int, int], None]:
        """Callback ``progress(done, total)`` (transfer samples, points of a list): ``what done/total``."""
        return self.step(f"{one_line(what)} {{0}}/{{1}}")

    def tracking(self, total: int, counter=None) -> Callable[[int, float], None]:
        """Callback ``progress(i, velocity)`` of the branch tracking (``i`` from 0), with the
        number of factorisations of ``counter`` (a :class:`fsistab.linalg.FactorCounter`) if given."""

        def callback(i: int, velocity: float) -> None:
            text = f"tracking branches: point {i + 1}/{total}, U* = {velocity:.4g}"
            if counter is not None:
                text += f", {counter.count} factorisations"
            self.update(text)

        return callback


class Interrupted(KeyboardInterrupt):
    """Raised inside an :func:`interruptible` block by SIGINT or SIGTERM (``signum``)."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def _files(paths: Iterable[Path] | str) -> str:
    """``2 files: a.nc, b.nc``: the distinct files of ``paths`` in the order first written (a
    resumable table saved after each record is one file, not one per save)."""
    if isinstance(paths, str):
        return paths
    names = list(dict.fromkeys(str(path) for path in paths))
    if not names:
        return "nothing"
    shown = ", ".join(names[:_SHOWN_FILES]) + (", …" if len(names) > _SHOWN_FILES else "")
    return f"{len(names)} file{'s' if len(names) > 1 else ''}: {shown}"


def interruption_message(elapsed: float, saved: Iterable[Path] | str, resume_hint: str) -> str:
    """``interrupted after 12.3 s; saved: 2 files: a.nc, b.nc; rerun the same command to resume``
    (each file once, at most five named, then ``…``; ``saved`` may also be a ready-made
    description)."""
    return f"interrupted after {elapsed:.1f} s; saved: {_files(saved)}; {resume_hint}"


_EXIT_STATUS = {signal.SIGINT: 130, signal.SIGTERM: 143}


@contextmanager
def interruptible(
    saved: Callable[[], list[Path]],
    resume_hint: str = "rerun the same command to resume",
    stream: TextIO | None = None,
) -> Iterator[None]:
    """Run the block so that SIGINT or SIGTERM ends it cleanly.

    The signal raises :class:`Interrupted` (a KeyboardInterrupt) inside the block, so that its
    ``finally`` clauses and context managers run (temporary files are removed, nothing half-written
    is kept). Then one line goes to ``stream`` (default stderr): the elapsed time, the files
    ``saved()`` lists and ``resume_hint``, and the process exits (SystemExit) with status 130
    (SIGINT) or 143 (SIGTERM). A KeyboardInterrupt raised otherwise in the block counts as SIGINT.
    A signal that was ignored on entry stays ignored (a shell starts background jobs with SIGINT
    ignored). The previous handlers are restored on every exit. Outside the main thread, where Python cannot
    install signal handlers, the block runs unchanged.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    start = time.monotonic()
    reporting = False

    def handler(signum, frame):
        # a second signal while the message is being written is ignored: the run is ending anyway
        if not reporting:
            raise Interrupted(signum)

    previous = {signum: signal.getsignal(signum) for signum in _EXIT_STATUS}
    signum = None
    try:
        for number, old in previous.items():
            if old is not signal.SIG_IGN:  # an ignored signal (a background job's SIGINT) stays ignored
                signal.signal(number, handler)
        yield
    except KeyboardInterrupt as exc:
        reporting = True
        signum = getattr(exc, "signum", signal.SIGINT)
    finally:
        reporting = True
        for number, old in previous.items():
            # None: a handler installed from C, which Python cannot reinstall; the default is closest
            signal.signal(number, signal.SIG_DFL if old is None else old)
    if signum is None:
        return
    elapsed = time.monotonic() - start
    try:
        files = list(saved())
    except Exception as exc:  # the report must not hide the interruption behind a traceback
        files = f"unknown (could not list the files: {one_line(exc)})"
    out = stream if stream is not None else sys.stderr
    out.write(interruption_message(elapsed, files, resume_hint) + "\n")
    out.flush()
    raise SystemExit(_EXIT_STATUS[signal.Signals(signum)])
