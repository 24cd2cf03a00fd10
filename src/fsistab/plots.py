"""Figures: one function per figure, each taking computed objects and a path (matplotlib, Agg)."""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.tri as mtri  # noqa: E402
import numpy as np  # noqa: E402


def _triangulation(mesh) -> mtri.Triangulation:
    coords = mesh.ngmesh.Coordinates()
    nodes = mesh.ngmesh.Elements2D().NumPy()["nodes"][:, :3].astype(np.int64) - 1
    return mtri.Triangulation(coords[:, 0], coords[:, 1], nodes)


def save_figure(fig, path: Path) -> Path:
    """Write ``fig`` to ``path`` (PNG, 150 dpi) atomically (:func:`fsistab.store.atomic_path`: an
    interrupted or failed write leaves neither file nor temporary) and close it."""
    from fsistab.store import atomic_path

    path = Path(path)
    try:
        with atomic_path(path, path.suffix) as tmp:  # the suffix last: matplotlib picks the format by it
            fig.savefig(tmp, dpi=150, bbox_inches="tight")
    finally:
        plt.close(fig)
    return path


def plot_mesh(mesh, path: Path, title: str = "") -> Path:
    """The whole mesh and a close-up of the body."""
    tri = _triangulation(mesh)
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.5))
    for ax, (xlim, ylim) in zip(axes, [(None, None), ((-0.8, 1.6), (-0.6, 0.6))], strict=True):
        ax.triplot(tri, lw=0.2, color="k")
        ax.set_aspect("equal")
        if xlim:
            ax.set_xlim(*xlim)
            ax.set_ylim(*ylim)
        ax.set_xlabel("X")
        ax.set_ylabel("Y")
    axes[0].set_title(title or f"{mesh.ne} triangles")
    axes[1].set_title("close-up")
    return save_figure(fig, path)


def plot_streamwise_velocity(steady, path: Path, window=None) -> Path:
    """Relative streamwise velocity ``(U - W⁰)·d`` near the body, recirculation outlined (= 0)."""
    from fsistab.forces import streamwise_direction
    from fsistab.steady import wall_velocity

    mesh = steady.mesh
    tri = _triangulation(mesh)
    values = np.asarray(steady.velocity(mesh(tri.x, tri.y)))
    d = streamwise_direction(steady.flow.theta0)
    relative = (values - np.array(wall_velocity(steady.flow.theta0))) @ d
    if window is None:
        window = ((-1.0, 3.0), (-0.8, 0.8)) if steady.mesh_spec.body.kind == "plate" else ((-2, 6), (-2, 2))
    fig, ax = plt.subplots(figsize=(10, 4))
    levels = np.linspace(min(relative.min(), -0.2), max(relative.max(), 1.2), 41)
    cs = ax.tricontourf(tri, relative, levels=levels, cmap="RdBu_r")
    ax.tricontour(tri, relative, levels=[0.0], colors="k", linewidths=1.2)
    fig.colorbar(cs, ax=ax, label="streamwise velocity (body frame)")
    ax.set_xlim(*window[0])
    ax.set_ylim(*window[1])
    ax.set_aspect("equal")
    ax.set_xlabel("X")
    ax.set_ylabel("Y")
    ax.set_title(
        f"{steady.mesh_spec.body.kind}, Re = {steady.flow.reynolds:g}, "
        f"alpha0 = {steady.flow.alpha0_deg:g} deg (black: zero streamwise velocity)"
    )
    return save_figure(fig, path)


_LABEL_COLOURS = {"fluid": "tab:blue", "heave": "tab:red", "pitch": "tab:green", "coupled": "tab:purple"}


def plot_spectrum(ds, path: Path, title: str = "") -> Path:
    """Eigenvalues in the (growth rate, frequency) plane, and a close-up near the neutral axis."""
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    growth, frequency, labels = ds["growth_rate"].values, ds["frequency"].values, ds["label"].values
    for ax in axes:
        for label, colour in _LABEL_COLOURS.items():
            sel = labels == label
            if sel.any():
                ax.plot(growth[sel], frequency[sel], "o", color=colour, label=label, ms=6)
        ax.axvline(0, color="k", lw=0.8)
        ax.set_xlabel("growth rate λ")
        ax.set_ylabel("frequency ω")
        ax.grid(alpha=0.3)
    axes[0].legend()
    axes[0].set_title(title or "spectrum")
    near = np.abs(growth) <= max(0.05, 2 * np.abs(growth).min()) if growth.size else growth
    span = max(np.abs(growth[near]).max() if np.any(near) else 0.05, 1e-3) * 1.3
    axes[1].set_xlim(-span, span)
    axes[1].set_title("close-up near the neutral axis")
    return save_figure(fig, path)


def write_modes_vtk(steady, fluid_index, modes: dict[str, np.ndarray], path: Path) -> Path:
    """Real and imaginary parts of the velocity and pressure of each mode, as one VTK file.

    ``modes`` maps a name to a fluid vector (the fluid unknowns, indexed by ``fluid_index``). The
    file is ``path`` with ``.vtu`` appended (unless it ends so), written atomically
    (:func:`fsistab.store.atomic_path`).
    """
    from ngsolve import GridFunction, VTKOutput

    from fsistab.store import atomic_path

    coefs, names = [], []
    for name, vector in modes.items():
        for part, values in (("re", vector.real), ("im", vector.imag)):
            field = GridFunction(steady.space)
            field.vec.FV().NumPy()[fluid_index] = values
            coefs += [field.components[0], field.components[1]]
            names += [f"{name}_velocity_{part}", f"{name}_pressure_{part}"]
    path = Path(path)  # a name with dots (alpha0 = 2.5) keeps them: ".vtu" is appended
    target = path if path.suffix == ".vtu" else path.with_name(path.name + ".vtu")
    with atomic_path(target, ".vtu") as tmp:
        # VTKOutput appends ".vtu" to the name it is given: give it the temporary without it
        stem = str(tmp.with_suffix(""))
        VTKOutput(steady.mesh, coefs=coefs, names=names, filename=stem, subdivision=1).Do()
    return target


# --- modes -----------------------------------------------------------------------------------------


def _mode_window(kind: str):
    return ((-1.0, 2.0), (-0.75, 0.75)) if kind == "plate" else ((-2.0, 8.0), (-2.5, 2.5))


def _draw_body(ax, body) -> None:
    from matplotlib.patches import Circle, FancyBboxPatch

    if body.kind == "plate":
        e = body.thickness
        r = body.corner_radius * e
        patch = FancyBboxPatch(
            (-0.5 + r, -e / 2 + r), 1 - 2 * r, e - 2 * r, boxstyle=f"round,pad={r}", fc="0.6", ec="k", lw=0.6
        )
    else:
        patch = Circle((0.0, 0.0), 0.5, fc="0.6", ec="k", lw=0.6)
    ax.add_patch(patch)


def mode_pressure(steady, fluid_index, fluid_vector: np.ndarray, phase: float = 0.0):
    """``Re(p̂ e^{iφ})`` of a mode at the mesh vertices, with the matching triangulation.

    ``fluid_vector`` holds the fluid unknowns (the dofs ``fluid_index`` of ``steady.space``); the
    pressure dofs are all free, so the wall lifting of the solid states does not enter.
    """
    from ngsolve import GridFunction

    field = GridFunction(steady.space)
    field.vec.FV().NumPy()[fluid_index] = (np.asarray(fluid_vector) * np.exp(1j * phase)).real
    tri = _triangulation(steady.mesh)
    values = np.asarray(field.components[1](steady.mesh(tri.x, tri.y))).reshape(-1)
    return tri, values


def plot_mode_snapshot(
    steady, fluid_index, pair, system, path: Path, phase: float = 0.0, window=None
) -> Path:
    """Pressure ``Re(p̂ e^{iφ})`` of an eigenmode near the body, with the body's motion as arrows.

    ``pair`` is an :class:`fsistab.eigen.Eigenpair` of ``system`` (its vector holds the active solid
    states, then the fluid unknowns ``fluid_index`` of ``steady.space``). At phase ``φ`` the heave
    ``h = Re(ĥ e^{iφ})`` is drawn at G along ``e_y`` (red) and, for the plate, the pitch rotation
    ``θ = Re(θ̂ e^{iφ})`` as the displacements ``θ e_z∧X = (0, ±θ/2)`` of the leading and trailing
    edges ``X = ∓1/2`` (green), with the displaced chord dashed. Arrows are scaled so that the
    largest amplitude is a quarter of a body length (the scale is in the legend).
    """
    kind = steady.mesh_spec.body.kind
    n_solid = system.n_solid
    tri, pressure = mode_pressure(steady, fluid_index, pair.vector[n_solid:], phase)
    window = window or _mode_window(kind)
    inside = (
        (tri.x >= window[0][0]) & (tri.x <= window[0][1]) & (tri.y >= window[1][0]) & (tri.y <= window[1][1])
    )
    vmax = float(np.percentile(np.abs(pressure[inside]), 99.5)) if inside.any() else 1.0
    vmax = vmax if vmax > 0 else 1.0
    fig, ax = plt.subplots(figsize=(10, 4.6))
    levels = np.linspace(-vmax, vmax, 41)
    cs = ax.tricontourf(tri, np.clip(pressure, -vmax, vmax), levels=levels, cmap="RdBu_r", extend="both")
    fig.colorbar(cs, ax=ax, label=f"Re(p̂ e^(iφ)), φ = {phase:.3g}")
    _draw_body(ax, steady.mesh_spec.body)

    rotation = np.exp(1j * phase)
    h_hat, theta_hat = pair.solid[0], pair.solid[1]
    h, theta = (h_hat * rotation).real, (theta_hat * rotation).real
    amplitude = max(abs(h_hat), 0.5 * abs(theta_hat) if kind == "plate" else 0.0)
    if n_solid and amplitude > 0:
        scale = 0.25 / amplitude
        arrow = {"angles": "xy", "scale_units": "xy", "scale": 1.0, "width": 0.004, "zorder": 5}
        ax.quiver([0.0], [0.0], [0.0], [scale * h], color="tab:red", label=f"heave h (×{scale:.3g})", **arrow)
        if kind == "plate":
            ax.quiver(
                [-0.5, 0.5],
                [0.0, 0.0],
                [0.0, 0.0],
                [-scale * theta / 2, scale * theta / 2],
                color="tab:green",
                label=f"pitch θ e_z∧X at the edges (×{scale:.3g})",
                **arrow,
            )
            ax.plot(
                [-0.5, 0.5],
                [scale * (h - theta / 2), scale * (h + theta / 2)],
                "k--",
                lw=1.0,
                label="displaced chord",
                zorder=5,
            )
        ax.legend(loc="upper right", fontsize=8)
    ax.set_xlim(*window[0])
    ax.set_ylim(*window[1])
    ax.set_aspect("equal")
    ax.set_xlabel("X")
    ax.set_ylabel("Y")
    ax.set_title(
        f"{kind}, Re = {steady.flow.reynolds:g}: mode σ = {pair.value.real:+.5f} + {pair.value.imag:.5f}i "
        f"({pair.label}), pressure at phase {phase:.3g}"
    )
    return save_figure(fig, path)


class SolidMotion(NamedTuple):
    """The body's motion over one period of a mode (what :func:`plot_solid_motion` draws).

    ``time`` is ``t/T`` with ``T = 2π/ω`` (or ``1/|λ|`` for a non-oscillating mode, ``1`` if both
    vanish); ``heave`` is ``Re(ĥ e^{σt})`` and ``angle_of_attack`` is ``-Re(θ̂ e^{σt})``.
    """

    path: Path
    time: np.ndarray
    heave: np.ndarray
    angle_of_attack: np.ndarray
    period: float


def solid_motion(value: complex, solid: np.ndarray, n: int = 201) -> tuple[np.ndarray, ...]:
    """``(t/T, h(t), α(t), T)`` over one period of ``q e^{σt}``, growth included."""
    value = complex(value)
    omega, growth = abs(value.imag), value.real
    period = 2 * np.pi / omega if omega > 1e-12 else (1.0 / abs(growth) if abs(growth) > 1e-12 else 1.0)
    t = np.linspace(0.0, 1.0, n)
    factor = np.exp(value * t * period)
    heave = (solid[0] * factor).real
    alpha = -(solid[1] * factor).real
    return t, heave, alpha, period


def plot_solid_motion(pair, path: Path, n: int = 201) -> SolidMotion:
    """Heave ``h(t)`` and angle of attack ``α(t) = -θ(t)`` over one period of an eigenmode.

    From the complex amplitudes ``pair.solid`` (``ĥ`` index 0, ``θ̂`` index 1) and
    ``σ = pair.value``: ``h = Re(ĥ e^{σt})``, growth ``e^{λt}`` included, ``t`` normalised by
    ``T = 2π/ω``. Returns the path and the plotted arrays.
    """
    t, heave, alpha, period = solid_motion(pair.value, pair.solid, n)
    fig, axes = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
    axes[0].plot(t, heave, color="tab:red")
    axes[0].set_ylabel("heave h")
    axes[1].plot(t, alpha, color="tab:green")
    axes[1].set_ylabel("angle of attack α = -θ [rad]")
    axes[1].set_xlabel("t / T" if abs(pair.value.imag) > 1e-12 else "t |λ|")
    for ax in axes:
        ax.axhline(0, color="k", lw=0.6)
        ax.grid(alpha=0.3)
    axes[0].set_title(
        f"σ = {pair.value.real:+.5f} + {pair.value.imag:.5f}i ({pair.label}), T = {period:.4g}; "
        f"|ĥ| = {abs(pair.solid[0]):.3g}, |θ̂| = {abs(pair.solid[1]):.3g}"
    )
    return SolidMotion(save_figure(fig, path), t, heave, alpha, period)


def plot_branches(
    ds, path: Path, frequency_scale=None, scale_label: str = "", reference_lines=None, title: str = ""
) -> Path:
    """Growth rate and frequency of eigenvalue branches against the reduced velocity.

    ``ds`` has dims ``reduced_velocity`` and ``branch`` and variables ``growth_rate`` and
    ``frequency``. ``frequency_scale`` (a number, or one value per ``reduced_velocity``) divides
    both, e.g. ``ω_n = 2π/U*`` (named ``scale_label``). ``reference_lines`` maps a legend label to
    frequencies (a number or one per ``reduced_velocity``), drawn dashed in the frequency panel
    and scaled the same way. Unstable points (growth rate > 0) are filled.
    """
    u = np.asarray(ds["reduced_velocity"].values, dtype=float)
    scale = (
        np.ones_like(u) if frequency_scale is None else np.broadcast_to(np.asarray(frequency_scale), u.shape)
    )
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, name in enumerate(ds["branch"].values):
        colour = colours[i % len(colours)]
        growth = np.asarray(ds["growth_rate"].sel(branch=name).values, dtype=float)
        frequency = np.asarray(ds["frequency"].sel(branch=name).values, dtype=float)
        for ax, y in zip(axes, (growth / scale, frequency / scale), strict=True):
            ax.plot(u, y, "-", color=colour, lw=1.2, label=str(name))
            unstable = growth > 0
            ax.plot(u[~unstable], y[~unstable], "o", mfc="white", mec=colour, ms=5)
            ax.plot(u[unstable], y[unstable], "o", color=colour, ms=5)
    for j, (label, values) in enumerate((reference_lines or {}).items()):
        values = np.broadcast_to(np.asarray(values, dtype=float), u.shape)
        axes[1].plot(u, values / scale, ls=("--", ":", "-.")[j % 3], color="0.3", lw=1, label=label)
    axes[0].axhline(0, color="k", lw=0.8)
    suffix = f" / {scale_label}" if frequency_scale is not None else ""
    axes[0].set_ylabel(f"growth rate λ{suffix}")
    axes[1].set_ylabel(f"frequency ω{suffix}")
    for ax in axes:
        ax.set_xlabel("reduced velocity U*")
        ax.grid(alpha=0.3)
    axes[1].legend(fontsize=8)
    axes[0].set_title(title or "eigenvalue branches (filled: unstable)")
    return save_figure(fig, path)


def _reciprocal(values):
    """``1/x`` with ``1/0 = inf`` and no warning (matplotlib probes secondary axes at 0)."""
    values = np.asarray(values, dtype=float)
    return np.divide(1.0, values, out=np.full_like(values, np.inf), where=values != 0)


def plot_stability_map(
    curves,
    divergence,
    path: Path,
    title: str = "",
    turning_points=(),
    crossings=(),
    unstable=None,
    reference=(),
    sides=None,
) -> Path:
    """Neutral curves in log–log ``(m, U*)`` axes with a second axis ``ω_θ = 1/U*`` (MODEL.md §8).

    ``curves``: list of ``(kind, mass_ratios, reduced_velocities)`` for the dynamic neutral curves
    (kind ``flutter`` or ``viv``), in order of arclength; ``divergence``: ``(mass_ratios,
    reduced_velocities)``. Shaded: above the divergence curve (static instability, grey), above
    each flutter curve (closed along the top of the plot, red) and inside each VIV curve (closed
    by the segment joining its ends, which lie on the bounds of m, blue) — the side where a
    growth rate is positive for the usual onset curves. ``turning_points`` (▽) and ``crossings``
    (codimension-two points, ★) are ``(m, U*)`` pairs. ``unstable = (m, U*, count)`` (1-D, 1-D,
    len(U*) × len(m)), when known (:func:`fsistab.transfer_map.unstable_grid`), replaces those
    fills by the exact unstable regions, darker with more unstable modes. ``reference``: ``(m, U*)``
    points of another method, drawn as open circles. ``sides``: per curve, the unstable side of
    each point (+1: larger U*, −1: smaller, 0: unknown; :class:`fsistab.neutral.MapCurve`), drawn as
    short ticks from about ``SIDE_TICKS`` points of the curve towards that side (one line of
    ``NaN``-separated segments per curve).
    """
    colours = {"flutter": "tab:red", "viv": "tab:blue"}
    fig, ax = plt.subplots(figsize=(7.5, 5.5))
    m_div, u_div = (np.asarray(a, dtype=float) for a in divergence)
    ok = np.isfinite(u_div)
    all_u = np.concatenate([np.asarray(v, dtype=float) for _, _, v in curves] + [u_div[ok], [1.0]])
    top, bottom = all_u.max() * 1.5, all_u.min() / 1.5
    if unstable is not None:
        m_grid, u_grid, counts = (np.asarray(a, dtype=float) for a in unstable)
        top, bottom = max(top, u_grid.max()), min(bottom, u_grid.min())
        filled = ax.contourf(
            m_grid,
            u_grid,
            counts,
            levels=[0.5, 1.5, 2.5, 99],
            colors=["#f4c7c3", "#e8877f", "#c0392b"],
            zorder=0,
        )
        fig.colorbar(filled, ax=ax, pad=0.12, label="unstable modes", ticks=[1, 2, 3])
    if ok.any():
        ax.plot(m_div[ok], u_div[ok], color="k", lw=1.5, label="divergence")
        if unstable is None:
            ax.fill_between(m_div[ok], u_div[ok], top * 10, color="0.85", zorder=0)
    labelled = set()
    for kind, masses, velocities in curves:
        masses, velocities = np.asarray(masses, dtype=float), np.asarray(velocities, dtype=float)
        colour = colours.get(kind, "tab:purple")
        label = kind if kind not in labelled else None
        labelled.add(kind)
        ax.plot(masses, velocities, "-", color=colour, lw=1.8, label=label)
        if len(masses) < 2 or unstable is not None:
            continue
        if kind == "viv":
            ax.fill(masses, velocities, color=colour, alpha=0.2, lw=0, zorder=0)
        else:
            ax.fill(
                np.concatenate([masses, [masses[-1], masses[0]]]),
                np.concatenate([velocities, [top * 10, top * 10]]),
                color=colour,
                alpha=0.12,
                lw=0,
                zorder=0,
            )
    ticked = False
    for (kind, masses, velocities), side in zip(curves, sides or [None] * len(curves), strict=True):
        ticks = _side_ticks(masses, velocities, side)
        if ticks is not None:
            label = None if ticked else "unstable side"
            ax.plot(*ticks, "-", color=colours.get(kind, "tab:purple"), lw=0.9, label=label)
            ticked = True
    if len(reference):
        m_r, u_r = np.asarray(reference, dtype=float).T
        ax.plot(m_r, u_r, "o", color="k", ms=3.5, mfc="none", mew=0.7, label="continuation")
    if len(turning_points):
        m_t, u_t = np.asarray(turning_points, dtype=float).T
        ax.plot(m_t, u_t, "v", color="k", ms=6, mfc="none", label="turning point")
    if len(crossings):
        m_c, u_c = np.asarray(crossings, dtype=float).T
        ax.plot(m_c, u_c, "*", color="tab:green", ms=11, label="codimension two")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(bottom, top)
    ax.set_xlabel("mass ratio m")
    ax.set_ylabel("reduced velocity U*")
    secondary = ax.secondary_yaxis("right", functions=(_reciprocal, _reciprocal))
    secondary.set_ylabel("ω_θ = 1/U*")
    ax.grid(alpha=0.3, which="both")
    ax.legend(loc="upper left")
    ax.set_title(title or "stability map (grey: static divergence)")
    return save_figure(fig, path)


SIDE_TICKS = 12  # unstable-side ticks per curve on the map figure
SIDE_TICK_LENGTH = 1.06  # a tick spans U* to U* · 1.06^side (log axes: the same length everywhere)


def _side_ticks(masses, velocities, side):
    """``(x, y)`` of the unstable-side ticks of one curve (segments separated by NaN), or None
    when no side is known."""
    if side is None:
        return None
    masses, velocities = np.asarray(masses, dtype=float), np.asarray(velocities, dtype=float)
    side = np.asarray(side, dtype=int)
    chosen = [k for k in np.unique(np.linspace(0, len(side) - 1, SIDE_TICKS).round().astype(int)) if side[k]]
    if not chosen:
        return None
    x = np.concatenate([[masses[k], masses[k], np.nan] for k in chosen])
    y = np.concatenate([[velocities[k], velocities[k] * SIDE_TICK_LENGTH ** side[k], np.nan] for k in chosen])
    return x, y


def plot_flow_neutral(curves, parameter: str, path: Path, title: str = "") -> Path:
    """Neutral curves in the ``(Re, U*)`` (log Re axis) or ``(α0, U*)`` plane; ``curves`` is a list
    of ``(kind, parameter_values, reduced_velocities, fold_parameters, fold_velocities)``; turning
    points in the parameter are marked ▽."""
    colours = {"flutter": "tab:red", "viv": "tab:blue"}
    fig, ax = plt.subplots(figsize=(7.0, 5.0))
    labelled = set()
    for kind, values, velocities, fold_values, fold_velocities in curves:
        label = kind if kind not in labelled else None
        labelled.add(kind)
        ax.plot(values, velocities, ".-", color=colours.get(kind, "tab:purple"), lw=1.6, ms=4, label=label)
        if len(fold_values):
            ax.plot(fold_values, fold_velocities, "v", color="k", mfc="none", ms=8)
    if parameter == "reynolds":
        ax.set_xscale("log")
        ax.set_xlabel("Reynolds number Re")
    else:
        ax.set_xlabel("angle of attack α0 [deg]")
    ax.set_ylabel("reduced velocity U*")
    ax.grid(alpha=0.3, which="both")
    ax.legend(loc="best")
    ax.set_title(title or "neutral curves (▽: turning points)")
    return save_figure(fig, path)


def plot_theodorsen_map(ds, path: Path, viscous=None, comparison=None, title: str = "") -> Path:
    """Theodorsen neutral curves (:func:`fsistab.theodorsen.neutral_curves`) in log–log ``(m, U*)``.

    ``ds`` has ``reduced_velocity(mass_ratio, boundary)``, ``onset`` and ``divergence_velocity``.
    ``viscous``: optional ``{"flutter": [(masses, velocities), ...], "divergence": (masses,
    velocities) or None}`` from ``fsistab neutral``, drawn dashed. ``comparison``: optional
    ``(masses, relative_errors)`` of the lowest flutter boundary, drawn in a second panel.
    """
    panels = 2 if comparison is not None else 1
    fig, axes = plt.subplots(1, panels, figsize=(7.5 * panels, 5.5), squeeze=False)
    ax = axes[0, 0]
    m = np.asarray(ds["mass_ratio"].values, dtype=float)
    u_div = np.asarray(ds["divergence_velocity"].values, dtype=float)
    ok = np.isfinite(u_div)
    if ok.any():
        ax.plot(m[ok], u_div[ok], color="k", lw=1.5, label="divergence (Theodorsen)")
        ax.fill_between(m[ok], u_div[ok], u_div[ok].max() * 10, color="0.88", zorder=0)
    velocities = np.asarray(ds["reduced_velocity"].values, dtype=float)
    onset = np.asarray(ds["onset"].values)
    for j in range(velocities.shape[1]):
        u = velocities[:, j]
        ax.plot(m, u, "-", color="tab:red", lw=1.5, label="flutter (Theodorsen)" if j == 0 else None)
        ax.plot(m[onset[:, j] == 1], u[onset[:, j] == 1], "o", color="tab:red", ms=3)
        ax.plot(m[onset[:, j] == 0], u[onset[:, j] == 0], "o", mfc="white", mec="tab:red", ms=3)
    extra = []
    if viscous:
        for i, (masses, vel) in enumerate(viscous.get("flutter", [])):
            ax.plot(
                masses, vel, "--", color="tab:blue", lw=1.5, label="flutter (viscous)" if i == 0 else None
            )
            extra.append(np.asarray(vel, dtype=float))
        if viscous.get("divergence") is not None:
            masses, vel = viscous["divergence"]
            ax.plot(masses, vel, "--", color="0.4", lw=1.2, label="divergence (viscous)")
            extra.append(np.asarray(vel, dtype=float))
    all_u = np.concatenate([velocities[np.isfinite(velocities)], u_div[ok], *extra])
    all_u = all_u[np.isfinite(all_u) & (all_u > 0)]
    if all_u.size:
        ax.set_ylim(all_u.min() / 1.5, all_u.max() * 1.5)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("mass ratio m")
    ax.set_ylabel("reduced velocity U*")
    ax.grid(alpha=0.3, which="both")
    ax.legend(loc="upper left", fontsize=8)
    ax.set_title(title or "Theodorsen typical section (filled: onset, open: restabilisation)")
    if comparison is not None:
        err_ax = axes[0, 1]
        masses, errors = (np.asarray(v, dtype=float) for v in comparison)
        order = np.argsort(masses)
        err_ax.plot(masses[order], 100 * errors[order], "o-", color="tab:purple", ms=4)
        err_ax.axhline(0, color="k", lw=0.8)
        err_ax.set_xscale("log")
        err_ax.set_xlabel("mass ratio m")
        err_ax.set_ylabel("(U*_F Theodorsen - U*_F viscous) / U*_F viscous  [%]")
        err_ax.grid(alpha=0.3, which="both")
        err_ax.set_title("lowest flutter boundary: relative error")
    return save_figure(fig, path)


def plot_viscous_theodorsen(ds, path: Path, title: str = "") -> Path:
    """The viscous Theodorsen function: ``(C_L, C_M)`` per unit ``(ĥ, θ̂)`` against the reduced
    frequency ``k = ω/2``, real and imaginary parts, from the linearised Navier–Stokes equations
    (``fsistab.transfer.viscous_theodorsen_dataset``) beside Theodorsen's model with thin-airfoil and
    with calibrated (viscous static) slopes."""
    k = ds.reduced_frequency.values
    styles = {
        "viscous_loads": dict(color="k", marker="o", ms=3, lw=1.2, label="linearised NS"),
        "theodorsen_thin_airfoil": dict(color="tab:blue", ls="--", lw=1.2, label="Theodorsen, thin airfoil"),
        "theodorsen_calibrated": dict(color="tab:red", ls=":", lw=1.6, label="Theodorsen, calibrated"),
    }
    fig, axes = plt.subplots(2, 4, figsize=(14, 6.5), sharex=True)
    for row, coefficient in enumerate(("lift", "moment")):
        for col, (motion, part) in enumerate(
            (("pitch", "real"), ("pitch", "imag"), ("heave", "real"), ("heave", "imag"))
        ):
            ax = axes[row, col]
            for name, style in styles.items():
                values = ds[name].sel(coefficient=coefficient, motion=motion, part=part).values
                ax.plot(k, values, **style)
            symbol = "C_L" if coefficient == "lift" else "C_M"
            unit = "θ̂" if motion == "pitch" else "ĥ"
            ax.set_title(f"{'Re' if part == 'real' else 'Im'} {symbol}/{unit}", fontsize=10)
            ax.set_xscale("log")
            ax.grid(alpha=0.3, which="both")
            if row == 1:
                ax.set_xlabel("k = ω c / (2 U∞)")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(title or f"viscous Theodorsen function, Re = {ds.attrs.get('reynolds', float('nan')):g}")
    fig.tight_layout()
    return save_figure(fig, path)


def plot_slopes(ds, path: Path, title: str = "") -> Path:
    """Static slopes ``dC_L/dα`` and ``d(-C_M)/dα`` (per radian, α = -θ, MODEL.md §9) against Re,
    with the thin-airfoil values 2π and π/2 as lines; ``ds`` as written by ``fsistab slopes``."""
    reynolds = ds.reynolds.values
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    for ax, name, thin, label in (
        (axes[0], "lift_slope_alpha", 2 * np.pi, "dC_L/dα"),
        (axes[1], "moment_slope_alpha", np.pi / 2, "d(−C_M)/dα"),
    ):
        ax.plot(reynolds, ds[name].values, "o-", color="k", label="linearised NS")
        ax.axhline(thin, color="tab:blue", ls="--", label="thin airfoil")
        ax.set_xscale("log")
        ax.set_xlabel("Re")
        ax.set_ylabel(f"{label} [1/rad]")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    fig.suptitle(
        title or f"static slopes, α0 = {ds.attrs.get('alpha0_deg', 0):g}°, mesh {ds.attrs.get('mesh', '')}"
    )
    fig.tight_layout()
    return save_figure(fig, path)


# --- figures of the workflows' Datasets (fsistab.workflows) -----------------------------------------


def plot_map(ds, path: Path, title: str = "") -> Path:
    """The stability map of :func:`fsistab.workflows.stability_map` (its Dataset) by
    :func:`plot_stability_map`: curves (legend by kind: flutter, viv), divergence, turning points,
    codimension-two points (★), unstable-side ticks and, for the transfer method, the unstable
    regions of ``unstable_count``."""
    from fsistab.neutral import map_curves

    unstable = None
    if "unstable_count" in ds:
        unstable = (ds.grid_mass_ratio.values, ds.grid_reduced_velocity.values, ds.unstable_count.values)
    return plot_stability_map(
        [(kind, m, u) for kind, m, u, _ in map_curves(ds)],
        (ds.mass_ratio.values, ds.divergence_reduced_velocity.values),
        path,
        title=title,
        turning_points=list(zip(ds.fold_mass_ratio.values, ds.fold_reduced_velocity.values, strict=True)),
        crossings=list(zip(ds.crossing_mass_ratio.values, ds.crossing_reduced_velocity.values, strict=True)),
        unstable=unstable,
        sides=[ds.curve_unstable_side.values[ds.curve.values == i] for i in range(ds.sizes["curve_index"])]
        if "curve_unstable_side" in ds
        else None,
    )


def plot_flow_neutral_curves(ds, path: Path, title: str = "") -> Path:
    """The curves of :func:`fsistab.workflows.flow_neutral_curves` by :func:`plot_flow_neutral`."""
    from fsistab.flow_neutral import flow_curves

    curves = [(kind, values, u, fp, fu) for kind, _, values, u, _, fp, fu, _ in flow_curves(ds)]
    return plot_flow_neutral(curves, ds.attrs["parameter"], path, title=title)


def plot_theodorsen_comparison(ds, path: Path, title: str = "") -> Path:
    """The Dataset of :func:`fsistab.workflows.theodorsen_comparison` by
    :func:`plot_theodorsen_map`, with the viscous curves and the relative error if it has them."""
    from fsistab.theodorsen import viscous_curves

    comparison = None
    if "comparison_mass_ratio" in ds and ds.sizes.get("comparison", 0):
        comparison = (ds.comparison_mass_ratio.values, ds.comparison_relative_error.values)
    return plot_theodorsen_map(ds, path, viscous=viscous_curves(ds), comparison=comparison, title=title)


# --- parameter studies (fsistab.study) -------------------------------------------------------------

_STUDY_MARKERS = {
    "coupled-mode flutter": "o",
    "pitch single-mode flutter": "^",
    "heave single-mode flutter": "v",
    "divergence": "s",
    "viv": "*",
}


def _study_axis(ds) -> tuple[str, str]:
    """The study's abscissa: α0 when it has several values, else Re; and the other dimension."""
    if ds.sizes["alpha0"] > 1 or ds.sizes["reynolds"] == 1:
        return "alpha0", "reynolds"
    return "reynolds", "alpha0"


def _study_label(dim: str, value: float) -> str:
    return f"Re = {value:g}" if dim == "reynolds" else f"α0 = {value:g}°"


def plot_study_coefficients(ds, path: Path, title: str = "") -> Path:
    """Steady ``C_L``, ``C_M`` (about G) and the recirculation length of a study
    (:func:`fsistab.study.run_study` with slopes) against α0 (one line per Re), or against Re."""
    x_dim, line_dim = _study_axis(ds)
    names = [
        ("lift_coefficient", "$C_L$"),
        ("moment_coefficient", "$C_M$ (about G)"),
        ("recirculation_length", "recirculation length / L"),
    ]
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    fig.subplots_adjust(wspace=0.35)
    for ax, (name, label) in zip(axes, names, strict=True):
        for value in ds[line_dim].values:
            series = ds[name].sel({line_dim: value})
            ax.plot(ds[x_dim].values, series.values, "o-", ms=4, label=_study_label(line_dim, value))
        ax.set_xlabel("α0 [deg]" if x_dim == "alpha0" else "Re")
        ax.set_ylabel(label)
        if x_dim == "reynolds":
            ax.set_xscale("log")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(title)
    return save_figure(fig, path)


def plot_study_thresholds(ds, path: Path, title: str = "") -> Path:
    """The leading fixed-body growth rate (with modes) and every threshold's critical U* (with
    thresholds), marker by class (coupled-mode, pitch or heave single-mode flutter, divergence,
    VIV), against α0 or Re, one colour per value of the other flow parameter and mass ratio."""
    x_dim, line_dim = _study_axis(ds)
    panels = [p for p in ("mode_growth_rate", "threshold_reduced_velocity") if p in ds]
    n = max(1, len(panels))
    fig, axes = plt.subplots(1, n, figsize=(6 * n, 4), squeeze=False, sharex=True)
    x = ds[x_dim].values
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, name in zip(axes[0], panels, strict=False):
        if name == "mode_growth_rate":
            for k, value in enumerate(ds[line_dim].values):
                lead = ds.mode_growth_rate.sel({line_dim: value}).max("mode", skipna=True)
                colour = colours[k % len(colours)]
                ax.plot(x, lead.values, "o-", color=colour, label=_study_label(line_dim, value))
            ax.axhline(0.0, color="k", lw=0.8)
            ax.set_ylabel("leading growth rate λ (fixed body)")
            ax.legend(fontsize=8)
        else:
            k = 0
            for value in ds[line_dim].values:
                for mass in ds.mass_ratio.values:
                    sub = ds.sel({line_dim: value, "mass_ratio": mass})
                    colour = colours[k % len(colours)]
                    k += 1
                    for kind, marker in _STUDY_MARKERS.items():
                        mask = sub.threshold_class.values == kind
                        xs = np.broadcast_to(x[:, None], mask.shape)[mask]
                        velocities = sub.threshold_reduced_velocity.values[mask]
                        ax.scatter(xs, velocities, marker=marker, color=colour)
                    ax.plot([], [], "-", color=colour, label=f"{_study_label(line_dim, value)}, m = {mass:g}")
            for kind, marker in _STUDY_MARKERS.items():
                ax.scatter([], [], marker=marker, color="grey", label=kind)
            ax.set_ylabel("critical U*")
            ax.set_yscale("log")
            ax.legend(fontsize=7)
        ax.set_xlabel("α0 [deg]" if x_dim == "alpha0" else "Re")
        if x_dim == "reynolds":
            ax.set_xscale("log")
        ax.grid(alpha=0.3)
    fig.suptitle(title)
    return save_figure(fig, path)


def plot_study_maps(ds, path: Path, title: str = "") -> Path:
    """The ``(m, U*)`` neutral curves of every point of a study with ``--map`` overlaid, one colour
    per point, and each point's divergence law ``U*_D = c √m`` dashed."""
    fig, ax = plt.subplots(figsize=(7, 5))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    k = 0
    masses = ds.map_mass_ratio.values
    finite = masses[np.isfinite(masses)]
    m_line = np.geomspace(finite.min(), finite.max(), 50) if finite.size else np.geomspace(1, 1e4, 50)
    for re in ds.reynolds.values:
        for a in ds.alpha0.values:
            sub = ds.sel(reynolds=re, alpha0=a)
            colour = colours[k % len(colours)]
            k += 1
            curves = sub.map_curve.values
            for c in np.unique(curves[curves >= 0]):
                on = curves == c
                ax.plot(sub.map_mass_ratio.values[on], sub.map_reduced_velocity.values[on], "-", color=colour)
            coefficient = float(sub.map_divergence_coefficient)
            if np.isfinite(coefficient):
                ax.plot(m_line, coefficient * np.sqrt(m_line), "--", color=colour, lw=0.8)
            ax.plot([], [], "-", color=colour, label=f"Re = {re:g}, α0 = {a:g}°")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("mass ratio m")
    ax.set_ylabel("U*")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, title="flutter/VIV —, divergence --")
    ax.set_title(title)
    return save_figure(fig, path)
