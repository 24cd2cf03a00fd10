"""Onset of a fixed body's wake instability (fsistab.onset, ``fsistab onset``): the secant on
analytic growth rates with known roots, input checks before any work, and the fixed cylinder's
critical Reynolds number on the coarse mesh against the fixed-cylinder references of docs/validation.md, rerun
from the cache."""

import json
import math
from pathlib import Path
from types import SimpleNamespace

import pytest
from typer.testing import CliRunner

from fsistab.cli import app
from fsistab.errors import ConvergenceError, InputError
from fsistab.onset import (
    OnsetIterate,
    bracket,
    check_onset,
    fitted_case,
    flow_at,
    leading_eigenpair,
    rounded,
    secant_onset,
)
from fsistab.params import Case, Flow
from fsistab.store import read_dataset

runner = CliRunner()


def _analytic(sigma):
    """An evaluator of ``σ(p)`` recording each ``(p, predicted eigenvalue)`` it is called with."""
    calls = []

    def evaluate(value, predicted):
        calls.append((value, predicted))
        return OnsetIterate(value, sigma(value))

    return evaluate, calls


def _wake(p):
    """A Hopf-like growth rate, curved in p, root 46.7, frequency linear in p (ω_c = 0.734)."""
    x = p - 46.7
    return complex(4e-3 * x - 6e-5 * x**2, 0.734 + 1.3e-3 * x)


def test_secant_converges_to_the_root_and_interpolates_the_frequency():
    evaluate, calls = _analytic(_wake)
    result = secant_onset(evaluate, "reynolds", 46.0, 2.0, 0.75j, tol=1e-12, step_tol=1e-14)
    assert result.critical_value == pytest.approx(46.7, abs=1e-9)
    # ω is linear in p: the interpolation between the last two iterates is exact at the root
    assert result.frequency == pytest.approx(0.734, abs=1e-10)
    assert result.strouhal == pytest.approx(0.734 / (2 * math.pi), abs=1e-10)
    rates = [abs(i.growth_rate) for i in result.iterates]
    assert rates[-1] < 1e-12 and len(rates) <= 7
    # superlinear: each of the last steps gains more than a factor 20 (a linear rate would not)
    assert all(b < a / 20 for a, b in zip(rates[2:-1], rates[3:], strict=False))
    # the mode is followed: the user's shift first, then predictions approaching the eigenvalue
    assert calls[0] == (46.0, 0.75j)
    errors = [abs(predicted - _wake(p)) for p, predicted in calls[2:]]
    assert errors[-1] < 1e-8 and errors[-1] < errors[0]


def test_secant_on_alpha0_finds_the_mirror_root_from_a_negative_guess():
    """A symmetric body's growth rate is even in α0: λ = 0.01(α0² - 9) has roots ±3."""
    evaluate, _ = _analytic(lambda a: complex(0.01 * (a * a - 9), 2.0))
    up = secant_onset(evaluate, "alpha0", 2.0, 0.5, 2j, tol=1e-12)
    down = secant_onset(evaluate, "alpha0", -2.0, -0.5, 2j, tol=1e-12)
    assert up.critical_value == pytest.approx(3.0, abs=1e-9)
    assert down.critical_value == pytest.approx(-3.0, abs=1e-9)


def _flat_then_steep(a):
    """Like the plate's wake mode at Re 500 on the medium mesh (-0.0745 at 8°, -0.0734 at 8.5°,
    then steep): the plain secant from 8° and 8.5° would step to 45.5°, out of the range."""
    return complex(-0.075 + 0.002 * (a - 8) + 0.08 * max(0.0, a - 9) ** 2, 3.9 - 0.1 * (a - 8))


def test_safeguarded_secant_limits_its_steps_until_the_root_is_bracketed():
    # the root beyond 9: with t = a - 9, 0.08 t² + 0.002 t - 0.073 = 0
    root = 9 + (-0.002 + math.sqrt(0.002**2 + 4 * 0.08 * 0.073)) / (2 * 0.08)
    assert abs(_flat_then_steep(root).real) < 1e-12 and 9.9 < root < 10.0
    evaluate, calls = _analytic(_flat_then_steep)
    result = secant_onset(evaluate, "alpha0", 8.0, 0.5, 3.9j, tol=1e-12, max_iterations=20)
    assert result.critical_value == pytest.approx(root, abs=1e-8)
    values = [p for p, _ in calls]
    # the third point is 4 steps of 0.5 beyond the second, and no iterate leaves [8, 10.5]
    assert values[2] == pytest.approx(10.5) and all(8.0 <= v <= 10.5 for v in values)
    # once bracketed, every iterate lies inside the bracket of the iterates before it
    for k in range(3, len(calls)):
        before = [SimpleNamespace(value=v, growth_rate=_flat_then_steep(v).real) for v in values[:k]]
        low, high = bracket(before)
        assert low < values[k] < high
    # without the safeguard (an unbounded expansion) the same start leaves the range
    with pytest.raises(ConvergenceError, match="left the range"):
        secant_onset(_analytic(_flat_then_steep)[0], "alpha0", 8.0, 0.5, 3.9j, max_expansion=math.inf)


def test_bracket_is_the_narrowest_sign_change_at_the_last_iterate():
    its = [SimpleNamespace(value=v, growth_rate=g) for v, g in [(8, -1), (10.5, 2), (9, -0.5), (9.5, -0.1)]]
    assert bracket(its) == (9.5, 10.5)
    assert bracket(its[:1] + its[2:]) is None


def test_secant_iterates_are_rounded_for_reruns():
    evaluate, calls = _analytic(_wake)
    result = secant_onset(evaluate, "reynolds", 46.0, 2.0, 0.75j, tol=1e-12, step_tol=1e-9)
    for p, _ in calls[1:]:
        assert p == rounded("reynolds", p) and p == float(f"{p:.10g}")
    assert result.iterations == len(calls)
    assert rounded("alpha0", 1.23456789012345) == 1.23456789


@pytest.mark.parametrize(
    ("sigma", "parameter", "guess", "step", "message"),
    [
        (lambda p: complex(-1e-3, 0.7), "reynolds", 40.0, 1.0, "does not change"),
        (lambda p: complex(-1e-3 * (p + 10), 0.7), "reynolds", 40.0, 1.0, "left the range"),
        (lambda p: complex(0.01 * (p - 50), 0.7), "alpha0", 40.0, 4.0, "left the range"),
        (lambda p: complex(1e-9 * (p - 50) ** 9, 0.7), "reynolds", 40.0, 1.0, "no onset"),
    ],
)
def test_secant_failures_are_reported(sigma, parameter, guess, step, message):
    evaluate, _ = _analytic(sigma)
    with pytest.raises(ConvergenceError, match=message):
        secant_onset(evaluate, parameter, guess, step, 0.7j, max_iterations=6)


def test_the_leading_mode_is_the_least_stable_one_near_the_shift():
    """Not the nearest to the prediction: the coarse plate at Re 500 between α0 = 9.5° and 10°,
    where the mode followed by proximity stays damped while its neighbour turns unstable."""
    pairs = [
        SimpleNamespace(value=complex(g, w), growth_rate=g)
        for g, w in [(-0.145, 4.057), (0.069, 3.877), (-0.197, 3.947)]
    ]
    assert leading_eigenpair(pairs).value == 0.069 + 3.877j


def test_the_evaluator_looks_right_of_the_predicted_eigenvalue(monkeypatch):
    """In a dense cluster of damped modes near the frequency, the six eigenvalues nearest an
    on-axis prediction miss an unstable mode a little further off (the medium plate at Re 500,
    α0 = 16°: +0.0648 + 2.4896i, missed from 0.0013 + 2.523i). The evaluator's Arnoldi target lies
    LOOKAHEAD to the right, where the unstable mode is among the nearest. The solver is replaced
    by the exact nearest-n selection of shift-invert Arnoldi on a known spectrum."""
    from fsistab import coupled, eigen, onset, operators, steady

    cluster = [complex(-0.03 + 0.004 * k, 2.523 + 0.011 * (k - 6)) for k in range(13)]
    unstable = 0.0648 + 2.4896j
    spectrum = [*cluster, unstable]

    def nearest(system, shifts, n, counter=None):
        chosen = sorted(spectrum, key=lambda z: abs(z - shifts[0]))[:n]
        return [SimpleNamespace(value=z, growth_rate=z.real, frequency=z.imag, residual=0.0) for z in chosen]

    monkeypatch.setattr(eigen, "eigenpairs_near", nearest)
    monkeypatch.setattr(steady, "solve_steady", lambda *a, **k: SimpleNamespace(from_cache=True))
    monkeypatch.setattr(operators, "fluid_operators", lambda state: None)
    monkeypatch.setattr(coupled, "CoupledSystem", lambda fluid, solid: SimpleNamespace(size=10))
    on_axis = 0.0013 + 2.523j
    assert unstable not in [p.value for p in nearest(None, [on_axis], 6)]  # the miss
    evaluate = onset.fixed_body_evaluator(None, Flow(500.0, 16.0), "alpha0")
    found = evaluate(16.0, on_axis)
    assert found.eigenvalue == unstable and found.shift.real == pytest.approx(on_axis.real + onset.LOOKAHEAD)


@pytest.mark.parametrize(
    ("kind", "parameter", "guess", "shift", "message"),
    [
        ("cylinder", "alpha0", 3.0, None, "the cylinder is round"),
        ("plate", "reynolds", 500.0, None, "give --shift for the plate"),
        ("plate", "alpha0", 50.0, 1j, "within ±45 degrees"),
        ("cylinder", "reynolds", -3.0, None, "must be in (0, 1e+07]"),
        ("cylinder", "reynolds", math.nan, None, "must be in (0, 1e+07]"),
        ("cylinder", "reynolds", 47.0, 0.7 - 0.1j, "frequency must be >= 0"),
        ("cylinder", "mass_ratio", 47.0, None, "--parameter must be one of reynolds, alpha0"),
    ],
)
def test_bad_onset_inputs(kind, parameter, guess, shift, message):
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace("]", r"\]").replace("+", r"\+")):
        check_onset(kind, parameter, guess, shift)


def test_default_shift_of_the_cylinder():
    assert check_onset("cylinder", "reynolds", 47, None) == (47.0, 0.75j)


def _run(args, where):
    return runner.invoke(app, ["onset", *args, "--out", str(where / "out"), "--cache", str(where / "cache")])


@pytest.fixture(scope="module")
def coarse_onset(tmp_path_factory):
    """``fsistab onset --body cylinder --guess 47 --mesh coarse --json`` from an empty cache."""
    where = tmp_path_factory.mktemp("onset")
    result = _run(["--body", "cylinder", "--guess", "47", "--mesh", "coarse", "--json"], where)
    assert result.exit_code == 0, result.output
    return where, json.loads(result.stdout)


def test_cylinder_critical_reynolds_coarse(coarse_onset):
    """The fixed-cylinder references of docs/validation.md: Re_c 46.6–46.8, ω_c 0.733–0.744. The coarse
    mesh (20 433 unknowns) gives Re_c = 46.766, ω_c = 0.73450, inside both ranges (the medium mesh:
    46.695, 0.73417)."""
    _, payload = coarse_onset
    assert set(payload) == {
        "parameter",
        "critical_value",
        "frequency",
        "iterations",
        "factorisations",
        "data",
        "figure",
        "mesh_reynolds",
    }
    assert payload["mesh_reynolds"] == 47.0  # the mesh of every iterate is fitted to the guess
    assert payload["parameter"] == "reynolds"
    assert Path(payload["figure"]).is_file() and Path(payload["figure"]).suffix == ".png"
    assert 46.6 <= payload["critical_value"] <= 46.8
    assert 0.733 <= payload["frequency"] <= 0.744
    ds = read_dataset(payload["data"])  # checksummed NetCDF
    assert ds.sizes["iterate"] == payload["iterations"] <= 8
    assert abs(ds.growth_rate.values[-1]) < 1e-6 and ds.residual.values.max() < 1e-8
    assert ds.attrs["critical_value"] == payload["critical_value"]
    # from an empty cache: one eigen factorisation per iterate plus the steady Newton steps
    assert payload["factorisations"] > payload["iterations"]


def test_cylinder_onset_rerun_reuses_the_steady_states(coarse_onset):
    where, first = coarse_onset
    result = _run(["--body", "cylinder", "--guess", "47", "--mesh", "coarse", "--json"], where)
    assert result.exit_code == 0, result.output
    again = json.loads(result.stdout)
    ds = read_dataset(again["data"])
    assert ds.steady_from_cache.values.all()
    assert again["factorisations"] == again["iterations"]  # the eigenvalue solves only
    assert again["critical_value"] == pytest.approx(first["critical_value"], abs=1e-8)
    assert again["frequency"] == pytest.approx(first["frequency"], abs=1e-8)


def test_mesh_fitted_to_the_guess_for_the_critical_reynolds_number():
    case = Case.create("cylinder", 2900, 0.0, "coarse")
    fitted = fitted_case(case, "reynolds", 47.0)
    assert fitted.flow == Flow(47.0, 0.0) and fitted.preset == "coarse" and fitted.body == case.body
    plate = Case.create("plate", 500, 3.0, "coarse")
    assert fitted_case(plate, "alpha0", 15.0) == plate  # the case's Re: the flow that is resolved
    assert flow_at(Flow(500, 3.0), "alpha0", 15.0) == Flow(500, 15.0)
    assert flow_at(Flow(500, 3.0), "reynolds", 47.0) == Flow(47.0, 3.0)
