"""Figures: one function per figure, each taking computed objects and a path (matplotlib: the command
line uses the Agg backend, a notebook or a script its own; the backend is never set on import).

Every figure is drawn inside :func:`figure_style` (one set of fonts and sizes, restored afterwards)
and written by :func:`save_figure`, atomically, as PNG or, inside :func:`figure_format`, as PDF or
SVG. Fields of the finite-element solution are evaluated by NGSolve on a subdivision of each triangle
(:func:`sample_mesh`), so that contours of the P2 velocity are smooth, and the body is drawn filled
from the (curved) wall of the mesh.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
from pathlib import Path
from types import MappingProxyType
from typing import NamedTuple

import matplotlib.pyplot as plt
import matplotlib.ticker
import matplotlib.tri as mtri
import numpy as np

from fsistab.bodies import body_type

# --- style and output format -------------------------------------------------------------------------

_SAVE_STYLE = MappingProxyType(
    {  # read when a file is written: save_figure sets them itself, whoever drew the figure
        "pdf.fonttype": 42,  # TrueType in PDFs: text stays editable and searchable (journals ask for it)
        "svg.fonttype": "path",  # SVG text as outlines: the same look without the font installed
        "svg.hashsalt": "fsistab",  # SVG ids from a fixed salt: the same figure gives the same bytes
    }
)
FIGURE_STYLE = MappingProxyType(
    {
        "font.size": 10.0,
        "axes.titlesize": 10.0,
        "axes.labelsize": 10.0,
        "xtick.labelsize": 9.0,
        "ytick.labelsize": 9.0,
        "legend.fontsize": 8.5,
        "legend.framealpha": 0.9,
        "figure.titlesize": 11.0,
        "lines.linewidth": 1.5,
        "lines.markersize": 5.0,
        "axes.linewidth": 0.8,
        "mathtext.fontset": "dejavusans",
        **_SAVE_STYLE,
    }
)
FIGURE_FORMATS = ("png", "pdf", "svg")
_FORMAT: contextvars.ContextVar[str | None] = contextvars.ContextVar("fsistab_figure_format", default=None)


@contextlib.contextmanager
def figure_style(overrides: dict | None = None):
    """Inside, matplotlib's rcParams are those of every fsistab figure (:data:`FIGURE_STYLE`, updated
    by ``overrides``); on exit (or an error) the previous rcParams are restored."""
    with plt.rc_context({**FIGURE_STYLE, **(overrides or {})}):
        yield


def _styled(draw):
    """Run a figure function inside :func:`figure_style`."""

    @functools.wraps(draw)
    def styled(*args, **kwargs):
        with figure_style():
            return draw(*args, **kwargs)

    return styled


def check_figure_format(fmt: str) -> str:
    """``fmt`` if it is one of :data:`FIGURE_FORMATS`, else InputError (one line)."""
    from fsistab.errors import InputError

    if fmt not in FIGURE_FORMATS:
        raise InputError(f"--format must be one of {', '.join(FIGURE_FORMATS)}, not {fmt!r}")
    return fmt


@contextlib.contextmanager
def figure_format(fmt: str):
    """Inside, :func:`save_figure` writes ``fmt`` (png, pdf or svg) whatever the image suffix of the
    path it is given (``.png`` becomes ``.pdf``...); the previous format is restored on exit. A
    context variable, so that nested or concurrent uses do not leak into each other."""
    token = _FORMAT.set(check_figure_format(fmt))
    try:
        yield
    finally:
        _FORMAT.reset(token)


def figure_path(path: Path) -> Path:
    """Where :func:`save_figure` writes ``path``: with the suffix of the current
    :func:`figure_format`, if any (an image suffix is replaced, another suffix, e.g. ``a2.5``, kept)."""
    path = Path(path)
    fmt = _FORMAT.get()
    if fmt is None:
        return path
    if path.suffix.lower().lstrip(".") in FIGURE_FORMATS:
        return path.with_suffix(f".{fmt}")
    return path.with_name(f"{path.name}.{fmt}")


_NO_DATES = {"pdf": {"CreationDate": None}, "svg": {"Date": None}}  # same figure, same bytes


def save_figure(fig, path: Path) -> Path:
    """Write ``fig`` to :func:`figure_path` of ``path`` (PNG at 150 dpi, or PDF/SVG, by the suffix)
    atomically (:func:`fsistab.store.atomic_path`: an interrupted or failed write leaves neither file
    nor temporary), close it and return the path written."""
    from fsistab.store import atomic_path

    path = figure_path(path)
    fmt = path.suffix.lower().lstrip(".")
    try:
        # the temporary keeps the suffix last: matplotlib picks the format by it
        with plt.rc_context(dict(_SAVE_STYLE)), atomic_path(path, path.suffix) as tmp:
            fig.savefig(tmp, dpi=150, bbox_inches="tight", metadata=_NO_DATES.get(fmt))
    finally:
        plt.close(fig)
    return path


# --- fields of the finite-element solution on subdivided triangles -------------------------------------


def _triangulation(mesh) -> mtri.Triangulation:
    coords = mesh.ngmesh.Coordinates()
    nodes = mesh.ngmesh.Elements2D().NumPy()["nodes"][:, :3].astype(np.int64) - 1
    return mtri.Triangulation(coords[:, 0], coords[:, 1], nodes)


def subdivision(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The uniform subdivision of a triangle into ``n²`` triangles: the lattice nodes as integer
    barycentric counts ``(i, j, k)``, ``i + j + k = n`` (the node ``(i λ0 + j λ1 + k λ2)/n`` of the
    element's vertices 0, 1, 2), and the sub-triangles as triples of node indices."""
    if n < 1:
        raise ValueError(f"subdivisions must be at least 1, not {n}")
    nodes = [(i, j) for j in range(n + 1) for i in range(n + 1 - j)]
    index = {node: k for k, node in enumerate(nodes)}
    triangles = []
    for j in range(n):
        for i in range(n - j):
            triangles.append((index[i, j], index[i + 1, j], index[i, j + 1]))
            if i + j < n - 1:
                triangles.append((index[i + 1, j], index[i + 1, j + 1], index[i, j + 1]))
    counts = np.array([(i, j, n - i - j) for i, j in nodes], dtype=np.int64)
    return counts, np.array(triangles, dtype=np.int64)


class SampledMesh(NamedTuple):
    """The triangles of a mesh (those meeting a window, and all at the wall), each subdivided into
    ``subdivisions²`` (:func:`subdivision`), their nodes shared between neighbours.

    ``triangulation`` has the physical coordinates of the nodes (the wall's curvature included);
    ``points`` are their NGSolve MeshPoints (an element and local coordinates), so that
    ``cf(points)`` evaluates any CoefficientFunction there without a point search; ``on_wall``
    flags the nodes on the wall; ``outline`` is the wall as closed polygons (first point repeated
    last), counter-clockwise, through the wall nodes.
    """

    triangulation: mtri.Triangulation
    points: np.ndarray
    on_wall: np.ndarray
    outline: tuple[np.ndarray, ...]

    def values(self, cf) -> np.ndarray:
        """``cf`` at the nodes: shape ``(nodes,)`` for a scalar, ``(nodes, dim)`` otherwise."""
        values = np.asarray(cf(self.points))
        return values[:, 0] if values.ndim == 2 and values.shape[1] == 1 else values

    def wall_triangles(self) -> np.ndarray:
        """The sub-triangles with a node on the wall (a mask for lines that must not follow it)."""
        return self.on_wall[self.triangulation.triangles].any(axis=1)


def _wall_edges(mesh) -> np.ndarray:
    from ngsolve import BND

    from fsistab.bodies import WALL

    return np.array(
        [[v.nr for v in e.vertices] for e in mesh.Elements(BND) if e.mat == WALL], dtype=np.int64
    ).reshape(-1, 2)


def sample_mesh(mesh, subdivisions: int = 4, window=None) -> SampledMesh:
    """:class:`SampledMesh` of ``mesh``: the triangles whose bounding box meets ``window = ((x0, x1),
    (y0, y1))`` (all if None) and those touching the wall, split into ``subdivisions²``.

    A node's identity is the set of its element's vertices with nonzero barycentric count and those
    counts, so that a node on an edge or a vertex is one node of the triangulation whichever element
    it comes from (contour lines then run across elements). A P2 field is exact at the nodes; a
    subdivision ``n`` draws it piecewise linearly on triangles ``n`` times smaller.
    """
    from ngsolve import VOL, CoefficientFunction, IntegrationRule, x, y

    counts, local_triangles = subdivision(subdivisions)
    n = subdivisions
    vertices = mesh.ngmesh.Elements2D().NumPy()["nodes"][:, :3].astype(np.int64) - 1
    coords = mesh.ngmesh.Coordinates()[:, :2]
    walls = _wall_edges(mesh)
    keep = np.isin(vertices, walls).any(axis=1)
    if window is None:
        keep[:] = True
    else:
        corners = coords[vertices]
        low, high = corners.min(axis=1), corners.max(axis=1)
        (x0, x1), (y0, y1) = window
        keep |= (high[:, 0] >= x0) & (low[:, 0] <= x1) & (high[:, 1] >= y0) & (low[:, 1] <= y1)
    elements = np.flatnonzero(keep)
    # node keys: the three (vertex, count) codes sorted, a zero count coded -1
    codes = vertices[elements][:, None, :] * (n + 1) + counts[None, :, :]
    codes = np.where(counts[None, :, :] > 0, codes, -1)
    codes = np.sort(codes, axis=2).reshape(-1, 3)
    keys, first, inverse = np.unique(codes, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    # NGSolve's reference triangle: the point (ξ, η) has barycentric coordinates (ξ, η, 1 - ξ - η)
    rule = IntegrationRule(points=[tuple(c[:2] / n) for c in counts], weights=[0.0] * len(counts))
    every = mesh.MapToAllElements(rule, VOL)  # element-major: element e, node k at e * len(counts) + k
    which = elements[first // len(counts)] * len(counts) + first % len(counts)
    points = every[which]
    xy = np.asarray(CoefficientFunction((x, y))(points))  # the deformed (curved) positions
    triangles = inverse.reshape(len(elements), len(counts))[:, local_triangles].reshape(-1, 3)
    triangulation = mtri.Triangulation(xy[:, 0], xy[:, 1], triangles)
    on_wall = _on_wall(keys, n, walls)
    return SampledMesh(triangulation, points, on_wall, _outline(keys, n, walls, xy))


def _key_vertices(keys: np.ndarray, n: int) -> np.ndarray:
    """The vertices of each node key (-1 where the count is zero), in key order."""
    return np.where(keys >= 0, keys // (n + 1), -1)


def _on_wall(keys: np.ndarray, n: int, walls: np.ndarray) -> np.ndarray:
    """Nodes at a wall vertex or on a wall edge."""
    nodes = _key_vertices(keys, n)
    used = (nodes >= 0).sum(axis=1)
    wall_vertices = np.unique(walls)
    single = (used == 1) & np.isin(nodes[:, 2], wall_vertices)
    edge_codes = set(map(tuple, np.sort(walls, axis=1).tolist()))
    pairs = np.sort(nodes[:, 1:], axis=1)
    double = (used == 2) & np.array([tuple(p) in edge_codes for p in pairs.tolist()], dtype=bool)
    return single | double


def _outline(keys: np.ndarray, n: int, walls: np.ndarray, xy: np.ndarray) -> tuple[np.ndarray, ...]:
    """The wall as closed counter-clockwise polygons through its vertices and edge nodes."""
    if not len(walls):
        return ()
    index = {tuple(k): i for i, k in enumerate(keys.tolist())}

    def node(vertex_counts) -> int:
        codes = sorted([v * (n + 1) + c for v, c in vertex_counts] + [-1] * (3 - len(vertex_counts)))
        return index[tuple(codes)]

    neighbours: dict[int, list[int]] = {}
    for a, b in walls.tolist():
        neighbours.setdefault(a, []).append(b)
        neighbours.setdefault(b, []).append(a)
    loops, seen = [], set()
    for start in neighbours:
        if start in seen:
            continue
        previous, current, path = None, start, []
        while True:
            seen.add(current)
            following = [v for v in neighbours[current] if v != previous]
            nxt = following[0]
            path.append(node([(current, n)]))
            path += [node([(current, n - k), (nxt, k)]) for k in range(1, n)]
            previous, current = current, nxt
            if current == start:
                break
        polygon = xy[path + path[:1]]
        if _signed_area(polygon) < 0:
            polygon = polygon[::-1]
        loops.append(polygon)
    return tuple(loops)


def _signed_area(polygon: np.ndarray) -> float:
    """Shoelace area of a closed polygon (positive counter-clockwise)."""
    x, y = polygon[:, 0], polygon[:, 1]
    return 0.5 * float(np.sum(x[:-1] * y[1:] - x[1:] * y[:-1]))


def polygon_area(polygon: np.ndarray) -> float:
    """Area enclosed by a closed polygon (first point repeated last)."""
    return abs(_signed_area(np.asarray(polygon, dtype=float)))


def draw_body(ax, outline, **style) -> None:
    """The body filled (grey, black edge), drawn over the fields."""
    from matplotlib.patches import Polygon

    style = {"fc": "0.55", "ec": "k", "lw": 0.7, "zorder": 4} | style
    for polygon in outline:
        ax.add_patch(Polygon(polygon[:-1], closed=True, **style))


@_styled
def plot_mesh(mesh, path: Path, title: str = "") -> Path:
    """The whole mesh and a close-up of the body (filled, its curved wall from :func:`sample_mesh`)."""
    tri = _triangulation(mesh)
    close_up = ((-0.8, 1.6), (-0.6, 0.6))
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    for ax, (xlim, ylim) in zip(axes, [(None, None), close_up], strict=True):
        ax.triplot(tri, lw=0.2, color="k")
        ax.set_aspect("equal")
        if xlim:
            ax.set_xlim(*xlim)
            ax.set_ylim(*ylim)
            draw_body(ax, sample_mesh(mesh, 2, close_up).outline)
        ax.set_xlabel("X")
        ax.set_ylabel("Y")
    axes[0].set_title(title or f"{mesh.ne} triangles")
    axes[1].set_title("close-up")
    return save_figure(fig, path)


def _field_window(kind: str):
    return body_type(kind).flow_window


def _zero_centred_levels(values: np.ndarray, low: float, high: float, count: int = 40) -> np.ndarray:
    """About ``count`` contour levels spanning ``values`` (at least ``[low, high]``), with 0 one of
    them, so that the sign of the field is read at the white of a diverging colour map."""
    vmin, vmax = min(float(np.nanmin(values)), low), max(float(np.nanmax(values)), high)
    below = max(2, round(count * -vmin / (vmax - vmin)))
    return np.concatenate([np.linspace(vmin, 0.0, below + 1), np.linspace(0.0, vmax, count - below + 1)[1:]])


def _streamlines(ax, tri: mtri.Triangulation, velocity: np.ndarray, window) -> None:
    """Streamlines of ``velocity`` (at the nodes of ``tri``), interpolated linearly on its triangles
    onto a regular grid of ``window`` (masked where no triangle is, e.g. in the body)."""
    (x0, x1), (y0, y1) = window
    nx = 300
    ny = max(20, round(nx * (y1 - y0) / (x1 - x0)))
    gx, gy = np.meshgrid(np.linspace(x0, x1, nx), np.linspace(y0, y1, ny))
    finder = tri.get_trifinder()
    u = mtri.LinearTriInterpolator(tri, velocity[:, 0], trifinder=finder)(gx, gy)
    v = mtri.LinearTriInterpolator(tri, velocity[:, 1], trifinder=finder)(gx, gy)
    ax.streamplot(gx, gy, u, v, density=1.1, color="0.25", linewidth=0.5, arrowsize=0.6, zorder=3)


@_styled
def plot_streamwise_velocity(
    steady, path: Path, window=None, subdivisions: int = 4, streamlines: bool = False
) -> Path:
    """Relative streamwise velocity ``(U - W⁰)·d`` near the body (docs/model.md §4, §6: body frame), on each
    triangle subdivided ``subdivisions`` times (:func:`sample_mesh`; P2 is exact at the nodes), a
    diverging colour map white at 0; the recirculation outlined by the zero line off the wall (the
    sub-triangles touching the wall are masked for that line: there the velocity vanishes by the
    no-slip condition); the body filled from the curved wall; with ``streamlines`` (about 2 s more on
    the coarse mesh), those of the relative velocity ``U − W⁰`` (thin grey)."""
    from matplotlib.colors import TwoSlopeNorm
    from matplotlib.ticker import MaxNLocator

    from fsistab.forces import streamwise_direction
    from fsistab.steady import wall_velocity

    kind = steady.mesh_spec.body.kind
    window = window or _field_window(kind)
    sampled = sample_mesh(steady.mesh, subdivisions, window)
    d = streamwise_direction(steady.flow.theta0)
    body_frame = sampled.values(steady.velocity) - np.array(wall_velocity(steady.flow.theta0))
    relative = body_frame @ d
    tri = sampled.triangulation
    levels = _zero_centred_levels(relative, -0.2, 1.2)
    # the free stream (≈ 1) at a middle red, not the darkest: the wake and the shear layers stand out
    norm = TwoSlopeNorm(vmin=levels[0], vcenter=0.0, vmax=1.6 * levels[-1])
    fig, ax = plt.subplots(figsize=(8.0, 3.6))
    filled = ax.tricontourf(tri, relative, levels=levels, cmap="RdBu_r", norm=norm)
    filled.set_rasterized(True)  # vector outputs stay small; lines, text and the body stay vector
    off_wall = mtri.Triangulation(tri.x, tri.y, tri.triangles, mask=sampled.wall_triangles())
    ax.tricontour(off_wall, relative, levels=[0.0], colors="k", linewidths=1.1)
    if streamlines:
        _streamlines(ax, tri, body_frame, window)
    draw_body(ax, sampled.outline)
    bar = fig.colorbar(filled, ax=ax, label="streamwise velocity (body frame)", shrink=0.9)
    ticks = MaxNLocator(8).tick_values(levels[0], levels[-1])
    bar.set_ticks(ticks[(ticks >= levels[0]) & (ticks <= levels[-1])])
    ax.set_xlim(*window[0])
    ax.set_ylim(*window[1])
    ax.set_aspect("equal")
    ax.set_xlabel("X")
    ax.set_ylabel("Y")
    ax.set_title(
        f"{kind}, Re = {steady.flow.reynolds:g}, α0 = {steady.flow.alpha0_deg:g}°: steady flow, "
        "recirculation inside the black line"
    )
    return save_figure(fig, path)


_LABEL_COLOURS = {"fluid": "tab:blue", "heave": "tab:red", "pitch": "tab:green", "coupled": "tab:purple"}


@_styled
def plot_spectrum(ds, path: Path, title: str = "") -> Path:
    """Eigenvalues in the (growth rate, frequency) plane, and a close-up near the neutral axis."""
    from matplotlib.ticker import MaxNLocator

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
        ax.xaxis.set_major_locator(MaxNLocator(6))  # long tick labels (-0.0125) would overlap
        ax.grid(alpha=0.3)
    axes[0].legend()
    axes[0].set_title(title or "spectrum")
    near = np.abs(growth) <= max(0.05, 2 * np.abs(growth).min()) if growth.size else growth
    span = max(np.abs(growth[near]).max() if np.any(near) else 0.05, 1e-3) * 1.3
    axes[1].set_xlim(-span, span)
    axes[1].set_title("close-up near the neutral axis")
    return save_figure(fig, path)


# --- modes -----------------------------------------------------------------------------------------


def _mode_window(kind: str):
    return body_type(kind).mode_window


def mode_pressure(
    steady, fluid_index, fluid_vector: np.ndarray, phase: float = 0.0, subdivisions: int = 2, window=None
):
    """``Re(p̂ e^{iφ})`` of a mode at the nodes of :func:`sample_mesh` (``subdivisions``, ``window``),
    with that :class:`SampledMesh`.

    ``fluid_vector`` holds the fluid unknowns (the dofs ``fluid_index`` of ``steady.space``); the
    pressure dofs are all free, so the wall lifting of the solid states does not enter.
    """
    from ngsolve import GridFunction

    field = GridFunction(steady.space)
    field.vec.FV().NumPy()[fluid_index] = (np.asarray(fluid_vector) * np.exp(1j * phase)).real
    sampled = sample_mesh(steady.mesh, subdivisions, window)
    return sampled, sampled.values(field.components[1])


def _area_quantile(tri: mtri.Triangulation, values: np.ndarray, window, q: float) -> float:
    """The ``q`` quantile of ``values`` (at the nodes of ``tri``) over the area of ``window``: the
    colour range of a field whose peak (a sharp edge) would otherwise wash out the rest, on meshes
    refined near the body where most nodes lie."""
    corners = np.stack([tri.x[tri.triangles], tri.y[tri.triangles]], axis=2)
    centre = corners.mean(axis=1)
    (x0, x1), (y0, y1) = window
    inside = (centre[:, 0] >= x0) & (centre[:, 0] <= x1) & (centre[:, 1] >= y0) & (centre[:, 1] <= y1)
    if not inside.any():
        return float(np.max(values, initial=0.0))
    a, b, c = corners[inside, 0], corners[inside, 1], corners[inside, 2]
    area = 0.5 * np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1]))
    mean = values[tri.triangles[inside]].mean(axis=1)
    order = np.argsort(mean)
    cumulative = np.cumsum(area[order])
    return float(mean[order][np.searchsorted(cumulative, q * cumulative[-1])])


def displaced_outline(outline: np.ndarray, heave: float, pitch: float) -> np.ndarray:
    """The outline moved by the linearised rigid displacement of a mode, heave ``h`` along ``e_y``
    and pitch ``θ`` about G at the origin (docs/model.md §3, §4):
    ``X + h e_y + θ e_z∧X = (X − θ Y, Y + h + θ X)``."""
    outline = np.asarray(outline, dtype=float)
    x, y = outline[:, 0], outline[:, 1]
    return np.column_stack([x - pitch * y, y + heave + pitch * x])


def _pitches(kind: str) -> bool:
    return "pitch" in body_type(kind).allowed_dofs


def mode_display_scale(kind: str, solid: np.ndarray) -> float:
    """The factor drawing a mode's body displacement with its largest amplitude a quarter of the
    body length: ``|ĥ|``, and for the plate the edges' ``|θ̂|/2`` (0 when the body does not move)."""
    amplitude = max(abs(solid[0]), 0.5 * abs(solid[1]) if _pitches(kind) and len(solid) > 1 else 0.0)
    return 0.25 / amplitude if amplitude > 0 else 0.0


@_styled
def plot_mode_snapshot(
    steady, fluid_index, pair, system, path: Path, phase: float = 0.0, window=None
) -> Path:
    """Pressure ``Re(p̂ e^{iφ})`` of an eigenmode near the body, with the body's motion drawn.

    ``pair`` is an :class:`fsistab.eigen.Eigenpair` of ``system`` (its vector holds the active solid
    states, then the fluid unknowns ``fluid_index`` of ``steady.space``). At phase ``φ`` the heave
    ``h = Re(ĥ e^{iφ})`` is drawn at G along ``e_y`` (red) and, for the plate, the pitch rotation
    ``θ = Re(θ̂ e^{iφ})`` as the displacements ``θ e_z∧X = (0, ±θ/2)`` of the leading and trailing
    edges ``X = ∓1/2`` (green), with the displaced chord dashed and the displaced body outlined
    (:func:`displaced_outline`). Displacements are scaled by :func:`mode_display_scale` (the largest
    amplitude a quarter of a body length; the factor is in the legend).
    """
    from matplotlib.ticker import MaxNLocator

    kind = steady.mesh_spec.body.kind
    n_solid = system.n_solid
    window = window or _mode_window(kind)
    sampled, pressure = mode_pressure(steady, fluid_index, pair.vector[n_solid:], phase, window=window)
    tri = sampled.triangulation
    vmax = _area_quantile(tri, np.abs(pressure), window, 0.98)
    vmax = vmax if vmax > 0 else 1.0
    fig, ax = plt.subplots(figsize=(8.0, 4.2))
    levels = np.linspace(-vmax, vmax, 41)
    cs = ax.tricontourf(tri, np.clip(pressure, -vmax, vmax), levels=levels, cmap="RdBu_r", extend="both")
    cs.set_rasterized(True)
    bar = fig.colorbar(cs, ax=ax, label=f"pressure Re(p̂ e^(iφ)), φ = {phase:.3g}", shrink=0.9)
    ticks = MaxNLocator(7, symmetric=True).tick_values(-vmax, vmax)
    bar.set_ticks(ticks[np.abs(ticks) <= vmax])
    draw_body(ax, sampled.outline)

    rotation = np.exp(1j * phase)
    h_hat, theta_hat = pair.solid[0], pair.solid[1]
    h, theta = (h_hat * rotation).real, (theta_hat * rotation).real
    scale = mode_display_scale(kind, pair.solid) if n_solid else 0.0
    if scale > 0:
        pitch = theta if _pitches(kind) else 0.0
        for k, polygon in enumerate(sampled.outline):
            moved = displaced_outline(polygon, scale * h, scale * pitch)
            label = f"displaced body (×{scale:.3g})" if k == 0 else None
            ax.fill(moved[:, 0], moved[:, 1], fc="none", ec="tab:orange", lw=1.6, zorder=6, label=label)
        arrow = {"angles": "xy", "scale_units": "xy", "scale": 1.0, "width": 0.004, "zorder": 7}
        ax.quiver([0.0], [0.0], [0.0], [scale * h], color="tab:red", label=f"heave h (×{scale:.3g})", **arrow)
        if _pitches(kind):
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
                zorder=7,
            )
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2, frameon=False)
    ax.set_xlim(*window[0])
    ax.set_ylim(*window[1])
    ax.set_aspect("equal")
    ax.set_xlabel("X")
    ax.set_ylabel("Y")
    ax.set_title(
        f"{kind}, Re = {steady.flow.reynolds:g}, α0 = {steady.flow.alpha0_deg:g}°: "
        f"σ = {pair.value.real:+.5f} + {pair.value.imag:.5f}i ({pair.label}), phase {phase:.3g}"
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


@_styled
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


@_styled
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
    axes[1].legend()
    axes[0].set_title(title or "eigenvalue branches (filled: unstable)")
    return save_figure(fig, path)


def _reciprocal(values):
    """``1/x`` with ``1/0 = inf`` and no warning (matplotlib probes secondary axes at 0)."""
    values = np.asarray(values, dtype=float)
    return np.divide(1.0, values, out=np.full_like(values, np.inf), where=values != 0)


_KIND_COLOURS = {"flutter": "tab:red", "viv": "tab:blue"}
# 1, 2, ≥ 3 unstable modes, light to dark: purples, apart from the red and blue of the curves
_UNSTABLE_COLOURS = ("#ebe5f2", "#cbbde0", "#a38cc6")
SIDE_BAND = 1.08  # the unstable-side band of a curve spans U* to U* · 1.08^side (log axis: constant width)
UNRESOLVED_LISTED = 4  # places of unresolved intervals named on a map (the others counted)
UNRESOLVED_GAP = 0.01  # relative gap below which unresolved intervals are one place on a map


def _side_bands(masses, velocities, side) -> list[np.ndarray]:
    """Quadrilaterals ``(4, 2)`` along a curve, one per segment whose two ends have the same known
    unstable side, spanning ``U*`` to ``U* · SIDE_BAND^side`` (the side where a growth rate is
    positive at fixed m)."""
    if side is None:
        return []
    masses, velocities = np.asarray(masses, dtype=float), np.asarray(velocities, dtype=float)
    side = np.asarray(side, dtype=int)
    quads = []
    for k in range(len(side) - 1):
        if side[k] and side[k] == side[k + 1]:
            factor = SIDE_BAND ** side[k]
            quads.append(
                np.array(
                    [
                        (masses[k], velocities[k]),
                        (masses[k + 1], velocities[k + 1]),
                        (masses[k + 1], velocities[k + 1] * factor),
                        (masses[k], velocities[k] * factor),
                    ]
                )
            )
    return quads


def unresolved_clusters(unresolved, gap: float = UNRESOLVED_GAP) -> list[tuple[float, float, str, int]]:
    """``(low, high, reason, count)``: the unresolved intervals ``(low, high, reason)`` of one
    reason merged where they touch or lie within ``gap`` (relative) of each other, in increasing
    frequency. A refinement that stalls near one frequency leaves hundreds of adjacent intervals
    (e.g. 587 within ω ∈ [0.01629, 0.01631] on the coarse plate at Re 500, α0 = 10°): one line."""
    clusters: list[list] = []
    for low, high, reason in sorted(unresolved, key=lambda r: (str(r[2]), float(r[0]))):
        low, high = float(low), float(high)
        last = clusters[-1] if clusters else None
        if last is not None and last[2] == reason and low <= last[1] * (1.0 + gap):
            last[1], last[3] = max(last[1], high), last[3] + 1
        else:
            clusters.append([low, high, reason, 1])
    return sorted((tuple(c) for c in clusters), key=lambda c: c[0])


def _unresolved_note(unresolved) -> str:
    """The unresolved frequency intervals of the transfer method, merged into clusters
    (:func:`unresolved_clusters`), one line each (the first few), under a header that says whether
    a curve may be missing there (not where every interval is a fold, which curves are drawn
    through)."""
    unresolved = list(unresolved)
    if not unresolved:
        return ""
    clusters = unresolved_clusters(unresolved)
    lines = [
        f"ω ∈ [{low:.4g}, {high:.4g}]" + (f" ({count} intervals)" if count > 1 else "") + f": {reason}"
        for low, high, reason, count in clusters[:UNRESOLVED_LISTED]
    ]
    if len(clusters) > UNRESOLVED_LISTED:
        rest = clusters[UNRESOLVED_LISTED:]
        lines.append(f"and {sum(c[3] for c in rest)} more in {len(rest)} places")
    count = len(unresolved)
    # a fold in ω is joined through by the map (fsistab.transfer_map); other reasons may hide a curve
    folds = all(reason == "fold" for _, _, reason in unresolved)
    why = "curves drawn through their folds" if folds else "curves may be missing there"
    header = f"{count} unresolved frequency interval{'s' if count > 1 else ''} ({why}):"
    return "\n".join([header, *lines])


@_styled
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
    unresolved=(),
    unshaded=(),
) -> Path:
    """Neutral curves in log–log ``(m, U*)`` axes with a second axis ``ω_θ = 1/U*`` (docs/model.md §8).

    ``curves``: list of ``(kind, mass_ratios, reduced_velocities)`` for the dynamic neutral curves
    (kind ``flutter`` or ``viv``, red and blue, numbered as in the tables when there are several), in
    order of arclength; ``divergence``: ``(mass_ratios, reduced_velocities)``, static instability
    above it (grey). ``sides``: per curve, the unstable side of each point (+1: larger U*, −1:
    smaller, 0: unknown; :class:`fsistab.neutral_map.NeutralCurve`), shaded as a narrow band along the curve
    on that side (:func:`_side_bands`): exact, and readable however many curves cross. ``unstable =
    (m, U*, count)`` (1-D, 1-D, len(U*) × len(m)), when known
    (:func:`fsistab.transfer_map.unstable_grid`), shades the exact unstable regions, darker with more
    unstable modes (instead of the grey). ``turning_points`` (▽) and ``crossings`` (codimension-two
    points, ★) are ``(m, U*)`` pairs; ``reference``: ``(m, U*)`` points of another method (open
    circles); ``unresolved``: ``(low, high, reason)`` frequency intervals the transfer method left
    unresolved, listed in a box; ``unshaded``: ``(kind, m_low, m_high)``, families whose unstable
    region is left out of the shading over that range of m (a curve missing), listed under it. The
    legend is under the axes, where it hides nothing.
    """
    fig, ax = plt.subplots(figsize=(7.0, 5.0))
    m_div = np.asarray(divergence[0], dtype=float)
    shading, bottom, top = _map_regions(ax, curves, divergence, unstable)
    shading += _map_curves(ax, curves, sides)
    _map_markers(ax, reference, turning_points, crossings)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(bottom, top)
    if len(m_div):  # the map's mass range, which the divergence line spans: a curve's first point
        # beyond it (kept so that its line reaches the edge) does not widen the axes
        ax.set_xlim(m_div.min(), m_div.max())
    ax.set_xlabel("mass ratio m")
    ax.set_ylabel("reduced velocity U*")
    secondary = ax.secondary_yaxis("right", functions=(_reciprocal, _reciprocal))
    secondary.set_ylabel("ω_θ = 1/U*")
    ax.grid(alpha=0.3, which="major")
    ax.grid(alpha=0.1, which="minor")  # light: over the shading, many minor lines hide the curves
    lines, names = ax.get_legend_handles_labels()
    legend = ax.legend(
        lines + shading,
        names + [h.get_label() for h in shading],
        loc="upper center",
        bbox_to_anchor=(0.5, -0.12),
        ncol=3,
        frameon=False,
    )
    ax.set_title(title or "stability map")
    gaps = [f"{kind} not shaded at m ∈ [{a:.3g}, {b:.3g}]: a curve missing" for kind, a, b in unshaded]
    note = "\n".join([_unresolved_note(unresolved), *gaps]).strip()
    if note:  # under the legend: nothing of the map is hidden
        fig.draw_without_rendering()
        below = legend.get_window_extent().transformed(fig.transFigure.inverted())
        fig.text(below.x0, below.y0, note, va="top", ha="left", fontsize="small")
    return save_figure(fig, path)


def _map_regions(ax, curves, divergence, unstable) -> tuple[list, float, float]:
    """The unstable regions of a map: the exact count of unstable modes (``unstable``) or, without
    it, grey above the divergence line; the line itself. Returns the legend patches and the U*
    limits of the axes."""
    from matplotlib.patches import Patch

    m_div, u_div = (np.asarray(a, dtype=float) for a in divergence)
    ok = np.isfinite(u_div)
    all_u = np.concatenate([np.asarray(v, dtype=float) for _, _, v in curves] + [u_div[ok], [1.0]])
    all_u = all_u[np.isfinite(all_u) & (all_u > 0)]
    top, bottom = all_u.max() * 1.5, all_u.min() / 1.5
    shading = []
    if unstable is not None:
        m_grid, u_grid, counts = (np.asarray(a, dtype=float) for a in unstable)
        top, bottom = max(top, u_grid.max()), min(bottom, u_grid.min())
        filled = ax.contourf(
            m_grid, u_grid, counts, levels=[0.5, 1.5, 2.5, np.inf], colors=_UNSTABLE_COLOURS, zorder=0
        )
        filled.set_rasterized(True)
        names = ("1 unstable mode", "2 unstable modes", "≥ 3 unstable modes")
        shading += [Patch(fc=c, ec="none", label=n) for c, n in zip(_UNSTABLE_COLOURS, names, strict=True)]
    if ok.any():
        ax.plot(m_div[ok], u_div[ok], color="k", lw=1.5, label="divergence")
        if unstable is None:
            ax.fill_between(m_div[ok], u_div[ok], top * 10, color="0.9", lw=0, zorder=0)
            shading.append(Patch(fc="0.9", ec="none", label="static divergence"))
    return shading, bottom, top


def _map_curves(ax, curves, sides) -> list:
    """The dynamic neutral curves (numbered when there are several) and the bands on their
    unstable side; the legend patch of the bands, if any."""
    from matplotlib.collections import PolyCollection
    from matplotlib.patches import Patch

    labelled = set()
    for i, (kind, masses, velocities) in enumerate(curves):
        masses, velocities = np.asarray(masses, dtype=float), np.asarray(velocities, dtype=float)
        colour = _KIND_COLOURS.get(kind, "tab:purple")
        label = kind if kind not in labelled else None
        labelled.add(kind)
        ax.plot(masses, velocities, "-", color=colour, lw=1.8, label=label, zorder=3)
        if len(curves) > 1 and len(masses):
            middle = len(masses) // 2
            ax.annotate(
                str(i),
                (masses[middle], velocities[middle]),
                xytext=(3, 3),
                textcoords="offset points",
                color=colour,
                fontweight="bold",
                zorder=6,
            )
    banded = False
    for (kind, masses, velocities), side in zip(curves, sides or [None] * len(curves), strict=True):
        quads = _side_bands(masses, velocities, side)
        if quads:
            colour = _KIND_COLOURS.get(kind, "tab:purple")
            ax.add_collection(PolyCollection(quads, fc=colour, ec="none", alpha=0.3, zorder=2, gid="side"))
            banded = True
    return [Patch(fc=_KIND_COLOURS["flutter"], ec="none", alpha=0.3, label="unstable side")] if banded else []


def _map_markers(ax, reference, turning_points, crossings) -> None:
    """Points of another method (○), turning points (▽) and codimension-two points (★)."""
    if len(reference):
        m_r, u_r = np.asarray(reference, dtype=float).T
        ax.plot(m_r, u_r, "o", color="k", ms=3.5, mfc="none", mew=0.7, label="continuation", zorder=4)
    if len(turning_points):
        m_t, u_t = np.asarray(turning_points, dtype=float).T
        ax.plot(m_t, u_t, "v", color="k", ms=6, mfc="none", label="turning point", zorder=5)
    if len(crossings):
        m_c, u_c = np.asarray(crossings, dtype=float).T
        ax.plot(m_c, u_c, "*", color="tab:green", mec="k", mew=0.4, ms=11, label="codimension two", zorder=5)


@_styled
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


@_styled
def plot_onset(ds, path: Path, title: str = "") -> Path:
    """The growth rate ``λ`` and frequency ``ω`` of the fixed body's leading mode at the secant's
    iterates (:func:`fsistab.onset.onset_dataset`) against the flow parameter (Re, on a log axis when
    the iterates span more than a factor 3; or α0 in degrees), the critical value where ``λ = 0``
    marked with its ``ω_c``."""
    parameter = ds.attrs["parameter"]
    order = np.argsort(ds.value.values)
    values = ds.value.values[order]
    critical, frequency = float(ds.attrs["critical_value"]), float(ds.attrs["frequency"])
    label = "Re" if parameter == "reynolds" else "α0 [deg]"
    fig, (ax_rate, ax_freq) = plt.subplots(1, 2, figsize=(10.0, 3.8))
    fig.subplots_adjust(wspace=0.3)
    ax_rate.plot(values, ds.growth_rate.values[order], "o-", ms=4, label="iterates")
    ax_rate.axhline(0.0, color="k", lw=0.8)
    ax_rate.set_ylabel("growth rate λ (fixed body)")
    ax_freq.plot(values, ds.frequency.values[order], "o-", ms=4, label="iterates")
    ax_freq.set_ylabel("frequency ω [U∞/L]")
    ax_rate.plot(
        [critical], [0.0], "*", color="tab:red", ms=12, label=f"critical {label.split()[0]} = {critical:.5g}"
    )
    ax_freq.plot([critical], [frequency], "*", color="tab:red", ms=12, label=f"ω_c = {frequency:.5g}")
    for ax in (ax_rate, ax_freq):
        ax.set_xlabel(label)
        if parameter == "reynolds" and values.max() > 3 * values.min():  # a narrow range reads better linear
            ax.set_xscale("log")
        ax.grid(alpha=0.3)
        ax.legend(fontsize="small")
    fig.suptitle(title)
    return save_figure(fig, path)


@_styled
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
    ax.legend(loc="upper left")
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


@_styled
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
            ax.set_title(f"{'Re' if part == 'real' else 'Im'} {symbol}/{unit}")
            ax.set_xscale("log")
            ax.grid(alpha=0.3, which="both")
            if row == 1:
                ax.set_xlabel("k = ω c / (2 U∞)")
    axes[0, 0].legend()
    fig.suptitle(title or f"viscous Theodorsen function, Re = {ds.attrs.get('reynolds', float('nan')):g}")
    fig.tight_layout()
    return save_figure(fig, path)


@_styled
def plot_slopes(ds, path: Path, title: str = "") -> Path:
    """Static slopes ``dC_L/dα`` and ``d(-C_M)/dα`` (per radian, α = -θ, docs/model.md §9) against Re,
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
        ax.legend()
    fig.suptitle(
        title or f"static slopes, α0 = {ds.attrs.get('alpha0_deg', 0):g}°, mesh {ds.attrs.get('mesh', '')}"
    )
    fig.tight_layout()
    return save_figure(fig, path)


# --- figures of the workflows' Datasets (fsistab.workflows) -----------------------------------------


@_styled
def plot_map(ds, path: Path, title: str = "") -> Path:
    """The stability map of :func:`fsistab.workflows.stability_map` (its Dataset) by
    :func:`plot_stability_map`: curves (legend by kind: flutter, viv), divergence, turning points,
    codimension-two points (★), unstable-side bands and, for the transfer method, the unstable
    regions of ``unstable_count`` and the unresolved frequency intervals."""
    from fsistab.neutral_map import map_curves, unshaded_families

    unstable = None
    if "unstable_count" in ds:
        unstable = (ds.grid_mass_ratio.values, ds.grid_reduced_velocity.values, ds.unstable_count.values)
    if not title and {"reynolds", "alpha0_deg"} <= set(ds.attrs):
        title = f"stability map, Re = {ds.attrs['reynolds']:g}, α0 = {ds.attrs['alpha0_deg']:g}°"
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
        unresolved=list(
            zip(ds.unresolved_low.values, ds.unresolved_high.values, ds.unresolved_reason.values, strict=True)
        )
        if "unresolved_low" in ds
        else (),
        unshaded=unshaded_families(ds),
    )


@_styled
def plot_flow_neutral_curves(ds, path: Path, title: str = "") -> Path:
    """The curves of :func:`fsistab.workflows.flow_neutral_curves` by :func:`plot_flow_neutral`."""
    from fsistab.flow_neutral import flow_curves

    curves = [(kind, values, u, fp, fu) for kind, _, values, u, _, fp, fu, _ in flow_curves(ds)]
    return plot_flow_neutral(curves, ds.attrs["parameter"], path, title=title)


@_styled
def plot_theodorsen_comparison(ds, path: Path, title: str = "") -> Path:
    """The Dataset of :func:`fsistab.workflows.theodorsen_comparison` by
    :func:`plot_theodorsen_map`, with the viscous curves and the relative error if it has them."""
    from fsistab.theodorsen import viscous_curves

    comparison = None
    if "comparison_mass_ratio" in ds and ds.sizes.get("comparison", 0):
        comparison = (ds.comparison_mass_ratio.values, ds.comparison_relative_error.values)
    return plot_theodorsen_map(ds, path, viscous=viscous_curves(ds), comparison=comparison, title=title)


# --- parameter studies (fsistab.study) -------------------------------------------------------------

NO_THRESHOLD = "no threshold in the U* range"
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


@_styled
def plot_study_coefficients(ds, path: Path, title: str = "") -> Path:
    """Steady ``C_L``, ``C_M`` (about G) and the recirculation length of a study
    (:func:`fsistab.study.run_study` with slopes) against α0 (one line per Re), or against Re."""
    x_dim, line_dim = _study_axis(ds)
    names = [
        ("lift_coefficient", "$C_L$"),
        ("moment_coefficient", "$C_M$ (about the pitch axis)"),
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
    axes[0].legend()
    fig.suptitle(title)
    return save_figure(fig, path)


@_styled
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
            ax.legend()
        else:
            k = 0
            for value in ds[line_dim].values:
                for mass in ds.mass_ratio.values:
                    sub = ds.sel({line_dim: value, "mass_ratio": mass})
                    colour = colours[k % len(colours)]
                    k += 1
                    restabilising = sub.threshold_boundary.values == "restabilisation"
                    for kind, marker in _STUDY_MARKERS.items():
                        for open_marker in (False, True):
                            mask = (sub.threshold_class.values == kind) & (restabilising == open_marker)
                            xs = np.broadcast_to(x[:, None], mask.shape)[mask]
                            velocities = sub.threshold_reduced_velocity.values[mask]
                            # onsets filled, restabilisations open: which side is unstable
                            face = "none" if open_marker else colour
                            ax.scatter(xs, velocities, marker=marker, facecolors=face, edgecolors=colour)
                    ax.plot([], [], "-", color=colour, label=f"{_study_label(line_dim, value)}, m = {mass:g}")
            for kind, marker in _STUDY_MARKERS.items():
                ax.scatter([], [], marker=marker, color="grey", label=kind)
            if (ds.threshold_boundary.values == "restabilisation").any():
                open_marker = {"facecolors": "none", "edgecolors": "grey"}
                ax.scatter([], [], marker="o", label="open: restabilisation", **open_marker)
            ax.set_ylabel("critical U*")
            velocities = ds.threshold_reduced_velocity.values
            if np.any(np.isfinite(velocities) & (velocities > 0)):
                ax.set_yscale("log")
                # plain numbers on the log axis (5, 6, 8 rather than 5×10⁰)
                ax.yaxis.set_major_formatter(matplotlib.ticker.LogFormatter())
                ax.yaxis.set_minor_formatter(matplotlib.ticker.LogFormatter(minor_thresholds=(2, 0.5)))
            else:  # no threshold anywhere in the study's U* range: say so (a log axis needs one)
                ax.text(0.5, 0.5, NO_THRESHOLD, transform=ax.transAxes, ha="center", va="center")
                low, high = float(np.min(x)), float(np.max(x))  # nothing drawn sets the abscissa
                ax.set_xlim(*((low / 1.2, high * 1.2) if x_dim == "reynolds" else (low - 1.0, high + 1.0)))
            # one entry per (flow point, mass ratio): beside the axes, where it hides no marker
            ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.02, 1.0))
        ax.set_xlabel("α0 [deg]" if x_dim == "alpha0" else "Re")
        if x_dim == "reynolds":
            ax.set_xscale("log")
        ax.grid(alpha=0.3)
    fig.suptitle(title)
    return save_figure(fig, path)


@_styled
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
    ax.legend(title="flutter/VIV —, divergence --", loc="upper left", bbox_to_anchor=(1.02, 1.0))
    ax.set_title(title)
    return save_figure(fig, path)


# --- adjoint sensitivity maps (fsistab.sensitivity) --------------------------------------------------


def map_window(kind: str):
    """The region drawn around the body (body lengths): near the plate, the cylinder's near wake."""
    return body_type(kind).sensitivity_window


def _map_panel(fig, ax, sampled, values, window, label, symmetric=True) -> None:
    from matplotlib.ticker import MaxNLocator

    tri = sampled.triangulation
    xy = np.column_stack([tri.x, tri.y])
    inside = (
        (xy[:, 0] >= window[0][0])
        & (xy[:, 0] <= window[0][1])
        & (xy[:, 1] >= window[1][0])
        & (xy[:, 1] <= window[1][1])
    )
    finite = np.abs(values[inside & np.isfinite(values)])
    vmax = float(np.quantile(finite, 0.995)) if finite.size else 1.0
    vmax = vmax if vmax > 0 else 1.0
    if symmetric:
        levels, cmap, shown = np.linspace(-vmax, vmax, 41), "RdBu_r", np.clip(values, -vmax, vmax)
    else:
        levels, cmap, shown = np.linspace(0, vmax, 41), "viridis", np.clip(values, 0, vmax)
    cs = ax.tricontourf(tri, shown, levels=levels, cmap=cmap, extend="both" if symmetric else "max")
    cs.set_rasterized(True)
    bar = fig.colorbar(cs, ax=ax, label=label, shrink=0.85, format="%.2g")
    ticks = MaxNLocator(7, symmetric=symmetric).tick_values(-vmax if symmetric else 0.0, vmax)
    bar.set_ticks(ticks[(ticks >= (-vmax if symmetric else 0.0)) & (ticks <= vmax)])
    ax.set_xlim(*window[0])
    ax.set_ylim(*window[1])
    ax.set_aspect("equal")
    ax.set_xlabel("X")
    ax.set_ylabel("Y")


def plot_sensitivity_maps(maps, steady, path: Path, scale: float = 1.0) -> Path:
    """One row per target: where a control cylinder moves the threshold (``δU*_c``, body
    conventions: ``scale`` = :func:`fsistab.params.body_velocity_scale`) or the fixed body's
    growth rate (``Re δσ``), and the structural sensitivity ``‖û†‖‖û‖``. Drawn on the sampled
    mesh (:func:`sample_mesh`), the body over it."""
    from fsistab.errors import InputError

    if not maps:
        raise InputError("no sensitivity map to draw")
    kind = steady.mesh_spec.body.kind
    window = map_window(kind)
    sampled = sample_mesh(steady.mesh, 3, window)
    with figure_style():
        fig, axes = plt.subplots(len(maps), 2, figsize=(11.0, 2.9 * len(maps) + 0.4), squeeze=False)
        for row, m in zip(axes, maps, strict=True):
            control = sampled.values(m.control[0])
            if m.slope is not None:
                values = -control / m.slope.real * scale
                label = f"δU*_c, cylinder d = {m.diameter:g}, C_d = {m.drag:g}"
            else:
                values, label = control, f"Re δσ, cylinder d = {m.diameter:g}, C_d = {m.drag:g}"
            _map_panel(fig, row[0], sampled, values, window, label)
            _map_panel(fig, row[1], sampled, sampled.values(m.structural), window, "‖û†‖ ‖û‖", False)
            name = f"{m.kind}, σ = {m.value.real:+.4f}{m.value.imag:+.4f}i"
            row[0].set_title(f"{name}: control cylinder at (X, Y)")
            row[1].set_title(f"{m.kind}: structural sensitivity")
            for ax in row:
                draw_body(ax, sampled.outline)
        fig.suptitle(
            f"{kind}, Re = {steady.flow.reynolds:g}, α0 = {steady.flow.alpha0_deg:g}°: adjoint sensitivities"
        )
        fig.tight_layout()
        return save_figure(fig, path)


# --- thresholds along U* (fsistab critical) -----------------------------------------------------------

_THRESHOLD_COLOURS = {"flutter": "tab:red", "viv": "tab:blue", "divergence": "tab:green"}


@_styled
def plot_thresholds(ds, path: Path, title: str = "") -> Path:
    """The thresholds of :func:`fsistab.workflows.critical_points` over the U* range searched:
    ``ω_c/ω_n`` (the solid's natural frequency: ω_θ of the plate, ω_h of the cylinder) at each
    ``U*_c``, coloured by kind, filled where the body loses stability (onset)
    and open where it regains it (restabilisation); the range searched shaded."""
    lo, hi = (float(v) for v in ds.attrs["velocity_range"])
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    ax.axvspan(lo, hi, color="0.93", zorder=0, label="U* range searched")
    for kind, colour in _THRESHOLD_COLOURS.items():
        for boundary, fill in (("onset", colour), ("restabilisation", "white")):
            sel = (ds.kind.values == kind) & (ds.boundary.values == boundary)
            if sel.any():
                u, ratio = ds.reduced_velocity.values[sel], ds.frequency_ratio.values[sel]
                ax.plot(u, ratio, "o", mfc=fill, mec=colour, ms=8, ls="none", label=f"{kind} {boundary}")
    if not ds.sizes.get("threshold", 0):
        ax.text(0.5, 0.5, "no threshold in this range", transform=ax.transAxes, ha="center", va="center")
    ax.set_xscale("log")
    ax.set_xlim(lo / 1.1, hi * 1.1)
    for axis_ticks in (ax.xaxis.set_major_formatter, ax.xaxis.set_minor_formatter):
        axis_ticks(matplotlib.ticker.FormatStrFormatter("%g"))  # a short range: plain U* under each tick
    ax.set_xlabel("reduced velocity U*")
    ax.set_ylabel("ω_c/ω_n (ω_θ: plate, ω_h: cylinder)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize="small")
    ax.set_title(title or "thresholds along U*")
    return save_figure(fig, path)


@_styled
def plot_lco(ds, path: Path, title: str = "") -> Path:
    """The bifurcation diagram of ``fsistab lco`` (:func:`fsistab.lco.limit_cycles`): the saturated
    amplitudes of the moving degrees of freedom against U* (filled: saturated; open: not, with a bar
    over the range of a modulated one's period amplitudes; triangles down: the sweep by decreasing
    U*), the linear thresholds dashed; beside it the frequency of the
    leading signal with the in-vacuo natural frequency."""
    from fsistab.lco import signals

    u = ds.reduced_velocity.values
    names = signals(ds)
    fig, (ax_amp, ax_freq) = plt.subplots(1, 2, figsize=(10.0, 3.8))
    fig.subplots_adjust(wspace=0.3)
    for name, colour in zip(names, ("tab:blue", "tab:orange"), strict=False):
        for prefix, marker, label in (("", "o", "increasing U*"), ("decreasing_", "v", "decreasing U*")):
            if f"{prefix}{name}_amplitude" not in ds:
                continue
            amp = ds[f"{prefix}{name}_amplitude"].values
            held = ds[f"{prefix}{name}_saturated"].values == 1
            unit = " [rad]" if name == "pitch" else ""
            ax_amp.plot(u, amp, "-", color=colour, lw=0.8, alpha=0.6)
            if held.any():
                ax_amp.plot(u[held], amp[held], marker, color=colour, ms=5, label=f"{name}{unit}, {label}")
            if (~held).any():
                ax_amp.plot(u[~held], amp[~held], marker, color=colour, ms=5, mfc="none",
                            label=f"{name}{unit}, {label}, not saturated")  # fmt: skip
            modulated = ds[f"{prefix}{name}_state"].values == "modulated"
            if modulated.any() and f"{prefix}{name}_low" in ds:  # the range of its period amplitudes
                low, high = (ds[f"{prefix}{name}_{k}"].values[modulated] for k in ("low", "high"))
                ax_amp.vlines(u[modulated], low, high, color=colour, lw=1.5)
            if not prefix:
                ax_freq.plot(u, ds[f"{name}_frequency"].values, marker + "-", color=colour, ms=4, label=name)
    for ax in (ax_amp, ax_freq):
        for k, threshold in enumerate(ds.threshold_velocity.values):
            ax.axvline(
                threshold, color="tab:red", ls="--", lw=1, label="linear threshold" if k == 0 else None
            )
        ax.set_xlabel("U*")
        ax.grid(alpha=0.3)
    scale = body_type(ds.attrs["body"]).velocity_scale
    natural = np.linspace(u.min(), u.max(), 50) if len(u) > 1 else u
    ax_freq.plot(natural, scale / natural, ":", color="k", label="in-vacuo natural frequency")
    ax_amp.set_ylim(bottom=0.0)
    ax_amp.set_ylabel("amplitude (half peak-to-peak)")
    ax_freq.set_ylabel("frequency ω [U∞/L]")
    for ax in (ax_amp, ax_freq):
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize="small")
    fig.suptitle(title)
    return save_figure(fig, path)


@_styled
def plot_time_series(ds, path: Path, title: str = "") -> Path:
    """A march's time series (``fsistab simulate``, one point of ``fsistab lco``): the moving
    degrees of freedom (heave in L, pitch in rad) above, the lift and drag coefficients below."""
    t = ds.time.values
    fig, (ax_solid, ax_loads) = plt.subplots(2, 1, figsize=(9.0, 5.2), sharex=True)
    dofs = [n for n in ("heave", "pitch") if n in ds.attrs.get("dofs", "")]
    for name in dofs or ["heave"]:
        ax_solid.plot(t, ds[name].values, lw=0.9, label=name + (" [rad]" if name == "pitch" else " [L]"))
    ax_loads.plot(t, ds.lift_coefficient.values, lw=0.9, label="lift coefficient $C_L$")
    ax_loads.plot(t, ds.drag_coefficient.values, lw=0.9, label="drag coefficient $C_D$")
    ax_loads.set_xlabel("time [L/U∞]")
    for ax in (ax_solid, ax_loads):
        ax.grid(alpha=0.3)
        ax.legend(fontsize="small", loc="upper left")
    fig.suptitle(title)
    return save_figure(fig, path)
