"""Mode and branch figures (fsistab.plots): each writes a non-trivial PNG; the solid motion is
checked against its complex amplitudes."""

import numpy as np
import pytest
import xarray as xr

from fsistab.coupled import CoupledSystem
from fsistab.eigen import eigenpairs_near
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators
from fsistab.params import Flow, Plate, Solid
from fsistab.plots import mode_pressure, plot_branches, plot_mode_snapshot, plot_solid_motion, solid_motion
from fsistab.steady import solve_steady


def _is_png(path, min_bytes=10_000):
    data = path.read_bytes()
    return data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > min_bytes


@pytest.fixture(scope="module")
def plate_mode(cache_dir):
    """A heave-pitch mode of the plate at Re = 500 (coarse mesh), m = 3, U* = 2."""
    steady = solve_steady(mesh_spec(Plate(), "coarse", 500), Flow(500), cache_dir=cache_dir)
    system = CoupledSystem(fluid_operators(steady), Solid(mass_ratio=3.0, reduced_velocity=2.0))
    pairs = eigenpairs_near(system, [0.01 + 0.45j], 1)
    return steady, system, pairs[0]


def test_mode_snapshot_writes_png(plate_mode, tmp_path):
    steady, system, pair = plate_mode
    for phase in (0.0, np.pi / 2):
        path = plot_mode_snapshot(
            steady, system.fluid.free_dofs, pair, system, tmp_path / f"m{phase}.png", phase
        )
        assert _is_png(path)


def test_mode_pressure_follows_the_phase(plate_mode):
    steady, system, pair = plate_mode
    index, fluid = system.fluid.free_dofs, pair.vector[system.n_solid :]
    _, p0 = mode_pressure(steady, index, fluid, 0.0)
    _, p1 = mode_pressure(steady, index, fluid, np.pi / 2)
    _, p2 = mode_pressure(steady, index, fluid, np.pi)
    assert np.abs(p0).max() > 0
    np.testing.assert_allclose(p2, -p0, atol=1e-12 * np.abs(p0).max())
    # Re(p̂ i) = -Im(p̂): the quarter-period field is independent of the first
    assert np.linalg.norm(p1 - p0) > 1e-3 * np.linalg.norm(p0)


def test_solid_motion_matches_the_amplitudes(plate_mode, tmp_path):
    _, _, pair = plate_mode
    motion = plot_solid_motion(pair, tmp_path / "motion.png")
    assert _is_png(motion.path)
    h_hat, theta_hat = pair.solid[0], pair.solid[1]
    assert motion.period == pytest.approx(2 * np.pi / pair.value.imag)
    assert motion.time[0] == 0.0 and motion.time[-1] == 1.0
    assert motion.heave[0] == pytest.approx(h_hat.real)
    assert motion.angle_of_attack[0] == pytest.approx(-theta_hat.real)
    # after one period the phase is back, scaled by the growth e^{λT}
    growth = np.exp(pair.value.real * motion.period)
    assert motion.heave[-1] == pytest.approx(h_hat.real * growth)
    assert motion.angle_of_attack[-1] == pytest.approx(-theta_hat.real * growth)
    # a quarter period later h = Re(ĥ i e^{λT/4}) = -Im(ĥ) e^{λT/4}
    t, heave, alpha, _ = solid_motion(pair.value, pair.solid, n=5)
    assert t[1] == pytest.approx(0.25)
    assert heave[1] == pytest.approx(-h_hat.imag * np.exp(pair.value.real * motion.period / 4))


def test_solid_motion_of_a_static_mode():
    t, heave, alpha, period = solid_motion(-0.5 + 0j, np.array([1.0, 0.2, 0, 0], dtype=complex), n=3)
    assert period == pytest.approx(2.0)
    np.testing.assert_allclose(heave, np.exp(-0.5 * 2.0 * t))
    np.testing.assert_allclose(alpha, -0.2 * np.exp(-0.5 * 2.0 * t))


def test_branches_figure(tmp_path):
    u = np.linspace(3, 12, 10)
    ds = xr.Dataset(
        {
            "growth_rate": (("reduced_velocity", "branch"), np.column_stack([0.05 - 0.01 * u, -0.01 * u])),
            "frequency": (("reduced_velocity", "branch"), np.column_stack([0.75 + 0 * u, 2 * np.pi / u])),
        },
        coords={"reduced_velocity": u, "branch": ["fluid", "solid"]},
    )
    path = plot_branches(ds, tmp_path / "branches.png")
    assert _is_png(path)
    scaled = plot_branches(
        ds,
        tmp_path / "scaled.png",
        frequency_scale=2 * np.pi / u,
        scale_label="ω_n",
        reference_lines={"added mass": 2 * np.pi / u * np.sqrt(20 / 21), "fixed": 0.745},
    )
    assert _is_png(scaled)


def test_stability_map_with_regions_turning_points_and_crossings(tmp_path):
    from fsistab.plots import plot_stability_map

    masses = np.geomspace(1, 1e4, 50)
    flutter = ("flutter", [30.0, 100.0, 60.0, 1000.0, 1e4], [1.0, 1.6, 2.0, 4.4, 14.0])
    viv = ("viv", [1.0, 3.0, 5.0, 3.0, 1.0], [0.067, 0.07, 0.073, 0.076, 0.08])
    path = plot_stability_map(
        [flutter, viv],
        (masses, 0.23 * np.sqrt(masses)),
        tmp_path / "map.png",
        turning_points=[(100.0, 1.6), (60.0, 2.0), (5.0, 0.073)],
        crossings=[(10.0, 0.73)],
    )
    assert _is_png(path)
