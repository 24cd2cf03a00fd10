"""Closed outlines of sections given by points: NACA four-digit sections and curves read from a file
(docs/model.md §11).

An outline is an ``(n, 2)`` array of distinct points in the body frame, counter-clockwise (the
body on the left), starting at its trailing edge (the point of largest ``X``) and not repeating
it at the end; the curve through them is splined by netgen.occ (:func:`outline_face`). Every check
runs here, on the points, before any mesh is made: a bad outline is one :class:`InputError` line.
NumPy and netgen are imported where needed (the command line reads its options first).
"""

from __future__ import annotations

import logging
import math
import re
from pathlib import Path

from fsistab.errors import InputError

CLOSING_GAP = 1.5  # a gap between the last and first points beyond this many spacings: an open curve
MIN_POINTS = 12  # fewer points do not describe a section a spline can follow
CORNER_ANGLE = math.radians(60.0)  # a turn sharper than this at a point is a corner, not a curve
SHORT_SIDE = 4.0  # a side shorter than this many wall sizes is meshed with the corner size
FLAT = 1e-7  # |turning angle| below this (radians): the point lies on a straight side
NACA_POINTS = 121  # points per surface of a NACA section (cosine spacing)
# the thickness polynomial's last coefficient: open (blunt) or closed trailing edge
NACA_LAST = {"open": -0.1015, "closed": -0.1036}
_NACA = re.compile(r"naca(\d)(\d)(\d\d)")


def naca_digits(name: str) -> tuple[float, float, float]:
    """``(m, p, t)`` of a NACA four-digit name (``naca2412``: camber 2 %, at 40 % chord, 12 %
    thick), each checked: thickness 1-40 %, a camber position when there is camber."""
    match = _NACA.fullmatch(name)
    if match is None:
        raise InputError(f"unknown NACA section {name!r}: write naca followed by four digits, e.g. naca0012")
    m, p, t = int(match[1]) / 100, int(match[2]) / 10, int(match[3]) / 100
    if not 0.01 <= t <= 0.40:
        raise InputError(f"NACA thickness must be 1-40 % of the chord, got {name!r}")
    if m > 0 and p == 0:
        raise InputError(f"{name!r} has camber but no camber position (second digit 0)")
    if m == 0 and p > 0:
        raise InputError(
            f"{name!r} has a camber position but no camber (first digit 0): write naca00{name[-2:]}"
        )
    return m, p, t


def naca_outline(name: str, trailing_edge: str = "closed", points: int = NACA_POINTS):
    """The outline of a NACA four-digit section, chord 1 along ``X`` from ``-1/2`` (leading edge)
    to ``1/2``: thickness ``y_t = 5t(0.2969√x - 0.1260x - 0.3516x² + 0.2843x³ + a₄x⁴)`` laid
    perpendicular to the camber line, ``a₄ = -0.1036`` (closed trailing edge) or ``-0.1015`` (the
    original coefficients: a blunt trailing edge 0.021·t... thick, closed by a straight segment),
    ``points`` per surface at cosine spacing (docs/model.md §11)."""
    import numpy as np

    if trailing_edge not in NACA_LAST:
        raise InputError(f"trailing edge must be closed or open, got {trailing_edge!r}")
    m, p, t = naca_digits(name)
    x = 0.5 * (1 - np.cos(np.linspace(0.0, np.pi, points)))
    thickness = (
        5
        * t
        * (0.2969 * np.sqrt(x) - 0.1260 * x - 0.3516 * x**2 + 0.2843 * x**3 + NACA_LAST[trailing_edge] * x**4)
    )
    if m > 0:
        front = x < p
        camber = np.where(
            front, m / p**2 * (2 * p * x - x**2), m / (1 - p) ** 2 * (1 - 2 * p + 2 * p * x - x**2)
        )
        slope = np.where(front, 2 * m / p**2 * (p - x), 2 * m / (1 - p) ** 2 * (p - x))
    else:
        camber, slope = np.zeros_like(x), np.zeros_like(x)
    phi = np.arctan(slope)
    upper = np.column_stack([x - thickness * np.sin(phi), camber + thickness * np.cos(phi)])
    lower = np.column_stack([x + thickness * np.sin(phi), camber - thickness * np.cos(phi)])
    outline = np.concatenate([upper[::-1], lower[1:]])  # trailing edge, upper, leading edge, lower
    if trailing_edge == "closed":
        outline = outline[:-1]  # the lower surface ends where the upper one starts
    outline[:, 0] -= 0.5
    return outline


def read_points(path: str | Path):
    """Rows ``x,y`` of a text file (commas, semicolons or blanks between; a header line, blank lines
    and ``#`` comments allowed), as an ``(n, 2)`` array."""
    import numpy as np

    path = Path(path)
    try:
        lines = path.read_text().splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the body file {path}: {exc}") from None
    rows, header_seen = [], False
    for number, line in enumerate(lines, 1):
        text = line.split("#", 1)[0].strip()
        if not text:
            continue
        fields = [f for f in re.split(r"[,;\s]+", text) if f]
        try:
            values = [float(f) for f in fields]
        except ValueError:
            if rows or header_seen:
                raise InputError(
                    f"{path}, line {number}: expected two numbers x,y, got {line.strip()!r}"
                ) from None
            header_seen = True  # the first non-blank line may be a header
            continue
        if len(values) != 2 or not all(math.isfinite(v) for v in values):
            raise InputError(f"{path}, line {number}: expected two finite numbers x,y, got {line.strip()!r}")
        rows.append(values)
    return np.array(rows, dtype=float).reshape(-1, 2)


def closed_outline(points, name: str = "the body curve"):
    """Distinct points of a closed curve: consecutive repeats dropped, the last point dropped if it
    repeats the first. Refused when the last point is farther from the first than 1.5 times the
    largest spacing between consecutive points (an open curve); a smaller gap is closed by a straight
    segment (a blunt trailing edge, or simply the first point not repeated)."""
    import numpy as np

    points = np.asarray(points, dtype=float)
    size = float(np.ptp(points[:, 0])) if len(points) else 0.0
    tol = 1e-9 * max(size, float(np.ptp(points[:, 1])) if len(points) else 0.0, 1e-300)
    keep = np.ones(len(points), dtype=bool)
    keep[1:] = np.hypot(*np.diff(points, axis=0).T) > tol
    points = points[keep]
    if len(points) > 1 and math.dist(points[0], points[-1]) <= tol:
        points = points[:-1]
    if len(points) < MIN_POINTS:
        raise InputError(f"{name} has {len(points)} distinct points: at least {MIN_POINTS} are needed")
    gap = math.dist(points[0], points[-1])
    spacing = float(np.hypot(*np.diff(points, axis=0).T).max())
    if gap > CLOSING_GAP * spacing:
        raise InputError(
            f"{name} is not closed: its last point is {gap:.4g} from its first, more than 1.5 times the "
            f"largest spacing between points ({spacing:.4g}); repeat the first point at the end"
        )
    return points


def signed_area(points) -> float:
    """Signed area of the polygon (positive when counter-clockwise)."""
    import numpy as np

    x, y = points[:, 0], points[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def self_intersection(points) -> tuple[int, int] | None:
    """The first pair of non-adjacent sides ``(i, j)`` of the closed polygon that cross or touch,
    None if it is simple (side ``i`` joins points ``i`` and ``i + 1``)."""
    import numpy as np

    a, b = points, np.roll(points, -1, axis=0)
    n = len(points)

    def orient(p, q, r):
        return (q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1]) - (q[..., 1] - p[..., 1]) * (
            r[..., 0] - p[..., 0]
        )

    def within(p, q, r):  # r in the bounding box of the side p-q (r on its line)
        low, high = np.minimum(p, q), np.maximum(p, q)
        return np.all((r >= low) & (r <= high), axis=-1)

    for i in range(n - 2):
        j = np.arange(i + 2, n if i > 0 else n - 1)  # not the side itself nor its neighbours
        if j.size == 0:
            continue
        d1, d2 = np.sign(orient(a[i], b[i], a[j])), np.sign(orient(a[i], b[i], b[j]))
        d3, d4 = np.sign(orient(a[j], b[j], a[i])), np.sign(orient(a[j], b[j], b[i]))
        crossing = (d1 * d2 < 0) & (d3 * d4 < 0)
        touching = (
            ((d1 == 0) & within(a[i], b[i], a[j]))
            | ((d2 == 0) & within(a[i], b[i], b[j]))
            | ((d3 == 0) & within(a[j], b[j], a[i]))
            | ((d4 == 0) & within(a[j], b[j], b[i]))
        )
        crossing |= touching
        if np.any(crossing):
            return i, int(j[np.argmax(crossing)])
    return None


def normalised_outline(points, reference_length: float | None = None, name: str = "the body curve"):
    """A checked outline in the body frame: closed, simple, counter-clockwise (a clockwise curve is
    reversed, and the log says so), lengths divided by ``reference_length`` (default: the curve's
    extent in ``X``, its chord), the ``X`` extent centred on 0, ``Y`` kept (its line ``Y = 0`` is the
    chord line), starting at the trailing edge (largest ``X``)."""
    import numpy as np

    points = closed_outline(points, name)
    crossing = self_intersection(points)
    if crossing is not None:
        i, j = crossing
        raise InputError(f"{name} intersects itself: its sides from points {i + 1} and {j + 1} cross")
    area = signed_area(points)
    chord = float(np.ptp(points[:, 0]))
    if chord <= 0 or abs(area) <= 1e-12 * chord**2:
        raise InputError(f"{name} encloses no area")
    if area < 0:
        logging.getLogger("fsistab").warning("%s is clockwise: reversed to counter-clockwise", name)
        points = points[::-1]
    scale = chord if reference_length is None else float(reference_length)
    if not (math.isfinite(scale) and scale > 0):
        raise InputError(f"the reference length must be positive and finite, got {reference_length}")
    points = points.copy()
    points[:, 0] -= 0.5 * (points[:, 0].min() + points[:, 0].max())
    points /= scale
    return np.roll(points, -int(np.argmax(points[:, 0])), axis=0)


def turning_angles(points):
    """Signed turning angle of the closed polygon at each point (radians, + counter-clockwise)."""
    import numpy as np

    incoming = points - np.roll(points, 1, axis=0)
    outgoing = np.roll(points, -1, axis=0) - points
    cross = incoming[:, 0] * outgoing[:, 1] - incoming[:, 1] * outgoing[:, 0]
    dot = np.sum(incoming * outgoing, axis=1)
    return np.arctan2(cross, dot)


def _tangent(points, i: int):
    """Unit tangent at point ``i``: the derivative of the parabola through its neighbours, by
    chord length."""
    import numpy as np

    n = len(points)
    before, here, after = points[(i - 1) % n], points[i], points[(i + 1) % n]
    h1, h2 = math.dist(before, here), math.dist(here, after)
    d = (-h2 / (h1 * (h1 + h2))) * before + ((h2 - h1) / (h1 * h2)) * here + (h1 / (h2 * (h1 + h2))) * after
    return d / np.linalg.norm(d)


def outline_breaks(points) -> list[int]:
    """Where the outline is split into sides, in order from 0: the trailing edge (0), the leading
    edge (smallest ``X``), the corners (turns sharper than 60°) and the ends of straight runs."""
    import numpy as np

    n = len(points)
    angles = np.abs(turning_angles(points))
    breaks = {0, int(np.argmin(points[:, 0]))} | set(np.flatnonzero(angles > CORNER_ANGLE).tolist())
    flat = angles < FLAT
    for i in np.flatnonzero(flat & ~np.roll(flat, 1)):  # a straight run starts at point i - 1 ...
        k = i
        while flat[(k + 1) % n] and (k + 1) % n != i:
            k = (k + 1) % n
        breaks |= {(i - 1) % n, (k + 1) % n}  # ... and ends at point k + 1
    return sorted(breaks)


def outline_sides(points):
    """The outline's sides as ``(indices, straight)``: point indices from one break to the next
    (:func:`outline_breaks`), and whether the side is a straight segment (two points, or all its
    inner points flat)."""
    import numpy as np

    n = len(points)
    breaks = outline_breaks(points)
    flat = np.abs(turning_angles(points)) < FLAT
    sides = []
    for start, end in zip(breaks, [*breaks[1:], breaks[0] + n], strict=True):
        indices = [k % n for k in range(start, end + 1)]
        sides.append((indices, bool(np.all(flat[indices[1:-1]]))))
    return sides


def _side_tangents(points, sides):
    """Tangent at each break where the outline is smooth (None at corners): a straight side's
    direction where one meets it, else :func:`_tangent`."""
    import numpy as np

    angles = np.abs(turning_angles(points))
    tangents = {}
    for indices, straight in sides:
        if straight:
            direction = points[indices[-1]] - points[indices[0]]
            for k in (indices[0], indices[-1]):
                tangents[k] = direction / np.linalg.norm(direction)
    for indices, _ in sides:
        k = indices[0]
        if k not in tangents:
            tangents[k] = _tangent(points, k)
    return {k: (None if angles[k] > CORNER_ANGLE else t) for k, t in tangents.items()}


def _meets_short_side(face, p, corner_size: float) -> bool:
    """Whether a side with the corner size ends at point ``p`` (its size needs no more)."""
    for edge in face.edges:
        if edge.maxh <= corner_size:
            for end in (edge.start, edge.end):
                if math.hypot(end.x - p.x, end.y - p.y) < 1e-9:
                    return True
    return False


ARC_TOLERANCE = 1e-8  # points within this of one circle (chords) are an arc of it


def circular_arc(points):
    """The unit tangent at the first point if ``points`` (three or more, turning less than half a
    turn) lie on one circle within ``ARC_TOLERANCE``, else None."""
    import numpy as np

    if len(points) < 3:
        return None
    a, b, c = points[0], points[len(points) // 2], points[-1]
    d = 2 * ((a[0] - c[0]) * (b[1] - c[1]) - (b[0] - c[0]) * (a[1] - c[1]))
    if abs(d) < 1e-300:
        return None
    sa, sb, sc = a @ a, b @ b, c @ c
    centre = np.array(
        [
            (sa * (b[1] - c[1]) + sb * (c[1] - a[1]) + sc * (a[1] - b[1])) / d,
            (sa * (c[0] - b[0]) + sb * (a[0] - c[0]) + sc * (b[0] - a[0])) / d,
        ]
    )
    radius = np.hypot(*(a - centre))
    if np.max(np.abs(np.hypot(*(points - centre).T) - radius)) > ARC_TOLERANCE:
        return None
    turns = turning_angles(np.vstack([points, centre]))[1:-1]  # the turns between the arc's chords
    if abs(float(np.sum(turns))) >= math.pi or not (np.all(turns > 0) or np.all(turns < 0)):
        return None
    sense = 1.0 if turns[0] > 0 else -1.0  # counter-clockwise about the centre, or clockwise
    radial = (a - centre) / radius
    return sense * np.array([-radial[1], radial[0]])


def outline_face(points, wall_size: float, corner_size: float, name: str):
    """The outline as a netgen.occ face: straight sides as lines, sides whose points lie on a circle
    as its arcs, the others as interpolating splines (``WorkPlane.Spline``) tangent to their
    neighbours where the outline is smooth; every
    edge named ``name`` with ``wall_size``, or ``corner_size`` if shorter than four wall sizes (the
    short sides and corner arcs of a blunt body), the breaks (trailing and leading edges, corners,
    ends of straight sides) with ``corner_size``."""
    from netgen.occ import WorkPlane, gp_Pnt2d, gp_Vec2d

    sides = outline_sides(points)
    tangents = _side_tangents(points, sides)
    wp = WorkPlane().MoveTo(*points[0])
    for indices, straight in sides:
        if straight:
            wp.LineTo(*points[indices[-1]])
            continue
        arc = circular_arc(points[indices])
        if arc is not None:  # points on a circle: the arc itself (a plate's rounded corner)
            wp.ArcTo(*points[indices[-1]], gp_Vec2d(*arc))
            continue
        given = {}
        for position, k in ((0, indices[0]), (len(indices) - 1, indices[-1])):
            if tangents[k] is not None:
                given[position] = gp_Vec2d(*tangents[k])
        wp.Spline([gp_Pnt2d(*points[k]) for k in indices[1:]], tangents=given)
    face = wp.Face()
    breaks = points[[indices[0] for indices, _ in sides]]
    for edge in face.edges:
        edge.name = name
        edge.maxh = corner_size if edge.mass < SHORT_SIDE * wall_size else wall_size
    for vertex in face.vertices:
        p = vertex.p
        if min(math.hypot(p.x - bx, p.y - by) for bx, by in breaks) < 1e-9 and not _meets_short_side(
            face, p, corner_size
        ):
            vertex.maxh = corner_size
    return face


def is_mirror_symmetric(points, tol: float = 1e-9) -> bool:
    """Whether the outline is its own mirror image about ``Y = 0`` (the same set of points)."""
    import numpy as np

    mirrored = points * np.array([1.0, -1.0])
    order = np.lexsort((points[:, 1], points[:, 0]))
    image = np.lexsort((mirrored[:, 1], mirrored[:, 0]))
    return bool(np.allclose(points[order], mirrored[image], rtol=0.0, atol=tol))


PROJECTION_SPACING = 2.5e-4  # grid of the tabulated projection (chords)
PROJECTION_SAMPLES = 2e-4  # spacing of the points of the wall's polyline it projects on (chords)
PROJECTION_BAND = 3e-3  # grid points farther from the wall keep themselves (never read at the wall)


def _closest_on_polyline(polyline, first, points, nearest):
    """Closest point of ``points`` on the polyline sides next to their ``nearest`` vertex (sides
    join vertices ``k`` and ``k + 1`` of the same edge: ``first[k + 1]`` is False)."""
    import numpy as np

    best = polyline[nearest].copy()
    best_distance = np.hypot(*(points - best).T)
    for shift in (-1, 0):  # the side before and the side after the nearest vertex
        a = np.clip(nearest + shift, 0, len(polyline) - 2)
        valid = ~first[a + 1]
        side = polyline[a + 1] - polyline[a]
        t = np.clip(
            np.sum((points - polyline[a]) * side, axis=1) / np.maximum(np.sum(side**2, axis=1), 1e-300), 0, 1
        )
        candidate = polyline[a] + t[:, None] * side
        distance = np.hypot(*(points - candidate).T)
        better = valid & (distance < best_distance)
        best[better], best_distance[better] = candidate[better], distance[better]
    return best


def upper_projection(face, margin: float = 0.004):
    """The closest point on the part ``Y ≥ 0`` of the face's wall, tabulated on a grid covering it
    (``margin`` around it) as ``(start, end, px, py)`` (``px``, ``py`` of shape ``(ny, nx)``, ``x``
    fastest: :func:`ngsolve.VoxelCoefficient`'s layout). The wall's edges are sampled every
    ``PROJECTION_SAMPLES`` and each grid point within ``PROJECTION_BAND`` of them projected on that
    polyline; the others keep their own position."""
    import numpy as np
    from scipy.spatial import cKDTree

    polyline, first = [], []
    for edge in face.edges:
        t0, t1 = edge.parameter_interval
        n = max(2, math.ceil(edge.mass / PROJECTION_SAMPLES))
        polyline += [(p.x, p.y) for p in (edge.Value(t) for t in np.linspace(t0, t1, n))]
        first += [True] + [False] * (n - 1)
    polyline, first = np.array(polyline), np.array(first)
    keep = polyline[:, 1] >= -1e-12
    first = (first | ~np.roll(keep, 1))[keep]  # a side starts again after the dropped points
    polyline = upper = polyline[keep]
    start = (upper[:, 0].min() - margin, 0.0)
    end = (upper[:, 0].max() + margin, upper[:, 1].max() + margin)
    nx = math.ceil((end[0] - start[0]) / PROJECTION_SPACING) + 1
    ny = math.ceil((end[1] - start[1]) / PROJECTION_SPACING) + 1
    gx, gy = np.meshgrid(np.linspace(start[0], end[0], nx), np.linspace(start[1], end[1], ny))
    grid = np.column_stack([gx.ravel(), gy.ravel()])
    distance, nearest = cKDTree(polyline).query(grid, distance_upper_bound=PROJECTION_BAND)
    near = np.isfinite(distance)
    closest = grid.copy()
    closest[near] = _closest_on_polyline(polyline, first, grid[near], nearest[near])
    return start, end, closest[:, 0].reshape(ny, nx), np.maximum(closest[:, 1], 0.0).reshape(ny, nx)
