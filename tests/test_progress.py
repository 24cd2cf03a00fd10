"""Progress lines and clean interruption (fsistab.progress): issue #13, item 5."""

import io
import os
import re
import signal
import subprocess
import sys
import textwrap
import threading
import time

import pytest

from fsistab import progress
from fsistab.params import Flow
from fsistab.progress import Interrupted, Reporter, interruptible


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


def test_adapters_format_the_library_callbacks():
    stream = io.StringIO()
    counter = type("Counter", (), {"count": 7})()
    with Reporter(stream=stream) as reporter:
        reporter.steady(Flow(2900.0, 5.0), 4)  # steady.solve_steady: progress(step_flow, iterations)
        reporter.count("transfer samples")(3, 40)  # transfer: progress(done, total)
        reporter.tracking(12, counter)(0, 4.5)  # critical/tracking: progress(i, velocity)
        step = reporter.step(
            "point {0}, U* = {1:.3f}, {factorisations} LU", factorisations=lambda: counter.count
        )
        counter.count = 9
        step(2, 5.25)
    messages = [line.split("] ", 1)[1] for line in stream.getvalue().splitlines()]
    assert messages == [
        "continuation: Re = 2900, alpha0 = 5 deg converged in 4 Newton iterations",
        "transfer samples 3/40",
        "tracking branches: point 1/12, U* = 4.5, 7 factorisations",
        "point 2, U* = 5.250, 9 LU",
    ]


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
