"""Progress lines and clean interruption (fsistab.progress): issue #13, item 5."""

import io
import logging
import os
import re
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import pytest

import fsistab
from fsistab import progress
from fsistab.progress import Interrupted, Reporter, interruptible, reporting


class FakeClock:
    """``time.monotonic`` replacement whose value the test sets."""

    def __init__(self, now: float = 1000.0):
        self.now = now

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def clock(monkeypatch):
    fake = FakeClock()
    monkeypatch.setattr(progress.time, "monotonic", fake)
    return fake


# --- Reporter, not a terminal ------------------------------------------------------------------


def test_plain_lines_carry_the_elapsed_time_since_enter(clock):
    stream = io.StringIO()
    with Reporter(stream=stream) as reporter:
        clock.now += 12.34
        reporter.update("steady state")
        clock.now += 100.0
        reporter("eigenvalues")  # the reporter itself is a progress=callback
        assert reporter.elapsed == pytest.approx(112.34)
    assert stream.getvalue() == "[   12.3 s] steady state\n[  112.3 s] eigenvalues\n"


def test_nothing_is_printed_on_enter_or_exit_when_not_a_terminal():
    stream = io.StringIO()
    with Reporter(stream=stream, label="mesh"):
        pass
    assert stream.getvalue() == ""


def test_a_repeated_message_is_printed_once(clock):
    stream = io.StringIO()
    with Reporter(stream=stream) as reporter:
        for message in ("point 1/3", "point 1/3", "point 2/3", "point 2/3", "point 2/3", "point 1/3"):
            reporter.update(message)
    messages = [line.split("] ", 1)[1] for line in stream.getvalue().splitlines()]
    assert messages == ["point 1/3", "point 2/3", "point 1/3"]


def test_lines_have_no_control_sequences_and_stay_one_line():
    stream = io.StringIO()
    with Reporter(stream=stream) as reporter:
        reporter.update("\x1b[1;31mred\x1b[0m text\nsecond line")
    text = stream.getvalue()
    assert "\x1b" not in text
    assert text.count("\n") == 1
    assert text.endswith("] red text second line\n")


def test_label_prefixes_messages_and_done_prints_the_final_line(clock):
    stream = io.StringIO()
    with Reporter(stream=stream, label="neutral") as reporter:
        clock.now += 1.0
        reporter.update("curve 1")
        clock.now += 2.5
        reporter.done("curve 1")  # a final line is printed even if it repeats the last step
    assert stream.getvalue() == "[    1.0 s] neutral: curve 1\n[    3.5 s] neutral: curve 1\n"


def test_with_a_logger_the_lines_are_info_records_and_nothing_is_printed(clock, caplog):
    stream = io.StringIO()
    logger = logging.getLogger("fsistab")
    with caplog.at_level(logging.INFO, logger="fsistab"):
        with Reporter(stream=stream, interactive=True, logger=logger) as reporter:
            assert not reporter.interactive  # never a spinner in a log
            clock.now += 2.0
            reporter("steady state")
            reporter("steady state")
            clock.now += 1.5
            reporter.done("map")
    assert stream.getvalue() == ""
    assert [(r.name, r.levelno, r.getMessage()) for r in caplog.records] == [
        ("fsistab", logging.INFO, "[    2.0 s] steady state"),
        ("fsistab", logging.INFO, "[    3.5 s] map"),
    ]


def test_reporting_passes_a_callback_through_or_logs(caplog):
    seen = []
    with reporting(seen.append) as say:
        say("given")
    assert seen == ["given"]
    with caplog.at_level(logging.INFO, logger="fsistab"), reporting(None) as say:
        say("from the API")
    assert [r.getMessage().split("] ", 1)[1] for r in caplog.records] == ["from the API"]


def test_a_workflow_runs_pinned_and_reporting(monkeypatch, caplog):
    for name in progress.BLAS_THREADS:
        monkeypatch.delenv(name, raising=False)
    with caplog.at_level(logging.INFO, logger="fsistab"), progress.running(None) as say:
        assert all(os.environ[name] == "1" for name in progress.BLAS_THREADS)
        say("fluid operators")
    assert not any(name in os.environ for name in progress.BLAS_THREADS)
    assert [r.getMessage().split("] ", 1)[1] for r in caplog.records] == ["fluid operators"]


@pytest.fixture
def fsistab_logger():
    """The logger ``fsistab`` as a fresh process has it (no handler, level unset: the command
    line's warning handler, installed by other tests in the same worker, removed), restored after
    the test."""
    logger = logging.getLogger("fsistab")
    handlers, level = list(logger.handlers), logger.level
    logger.handlers[:] = []
    logger.setLevel(logging.NOTSET)
    yield logger
    logger.handlers[:] = handlers
    logger.setLevel(level)


def test_the_api_is_silent_until_show_progress(fsistab_logger, capsys):
    with reporting(None) as say:
        say("not shown")
    assert capsys.readouterr().err == ""
    handler = fsistab.show_progress()
    assert fsistab.show_progress() is handler  # once
    with reporting(None) as say:
        say("steady state")
    fsistab_logger.warning("damaged entry moved aside")
    fsistab_logger.debug("not at INFO")
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 2 and re.fullmatch(r"\[ +\d+\.\d s\] steady state", lines[0])
    assert lines[1] == "warning: damaged entry moved aside"
    fsistab_logger.removeHandler(handler)
    with reporting(None) as say:
        say("off again")
    assert capsys.readouterr().err == ""


def test_show_progress_writes_to_a_given_stream_and_keeps_a_lower_level(fsistab_logger):
    fsistab_logger.setLevel(logging.DEBUG)
    stream = io.StringIO()
    fsistab.show_progress(stream)
    assert fsistab_logger.level == logging.DEBUG  # the user's lower level is kept
    fsistab_logger.info("one\nline")
    assert stream.getvalue() == "one line\n"


# --- BLAS threads --------------------------------------------------------------------------------


def _blas_threads() -> dict[str, int]:
    from threadpoolctl import threadpool_info

    return {i["filepath"]: i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}


def test_blas_threads_pin_one_thread_in_the_block_and_restore_after():
    import numpy  # noqa: F401 - its BLAS is loaded
    from threadpoolctl import threadpool_limits

    environ = {"PATH": "/bin"}
    with threadpool_limits(limits=2, user_api="blas"):  # the user's setting before the block
        before = _blas_threads()
        assert before and set(before.values()) == {2}
        with progress.blas_threads(environ) as pinned:
            assert pinned
            assert set(_blas_threads().values()) == {1}
            assert {k: environ[k] for k in progress.BLAS_THREADS} == dict.fromkeys(progress.BLAS_THREADS, "1")
            with progress.blas_threads(environ) as inner:  # nested: nothing more
                assert not inner
        assert _blas_threads() == before
        assert environ == {"PATH": "/bin"}


@pytest.mark.parametrize("variable", ["OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"])
def test_blas_threads_leave_a_user_choice_alone(variable):
    from threadpoolctl import threadpool_limits

    environ = {variable: "2"}
    with threadpool_limits(limits=2, user_api="blas"):
        with progress.blas_threads(environ) as pinned:
            assert not pinned and environ == {variable: "2"}
            assert set(_blas_threads().values()) == {2}


def test_blas_threads_as_a_decorator():
    environ = {}

    @progress.blas_threads(environ)
    def work():
        return dict(environ)

    assert work() == dict.fromkeys(progress.BLAS_THREADS, "1") and environ == {}


_LOADED_INSIDE = textwrap.dedent(
    """
    import json, os
    for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.pop(name, None)
    import numpy
    from threadpoolctl import threadpool_info, threadpool_limits
    import fsistab

    def counts():
        return {i["filepath"]: i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}

    threadpool_limits(limits=2, user_api="blas")  # as on a two-core machine, whatever this one has
    before = counts()
    with fsistab.blas_threads():
        import scipy.linalg  # its own OpenBLAS, loaded inside the block
        inside = counts()
    env = "OMP_NUM_THREADS" in os.environ
    print(json.dumps({"before": before, "inside": inside, "after": counts(), "env": env}))
    """
)


def test_a_library_loaded_inside_the_block_gets_the_user_threads_back():
    import json

    done = subprocess.run([sys.executable, "-c", _LOADED_INSIDE], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    new = set(result["inside"]) - set(result["before"])
    assert new, "scipy loaded no BLAS of its own"
    assert set(result["inside"].values()) == {1}
    assert result["after"] == dict.fromkeys(result["inside"], 2) and not result["env"]


def test_at_the_command_line_start_only_the_variables_are_set():
    """Before NumPy is imported no BLAS is loaded: the variables alone pin the libraries that load
    later, and threadpoolctl is not even imported (the command line answers ``--help`` at once)."""
    code = (
        "import os, sys\n"
        "for name in ('OMP_NUM_THREADS', 'OPENBLAS_NUM_THREADS', 'MKL_NUM_THREADS'):\n"
        "    os.environ.pop(name, None)\n"
        "import fsistab\n"
        "with fsistab.blas_threads() as pinned:\n"
        "    assert 'threadpoolctl' not in sys.modules and 'numpy' not in sys.modules\n"
        "    import numpy\n"
        "    from threadpoolctl import threadpool_info\n"
        "    counts = {i['num_threads'] for i in threadpool_info() if i['user_api'] == 'blas'}\n"
        "    print(pinned, os.environ['OPENBLAS_NUM_THREADS'], counts)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.stdout == "True 1 {1}\n", done.stderr


def test_importing_fsistab_changes_no_global_state():
    code = (
        "import os, logging; before = dict(os.environ); import fsistab; "
        "assert dict(os.environ) == before; "
        "logger = logging.getLogger('fsistab'); assert not logger.handlers and logger.level == 0; print('ok')"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.stdout == "ok\n", done.stderr


def test_a_terminal_gets_the_spinner_not_timed_lines():
    leader, follower = os.openpty()
    with open(follower, "w", closefd=True) as terminal, open(leader, "rb", buffering=0, closefd=True):
        assert Reporter(stream=terminal).interactive
        assert not Reporter(stream=terminal, interactive=False).interactive
    stream = io.StringIO()
    with Reporter(stream=stream, interactive=True) as reporter:
        reporter.update("working hard")
        reporter.done("finished")
    text = stream.getvalue()
    assert "finished (" in text
    assert not re.search(r"^\[ *\d+\.\d s\]", text, re.MULTILINE)


# --- interruptible, in process ---------------------------------------------------------------


def _handlers():
    return signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)


@pytest.fixture(autouse=True)
def signals_not_ignored():
    """Both signals handled by Python during each test, whatever the runner inherited (a shell
    starts background jobs with SIGINT ignored, and interruptible leaves an ignored signal alone)."""
    previous = _handlers()
    signal.signal(signal.SIGINT, signal.default_int_handler)
    if previous[1] is signal.SIG_IGN:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
    yield
    signal.signal(signal.SIGINT, previous[0])
    signal.signal(signal.SIGTERM, previous[1])


def test_handlers_are_installed_in_the_block_and_restored_after_a_normal_exit():
    before = _handlers()
    with interruptible(lambda: []):
        inside = _handlers()
    assert inside[0] is not before[0] and inside[1] is not before[1]
    assert _handlers() == before


def test_handlers_are_restored_after_an_error_which_propagates():
    before = _handlers()
    with pytest.raises(ZeroDivisionError), interruptible(lambda: []):
        1 / 0  # noqa: B018
    assert _handlers() == before


def test_sigterm_in_process_raises_in_the_block_then_exits_143(tmp_path):
    before = _handlers()
    stream = io.StringIO()
    cleaned = []
    saved = [tmp_path / "a.nc", tmp_path / "b.nc"]
    with pytest.raises(SystemExit) as exit_info, interruptible(lambda: saved, "rerun to resume", stream):
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(5)  # the handler interrupts the sleep
            pytest.fail("the signal did not interrupt the block")
        except Interrupted as exc:
            cleaned.append(exc.signum)
            raise
    assert exit_info.value.code == 143
    assert cleaned == [signal.SIGTERM]
    assert re.fullmatch(
        rf"interrupted after \d+\.\d s; saved: 2 files: {re.escape(str(saved[0]))}, "
        rf"{re.escape(str(saved[1]))}; rerun to resume\n",
        stream.getvalue(),
    )
    assert _handlers() == before


def test_a_failing_saved_callback_does_not_hide_the_interruption():
    stream = io.StringIO()

    def saved():
        raise OSError("disk gone")

    with pytest.raises(SystemExit) as exit_info, interruptible(saved, stream=stream):
        raise KeyboardInterrupt
    assert exit_info.value.code == 130
    assert "saved: unknown (could not list the files: disk gone)" in stream.getvalue()


def test_an_ignored_signal_stays_ignored():
    previous = signal.signal(signal.SIGTERM, signal.SIG_IGN)
    try:
        with interruptible(lambda: []):
            assert signal.getsignal(signal.SIGTERM) is signal.SIG_IGN
            os.kill(os.getpid(), signal.SIGTERM)  # ignored: the block goes on
        assert signal.getsignal(signal.SIGTERM) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGTERM, previous)


def test_outside_the_main_thread_the_block_runs_unchanged():
    before = _handlers()
    seen = []

    def work():
        with interruptible(lambda: []):
            seen.append(_handlers())

    thread = threading.Thread(target=work)
    thread.start()
    thread.join()
    assert seen == [before]
    assert _handlers() == before


def test_the_message_names_at_most_five_files():
    files = [f"f{i}.nc" for i in range(7)]
    message = progress.interruption_message(3.14159, files, "rerun")
    assert message == "interrupted after 3.1 s; saved: 7 files: f0.nc, f1.nc, f2.nc, f3.nc, f4.nc, …; rerun"
    assert progress.interruption_message(0.0, [], "rerun") == "interrupted after 0.0 s; saved: nothing; rerun"
    assert "saved: 1 file: a.nc;" in progress.interruption_message(0.0, ["a.nc"], "rerun")


def test_a_file_saved_many_times_is_named_once():
    """A resumable table is saved after each record: 52 saves of 2 files are 2 files."""
    saves = [Path("out/samples.nc"), Path("out/models.nc")] * 26
    message = progress.interruption_message(1.0, saves, "rerun")
    assert message == "interrupted after 1.0 s; saved: 2 files: out/samples.nc, out/models.nc; rerun"


# --- interruptible, a real process receiving the signal --------------------------------------

_CHILD = textwrap.dedent(
    """
    import signal, sys, time
    from pathlib import Path
    from fsistab.progress import interruptible

    # a shell starts background jobs with SIGINT ignored, which interruptible respects; the test
    # wants a process that the signals reach
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    saved = [Path(f"out/curve_{i}.nc") for i in range(7)]
    with interruptible(lambda: saved):
        try:
            print("ready", flush=True)
            time.sleep(30)
        finally:
            print("cleanup ran", flush=True)
    print("not reached", flush=True)
    """
)


@pytest.mark.parametrize(("signum", "status"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signalled_process_says_what_was_saved_and_exits(signum, status):
    child = subprocess.Popen(
        [sys.executable, "-c", _CHILD], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        assert child.stdout.readline() == "ready\n"
        time.sleep(0.2)
        child.send_signal(signum)
        out, err = child.communicate(timeout=10)
    finally:
        child.kill()
    assert child.returncode == status
    assert out == "cleanup ran\n"
    assert re.fullmatch(
        r"interrupted after \d+\.\d s; saved: 7 files: out/curve_0\.nc, out/curve_1\.nc, out/curve_2\.nc, "
        r"out/curve_3\.nc, out/curve_4\.nc, …; rerun the same command to resume\n",
        err,
    )
