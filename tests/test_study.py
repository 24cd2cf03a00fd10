"""Parameter studies (fsistab.study, ``fsistab study``): the classification of thresholds on
synthetic energies, input checks before any work, and on the coarse plate at Re 100 (α0 = 0, 2,
4°, slopes and modes): the serial run against physics (symmetry, slope against the coefficients,
continuation from the neighbour), a real 2-process LocalCluster giving the same numbers, a rerun
computing nothing, a damaged point file recomputed, a failed point reported while the others go
on, a worker killed mid-study losing no finished point; thresholds at one point checked against
the divergence formula and the eigenvalues."""

import json
import logging
import math
import os
import signal
import sys
import threading
import time
from dataclasses import replace
from functools import partial
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from damage import damage
from typer.testing import CliRunner

from fsistab import study
from fsistab.cli import app
from fsistab.errors import ConvergenceError, InputError
from fsistab.operators import FluidOperators
from fsistab.params import Case, MapSettings, Solid
from fsistab.study import (
    CLASSES,
    StudySettings,
    check_execution,
    classify,
    mode_energies,
    point_path,
    run_study,
    study_lists,
)

runner = CliRunner()
SETTINGS = StudySettings(
    reynolds=(100.0,), alpha0=(0.0, 2.0, 4.0), slopes=True, modes=True, shifts=(0.5j,), n_modes=3
)
# what depends on the execution (the neighbour a steady state continued from, the time taken)
EXECUTION = ("point_steady_start", "point_seconds", "point_factorisations")


# --- classification (no mesh) ----------------------------------------------------------------------


def _classify(frequency=0.2, heave=1.0, pitch=1.0, fluid=0.1, wake=math.nan, branch=False):
    # in-vacuo frequencies of Ω = 0.8 at U* = 5: ω_h = 0.16, ω_θ = 0.2
    return classify(frequency, heave, pitch, fluid, 0.16, 0.2, wake, branch)


def test_classes_by_mechanism_when_the_one_dof_rates_are_known():
    """Rules 3 and 5: the one-dof growth rates decide, whatever the solid energy shares say: the
    mode's own dof (the larger solid energy) alone unstable makes it that dof's single-mode
    flutter; the other dof alone unstable does not."""
    heave_led = {"heave": 9.0, "pitch": 1.0}  # single-mode by energy alone
    assert classify(0.2, *heave_led.values(), 0.1, 0.16, 0.2, math.nan, False, -0.003, -0.014) == (
        "coupled-mode flutter"
    )
    assert classify(0.2, *heave_led.values(), 0.1, 0.16, 0.2, math.nan, False, 0.0, -0.014) == (
        "heave single-mode flutter"
    )
    assert classify(0.2, *heave_led.values(), 0.1, 0.16, 0.2, math.nan, False, 0.001, 0.002) == (
        "heave single-mode flutter"
    )
    # heave-led, only pitch alone unstable (its own mode, elsewhere): the coupling destabilises
    assert classify(0.16, *heave_led.values(), 0.1, 0.16, 0.2, math.nan, False, -0.001, 0.002) == (
        "coupled-mode flutter"
    )
    assert classify(0.2, 1.0, 9.0, 0.1, 0.16, 0.2, math.nan, False, 0.002, 0.001) == (
        "pitch single-mode flutter"
    )
    # VIV and divergence are decided before
    assert classify(0.0, 1.0, 1.0, 0.1, 0.16, 0.2, math.nan, False, 0.1, 0.1) == "divergence"
    assert classify(0.2, 1.0, 1.0, 5.0, 0.16, 0.2, math.nan, True, 0.1, 0.1) == "viv"
    assert classify(0.9, 1.0, 1.0, 5.0, 0.16, 0.2, 1.0, False, 0.1, 0.1) == "viv"


def test_fluid_dominated_onsets_at_a_solid_frequency():
    """Rule 3 before rule 4: near stall the separated flow holds most of the energy near the body
    of a pitch single-mode flutter. The onsets of the Re 500 α0 study on the default mesh
    (docs/gallery): at α0 = 8°, U* 5.01856, ω 0.19084, energy shares heave / pitch / fluid
    0.083 / 0.110 / 0.807, pitch alone +7.5e-5, heave alone -9e-4."""
    u = 5.01856
    assert classify(0.19084, 0.083, 0.110, 0.807, 0.8 / u, 1 / u, math.nan, False, -9e-4, 7.5e-5) == (
        "pitch single-mode flutter"
    )
    # the same energies without the pitch alone unstable: a wake mode carrying the body
    assert classify(0.19084, 0.083, 0.110, 0.807, 0.8 / u, 1 / u, math.nan, False, -9e-4, -1e-4) == "viv"
    # pitch alone unstable but the onset far (> 30 %) from the pitch frequency: not its flutter
    assert classify(0.27, 0.083, 0.110, 0.807, 0.8 / u, 1 / u, math.nan, False, -9e-4, 7.5e-5) == "viv"
    # solid-dominated, pitch alone unstable: no frequency condition (aerodynamic stiffness moves it)
    assert classify(0.27, 0.1, 0.8, 0.1, 0.8 / u, 1 / u, math.nan, False, -9e-4, 7.5e-5) == (
        "pitch single-mode flutter"
    )
    # at the wake frequency (nearer it than the pitch frequency), rule 2 comes first: lock-in
    assert classify(0.19084, 0.083, 0.110, 0.807, 0.8 / u, 1 / u, 0.19, False, -9e-4, 7.5e-5) == "viv"


def test_classes_of_the_stored_alpha0_study():
    """classify_thresholds redraws the classes of a stored study from its shares, frequencies and
    one-dof rates: the Re 500 α0 study on the previous default mesh (docs/data; its points at 0°–12° were
    computed when the energy rule came first and stored `viv` for the pitch-led onsets). The
    expected classes are the physics of each critical mode: coupled-mode flutter at 0–6° (heave-led,
    both dofs alone stable), divergence at 0–4°; pitch single-mode flutter at 8°–16° (pitch-led,
    at ω/ω_θ = 0.96–1.01, pitch alone unstable); at 10° and 12° the heave-led onsets at the heave
    frequency with heave alone stable are coupled-mode flutter."""
    import xarray as xr

    data = xr.load_dataset(Path(__file__).parents[1] / "docs" / "data" / "alpha0_study_Re500_medium.nc")
    classes = study.classify_thresholds(data).sel(reynolds=500.0, mass_ratio=1000.0)
    coupled, pitch = "coupled-mode flutter", "pitch single-mode flutter"
    expected = {
        0.0: [coupled, "divergence"],
        2.0: [coupled, "divergence"],
        4.0: [coupled, "divergence"],
        6.0: [coupled, ""],
        8.0: [pitch, ""],
        10.0: [pitch, coupled],
        12.0: [coupled, pitch],
        14.0: [pitch, ""],
        16.0: [pitch, ""],
    }
    assert {a: classes.sel(alpha0=a).values.tolist() for a in expected} == expected


def test_plate_flutter_at_re_2900_is_coupled_mode(plate_operators):
    """Moulin & Marquet 2021: the plate's flutter at Re 2900, m = 1000 is coupled-mode flutter. Its
    critical mode holds 94 % of the near-body kinetic energy in heave (coarse mesh, U*_c 4.3928,
    ω_c 0.18762), but heave alone and pitch alone are both stable there."""
    from fsistab.study import single_dof_growth

    solid = Solid(mass_ratio=1000.0, reduced_velocity=4.3928)
    heave = single_dof_growth(plate_operators, solid, 4.3928, 0.18762, "heave")
    pitch = single_dof_growth(plate_operators, solid, 4.3928, 0.18762, "pitch")
    assert heave < -1e-3 and pitch < -1e-3
    assert classify(0.18762, 0.94, 0.01, 0.05, 0.8 / 4.3928, 1 / 4.3928, math.nan, False, heave, pitch) == (
        "coupled-mode flutter"
    )


def test_classes_by_energy_shares():
    assert _classify(heave=1.0, pitch=1.0) == "coupled-mode flutter"
    assert _classify(heave=9.0, pitch=1.0) == "heave single-mode flutter"
    assert _classify(heave=1.0, pitch=9.0) == "pitch single-mode flutter"
    # the limits: three quarters of the solid energy in one dof makes it single-mode
    assert _classify(heave=3.0, pitch=1.0) == "heave single-mode flutter"
    assert _classify(heave=1.0, pitch=3.0) == "pitch single-mode flutter"
    assert _classify(heave=2.9, pitch=1.0) == "coupled-mode flutter"
    # a heave-only body (the cylinder): its flutter is heave single-mode
    assert _classify(heave=1.0, pitch=0.0) == "heave single-mode flutter"


def test_divergence_and_viv():
    assert _classify(frequency=0.0, heave=0.0, pitch=0.0, fluid=0.0) == "divergence"
    assert _classify(frequency=0.0, heave=0.0, pitch=1.0) == "divergence"
    # the fluid holds half the energy or more: a wake mode carrying the body
    assert _classify(heave=0.5, pitch=0.5, fluid=1.0) == "viv"
    assert _classify(heave=0.5, pitch=0.5, fluid=0.99) == "coupled-mode flutter"
    # on the tracked wake branch, whatever its energies
    assert _classify(branch=True) == "viv"
    # within 30 % of the wake frequency and nearer to it than to both solid frequencies
    assert _classify(frequency=0.9, wake=1.0) == "viv"
    assert _classify(frequency=0.69, wake=1.0) == "coupled-mode flutter"  # 31 % away
    # near the wake frequency but nearer the pitch frequency: the solid's flutter
    assert _classify(frequency=0.2, wake=0.25, heave=1.0, pitch=9.0) == "pitch single-mode flutter"
    assert set(CLASSES) == {
        "coupled-mode flutter",
        "pitch single-mode flutter",
        "heave single-mode flutter",
        "divergence",
        "viv",
    }


def test_classify_refuses_non_finite_or_negative_inputs():
    with pytest.raises(InputError):
        _classify(frequency=math.nan)
    with pytest.raises(InputError):
        _classify(heave=-1.0)


def test_mode_energies_of_a_known_vector():
    """E_h = (m/4)|ḣ|², E_θ = (m/4) r_θ²|θ'|², E_f = ½ q_fᴴ M_near q_f (units ρL²U∞²)."""
    mass, r = 100.0, 0.3
    solid_states = np.array([0.1, 0.2j, 2.0, 1.0 + 1.0j])
    fluid = np.array([1.0, 2.0j])
    operators = SimpleNamespace(mff_near=np.diag([2.0, 0.5]), theta0=0.0)
    operators.near_energy = partial(FluidOperators.near_energy, operators)  # the method under test
    system = SimpleNamespace(
        split=lambda q: (solid_states, fluid),
        solid=SimpleNamespace(mass_ratio=mass, r_theta=r, static_unbalance=0.0),
        fluid=operators,
    )
    heave, pitch, fluid_energy = mode_energies(system, np.zeros(6))
    assert heave == pytest.approx(25 * 4.0)
    assert pitch == pytest.approx(25 * 0.09 * 2.0)
    assert fluid_energy == pytest.approx(0.5 * (2.0 * 1.0 + 0.5 * 4.0))


# --- inputs refused before any work ----------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"reynolds": ()}, "at least one value of --Re"),
        ({"reynolds": (100, 100)}, "distinct"),
        ({"reynolds": (-5,)}, "--Re"),
        ({"reynolds": (1e9,)}, "--Re"),
        ({"alpha0": (50,)}, "--alpha0"),
        ({"alpha0": (math.nan,)}, "--alpha0"),
        ({"slopes": False, "modes": False}, "nothing to compute"),
        ({"thresholds": (0.0,)}, "mass ratios"),
        ({"shifts": (0.5 - 1j,)}, "--shift"),
        ({"n_modes": 0}, "--n-modes"),
        ({"velocity_range": (10.0, 2.0)}, "--reduced-velocity-range"),
        ({"points": 1}, "--points"),
        ({"wake_shift": 0.5 + 0j}, "--wake-shift"),
        ({"r_theta": -1.0}, "radius of gyration"),
    ],
)
def test_bad_settings_are_refused_in_one_line(kwargs, message):
    with pytest.raises(InputError, match=message) as info:
        replace(SETTINGS, **kwargs)
    assert "\n" not in str(info.value)


def test_body_dependent_checks():
    with pytest.raises(InputError, match="--shift"):
        replace(SETTINGS, shifts=()).check_body("plate")
    replace(SETTINGS, shifts=()).check_body("cylinder")  # the cylinder's wake mode by default
    assert replace(SETTINGS, shifts=()).mode_shifts("cylinder") == (0.75j,)
    with pytest.raises(InputError, match="plate"):
        replace(SETTINGS, map=True, map_settings=MapSettings()).check_body("cylinder")
    with pytest.raises(InputError, match="degree of freedom"):
        replace(SETTINGS, thresholds=(10.0,), dofs=()).check_body("plate")
    with pytest.raises(InputError, match="not both"):
        check_execution(2, "tcp://localhost:8786")
    with pytest.raises(InputError, match="--workers"):
        check_execution(0, None)


def test_study_lists_of_the_command_line():
    args = ["--Re", "100", "500", "--alpha0", "-4", "0", "4", "--thresholds=1000", "20"]
    assert study_lists(args) == {
        "reynolds": [100.0, 500.0],
        "alpha0": [-4.0, 0.0, 4.0],
        "thresholds": [1000.0, 20.0],
    }
    for bad, message in (
        (["--Re", "abc"], "not a number"),
        (["--Re", "1", "--Re", "2"], "twice"),
        (["--bogus", "1"], "no such option"),
        (["7"], "unexpected argument"),
    ):
        with pytest.raises(InputError, match=message):
            study_lists(bad)


@pytest.mark.parametrize(
    "args, message",
    [
        (["--slopes"], "--Re"),
        (["--Re", "100", "100", "--slopes"], "distinct"),
        (["--Re", "100", "--alpha0", "60", "--slopes"], "--alpha0"),
        (["--Re", "100"], "nothing to compute"),
        (["--Re", "100", "--modes"], "--shift"),
        (["--Re", "100", "--slopes", "--workers", "2", "--scheduler", "tcp://h:1"], "not both"),
        (["--Re", "100", "--slopes", "--mesh", "huge"], "preset"),
        (["--Re", "100", "--slopes", "--body", "cylinder", "--map"], "plate"),
        (["x", "--Re", "100", "--slopes"], "unexpected argument"),
        (["--Re", "100", "x", "--slopes"], "'x' is not a number (after --Re)"),
        (["--Re", "100", "--slopes", "--scheduler", "garbage"], "missing port number"),
        (["--Re", "100", "--slopes", "--scheduler", "udp://localhost:8786"], "unknown address scheme 'udp'"),
        (["--Re", "100", "--slopes", "--scheduler", "tcp://localhost"], "--scheduler must be an address"),
    ],
)
def test_command_refuses_bad_input_before_any_work(tmp_path, args, message):
    out = tmp_path / "out"
    result = runner.invoke(app, ["study", *args, "--out", str(out), "--cache", str(tmp_path / "c")])
    assert result.exit_code == 2, result.output
    assert message in result.output and result.output.count("\n") == 1
    assert not out.exists()  # refused before anything was created


# --- the coarse plate at Re 100 ------------------------------------------------------------------------


@pytest.fixture(scope="module")
def base_case():
    return Case.create("plate", 100.0, 0.0, "coarse")


@pytest.fixture(scope="module")
def serial(tmp_path_factory, base_case):
    root = tmp_path_factory.mktemp("serial")
    return root, run_study(base_case, SETTINGS, root / "cache", root / "out")


@pytest.fixture(scope="module")
def parallel(tmp_path_factory, base_case, client):
    """The same study on 2 worker processes, from an empty cache."""
    root = tmp_path_factory.mktemp("parallel")
    return root, run_study(base_case, SETTINGS, root / "cache", root / "out", client=client)


def _point_files(directory):
    """The finished points' files (not the temporary ``.*.part.nc`` of a write in progress)."""
    return sorted(p for p in directory.glob("*.nc") if not p.name.startswith("."))


def _assert_same_results(a, b):
    assert set(a.data_vars) == set(b.data_vars)
    for name in a.data_vars:
        if name in EXECUTION:
            continue
        if a[name].dtype.kind in "fc":
            # steady states agree to Newton's tolerance (continued from different neighbours) and
            # eigenvalues to ARPACK's (random start vector)
            np.testing.assert_allclose(a[name].values, b[name].values, rtol=1e-7, atol=1e-9, err_msg=name)
        else:
            np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)


def test_serial_study_against_physics(serial):
    _, ds = serial
    assert ds.attrs["points"] == 3 and ds.attrs["computed"] == 3 and ds.attrs["failed"] == 0
    assert (ds.status.values == "done").all()
    lift = ds.lift_coefficient.sel(reynolds=100.0).values
    assert abs(lift[0]) < 1e-8  # the symmetric plate at α0 = 0
    assert 0 < lift[1] < lift[2]
    # the static slope (linearised) against the steady lift (nonlinear) at 2°: C_L is odd in α,
    # so the secant differs from the tangent by O(α²)
    secant = lift[1] / math.radians(2.0)
    assert secant == pytest.approx(float(ds.lift_slope_alpha.sel(reynolds=100.0, alpha0=0.0)), rel=0.02)
    # the modes: the least stable first, damped (Re 100 is below the plate's wake onset)
    rates = ds.mode_growth_rate.values[0]
    assert np.all(np.diff(rates, axis=-1) <= 0) and np.all(rates < 0)
    # in order of |α0| each steady state continued from its neighbour on the same mesh
    starts = ds.point_steady_start.sel(reynolds=100.0).values.tolist()
    assert starts == ["rest", "Re 100, a 0", "Re 100, a 2"]
    assert ds.attrs["factorisations"] == int(ds.point_factorisations.sum()) > 0


def test_local_cluster_gives_the_serial_results(serial, parallel):
    _, ds = parallel
    assert ds.attrs["computed"] == 3 and ds.attrs["failed"] == 0
    assert "dask.distributed (2 workers)" == ds.attrs["execution"]
    _assert_same_results(serial[1], ds)


def test_a_worker_with_two_threads_gives_the_serial_results(base_case, serial, tmp_path):
    """A scheduler's worker may run several tasks in threads; Netgen and NGSolve are not safe in
    two threads at once, so its points take turns (``fsistab.mesh.NGSOLVE_LOCK``)."""
    distributed = pytest.importorskip("distributed")
    cluster = partial(distributed.LocalCluster, n_workers=1, processes=True, dashboard_address=None)
    with cluster(threads_per_worker=2) as two_threads, distributed.Client(two_threads) as threaded:
        ds = run_study(base_case, SETTINGS, tmp_path / "cache", tmp_path / "out", client=threaded)
    assert ds.attrs["computed"] == 3 and ds.attrs["failed"] == 0
    _assert_same_results(serial[1], ds)


def test_rerun_on_the_cluster_computes_nothing(base_case, parallel, client):
    root, first = parallel
    files = _point_files(root / "out" / "points")
    assert len(files) == 3
    stamps = [f.stat().st_mtime_ns for f in files]
    again = run_study(base_case, SETTINGS, root / "cache", root / "out", client=client)
    assert again.attrs["computed"] == 0 and again.attrs["factorisations"] == 0
    assert [f.stat().st_mtime_ns for f in files] == stamps
    _assert_same_results(first, again)
    for name in EXECUTION[:1]:
        np.testing.assert_array_equal(first[name].values, again[name].values)


def test_point_identity_counts_only_what_is_computed(base_case, tmp_path):
    """A point's file is found again when the grid grows or an unused option changes, not when
    what it computes changes."""
    same = point_path(tmp_path, base_case, SETTINGS)
    assert point_path(tmp_path, base_case, replace(SETTINGS, reynolds=(100.0, 500.0))) == same
    assert point_path(tmp_path, base_case, replace(SETTINGS, points=12, r_theta=0.3)) == same
    assert point_path(tmp_path, base_case, replace(SETTINGS, shifts=(0.6j,))) != same
    assert point_path(tmp_path, base_case, replace(SETTINGS, thresholds=(1000.0,))) != same
    other = replace(base_case, flow=replace(base_case.flow, alpha0_deg=2.0))
    assert point_path(tmp_path, other, SETTINGS) != same


def test_command_on_a_running_scheduler(serial, client):
    """``--scheduler ADDRESS``: the command connects to the running cluster (nothing to compute)."""
    root, ds = serial
    args = ["study", "--Re", "100", "--alpha0", "0", "2", "4", "--slopes", "--modes", "--shift", "0.5j"]
    args += ["--n-modes", "3", "--mesh", "coarse", "--out", str(root / "out"), "--cache", str(root / "cache")]
    result = runner.invoke(app, [*args, "--scheduler", client.scheduler.address, "--json"])
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    assert payload["computed"] == 0 and payload["execution"] == "dask.distributed (2 workers)"


def test_command_reads_the_finished_study(serial):
    root, ds = serial
    args = ["study", "--Re", "100", "--alpha0", "0", "2", "4", "--slopes", "--modes", "--shift", "0.5j"]
    args += ["--n-modes", "3", "--mesh", "coarse", "--out", str(root / "out"), "--cache", str(root / "cache")]
    result = runner.invoke(app, [*args, "--json"])
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    assert payload["points"] == 3 and payload["computed"] == 0 and payload["failed"] == []
    assert payload["factorisations"] == 0 and payload["data"] == ds.attrs["data"]
    assert len(payload["figures"]) == 2 and all(os.path.exists(f) for f in payload["figures"])


def test_damaged_point_file_is_reported_and_recomputed(base_case, serial, caplog):
    root, first = serial
    path = point_path(
        root / "out", replace(base_case, flow=replace(base_case.flow, alpha0_deg=2.0)), SETTINGS
    )
    damage(path, "flipped", "mode_growth_rate")
    with caplog.at_level(logging.WARNING, logger="fsistab"):
        again = run_study(base_case, SETTINGS, root / "cache", root / "out")
    assert "damaged" in caplog.text and path.with_name(path.name + ".damaged").exists()
    assert again.attrs["computed"] == 1
    _assert_same_results(first, again)


def test_failed_point_is_reported_and_the_others_go_on(base_case, serial, tmp_path, monkeypatch):
    root, first = serial
    original = study.run_point

    def failing(case, settings, cache_dir, progress=None):
        if case.flow.alpha0_deg == 2.0:
            raise ConvergenceError("steady continuation lost the branch (test)\nsecond line")
        return original(case, settings, cache_dir, progress)

    monkeypatch.setattr(study, "run_point", failing)
    # in-process execution needs no dask: make importing it fail
    for name in ("dask", "distributed"):
        monkeypatch.setitem(sys.modules, name, None)
    ds = run_study(base_case, SETTINGS, root / "cache", tmp_path / "out")
    status = ds.status.sel(reynolds=100.0).values.tolist()
    assert status == ["done", "failed", "done"] and ds.attrs["failed"] == 1
    assert ds.error.sel(reynolds=100.0, alpha0=2.0).item() == "steady continuation lost the branch (test)"
    assert np.isnan(ds.lift_coefficient.sel(reynolds=100.0, alpha0=2.0).item())
    assert len(_point_files(tmp_path / "out" / "points")) == 2
    monkeypatch.setattr(study, "run_point", original)
    again = run_study(base_case, SETTINGS, root / "cache", tmp_path / "out")
    assert again.attrs["computed"] == 1 and again.attrs["failed"] == 0
    _assert_same_results(first, again)


def test_killed_worker_loses_no_finished_point(base_case, parallel, client, tmp_path):
    """A worker process killed (SIGKILL) while it computes a point: the points finished before
    keep their files, dask resubmits the lost one, and a resubmission of the study completes."""
    root, first = parallel
    points = tmp_path / "out" / "points"
    outcome = {}

    def run():
        outcome["ds"] = run_study(base_case, SETTINGS, root / "cache", tmp_path / "out", client=client)

    thread = threading.Thread(target=run)
    thread.start()
    killed, finished = None, {}
    deadline = time.monotonic() + 120
    while thread.is_alive() and killed is None and time.monotonic() < deadline:
        done = _point_files(points)
        busy = [w for w, keys in client.processing().items() if keys]
        if done and busy:
            finished = {f: f.stat().st_mtime_ns for f in done}
            killed = busy[0]
            pid = client.run(os.getpid, workers=[killed])[killed]
            os.kill(pid, signal.SIGKILL)  # the worker process dies mid-point (its nanny restarts it)
        time.sleep(0.02)
    thread.join(timeout=300)
    assert killed is not None, "the study finished before a worker could be killed"
    ds = outcome["ds"]
    # the finished points were not recomputed
    assert all(f.stat().st_mtime_ns == stamp for f, stamp in finished.items())
    # (a finished task whose result was lost with its worker is run again by dask: it reads the
    # point's file instead of computing, hence the check above)
    if ds.attrs["failed"]:  # dask gave up on the point (worker lost repeatedly): resubmit
        again = run_study(base_case, SETTINGS, root / "cache", tmp_path / "out", client=client)
        assert again.attrs["computed"] == ds.attrs["failed"] and again.attrs["failed"] == 0
        ds = again
    assert (ds.status.values == "done").all() and len(_point_files(points)) == 3
    _assert_same_results(first, ds)


def test_thresholds_at_one_point(base_case, serial):
    """Heave flutter and divergence of the plate at Re 100, m = 1000: the divergence against
    ``U*_D = √(m r_θ²/(dC_M/dθ))`` (exact at α0 = 0, docs/model.md §8), the flutter point neutral."""
    from fsistab.coupled import CoupledSystem
    from fsistab.eigen import eigenpairs_near
    from fsistab.mesh import spec_for
    from fsistab.operators import fluid_operators
    from fsistab.steady import solve_steady

    root, _ = serial
    settings = StudySettings(
        reynolds=(100.0,), slopes=True, thresholds=(1000.0,), velocity_range=(4.0, 10.0), points=6
    )
    point = study.run_point(base_case, settings, root / "cache")
    ds = point.sel(mass_ratio=1000.0)
    kinds = ds.threshold_kind.values.tolist()
    assert "divergence" in kinds and "flutter" in kinds
    assert int(ds.threshold_unresolved_intervals) == 0
    assert set(ds.threshold_class.values.tolist()) <= set(CLASSES)
    divergence = ds.threshold_reduced_velocity.values[kinds.index("divergence")]
    expected = math.sqrt(1000.0 * settings.r_theta**2 / float(ds.moment_slope_alpha))
    assert divergence == pytest.approx(expected, rel=1e-6)
    assert ds.threshold_class.values[kinds.index("divergence")] == "divergence"
    k = kinds.index("flutter")
    shares = [float(ds[f"threshold_{s}_share"].values[k]) for s in ("heave", "pitch", "fluid")]
    assert sum(shares) == pytest.approx(1.0) and min(shares) >= 0
    velocity, frequency = ds.threshold_reduced_velocity.values[k], ds.threshold_frequency.values[k]
    assert ds.threshold_frequency_over_pitch.values[k] == pytest.approx(frequency * velocity)
    # an independent eigenvalue solve at (m, U*_c): an eigenvalue on the imaginary axis at ω_c
    steady = solve_steady(spec_for(base_case), base_case.flow, cache_dir=root / "cache")
    solid = settings.solid("plate", 1000.0, float(velocity))
    pairs = eigenpairs_near(CoupledSystem(fluid_operators(steady), solid), [1j * frequency], 2)
    nearest = min(pairs, key=lambda p: abs(p.value - 1j * frequency))
    assert abs(nearest.growth_rate) < 1e-7 and nearest.frequency == pytest.approx(frequency, rel=1e-6)
    # a point stored under other rules is classified anew, from its stored shares, frequency
    # ratios and one-dof rates, when the study is assembled
    stale = point.assign(threshold_class=point.threshold_class.where(point.threshold_kind == "", "viv"))
    outcome = study.PointOutcome(base_case.flow, stale)
    assembled = study.assemble(base_case, settings, {base_case.flow: outcome})
    refreshed = assembled.threshold_class.sel(reynolds=100.0, alpha0=0.0)
    assert refreshed.values.tolist() == point.threshold_class.values.tolist()
    assert "viv" not in refreshed.values.tolist()


def test_figures_of_a_study(serial, tmp_path):
    """The figures of a study draw from its Dataset: coefficients and modes from the serial run,
    overlaid maps from a small synthetic one (two points, two curves, one without divergence)."""
    import xarray as xr

    from fsistab import plots

    _, ds = serial
    assert plots.plot_study_coefficients(ds, tmp_path / "c.png").stat().st_size > 0
    assert plots.plot_study_thresholds(ds, tmp_path / "t.png").stat().st_size > 0
    m = np.array([[[10.0, 100.0, 1000.0, np.nan]], [[10.0, 100.0, 20.0, 200.0]]])
    synthetic = xr.Dataset(
        {
            "map_mass_ratio": (("reynolds", "alpha0", "map_point"), m),
            "map_reduced_velocity": (("reynolds", "alpha0", "map_point"), 0.2 * np.sqrt(m)),
            "map_curve": (("reynolds", "alpha0", "map_point"), np.array([[[0, 0, 0, -1]], [[0, 0, 1, 1]]])),
            "map_divergence_coefficient": (("reynolds", "alpha0"), np.array([[0.28], [np.inf]])),
        },
        coords={"reynolds": [100.0, 500.0], "alpha0": [0.0]},
    )
    assert plots.plot_study_maps(synthetic, tmp_path / "m.png").stat().st_size > 0


def test_leading_modes_pick_the_least_stable_of_each_point():
    """Per point the mode of largest growth rate (NaN modes padded at the end are skipped); a
    point without any mode (failed) gives NaN."""
    from fsistab.study import leading_modes

    nan = np.nan
    rates = np.array([[[-0.1, 0.02, nan], [nan, nan, nan]], [[-0.3, -0.2, -0.25], [0.1, nan, 0.3]]])
    frequencies = np.array([[[1.0, 2.0, nan], [nan, nan, nan]], [[3.0, 4.0, 5.0], [6.0, nan, 7.0]]])
    lead_rate, lead_frequency = leading_modes(rates, frequencies)
    np.testing.assert_array_equal(lead_rate, [[0.02, nan], [-0.2, 0.3]])
    np.testing.assert_array_equal(lead_frequency, [[2.0, nan], [4.0, 7.0]])
