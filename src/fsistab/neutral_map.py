"""The vocabulary of a stability map in the (m, U*) plane (docs/model.md §8), shared by every
method that draws one (continuation, :mod:`fsistab.neutral`; transfer functions,
:mod:`fsistab.transfer_map`; threshold sweeps, :mod:`fsistab.frequency_sweep`).

Neutral points and turning points, dynamic curves labelled flutter or VIV by the one rule
:func:`curve_kind` (the frequency locked at the wake mode's while ``1/U*`` varies: VIV), the
unstable side of every point (:func:`sides_from_role`), the divergence curve
``U*_D(m) = √(m r_θ²/(dC_M/dθ))``, codimension-two crossings of all curves
(:func:`map_crossings`), and the map as one labelled Dataset (:func:`neutral_map_dataset`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from fsistab.continuation import polyline_intersections
from fsistab.errors import ConvergenceError, InputError
from fsistab.neutral_point import NeutralPoint, TurningPoint, divergence_velocity


def divergence_curve(moment_slope: float, r_theta: float, mass_ratios: np.ndarray) -> np.ndarray:
    """``U*_D(m)`` of :func:`divergence_velocity` on ``mass_ratios`` (docs/model.md §8), as the map
    stores it: NaN (no line to draw) where the slope is not positive."""
    velocities = np.asarray(divergence_velocity(moment_slope, r_theta, mass_ratios))
    return np.where(np.isinf(velocities), np.nan, velocities)


@dataclass(frozen=True)
class CurveCrossing:
    """A codimension-two point where two neutral curves cross in the ``(m, U*)`` plane, on segment
    ``segments[0]`` of the first curve and ``segments[1]`` of the second; ``refined`` when the
    ``refine`` callback of :func:`curve_crossings` converged from the interpolated crossing."""

    mass_ratio: float
    reduced_velocity: float
    segments: tuple[int, int]
    refined: bool


def curve_crossings(
    first: Sequence,
    second: Sequence,
    refine: Callable[[float, float, tuple[int, int]], tuple[float, float]] | None = None,
) -> tuple[CurveCrossing, ...]:
    """Crossings of two neutral curves given as sequences of ``(log m, U*)`` points.

    The piecewise-linear interpolants in ``(log m, U*)`` are intersected (error ``O(Δs²)`` times
    the curvature); ``refine(log m, U*, segments)``, if given, returns the crossing refined on the
    curves themselves (e.g. Newton on both neutral systems) — a refinement that raises
    :class:`~fsistab.errors.ConvergenceError` leaves the interpolated crossing, ``refined=False``.
    For a divergence curve use ``(log m, divergence_curve(...))`` on a fine grid of m.
    """
    crossings = []
    for point, i, _, j, _ in polyline_intersections(first, second):
        log_mass, velocity, refined = float(point[0]), float(point[1]), False
        if refine is not None:
            try:
                log_mass, velocity = refine(log_mass, velocity, (i, j))
                refined = True
            except ConvergenceError:
                pass
        crossings.append(CurveCrossing(math.exp(log_mass), float(velocity), (i, j), refined))
    return tuple(crossings)


CURVE_PARAMETERS = ("mass_ratio", "reynolds", "alpha0")


@dataclass(frozen=True)
class NeutralCurve:
    """A neutral curve: the one curve type of every threshold method (continuation in ``(m, U*)``,
    :mod:`fsistab.neutral`; the transfer map, :mod:`fsistab.transfer_map`; continuation in a flow
    parameter, :mod:`fsistab.flow_neutral`). ``points`` in order of arclength, ``parameter`` the
    coordinate that moves with ``U*`` along it: ``mass_ratio``, ``reynolds`` or ``alpha0`` (the
    points' ``alpha0_deg``).

    ``kind`` is ``flutter`` or ``viv`` (:func:`curve_kind`, from its ``frequency_following``) when
    known; ``boundary`` the seed's role (onset or restabilisation) and ``seed_mass_ratio`` where a
    map curve was seeded; per point, ``unstable_sides`` is +1 where the system is unstable for
    larger U* at fixed m, −1 for smaller (0: not known; an empty tuple: unknown for every point).
    ``folds`` are indices after which ``d(parameter)/ds`` changes sign, ``turning_points`` those
    located on the curve; ``stops`` say why each traced direction ended."""

    points: tuple[NeutralPoint, ...]
    parameter: str = "mass_ratio"
    kind: str = ""
    boundary: str = ""
    seed_mass_ratio: float = math.nan
    turning_points: tuple[TurningPoint, ...] = ()
    folds: tuple[int, ...] = ()
    stops: tuple[str, ...] = ()
    factorisations: int = 0
    unstable_sides: tuple[int, ...] = ()
    frequency_following: float = math.nan

    def __post_init__(self):
        if self.parameter not in CURVE_PARAMETERS:
            raise InputError(f"a neutral curve's parameter is one of {', '.join(CURVE_PARAMETERS)}")
        if len(self.unstable_sides) not in (0, len(self.points)):
            raise InputError("unstable_sides needs one value per point of the curve")

    def values(self, name: str) -> np.ndarray:
        """One field of every point (``mass_ratio``, ``reduced_velocity``, ``frequency``, ...)."""
        return np.array([getattr(p, name) for p in self.points], dtype=float)

    @property
    def mass_ratios(self) -> np.ndarray:
        return self.values("mass_ratio")

    @property
    def reduced_velocities(self) -> np.ndarray:
        return self.values("reduced_velocity")

    @property
    def frequencies(self) -> np.ndarray:
        return self.values("frequency")

    def sides(self) -> np.ndarray:
        """``unstable_sides`` as an array, 0 for every point if unknown."""
        return np.array(self.unstable_sides or [0] * len(self.points), dtype=int)

    @property
    def plane_points(self) -> np.ndarray:
        """``(log m, U*)`` of every point (rows), the input of :func:`curve_crossings`."""
        return np.column_stack([np.log(self.mass_ratios), self.reduced_velocities])


VIV_FOLLOWING = 0.5  # a curve whose frequency follows less than half of the solid's is VIV


def following_ratio(dlog_frequency: float, dlog_velocity: float, dlog_mass: float) -> float:
    """``|d log ω| / max(|d log U*|, ½ |d log m|)``: how far the frequency of a neutral curve
    follows the solid's frequency scale when ``(m, U*)`` move by ``(d log m, d log U*)`` along it
    (why these weights: :func:`frequency_following`). The changes are either the ranges over the
    curve's points (:func:`frequency_following`) or the derivatives along its exact tangent at one
    neutral point (:func:`fsistab.frequency_sweep.local_following`). NaN when neither U* nor m
    moves."""
    span = max(abs(dlog_velocity), 0.5 * abs(dlog_mass))
    return abs(dlog_frequency) / span if span > 0 else math.nan


def following_kind(following: float) -> str:
    """``viv`` when a frequency following (:func:`following_ratio`) is below ``VIV_FOLLOWING``,
    ``flutter`` otherwise, also when it is NaN (not measurable)."""
    return "viv" if following < VIV_FOLLOWING else "flutter"


def frequency_following(
    mass_ratios: Sequence[float], reduced_velocities: Sequence[float], frequencies: Sequence[float]
) -> float:
    """How far the frequency of a neutral curve follows the solid's frequency along it:
    ``Δ log ω / max(Δ log U*, ½ Δ log m)``, ``Δ`` the range over its points (NaN with fewer than
    two points or no change in U* and m).

    The solid's frequencies in the fluid are ``(Ω/U*, 1/U*) · √(m/(m + m_a))`` (in-vacuo
    ``Ω/U*``, ``1/U*``, docs/model.md §2-§3, lowered by an added mass ``m_a``): along a curve they move
    by ``Δ log U*``, and by up to ``½ Δ log m`` more through the mass ratio for a light body.
    Along a flutter curve the critical frequency follows them (at large m ``U* ∝ √m`` and
    ``ω U*`` stays O(1): a following near 1); along a VIV curve it stays locked at the frequency of
    the fixed body's wake mode while the solid's passes it (a following near 0). Coarse plate,
    Re = 2900, m ≥ 1, transfer (continuation): 0.03 (0.016) on the VIV window, 0.14 (0.05) on its
    upper lock-in boundary near ω = 10.4 (m from 1 to 1.3 at U* ≈ 0.083, where ``Δ log U*`` alone
    would give 0.8), 0.0006 on the lock-in onset near ω = 11.24; 0.89 on the flutter curve from
    m = 560 to 2700 (continuation)."""
    m = np.asarray(mass_ratios, dtype=float)
    u = np.asarray(reduced_velocities, dtype=float)
    w = np.asarray(frequencies, dtype=float)
    if not len(m) == len(u) == len(w):
        raise InputError("frequency_following needs one mass ratio, U* and frequency per point")
    keep = (m > 0) & (u > 0) & (w > 0) & np.isfinite(m) & np.isfinite(u) & np.isfinite(w)
    if keep.sum() < 2:
        return math.nan
    ranges = (np.ptp(np.log(x[keep])) for x in (w, u, m))
    return float(following_ratio(*ranges))


def curve_kind(
    mass_ratios: Sequence[float], reduced_velocities: Sequence[float], frequencies: Sequence[float]
) -> str:
    """``viv`` or ``flutter``: the family of a dynamic neutral curve from its points (in the mass
    range). **VIV** — the fixed body's wake (fluid) mode locked onto a solid frequency — when its
    :func:`frequency_following` is below ``VIV_FOLLOWING`` (the frequency stays at the wake mode's
    while the solid's moves), **flutter** otherwise (also when it cannot be measured: a single
    point). Both map methods label by this rule, from the curve alone: no wake-frequency hint and
    no extra factorisation; the threshold sweep applies it at each threshold, to the curve's
    tangent there (:func:`fsistab.frequency_sweep.local_following`)."""
    return following_kind(frequency_following(mass_ratios, reduced_velocities, frequencies))


def sides_from_role(plane: np.ndarray, seed_index: int, boundary: str) -> tuple[int, ...]:
    """The unstable side at every point of a continued curve (rows ``(log m, U*)`` in order) from
    its role at the seed: ``+1`` (unstable for larger U* at fixed m) at an ``onset`` seed, ``−1``
    at a ``restabilisation``. Along a smooth neutral curve ``Re σ = 0`` the unstable side is a
    fixed side of the curve (``∇ Re σ`` is normal to it and does not vanish), so the sign of
    ``∂(Re σ)/∂U*`` is that of ``d(log m)/ds`` times a constant: it changes at each turning point
    in m. The constant makes the seed's side its role (``log m`` grows there along the order of a
    continued curve, whose part towards smaller m is reversed). ``d(log m)/ds`` at a point: the
    centred difference of its neighbours (one-sided at the ends); 0 where it vanishes."""
    plane = np.asarray(plane, dtype=float).reshape(-1, 2)
    if boundary not in ("onset", "restabilisation"):
        raise InputError(f"the seed's boundary is onset or restabilisation, got {boundary!r}")
    if not 0 <= seed_index < max(len(plane), 1):
        raise InputError(f"the seed index {seed_index} is not a point of the curve")
    role = 1 if boundary == "onset" else -1
    if len(plane) < 2:
        return (role,) * len(plane)
    log_m = plane[:, 0]
    growth = np.sign(np.concatenate([log_m[1:], log_m[-1:]]) - np.concatenate([log_m[:1], log_m[:-1]]))
    constant = role * (growth[seed_index] or 1.0)
    return tuple(int(constant * g) for g in growth)


def characterised(curve: NeutralCurve, seed_index: int, mass_range: tuple[float, float]) -> NeutralCurve:
    """A continued curve with its unstable sides (:func:`sides_from_role`), frequency following and
    kind (:func:`curve_kind`, on its points in ``mass_range``)."""
    inside = [p for p in curve.points if mass_range[0] <= p.mass_ratio <= mass_range[1]] or curve.points
    values = (
        [p.mass_ratio for p in inside],
        [p.reduced_velocity for p in inside],
        [p.frequency for p in inside],
    )
    return replace(
        curve,
        kind=curve_kind(*values),
        unstable_sides=sides_from_role(curve.plane_points, seed_index, curve.boundary),
        frequency_following=frequency_following(*values),
    )


@dataclass(frozen=True)
class MapCrossing:
    """A codimension-two point: curves ``first`` and ``second`` (indices into the map's curves,
    ``-1`` the divergence curve; ``first == second`` where a curve crosses itself) cross, with the
    frequency of each curve there (0 on the divergence curve; interpolated along the segments)."""

    first: int
    second: int
    crossing: CurveCrossing
    frequencies: tuple[float, float] = (math.nan, math.nan)


@dataclass(frozen=True)
class NeutralMap:
    """Every neutral curve found in the ``(m, U*)`` plane (docs/model.md §8): dynamic curves (flutter,
    VIV) with their turning points, the divergence curve ``U*_D(m)`` of the static moment slope,
    and the codimension-two crossings of all of them; ``unresolved`` the frequency intervals
    ``(low, high, reason)`` the transfer method left unresolved (none by continuation)."""

    curves: tuple[NeutralCurve, ...]
    divergence_mass_ratios: np.ndarray
    divergence_velocities: np.ndarray
    moment_slope: float
    crossings: tuple[MapCrossing, ...]
    factorisations: int
    unresolved: tuple[tuple[float, float, str], ...] = ()


def map_crossings(
    curves: Sequence[NeutralCurve],
    masses: np.ndarray,
    divergence: np.ndarray,
    r_theta: float | None = None,
    moment_slope: float | None = None,
) -> tuple[MapCrossing, ...]:
    """Codimension-two points of a map: crossings, in ``(log m, U*)``, of every pair of dynamic
    curves, of each with itself (two non-adjacent segments: a folded curve crossing its own other
    part) and of each with the divergence curve ``divergence(masses)`` (index ``-1``), wherever the
    curves fold. With ``r_theta`` and ``moment_slope`` a crossing with divergence is put on the
    exact divergence curve ``U*_D = r_θ √(m/slope)`` (Newton along the dynamic curve's segment)
    instead of its polyline. Each carries both curves' frequencies there (0 for divergence)."""
    planes = [c.plane_points for c in curves]
    frequencies = [np.array([p.frequency for p in c.points]) for c in curves]
    crossings = []
    ok = np.isfinite(divergence)
    if ok.sum() > 1:
        planes_div = np.column_stack([np.log(masses[ok]), divergence[ok]])
        for i, plane in enumerate(planes):
            refine = None
            if r_theta is not None and moment_slope is not None and moment_slope > 0:
                refine = _on_divergence(plane, r_theta / math.sqrt(moment_slope))
            crossings += _with_frequencies(
                i, -1, curve_crossings(plane, planes_div, refine), planes, frequencies
            )
    for i in range(len(planes)):
        own = [c for c in curve_crossings(planes[i], planes[i]) if c.segments[1] > c.segments[0] + 1]
        crossings += _with_frequencies(i, i, own, planes, frequencies)
        for j in range(i + 1, len(planes)):
            crossings += _with_frequencies(i, j, curve_crossings(planes[i], planes[j]), planes, frequencies)
    return tuple(crossings)


def _frequency_at(plane: np.ndarray, w: np.ndarray, segment: int, point: np.ndarray) -> float:
    """The frequency of a curve (points ``plane``, frequencies ``w``) at ``point`` of its segment
    ``segment``, interpolated linearly along the segment."""
    if len(plane) < 2:
        return float(w[0]) if len(w) else math.nan
    d = plane[segment + 1] - plane[segment]
    a = float(np.clip((point - plane[segment]) @ d / max(float(d @ d), 1e-300), 0.0, 1.0))
    return float(w[segment] + a * (w[segment + 1] - w[segment]))


def _with_frequencies(i: int, j: int, found, planes, frequencies) -> list[MapCrossing]:
    """The crossings ``found`` of curves ``i`` and ``j`` (``-1``: divergence, frequency 0) with both
    curves' frequencies there."""
    crossings = []
    for c in found:
        point = np.array([math.log(c.mass_ratio), c.reduced_velocity])
        pair = tuple(
            0.0 if k < 0 else _frequency_at(planes[k], frequencies[k], segment, point)
            for k, segment in ((i, c.segments[0]), (j, c.segments[1]))
        )
        crossings.append(MapCrossing(i, j, c, pair))
    return crossings


def _on_divergence(plane: np.ndarray, coefficient: float):
    """``refine`` of :func:`curve_crossings`: the point of segment ``i`` of ``plane`` (``(log m,
    U*)``, linear in the segment parameter ``a``) on ``U* = coefficient · e^{log m / 2}``, by Newton
    in ``a`` from the polyline crossing (ConvergenceError if it leaves the segment)."""

    def refine(log_mass: float, velocity: float, segments: tuple[int, int]) -> tuple[float, float]:
        start, end = plane[segments[0]], plane[segments[0] + 1]
        d = end - start
        a = float((np.array([log_mass, velocity]) - start) @ d / max(float(d @ d), 1e-300))
        for _ in range(50):
            x = start + a * d
            gap = x[1] - coefficient * math.exp(x[0] / 2)
            slope = d[1] - coefficient * math.exp(x[0] / 2) * d[0] / 2
            if slope == 0:
                break
            step = gap / slope
            a -= step
            if abs(step) < 1e-15:
                break
        if not -1e-9 <= a <= 1 + 1e-9 or not math.isfinite(a):
            raise ConvergenceError("the crossing with divergence left the segment")
        x = start + a * d
        return float(x[0]), float(coefficient * math.exp(x[0] / 2))

    return refine


def neutral_map_dataset(result: NeutralMap, attrs: dict):
    """The map as one xarray Dataset: curve points along ``point`` with a ``curve`` index and their
    unstable side, each curve's kind and frequency following (``curve_index``), turning points along
    ``fold``, crossings along ``crossing`` (the two curves, their kinds and frequencies), the
    unresolved frequency intervals of the transfer method along ``unresolved`` (``low``, ``high``,
    ``reason``), the divergence curve along ``mass_ratio``."""
    import xarray as xr

    rows = [(i, p) for i, c in enumerate(result.curves) for p in c.points]
    folds = [(i, t) for i, c in enumerate(result.curves) for t in c.turning_points]
    kinds = [c.kind for c in result.curves]

    def kind_of(index: int) -> str:
        return "divergence" if index < 0 else kinds[index]

    empty = np.zeros(0)
    return xr.Dataset(
        {
            "curve": ("point", np.array([i for i, _ in rows], dtype=int)),
            "curve_mass_ratio": ("point", np.array([p.mass_ratio for _, p in rows])),
            "curve_reduced_velocity": ("point", np.array([p.reduced_velocity for _, p in rows])),
            "curve_frequency": ("point", np.array([p.frequency for _, p in rows])),
            "curve_unstable_side": (
                "point",
                np.concatenate([c.sides() for c in result.curves] or [empty]).astype(int),
                {"description": "+1: unstable for larger U* at fixed m, -1: for smaller, 0: not known"},
            ),
            "curve_kind": ("curve_index", np.array(kinds, dtype=str)),
            "curve_frequency_following": (
                "curve_index",
                np.array([c.frequency_following for c in result.curves], dtype=float),
                {"description": "range of log(frequency) / range of log(U*) along the curve; viv below 1/2"},
            ),
            "fold_curve": ("fold", np.array([i for i, _ in folds], dtype=int)),
            "fold_mass_ratio": ("fold", np.array([t.mass_ratio for _, t in folds])),
            "fold_reduced_velocity": ("fold", np.array([t.reduced_velocity for _, t in folds])),
            "crossing_first": ("crossing", np.array([c.first for c in result.crossings], dtype=int)),
            "crossing_second": ("crossing", np.array([c.second for c in result.crossings], dtype=int)),
            "crossing_mass_ratio": ("crossing", np.array([c.crossing.mass_ratio for c in result.crossings])),
            "crossing_reduced_velocity": (
                "crossing",
                np.array([c.crossing.reduced_velocity for c in result.crossings]),
            ),
            "crossing_first_kind": (
                "crossing",
                np.array([kind_of(c.first) for c in result.crossings], dtype=str),
            ),
            "crossing_second_kind": (
                "crossing",
                np.array([kind_of(c.second) for c in result.crossings], dtype=str),
            ),
            "crossing_first_frequency": ("crossing", np.array([c.frequencies[0] for c in result.crossings])),
            "crossing_second_frequency": ("crossing", np.array([c.frequencies[1] for c in result.crossings])),
            "unresolved_low": ("unresolved", np.array([u[0] for u in result.unresolved], dtype=float)),
            "unresolved_high": ("unresolved", np.array([u[1] for u in result.unresolved], dtype=float)),
            "unresolved_reason": ("unresolved", np.array([u[2] for u in result.unresolved], dtype=str)),
            "divergence_reduced_velocity": ("mass_ratio", result.divergence_velocities),
        },
        coords={"mass_ratio": result.divergence_mass_ratios},
        attrs={**attrs, "moment_slope": result.moment_slope, "factorisations": result.factorisations},
    )


def map_curves(ds) -> list[tuple[str, np.ndarray, np.ndarray, np.ndarray]]:
    """``(kind, m, U*, ω)`` of each dynamic curve of a map dataset (:func:`neutral_map_dataset`), in
    order of arclength."""
    index = ds.curve.values
    return [
        (
            str(kind),
            ds.curve_mass_ratio.values[index == i],
            ds.curve_reduced_velocity.values[index == i],
            ds.curve_frequency.values[index == i],
        )
        for i, kind in enumerate(ds.curve_kind.values)
    ]


def unshaded_families(ds) -> list[tuple[str, float, float]]:
    """``(kind, m_low, m_high)`` for each family (divergence, flutter, viv) whose signed crossings
    do not add up somewhere on a map's shading grid: a curve of that family is missing there (an
    unresolved interval), so its unstable region is left unshaded over that range of m
    (:func:`fsistab.transfer_map.unstable_grid`). Empty without a grid."""
    if "unshaded" not in ds:
        return []
    masses = ds.grid_mass_ratio.values
    return [
        (str(kind), float(masses[row].min()), float(masses[row].max()))
        for kind, row in zip(ds.shading_family.values, ds.unshaded.values.astype(bool), strict=True)
        if row.any()
    ]


def map_curve_names(ds) -> list[str]:
    """``flutter 0``, ``viv 1``, ...: the names of a map dataset's curves (tables, JSON)."""
    return [f"{kind} {i}" for i, kind in enumerate(ds.curve_kind.values)]
