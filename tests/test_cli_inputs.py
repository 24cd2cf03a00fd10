"""Bad input on the command line: a property-based campaign over every command's numeric and path
options. Each bad value must give exit status 2, exactly one line on stderr, no traceback, nothing
on stdout and no file written; and it must be refused before any work (the step that first touches
the disk and the machine, ``fsistab.cli._prepare``, is replaced by a sentinel that would answer
differently)."""

import math
import tempfile
from pathlib import Path
from unittest import mock

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from fsistab import cli
from fsistab.errors import InputError

runner = CliRunner()
SENTINEL = "validation passed"

# valid arguments of each command (coarse mesh: the estimate of check_fits is quick)
BASE = {
    "mesh": ["mesh", "--mesh", "coarse"],
    "steady": ["steady", "--mesh", "coarse"],
    "spectrum": ["spectrum", "--mesh", "coarse"],
    "slopes": ["slopes", "--Re", "100", "--mesh", "coarse"],
    "critical": ["critical", "--mesh", "coarse"],
    "neutral": ["neutral", "--mesh", "coarse"],
    "neutral-continuation": ["neutral", "--mesh", "coarse", "--method", "continuation"],
    "flow-neutral": ["flow-neutral", "--mesh", "coarse"],
    "theodorsen": ["theodorsen", "--mass-ratio-range", "1", "1e4"],
    "theodorsen-given": ["theodorsen", "--slopes", "given", "--lift-slope-alpha", "5.98"]
    + ["--moment-slope-alpha", "1.562"],
    "transfer": ["transfer", "--mesh", "coarse"],
    "simulate": ["simulate", "--mesh", "coarse", "--duration", "1"],
    "lco": ["lco", "--mesh", "coarse", "--reduced-velocity-range", "4", "8", "--duration", "1"],
}

CASE = {"--Re": "positive", "--alpha0": "angle", "--aspect-ratio": "aspect", "--corner-radius": "corner"}
CASE |= {"--domain": "domain", "--mesh": "preset", "--body": "body", "--mesh-reynolds": "positive"}
SOLID = {
    "--freq-ratio": "positive",
    "--zeta-h": "damping",
    "--zeta-theta": "damping",
    "--r-theta": "positive",
    "--elastic-axis": "elastic-axis",
    "--static-unbalance": "unbalance",
}
MAP = {
    "--mass-ratio-range": "range",
    "--start-mass-ratio": "positive",
    "--reduced-velocity-range": "range",
    "--seed-mass-ratio": "positive",
    "--wake-frequency": "positive",
    "--points": ("count", 2, 500),
    "--max-points": ("count", 1, 10_000),
    "--frequency-range": "range",
    "--tolerance": "tolerance",
    "--max-frequencies": ("count", 4, 100_000),
    "--reduced-blocks": "blocks",
    "--reduced-tolerance": "reduced-tolerance",
    "--method": "method",
}
THEODORSEN = CASE | SOLID
THEODORSEN |= {"--mass-ratio": "positive", "--mass-ratio-range": "range", "--reduced-velocity-range": "range"}
THEODORSEN |= {"--points": ("count", 2, 2000)}
OPTIONS = {
    "mesh": CASE,
    "steady": CASE,
    "spectrum": CASE
    | SOLID
    | {
        "--mass-ratio": "positive",
        "--reduced-velocity": "positive",
        "--dofs": "dofs",
        "--n-eigenvalues": ("count", 1, 50),
        "--mode-figures": ("count", 0, 50),
        "--phase": "phase",
        "--shift": "complex",
    },
    "slopes": {k: v for k, v in CASE.items() if k != "--body"},
    "critical": CASE
    | SOLID
    | {
        "--mass-ratio": "positive",
        "--dofs": "dofs",
        "--reduced-velocity-range": "range",
        "--points": ("count", 2, 500),
        "--wake-shift": "complex",
    },
    "neutral": CASE | SOLID | MAP,
    "neutral-continuation": SOLID | MAP,
    "flow-neutral": CASE
    | SOLID
    | {
        "--mass-ratio": "positive",
        "--parameter": "parameter",
        "--range": "alpha-range",
        "--reduced-velocity-range": "range",
        "--points": ("count", 2, 500),
        "--max-points": ("count", 1, 10_000),
    },
    "theodorsen": THEODORSEN,
    "theodorsen-given": {"--lift-slope-alpha": "lift-slope", "--moment-slope-alpha": "moment-slope"},
    "transfer": CASE | {"--reduced-frequency-range": "range", "--points": ("count", 2, 2000)},
    "simulate": CASE
    | SOLID
    | {
        "--mass-ratio": "positive",
        "--reduced-velocity": "positive",
        "--dofs": "dofs",
        "--duration": "positive",
        "--time-step": "positive",
        "--perturbation": "damping",
        "--perturbation-of": "scale",
        "--shift": "complex",
        "--checkpoint-every": ("count", 1, 10_000_000),
        "--snapshot-interval": "positive",
        "--step-tolerance": "reduced-tolerance",
        "--max-step-iterations": ("count", 1, 1000),
        "--animation": "animation",
    },
    "lco": CASE
    | SOLID
    | {
        "--mass-ratio": "positive",
        "--reduced-velocity-range": "range",
        "--points": ("count", 1, 500),
        "--dofs": "dofs",
        "--duration": "positive",
        "--time-step": "positive",
        "--perturbation": "damping",
        "--perturbation-of": "scale",
        "--shift": "complex",
        "--checkpoint-every": ("count", 1, 10_000_000),
        "--periods": ("count", 2, 1000),
        "--max-step-iterations": ("count", 1, 1000),
        "--step-tolerance": "reduced-tolerance",
        "--saturation-tolerance": "tolerance",
        "--workers": ("count", 1, 256),
    },
}

non_finite = st.sampled_from(["nan", "inf", "-inf", "NaN", "-Infinity"])
text = st.sampled_from(["abc", "", "1,5", "0x", "--", "1e", "j"])
huge = st.floats(min_value=1e10, max_value=1e308).map(repr)
negative = st.floats(max_value=-1e-300, allow_infinity=False, allow_nan=False).map(repr)
non_positive = st.one_of(negative, st.sampled_from(["0", "0.0", "-0"]))


def _values(kind) -> st.SearchStrategy:
    """Strategy of bad values (lists of strings: the option's arguments) for an option of ``kind``."""
    one = {
        "positive": st.one_of(non_positive, non_finite, text, huge),
        "damping": st.one_of(negative, non_finite, text, huge),
        "angle": st.one_of(non_finite, text, st.floats(min_value=45.001, max_value=1e300).map(repr)),
        "aspect": st.one_of(st.floats(max_value=1.0, allow_nan=False).map(repr), non_finite, text),
        "corner": st.one_of(negative, st.floats(min_value=0.5, max_value=1e300).map(repr), non_finite, text),
        "preset": st.sampled_from(["huge", "", "Coarse", "1"]),
        "body": st.sampled_from(["sphere", "", "Plate", "wing"]),
        "dofs": st.sampled_from(["twist", "heave,heave", ",", "pitch,twist", "heave;pitch"]),
        "phase": st.one_of(non_finite, text, st.floats(min_value=100.001, max_value=1e300).map(repr)),
        "complex": st.sampled_from(["abc", "nan", "inf+1j", "1+nanj", "1e5j", "", "j j"]),
        "scale": st.sampled_from(["roll", "", "Pitch", "1", "heave,pitch"]),
        "tolerance": st.one_of(
            non_positive, non_finite, text, st.floats(min_value=0.5, max_value=1e300).map(repr)
        ),
        "reduced-tolerance": st.one_of(
            non_positive, non_finite, text, st.floats(min_value=1e-2, max_value=1e300).map(repr)
        ),
        "blocks": st.one_of(
            st.sampled_from(["1", "2", "-1", "abc", "2.5", "nan"]), st.integers(min_value=10_001).map(str)
        ),
        "method": st.sampled_from(["fast", "", "Transfer", "1"]),
        "animation": st.sampled_from(["webm", "", "GIF", "png", "1"]),
        "parameter": st.sampled_from(["mach", "", "Re", "alpha"]),
        "elastic-axis": st.one_of(non_finite, text, st.floats(min_value=0.5001, max_value=1e300).map(repr)),
        "unbalance": st.one_of(non_finite, text, st.floats(min_value=0.289, max_value=1e300).map(repr)),
        "lift-slope": st.one_of(non_positive, non_finite, text),
        "moment-slope": st.one_of(st.sampled_from(["0", "0.0", "-0"]), non_finite, text),
    }
    if kind in one:
        return one[kind].map(lambda v: [v])
    if isinstance(kind, tuple):
        _, low, high = kind
        bad = st.one_of(
            st.integers(max_value=low - 1).map(str),
            st.integers(min_value=high + 1).map(str),
            st.sampled_from(["abc", "2.5", "nan", "inf", ""]),
        )
        return bad.map(lambda v: [v])
    finite = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False)
    if kind in ("range", "alpha-range"):
        decreasing = (
            st.tuples(finite, finite).filter(lambda p: p[0] >= p[1]).map(lambda p: [repr(p[0]), repr(p[1])])
        )
        bad_end = (
            st.one_of(non_finite, text, non_positive) if kind == "range" else st.one_of(non_finite, text)
        )
        with_bad = st.tuples(bad_end, st.sampled_from(["1", "5", "inf"]))
        cases = [decreasing, with_bad.map(list), with_bad.map(lambda p: [p[1], p[0]])]
        if kind == "range":
            cases.append(huge.map(lambda v: ["1", v]))
        else:  # not containing the starting alpha0 = 0, or beyond ±45 degrees
            cases.append(st.floats(min_value=0.01, max_value=40).map(lambda v: [repr(v), "45"]))
            cases.append(st.floats(min_value=45.01, max_value=1e300).map(lambda v: ["-1", repr(v)]))
        return st.one_of(*cases)
    if kind == "domain":
        small = st.floats(max_value=1.999, allow_nan=False, allow_infinity=False).map(repr)
        bad = st.one_of(small, non_finite, text)
        return st.tuples(bad, st.integers(0, 2)).map(
            lambda p: [p[0] if i == p[1] else "40" for i in range(3)]
        )
    raise AssertionError(kind)


def _sentinel(*args, **kwargs):
    raise InputError(SENTINEL)


def _check_refused(args: list[str], workdir: Path, before_prepare: bool = True):
    out, cache = workdir / "out", workdir / "cache"
    full = [*args, "--json", "--out", str(out), "--cache", str(cache)]
    if before_prepare:
        with mock.patch.object(cli, "_prepare", _sentinel):
            result = runner.invoke(cli.app, full)
    else:
        result = runner.invoke(cli.app, full)
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert result.exit_code == 2, (args, result.output)
    assert len(lines) == 1, (args, result.stderr)
    assert lines[0].startswith("error: ") and SENTINEL not in lines[0], (args, lines)
    assert "Traceback" not in result.output and result.stdout == ""
    assert not isinstance(result.exception, Exception) or isinstance(result.exception, SystemExit)
    return lines[0]


@pytest.mark.parametrize("command", sorted(BASE))
def test_the_base_arguments_are_valid(command, tmp_path):
    """The campaign's reference: with the base arguments every check passes (the sentinel answers)."""
    with mock.patch.object(cli, "_prepare", _sentinel):
        result = runner.invoke(cli.app, [*BASE[command], "--json"])
    assert result.exit_code == 2 and SENTINEL in result.stderr, result.output


@pytest.mark.parametrize("command", sorted(BASE))
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_bad_value_of_any_option_is_refused_before_work(command, data):
    option = data.draw(st.sampled_from(sorted(OPTIONS[command])), label="option")
    values = data.draw(_values(OPTIONS[command][option]), label="values")
    with tempfile.TemporaryDirectory() as scratch:
        workdir = Path(scratch)
        _check_refused([*BASE[command], option, *values], workdir)
        assert list(workdir.iterdir()) == []


def _bad_directories(workdir: Path) -> list[Path]:
    a_file = workdir / "a_file"
    a_file.write_text("not a directory")
    return [a_file, a_file / "below", Path("/proc/fsistab-x"), Path("/dev/null"), Path("/sys/fsistab-x")]


@pytest.mark.parametrize("command", ["mesh", "spectrum", "neutral", "theodorsen", "transfer", "slopes"])
@pytest.mark.parametrize("which", ["--out", "--cache"])
def test_out_and_cache_must_be_writable_directories(command, which, tmp_path):
    """``--out``/``--cache`` a file, below a file, in /proc, /dev/null or /sys: one line, exit 2, and
    nothing created (not even the other, valid, directory)."""
    for bad in _bad_directories(tmp_path):
        other = tmp_path / "other"
        args = [*BASE[command], "--json"]
        args += [which, str(bad), "--cache" if which == "--out" else "--out", str(other)]
        result = runner.invoke(cli.app, args)
        lines = [line for line in result.stderr.splitlines() if line.strip()]
        assert result.exit_code == 2 and len(lines) == 1, (bad, result.output)
        assert f"{which} {bad}" in lines[0] and "not a writable directory" in lines[0]
        assert "Traceback" not in result.output and result.stdout == ""
        assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]
        assert (tmp_path / "a_file").read_text() == "not a directory"


@pytest.mark.parametrize(
    "args",
    [
        ["mesh"],
        ["steady"],
        ["spectrum"],
        ["critical"],
        ["neutral"],
        ["flow-neutral"],
        ["transfer"],
        ["slopes", "--Re", "100", "1e6"],
        ["theodorsen", "--slopes", "calibrated"],
    ],
)
def test_a_mesh_too_large_for_the_machine_is_refused_before_meshing(args, tmp_path):
    """Re = 10⁶ on the medium preset: millions of unknowns, refused by the estimate before any
    directory or mesh exists."""
    args = [*args, "--mesh", "medium"] + (["--Re", "1e6"] if args[0] != "slopes" else [])
    line = _check_refused(args, tmp_path, before_prepare=False)
    assert "mesh too large" in line
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "args, reason",
    [
        (["spectrum", "--mass-ratio", "0"], "mass ratio must be positive"),
        (["spectrum", "--reduced-velocity", "0"], "reduced velocity must be positive"),
        (["spectrum", "--body", "cylinder", "--mass-ratio", "0"], "mass ratio must be positive"),
        (["neutral", "--max-points", "0"], "--max-points"),
        (["critical", "--reduced-velocity-range", "2", "inf"], "--reduced-velocity-range"),
        (["spectrum", "--phase", "nan"], "--phase must be finite"),
        (
            ["theodorsen", "--slopes", "given", "--lift-slope-alpha", "0", "--moment-slope-alpha", "0"],
            "degenerate",
        ),
        (
            ["theodorsen", "--slopes", "given", "--lift-slope-alpha", "6", "--moment-slope-alpha", "0"],
            "degenerate",
        ),
        (["theodorsen", "--lift-slope-alpha", "6"], "need --slopes given"),
        (["theodorsen", "--elastic-axis", "0.7"], "elastic axis"),
        (["critical", "--dofs", "none"], "at least one solid degree of freedom"),
        (["simulate", "--animation", "gif"], "--animation needs --snapshot-interval"),
        (["critical", "--method", "guess"], "--method must be one of transfer, tracking"),
        (["spectrum", "--body", "cylinder", "--dofs", "pitch"], "no pitch"),
        (["spectrum", "--body", "cylinder", "--zeta-theta", "-1"], "pitch damping ratio"),  # unused, refused
        (["spectrum", "--body", "cylinder", "--aspect-ratio", "0.5"], "chord/thickness"),  # unused, refused
        (["neutral", "--method", "transfer", "--seed-mass-ratio", "-3"], "--seed-mass-ratio"),  # unused
        (["neutral", "--body", "cylinder"], "implemented for the plate"),
        (["steady", "--Re", "1e300"], "at most"),
        (["critical", "--sponge", "0.2"], "--sponge must be"),
        (["spectrum", "--sponge", "0.2,0.9"], "sponge zone"),
        (["neutral", "--sponge", "-1,0.25"], "sigma_max must be positive"),
        (["simulate", "--dofs", "heave", "--perturbation-of", "pitch"], "pitch is not a degree of freedom"),
        (
            ["lco", "--body", "cylinder", "--reduced-velocity-range", "4", "5", "--perturbation-of", "pitch"],
            "pitch is not a degree of freedom",
        ),
        (["simulate", "--perturbation-of", "pitch", "--perturbation", "2"], "at most 1 (radians)"),
    ],
)
def test_named_bad_values_are_refused_with_the_reason(args, reason, tmp_path):
    line = _check_refused(args, tmp_path)
    assert reason in line
    assert list(tmp_path.iterdir()) == []


def test_help_and_bad_input_need_no_numerical_import():
    """``fsistab --help`` and a refused value import neither NGSolve nor xarray (they answer at once)."""
    import subprocess
    import sys

    code = (
        "import sys\n"
        "from typer.testing import CliRunner\n"
        "from fsistab.cli import app\n"
        "r = CliRunner().invoke(app, ['--help'])\n"
        "assert r.exit_code == 0\n"
        "r = CliRunner().invoke(app, ['spectrum', '--mass-ratio', '0'])\n"
        "assert r.exit_code == 2\n"
        "print(sorted(m for m in ('ngsolve', 'netgen', 'xarray', 'scipy') if m in sys.modules))\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert result.stdout.strip() == "[]"


def test_the_console_command_runs_blas_single_threaded_unless_told():
    """The ``fsistab`` entry point sets one BLAS thread before NumPy or NGSolve load (they are
    imported lazily, after it); a user who set any of the variables keeps all of them as set."""
    import os
    import subprocess
    import sys

    code = (
        "import os, sys\n"
        "from fsistab.cli import main\n"
        "assert 'numpy' not in sys.modules and 'ngsolve' not in sys.modules\n"
        "sys.argv = ['fsistab', '--help']\n"
        "try:\n"
        "    main()\n"
        "except SystemExit:\n"
        "    pass\n"
        "print('|'.join(os.environ.get(v, '-') for v in ('OMP_NUM_THREADS', 'OPENBLAS_NUM_THREADS')))\n"
    )
    environ = {k: v for k, v in os.environ.items() if k not in cli.BLAS_THREADS}
    for omp, expected in ((None, "1|1"), ("3", "3|-")):
        if omp is not None:
            environ["OMP_NUM_THREADS"] = omp
        command = [sys.executable, "-c", code]
        run = subprocess.run(command, capture_output=True, text=True, env=environ, check=True)
        assert run.stdout.strip().splitlines()[-1] == expected


def test_warnings_of_the_library_are_single_plain_lines_on_stderr(capsys):
    """A damaged cache entry is reported by ``logging.getLogger("fsistab").warning``: the handler the
    CLI installs prints it as one line on stderr, nothing on stdout."""
    import logging

    cli._install_warning_handler()
    cli._install_warning_handler()  # installed once
    logger = logging.getLogger("fsistab")
    assert sum(isinstance(h, cli._PlainWarnings) for h in logger.handlers) == 1
    logger.warning("damaged cache entry %s\nrecomputed", "x.nc")
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.splitlines() == ["warning: damaged cache entry x.nc recomputed"]
    assert math.isfinite(1.0)
