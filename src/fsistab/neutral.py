"""Neutral curves in the (m, U*) plane by pseudo-arclength continuation (docs/model.md §8).

A point of a dynamic neutral curve solves, in the unknowns ``y = (Re q̂, Im q̂, ω, U*, μ = log m)``::

    (iω M(m) + J(U*, m)) q̂ = 0,   Re(ĥ) = 0,   q̂ᴴ M q̂ = 1,
    t_U (U* - U*_k) + t_μ (μ - μ_k) = Δs                       (arclength in the parameter plane)

with ``(t_U, t_μ)`` the unit tangent of the curve at the previous point ``k``. The continuation is
the generic one of :mod:`fsistab.continuation` with arclength weights on ``(U*, μ)`` only and a
tangent predictor (three extra solves per point with the last factorisation; the turn control that
it allows keeps the steps from jumping across the S-shaped part of the flutter curve, which a secant
predictor with ``Δs = 0.5`` does on the coarse plate mesh); the residual and the bordered solve are
those of the neutral-point problem :class:`fsistab.critical.AugmentedProblem` (the same problem,
with m held, gives :func:`fsistab.critical.flutter_point`; :mod:`fsistab.neutral_point`). Because
the arclength is measured in the plane (log m, U*), the continuation passes turning points where the
curve folds back in ``m``; they are reported (where ``d(log m)/ds`` changes sign, located where the
tangent's ``μ`` component vanishes) and stored with the curve. Every aerodynamic term of the solid
rows, and their inertia, scale with ``1/m``: ``∂(J + iωM)/∂μ q̂ = -(aerodynamic solid rows)(q̂)`` is
explicit. Each Newton step needs one factorisation of the fluid block at ``iω``
(:mod:`fsistab.linalg`), kept while the residual falls tenfold per iteration (chord), four solves
and a 3×3 real border. The divergence curve is ``U*_D(m) = √(m r_θ²/(dC_M/dθ))`` exactly (static
moment independent of ``h``; :func:`divergence_velocity`). Codimension-two points where two neutral
curves cross (flutter meeting divergence, two flutter curves, flutter and VIV, VIV and divergence, a
folded curve and itself) come from :func:`curve_crossings` (:func:`map_crossings` for a map).
:func:`trace_neutral_map` assembles a whole stability map: seed sweeps in U* (flutter at a few m,
VIV near the wake frequency), every new threshold continued both ways, the divergence curve and all
crossings. Every curve is labelled flutter or VIV by :func:`curve_kind` (the frequency locked at the
wake mode's while ``1/U*`` varies: VIV), the rule of the transfer method too, and every point says
on which side of it the system is unstable (:func:`sides_from_role`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from fsistab.continuation import ContinuationIterator, ContinuationSettings, Event, TestFunction
from fsistab.critical import AugmentedProblem, find_thresholds
from fsistab.errors import ConvergenceError, InputError
from fsistab.linalg import FactorCounter, FluidFactor
from fsistab.neutral_map import (
    NeutralCurve,
    NeutralMap,
    NeutralPoint,
    TurningPoint,
    characterised,
    divergence_curve,
    map_crossings,
)
from fsistab.neutral_point import STATIC_FREQUENCY
from fsistab.operators import FluidOperators
from fsistab.params import Solid
from fsistab.progress import Progress
from fsistab.slopes import static_slopes
from fsistab.store import ResumableTable


def _zero_frequency(y: np.ndarray) -> float:
    """The test function that ends a neutral curve where its frequency reaches zero (relative to
    the solid's scale ``1/U*`` when that is above 1): a codimension-two point with divergence."""
    return float(y[-3] - 1e-4 * max(1.0, 1.0 / y[-2]))


def _neutral_point(problem: AugmentedProblem, y: np.ndarray, iterations: int) -> NeutralPoint:
    q, omega, velocity, log_mass = problem.unpack(y)
    return NeutralPoint(math.exp(log_mass), velocity, omega, mode=q, iterations=iterations)


def _turning_point(problem: AugmentedProblem, event: Event) -> TurningPoint:
    _, omega, velocity, log_mass = problem.unpack(event.point)
    return TurningPoint(math.exp(log_mass), velocity, omega, index=event.index, localised=event.localised)


def _neutral_stop(iterator: ContinuationIterator, n: int) -> str:
    """Why a neutral curve ended: ``mass_bound``, ``velocity_bound``, ``zero_frequency``,
    ``max_points`` or ``step_too_small``."""
    if iterator.stop == "bound":
        return "mass_bound" if iterator.stop_event.component == 2 * n + 2 else "velocity_bound"
    return "zero_frequency" if iterator.stop == "event:zero_frequency" else iterator.stop


def _neutral_iterator(
    problem: AugmentedProblem,
    y0: np.ndarray,
    settings: ContinuationSettings,
    mass_range: tuple[float, float],
    velocity_range: tuple[float, float],
    orientation: tuple[float, float],
) -> ContinuationIterator:
    """The continuation of the neutral curve of ``problem`` through ``y0`` (module doc) oriented by
    ``orientation = (ΔU*, Δlog m)``: it ends at the bounds of ``mass_range`` and ``velocity_range``
    or where the frequency reaches zero."""
    n = problem.n
    d0 = np.zeros(problem.size)
    d0[-2:] = orientation
    return ContinuationIterator(
        problem.curve(),
        y0,
        d0,
        settings,
        bounds={2 * n + 2: (math.log(mass_range[0]), math.log(mass_range[1])), 2 * n + 1: velocity_range},
        events={"zero_frequency": TestFunction(_zero_frequency, terminal=True, localise=False)},
    )


def continue_neutral_curve(
    fluid: FluidOperators,
    start: NeutralPoint,
    template: Solid,
    *,
    mass_range: tuple[float, float] = (1.0, 1e4),
    velocity_range: tuple[float, float] = (1e-2, 20.0),
    direction: float = -1.0,
    initial_direction: tuple[float, float] | None = None,
    step: float = 0.2,
    min_step: float = 1e-3,
    max_step: float = 0.5,
    max_points: int = 200,
    locate_folds: bool = True,
    counter: FactorCounter | None = None,
    on_point: Callable[[NeutralPoint], None] | None = None,
    on_fold: Callable[[TurningPoint], None] | None = None,
) -> NeutralCurve:
    """Follow the flutter/VIV neutral curve through ``start`` (a dynamic neutral point with its mode).

    Arclength in the plane ``(U*, log m)``; ``direction`` −1 starts towards smaller m, or
    ``initial_direction = (ΔU*, Δlog m)`` orients the first step (to resume past a turning point).
    Steps grow after quick convergence and halve after a failure or a turn of the tangent by more
    than 0.5 rad within one step (:class:`fsistab.continuation.ContinuationIterator`); the curve
    stops when it leaves ``mass_range``/``velocity_range`` or the frequency reaches zero (a
    codimension-two point with the divergence curve), or after ``max_points``. Turning points in m
    are reported (and located on the curve when ``locate_folds``, a few extra factorisations
    each). ``on_point`` is called for every accepted point (to save progress), ``on_fold`` for
    every turning point, before the point that follows it.
    """
    if start.kind == "divergence" or abs(start.frequency) < STATIC_FREQUENCY or start.mode is None:
        raise InputError("continue_neutral_curve follows dynamic (ω > 0) neutral curves")
    if not 0 < mass_range[0] < mass_range[1] or not 0 < velocity_range[0] < velocity_range[1]:
        raise InputError("mass and velocity ranges must be positive and increasing")
    counter = counter if counter is not None else FactorCounter()
    first = counter.count
    problem = AugmentedProblem(fluid, template, counter)
    settings = ContinuationSettings.neutral_curve(
        step=step, min_step=min_step, max_step=max_step, max_points=max_points,
        tol=1e-10, locate_tol=1e-6, locate_folds=locate_folds,
    )  # fmt: skip
    orientation = initial_direction if initial_direction is not None else (0.0, float(np.sign(direction)))
    n = problem.n
    y0 = problem.pack(
        np.asarray(start.mode, dtype=complex),
        start.frequency,
        start.reduced_velocity,
        math.log(start.mass_ratio),
    )
    mode = y0[:n] + 1j * y0[n : 2 * n]
    points = [NeutralPoint(start.mass_ratio, start.reduced_velocity, start.frequency, mode=mode)]
    turning: list[TurningPoint] = []
    iterator = _neutral_iterator(problem, y0, settings, mass_range, velocity_range, orientation)
    try:
        for accepted in itertools.islice(iterator, 1, None):  # the points after the start
            for event in accepted.events:
                if event.kind == "fold":
                    turning.append(_turning_point(problem, event))
                    if on_fold:
                        on_fold(turning[-1])
            points.append(_neutral_point(problem, accepted.point, accepted.iterations))
            if on_point:
                on_point(points[-1])
    except ConvergenceError:  # no step from the start converged: a one-point curve
        return NeutralCurve(tuple(points), stops=("step_too_small",), factorisations=counter.count - first)
    return NeutralCurve(
        tuple(points),
        turning_points=tuple(turning),
        folds=tuple(t.index for t in turning),
        stops=(_neutral_stop(iterator, problem.n),),
        factorisations=counter.count - first,
    )


CURVE_FIELDS = {
    "point": ("mass_ratio", "reduced_velocity", "frequency"),
    "fold": ("fold_mass_ratio", "fold_reduced_velocity", "fold_frequency", "fold_index", "fold_localised"),
}


def curve_table(path, attrs: dict):
    """The resumable table (:class:`fsistab.store.ResumableTable`) of one neutral curve of identity
    ``attrs``: its points along ``point``, its turning points in m along ``fold``, the last point's
    mode as state ``last_mode`` (to resume), finished with attribute ``stop``."""

    return ResumableTable(path, attrs, CURVE_FIELDS, state=("last_mode",))


def _point_record(point: NeutralPoint) -> dict:
    return {
        "mass_ratio": point.mass_ratio,
        "reduced_velocity": point.reduced_velocity,
        "frequency": point.frequency,
    }


def _fold_record(fold: TurningPoint) -> dict:
    return {
        "fold_mass_ratio": fold.mass_ratio,
        "fold_reduced_velocity": fold.reduced_velocity,
        "fold_frequency": fold.frequency,
        "fold_index": fold.index,
        "fold_localised": int(fold.localised),
    }


def saved_points(table) -> list[NeutralPoint]:
    """The points of a curve table; only the last one carries its mode (the others an empty one)."""
    points = [
        NeutralPoint(
            float(r["mass_ratio"]), float(r["reduced_velocity"]), float(r["frequency"]), mode=np.zeros(0)
        )
        for r in table.records_of("point")
    ]
    if points and "last_mode" in table.state:
        points[-1] = replace(points[-1], mode=table.state["last_mode"])
    return points


def saved_turning_points(table) -> list[TurningPoint]:
    """The turning points of a curve table."""
    return [
        TurningPoint(
            float(r["fold_mass_ratio"]),
            float(r["fold_reduced_velocity"]),
            float(r["fold_frequency"]),
            index=int(r["fold_index"]),
            localised=bool(r["fold_localised"]),
        )
        for r in table.records_of("fold")
    ]


class _CurveRecorder:
    """Saves a neutral curve in its table as it is traced: each point (with its mode, the state to
    resume from) after the ``points`` already there, each turning point with the point that follows
    it, numbered along the whole curve (``offset`` the index of the continuation's start)."""

    def __init__(self, table, points: list[NeutralPoint], offset: int):
        self.table, self.points, self.offset = table, points, offset

    def save(self, point: NeutralPoint) -> None:
        self.points.append(point)
        self.table.append(_point_record(point), kind="point", state={"last_mode": point.mode})

    def save_fold(self, fold: TurningPoint) -> None:
        fold = replace(fold, index=fold.index + self.offset)
        self.table.append(_fold_record(fold), kind="fold", save=False)


def trace_curve_resumable(
    fluid: FluidOperators,
    start: NeutralPoint,
    template: Solid,
    path,
    attrs: dict,
    **options,
) -> list[NeutralPoint]:
    """:func:`continue_neutral_curve` saving its table (:func:`curve_table`) at ``path`` after every
    point.

    If ``path`` holds a curve with the same ``attrs`` that was interrupted, or stopped at fewer
    than ``max_points`` points, it continues from its last point in the direction of its last
    step (so a resumed curve keeps going past a turning point); a damaged file (checksum) is
    reported and the curve restarts, a file of other ``attrs`` is refused (CacheError).
    Turning points in m are stored with the curve."""
    table = curve_table(path, attrs)
    points = saved_points(table)
    if points:
        wanted = options.get("max_points", 200)
        if table.complete and (table.final_attrs.get("stop") != "max_points" or len(points) >= wanted):
            return points
        options = {**options, "max_points": wanted - len(points) + 1}
        last = points[-1]
        if len(points) > 1:
            before = points[-2]
            options["initial_direction"] = (
                last.reduced_velocity - before.reduced_velocity,
                math.log(last.mass_ratio / before.mass_ratio),
            )
        start = NeutralPoint(
            last.mass_ratio, last.reduced_velocity, last.frequency, kind="flutter", mode=last.mode
        )
    else:
        points = [NeutralPoint(start.mass_ratio, start.reduced_velocity, start.frequency, mode=start.mode)]
        table.append(_point_record(start), kind="point", state={"last_mode": start.mode}, save=False)
    recorder = _CurveRecorder(table, points, len(points) - 1)
    curve = continue_neutral_curve(
        fluid, start, template, on_point=recorder.save, on_fold=recorder.save_fold, **options
    )
    table.finish({"stop": curve.stops[-1]})
    return points


@dataclass(frozen=True)
class Seed:
    """A sweep in U* at fixed ``mass_ratio`` whose thresholds start neutral curves; ``wake_shift``
    (``iω_wake``) also tracks the wake mode, so that vortex-induced vibration is found."""

    mass_ratio: float
    velocities: tuple[float, ...]
    wake_shift: complex | None = None


def map_seeds(
    start_mass: float,
    velocity_range: tuple[float, float],
    points: int,
    seed_masses: Sequence[float] = (),
    wake_frequency: float | None = None,
    viv_mass: float = 1.0,
    freq_ratio: float = 0.8,
) -> list[Seed]:
    """Sweeps of a stability map: ``points`` values of U* over ``velocity_range`` at ``start_mass``,
    the same range scaled by ``√(m/start_mass)`` at each of ``seed_masses`` (flutter speeds grow
    like ``√m``), and, given the wake frequency ``ω_w``, a VIV sweep at ``viv_mass`` over the U*
    where the solid frequencies ``Ω/U*`` (heave) and ``1/U*`` (pitch) pass ``ω_w``:
    ``U* ∈ [0.5 min(Ω, 1), 2 max(Ω, 1)]/ω_w``."""
    low, high = velocity_range
    seeds = [Seed(start_mass, tuple(np.geomspace(low, high, points)))]
    for mass in seed_masses:
        scale = math.sqrt(mass / start_mass)
        seeds.append(Seed(mass, tuple(np.geomspace(low * scale, high * scale, points))))
    if wake_frequency is not None:
        viv = (0.5 * min(freq_ratio, 1.0) / wake_frequency, 2.0 * max(freq_ratio, 1.0) / wake_frequency)
        seeds.append(Seed(viv_mass, tuple(np.geomspace(*viv, points)), 1j * wake_frequency))
    return seeds


def _on_traced_curve(curves: Sequence[NeutralCurve], kind: str, mass_ratio: float, velocity: float) -> bool:
    """Whether a threshold at ``(m, U*)`` lies on a curve already traced (1 % in U*, linear
    interpolation between the curve's points at that m)."""
    log_m = math.log(mass_ratio)
    for curve in curves:
        if curve.kind != kind:
            continue
        plane = curve.plane_points
        for (x0, u0), (x1, u1) in zip(plane[:-1], plane[1:], strict=True):
            if min(x0, x1) <= log_m <= max(x0, x1) and x0 != x1:
                u = u0 + (log_m - x0) / (x1 - x0) * (u1 - u0)
                if abs(u - velocity) < 1e-2 * velocity:
                    return True
    return False


def _trace_both_ways(
    fluid: FluidOperators,
    threshold: NeutralPoint,
    solid: Solid,
    seed_mass: float,
    index: int,
    files: tuple[Path, str],
    attrs: dict,
    *,
    mass_range: tuple[float, float],
    max_points: int,
    counter: FactorCounter,
    say: Callable[[str], None],
) -> tuple[NeutralCurve, int]:
    """Curve ``index`` of a map: the neutral curve through ``threshold`` (of a sweep at
    ``seed_mass`` with the solid ``solid``) continued towards smaller and larger m
    (:func:`trace_curve_resumable`, files ``neutral_{tag}_curve{index}_{down|up}.nc`` in the
    directory of ``files = (directory, tag)``), the first half reversed: the map's curve (not yet
    characterised) and the seed's index in its points."""
    halves, turning, stops = [], [], []
    for direction in (-1, 1):
        name = "down" if direction < 0 else "up"
        path = files[0] / f"neutral_{files[1]}_curve{index}_{name}.nc"
        identity = {**attrs, "kind": threshold.kind, "direction": direction}
        say(f"curve {index} ({threshold.kind} from m = {seed_mass:g}) towards {name}")
        traced = trace_curve_resumable(
            fluid, threshold, solid, path, identity,
            direction=direction, mass_range=mass_range, max_points=max_points, counter=counter,
        )  # fmt: skip
        table = curve_table(path, identity)  # the saved half: its turning points and stop
        halves.append(traced)
        turning.extend(saved_turning_points(table))
        stops.append(str(table.final_attrs.get("stop", "")))
    ordered = tuple(reversed(halves[0])) + tuple(halves[1][1:])
    curve = NeutralCurve(
        ordered,
        kind=threshold.kind,
        boundary=threshold.boundary,
        seed_mass_ratio=seed_mass,
        turning_points=tuple(turning),
        stops=(stops[0], stops[1]),
    )
    return curve, len(halves[0]) - 1


def trace_neutral_map(
    fluid: FluidOperators,
    template: Solid,
    seeds: Sequence[Seed],
    out_dir,
    tag: str,
    attrs: dict,
    *,
    mass_range: tuple[float, float] = (1.0, 1e4),
    max_points: int = 60,
    counter: FactorCounter | None = None,
    progress: Progress = None,
) -> NeutralMap:
    """The stability map of docs/model.md §8 in the plane ``(m, U*)``.

    Each seed sweep (:func:`fsistab.critical.find_thresholds`) gives thresholds; every dynamic one
    not already on a traced curve is continued towards smaller and larger m
    (:func:`trace_curve_resumable`, files ``neutral_{tag}_curve{k}_{down|up}.nc`` in ``out_dir``,
    so an interrupted map resumes). Divergence is ``U*_D(m) = √(m r_θ²/(dC_M/dθ))`` (exact at
    α0 = 0, one extra solve); crossings between every pair of curves are the codimension-two points.
    Each curve's kind (:func:`curve_kind`) and unstable sides (:func:`sides_from_role`) come from
    its points and its seed's role, at no extra factorisation; the sweeps' own labels (which need
    the wake frequency) only tell which thresholds lie on curves already traced.
    ``template`` gives the solid parameters other than ``m`` and ``U*``.
    """
    out_dir = Path(out_dir)
    counter = counter if counter is not None else FactorCounter()
    say = progress or (lambda message: None)
    curves: list[NeutralCurve] = []
    seeds_at: list[int] = []  # per curve: the seed's index in its points
    static = FluidFactor(fluid, 0.0, counter)  # J_ff: divergence of every sweep and the slope
    for seed in seeds:
        say(f"sweep in U* at m = {seed.mass_ratio:g}")
        solid = replace(template, mass_ratio=seed.mass_ratio, reduced_velocity=seed.velocities[0])
        thresholds, _ = find_thresholds(
            fluid,
            solid,
            np.array(seed.velocities),
            wake_shift=seed.wake_shift,
            counter=counter,
            static_factor=static,
        )
        for threshold in thresholds:
            if threshold.kind == "divergence" or _on_traced_curve(
                curves, threshold.kind, threshold.mass_ratio, threshold.reduced_velocity
            ):
                continue
            curve, seed_index = _trace_both_ways(
                fluid, threshold, solid, seed.mass_ratio, len(curves), (out_dir, tag), attrs,
                mass_range=mass_range, max_points=max_points, counter=counter, say=say,
            )  # fmt: skip
            curves.append(curve)
            seeds_at.append(seed_index)
    # labels and unstable sides by the transfer method's rule (find_thresholds' kinds only matched
    # thresholds to the curves already traced)
    curves = [characterised(curve, index, mass_range) for curve, index in zip(curves, seeds_at, strict=True)]
    slope = static_slopes(fluid, counter, factor=static).moment
    masses = np.geomspace(mass_range[0], mass_range[1], 200)
    divergence = divergence_curve(slope, template.r_theta, masses)
    crossings = map_crossings(curves, masses, divergence, template.r_theta, slope)
    return NeutralMap(tuple(curves), masses, divergence, slope, crossings, counter.count)
