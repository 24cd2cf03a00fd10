import json
import math
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from fsistab.cli import app

runner = CliRunner()


def _run(args, tmp_path):
    return runner.invoke(app, [*args, "--out", str(tmp_path / "out"), "--cache", str(tmp_path / "cache")])


def test_steady_json(tmp_path):
    result = _run(["steady", "--body", "cylinder", "--Re", "40", "--mesh", "coarse", "--json"], tmp_path)
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)  # exactly one JSON object on stdout
    for key in (
        "reynolds",
        "alpha0_deg",
        "lift_coefficient",
        "moment_coefficient",
        "drag_coefficient",
        "recirculation_length",
        "ndof",
        "newton_iterations",
    ):
        assert key in payload
    assert payload["reynolds"] == 40
    assert 1.3 < payload["drag_coefficient"] < 1.7
    assert (tmp_path / "out" / "steady_cylinder_Re40_a0.png").stat().st_size > 10_000


def test_steady_table_and_mesh_command(tmp_path):
    result = _run(["mesh", "--body", "plate", "--Re", "100", "--mesh", "coarse"], tmp_path)
    assert result.exit_code == 0, result.output
    assert "triangles" in result.stdout and "ndof" in result.stdout
    result = _run(["steady", "--body", "plate", "--Re", "100", "--alpha0", "3", "--mesh", "coarse"], tmp_path)
    assert result.exit_code == 0, result.output
    assert "lift coefficient" in result.stdout and "Newton residuals" in result.stdout


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["steady", "--Re", "0"], "Reynolds number must be positive"),
        (["steady", "--Re", "nan"], "Reynolds number must be finite"),
        (["steady", "--aspect-ratio", "1"], "chord/thickness ratio must be > 1"),
        (["steady", "--mesh", "huge"], "unknown mesh preset"),
        (["mesh", "--body", "sphere"], "unknown body"),
        (["mesh", "--body", "cylinder", "--mesh", "quick"], "defined for the plate, airfoil, curve only"),
        (["steady", "--alpha0", "60"], "alpha0 must be within"),
        (["onset", "--body", "cylinder", "--parameter", "alpha0", "--guess", "3"], "the cylinder is round"),
        (["onset", "--guess", "2900"], "give --shift for the plate"),
        (["onset", "--body", "cylinder"], "Missing option '--guess'"),
        (["onset", "--body", "cylinder", "--guess", "0"], "must be in (0, 1e+07]"),
        (["onset", "--body", "cylinder", "--guess", "47", "--shift", "abc"], "cannot read the shift"),
        (["onset", "--body", "cylinder", "--guess", "47", "--parameter", "re"], "--parameter must be one of"),
        (["onset", "--body", "cylinder", "--guess", "47", "--mesh", "huge"], "unknown mesh preset"),
    ],
)
def test_bad_input_one_line_error_and_nothing_written(tmp_path, args, message):
    result = _run([*args, "--json"], tmp_path)
    assert result.exit_code == 2
    assert result.stdout == ""
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and message in lines[0]
    assert not (tmp_path / "out").exists() and not (tmp_path / "cache").exists()


def test_corrupt_cache_is_refused(tmp_path, caplog):
    args = ["steady", "--body", "cylinder", "--Re", "30", "--mesh", "coarse", "--json"]
    assert _run(args, tmp_path).exit_code == 0
    for entry in (tmp_path / "cache" / "steady").iterdir():
        entry.write_bytes(b"garbage")
    result = _run(args, tmp_path)
    assert result.exit_code == 0  # a damaged entry is reported and recomputed, never used (store)
    assert "damaged" in caplog.text and "recomputing" in caplog.text  # on stderr through the CLI's handler


def test_spectrum_json_and_figures(tmp_path):
    args = ["spectrum", "--body", "cylinder", "--Re", "60", "--mesh", "coarse", "--mass-ratio", "20"]
    args += ["--reduced-velocity", "4", "--shift", "0.05+0.75j", "--n-eigenvalues", "2", "--json"]
    result = _run(args, tmp_path)
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    first = payload["eigenvalues"][0]
    assert set(first) == {"growth_rate", "frequency", "label", "residual"}
    assert first["residual"] < 1e-8
    assert (tmp_path / "out" / "spectrum_cylinder_Re60_a0.nc").exists()
    assert len(payload["mode_figures"]) == 4 and all((tmp_path / "out").glob("mode0_*.png"))
    assert payload["vtk"].endswith(".vtu")


def test_spectrum_refuses_bad_solid_before_work(tmp_path):
    result = _run(["spectrum", "--mass-ratio", "-1", "--json"], tmp_path)
    assert result.exit_code == 2 and "mass ratio must be positive" in result.stderr
    assert not (tmp_path / "cache").exists()
    result = _run(["spectrum", "--shift", "abc", "--json"], tmp_path)
    assert result.exit_code == 2 and "cannot read the shift" in result.stderr


def test_critical_json_matches_the_static_formula(tmp_path, plate_2900, plate_coarse_spec, plate_operators):
    """``fsistab critical`` (frequency sweep, the default): flutter onset then divergence at
    m = 1000 (Moulin & Marquet 2021 order); the divergence speed is the torsional formula
    √(m r_θ²/(dC_M/dθ)) of the static slope; the JSON names the method and has no unresolved
    interval."""
    import math

    from fsistab.params import Flow
    from fsistab.slopes import static_slopes
    from fsistab.steady import save_steady, steady_path

    cache = tmp_path / "cache"
    save_steady(plate_2900, steady_path(plate_coarse_spec, Flow(2900), cache))
    args = [
        "critical", "--body", "plate", "--Re", "2900", "--mesh", "coarse", "--mass-ratio", "1000",
        "--json", "--out", str(tmp_path / "out"), "--cache", str(cache),
    ]  # fmt: skip
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    kinds = [(p["kind"], p["boundary"]) for p in payload["critical_points"]]
    assert kinds == [("flutter", "onset"), ("divergence", "onset")]
    assert payload["method"] == "transfer" and payload["unresolved_intervals"] == 0
    slope = static_slopes(plate_operators).moment
    divergence = payload["critical_points"][1]["reduced_velocity"]
    assert divergence == pytest.approx(math.sqrt(1000 * 0.289**2 / slope), rel=1e-9)
    # --out holds the thresholds (NetCDF, the JSON's values) and their figure
    from fsistab.store import read_dataset

    saved = read_dataset(Path(payload["netcdf"]))
    assert Path(payload["netcdf"]).parent == tmp_path / "out"
    assert saved.reduced_velocity.values.tolist() == [
        p["reduced_velocity"] for p in payload["critical_points"]
    ]
    assert Path(payload["figure"]).stat().st_size > 10_000


def test_critical_kind_does_not_depend_on_the_wake_shift(
    tmp_path, plate_2900, plate_coarse_spec, plate_operators
):
    """``fsistab critical --wake-shift 0+0.19i`` at m = 1000: the fixed plate's least stable mode
    near 0.19 (a weakly damped far-field mode, ω ≈ 0.21) lies within 30 % of the flutter frequency
    0.1876, where the earlier rule called the onset VIV; the onset's frequency follows the solid's
    (ω_c U*_c ≈ Ω), so it stays flutter: the shift only adds samples."""
    from fsistab.critical import wake_mode_near
    from fsistab.params import Flow
    from fsistab.steady import save_steady, steady_path

    hint = wake_mode_near(plate_operators, 0.19).frequency
    cache = tmp_path / "cache"
    save_steady(plate_2900, steady_path(plate_coarse_spec, Flow(2900), cache))
    args = [
        "critical", "--body", "plate", "--Re", "2900", "--mesh", "coarse", "--mass-ratio", "1000",
        "--wake-shift", "0+0.19i", "--json", "--out", str(tmp_path / "out"), "--cache", str(cache),
    ]  # fmt: skip
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    points = json.loads(result.stdout)["critical_points"]
    assert [(p["kind"], p["boundary"]) for p in points] == [("flutter", "onset"), ("divergence", "onset")]
    onset = points[0]
    assert abs(onset["frequency"] / hint - 1) < 0.3  # the 30 % rule would have said viv
    assert onset["frequency"] * onset["reduced_velocity"] == pytest.approx(0.8, rel=0.1)


def test_neutral_map_json_and_resume(tmp_path, plate_2900, plate_coarse_spec, plate_operators):
    """``fsistab neutral``: one flutter curve through the m = 1000 threshold, the divergence
    curve, figure and map file; the rerun resumes the saved curves."""
    from fsistab.params import Flow
    from fsistab.steady import save_steady, steady_path

    cache = tmp_path / "cache"
    save_steady(plate_2900, steady_path(plate_coarse_spec, Flow(2900), cache))
    args = [
        "neutral", "--body", "plate", "--Re", "2900", "--mesh", "coarse", "--json",
        "--method", "continuation",
        "--mass-ratio-range", "500", "2000", "--reduced-velocity-range", "4", "5", "--points", "3",
        "--max-points", "2", "--out", str(tmp_path / "out"), "--cache", str(cache),
    ]  # fmt: skip
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    (curve,) = payload["curves"]
    assert curve["kind"] == "flutter" and len(curve["mass_ratio"]) == 3
    assert curve["mass_ratio"] == sorted(curve["mass_ratio"]) and 1000.0 in curve["mass_ratio"]
    assert payload["codimension_two"] == [] and payload["wake_frequency"] is None
    assert payload["divergence"]["moment_slope"] > 0
    # the divergence curve is U*_D = √(m r_θ²/(dC_M/dθ)) with the static slope computed apart
    from fsistab.slopes import static_slopes

    slope = static_slopes(plate_operators).moment
    masses = np.array(payload["divergence"]["mass_ratio"])
    assert masses[0] == pytest.approx(500) and masses[-1] == pytest.approx(2000)
    np.testing.assert_allclose(
        payload["divergence"]["reduced_velocity"], np.sqrt(masses * 0.289**2 / slope), rtol=1e-8
    )
    assert (tmp_path / "out" / "neutral_plate_Re2900_a0.png").stat().st_size > 10_000
    assert (tmp_path / "out" / "neutral_plate_Re2900_a0_map.nc").is_file()
    again = json.loads(runner.invoke(app, args).stdout)
    assert again["curves"][0]["reduced_velocity"] == curve["reduced_velocity"]
    assert again["factorisations"] < payload["factorisations"]


def test_neutral_map_by_transfer_json_and_reuse(tmp_path, plate_2900, plate_coarse_spec):
    """``fsistab neutral --method transfer``: the same flutter onset at m = 1000 as the continuation
    method's Newton (4.39277, docs/transfer.md), the divergence line, the samples and reduced-model
    files; the rerun factorises nothing. With exact samples only at the same tangent tolerance
    (``--reduced-blocks 0 --tolerance 3e-3``; their own default is the coarser 3e-2) the same curves
    from more factorisations."""
    from fsistab.params import Flow
    from fsistab.steady import save_steady, steady_path

    cache = tmp_path / "cache"
    save_steady(plate_2900, steady_path(plate_coarse_spec, Flow(2900), cache))
    args = [
        "neutral", "--body", "plate", "--Re", "2900", "--mesh", "coarse", "--json", "--method", "transfer",
        "--mass-ratio-range", "500", "2000", "--frequency-range", "0.1", "0.3",
        "--out", str(tmp_path / "out"), "--cache", str(cache),
    ]  # fmt: skip
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    assert payload["method"] == "transfer" and 0 < payload["reduced_models"] <= payload["factorisations"]
    flutter = [c for c in payload["curves"] if c["kind"] == "flutter"]
    onsets = [
        u
        for c in flutter
        for m, u in zip(c["mass_ratio"], c["reduced_velocity"], strict=True)
        if 500 <= m <= 2000
    ]
    assert len(onsets) >= 3
    slope = payload["divergence"]["moment_slope"]
    assert 0.289 * (1000 / slope) ** 0.5 == pytest.approx(7.31235, rel=1e-5)
    assert (tmp_path / "out" / "reduced_plate_Re2900_a0_models.nc").is_file()
    assert (tmp_path / "out" / "neutral_plate_Re2900_a0.png").stat().st_size > 10_000
    assert payload["factorisations_total"] == payload["factorisations"]  # nothing reused
    again = json.loads(runner.invoke(app, args).stdout)
    assert again["factorisations"] == 0
    # the total counts every run that built the samples and models the rerun reuses
    assert again["factorisations_total"] == payload["factorisations_total"]
    assert again["curves"] == payload["curves"]
    # `fsistab theodorsen` finds the map the default method stored in the cache (its own --out
    # elsewhere) and compares its lowest flutter boundary with Theodorsen's: the viscous values are
    # the map's own points
    theodorsen = runner.invoke(
        app,
        ["theodorsen", "--mass-ratio-range", "500", "2000", "--points", "3", "--Re", "2900", "--json"]
        + ["--out", str(tmp_path / "theodorsen"), "--cache", str(cache)],
    )
    assert theodorsen.exit_code == 0, theodorsen.output
    comparison = json.loads(theodorsen.stdout)["comparison"]
    assert comparison, "the viscous map was not found"
    map_points = {
        (m, u) for c in flutter for m, u in zip(c["mass_ratio"], c["reduced_velocity"], strict=True)
    }
    assert all((c["mass_ratio"], c["viscous"]) in map_points for c in comparison)
    near = min(comparison, key=lambda c: abs(math.log(c["mass_ratio"] / 1000)))
    # thin airfoil 4.61 against the viscous onset 4.39 near m = 1000 (docs/cli.md): about +5 %
    assert 0.02 < near["relative_error"] < 0.08
    exact_args = [
        *args[:-4],
        "--out",
        str(tmp_path / "exact"),
        "--cache",
        str(cache),
        "--reduced-blocks",
        "0",
        "--tolerance",
        "3e-3",
    ]
    exact = json.loads(runner.invoke(app, exact_args).stdout)
    assert exact["reduced_models"] == 0 and exact["factorisations"] > payload["factorisations"]
    assert (tmp_path / "exact" / "transfer_plate_Re2900_a0_samples.nc").is_file()
    # the same curves (accuracy against Newton: tests/test_reduced_model.py); points at other ω
    assert [c["kind"] for c in exact["curves"]] == [c["kind"] for c in payload["curves"]]

    def points(p):
        pairs = [
            (m, u) for c in p["curves"] for m, u in zip(c["mass_ratio"], c["reduced_velocity"], strict=True)
        ]
        return np.log(pairs)

    reference = points(exact)
    assert max(np.abs(reference - x).sum(axis=1).min() for x in points(payload)) < 0.05


@pytest.mark.parametrize(
    "args, message",
    [
        (["neutral", "--method", "fast"], "--method"),
        (["neutral", "--method", "transfer", "--frequency-range", "1", "0.5"], "--frequency-range"),
        (["neutral", "--reduced-blocks", "2"], "--reduced-blocks"),
        (["neutral", "--reduced-tolerance", "0.5"], "--reduced-tolerance"),
        (["neutral", "--min-step", "0"], "--min-step must be in (0, 0.5)"),
        (["neutral", "--method", "continuation", "--seed-mass-ratio", "1e5"], "seed-mass-ratio"),
        (["neutral", "--wake-frequency", "-1"], "wake-frequency"),
        (["flow-neutral", "--parameter", "mach"], "--parameter"),
        (["flow-neutral", "--parameter", "alpha0", "--range", "1", "5"], "--range"),
        (["flow-neutral", "--reduced-velocity-range", "5", "2"], "reduced-velocity-range"),
    ],
)
def test_map_commands_refuse_bad_input_before_work(tmp_path, args, message):
    result = _run([*args, "--mesh", "coarse"], tmp_path)
    assert result.exit_code != 0 and message in result.output
    assert not (tmp_path / "cache").exists()  # nothing computed or cached


def test_flow_neutral_json(tmp_path, plate_2900, plate_coarse_spec):
    """``fsistab flow-neutral``: the m = 1000 flutter onset continued towards lower Re; the rerun
    reads the saved curves."""
    from fsistab.params import Flow
    from fsistab.steady import save_steady, steady_path

    cache = tmp_path / "cache"
    save_steady(plate_2900, steady_path(plate_coarse_spec, Flow(2900), cache))
    args = [
        "flow-neutral", "--parameter", "reynolds", "--range", "2000", "2900", "--Re", "2900",
        "--mesh", "coarse", "--mass-ratio", "1000", "--reduced-velocity-range", "4", "5",
        "--points", "3", "--max-points", "2", "--json", "--out", str(tmp_path / "out"), "--cache", str(cache),
    ]  # fmt: skip
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    down, up = payload["curves"]
    assert down["direction"] == "decreasing" and len(down["reynolds"]) == 2
    assert down["reynolds"][0] == pytest.approx(2900) and 2000 < down["reynolds"][1] < 2900
    assert up["stop"] == "reynolds_bound"
    assert (tmp_path / "out" / "flow_neutral_plate_Re2900_a0_reynolds_m1000.png").stat().st_size > 10_000
    again = json.loads(runner.invoke(app, args).stdout)
    assert again["curves"][0]["reduced_velocity"] == down["reduced_velocity"]
    assert again["factorisations"] < payload["factorisations"]


def test_progress_lines_when_stderr_is_not_a_terminal(tmp_path):
    """Plain timed progress lines on stderr; stdout holds the JSON object only."""
    result = _run(["theodorsen", "--mass-ratio-range", "1", "100", "--points", "3", "--json"], tmp_path)
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["mass_ratio"] == pytest.approx([1.0, 10.0, 100.0])
    lines = result.stderr.splitlines()
    assert lines and all(line.startswith("[") and " s] " in line for line in lines)
    assert any("Theodorsen neutral curves at 3 mass ratios" in line for line in lines)


def test_interruption_says_what_was_saved_and_how_to_resume(tmp_path, monkeypatch):
    """SIGINT during a workflow: exit 130, one line naming the files written so far and the rerun."""
    from fsistab import store, workflows

    def interrupted(case, cache, progress):
        progress("meshing")
        store.atomic_write_bytes(cache / "partial.nc", b"data")
        raise KeyboardInterrupt

    monkeypatch.setattr(workflows, "mesh_summary", interrupted)
    result = _run(["mesh", "--mesh", "coarse", "--json"], tmp_path)
    assert result.exit_code == 130 and result.stdout == ""
    last = result.stderr.splitlines()[-1]
    assert last.startswith("interrupted after") and str(tmp_path / "cache" / "partial.nc") in last
    assert "rerun the same command to resume" in last


def test_theodorsen_tables(tmp_path):
    """The typical section of docs/model.md §2 with thin-airfoil slopes at m = 1000: U*_F = 4.61 with
    ω_F/ω_θ = 0.83, U*_D = 7.29 (docs/cli.md); the map without a viscous map in the cache says so."""
    result = _run(["theodorsen", "--mass-ratio", "1000"], tmp_path)
    assert result.exit_code == 0, result.output
    flutter = next(line for line in result.stdout.splitlines() if "flutter" in line)
    divergence = next(line for line in result.stdout.splitlines() if "divergence" in line)
    assert "4.607" in flutter and "0.827" in flutter and "7.29" in divergence
    result = _run(["theodorsen", "--mass-ratio-range", "1", "100", "--points", "3"], tmp_path)
    assert result.exit_code == 0, result.output
    assert "Theodorsen neutral curves" in result.stdout
    assert "no stability map of plate_Re2900_a0 in the cache" in " ".join(result.stdout.split())


def test_neutral_table_from_a_map(tmp_path, monkeypatch):
    """The table of `fsistab neutral` (the map computation replaced by a hand-made map): curves,
    the divergence law U*_D = √(r_θ²/(dC_M/dθ)) √m = 0.289/√1.562 √m = 0.2312 √m, crossings."""
    from fsistab import workflows
    from fsistab.neutral_map import (
        CurveCrossing,
        MapCrossing,
        NeutralCurve,
        NeutralMap,
        NeutralPoint,
        neutral_map_dataset,
    )
    from fsistab.params import MapSettings

    points = tuple(
        NeutralPoint(m, u, 0.2, mode=np.zeros(1), iterations=3)
        for m, u in [(500, 3.1), (1000, 4.4), (2000, 6.2)]
    )
    masses = np.geomspace(500, 2000, 5)
    result = NeutralMap(
        (
            NeutralCurve(
                points, kind="flutter", seed_mass_ratio=1000.0, boundary="onset", stops=("m_bound", "m_bound")
            ),
        ),
        masses,
        0.289 * np.sqrt(masses / 1.562),
        1.562,
        (MapCrossing(0, -1, CurveCrossing(1500.0, 5.0, (1, 2), True)),),
        0,
    )
    attrs = {"reynolds": 2900.0, "r_theta": 0.289, "wake_frequency": math.nan, "method": "continuation"}

    def fake_map(case, template, settings, cache, out, progress, client=None):
        ds = workflows._map_details(neutral_map_dataset(result, attrs), result, None, MapSettings())
        ds = ds.assign_attrs(divergence_coefficient=workflows.divergence_coefficient(ds))
        return ds.assign_attrs(factorisations_this_run=0, reduced_models=0, data=str(out / "map.nc"))

    monkeypatch.setattr(workflows, "stability_map", fake_map)
    args = ["neutral", "--mesh", "coarse", "--mass-ratio-range", "500", "2000"]
    args += ["--out", str(tmp_path / "out"), "--cache", str(tmp_path / "cache")]
    run = runner.invoke(app, args, env={"COLUMNS": "250"})  # a wide table: no wrapped cells
    assert run.exit_code == 0, run.output
    text = " ".join(run.stdout.split())
    assert "U*_D = 0.2312 √m" in text
    assert "codimension-two point: flutter 0 × divergence at m = 1500, U* = 5" in text
    assert "no VIV sweep" in text and (tmp_path / "out" / "neutral_plate_Re2900_a0.png").is_file()


def _critical_dataset(out, method, kinds=()):
    import xarray as xr

    n = len(kinds)
    return xr.Dataset(
        {
            "kind": ("threshold", np.array([k for k, _ in kinds], dtype=str)),
            "boundary": ("threshold", np.array([b for _, b in kinds], dtype=str)),
            "reduced_velocity": ("threshold", np.linspace(4.0, 7.0, n)),
            "frequency": ("threshold", np.linspace(0.2, 0.0, n)),
            "frequency_ratio": ("threshold", np.linspace(0.8, 0.0, n)),
        },
        attrs={
            "body": "plate", "reynolds": 2900.0, "mass_ratio": 1000.0, "velocity_range": [2.0, 10.0],
            "points": 24, "method": method, "frequencies_sampled": 37, "branches_tracked": 3,
            "unresolved_intervals": 0, "factorisations": 5, "netcdf": str(out / "critical.nc"),
        },
    )  # fmt: skip


@pytest.mark.parametrize(
    "method, kinds, said, unsaid",
    [
        ("transfer", [("flutter", "onset")], "G(iω) sampled at 37 frequencies (no sweep in U*)", "tracked"),
        ("transfer", [], "no threshold for U* in [2, 10]", "tracked"),
        (
            "tracking",
            [("divergence", "onset")],
            "3 eigenvalue branches tracked over 24 values of U*",
            "G(iω)",
        ),
    ],
)
def test_critical_says_what_the_search_did(tmp_path, monkeypatch, method, kinds, said, unsaid):
    """The transfer method sweeps no U* (its --points are unused): the summary names the
    frequencies sampled, the tracking method its branches and U* values; a search that finds
    nothing says so; the figure is written in --out beside the data, also without a threshold."""
    from fsistab import workflows

    def fake(case, solid, sweep, cache, out, progress, client=None):
        return _critical_dataset(out, method, kinds)

    monkeypatch.setattr(workflows, "critical_points", fake)
    args = ["critical", "--mesh", "coarse", "--method", method]
    args += ["--out", str(tmp_path / "out"), "--cache", str(tmp_path / "cache")]
    run = runner.invoke(app, args, env={"COLUMNS": "200"})
    assert run.exit_code == 0, run.output
    text = " ".join(run.stdout.split())
    assert said in text and unsaid not in text
    assert (tmp_path / "out" / "critical.png").stat().st_size > 5_000


def test_spectrum_verdict_counts_the_unstable_eigenvalues():
    import xarray as xr

    from fsistab.reports import unstable_verdict

    def spectrum(growth):
        n = len(growth)
        return xr.Dataset(
            {
                "growth_rate": ("mode", np.array(growth, dtype=float)),
                "frequency": ("mode", np.linspace(0.7, 0.8, n)),
                "label": ("mode", np.array(["fluid"] * n, dtype=str)),
            }
        )

    assert unstable_verdict(spectrum([-0.01, -0.2])) == "no unstable eigenvalue among the 2 eigenvalues found"
    one = unstable_verdict(spectrum([0.0125, -0.2]))
    assert one == "1 unstable eigenvalue among the 2 eigenvalues found: λ = +0.012500, ω = 0.700000 (fluid)"
    two = unstable_verdict(spectrum([0.01, 0.02, -0.3]))
    assert two.startswith("2 unstable eigenvalues among the 3 eigenvalues found: λ = +0.010000")
    assert unstable_verdict(spectrum([])) == "no unstable eigenvalue among the 0 eigenvalues found"


@pytest.mark.parametrize("option", ["--out", "--cache"])
def test_an_empty_directory_path_is_refused(tmp_path, monkeypatch, option):
    """An empty --out or --cache would be the current folder: one error line, nothing written."""
    monkeypatch.chdir(tmp_path)
    other = "--cache" if option == "--out" else "--out"
    result = runner.invoke(app, ["mesh", "--mesh", "coarse", option, "", other, str(tmp_path / "d")])
    assert result.exit_code == 2 and result.stdout == ""
    assert result.stderr.strip() == f"error: {option} must name a directory, got an empty path"
    assert list(tmp_path.iterdir()) == []


def test_version():
    from fsistab import __version__

    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0 and result.stdout == f"fsistab {__version__}\n"
