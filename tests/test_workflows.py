"""Workflows (fsistab.workflows) on small hand-made inputs: the Theodorsen comparison finds the map
dataset that ``fsistab neutral`` stores in the cache with either method, the JSON payloads carry the map's
values, and the flow-plane half-curves are stacked and read back unchanged. The workflows on real
steady states run in tests/test_cli.py."""

import math

import numpy as np
import pytest
import xarray as xr

from fsistab import workflows
from fsistab.flow_neutral import flow_curves, stack_flow_curves
from fsistab.neutral_map import (
    CurveCrossing,
    MapCrossing,
    NeutralCurve,
    NeutralMap,
    NeutralPoint,
    TurningPoint,
    neutral_map_dataset,
)
from fsistab.params import Case, FlowNeutralSettings, MapSettings, TheodorsenSettings, solid_for
from fsistab.payloads import payload as make_payload
from fsistab.store import write_dataset
from fsistab.theodorsen import viscous_curves

FLUTTER = [(500.0, 3.1), (1000.0, 4.4), (2000.0, 6.2)]  # the lowest flutter curve
UPPER = [(1000.0, 9.0), (2000.0, 12.0)]  # a second flutter curve, above the first
VIV = [(400.0, 0.5), (600.0, 0.5), (800.0, 0.5)]  # lower than both: must not enter the envelope


def _points(pairs, frequency=0.2):
    return tuple(NeutralPoint(m, u, frequency, mode=np.zeros(1), iterations=3) for m, u in pairs)


def _map(r_theta=0.289, moment_slope=1.562):
    curves = (
        NeutralCurve(
            _points(FLUTTER),
            kind="flutter",
            seed_mass_ratio=1000.0,
            boundary="onset",
            turning_points=(TurningPoint(900.0, 4.0, 0.21, index=0, localised=True),),
            stops=("a", "b"),
        ),
        NeutralCurve(
            _points(UPPER), kind="flutter", seed_mass_ratio=math.nan, boundary="onset", stops=("c", "d")
        ),
        NeutralCurve(_points(VIV, 11.0), kind="viv", seed_mass_ratio=1.0, boundary="onset", stops=("e", "f")),
    )
    masses = np.geomspace(500, 2000, 5)
    divergence = np.sqrt(masses * r_theta**2 / moment_slope)
    crossing = MapCrossing(0, -1, CurveCrossing(1500.0, 5.0, (1, 2), True))
    return NeutralMap(curves, masses, divergence, moment_slope, (crossing,), 7)


def _map_dataset(r_theta=0.289, method="transfer"):
    result = _map(r_theta)
    attrs = {
        "reynolds": 2900.0,
        "alpha0_deg": 0.0,
        "mesh_key": "k",
        "freq_ratio": 0.8,
        "zeta_h": 0.0,
        "zeta_theta": 0.05,
        "r_theta": r_theta,
        "wake_frequency": math.nan,
        "method": method,
    }
    ds = workflows._map_details(neutral_map_dataset(result, attrs), result, None, MapSettings())
    return ds.assign_attrs(factorisations_this_run=7, reduced_models=0, data="map.nc", figure="map.png")


@pytest.mark.parametrize("method", ["transfer", "continuation"])
def test_theodorsen_comparison_reads_the_map_of_either_method(tmp_path, method):
    write_dataset(_map_dataset(method=method), workflows.stored_map_path(tmp_path, "plate_Re2900_a0"))
    settings = TheodorsenSettings(mass_range=(500, 2000), points=3)
    section = workflows.typical_section(solid_for("plate"), settings)
    ds = workflows.theodorsen_comparison(section, settings, Case.create("plate", 2900), tmp_path, tmp_path)
    # the lower envelope of the flutter curves only (the VIV curve is lower but not flutter)
    np.testing.assert_array_equal(ds.comparison_mass_ratio.values, [m for m, _ in FLUTTER])
    np.testing.assert_array_equal(ds.comparison_viscous.values, [u for _, u in FLUTTER])
    # thin airfoil at m = 1000: U*_F = 4.61 (docs/cli.md, Theodorsen typical section)
    assert ds.comparison_theodorsen.values[1] == pytest.approx(4.61, abs=5e-3)
    error = ds.comparison_relative_error.values[1]
    assert error == pytest.approx((ds.comparison_theodorsen.values[1] - 4.4) / 4.4, rel=1e-12)
    assert error == pytest.approx((4.61 - 4.4) / 4.4, abs=2e-3)
    viscous = viscous_curves(ds)
    assert len(viscous["flutter"]) == 2
    np.testing.assert_allclose(viscous["divergence"][1], 0.289 * np.sqrt(np.geomspace(500, 2000, 5) / 1.562))
    payload = make_payload("theodorsen-map", ds.assign_attrs(figure="f.png"))
    assert [c["viscous"] for c in payload["comparison"]] == [u for _, u in FLUTTER]
    assert (tmp_path / "theodorsen_plate_Re2900_a0_thin-airfoil.nc").is_file()


def test_theodorsen_comparison_refuses_a_map_of_other_solid_parameters(tmp_path):
    write_dataset(_map_dataset(r_theta=0.3), workflows.stored_map_path(tmp_path, "plate_Re2900_a0"))
    settings = TheodorsenSettings(mass_range=(500, 2000), points=2)
    section = workflows.typical_section(solid_for("plate"), settings)
    ds = workflows.theodorsen_comparison(section, settings, Case.create("plate", 2900), tmp_path, tmp_path)
    assert "other solid parameters" in ds.attrs["viscous_comparison"]
    assert "comparison_mass_ratio" not in ds and viscous_curves(ds) is None
    # no map for another Re
    ds = workflows.theodorsen_comparison(section, settings, Case.create("plate", 1000), tmp_path, tmp_path)
    assert ds.attrs["viscous_comparison"].startswith("no stability map of plate_Re1000_a0 in the cache")


def test_theodorsen_comparison_of_a_typical_section_reads_its_own_map(tmp_path):
    """A section with an elastic axis and a static unbalance (docs/model.md §3.1) is compared with the
    map of the same section (its mesh about the axis: tag ``_ea-0.25``), never with another's."""
    typical = _map_dataset().assign_attrs(elastic_axis=-0.25, static_unbalance=0.1)
    write_dataset(typical, workflows.stored_map_path(tmp_path, "plate_Re2900_a0_ea-0.25"))
    write_dataset(_map_dataset(), workflows.stored_map_path(tmp_path, "plate_Re2900_a0"))
    settings = TheodorsenSettings(mass_range=(500, 2000), points=3, elastic_axis=-0.25, static_unbalance=0.1)
    section = workflows.typical_section(solid_for("plate"), settings)
    ds = workflows.theodorsen_comparison(section, settings, Case.create("plate", 2900), tmp_path, tmp_path)
    np.testing.assert_array_equal(ds.comparison_viscous.values, [u for _, u in FLUTTER])
    other = TheodorsenSettings(mass_range=(500, 2000), points=3, elastic_axis=-0.25)
    section = workflows.typical_section(solid_for("plate"), other)
    ds = workflows.theodorsen_comparison(section, other, Case.create("plate", 2900), tmp_path, tmp_path)
    assert "other solid parameters" in ds.attrs["viscous_comparison"]


def test_neutral_payload_carries_the_map(tmp_path):
    ds = _map_dataset()
    payload = make_payload("neutral", ds)
    first, upper, viv = payload["curves"]
    assert [first["kind"], upper["kind"], viv["kind"]] == ["flutter", "flutter", "viv"]
    assert list(zip(first["mass_ratio"], first["reduced_velocity"], strict=True)) == FLUTTER
    assert first["frequency"] == [0.2, 0.2, 0.2] and viv["frequency"] == [11.0] * 3
    assert first["turning_points"] == [{"mass_ratio": 900.0, "reduced_velocity": 4.0, "frequency": 0.21}]
    assert first["stops"] == ["a", "b"] and viv["stops"] == ["e", "f"]
    assert first["seed_mass_ratio"] == 1000.0 and upper["seed_mass_ratio"] is None
    assert payload["codimension_two"] == [
        {
            "curves": ["flutter 0", "divergence"],
            "kinds": ["flutter", "divergence"],
            "mass_ratio": 1500.0,
            "reduced_velocity": 5.0,
            "frequencies": [None, None],
        }
    ]
    assert payload["wake_frequency"] is None and payload["factorisations"] == 7
    masses = np.geomspace(500, 2000, 5)
    np.testing.assert_allclose(payload["divergence"]["reduced_velocity"], np.sqrt(masses * 0.289**2 / 1.562))
    # U*_D/√m = √(r_θ²/(dC_M/dθ)), by hand; none without a restoring slope
    assert workflows.divergence_coefficient(ds) == pytest.approx(0.289 / math.sqrt(1.562), rel=1e-14)
    assert math.isinf(workflows.divergence_coefficient(ds.assign_attrs(moment_slope=-0.1)))


def test_flow_curves_stack_the_halves_and_read_back():
    def half(kind, direction, values, velocities, folds=(), stop="max_points"):
        return xr.Dataset(
            {
                "alpha0_deg": ("point", np.array(values, dtype=float)),
                "reynolds": ("point", np.full(len(values), 2900.0)),
                "reduced_velocity": ("point", np.array(velocities, dtype=float)),
                "frequency": ("point", np.full(len(values), 0.3)),
                "fold_alpha0_deg": ("fold", np.array([f[0] for f in folds], dtype=float)),
                "fold_reduced_velocity": ("fold", np.array([f[1] for f in folds], dtype=float)),
            },
            attrs={"kind": kind, "direction": direction, "stop": stop},
        )

    halves = [
        half("flutter", -1, [0.0], [4.4]),
        half("flutter", 1, [0.0, 1.0, 2.0], [4.4, 4.6, 4.5], [(1.8, 4.6)]),
    ]
    settings = FlowNeutralSettings("alpha0", (0.0, 5.0), 0.0)
    ds = stack_flow_curves(halves, settings.parameter, {"mass_ratio": 1000.0, "factorisations": 3})
    down, up = flow_curves(ds)
    assert down[:2] == ("flutter", -1) and up[:2] == ("flutter", 1)
    np.testing.assert_array_equal(up[2], [0.0, 1.0, 2.0])
    np.testing.assert_array_equal(up[3], [4.4, 4.6, 4.5])
    np.testing.assert_array_equal(up[5], [1.8])
    assert down[5].size == 0
    payload = make_payload("flow-neutral", ds.assign_attrs(figure="f.png"))
    assert [c["direction"] for c in payload["curves"]] == ["decreasing", "increasing"]
    assert payload["curves"][1]["alpha0"] == [0.0, 1.0, 2.0]
    assert payload["curves"][1]["turning_points"] == [{"alpha0": 1.8, "reduced_velocity": 4.6}]


def test_map_shading_reaches_the_divergence_line():
    """The shading grid spans the divergence line as well as the curves: at Re 500 the lowest
    curve point is U* = 0.856 while divergence reaches U* = 0.257 at m = 1 (docs/stability_map.md);
    infinite values (no divergence) are left out."""
    grid = workflows.shading_velocities([0.856, 80.0], [0.2573, 25.7, np.inf])
    assert grid[0] == pytest.approx(0.2573 / 1.5) and grid[-1] == pytest.approx(80.0 * 1.5)
    assert np.all(np.diff(grid) > 0) and len(grid) == 150
    assert workflows.shading_velocities([2.0], [np.inf])[0] == pytest.approx(1.0 / 1.5)
