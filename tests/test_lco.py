"""Limit-cycle amplitudes (fsistab.lco): the saturation test and the amplitude law on analytic
signals, the onset fit on an exact square-root law, the resume of an interrupted sweep, bad input,
and a short coarse march whose extracted frequency is the eigenvalue's."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from fsistab import lco, payloads, reports
from fsistab.errors import InputError
from fsistab.params import Case, LcoSettings, SimulationSettings, solid_for


def _landau(t, growth, omega, start, limit):
    """``A(t) sin(ωt)`` with ``A`` the solution of ``A' = σA(1 − A²/A∞²)`` from ``A(0) = start``:
    a supercritical oscillation growing to its limit cycle, whose amplitude law is known."""
    envelope = limit / np.sqrt(1 + (limit**2 / start**2 - 1) * np.exp(-2 * growth * t))
    return envelope * np.sin(omega * t)


def test_a_growing_then_saturating_oscillation_is_saturated_at_its_limit():
    t = np.arange(0.0, 400.0, 0.02)
    s = lco.saturation(t, 0.1 + _landau(t, 0.08, 0.73, 1e-4, 0.4), periods=4, tolerance=1e-3)
    assert s.state == "saturated" and s.saturated
    assert s.amplitude == pytest.approx(0.4, rel=1e-4)
    assert s.frequency == pytest.approx(0.73, rel=1e-4)
    assert s.mean == pytest.approx(0.1, abs=1e-4)
    assert abs(s.change) < 1e-6


def test_a_signal_still_growing_or_decaying_is_said_so():
    t = np.arange(0.0, 100.0, 0.01)
    omega, rate = 0.9, 0.01
    growing = lco.saturation(t, np.exp(rate * t) * np.sin(omega * t), periods=4)
    assert growing.state == "growing" and not growing.saturated
    # the envelope grows by e^{rate·T} per period T = 2π/ω (to the sampling's and the
    # peak-location's small error)
    assert growing.change == pytest.approx(math.expm1(rate * 2 * math.pi / omega), rel=2e-2)
    decaying = lco.saturation(t, np.exp(-rate * t) * np.sin(omega * t), periods=4)
    assert decaying.state == "decaying" and decaying.change < 0
    short = lco.saturation(t[:1500], np.sin(omega * t[:1500]), periods=4)  # two periods
    assert short.state == "too short" and math.isnan(short.change) and short.found < 4


def test_a_slow_modulation_is_modulated_even_at_its_top():
    """A beating oscillation whose envelope peaks within the record's last four periods: they are
    flat (the envelope test alone would call it saturated), its second half rises and falls."""
    t = np.arange(0.0, 400.0, 0.01)
    omega, depth, slow = 1.3, 0.25, 2 * math.pi / 100.0
    envelope = 0.5 * (1 + depth * np.cos(slow * (t - 386.6)))  # its top amid the last four periods
    s = lco.saturation(t, 0.02 + envelope * np.sin(omega * t), periods=4, tolerance=0.01)
    assert abs(s.change) < 0.01  # the last four periods pass the envelope test
    assert s.state == "modulated" and not s.saturated
    assert s.low == pytest.approx(0.5 * (1 - depth), rel=0.02)
    assert s.high == pytest.approx(0.5 * (1 + depth), rel=0.02)
    assert s.largest == pytest.approx(0.5 * (1 + depth), rel=0.01)
    assert s.amplitude == pytest.approx(0.5, rel=0.05)  # the mean over the second half's periods
    assert s.frequency == pytest.approx(omega, rel=0.01)


def test_a_limit_cycle_keeps_its_range_and_largest_excursion():
    t = np.arange(0.0, 400.0, 0.02)
    s = lco.saturation(t, 0.1 + _landau(t, 0.08, 0.73, 1e-4, 0.4), periods=4, tolerance=1e-3)
    assert s.state == "saturated"
    assert s.low == pytest.approx(0.4, rel=1e-4) and s.high == pytest.approx(0.4, rel=1e-4)
    assert s.largest == pytest.approx(0.4, rel=1e-4)


def test_the_envelope_growth_rate_follows_the_amplitude_law():
    """For ``A' = σA(1 − A²/A∞²)`` the rate measured between periods is ``σ(1 − A²/A∞²)``: its zero is
    the limit cycle, with ``dσ/dA < 0`` (stable)."""
    t = np.arange(0.0, 300.0, 0.01)
    growth, limit = 0.02, 0.3
    amplitudes, rates = lco.envelope_growth(t, _landau(t, growth, 1.1, 0.01, limit))
    expected = growth * (1 - amplitudes**2 / limit**2)
    assert len(rates) > 40
    np.testing.assert_allclose(rates, expected, atol=2e-3 * growth)
    assert np.all(np.diff(rates[amplitudes > 0.05]) < 0)


@pytest.mark.parametrize("offset", [0.0, 0.37])
def test_half_period_peaks_are_placed_between_samples(offset):
    """A sinusoid sampled at ωΔt = 0.3: every closed half period's peak is found at the analytic
    amplitude and time to the parabola's O((ωΔt)⁴) error, where the largest sample is up to 1.1 %
    low (so two time steps compared by their samples would differ by that): the unrefined
    maxima fail the tolerance."""
    omega, phase, amplitude, level = 1.3, 0.4, 0.7, 0.2
    t = (np.arange(0.0, 40.0, 0.3 / omega) + offset * 0.3 / omega)[:-1]
    at, peaks = lco.half_period_peaks(t, level + amplitude * np.sin(omega * t + phase), level)
    order = np.arange(1, 16)  # the half periods closed on both sides within t < 40
    np.testing.assert_allclose(at, (np.pi / 2 + order * np.pi - phase) / omega, atol=5e-4)
    np.testing.assert_allclose(peaks, amplitude, rtol=3e-4)


@pytest.mark.parametrize(("limit", "rate", "modulation"), [(6.1, -0.004, 0.015), (0.13, -0.0025, 0.011)])
def test_envelope_limit_recovers_a_settling_modulation(limit, rate, modulation):
    """An oscillation at ω = 0.18 whose amplitude settles as ``limit + b e^{rate t} cos(Ωt + φ)``
    (a stable cycle's slowest Floquet pair, the shape of the plate's marches in
    docs/simulation.md): from its half-period peaks over less than two modulations the fit returns
    the limit, rate and frequency given, and, fitted on the first 500 time units only, predicts
    the peaks of the next 350. The swing at the start is a fifth of the limit, so the last peak
    alone is 0.2 % or more off the limit: the tolerances separate a fit from reading it."""
    t = np.arange(0.0, 900.0, 0.05)
    envelope = limit * (1 + 0.2 * np.exp(rate * t) * np.cos(modulation * t + 0.3))
    at, peaks = lco.half_period_peaks(t, envelope * np.sin(0.18 * t))
    fitted = lco.envelope_limit(at, peaks)
    assert abs(peaks[-1] / limit - 1) > 2e-3
    assert fitted.limit == pytest.approx(limit, rel=1e-4)
    assert fitted.limit_error < 1e-4 * limit
    assert fitted.rate == pytest.approx(rate, rel=1e-2)
    assert fitted.frequency == pytest.approx(modulation, rel=1e-2)
    early = at <= 500
    ahead = lco.envelope_limit(at[early], peaks[early])
    np.testing.assert_allclose(ahead(at[~early]), peaks[~early], rtol=1e-3)
    with pytest.raises(ValueError, match="eight"):
        lco.envelope_limit(at[:7], peaks[:7])


def test_onset_fit_recovers_a_square_root_law():
    u = np.array([4.0, 4.5, 5.0, 5.5, 6.0])
    amplitude = np.sqrt(np.clip(0.2 * (u - 4.3), 0, None))
    slope, start = lco.onset_fit(u, amplitude, np.ones(5), threshold=4.3)
    assert slope == pytest.approx(0.2, rel=1e-10) and start == pytest.approx(4.3, rel=1e-10)
    assert all(math.isnan(v) for v in lco.onset_fit(u, amplitude, np.zeros(5), threshold=4.3))


@pytest.mark.parametrize(
    ("velocity_range", "points", "message"),
    [
        ((5.0, 4.0), 3, "reversed"),
        ((4.0, 5.0), 0, "--points must be between 1"),
        ((4.0, 4.0), 3, "needs a range"),
        ((-1.0, 4.0), 3, "positive"),
        ((1.0, 9e5), 3, "thresholds are searched 20% beyond"),
    ],
)
def test_bad_sweeps_are_refused_in_one_line(velocity_range, points, message):
    with pytest.raises(InputError, match=message) as caught:
        LcoSettings(velocity_range, points, SimulationSettings(10.0))
    assert "\n" not in str(caught.value)
    assert LcoSettings((4.0, 4.0), 1, SimulationSettings(10.0)).velocities() == (4.0,)
    assert LcoSettings((4.0, 6.0), 5, SimulationSettings(10.0)).velocities() == (4.0, 4.5, 5.0, 5.5, 6.0)


def test_the_command_refuses_a_reversed_range_before_any_work(tmp_path):
    from typer.testing import CliRunner

    from fsistab.cli import app

    where = ["--out", str(tmp_path / "out"), "--cache", str(tmp_path / "cache")]
    result = CliRunner().invoke(app, ["lco", "--reduced-velocity-range", "6", "4", *where])
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert result.exit_code == 2 and len(lines) == 1 and "reversed" in lines[0]
    result = CliRunner().invoke(app, ["lco", "--reduced-velocity-range", "4", "6", "--points", "0", *where])
    assert result.exit_code == 2 and "--points must be between 1" in result.stderr
    assert not (tmp_path / "out").exists()


def _fake_series(velocity: float) -> xr.Dataset:
    t = np.arange(0.0, 200.0, 0.1)
    heave = _landau(t, 0.1, 0.8, 1e-3, 0.05 * velocity)
    names = (
        "pitch",
        "heave_rate",
        "pitch_rate",
        "lift_coefficient",
        "drag_coefficient",
        "moment_coefficient",
    )
    data = {"heave": ("time", heave)} | {n: ("time", np.zeros_like(t)) for n in names}
    data["lift_coefficient"] = ("time", 2 * heave)
    return xr.Dataset(data, coords={"time": t}, attrs={"ndof": 10, "dofs": "heave", "checkpoint": "c.nc"})


def test_an_interrupted_sweep_resumes_without_redoing_finished_points(tmp_path, monkeypatch):
    """The march is replaced by a known signal (its amplitude 0.05 U*): the second point is
    interrupted; rerun, the first is read back from its file, not marched again."""
    from fsistab import workflows

    calls = []

    class Result:
        def __init__(self, velocity):
            self.dataset = _fake_series(velocity)

    def fake_simulate(case, solid, settings, cache_dir, out, progress=None):
        velocity = solid.reduced_velocity * 2 * math.pi
        calls.append(round(velocity, 9))
        if len(calls) == 2 and not (tmp_path / "interrupted").exists():
            (tmp_path / "interrupted").touch()
            raise KeyboardInterrupt
        return Result(velocity)

    monkeypatch.setattr(workflows, "simulate", fake_simulate)
    case = Case.create("cylinder", 100, preset="coarse")
    solid = solid_for("cylinder", 10.0, 4.0, dofs=("heave",))
    settings = LcoSettings((4.0, 6.0), 3, SimulationSettings(200.0, 0.1))
    with pytest.raises(KeyboardInterrupt):
        lco.limit_cycles(case, solid, settings, 10.0, tmp_path, tmp_path / "out", thresholds=False)
    assert calls == [4.0, 5.0]
    ds = lco.limit_cycles(case, solid, settings, 10.0, tmp_path, tmp_path / "out", thresholds=False)
    assert calls == [4.0, 5.0, 5.0, 6.0] and ds.attrs["computed"] == 2
    # to the sampling: the peak falls between samples by at most ωΔt/2 in phase, 1 − cos(0.04)
    np.testing.assert_allclose(ds.heave_amplitude, 0.05 * ds.reduced_velocity, rtol=1e-3)
    assert list(ds.heave_state.values) == ["saturated"] * 3
    np.testing.assert_allclose(ds.heave_frequency, 0.8, rtol=1e-4)
    assert ds.attrs["onset"] == "undetermined (thresholds not computed: --no-thresholds)"
    again = lco.limit_cycles(case, solid, settings, 10.0, tmp_path, tmp_path / "out", thresholds=False)
    assert len(calls) == 4 and again.attrs["computed"] == 0
    from fsistab.store import read_dataset

    written = read_dataset(ds.attrs["data"])
    assert written.heave_amplitude.attrs["units"] == "1" and written.heave_state.dtype.kind in "UO"
    # the outputs layer: the diagram, the JSON payload and the report from the same dataset
    from pathlib import Path

    from fsistab import figures, reports
    from fsistab.payloads import payload

    drawn = figures.lco(ds)
    assert Path(drawn.attrs["figure"]).stat().st_size > 0
    p = payload("lco", drawn)
    assert [point["heave"]["state"] for point in p["points"]] == ["saturated"] * 3
    assert Path(p["figure"]).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p["failed"] == 0
    lines = reports.lco(drawn, p)  # the table, the thresholds' line and the run's (no onset fit)
    assert len(lines) == 3 and "none in the range" in lines[1]


def test_classify_onset_by_hysteresis_and_by_the_fit():
    u = np.array([4.0, 4.5, 5.0, 5.5])
    up = np.array([0.0, 0.0, 0.2, 0.3])
    states = np.array(["decaying", "decaying", "saturated", "saturated"])
    ds = xr.Dataset(
        {
            "heave_amplitude": ("reduced_velocity", up),
            "heave_saturated": ("reduced_velocity", np.ones(4)),
            "heave_state": ("reduced_velocity", states),
        },
        coords={"reduced_velocity": u},
        attrs={"dofs": "heave", "onset_slope": 0.1, "onset_velocity": 4.6},
    )
    assert lco.classify_onset(ds, 4.7) == "supercritical"
    assert lco.classify_onset(ds.assign_attrs(onset_velocity=3.0), 4.7) == "undetermined"
    held = ds.assign(
        decreasing_heave_amplitude=("reduced_velocity", np.array([0.0, 0.15, 0.2, 0.3])),
        decreasing_heave_saturated=("reduced_velocity", np.ones(4)),
    )
    assert lco.classify_onset(held, 4.7) == "subcritical"


@pytest.mark.slow
def test_lco_command_on_the_coarse_cylinder_gives_the_eigenvalue_frequency(tmp_path):
    """Two short marches of the heaving cylinder at Re 60 (m = 10) from its wake mode: the
    command's JSON and NetCDF structure, and the frequency of the heave's whole periods within 1 %
    of the eigenvalue's: the march follows the linear mode while it is small. Δt = 0.1 keeps BDF2's
    phase error to about 0.2 % (docs/simulation.md); the rest is the reading of a growing or
    decaying transient of two periods by crossings of a mid-level (the extraction is meant for
    saturated cycles; tests/test_simulation.py checks the march's accuracy by Prony's fit to 1e-5)."""
    from typer.testing import CliRunner

    from fsistab.cli import app
    from fsistab.coupled import CoupledSystem
    from fsistab.eigen import eigenpairs_near
    from fsistab.store import read_dataset
    from fsistab.workflows import _fluid

    where = ["--out", str(tmp_path / "out"), "--cache", str(tmp_path / "cache")]
    args = ["lco", "--body", "cylinder", "--Re", "60", "--mesh", "coarse", "--mass-ratio", "10"]
    args += ["--reduced-velocity-range", "5", "6", "--points", "2", "--duration", "18", "--time-step", "0.1"]
    args += ["--perturbation", "1e-3", "--shift", "0.05+0.75j", "--periods", "2", "--no-thresholds"]
    result = CliRunner().invoke(app, [*args, "--json", *where])
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    assert [p["reduced_velocity"] for p in payload["points"]] == [5.0, 6.0]
    assert payload["failed"] == 0 and payload["computed"] == 2 and payload["thresholds"] == []
    ds = read_dataset(payload["data"])
    assert ds.heave_amplitude.sizes["reduced_velocity"] == 2 and ds.heave_amplitude.attrs["units"] == "1"
    case = Case.create("cylinder", 60, preset="coarse")
    _, fluid = _fluid(case, tmp_path / "cache", lambda message: None)
    for point in payload["points"]:
        solid = solid_for("cylinder", 10.0, point["reduced_velocity"], dofs=("heave",))
        pair = min(
            eigenpairs_near(CoupledSystem(fluid, solid), [0.05 + 0.75j], 6),
            key=lambda p: abs(p.value - 0.05 - 0.75j),
        )
        assert point["heave"]["frequency"] == pytest.approx(pair.frequency, rel=1e-2)
        # about two periods of a linear transient: never judged a limit cycle
        assert point["heave"]["state"] == "too short"


def test_the_decreasing_sweep_starts_each_march_from_the_saturated_state_above(tmp_path, monkeypatch):
    """``hysteresis``: after the increasing sweep, the marches by decreasing U* start from the
    checkpoint of the one above (a chain), and their amplitudes are kept beside the others."""
    from fsistab import workflows

    starts = []

    class Result:
        def __init__(self, velocity, start):
            # a subcritical system: from rest nothing grows below U* = 6; from a cycle it stays
            amplitude = 0.05 * velocity if (start is not None or velocity >= 6) else 1e-3
            self.dataset = (
                _fake_series(velocity)
                .assign(heave=lambda ds: ds.heave * amplitude / (0.05 * velocity))
                .assign_attrs(checkpoint=f"state_u{velocity:g}.nc")
            )

    def fake_simulate(case, solid, settings, cache_dir, out, progress=None):
        velocity = round(solid.reduced_velocity * 2 * math.pi, 9)
        starts.append((velocity, settings.start))
        return Result(velocity, settings.start)

    monkeypatch.setattr(workflows, "simulate", fake_simulate)
    case = Case.create("cylinder", 100, preset="coarse")
    solid = solid_for("cylinder", 10.0, 4.0, dofs=("heave",))
    settings = LcoSettings((4.0, 6.0), 3, SimulationSettings(200.0, 0.1), hysteresis=True)
    ds = lco.limit_cycles(case, solid, settings, 10.0, tmp_path, tmp_path / "out", thresholds=False)
    assert starts == [(4.0, None), (5.0, None), (6.0, None), (5.0, "state_u6.nc"), (4.0, "state_u5.nc")]
    np.testing.assert_allclose(ds.decreasing_heave_amplitude, [0.2, 0.25, 0.3], rtol=1e-3)
    np.testing.assert_allclose(ds.heave_amplitude, [1e-3, 1e-3, 0.3], rtol=1e-3)
    assert lco.classify_onset(ds, 5.5) == "subcritical"
    assert list(ds.decreasing_start_state.values) == ["saturated", "saturated", "not chained"]


def test_a_resumed_march_rebuilds_its_iteration_matrix_only_after_a_hard_step():
    """A march interrupted after a step that needed more chord iterations than the rebuild
    threshold gets the matrix rebuilt at the resumed state (it is not saved); after an easy step,
    or at the start, nothing changes."""
    from types import SimpleNamespace

    from fsistab.workflows import _resume_linearisation

    class Stepper:
        refresh_after = 6

        def __init__(self):
            self.rebuilt = []

        def refresh(self, q):
            self.rebuilt.append(q)

    state = SimpleNamespace(step=430, time=86.0, current="q")
    for iterations, expected in ((72, ["q"]), (6, []), (3, [])):
        stepper = Stepper()
        table = SimpleNamespace(records=[{"chord_iterations": 2}, {"chord_iterations": iterations}])
        _resume_linearisation(table, stepper, state, lambda message: None)
        assert stepper.rebuilt == expected
    stepper = Stepper()
    _resume_linearisation(
        SimpleNamespace(records=[{"chord_iterations": 0}]), stepper, SimpleNamespace(step=0), print
    )
    assert stepper.rebuilt == []


# --- the reviewer's findings: each test fails with the code before its fix --------------------------


def _fake_marches(monkeypatch, make_series) -> list:
    """Replace the march by ``make_series(velocity, start)``; the ``(velocity, start)`` of each march
    are recorded in the returned list."""
    from fsistab import workflows

    calls = []

    class Result:
        def __init__(self, dataset):
            self.dataset = dataset

    def fake_simulate(case, solid, settings, cache_dir, out, progress=None):
        velocity = round(solid.reduced_velocity * 2 * math.pi, 9)
        calls.append((velocity, settings.start))
        return Result(make_series(velocity, settings.start))

    monkeypatch.setattr(workflows, "simulate", fake_simulate)
    return calls


def _thresholds_found(monkeypatch, velocities, kinds, boundaries, error=None):
    """Replace the linear thresholds' search by a dataset of these thresholds (or ``error``)."""
    from fsistab import workflows

    def fake_critical(case, solid, sweep, cache_dir, out=None, progress=None):
        if error is not None:
            raise error
        return xr.Dataset(
            {
                "kind": ("threshold", np.array(kinds)),
                "boundary": ("threshold", np.array(boundaries)),
                "reduced_velocity": ("threshold", np.array(velocities, dtype=float)),
            }
        )

    monkeypatch.setattr(workflows, "critical_points", fake_critical)


def test_a_slow_linear_transient_from_the_perturbation_is_never_a_limit_cycle():
    """Near a threshold (σ₀T₀ = 8e-4 per period, below the 1 % tolerance) the linear transient
    ``e^{σ₀t} sin ω₀t`` passes the envelope test; with the start mode recorded the march is
    ``transient``. A cycle grown from the perturbation to 400 times its size stays saturated."""
    t = np.arange(0.0, 200.0, 0.1)
    settings = LcoSettings((5.0, 5.0), 1, SimulationSettings(200.0, 0.1))
    slow = _fake_series(5.0).assign(heave=("time", 1e-3 * np.exp(1e-4 * t) * np.sin(0.8 * t)))
    slow = slow.assign_attrs(start_growth_rate=1e-4, start_frequency=0.8)
    point = lco.point_dataset(slow, 5.0, settings)
    assert point.heave_state.item() == "transient" and point.heave_saturated.item() == 0
    grown = _fake_series(8.0).assign_attrs(start_growth_rate=0.1, start_frequency=0.8)
    point = lco.point_dataset(grown, 8.0, settings)
    assert point.heave_state.item() == "saturated" and point.heave_saturated.item() == 1
    # the second rule alone: an amplitude within a factor 2 of the first period's has not left it
    steady = lco.Saturation(1.5e-3, 0.8, 0.0, 0.0, 4, 20, "saturated", first=1e-3)
    assert not lco.left_linear_transient(steady, 0.1, 0.8, 0.01)
    assert lco.left_linear_transient(replace_amplitude(steady, 0.4), 0.1, 0.8, 0.01)
    assert lco.left_linear_transient(steady, math.nan, math.nan, 0.01)  # a given start: envelope only


def test_a_body_released_near_its_cycle_is_judged_by_its_envelope():
    """Released at 0.06 (``--perturbation-of heave``) with a cycle of 0.05: the amplitude stays
    within a factor 2 of the first period's, which from a small perturbation would mean the march
    has not left its start; from a finite-amplitude release it is saturated by the envelope test."""
    t = np.arange(0.0, 200.0, 0.1)
    settings = LcoSettings((5.0, 5.0), 1, SimulationSettings(200.0, 0.1, 0.06, perturbation_of="heave"))
    envelope = 0.05 + 0.01 * np.exp(-0.1 * t)
    released = _fake_series(5.0).assign(heave=("time", envelope * np.sin(0.8 * t)))
    attrs = {"start_growth_rate": 0.1, "start_frequency": 0.8}
    point = lco.point_dataset(released.assign_attrs(attrs, perturbation_of="heave"), 5.0, settings)
    assert point.heave_state.item() == "saturated"
    point = lco.point_dataset(released.assign_attrs(attrs), 5.0, settings)
    assert point.heave_state.item() == "transient"


def replace_amplitude(s, amplitude):
    from dataclasses import replace

    return replace(s, amplitude=amplitude)


def test_just_above_a_supercritical_onset_a_growing_march_is_no_hysteresis():
    """The increasing march at U* = 5 (above the threshold 4.7) is still growing at 0.01 where the
    decreasing one holds 0.2: no evidence of a subcritical onset. Below the threshold, where the
    increasing march decayed, the same contrast is."""
    u = np.array([4.0, 4.5, 5.0, 5.5])
    ds = xr.Dataset(
        {
            "heave_amplitude": ("reduced_velocity", np.array([0.0, 0.0, 0.01, 0.3])),
            "heave_saturated": ("reduced_velocity", np.array([0.0, 0.0, 0.0, 1.0])),
            "heave_state": ("reduced_velocity", np.array(["decaying", "decaying", "growing", "saturated"])),
            "decreasing_heave_amplitude": ("reduced_velocity", np.array([0.0, 0.0, 0.2, 0.3])),
            "decreasing_heave_saturated": ("reduced_velocity", np.array([0.0, 0.0, 1.0, 1.0])),
        },
        coords={"reduced_velocity": u},
        attrs={"dofs": "heave", "onset_slope": 0.1, "onset_velocity": 4.6},
    )
    assert lco.classify_onset(ds, 4.7) == "supercritical"
    below = ds.assign(decreasing_heave_amplitude=("reduced_velocity", np.array([0.0, 0.15, 0.2, 0.3])))
    below["decreasing_heave_saturated"] = ("reduced_velocity", np.array([0.0, 1.0, 1.0, 1.0]))
    assert lco.classify_onset(below, 4.7) == "subcritical"
    growing = below.assign(
        heave_state=("reduced_velocity", np.array(["decaying", "growing", "growing", "x"]))
    )
    assert lco.classify_onset(growing, 4.7) == "supercritical"


def test_the_diagram_marks_only_onsets_and_keeps_its_marches_when_the_search_fails(tmp_path, monkeypatch):
    _fake_marches(monkeypatch, lambda velocity, start: _fake_series(velocity))
    case = Case.create("cylinder", 100, preset="coarse")
    solid = solid_for("cylinder", 10.0, 4.0, dofs=("heave",))
    settings = LcoSettings((4.0, 6.0), 3, SimulationSettings(200.0, 0.1))
    kinds, boundaries = ["flutter", "flutter", "divergence"], ["onset", "restabilisation", "onset"]
    _thresholds_found(monkeypatch, [5.0, 7.0, 3.0], kinds, boundaries)
    ds = lco.limit_cycles(case, solid, settings, 10.0, tmp_path, tmp_path / "out")
    assert list(ds.threshold_velocity.values) == [5.0]
    _thresholds_found(monkeypatch, [], [], [], error=RuntimeError("no convergence"))
    ds = lco.limit_cycles(case, solid, settings, 10.0, tmp_path, tmp_path / "out")
    assert "threshold search failed" in ds.attrs["onset"] and "no convergence" in ds.attrs["onset"]
    assert ds.sizes["threshold"] == 0 and list(ds.heave_state.values) == ["saturated"] * 3
    assert Path(ds.attrs["data"]).is_file()


def test_the_diagram_keeps_each_start_mode_and_warns_of_a_decaying_one_past_the_threshold(
    tmp_path, monkeypatch
):
    """A coupled-mode pair past the threshold (5.0): at U* = 5.5 the shift picked the decaying
    partner (λ < 0), at 6.0 the growing mode. The diagram keeps every start mode, the report and
    the JSON say which march started from the decaying one; below the threshold (4.5) and at it
    (5.0) a decaying start mode is expected and not flagged."""
    rates = {4.5: -0.002, 5.0: -0.001, 5.5: -0.0132, 6.0: 0.0008}

    def released(velocity, start):
        return _fake_series(velocity).assign_attrs(
            start_growth_rate=rates[velocity], start_frequency=0.17, perturbation_of="heave"
        )

    _fake_marches(monkeypatch, released)
    _thresholds_found(monkeypatch, [5.0], ["flutter"], ["onset"])
    case = Case.create("cylinder", 100, preset="coarse")
    solid = solid_for("cylinder", 10.0, 4.5, dofs=("heave",))
    settings = LcoSettings((4.5, 6.0), 4, SimulationSettings(200.0, 0.1, 0.1, perturbation_of="heave"))
    ds = lco.limit_cycles(case, solid, settings, 10.0, tmp_path, tmp_path / "out")
    assert list(ds.error.values) == [""] * 4
    assert ds.start_growth_rate.values == pytest.approx([-0.002, -0.001, -0.0132, 0.0008])
    warning = ds.attrs["start_mode_warning"]
    assert "U* = 5.5 (λ = -0.0132" in warning
    assert all(f"λ = {r:+.3g}," not in warning for r in (-0.002, -0.001, 0.0008))
    payload = payloads.payload("lco", ds)
    assert payload["points"][2]["start_eigenvalue"] == {"growth_rate": -0.0132, "frequency": 0.17}
    lines = [line for line in reports.lco(ds, payload) if isinstance(line, str)]  # the table apart
    assert any(line.startswith("warning: past the linear threshold") for line in lines)
    _fake_marches(
        monkeypatch,
        lambda velocity, start: released(velocity, start).assign_attrs(
            start_growth_rate=abs(rates[velocity])
        ),
    )
    ds = lco.limit_cycles(case, solid, settings, 10.0, tmp_path, tmp_path / "out2")
    assert ds.attrs["start_mode_warning"] == "" and payloads.payload("lco", ds)["start_mode_warning"] is None


def test_records_beyond_the_duration_are_not_read_nor_chained_from(tmp_path, monkeypatch):
    """The march cache holds a longer run (to t = 400) of the same march: read to --duration 200 the
    oscillation still grows (it saturates only later), and the decreasing sweep refuses to start
    from the checkpoint's state at t = 400."""
    t = np.arange(0.0, 400.0, 0.1)

    def longer(velocity, start):
        heave = _landau(t, 0.02, 0.8, 1e-3, 0.1)
        return xr.Dataset(
            {n: ("time", heave if n == "heave" else 0 * t) for n in ("heave", "pitch", "lift_coefficient")},
            coords={"time": t},
            attrs={"dofs": "heave", "checkpoint": f"state_u{velocity:g}.nc", "duration": 399.9},
        )

    settings = LcoSettings((5.0, 6.0), 2, SimulationSettings(200.0, 0.1), hysteresis=True)
    point = lco.point_dataset(longer(5.0, None), 5.0, settings)
    assert point.heave_state.item() == "growing"
    assert point.attrs["duration"] == pytest.approx(200.0) and point.attrs["march_end"] == pytest.approx(
        399.9
    )
    calls = _fake_marches(monkeypatch, longer)
    case = Case.create("cylinder", 100, preset="coarse")
    solid = solid_for("cylinder", 10.0, 5.0, dofs=("heave",))
    ds = lco.limit_cycles(case, solid, settings, 10.0, tmp_path, tmp_path / "out", thresholds=False)
    assert calls == [(5.0, None), (6.0, None)]
    assert "beyond --duration 200" in str(ds.decreasing_error.values[0])


def test_the_given_start_state_starts_every_march_of_the_sweep(tmp_path, monkeypatch):
    calls = _fake_marches(monkeypatch, lambda velocity, start: _fake_series(velocity))
    case = Case.create("cylinder", 100, preset="coarse")
    solid = solid_for("cylinder", 10.0, 4.0, dofs=("heave",))
    settings = LcoSettings((4.0, 5.0), 2, SimulationSettings(200.0, 0.1, start="given.nc"))
    lco.limit_cycles(case, solid, settings, 10.0, tmp_path, tmp_path / "out", thresholds=False)
    assert calls == [(4.0, "given.nc"), (5.0, "given.nc")]


def test_a_point_identity_covers_the_sponge_and_the_typical_section():
    """Both enter the march's residual: a point computed with one is never read back for the other."""
    settings = LcoSettings((4.0, 4.0), 1, SimulationSettings(100.0, 0.1))
    plate = Case.create("plate", 1000, preset="coarse", sponge="none")
    sponged = Case.create("plate", 1000, preset="coarse", sponge="0.2,0.25")
    solid = solid_for("plate", 100.0, 4.0)
    identities = {
        lco.point_identity(plate, solid, 4.0, settings, None),
        lco.point_identity(sponged, solid, 4.0, settings, None),
        lco.point_identity(plate, replace_solid(solid, static_unbalance=0.05), 4.0, settings, None),
        lco.point_identity(plate, replace_solid(solid, elastic_axis=-0.1), 4.0, settings, None),
    }
    assert len(identities) == 4


def test_a_start_file_marched_further_is_another_start(tmp_path):
    """``--start`` is identified by its bytes as well as its path: the checkpoint of a march run
    further since (same path, another last state) gives another point identity, so the cached
    march from the old state is never taken for the new one; the perturbation's scale is part of
    the identity too (and absent at its default, so the keys of earlier marches stay theirs)."""
    start = tmp_path / "given.nc"
    start.write_bytes(b"state one")
    case = Case.create("cylinder", 100, preset="coarse")
    solid = solid_for("cylinder", 10.0, 4.0, dofs=("heave",))
    settings = LcoSettings((4.0, 4.0), 1, SimulationSettings(100.0, 0.1))
    first = lco.point_identity(case, solid, 4.0, settings, str(start))
    assert lco.point_identity(case, solid, 4.0, settings, str(start)) == first
    start.write_bytes(b"state two")
    assert lco.point_identity(case, solid, 4.0, settings, str(start)) != first
    default = lco.point_identity(case, solid, 4.0, settings, None)
    assert "perturbation_of" not in default
    heave = LcoSettings((4.0, 4.0), 1, SimulationSettings(100.0, 0.1, perturbation_of="heave"))
    assert '"perturbation_of": "heave"' in lco.point_identity(case, solid, 4.0, heave, None)


def test_without_thresholds_the_onset_says_why_it_is_undetermined(tmp_path, monkeypatch):
    _fake_marches(monkeypatch, lambda velocity, start: _fake_series(velocity))
    case = Case.create("cylinder", 100, preset="coarse")
    solid = solid_for("cylinder", 10.0, 4.0, dofs=("heave",))
    settings = LcoSettings((4.0, 5.0), 2, SimulationSettings(200.0, 0.1))
    ds = lco.limit_cycles(case, solid, settings, 10.0, tmp_path, tmp_path / "out", thresholds=False)
    assert ds.attrs["onset"] == "undetermined (thresholds not computed: --no-thresholds)"


def replace_solid(solid, **changes):
    from dataclasses import replace

    return replace(solid, **changes)


def test_both_sweeps_are_counted_and_kept_apart_with_their_provenance(tmp_path, monkeypatch):
    """A decreasing march that fails counts as failed (exit status 1); a run with --hysteresis is
    another file than one without; the chain from a march still growing is flagged; the file
    carries the solid, the sponge and the march settings."""

    def series(velocity, start):
        if start == "state_u5.nc":
            raise RuntimeError("step failed")
        ds = _fake_series(velocity).assign_attrs(checkpoint=f"state_u{velocity:g}.nc")
        if velocity == 6.0:  # still growing at the top
            t = ds.time.values
            ds = ds.assign(heave=("time", 1e-3 * np.exp(0.01 * t) * np.sin(0.8 * t)))
        return ds

    _fake_marches(monkeypatch, series)
    case = Case.create("cylinder", 100, preset="coarse")
    solid = solid_for("cylinder", 10.0, 4.0, dofs=("heave",))
    simulation = SimulationSettings(200.0, 0.1, shift=0.1 + 0.75j, tolerance=1e-7)
    plain = LcoSettings((4.0, 6.0), 3, simulation)
    hysteresis = LcoSettings((4.0, 6.0), 3, simulation, hysteresis=True)
    first = lco.limit_cycles(case, solid, plain, 10.0, tmp_path, tmp_path / "out", thresholds=False)
    both = lco.limit_cycles(case, solid, hysteresis, 10.0, tmp_path, tmp_path / "out", thresholds=False)
    assert first.attrs["failed"] == 0 and both.attrs["failed"] == 1
    assert first.attrs["data"] != both.attrs["data"]
    assert list(both.decreasing_start_state.values) == ["failed", "growing", "not chained"]
    from fsistab.store import read_dataset

    a = read_dataset(both.attrs["data"]).attrs
    assert a["zeta_h"] == solid.zeta_h and a["static_unbalance"] == 0.0 and a["sponge"] == "none"
    assert a["shift"] == "0.1+0.75j" and a["step_tolerance"] == 1e-7 and a["hysteresis"] == 1


def test_a_fixed_body_s_diagram_is_read_on_the_lift(tmp_path, monkeypatch):
    """Without heave or pitch the onset fit is the lift coefficient's, as the diagram draws it:
    ``A² = 0.2 (U* − 4.3)``."""

    def lift(velocity, start):
        t = np.arange(0.0, 200.0, 0.1)
        signal = _landau(t, 0.1, 0.8, 1e-3, math.sqrt(0.2 * (velocity - 4.3)))
        zeros = np.zeros_like(t)
        data = {"heave": ("time", zeros), "pitch": ("time", zeros), "lift_coefficient": ("time", signal)}
        return xr.Dataset(data, coords={"time": t}, attrs={"dofs": "none", "checkpoint": "c.nc"})

    _fake_marches(monkeypatch, lift)
    _thresholds_found(monkeypatch, [4.3], ["flutter"], ["onset"])
    case = Case.create("cylinder", 100, preset="coarse")
    solid = solid_for("cylinder", 10.0, 4.5, dofs=())
    settings = LcoSettings((4.5, 5.5), 3, SimulationSettings(200.0, 0.1))
    ds = lco.limit_cycles(case, solid, settings, 10.0, tmp_path, tmp_path / "out")
    # the amplitudes to the sampling (1e-3, see the resume test): U*_0 to about 1e-2
    assert ds.attrs["onset_velocity"] == pytest.approx(4.3, abs=2e-2)
    assert ds.attrs["onset"] == "supercritical"
