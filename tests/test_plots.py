"""Figures (fsistab.plots): what each draws is read back from the Figure objects (line data,
arrows) and compared with the values it was given; the solid motion is checked against its
complex amplitudes."""

import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from matplotlib.quiver import Quiver

from fsistab import plots
from fsistab.bodies import Plate
from fsistab.coupled import CoupledSystem
from fsistab.eigen import eigenpairs_near
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators
from fsistab.params import Flow, Solid
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
        # the body, filled, and its outline displaced by h e_y + θ e_z∧X at the same scale
        outline = plots.sample_mesh(steady.mesh, 2, ((-1.0, 2.0), (-0.75, 0.75))).outline[0]
        body, moved = _patch_vertices(ax, "0.55"), _patch_vertices(ax, "none")
        assert len(body) == len(moved) == 1
        np.testing.assert_allclose(body[0], outline[:-1], atol=1e-12)
        x, y = outline[:, 0], outline[:, 1]
        expected = np.column_stack([x - scale * theta * y, y + scale * (h + theta * x)])
        np.testing.assert_allclose(moved[0], expected[:-1], atol=1e-12)
        labels = [t.get_text() for t in ax.get_legend().get_texts()]
        assert f"displaced body (×{scale:.3g})" in labels


def _patch_vertices(ax, facecolour):
    """Vertices of the polygons of ``ax`` filled with ``facecolour`` ("none": outlines only), in
    data coordinates (closing point dropped)."""
    from matplotlib.colors import to_rgba
    from matplotlib.patches import Polygon

    rgba = to_rgba(facecolour)
    return [
        p.get_xy()[:-1] if np.allclose(p.get_xy()[0], p.get_xy()[-1]) else p.get_xy()
        for p in ax.patches
        if isinstance(p, Polygon) and np.allclose(p.get_facecolor(), rgba)
    ]


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


def test_stability_map_axes_are_the_mass_range_even_where_a_line_runs_beyond_it(tmp_path, figures):
    """A curve's first point beyond the mass range (kept so that its line reaches the edge; at
    Re 2900 the upper flutter branch's is m = 1.4e4, U* = 160 on a map to m = 10⁴) is drawn, but
    the axes stay the map's mass range (the U* range holds the whole line, which crosses the edge
    between its points)."""
    from fsistab.plots import plot_stability_map

    masses = np.geomspace(1, 1e4, 50)
    flutter = ("flutter", [1000.0, 1e4, 1.4e4], [41.6, 132.0, 160.0])
    plot_stability_map([flutter], (masses, 0.23 * np.sqrt(masses)), tmp_path / "map.png")
    ax = figures[-1].axes[0]
    assert _has_line(ax, flutter[1], flutter[2])
    assert ax.get_xlim() == pytest.approx((1.0, 1e4))
    assert ax.get_ylim()[1] == pytest.approx(160.0 * 1.5)


def _map_dataset():
    from fsistab.neutral_map import neutral_map_dataset

    return neutral_map_dataset(
        _map_result(), {"r_theta": 0.289, "freq_ratio": 0.8, "zeta_h": 0.0, "zeta_theta": 0.05}
    )


def _map_result():
    from fsistab.neutral_map import (
        CurveCrossing,
        MapCrossing,
        NeutralCurve,
        NeutralMap,
        NeutralPoint,
        TurningPoint,
    )

    def points(pairs):
        return tuple(NeutralPoint(m, u, 0.2, mode=np.zeros(1), iterations=3) for m, u in pairs)

    curves = (
        NeutralCurve(
            points([(500, 3.1), (1000, 4.4), (2000, 6.2)]),
            kind="flutter",
            seed_mass_ratio=1000.0,
            boundary="onset",
            stops=("a", "b"),
        ),
        NeutralCurve(
            points([(1, 0.07), (3, 0.08)]),
            kind="viv",
            seed_mass_ratio=1.0,
            boundary="onset",
            turning_points=(TurningPoint(2, 0.075, 11, index=0, localised=True),),
            stops=("c", "d"),
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


def test_onset_figure_draws_the_iterates_in_order_and_the_critical_point(tmp_path, figures):
    """``fsistab onset``'s figure: λ and ω of the iterates sorted by α0 (the secant visits them out
    of order), the critical α0 at λ = 0 and ω_c marked."""
    from fsistab.onset import OnsetIterate, OnsetResult, onset_dataset

    rows = [(9.5, -0.0623 + 4.128j), (10.0, 0.0690 + 3.877j), (9.737, -0.0126 + 3.957j)]
    iterates = tuple(OnsetIterate(a, s, 1e-12, s, 1.0, 2.0, 1, True, 100) for a, s in rows)
    ds = onset_dataset(OnsetResult("alpha0", 9.769, 3.947, iterates))
    assert _is_png(plots.plot_onset(ds, tmp_path / "onset.png", title="t"))
    rate, freq = figures[-1].axes[:2]
    assert _has_line(rate, [9.5, 9.737, 10.0], [-0.0623, -0.0126, 0.0690])
    assert _has_line(freq, [9.5, 9.737, 10.0], [4.128, 3.957, 3.877])
    assert _has_line(rate, [9.769], [0.0]) and _has_line(freq, [9.769], [3.947])
    assert rate.get_xscale() == "linear" and "α0" in rate.get_xlabel()


def test_theodorsen_figure_draws_curves_viscous_map_and_errors(tmp_path, figures):
    from fsistab import workflows
    from fsistab.params import Case, TheodorsenSettings, solid_for
    from fsistab.store import write_dataset

    write_dataset(_map_dataset(), workflows.stored_map_path(tmp_path, "plate_Re2900_a0"))
    settings = TheodorsenSettings(mass_range=(500, 2000), points=3)
    section = workflows.typical_section(solid_for("plate"), settings)
    ds = workflows.theodorsen_comparison(section, settings, Case.create("plate", 2900), tmp_path, tmp_path)
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


def test_map_figure_legend_names_the_kinds_and_bands_the_unstable_sides(tmp_path, figures):
    """The legend of the map figure names both families (flutter, viv), the codimension-two points
    (★) and the unstable-side bands, and lies under the axes; a band goes along each segment whose
    two ends have the same unstable side, from the curve towards larger U* (side +1) or smaller U*
    (side −1), and a segment whose ends disagree has none."""
    from matplotlib.collections import PolyCollection

    ds = _sided_map_dataset([(1, 1, -1), (-1, -1)])
    plots.plot_map(ds, tmp_path / "map.png")
    fig = figures[-1]
    ax = fig.axes[0]
    legend = ax.get_legend()
    labels = [t.get_text() for t in legend.get_texts()]
    assert {"flutter", "viv", "codimension two", "unstable side", "divergence"} <= set(labels)
    fig.draw_without_rendering()
    assert legend.get_window_extent().y1 < ax.get_window_extent().y0  # under the axes
    bands = [c for c in ax.collections if isinstance(c, PolyCollection) and c.get_gid() == "side"]
    quads = sorted((p.vertices[:4] for band in bands for p in band.get_paths()), key=lambda q: q[0, 0])
    step = plots.SIDE_BAND
    expected = [
        [(1, 0.07), (3, 0.08), (3, 0.08 / step), (1, 0.07 / step)],  # viv, side -1: below
        [(500, 3.1), (1000, 4.4), (1000, 4.4 * step), (500, 3.1 * step)],  # flutter 1st segment: above
    ]  # the flutter segment (1000, 2000) changes side: no band
    assert len(quads) == 2
    for quad, want in zip(quads, expected, strict=True):
        np.testing.assert_allclose(quad, want, rtol=1e-12)


def _sided_map_dataset(sides, unresolved=()):
    from fsistab.neutral_map import NeutralMap, neutral_map_dataset

    ds = _map_dataset()
    result = NeutralMap(
        tuple(
            c.__class__(**{**c.__dict__, "unstable_sides": side})
            for c, side in zip(_map_result().curves, sides, strict=True)
        ),
        ds.mass_ratio.values,
        ds.divergence_reduced_velocity.values,
        1.56,
        _map_result().crossings,
        0,
        tuple(unresolved),
    )
    return neutral_map_dataset(result, dict(ds.attrs))


def test_map_figure_lists_the_unresolved_intervals_and_shades_the_counts(tmp_path, figures):
    """At any α0 a transfer map may leave frequency intervals unresolved: they are listed (the
    first UNRESOLVED_LISTED, the others counted) under the legend; the unstable counts are shaded
    with one legend entry per level."""
    unresolved = [(0.1 * k, 0.1 * k + 0.05, f"reason {k}") for k in range(1, 7)]
    ds = _sided_map_dataset([(1, 1, 1), (1, 1)], unresolved)
    m, u = np.geomspace(1, 2000, 20), np.geomspace(0.05, 10, 30)
    counts = (u[:, None] > 0.23 * np.sqrt(m)[None, :]).astype(int) + (u[:, None] > 5.0)
    ds = ds.assign_coords(grid_mass_ratio=m, grid_reduced_velocity=u).assign(
        unstable_count=(("grid_reduced_velocity", "grid_mass_ratio"), counts)
    )
    plots.plot_map(ds, tmp_path / "map.png")
    fig = figures[-1]
    (note,) = [t.get_text() for t in fig.texts]
    listed = unresolved[: plots.UNRESOLVED_LISTED]
    assert note.startswith(f"{len(unresolved)} unresolved frequency intervals")
    for low, high, reason in listed:
        assert f"ω ∈ [{low:.4g}, {high:.4g}]: {reason}" in note
    assert "reason 6" not in note and f"and {len(unresolved) - len(listed)} more in 2 places" in note
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert {"1 unstable mode", "2 unstable modes", "≥ 3 unstable modes"} <= set(labels)
    assert "static divergence" not in labels  # the counts include it


def test_study_thresholds_mark_onsets_filled_and_restabilisations_open(tmp_path, figures):
    """The stored Re study on the previous default mesh (docs/data) has onsets and restabilisations: each
    is drawn at its (Re, U*) with a filled or an open marker, and the log axis reads in numbers."""
    import xarray as xr

    data = xr.load_dataset(Path(__file__).parents[1] / "docs" / "data" / "reynolds_study_medium.nc")
    plots.plot_study_thresholds(data, tmp_path / "t.png")
    ax = figures[-1].axes[-1]
    drawn = {"filled": set(), "open": set()}
    for collection in ax.collections:
        faces = collection.get_facecolors()
        for x, y in collection.get_offsets():
            drawn["open" if len(faces) == 0 else "filled"].add((round(float(x)), round(float(y), 4)))
    boundary = data.threshold_boundary.values
    for name, kind in (("filled", "onset"), ("open", "restabilisation")):
        velocity = data.threshold_reduced_velocity.values
        expected = {
            (round(float(data.reynolds[i])), round(float(velocity[i, j, k, n]), 4))
            for i, j, k, n in np.argwhere(boundary == kind)
        }
        assert expected and expected == drawn[name]
    assert "open: restabilisation" in [t.get_text() for t in ax.get_legend().get_texts()]
    assert ax.yaxis.get_major_formatter().__class__.__name__ == "LogFormatter"


def test_study_without_thresholds_says_so_instead_of_failing(tmp_path, figures):
    """A study whose U* range holds no threshold (every critical U* NaN) draws its panel with a
    note: a log axis cannot be drawn without one positive value."""
    import xarray as xr

    data = xr.load_dataset(Path(__file__).parents[1] / "docs" / "data" / "reynolds_study_medium.nc")
    data["threshold_reduced_velocity"] = data.threshold_reduced_velocity * np.nan
    plots.plot_study_thresholds(data, tmp_path / "t.png")
    ax = figures[-1].axes[-1]
    assert (tmp_path / "t.png").is_file() and ax.get_yscale() == "linear"
    assert [t.get_text() for t in ax.texts] == [plots.NO_THRESHOLD]


def test_adjacent_unresolved_intervals_are_one_place():
    """A refinement stalled near one frequency leaves hundreds of adjacent intervals: one line for
    them (with their count), apart from an interval elsewhere and from another reason's."""
    edges = 0.016293 + 1e-7 * np.arange(501)
    stalled = [(lo, hi, "sweep") for lo, hi in zip(edges[:-1], edges[1:], strict=True)]
    stalled = stalled[::2] + stalled[1::2]  # in any order
    other = [(0.5, 0.6, "sweep"), (0.01630, 0.01631, "tangency")]
    clusters = plots.unresolved_clusters(stalled + other)
    assert [(c[2], c[3]) for c in clusters] == [("sweep", 500), ("tangency", 1), ("sweep", 1)]
    assert clusters[0][:2] == pytest.approx((edges[0], edges[-1]))
    note = plots._unresolved_note(stalled + other)
    assert note.startswith("502 unresolved frequency intervals")
    assert "ω ∈ [0.01629, 0.01634] (500 intervals): sweep" in note
    assert len(note.splitlines()) == 4  # the header and three places
    assert plots._unresolved_note([(1.7, 1.7001, "fold")]).startswith(
        "1 unresolved frequency interval (curves drawn through their folds):"
    )
    assert "(curves may be missing there):" in plots._unresolved_note([(1.7, 1.7001, "fold"), *other])
    # apart by more than the gap (1 %): two places
    assert len(plots.unresolved_clusters([(1.0, 1.1, "sweep"), (1.12, 1.2, "sweep")])) == 2


# --- fields on subdivided triangles, the body, the zero line ----------------------------------------


@pytest.mark.parametrize("n", [1, 2, 3, 5])
def test_subdivision_tiles_the_triangle(n):
    counts, triangles = plots.subdivision(n)
    assert len(counts) == (n + 1) * (n + 2) // 2 and len(triangles) == n * n
    assert (counts.sum(axis=1) == n).all() and (counts >= 0).all()
    assert len({tuple(c) for c in counts.tolist()}) == len(counts)
    xi, eta = counts[:, 0] / n, counts[:, 1] / n
    a, b, c = (np.column_stack([xi, eta])[triangles[:, k]] for k in range(3))
    signed = 0.5 * ((b - a)[:, 0] * (c - a)[:, 1] - (c - a)[:, 0] * (b - a)[:, 1])
    # n² triangles of one orientation and equal area tile the reference triangle (area 1/2)
    np.testing.assert_allclose(signed, 0.5 / n**2, rtol=1e-12)


@pytest.fixture(scope="module")
def square_mesh():
    from netgen.geom2d import unit_square
    from ngsolve import Mesh

    return Mesh(unit_square.GenerateMesh(maxh=0.3))


@pytest.mark.parametrize("n", [2, 4])
def test_sampled_p2_field_is_exact_at_the_new_nodes(square_mesh, n):
    """A P2 field (exactly representable: its interpolant is itself) is reproduced at every node of
    the subdivision, edge midpoints and interior points included, to round-off; the nodes are those
    of a continuous Pn Lagrange space (shared between neighbours: NGSolve's H1 order-n dof count)
    and the sub-triangles cover the square."""
    from ngsolve import H1, GridFunction, x, y

    space = H1(square_mesh, order=2)
    field = GridFunction(space)
    field.Set(1 + x - 2 * y + 3 * x * x - 4 * x * y + 0.5 * y * y)
    sampled = plots.sample_mesh(square_mesh, n)
    tri = sampled.triangulation
    exact = 1 + tri.x - 2 * tri.y + 3 * tri.x**2 - 4 * tri.x * tri.y + 0.5 * tri.y**2
    np.testing.assert_allclose(sampled.values(field), exact, atol=1e-12)
    assert len(tri.x) == H1(square_mesh, order=n).ndof
    assert len(tri.triangles) == n * n * square_mesh.ne
    corners = np.stack([tri.x[tri.triangles], tri.y[tri.triangles]], axis=2)
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    area = 0.5 * np.abs((b - a)[:, 0] * (c - a)[:, 1] - (c - a)[:, 0] * (b - a)[:, 1])
    assert area.sum() == pytest.approx(1.0, rel=1e-12)
    assert not sampled.on_wall.any() and sampled.outline == ()  # no wall on the unit square


def _plate_distance(points, plate=None):
    """Signed distance to the plate (a rounded rectangle of chord 1, thickness 1/20, corner
    radius 0.1 × thickness), negative inside."""
    e = 1.0 / 20.0
    r = 0.1 * e
    q = np.abs(np.asarray(points, dtype=float)) - np.array([0.5 - r, e / 2 - r])
    return np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0) - r


def test_body_outline_is_the_closed_curved_wall(plate_mode):
    """The outline of the plate is one closed counter-clockwise polygon through every wall node of
    the subdivision, on the exact (curved) wall, enclosing the plate's area ``e − (4 − π) r²``; the
    straight-cornered rectangle would differ by 4e-4."""
    steady = plate_mode[0]
    sampled = plots.sample_mesh(steady.mesh, 4, ((-1.0, 2.0), (-0.5, 0.5)))
    (outline,) = sampled.outline
    np.testing.assert_array_equal(outline[0], outline[-1])
    assert len(outline) - 1 == sampled.on_wall.sum()
    assert len(np.unique(outline[:-1].round(12), axis=0)) == len(outline) - 1
    x, y = outline[:, 0], outline[:, 1]
    assert 0.5 * np.sum(x[:-1] * y[1:] - x[1:] * y[:-1]) > 0  # counter-clockwise
    assert np.abs(_plate_distance(outline)).max() < 1e-5  # the mesh file rounds coordinates to ~1e-6
    e, r = 1 / 20, 0.1 / 20
    assert plots.polygon_area(outline) == pytest.approx(e - (4 - np.pi) * r * r, rel=2e-5)


def test_steady_figure_zero_line_stays_off_the_wall(plate_mode, tmp_path, figures):
    """The zero streamwise-velocity line is drawn in the flow (the recirculation behind the blunt
    trailing edge at Re = 500) but nowhere along the wall, where the no-slip velocity vanishes and
    an unmasked zero contour follows it; the body is drawn filled from the curved wall."""
    from matplotlib.contour import QuadContourSet
    from matplotlib.tri import TriContourSet

    steady = plate_mode[0]
    path = plots.plot_streamwise_velocity(steady, tmp_path / "steady.png")
    assert _is_png(path)
    ax = figures[-1].axes[0]
    line_sets = [c for c in ax.collections if isinstance(c, TriContourSet) and not c.filled]
    assert not any(isinstance(c, QuadContourSet) for c in ax.collections)
    (zero,) = line_sets
    drawn = np.concatenate([p.vertices for p in zero.get_paths()])
    assert len(drawn) > 0 and np.abs(drawn[:, 1]).max() < 0.1 and drawn[:, 0].min() > 0.4
    assert _plate_distance(drawn).min() > 1e-4
    # the same contour without the mask runs along the wall
    sampled = plots.sample_mesh(steady.mesh, 4, ((-1.0, 3.0), (-0.8, 0.8)))
    from fsistab.forces import streamwise_direction
    from fsistab.steady import wall_velocity

    d = streamwise_direction(steady.flow.theta0)
    relative = (sampled.values(steady.velocity) - np.array(wall_velocity(steady.flow.theta0))) @ d
    np.testing.assert_allclose(relative[sampled.on_wall], 0.0, atol=1e-12)
    (body,) = _patch_vertices(ax, "0.55")
    np.testing.assert_allclose(body, sampled.outline[0][:-1], atol=1e-12)


def test_displaced_outline_is_the_rigid_displacement():
    """``X + h e_y + θ e_z∧X``: the edges ``(∓1/2, 0)`` move by ``h ∓ θ/2`` along Y (the pitch
    arrows), a point above G moves back by ``θ Y``."""
    outline = np.array([[-0.5, 0.0], [0.5, 0.0], [0.0, 0.025], [-0.5, 0.0]])
    moved = plots.displaced_outline(outline, 0.1, 0.2)
    np.testing.assert_allclose(moved[:2], [[-0.5, 0.1 - 0.1], [0.5, 0.1 + 0.1]], atol=1e-15)
    np.testing.assert_allclose(moved[2], [-0.2 * 0.025, 0.125], atol=1e-15)
    assert plots.mode_display_scale("plate", np.array([0.1, -1.0])) == pytest.approx(0.5)
    assert plots.mode_display_scale("cylinder", np.array([0.1, -1.0])) == pytest.approx(2.5)
    assert plots.mode_display_scale("plate", np.zeros(2)) == 0.0


# --- style and output format -----------------------------------------------------------------------


def test_style_is_applied_inside_and_restored_after(tmp_path, figures):
    """Whatever the caller's rcParams, a figure gets the sizes of FIGURE_STYLE, and the caller's
    rcParams are intact afterwards, also when the body of the context raises."""
    import matplotlib as mpl

    u = np.linspace(3, 12, 4)
    ds = xr.Dataset(
        {
            "growth_rate": (("reduced_velocity", "branch"), -np.ones((4, 1))),
            "frequency": (("reduced_velocity", "branch"), np.ones((4, 1))),
        },
        coords={"reduced_velocity": u, "branch": ["a"]},
    )
    with mpl.rc_context({"font.size": 17.0, "axes.labelsize": 23.0, "axes.titlesize": 21.0}):
        before = dict(mpl.rcParams)
        plot_branches(ds, tmp_path / "b.png")
        ax = figures[-1].axes[0]
        assert ax.xaxis.label.get_fontsize() == plots.FIGURE_STYLE["axes.labelsize"] != 23.0
        assert ax.title.get_fontsize() == plots.FIGURE_STYLE["axes.titlesize"] != 21.0
        assert dict(mpl.rcParams) == before
        with pytest.raises(RuntimeError), plots.figure_style({"font.size": 6.0}):
            assert mpl.rcParams["font.size"] == 6.0
            assert mpl.rcParams["axes.labelsize"] == plots.FIGURE_STYLE["axes.labelsize"]
            raise RuntimeError
        assert dict(mpl.rcParams) == before


def _save_empty(path):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1], label="line")
    ax.set_title("α0 = 2.5°")
    return plots.save_figure(fig, path)


def test_vector_formats_are_written_atomically_and_valid(tmp_path):
    import xml.etree.ElementTree as ET

    with plots.figure_format("pdf"):
        pdf = _save_empty(tmp_path / "steady_a2.5.png")
        bare = _save_empty(tmp_path / "steady_a2.5")
    with plots.figure_format("svg"):
        svg = _save_empty(tmp_path / "map.png")
    png = _save_empty(tmp_path / "after.png")  # the format does not outlive its context
    assert pdf == tmp_path / "steady_a2.5.pdf" and bare == tmp_path / "steady_a2.5.pdf"
    assert svg == tmp_path / "map.svg" and png == tmp_path / "after.png"
    data = pdf.read_bytes()
    assert data.startswith(b"%PDF-") and data.rstrip().endswith(b"%%EOF")
    assert ET.parse(svg).getroot().tag == "{http://www.w3.org/2000/svg}svg"
    assert _is_png(png)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["after.png", "map.svg", "steady_a2.5.pdf"]
    # the same figure twice gives the same bytes (no dates written)
    with plots.figure_format("svg"):
        again = _save_empty(tmp_path / "again.png")
    assert again.read_bytes() == svg.read_bytes()


def test_unknown_format_is_refused():
    from fsistab.errors import InputError

    with pytest.raises(InputError, match="--format must be one of png, pdf, svg"):
        with plots.figure_format("jpeg"):
            pass


def test_cli_format_option_writes_vector_figures(tmp_path, cache_dir):
    from typer.testing import CliRunner

    from fsistab.cli import app

    runner = CliRunner()
    args = ["mesh", "--mesh", "coarse", "--Re", "500", "--cache", str(cache_dir), "--json"]
    result = runner.invoke(app, [*args, "--out", str(tmp_path), "--format", "pdf"])
    assert result.exit_code == 0, result.output
    figure = Path(json.loads(result.stdout)["figure"])
    assert figure.suffix == ".pdf" and figure.read_bytes().startswith(b"%PDF-")
    bad = runner.invoke(app, [*args, "--out", str(tmp_path / "bad"), "--format", "jpg"])
    assert bad.exit_code == 2 and "--format must be one of png, pdf, svg" in bad.output
