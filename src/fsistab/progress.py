"""Progress reporting, clean interruption and the BLAS threads of long computations: what the
command line and the Python API share.

:class:`Reporter` shows a spinner on a terminal and, when the stream is not a terminal (a log file,
a pipe, a batch job), prints one plain line per step, ``[   12.3 s] message``, so that a long run
leaves a readable log. Given a ``logger`` instead, it emits the same lines as INFO records of the
logger ``fsistab``: the Python API's progress, silent until the user turns it on
(:func:`show_progress`, or any logging configuration). :func:`reporting` picks between the two.

:func:`blas_threads` runs a block with BLAS on one thread unless the user chose a number: fsistab
runs its own threads (two sparse factorisations at once), and BLAS threads beside them slow it
down on shared cores. Importing fsistab changes nothing; the command line and each workflow run
inside the block (a workflow through :func:`running`, which also gives it its progress callback).

:func:`interruptible` turns SIGINT and SIGTERM into an exception inside its block, then says how
long the run lasted, which files were saved and how to resume, and exits with the conventional
status ``128 + signal`` (130, 143). Nest the reporter inside, so that the spinner is gone before
the message is written::

    with interruptible(lambda: store_files(out), "rerun the same command to resume"), Reporter() as reporter:
        result = workflow(..., progress=reporter)
"""

from __future__ import annotations

import logging
import os
import re
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator, MutableMapping
from contextlib import contextmanager
from pathlib import Path
from typing import TextIO

_ANSI = re.compile(r"\x1b\[[0-9;?]*[ -/]*[@-~]|\x1b\][^\x07]*\x07")
_SHOWN_FILES = 5
LOGGER = "fsistab"
# the variables that set the BLAS and OpenMP threads: a user who set any of them chose
BLAS_THREADS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


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
    ``stream`` (default ``sys.stderr``) is a terminal. With ``logger``, the lines go to it as INFO
    records instead of to a stream, and there is no spinner.
    """

    def __init__(
        self,
        stream: TextIO | None = None,
        interactive: bool | None = None,
        label: str = "",
        logger: logging.Logger | None = None,
    ):
        self._stream = stream
        self._interactive = interactive
        self._label = one_line(label)
        self._logger = logger
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
        if self._logger is not None:
            return False
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
        line = f"[{self.elapsed:7.1f} s] {text}"
        if self._logger is not None:
            self._logger.info("%s", line)
            return
        self.stream.write(line + "\n")
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


Progress = Callable[[str], None] | None
"""The one progress interface of fsistab: a callable taking one line of text (or None: silent).
Every long computation reports through it (workflows, thresholds, solvers, the steady flow); the
command line passes a :class:`Reporter`, the Python API a logging reporter (:func:`reporting`)."""


@contextmanager
def reporting(progress: Progress = None) -> Iterator[Callable[[str], None]]:
    """The progress callback of one workflow call: ``progress`` when the caller gave one (the
    command line's :class:`Reporter`), else a :class:`Reporter` whose timed lines are INFO records
    of the logger ``fsistab`` (shown by :func:`show_progress`)."""
    if progress is not None:
        yield progress
        return
    with Reporter(logger=logging.getLogger(LOGGER)) as reporter:
        yield reporter


@contextmanager
def running(progress: Progress = None) -> Iterator[Callable[[str], None]]:
    """What every workflow runs in, called from Python or from the command line: BLAS on one thread
    (:func:`blas_threads`) and its progress callback (:func:`reporting`), yielded::

        with running(progress) as say:
            say("steady state")
    """
    with blas_threads(), reporting(progress) as say:
        yield say


class _ProgressHandler(logging.Handler):
    """fsistab's records as plain lines on a stream (stderr by default, resolved at each record):
    progress as it comes, warnings prefixed ``warning:``."""

    def __init__(self, stream: TextIO | None = None, level: int = logging.INFO):
        super().__init__(level)
        self._stream = stream

    def emit(self, record: logging.LogRecord) -> None:
        try:
            text = one_line(record.getMessage())
            if record.levelno >= logging.WARNING:
                text = f"{record.levelname.lower()}: {text}"
            stream = self._stream if self._stream is not None else sys.stderr
            stream.write(text + "\n")
            stream.flush()
        except Exception:  # progress must never end the run
            self.handleError(record)


def show_progress(stream: TextIO | None = None, level: int = logging.INFO) -> logging.Handler:
    """Print the progress of fsistab's workflows called from Python, one timed line per step, on
    ``stream`` (default stderr): attaches a plain handler to the logger ``fsistab`` and lowers its
    level to ``level`` if it is higher or unset. A second call returns the handler already there.
    ``logging.getLogger("fsistab").removeHandler(handler)`` turns it off again."""
    logger = logging.getLogger(LOGGER)
    for handler in logger.handlers:
        if isinstance(handler, _ProgressHandler):
            return handler
    handler = _ProgressHandler(stream, level)
    logger.addHandler(handler)
    if logger.level == logging.NOTSET or logger.level > level:
        logger.setLevel(level)
    return handler


# --- BLAS threads ------------------------------------------------------------------------------


@contextmanager
def blas_threads(environ: MutableMapping[str, str] | None = None) -> Iterator[bool]:
    """Run the block with BLAS and OpenMP on one thread, unless the user set any of
    :data:`BLAS_THREADS` in ``environ`` (default ``os.environ``): then nothing changes (OpenBLAS
    reads its own variable before ``OMP_NUM_THREADS``, so setting one would override the user's
    choice). Yields whether it pinned the threads.

    fsistab runs its own threads (two sparse factorisations at once,
    :func:`fsistab.linalg.sample_threads`); BLAS threads beside them oversubscribe the cores and
    slow every factorisation down. The block sets the variables to 1, so that the libraries that
    load inside it (NumPy and NGSolve, which the command line imports lazily) and the processes it
    starts (a dask ``LocalCluster``'s workers) use one thread, and limits the libraries already
    loaded (``threadpoolctl``; none is before NumPy is imported, and then it is not even imported,
    which keeps the command line's start quick). On exit the variables and the libraries' thread
    counts come back; a library first loaded inside the block gets the count of a library of the
    same kind loaded before (the user's BLAS setting), if there was one. A block inside another
    pins nothing more. Usable as a decorator too (``@blas_threads()``).
    """
    environ = os.environ if environ is None else environ
    if any(name in environ for name in BLAS_THREADS):
        yield False
        return
    before = None
    if "numpy" in sys.modules:  # else no BLAS is loaded yet (the command line at its start)
        from threadpoolctl import ThreadpoolController

        before = {lib.filepath: lib.num_threads for lib in ThreadpoolController().lib_controllers}
        ThreadpoolController().limit(limits=1)
    environ.update(dict.fromkeys(BLAS_THREADS, "1"))
    try:
        yield True
    finally:
        for name in BLAS_THREADS:
            environ.pop(name, None)
        if before is not None:
            _restore_threads(before)


def _restore_threads(before: dict[str, int]) -> None:
    """Give each loaded BLAS/OpenMP library its thread count of ``before`` (by file); one loaded
    since gets the largest count of the libraries of its kind in ``before``, else keeps its own."""
    from threadpoolctl import ThreadpoolController

    libraries = ThreadpoolController().lib_controllers
    by_kind: dict[str, int] = {}
    for lib in libraries:
        if lib.filepath in before:
            by_kind[lib.internal_api] = max(by_kind.get(lib.internal_api, 0), before[lib.filepath])
    for lib in libraries:
        count = before.get(lib.filepath, by_kind.get(lib.internal_api))
        if count is not None and count != lib.num_threads:
            lib.set_num_threads(count)


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
