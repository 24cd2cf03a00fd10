"""The stability map of the whole ``(m, U*)`` plane from the fluid's transfer function ``G(iω)``,
one frequency at a time (docs/model.md §7-§8).

At each sampled frequency every neutral point ``(m, U*)`` follows from the real roots of a
polynomial resultant, with its tangent along the neutral curve and its crossing rate
(:mod:`fsistab.map_roots`); the fluid enters only through ``G(iω)`` and ``dG/ds``, independent of
``m`` and ``U*``. The neutral curves are these points as ``ω`` varies, joined between samples by
cubic Hermite interpolants in ``log ω`` (:class:`TransferCurve`); two branches born or dying
together at a fold in ``ω`` are joined through it.

The map engine (:func:`transfer_neutral_map`) is four kinds of objects and a short loop
(:mod:`fsistab.map_engine`):

- sample sources (:mod:`fsistab.map_sources`): exact samples (one factorisation each), reduced
  Krylov models certified on intervals, reduced models at sharp resonances and at ``s = 0``, and
  certified rational fits of exact samples — each answers "``G``, ``dG/ds`` at ``ω``" or cannot;
- the samples, saved through the store and reused for any solid parameters (:mod:`fsistab.map_samples`);
- the refinement policy (:mod:`fsistab.map_refinement`): the initial grid, bisection of intervals
  whose roots are not matched by their tangents, sweeps of curves that may cross the whole mass
  range inside an interval, samples at unresolved fluid resonances, following a curve below the
  lowest frequency, the budget;
- the root tracker (:mod:`fsistab.map_tracker`): roots and resultant tracks by frequency, matched
  across neighbouring frequencies.

The side that is unstable follows from the crossing rate ``∂(Re σ)/∂(log U*)`` at fixed ``m``
(``dσ = −F_u du / F_s``): positive is an onset of instability as U* grows, negative a
restabilisation. Counting crossings along U* from a U* where the coupled system is stable gives the
number of unstable modes in every region (:func:`unstable_counts`). Each curve is labelled
``flutter`` or ``viv`` from its own roots (:func:`fsistab.neutral_map.curve_kind`), with no
wake-frequency hint; intervals of ω left unresolved are reported with their reason
(:class:`UnresolvedInterval`).

Units: chord-based (plate) or diameter-based (cylinder, via :meth:`fsistab.params.Solid.cylinder`)
time ``L/U∞`` (docs/model.md §2, §10); ``m``, ``U*`` as in :class:`fsistab.params.Solid`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property, partial
from pathlib import Path

import numpy as np
import numpy.polynomial.polynomial as npoly

from fsistab.errors import InputError
from fsistab.linalg import FactorCounter
from fsistab.map_distributed import DistributedExactSource
from fsistab.map_engine import MapEngine, MapSources
from fsistab.map_refinement import (  # noqa: F401 (the map's rules, public here too)
    FIT_FIRST_SPAN,
    FIT_MIN_STEP,
    FITTED_SAMPLES,
    LOW_MODEL_REACH,
    LOWEST_FREQUENCY,
    RESONANCE_DAMPING,
    RESONANCE_MARGIN,
    RESONANCE_SHARE,
    RESONANCE_STEP,
    SHARP_RESONANCE,
    SHARP_SHARE,
    RefinementPolicy,
    default_frequency_range,
    initial_frequencies,
    resonance,
    sharp_resonance,
    unresolved_resonance,
)
from fsistab.map_roots import (  # noqa: F401 (the roots at one frequency, public here too)
    AxisSample,
    NeutralRoot,
    _adjugate,
    _dof_indices,
    _polish,
    _real_resultant,
    _root_with_tangent,
    _roots_on_tracks,
    _weights,
    characteristic_function,
    divergence_lines,
    log_step,
    neutral_roots,
    resultant_tracks,
    roots_from_loads,
    scaled_polynomials,
    second_order_loads,
    undamped_resonances,
)
from fsistab.map_samples import (  # noqa: F401
    SAMPLE_FIELDS,
    SampleStore,
    read_samples,
    sample_record,
    samples_table,
)
from fsistab.map_sources import (  # noqa: F401
    FIT_MARGINS,
    REFINEMENT_RADIUS,
    RESONANCE_BLOCKS,
    RESONANCE_TOLERANCE,
    SAMPLE_REFINE,
    ExactSource,
    RationalFitSource,
    ReducedSource,
    ResonanceSource,
    _AxisModel,
    _model_cover,
)
from fsistab.map_tracker import (  # noqa: F401 (the root tracker, public here too)
    SWEEP_STEP,
    YOUNG_PAIR,
    RootTracker,
    _born,
    _born_outside,
    _leaves,
    _match,
    _resolved,
    _side,
    _side_jump,
    _swept,
)
from fsistab.neutral_map import (
    NeutralCurve,
    NeutralMap,
    NeutralPoint,
    TurningPoint,
    curve_kind,
    divergence_curve,
    frequency_following,
    map_crossings,
)
from fsistab.neutral_point import divergence_velocity
from fsistab.operators import FluidOperators
from fsistab.params import Solid
from fsistab.progress import Progress
from fsistab.reduced_model import ReducedModels
from fsistab.symmetry import antisymmetric_operators

# root-matching tolerance in (log m, log U*) with exact samples (one factorisation each): the Hermite
# interpolants between samples are then good to about its square, 1e-3
EXACT_TOLERANCE = 3e-2
FOLD_POINTS = 9  # points of a curve's interpolant through a fold in ω, drawn between its pair


def _geometric(omega0: float, step: float, tau: float) -> float:
    """``ω`` at ``τ ∈ [0, 1]`` of a segment from ``omega0`` that is ``step`` long in ``log ω``."""
    return float(omega0 * math.exp(step * tau))


def _through_fold(omega0: float, rate0: float, rate1: float, tau: float) -> float:
    """``ω`` at ``τ ∈ [0, 1]`` of a segment through a fold in ω from and back to ``omega0``: the
    cubic Hermite with ``dω/dτ`` equal to ``rate0``, ``rate1`` at its ends (its extreme is the fold)."""
    return float(npoly.polyval(tau, _hermite(omega0, rate0, omega0, rate1, 1.0)))


def _rate_at(coef: np.ndarray, q0: float, q1: float, tau: float) -> float:
    """The crossing rate at ``τ`` of a segment whose ``(log m, log U*)`` Hermite is ``coef``:
    ``rate/(d log m/dτ)``, ``q0`` and ``q1`` at its ends, interpolated linearly, times the
    interpolant's ``d log m/dτ`` (:meth:`TransferCurve.crossings_at`)."""
    return float((q0 + tau * (q1 - q0)) * npoly.polyval(tau, npoly.polyder(coef[:, 0])))


def _hermite(x0: np.ndarray, t0: np.ndarray, x1: np.ndarray, t1: np.ndarray, h: float) -> np.ndarray:
    """Cubic Hermite coefficients in ``τ ∈ [0, 1]`` (ascending, one column per component)."""
    d = x1 - x0
    return np.array([x0, h * t0, 3 * d - h * (2 * t0 + t1), -2 * d + h * (t0 + t1)])


@dataclass(frozen=True)
class TransferCurve:
    """A neutral curve: exact neutral points at the sampled frequencies, in order along the curve,
    joined by cubic Hermite interpolants in ``log ω``; ``kind`` is ``flutter`` or ``viv``.

    ``folds`` lists ``(k, s)`` for segments ``k`` that pass through a fold in ``ω`` (two roots at
    the same sampled frequency, a pair born or dying just beyond it): there the Hermite runs in a
    chord parameter, with end directions ``s t_k`` and ``-s t_{k+1}`` (``s = -1`` if the fold lies
    below the frequency of the pair, ``+1`` above)."""

    kind: str
    roots: tuple[NeutralRoot, ...]
    folds: tuple[tuple[int, int], ...] = ()

    def _segments(self):
        """Per interval: the roots, the cubic Hermite of ``(log m, log U*)`` in ``τ ∈ [0, 1]``
        (values and exact tangents), ``ω(τ)`` along it (geometric, ``log ω`` linear in ``τ``;
        across a fold the cubic through it, :func:`_through_fold`) and ``rate/(d log m/dτ)`` at
        both ends (made once per curve, :attr:`_segment_table`)."""
        return iter(segment for segment, _ in self._segment_table)

    @cached_property
    def _segment_table(self) -> tuple:
        """``(segment, (low, high))`` per interval: :meth:`_segments`' tuple and the range of
        ``log m`` over ``τ ∈ [0, 1]`` (ends and interior extrema of the cubic), so that a query at
        one m solves only the cubics that reach it (a map's shading grid asks hundreds of m)."""
        table = []
        for segment in self._hermite_segments():
            coef = segment[2][:, 0]
            slope = npoly.polyder(coef)
            taus = [0.0, 1.0]
            if np.any(slope[1:]):
                taus += [t.real for t in npoly.polyroots(npoly.polytrim(slope, tol=0.0)) if 0 < t.real < 1]
            values = npoly.polyval(np.array(taus), coef)
            table.append((segment, (float(values.min()), float(values.max()))))
        return tuple(table)

    def _hermite_segments(self):
        folds = dict(self.folds)
        for k, (r0, r1) in enumerate(zip(self.roots[:-1], self.roots[1:], strict=True)):
            if k in folds:
                chord = float(np.linalg.norm(r1.plane - r0.plane))
                unit = lambda t: t / max(float(np.linalg.norm(t)), 1e-300)  # noqa: E731
                start, end = folds[k] * chord * unit(r0.tangent), -folds[k] * chord * unit(r1.tangent)
                plane = _hermite(r0.plane, start, r1.plane, end, 1.0)
                # dω/dτ = |d plane/dτ| / |tangent| at both ends, ω back to the pair's at τ = 1
                rates = [s * chord / np.linalg.norm(r.tangent) for s, r in ((folds[k], r0), (-folds[k], r1))]
                omega = partial(_through_fold, r0.frequency, *rates)
            else:
                step = log_step(r0.frequency, r1.frequency)
                plane = _hermite(r0.plane, r0.log_tangent, r1.plane, r1.log_tangent, step)
                omega = partial(_geometric, r0.frequency, step)
            slope = npoly.polyder(plane[:, 0])
            ends = (npoly.polyval(0.0, slope), npoly.polyval(1.0, slope))
            q = tuple(r.crossing_rate / d if d else 0.0 for r, d in zip((r0, r1), ends, strict=True))
            yield r0, r1, plane, omega, q

    def points(self) -> list[tuple[float, float, float, float]]:
        """``(m, U*, ω, crossing rate)`` along the curve: the exact roots and, on each segment
        through a fold in ω, ``FOLD_POINTS`` points of its interpolant between them. A map drawn
        as lines between points (:func:`as_neutral_map`) would otherwise cut the curve's nose there
        with the chord between the pair, which the sampling leaves far from the fold."""
        folds = dict(self.folds)
        points = []
        for k, (r0, _, coef, omega, (q0, q1)) in enumerate(self._segments()):
            points.append((r0.mass_ratio, r0.reduced_velocity, r0.frequency, r0.crossing_rate))
            for tau in np.linspace(0.0, 1.0, FOLD_POINTS + 2)[1:-1] if k in folds else ():
                log_m, log_u = npoly.polyval(tau, coef)
                points.append((math.exp(log_m), math.exp(log_u), omega(tau), _rate_at(coef, q0, q1, tau)))
        last = self.roots[-1]
        return [*points, (last.mass_ratio, last.reduced_velocity, last.frequency, last.crossing_rate)]

    def velocities_at(self, mass_ratio: float) -> list[tuple[float, float]]:
        """``(U*, ω)`` of every point of the curve at ``mass_ratio`` (Hermite interpolation)."""
        return [(u, w) for u, w, _ in self.crossings_at(mass_ratio)]

    def crossings_at(self, mass_ratio: float) -> list[tuple[float, float, float]]:
        """``(U*, ω, crossing rate)`` of every point of the curve at ``mass_ratio``. The rate is
        exact at the sampled roots; in between, ``rate/(d log m/dω)`` — smooth through turning
        points, where both vanish, since the unstable side keeps its place relative to the curve —
        is interpolated linearly and multiplied by the interpolant's ``d log m/dω`` (in the chord
        parameter across a fold)."""
        target = math.log(mass_ratio)
        margin = 1e-6 * (1.0 + abs(target))  # far wider than the roots' acceptance below
        found = []
        for (_, _, coef, omega, (q0, q1)), (low, high) in self._segment_table:
            if not low - margin <= target <= high + margin:
                continue  # no real root in [0, 1]: the cubic does not reach log m there
            poly = coef[:, 0].copy()
            poly[0] -= target
            for tau in npoly.polyroots(npoly.polytrim(poly, tol=0.0)) if np.any(poly[1:]) else []:
                if abs(tau.imag) < 1e-9 and -1e-12 <= tau.real <= 1 + 1e-12:
                    tau = float(np.clip(tau.real, 0, 1))
                    log_u = npoly.polyval(tau, coef[:, 1])
                    found.append((math.exp(log_u), omega(tau), _rate_at(coef, q0, q1, tau)))
        unique = []
        for u, w, rate in found:  # a root at a shared sample is found from both sides
            if all(abs(u - v) > 1e-10 * u for v, _, _ in unique):
                unique.append((u, w, rate))
        return unique

    def turning_points(self) -> list[tuple[float, float, float]]:
        """``(m, U*, ω)`` where ``m`` is extremal along the curve (turning points of docs/model.md §8)."""
        points = []
        for _, _, coef, omega, _ in self._segments():
            slope = npoly.polyder(coef[:, 0])
            for tau in npoly.polyroots(npoly.polytrim(slope, tol=0.0)) if np.any(slope[1:]) else []:
                if abs(tau.imag) < 1e-12 and 0 < tau.real < 1:
                    tau = float(tau.real)
                    before = npoly.polyval(tau - 1e-6, slope)
                    after = npoly.polyval(tau + 1e-6, slope)
                    if before * after < 0:
                        x = npoly.polyval(tau, coef)
                        points.append((math.exp(x[0]), math.exp(x[1]), omega(tau)))
        return points


UNRESOLVED_REASONS = {
    "budget": "the budget of frequencies (max_samples) was reached before the interval was resolved",
    "fold": "a fold in ω: two branches born or dying together, joined through it (no sample can resolve it)",
    "min_step": "roots still unmatched at the smallest step (min_step): a curve ends or moves too fast in ω",
    "sweep": "a curve may cross the whole mass range inside the interval, not seen down to SWEEP_STEP",
    "range": "a curve leaves the sampled frequency range inside the mass range: it goes on outside it",
}


@dataclass(frozen=True)
class UnresolvedInterval:
    """A frequency interval ``[low, high]`` that the sampling left unresolved, and why: a key of
    ``UNRESOLVED_REASONS`` (``budget``, ``fold``, ``min_step``, ``sweep``, ``range``)."""

    low: float
    high: float
    reason: str

    def __post_init__(self):
        if self.reason not in UNRESOLVED_REASONS:
            raise InputError(f"unknown reason {self.reason!r} for an unresolved interval")


@dataclass(frozen=True)
class TransferMap:
    """The neutral curves of the ``(m, U*)`` plane from ``G(iω)`` at ``frequencies`` (+ ω = 0):
    dynamic curves, divergence lines ``U*_D = √(m/λ)`` with their crossing rates, the cost, and the
    intervals of ω left unresolved, each with its reason."""

    curves: tuple[TransferCurve, ...]
    divergence_lambdas: np.ndarray
    divergence_rates: np.ndarray
    frequencies: np.ndarray
    mass_range: tuple[float, float]
    factorisations: int
    unresolved: tuple[UnresolvedInterval, ...]
    rational_fits: int = 0  # certified rational fits that refined the sampling below min_step
    interpolated: int = 0  # frequencies sampled from them
    resonance_models: int = 0  # reduced fluid models at resonances and at s = 0 (exact samples elsewhere)
    # the factorisations behind the map over every run that built it: this run's (``factorisations``)
    # and those of the saved samples and models it reused (one per exact sample, one per model)
    factorisations_total: int = 0
    # wall time of the batches of exact samples (in threads or on dask workers), seconds
    sampling_seconds: float = 0.0

    def divergence_velocities(self, mass_ratio: float) -> np.ndarray:
        # λ is the static load slope per unit inertia r_θ² (docs/model.md §8): U*_D = √(m · 1 / λ)
        return np.asarray(divergence_velocity(self.divergence_lambdas, 1.0, mass_ratio), dtype=float)

    def crossings_at(self, mass_ratio: float) -> list[tuple[float, float, str]]:
        """All neutral points at ``mass_ratio``, sorted by U*: ``(U*, crossing rate, kind)``."""
        points = [
            (u, rate, "divergence")
            for u, rate in zip(self.divergence_velocities(mass_ratio), self.divergence_rates, strict=True)
        ]
        for curve in self.curves:
            points += [(u, rate, curve.kind) for u, _, rate in curve.crossings_at(mass_ratio)]
        return sorted(points)


def unstable_counts(
    tmap: TransferMap,
    mass_ratio: float,
    velocities: Sequence[float],
    base: int = 0,
    kinds: Sequence[str] = ("divergence", "flutter", "viv"),
) -> np.ndarray:
    """Number of unstable coupled modes at ``(mass_ratio, U*)`` for each U* in ``velocities``:
    ``base`` (the count below the lowest neutral point, e.g. from the eigen-solver) plus the signed
    crossings (``+1`` onset, ``-1`` restabilisation) below each U*, of the curves of ``kinds``."""
    crossings = [(u, rate) for u, rate, kind in tmap.crossings_at(mass_ratio) if kind in kinds]
    return np.array([base + sum(1 if rate > 0 else -1 for u, rate in crossings if u < v) for v in velocities])


def _signed_count(crossings, velocities: np.ndarray, kind: str) -> np.ndarray:
    """:func:`unstable_counts` (``base`` 0) of one family from the crossings at one mass ratio."""
    signs = [(u, 1 if rate > 0 else -1) for u, rate, k in crossings if k == kind]
    return np.array([sum(sign for u, sign in signs if u < v) for v in velocities], dtype=int)


def transfer_neutral_map(
    fluid: FluidOperators,
    template: Solid,
    *,
    mass_range: tuple[float, float] = (1.0, 1e4),
    omega_range: tuple[float, float] | None = None,
    follow_low: bool | None = None,
    wake_frequency: float | None = None,
    initial: int = 48,
    tolerance: float | None = None,
    min_step: float | None = None,
    max_samples: int | None = None,
    samples_path: Path | None = None,
    reduced: ReducedModels | None = None,
    counter: FactorCounter | None = None,
    progress: Progress = None,
    threads: int | None = None,
    fit_first: bool = True,
    resonance_blocks: int = RESONANCE_BLOCKS,
    client=None,
) -> TransferMap:
    """Every neutral curve of the ``(m, U*)`` plane with ``m`` in ``mass_range`` and frequency in
    ``omega_range`` (module docstring), for the solid parameters of ``template`` other than ``m``
    and ``U*``; divergence from ``G(0)``. Without ``omega_range`` the range is
    :func:`default_frequency_range` and (``follow_low``, the default then) extended down by
    halving while a curve leaves it inside the mass range, down to ``LOWEST_FREQUENCY`` (the
    flutter curve's restabilisation branch). ``wake_frequency``, if given, is only a guess that adds
    initial frequencies around it and widens the default range; curves are labelled ``flutter`` or
    ``viv`` from their own roots (:func:`fsistab.neutral_map.curve_kind`).

    From ``initial`` log-spaced frequencies (and every saved one) the refinement policy
    (:class:`fsistab.map_refinement.RefinementPolicy`) samples until every root in the mass range is
    matched to its neighbour's within ``tolerance`` in ``(log m, log U*)`` by its tangent, down to the
    relative step ``min_step``, at most ``max_samples`` frequencies that cost a factorisation (or a
    reduced model); intervals it leaves are listed with their reasons (:class:`UnresolvedInterval`).

    Where the samples come from (:mod:`fsistab.map_sources`): with ``reduced``
    (:class:`fsistab.reduced_model.ReducedModels`), reduced models certified on intervals, built near
    exact samples (defaults ``tolerance`` 3e-3, ``min_step`` 1e-7, ``max_samples`` 4000); without,
    exact samples (``threads`` at a time, each kept as it finishes and saved by the store), reduced models of
    ``resonance_blocks`` Krylov blocks at a sharp resonance and at ``s = 0`` (0: none), and certified
    rational fits of the exact samples, tried before exact bisections with ``fit_first`` (defaults
    ``EXACT_TOLERANCE``, 1e-3, 400 not counting fitted frequencies). With ``samples_path`` the samples
    and models are saved and reused by a rerun of the same mesh and flow, for any solid parameters;
    models lost from a damaged file are rebuilt (:meth:`fsistab.reduced_model.ReducedModels.restore`).

    The result's ``factorisations`` are this run's (counted by ``counter``), its
    ``factorisations_total`` those of every run that built the samples and models it reuses.

    ``client``: a ``dask.distributed`` client whose workers factorise the batches of exact samples
    (:class:`fsistab.map_distributed.DistributedExactSource`; the same samples, bit for bit, hence
    the same map); None: ``threads`` in this process.
    """
    exact = reduced is None
    policy = _refinement_policy(
        mass_range,
        omega_range,
        follow_low,
        wake_frequency,
        tolerance,
        min_step,
        max_samples,
        exact,
        fit_first,
    )
    counter = counter if counter is not None else FactorCounter()
    say = progress or (lambda message: None)
    start = counter.count
    # the antisymmetric fields only, for a symmetric section at zero incidence (fsistab.symmetry):
    # the same G from half the unknowns
    fluid = antisymmetric_operators(fluid)
    # finished samples (checksummed; a damaged file is reported and recomputed, another flow's refused)
    store = SampleStore.at(samples_path, fluid)
    resonances = _resonance_models(fluid, samples_path, resonance_blocks, say) if exact else None
    reused = _reused_factorisations(store, (reduced, resonances))
    sources = _map_sources(fluid, store, reduced, resonances, counter, threads, client, say)
    tracker = RootTracker(template, policy.wide, fluid.theta0, fluid.loads0)
    engine = MapEngine(policy, sources, store, tracker, counter, say)
    run = _run_engine(engine, sources, initial_frequencies(policy.omega_range, initial, wake_frequency))
    spent = counter.count - start
    return _transfer_map(run, sources, policy, template, fluid, (spent, spent + reused))


def _reused_factorisations(store: SampleStore, saved: Sequence[ReducedModels | None]) -> int:
    """The factorisations behind the saved samples and models this run reuses (one per exact
    sample, one per model): with this run's, the map's ``factorisations_total``. Counted before the
    models lost from a damaged file are rebuilt where they were
    (:meth:`fsistab.reduced_model.ReducedModels.restore`): those are this run's."""
    reused = store.reused_factorisations + sum(len(m.models) for m in saved if m is not None)
    for models in saved:
        if models is not None:
            models.restore()  # those lost from a damaged file, rebuilt where they were
    return reused


def _map_sources(
    fluid, store: SampleStore, reduced, resonances, counter: FactorCounter, threads, client, say
) -> MapSources:
    """Where the samples come from (:mod:`fsistab.map_sources`): exact samples, ``threads`` at a time
    in this process or, with ``client``, on its ``dask.distributed`` workers
    (:class:`fsistab.map_distributed.DistributedExactSource`: the same samples, bit for bit, hence the
    same map); the reduced models at sharp resonances and at ``s = 0`` (``resonances``, their
    factorisations charged to ``counter``); certified rational fits of the saved samples; and with
    ``reduced``, reduced models certified on intervals, built near exact samples."""
    exact_source = (
        ExactSource(fluid, counter, threads)
        if client is None
        else DistributedExactSource(fluid, counter, client, say)
    )
    sources = MapSources(
        exact_source,
        ResonanceSource(resonances),
        RationalFitSource(store, FIT_MARGINS),
        ReducedSource(reduced, store, say) if reduced is not None else None,
    )
    sources.resonances.charge(counter)
    return sources


def _run_engine(engine: MapEngine, sources: MapSources, frequencies):
    """The map engine's loop from ``frequencies``; what the exact source holds (operators on dask
    workers) freed however the loop ends."""
    try:
        return engine.run(frequencies)
    finally:
        sources.exact.release()


def _transfer_map(run, sources: MapSources, policy, template: Solid, fluid, factorisations) -> TransferMap:
    """The map of the loop's ``run``: curves assembled from its roots, divergence from ``G(0)``;
    ``factorisations``: this run's and the total."""
    tracker = run.tracker
    curves = _assemble(tracker.roots, tracker.tracks, policy.inner)
    lambdas, rates = divergence_lines(run.static, template, fluid.theta0, fluid.loads0)
    return TransferMap(
        tuple(curves),
        lambdas,
        rates,
        np.array(sorted({0.0, *tracker.roots})),
        (float(policy.inner[0]), float(policy.inner[1])),
        factorisations[0],
        unresolved_intervals(run.unresolved, curves),
        len(sources.fits.fits),
        run.interpolated,
        len(sources.resonances.covers),
        factorisations_total=factorisations[1],
        sampling_seconds=sources.exact.seconds,
    )


def _refinement_policy(
    mass_range, omega_range, follow_low, wake_frequency, tolerance, min_step, max_samples, exact, fit_first
) -> RefinementPolicy:
    """The policy of :func:`transfer_neutral_map`'s arguments, defaults filled in and checked (one
    clear error before any work)."""
    tolerance = tolerance if tolerance is not None else (EXACT_TOLERANCE if exact else 3e-3)
    min_step = min_step if min_step is not None else (1e-3 if exact else 1e-7)
    max_samples = max_samples if max_samples is not None else (400 if exact else 4000)
    follow = omega_range is None if follow_low is None else follow_low
    omega_range = default_frequency_range(wake_frequency) if omega_range is None else omega_range
    _check_ranges(mass_range, omega_range, tolerance, min_step)
    low, high = mass_range
    return RefinementPolicy(
        inner=(low, high),
        wide=(low / 4, high * 4),  # roots followed; those in mass_range must be matched
        omega_range=omega_range,
        tolerance=tolerance,
        min_step=min_step,
        max_samples=max_samples,
        exact=exact,
        follow=follow,
        fit_first=fit_first,
    )


def _check_ranges(mass_range, omega_range, tolerance: float, min_step: float) -> None:
    """One clear error for a bad mass range, frequency range, tolerance or step (before any work)."""
    low, high = mass_range
    if not (0 < low < high and math.isfinite(high)):
        raise InputError(f"the mass-ratio range must satisfy 0 < low < high, got {mass_range}")
    if not (0 < omega_range[0] < omega_range[1] and math.isfinite(omega_range[1])):
        raise InputError(f"the frequency range must satisfy 0 < low < high, got {omega_range}")
    if not 0 < tolerance < 0.5 or not 0 < min_step < 0.5:
        raise InputError(f"tolerance and min_step must be in (0, 0.5), got {tolerance}, {min_step}")


def _resonance_models(fluid, samples_path, blocks: int, say) -> ReducedModels | None:
    """With exact samples, the reduced models at resonances and at s = 0 (``blocks`` Krylov
    blocks, plain solves: their residual is far below the models' tolerance), saved next to the
    samples (a rerun reuses them); their factorisations are counted apart (:class:`ResonanceSource`)."""
    if not blocks:
        return None
    samples = None if samples_path is None else Path(samples_path)
    path = None if samples is None else samples.with_name(samples.stem + "_resonance_models.nc")
    return ReducedModels(
        fluid,
        tolerance=RESONANCE_TOLERANCE,
        blocks=blocks,
        path=path,
        counter=FactorCounter(),
        progress=say,
        refine=False,
    )


def unresolved_intervals(
    unresolved: dict[tuple[float, float], str], curves: Sequence[TransferCurve]
) -> tuple[UnresolvedInterval, ...]:
    """The intervals left unresolved, in order of ω, with their reasons; an interval whose
    unmatched roots are the two ends of a curve joined through a fold in ω (on that side of the
    pair's frequency, :attr:`TransferCurve.folds`) is a ``fold``, whatever stopped its bisection."""
    folds = {(curve.roots[k].frequency, side) for curve in curves for k, side in curve.folds}
    intervals = []
    for (w0, w1), reason in sorted(unresolved.items()):
        if reason != "range" and ((w1, -1) in folds or (w0, +1) in folds):
            reason = "fold"
        intervals.append(UnresolvedInterval(float(w0), float(w1), reason))
    return tuple(intervals)


def _assemble(
    roots: dict[float, list[NeutralRoot]],
    tracks: dict[float, np.ndarray],
    mass_range: tuple[float, float],
) -> list[TransferCurve]:
    """Chain matched roots of adjacent frequencies into curves, join the two branches of a fold in
    ``ω`` (:func:`_fold_links`), keep the curves that enter ``mass_range``, each labelled by
    :func:`fsistab.neutral_map.curve_kind` from its roots in the mass range."""

    grid = sorted(roots)
    successor: dict[tuple[float, int], tuple[float, int]] = {}
    has_predecessor = set()
    for w0, w1 in zip(grid[:-1], grid[1:], strict=True):
        for i, j, _ in _match(roots[w0], roots[w1], log_step(w0, w1), 0.25):
            successor[(w0, i)] = (w1, j)
            has_predecessor.add((w1, j))
    chains = []
    for w in grid:
        for i in range(len(roots[w])):
            if (w, i) in has_predecessor:
                continue
            chain, key = [], (w, i)
            while key is not None:
                chain.append(roots[key[0]][key[1]])
                key = successor.get(key)
            chains.append(chain)
    curves = []
    for chain, folds in _join_folds(chains, _fold_links(chains, grid, tracks)):
        inside = [mass_range[0] <= r.mass_ratio <= mass_range[1] for r in chain]
        if len(chain) < 2 or not any(inside):
            continue
        kept = [r for r, ok in zip(chain, inside, strict=True) if ok]
        kind = curve_kind(*_points_of(kept))
        curves.append(TransferCurve(kind, tuple(chain), tuple(folds)))
    return curves


def _points_of(roots: Sequence[NeutralRoot]) -> tuple[list[float], list[float], list[float]]:
    """``(m, U*, ω)`` of roots, as :func:`fsistab.neutral_map.curve_kind` takes them."""
    return [r.mass_ratio for r in roots], [r.reduced_velocity for r in roots], [r.frequency for r in roots]


def _fold_links(
    chains: list[list[NeutralRoot]], grid: list[float], tracks: dict[float, np.ndarray]
) -> dict[tuple[int, int], tuple[tuple[int, int], int]]:
    """Ends of chains that meet at a fold in ``ω``: exactly two chains start (end) at the same
    sampled frequency, not the first (last) one, while the resultant gains (loses) at least two
    real roots in the interval before (after) it — a pair born (dying) there. Returns, for each
    linked end ``(chain, 0 | -1)``, the other end and the side of the fold (``-1`` below, ``+1``
    above the pair's frequency)."""
    index = {w: k for k, w in enumerate(grid)}
    links = {}
    for end, step, side in ((0, -1, -1), (-1, +1, +1)):
        at: dict[float, list[int]] = {}
        for c, chain in enumerate(chains):
            at.setdefault(chain[end].frequency, []).append(c)
        for w, members in at.items():
            k = index[w] + step
            if len(members) != 2 or not 0 <= k < len(grid):
                continue
            if len(tracks[w]) - len(tracks[grid[k]]) >= 2:
                a, b = members
                links[(a, end)] = ((b, end), side)
                links[(b, end)] = ((a, end), side)
    return links


def _join_folds(chains: list[list[NeutralRoot]], links: dict) -> list[tuple[list[NeutralRoot], list]]:
    """Chains joined through their linked ends: ``(roots in order, [(segment, side), ...])``."""
    used = set()
    joined = []
    free = [c for c in range(len(chains)) if (c, 0) not in links or (c, -1) not in links]
    for c in [*free, *range(len(chains))]:  # free ends first; what remains are closed loops
        if c in used:
            continue
        end = 0 if (c, 0) not in links else -1 if (c, -1) not in links else 0
        roots, folds = [], []
        while c not in used:
            used.add(c)
            piece = chains[c] if end == 0 else chains[c][::-1]
            roots.extend(piece)
            other = -1 - end  # the end where this piece leaves
            if (c, other) not in links:
                break
            (c, end), side = links[(c, other)]
            if c not in used:
                folds.append((len(roots) - 1, side))
        joined.append((roots, folds))
    return joined


def as_neutral_map(tmap: TransferMap, template: Solid, points: int = 200):
    """The transfer map in the form of :class:`fsistab.neutral_map.NeutralMap` (same dataset, figure and
    JSON as the continuation method): each curve's points (:meth:`TransferCurve.points`: its exact
    roots and its interpolant through folds in ω) inside the mass range (and the next one outside,
    so that lines reach the edges) with, per point, the unstable side (the sign of its crossing
    rate), and its frequency following (:func:`fsistab.neutral_map.frequency_following`, on
    the roots in the mass range, as its kind), turning points from the Hermite
    interpolants, the divergence line of the largest ``λ`` (lowest ``U*_D``, ``moment_slope =
    λ r_θ²``: the torsional formula's slope), crossings of all curves and the unresolved
    intervals."""

    low, high = tmap.mass_range
    curves = []
    for curve in tmap.curves:
        along = curve.points()
        inside = [low <= m <= high for m, *_ in along]
        keep = [
            p
            for k, p in enumerate(along)
            if inside[k] or (k > 0 and inside[k - 1]) or (k + 1 < len(inside) and inside[k + 1])
        ]
        neutral = tuple(NeutralPoint(m, u, w) for m, u, w, _ in keep)
        folds = tuple(
            TurningPoint(m, u, w, localised=True) for m, u, w in curve.turning_points() if low <= m <= high
        )
        onset = np.mean([rate > 0 for *_, rate in keep]) >= 0.5
        inside_roots = [r for r in curve.roots if low <= r.mass_ratio <= high]
        curves.append(
            NeutralCurve(
                neutral,
                kind=curve.kind,
                boundary="onset" if onset else "restabilisation",
                turning_points=folds,
                stops=("", ""),
                unstable_sides=tuple(int(np.sign(rate)) for *_, rate in keep),
                frequency_following=frequency_following(*_points_of(inside_roots)),
            )
        )
    masses = np.geomspace(low, high, points)
    slope = (
        float(tmap.divergence_lambdas.max() * template.r_theta**2) if len(tmap.divergence_lambdas) else 0.0
    )
    divergence = divergence_curve(slope, template.r_theta, masses)
    crossings = map_crossings(curves, masses, divergence, template.r_theta, slope)
    unresolved = tuple((u.low, u.high, u.reason) for u in tmap.unresolved)
    return NeutralMap(tuple(curves), masses, divergence, slope, crossings, tmap.factorisations, unresolved)


def nearest_on_map(
    tmap: TransferMap, mass_ratio: float, reduced_velocity: float, frequency: float
) -> tuple[float, float] | None:
    """The point ``(U*, ω)`` of the map's dynamic curves at ``mass_ratio`` nearest to a given
    neutral point (in ``|log U*|`` plus relative ``ω``): how a point of another method (e.g. the
    continuation's) is compared with this one. None if no curve reaches that m."""
    candidates = [p for curve in tmap.curves for p in curve.velocities_at(mass_ratio)]
    if not candidates:
        return None
    return min(
        candidates,
        key=lambda p: abs(math.log(p[0] / reduced_velocity)) + abs(p[1] - frequency) / frequency,
    )


def unstable_grid(
    tmap: TransferMap, masses: Sequence[float], velocities: Sequence[float]
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """:func:`unstable_counts` on a grid (``len(velocities) × len(masses)``, for shading a map),
    counted separately for divergence, flutter and VIV curves (different modes: static, solid
    frequencies, wake frequency): a family whose count falls below zero at some m has a curve
    missing there (:func:`transfer_neutral_map` did not resolve it), so it is left out of that
    column and the column is flagged in ``incomplete[kind]``."""
    total = np.zeros((len(velocities), len(masses)), dtype=int)
    incomplete = {}
    velocities = np.asarray(velocities, dtype=float)
    crossings = [tmap.crossings_at(m) for m in masses]  # once per mass, for the three families
    for kind in ("divergence", "flutter", "viv"):
        counts = np.column_stack([_signed_count(at, velocities, kind) for at in crossings])
        incomplete[kind] = counts.min(axis=0) < 0
        total += np.where(incomplete[kind][None, :], 0, counts)
    return total, incomplete
