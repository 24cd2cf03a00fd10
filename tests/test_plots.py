"""Figures (fsistab.plots): what each draws is read back from the Figure objects (line data,
arrows) and compared with the values it was given; the solid motion is checked against its
complex amplitudes."""

import numpy as np
import pytest
import xarray as xr
from matplotlib.quiver import Quiver

from fsistab import plots
from fsistab.coupled import CoupledSystem
from fsistab.eigen import eigenpairs_near
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators
from fsistab.params import Flow, Plate, Solid
from fsistab.plots import mode_pressure, plot_branches, plot_mode_snapshot, plot_solid_motion, solid_motion
from fsistab.steady import solve_steady


def _is_png(path):
    return path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.fixture
def figures(monkeypatch):
    """The Figure objects the plot functions save (still written, so the paths are PNGs)."""
    drawn = []
    save = plots.save_figure

    def keep(fig, path):
        drawn.append(fig)
        return save(fig, path)

    monkeypatch.setattr(plots, "save_figure", keep)
    return drawn


def _lines(ax):
    return [
        (np.asarray(line.get_xdata(), dtype=float), np.asarray(line.get_ydata(), dtype=float))
        for line in ax.lines
    ]


def _has_line(ax, x, y) -> bool:
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    return any(
        lx.shape == x.shape
        and np.allclose(lx, x, rtol=1e-12, equal_nan=True)
        and np.allclose(ly, y, rtol=1e-12, equal_nan=True)
        for lx, ly in _lines(ax)
    )


@pytest.fixture(scope="module")
def plate_mode(cache_dir):
    """A heave-pitch mode of the plate at Re = 500 (coarse mesh), m = 3, U* = 2."""
    steady = solve_steady(mesh_spec(Plate(), "coarse", 500), Flow(500), cache_dir=cache_dir)
    system = CoupledSystem(fluid_operators(steady), Solid(mass_ratio=3.0, reduced_velocity=2.0))
    pairs = eigenpairs_near(system, [0.01 + 0.45j], 1)
    return steady, system, pairs[0]


def test_mode_snapshot_draws_the_motion_of_the_mode(plate_mode, tmp_path, figures):
    """Heave arrow ``h = Re(ĥ e^{iφ})`` at G, pitch arrows ``∓θ/2`` at the edges and the displaced
    chord, scaled so that the largest amplitude is a quarter chord."""
    steady, system, pair = plate_mode
    h_hat, theta_hat = pair.solid[0], pair.solid[1]
    scale = 0.25 / max(abs(h_hat), 0.5 * abs(theta_hat))
    for phase in (0.0, np.pi / 2):
        path = plot_mode_snapshot(
            steady, system.fluid.free_dofs, pair, system, tmp_path / f"m{phase}.png", phase
        )
        assert _is_png(path)
        ax = figures[-1].axes[0]
        h, theta = (h_hat * np.exp(1j * phase)).real, (theta_hat * np.exp(1j * phase)).real
        heave, pitch = [c for c in ax.collections if isinstance(c, Quiver)]
        np.testing.assert_allclose(heave.V, [scale * h], rtol=1e-12)
        np.testing.assert_allclose(pitch.V, [-scale * theta / 2, scale * theta / 2], rtol=1e-12)
        assert _has_line(ax, [-0.5, 0.5], [scale * (h - theta / 2), scale * (h + theta / 2)])


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


def test_solid_motion_matches_the_amplitudes(plate_mode, tmp_path, figures):
    _, _, pair = plate_mode
    motion = plot_solid_motion(pair, tmp_path / "motion.png")
    assert _is_png(motion.path)
    heave_ax, alpha_ax = figures[-1].axes
    assert _has_line(heave_ax, motion.time, motion.heave) and _has_line(
        alpha_ax, motion.time, motion.angle_of_attack
    )
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


def test_branches_figure(tmp_path, figures):
    u = np.linspace(3, 12, 10)
    growth = np.column_stack([0.05 - 0.01 * u, -0.01 * u])
    frequency = np.column_stack([0.75 + 0 * u, 2 * np.pi / u])
    ds = xr.Dataset(
        {
            "growth_rate": (("reduced_velocity", "branch"), growth),
            "frequency": (("reduced_velocity", "branch"), frequency),
        },
        coords={"reduced_velocity": u, "branch": ["fluid", "solid"]},
    )
    assert _is_png(plot_branches(ds, tmp_path / "branches.png"))
    left, right = figures[-1].axes
    for j in range(2):
        assert _has_line(left, u, growth[:, j]) and _has_line(right, u, frequency[:, j])
    unstable = growth[:, 0] > 0  # filled markers: the unstable points only
    assert _has_line(left, u[unstable], growth[unstable, 0])
    scale = 2 * np.pi / u
    added_mass = 2 * np.pi / u * np.sqrt(20 / 21)
    plot_branches(
        ds,
        tmp_path / "scaled.png",
        frequency_scale=scale,
        scale_label="ω_n",
        reference_lines={"added mass": added_mass, "fixed": 0.745},
    )
    left, right = figures[-1].axes
    assert _has_line(left, u, growth[:, 1] / scale) and _has_line(right, u, frequency[:, 0] / scale)
    assert _has_line(right, u, added_mass / scale) and _has_line(right, u, 0.745 / scale)
    assert "ω_n" in left.get_ylabel()


def test_stability_map_draws_the_curves_turning_points_and_crossings(tmp_path, figures):
    from fsistab.plots import plot_stability_map

    masses = np.geomspace(1, 1e4, 50)
    flutter = ("flutter", [30.0, 100.0, 60.0, 1000.0, 1e4], [1.0, 1.6, 2.0, 4.4, 14.0])
    viv = ("viv", [1.0, 3.0, 5.0, 3.0, 1.0], [0.067, 0.07, 0.073, 0.076, 0.08])
    turning = [(100.0, 1.6), (60.0, 2.0), (5.0, 0.073)]
    path = plot_stability_map(
        [flutter, viv],
        (masses, 0.23 * np.sqrt(masses)),
        tmp_path / "map.png",
        turning_points=turning,
        crossings=[(10.0, 0.73)],
    )
    assert _is_png(path)
    ax = figures[-1].axes[0]
    assert _has_line(ax, masses, 0.23 * np.sqrt(masses))
    assert _has_line(ax, flutter[1], flutter[2]) and _has_line(ax, viv[1], viv[2])
    assert _has_line(ax, [m for m, _ in turning], [u for _, u in turning])
    assert _has_line(ax, [10.0], [0.73])
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"


def _map_dataset():
    from fsistab.neutral import neutral_map_dataset

    return neutral_map_dataset(
        _map_result(), {"r_theta": 0.289, "freq_ratio": 0.8, "zeta_h": 0.0, "zeta_theta": 0.05}
    )


def _map_result():
    from fsistab.neutral import (
        CurveCrossing,
        MapCrossing,
        MapCurve,
        NeutralMap,
        NeutralPoint,
        TurningPoint,
    )

    def points(pairs):
        return tuple(NeutralPoint(m, u, 0.2, np.zeros(1), 3) for m, u in pairs)

    curves = (
        MapCurve("flutter", 1000.0, "onset", points([(500, 3.1), (1000, 4.4), (2000, 6.2)]), (), ("a", "b")),
        MapCurve(
            "viv",
            1.0,
            "onset",
            points([(1, 0.07), (3, 0.08)]),
            (TurningPoint(2, 0.075, 11, 0, True),),
            ("c", "d"),
        ),
    )
    masses = np.geomspace(1, 2000, 7)
    return NeutralMap(
        curves,
        masses,
        0.23 * np.sqrt(masses),
        1.56,
        (MapCrossing(0, -1, CurveCrossing(1500, 5.0, (1, 2), True)),),
        0,
    )


def test_map_figure_draws_the_map_dataset(tmp_path, figures):
    ds = _map_dataset()
    assert _is_png(plots.plot_map(ds, tmp_path / "map.png"))
    ax = figures[-1].axes[0]
    assert _has_line(ax, [500, 1000, 2000], [3.1, 4.4, 6.2]) and _has_line(ax, [1, 3], [0.07, 0.08])
    assert _has_line(ax, ds.mass_ratio.values, ds.divergence_reduced_velocity.values)
    assert _has_line(ax, [2.0], [0.075]) and _has_line(ax, [1500.0], [5.0])


def test_flow_neutral_figure_draws_the_half_curves(tmp_path, figures):
    ds = xr.Dataset(
        {
            "curve": ("point", np.array([0, 1, 1, 1])),
            "parameter_value": ("point", np.array([2900.0, 2900.0, 2500.0, 2100.0])),
            "reduced_velocity": ("point", np.array([4.4, 4.4, 4.2, 4.3])),
            "frequency": ("point", np.full(4, 0.2)),
            "fold_curve": ("fold", np.array([1])),
            "fold_parameter_value": ("fold", np.array([2400.0])),
            "fold_reduced_velocity": ("fold", np.array([4.19])),
            "kind": ("curve_index", np.array(["flutter", "flutter"])),
            "direction": ("curve_index", np.array([1, -1])),
            "stop": ("curve_index", np.array(["reynolds_bound", "max_points"])),
        },
        attrs={"parameter": "reynolds"},
    )
    assert _is_png(plots.plot_flow_neutral_curves(ds, tmp_path / "flow.png"))
    ax = figures[-1].axes[0]
    assert _has_line(ax, [2900.0], [4.4]) and _has_line(ax, [2900.0, 2500.0, 2100.0], [4.4, 4.2, 4.3])
    assert _has_line(ax, [2400.0], [4.19]) and ax.get_xscale() == "log"


def test_theodorsen_figure_draws_curves_viscous_map_and_errors(tmp_path, figures):
    from fsistab import workflows
    from fsistab.params import Case, TheodorsenSettings, solid_for
    from fsistab.store import write_dataset

    write_dataset(_map_dataset(), tmp_path / "neutral_plate_Re2900_a0_map.nc")
    settings = TheodorsenSettings(mass_range=(500, 2000), points=3)
    section = workflows.typical_section(solid_for("plate"), settings)
    ds = workflows.theodorsen_comparison(section, settings, Case.create("plate", 2900), tmp_path)
    assert _is_png(plots.plot_theodorsen_comparison(ds, tmp_path / "theodorsen.png"))
    curves, errors = figures[-1].axes
    m = ds.mass_ratio.values
    assert _has_line(curves, m, ds.divergence_velocity.values)
    assert _has_line(curves, m, ds.reduced_velocity.values[:, 0])
    assert _has_line(curves, [500, 1000, 2000], [3.1, 4.4, 6.2])  # the viscous flutter curve
    order = np.argsort(ds.comparison_mass_ratio.values)
    assert _has_line(
        errors, ds.comparison_mass_ratio.values[order], 100 * ds.comparison_relative_error.values[order]
    )
    assert np.isfinite(ds.comparison_relative_error.values).all()


def test_map_figure_legend_names_the_kinds_and_ticks_the_unstable_sides(tmp_path, figures):
    """The legend of the map figure names both families (flutter, viv), the codimension-two points
    (★) and the unstable-side ticks, which go from a curve point towards larger U* where the side
    is +1 and towards smaller U* where it is −1."""
    from fsistab.neutral import NeutralMap, neutral_map_dataset

    ds = _map_dataset()
    result = NeutralMap(
        tuple(
            c.__class__(**{**c.__dict__, "unstable_sides": sides})
            for c, sides in zip(_map_result().curves, [(1, 1, -1), (-1, 1)], strict=True)
        ),
        ds.mass_ratio.values,
        ds.divergence_reduced_velocity.values,
        1.56,
        _map_result().crossings,
        0,
    )
    ds = neutral_map_dataset(result, dict(ds.attrs))
    plots.plot_map(ds, tmp_path / "map.png")
    ax = figures[-1].axes[0]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert {"flutter", "viv", "codimension two", "unstable side", "divergence"} <= set(labels)
    step = plots.SIDE_TICK_LENGTH
    flutter_ticks = (
        [500, 500, np.nan, 1000, 1000, np.nan, 2000, 2000, np.nan],
        [3.1, 3.1 * step, np.nan, 4.4, 4.4 * step, np.nan, 6.2, 6.2 / step, np.nan],
    )
    viv_ticks = ([1, 1, np.nan, 3, 3, np.nan], [0.07, 0.07 / step, np.nan, 0.08, 0.08 * step, np.nan])
    assert _has_line(ax, *flutter_ticks) and _has_line(ax, *viv_ticks)
