"""Pseudo-arclength continuation of a curve ``F(y) = 0`` in ``R^N`` (docs/model.md §8), NumPy only.

The curve is the solution set of ``F: R^N → R^(N-1)``, usually ``y = (x, p)`` with state ``x`` and
one parameter ``p`` (a complex state is passed as its real and imaginary parts by the caller).
Point ``k + 1`` follows from point ``k`` by the predictor ``y_k + Δs t_k`` and Newton on the
bordered system::

    F(y) = 0,      ⟨t_k, y - y_k⟩_W - Δs = 0                     (pseudo-arclength)

where ``⟨a, b⟩_W = Σ w_i a_i b_i`` with non-negative weights ``w`` (zero weights give a seminorm:
the neutral curves of :mod:`fsistab.neutral` measure arclength in the plane ``(U*, log m)`` only).
The predictor direction is the tangent, from the bordered solve::

    [ F_y(y_k)       ] τ = [0]        t_k = τ / ‖τ‖_W              (orientation: ⟨τ, t_{k-1}⟩_W > 0)
    [ (W t_{k-1})ᵀ   ]     [1]

or the secant ``(y_k - y_{k-1}) / ‖y_k - y_{k-1}‖_W``. The problem supplies only ``F`` and a solver
of that bordered matrix (``solve(y, border, rhs, reuse)``), so a solver that reuses a sparse
factorisation (chord Newton) plugs in; :func:`dense_bordered_solver` builds one from a Jacobian
matrix for small problems.

Detection between consecutive points, each localised on the curve by a bracketing root finder
(Illinois regula falsi inside a bisection bracket) along the chord of the bracket:

- turning points (folds) of the parameter ``p = y[parameter]``: sign change of ``t_p`` (tangent
  predictor) or of the secant's ``Δp`` (secant predictor); located where ``τ_p = 0``;
- events: sign changes of user test functions ``g(y)`` (a Hopf point where the trace of a 2×2
  Jacobian vanishes, two neutral curves crossing, ...), located where ``g = 0``;
- bounds on components of ``y``: the curve stops there (at the bound itself with ``clip``).

The continuation is an iterator of the accepted points, as BifurcationKit.jl's ``ContIterable``
separates the problem, the iteration and its state: a :class:`ContinuationIterator` (problem,
start, direction, settings, bounds, test functions) yields each point as a
:class:`ContinuationPoint` (the point, its tangent, the step to it, the events found on that step)
and says why the curve ended (``stop``); the caller decides when to stop and what to keep.
:func:`continuation` gathers a whole curve into a :class:`ContinuationBranch`.

The corrector is :func:`newton`, the one Newton of the package: it solves any square system
``G(y) = 0`` given ``G`` and a solver of ``G_y δ = rhs`` (:class:`SquareProblem`), e.g. a neutral
point at a fixed point of its parameter plane (:meth:`CurveProblem.pinned`: ``F(y) = 0`` with one
component of ``y`` held, the bordered solve with border ``e_k``). The settings of a continuation
are one frozen, validated :class:`ContinuationSettings`.

Steps grow by ``growth`` after a corrector that needed at most ``fast_iterations`` iterations,
halve after a failure or, with the tangent predictor, when the step's chord or the new tangent
turns by more than ``max_turn`` from the tangent (this also refuses most jumps across an S-shaped
part of the curve), and stay within ``[min_step, max_step]``. The secant predictor has no such
control after the first step (the angle between consecutive secants does not fall with the
step): prefer the tangent predictor on curves with sharp turns.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from numbers import Integral, Real

import numpy as np

from fsistab.errors import ConvergenceError, InputError

Residual = Callable[[np.ndarray], np.ndarray]
BorderedSolve = Callable[[np.ndarray, np.ndarray, np.ndarray, bool], np.ndarray]
SquareSolve = Callable[[np.ndarray, np.ndarray, bool], np.ndarray]

# what a failed evaluation of the residual or of a Newton step may raise: the iteration stops there
_RESIDUAL_ERRORS = (ConvergenceError, FloatingPointError, ValueError)
_SOLVE_ERRORS = (ConvergenceError, np.linalg.LinAlgError, FloatingPointError)


@dataclass(frozen=True)
class SquareProblem:
    """A square system ``G(y) = 0``, ``G: R^N → R^N``, and ``solve(y, rhs, reuse)`` returning ``δ``
    with ``G_y(y) δ = rhs`` (``reuse`` as for :class:`CurveProblem`).

    ``singular_is_root`` says that a ``LinAlgError`` of ``solve`` at ``y`` means that ``y`` is a
    root: for a solver that eliminates through a block which is exactly singular at the root only
    (e.g. ``J(U*)`` in the static problem of :mod:`fsistab.critical`, affine in ``1/U*²``, where a
    Newton step can land on the root exactly). :func:`newton` then stops there, converged."""

    residual: Residual
    solve: SquareSolve
    singular_is_root: bool = False


@dataclass(frozen=True)
class NewtonResult:
    """What :func:`newton` did: the last ``point``, whether it ``converged``, the number of Newton
    steps (``iterations``, one solve each), ``residuals`` ``‖G‖`` at the points of ``path`` (every
    point where ``G`` was evaluated, in order), the last step ``δ`` (``None`` before the first)
    and, on failure, the ``reason``."""

    point: np.ndarray
    converged: bool
    iterations: int
    residuals: tuple[float, ...]
    last_step: np.ndarray | None
    reason: str = ""
    path: tuple[np.ndarray, ...] = ()


def newton(
    problem: SquareProblem,
    start: np.ndarray,
    *,
    tol: float = 1e-10,
    max_iterations: int = 10,
    chord: bool = False,
    small_step: Callable[[np.ndarray, np.ndarray], bool] | None = None,
    final_residual: bool = False,
) -> NewtonResult:
    """Newton's method on ``G(y) = 0`` from ``start``: converged when ``‖G(y)‖ < tol`` or, if given,
    when ``small_step(δ, y_new)`` holds after a step (a step-size criterion evaluates ``G`` once
    less; with ``final_residual`` it does not: ``G`` is evaluated and recorded at ``y_new``, which
    is then returned converged unless that evaluation fails), or at a singular point of a problem
    whose ``singular_is_root`` (:class:`SquareProblem`). With ``chord`` the solver may reuse its
    factorisation (``reuse=True``) while the residual falls at least tenfold per iteration. Never
    raises for a failed iteration: an exception of the residual (:class:`ConvergenceError`,
    ``FloatingPointError``, ``ValueError``) or of the solve (:class:`ConvergenceError`,
    ``LinAlgError``, ``FloatingPointError``), a non-finite value, or ``max_iterations`` steps
    without convergence return ``converged=False`` with the reason.
    """
    if final_residual and small_step is None:
        raise InputError("final_residual applies to a small_step criterion: give one")
    trace = _NewtonTrace(np.array(start, dtype=float))
    previous = math.inf
    stepped_small = False
    for iteration in range(max_iterations + 1):
        y = trace.point
        try:
            residual = np.asarray(problem.residual(y), dtype=float)
        except _RESIDUAL_ERRORS as error:
            return trace.result(False, iteration, str(error))
        norm = float(np.linalg.norm(residual))
        trace.residuals.append(norm)
        trace.path.append(y)
        if not math.isfinite(norm):
            return trace.result(False, iteration, "non-finite residual")
        if norm < tol or stepped_small:
            return trace.result(True, iteration)
        if iteration == max_iterations:
            break
        reuse = chord and iteration > 0 and norm <= 0.1 * previous
        previous = norm
        try:
            trace.step = step = np.asarray(problem.solve(y, -residual, reuse), dtype=float)
        except np.linalg.LinAlgError as error:
            singular = problem.singular_is_root
            return trace.result(singular, iteration, "" if singular else str(error))
        except _SOLVE_ERRORS as error:
            return trace.result(False, iteration, str(error))
        if not np.all(np.isfinite(step)):
            return trace.result(False, iteration, "non-finite Newton step")
        trace.point = y + step
        if small_step is not None and small_step(step, trace.point):
            if not final_residual:
                return trace.result(True, iteration + 1)
            stepped_small = True  # converged once G at y is recorded
    return trace.result(False, max_iterations, f"residual {norm:.1e} after {max_iterations} iterations")


@dataclass
class _NewtonTrace:
    """What a Newton iteration has done so far: the current ``point``, the residual norms at the
    points of ``path``, the last ``step``."""

    point: np.ndarray
    residuals: list[float] = field(default_factory=list)
    path: list[np.ndarray] = field(default_factory=list)
    step: np.ndarray | None = None

    def result(self, converged: bool, iterations: int, reason: str = "") -> NewtonResult:
        return NewtonResult(
            self.point, converged, iterations, tuple(self.residuals), self.step, reason, tuple(self.path)
        )


@dataclass(frozen=True)
class CurveProblem:
    """``F(y) = 0`` with ``F: R^N → R^(N-1)`` and a solver of its bordered Jacobian.

    ``solve(y, border, rhs, reuse)`` returns ``δ`` with ``[F_y(y); borderᵀ] δ = rhs``; ``reuse``
    says that a factorisation made at a nearby ``y`` may be reused (chord Newton) — the corrector
    sets it while the residual falls at least tenfold per iteration, a solver may ignore it.
    ``parameter`` is the index of ``p`` in ``y`` (folds are turning points in ``p``); ``weights``
    the arclength weights ``w`` (default all ones).
    """

    residual: Residual
    solve: BorderedSolve
    parameter: int = -1
    weights: np.ndarray | None = None

    @classmethod
    def from_jacobian(
        cls,
        residual: Residual,
        jacobian: Callable[[np.ndarray], np.ndarray],
        *,
        parameter: int = -1,
        weights: np.ndarray | None = None,
    ) -> CurveProblem:
        """A small problem with a dense ``(N-1) × N`` Jacobian ``[F_x F_p]``."""
        return cls(residual, dense_bordered_solver(jacobian), parameter, weights)

    def pinned(self, index: int, value: float) -> SquareProblem:
        """The square system ``F(y) = 0, y[index] = value`` (one point of the curve, e.g. a neutral
        point at a fixed mass ratio), solved with the bordered solver and border ``e_index``. The
        held component's step is set exactly (no round-off drift of a held parameter)."""

        def residual(y: np.ndarray) -> np.ndarray:
            return np.append(self.residual(y), y[index] - value)

        def solve(y: np.ndarray, rhs: np.ndarray, reuse: bool) -> np.ndarray:
            border = np.zeros(len(y))
            border[index] = 1.0
            delta = np.array(self.solve(y, border, rhs, reuse), dtype=float)
            delta[index] = rhs[-1]
            return delta

        return SquareProblem(residual, solve)


def dense_bordered_solver(jacobian: Callable[[np.ndarray], np.ndarray]) -> BorderedSolve:
    """Bordered solve ``[F_y; borderᵀ] δ = rhs`` with a dense Jacobian ``F_y`` (``(N-1) × N``)."""

    def solve(y: np.ndarray, border: np.ndarray, rhs: np.ndarray, reuse: bool = False) -> np.ndarray:
        matrix = np.atleast_2d(np.asarray(jacobian(y), dtype=float))
        if matrix.shape != (len(y) - 1, len(y)):
            raise InputError(
                f"the Jacobian of F at a point of R^{len(y)} must be {len(y) - 1} × {len(y)}, "
                f"got {matrix.shape[0]} × {matrix.shape[1]}"
            )
        return np.linalg.solve(np.vstack([matrix, border]), rhs)

    return solve


@dataclass(frozen=True)
class TestFunction:
    """A test function ``g(y)`` whose sign change along the curve is an event; ``terminal`` ends
    the curve there (at the located point when ``localise``)."""

    __test__ = False  # not a pytest class

    function: Callable[[np.ndarray], float]
    terminal: bool = False
    localise: bool = True


@dataclass(frozen=True)
class Event:
    """A special point between points ``index`` and ``index + 1`` of a curve (those of a
    :class:`ContinuationBranch`, the ``index`` of a :class:`ContinuationPoint`).

    ``kind`` is ``"fold"`` (turning point in the parameter), ``"bound"`` or the name of a test
    function; ``component`` the index in ``y`` of the folding parameter or of the bounded
    component; ``point`` the full point ``y`` (on the curve when ``localised``), ``arclength``
    its pseudo-arclength from the start, ``value`` the test function there (``τ_p`` for a fold),
    ``iterations`` the corrector solves spent locating it.
    """

    kind: str
    index: int
    point: np.ndarray
    arclength: float
    value: float
    localised: bool
    iterations: int
    component: int | None = None

    @property
    def parameter_value(self) -> float:
        """``y[component]`` at the event (the fold value of the parameter)."""
        return float(self.point[self.component if self.component is not None else -1])


@dataclass(frozen=True)
class ContinuationBranch:
    """A continued curve, as :func:`continuation` gathers it: ``points`` (rows, as recorded),
    unit ``tangents`` (the predictor direction at each point: tangent, or incoming secant),
    ``steps`` the ``Δs`` of each accepted step, ``iterations`` the corrector iterations of each
    point, ``events`` in order of arclength, ``stop`` why the continuation ended (``max_points``,
    ``bound``, ``step_too_small`` or ``event:<name>``)."""

    points: np.ndarray
    tangents: np.ndarray
    steps: np.ndarray
    iterations: np.ndarray
    events: tuple[Event, ...]
    stop: str
    parameter: int = -1
    stop_event: Event | None = field(default=None)

    def __post_init__(self):
        for name in ("points", "tangents", "steps", "iterations"):
            value = np.array(getattr(self, name))
            value.setflags(write=False)
            object.__setattr__(self, name, value)

    @property
    def arclengths(self) -> np.ndarray:
        return np.concatenate([[0.0], np.cumsum(self.steps)])

    @property
    def folds(self) -> tuple[Event, ...]:
        return tuple(e for e in self.events if e.kind == "fold")

    @property
    def parameter_values(self) -> np.ndarray:
        return self.points[:, self.parameter]


class _StepFailure(Exception):
    """The corrector failed for this step size (caught inside this module)."""


def _wdot(weights: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    return float(np.dot(weights * a, b))


def _wnorm(weights: np.ndarray, a: np.ndarray) -> float:
    return math.sqrt(max(_wdot(weights, a, a), 0.0))


def _sign(value: float) -> int:
    return 1 if value > 0 else (-1 if value < 0 else 0)


@dataclass(frozen=True)
class _Curve:
    """The numerical kernel shared by the continuation and the localisation: corrector, tangent
    and the fold test ``τ_p`` of the component ``parameter``."""

    problem: CurveProblem
    weights: np.ndarray
    tol: float
    max_iterations: int
    parameter: int

    def correct(self, guess: np.ndarray, anchor: np.ndarray, direction: np.ndarray, step: float):
        """:func:`newton` (chord) on ``F(y) = 0, ⟨direction, y - anchor⟩_W = step`` from ``guess``."""
        border = self.weights * direction
        system = SquareProblem(
            lambda y: np.append(self.problem.residual(y), border @ (y - anchor) - step),
            lambda y, rhs, reuse: self.problem.solve(y, border, rhs, reuse),
        )
        result = newton(system, guess, tol=self.tol, max_iterations=self.max_iterations, chord=True)
        if not result.converged:
            raise _StepFailure(result.reason)
        return result.point, result.iterations

    def tangent(self, y: np.ndarray, previous: np.ndarray, reuse: bool) -> np.ndarray:
        """Unit tangent at ``y`` oriented along ``previous`` (bordered solve with ``W previous``)."""
        rhs = np.zeros(len(y))
        rhs[-1] = 1.0
        try:
            tau = self.problem.solve(y, self.weights * previous, rhs, reuse)
        except (ConvergenceError, np.linalg.LinAlgError, FloatingPointError) as error:
            raise _StepFailure(str(error)) from error
        norm = _wnorm(self.weights, tau)
        if not (math.isfinite(norm) and norm > 0):
            raise _StepFailure("the tangent has no component along the weighted arclength")
        return tau / norm

    def fold_test(self, point: np.ndarray, chord: np.ndarray) -> float:
        """``τ_p`` at ``point``: the parameter component of an exact tangent (no chord
        factorisation) oriented along ``chord``, which vanishes at a fold."""
        return float(self.tangent(point, chord, reuse=False)[self.parameter])


def _locate(
    curve: _Curve,
    start: np.ndarray,
    end: np.ndarray,
    test: Callable[[np.ndarray, np.ndarray], float],
    values: tuple[float, float],
    tol: float,
    max_iterations: int,
):
    """Zero of ``test(y, chord)`` between two points of the curve that bracket a sign change.

    Points between are parametrised by ``σ ∈ [0, L]`` along the chord ``u = (end - start)/L``:
    ``F(y) = 0, ⟨u, y - start⟩_W = σ`` (a graph over the chord while the direction turns by less
    than 90°), predicted by linear interpolation. Illinois regula falsi, falling back to bisection
    when it leaves the bracket; stops when ``|g| ≤ tol · max|g(ends)|`` or the bracket is shorter
    than ``tol · L``. Returns ``(y, σ/L, g, iterations, localised)``.
    """
    chord = end - start
    length = _wnorm(curve.weights, chord)
    u = chord / length
    lo, hi = 0.0, length
    g_lo, g_hi = values
    scale = max(abs(g_lo), abs(g_hi))
    best = (start, 0.0, g_lo) if abs(g_lo) <= abs(g_hi) else (end, 1.0, g_hi)
    side = 0
    for iteration in range(1, max_iterations + 1):
        sigma = (lo * g_hi - hi * g_lo) / (g_hi - g_lo)
        if not (lo < sigma < hi) or not math.isfinite(sigma):
            sigma = 0.5 * (lo + hi)
        try:
            y, _ = curve.correct(start + (sigma / length) * chord, start, u, sigma)
            g = test(y, u)
        except _StepFailure:
            return best[0], best[1], best[2], iteration, False
        if abs(g) < abs(best[2]):
            best = (y, sigma / length, g)
        if abs(g) <= tol * scale or (hi - lo) <= tol * length:
            return y, sigma / length, g, iteration, True
        if _sign(g) == _sign(g_hi):
            hi, g_hi = sigma, g
            if side == 1:
                g_lo /= 2
            side = 1
        else:
            lo, g_lo = sigma, g
            if side == -1:
                g_hi /= 2
            side = -1
    return best[0], best[1], best[2], max_iterations, False


@dataclass(frozen=True)
class _Bracket:
    """Two points of the curve ``start`` (index ``index``) and ``end`` that bracket a sign change;
    ``middle`` the accepted point between them for a fold bracket of the secant predictor."""

    start: np.ndarray
    index: int
    start_arclength: float
    end: np.ndarray
    end_arclength: float
    middle: np.ndarray | None = None

    def locate(self, curve, kind, test, values, component, localise, tol, max_iterations) -> Event:
        """The event where ``test`` vanishes (located by :func:`_locate` when ``localise``,
        otherwise linearly interpolated and not on the curve)."""
        if localise:
            point, fraction, value, its, ok = _locate(
                curve, self.start, self.end, test, values, tol, max_iterations
            )
        else:
            fraction = values[0] / (values[0] - values[1])
            point, value, its, ok = self.start + fraction * (self.end - self.start), math.nan, 0, False
        index = self.index
        if self.middle is not None:  # which of the two steps holds it
            chord = self.end - self.start
            middle = _wdot(curve.weights, chord, self.middle - self.start) / _wdot(
                curve.weights, chord, chord
            )
            index += 1 if fraction > middle else 0
        arclength = self.start_arclength + fraction * (self.end_arclength - self.start_arclength)
        return Event(kind, index, point, arclength, value, ok, its, component)


def _event_test(function: Callable[[np.ndarray], float]):
    return lambda y, _chord: float(function(y))


def _excess(index: int, bound: float):
    return lambda y, _chord: float(y[index] - bound)


@dataclass(frozen=True)
class ContinuationSettings:
    """How a continuation (:class:`ContinuationIterator`) steps along a curve (module doc),
    validated on construction.

    ``step`` the first ``Δs``, kept in ``[min_step, max_step]``, multiplied by ``growth`` after a
    corrector of at most ``fast_iterations`` iterations; ``max_points`` recorded points (the start
    included); ``predictor`` ``"tangent"`` (one bordered solve per point, exact fold brackets) or
    ``"secant"`` (no extra solve); ``max_turn`` (rad) the largest turn of the direction in one
    step; ``tol``/``max_iterations`` the corrector's (:func:`newton`); ``locate_tol``/
    ``max_locate_iterations`` those of the localisation of folds, events and bounds; ``clip`` ends
    a curve at a bound itself (else at the first point beyond it); ``detect_folds``,
    ``locate_folds`` report turning points in the parameter and locate them on the curve;
    ``correct_start`` corrects the start onto the curve first.
    """

    step: float = 0.1
    min_step: float = 1e-4
    max_step: float = 1.0
    max_points: int = 200
    predictor: str = "tangent"
    tol: float = 1e-10
    max_iterations: int = 10
    fast_iterations: int = 3
    growth: float = 1.5
    max_turn: float = 0.5
    locate_tol: float = 1e-10
    max_locate_iterations: int = 40
    clip: bool = True
    detect_folds: bool = True
    locate_folds: bool = True
    correct_start: bool = True

    def __post_init__(self):
        if self.predictor not in ("tangent", "secant"):
            raise InputError(f"predictor must be 'tangent' or 'secant', not {self.predictor!r}")
        for name in ("step", "min_step", "max_step", "growth", "max_turn", "tol", "locate_tol"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, Real) or not math.isfinite(value):
                raise InputError(f"continuation setting {name} must be a finite number, got {value!r}")
        for name in ("max_points", "max_iterations", "fast_iterations", "max_locate_iterations"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, Integral):
                raise InputError(f"continuation setting {name} must be an integer, got {value!r}")
        if not (0 < self.min_step <= self.step <= self.max_step) or self.growth < 1 or self.max_points < 1:
            raise InputError("steps must satisfy 0 < min_step ≤ step ≤ max_step, growth ≥ 1, max_points ≥ 1")
        if self.tol <= 0 or self.locate_tol <= 0 or self.max_turn <= 0:
            raise InputError("tolerances and max_turn must be positive")
        if self.max_iterations < 0 or self.fast_iterations < 0 or self.max_locate_iterations < 1:
            raise InputError("iteration counts must be non-negative (max_locate_iterations ≥ 1)")

    @classmethod
    def neutral_curve(cls, **fields) -> ContinuationSettings:
        """The settings of a neutral curve (:mod:`fsistab.neutral`, :mod:`fsistab.flow_neutral`):
        each corrector iteration costs a factorisation, so at most 12 (4 count as fast) and 8 to
        locate an event; a curve ends at the first point beyond a bound. ``fields`` override."""
        base = {"clip": False, "max_iterations": 12, "fast_iterations": 4, "max_locate_iterations": 8}
        return cls(**{**base, **fields})


@dataclass(frozen=True)
class ContinuationPoint:
    """One accepted point of a curve, as :class:`ContinuationIterator` yields it.

    ``index`` counts the points (0: the corrected start); ``point`` the full ``y``; ``tangent`` the
    unit predictor direction at it (the tangent, or the incoming secant); ``step`` the ``Δs`` of
    the step to it (0 at the start) and ``arclength`` its pseudo-arclength from the start;
    ``iterations`` the corrector's; ``events`` those found on the step to it, in order of
    arclength, the terminal one (which ends the curve here) last."""

    index: int
    point: np.ndarray
    tangent: np.ndarray
    step: float
    arclength: float
    iterations: int
    events: tuple[Event, ...] = ()


@dataclass
class _State:
    """Where an iteration stands: the last accepted ``point`` (number ``count - 1``) with its
    ``tangent``, ``arclength`` and test-function ``values``, the point before it (for the fold
    brackets of the secant predictor), and the ``step`` ``Δs`` to try next."""

    point: np.ndarray
    tangent: np.ndarray
    arclength: float
    values: dict[str, float]
    step: float
    count: int = 1
    previous: np.ndarray | None = None
    previous_arclength: float = 0.0


def _checked_start(problem: CurveProblem, start, direction) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(y0, weights, d0)``: the start, the arclength weights and the initial direction (not yet
    normalised), validated (:class:`~fsistab.errors.InputError`)."""
    y0 = np.array(start, dtype=float)
    n = y0.size
    if y0.ndim != 1 or n < 2:
        raise InputError("the start of a curve is a point of R^N with N ≥ 2 (state and parameter)")
    weights = np.ones(n) if problem.weights is None else np.asarray(problem.weights, dtype=float)
    if weights.shape != (n,) or np.any(weights < 0) or not np.any(weights > 0):
        raise InputError(f"the arclength weights must be {n} non-negative numbers, not all zero")
    d0 = np.asarray(direction, dtype=float)
    if d0.shape != (n,) or _wnorm(weights, d0) == 0:
        raise InputError("the initial direction must have a nonzero weighted component")
    return y0, weights, d0


def _checked_bounds(bounds, y0: np.ndarray) -> dict[int, tuple[float, float]]:
    """The bounds on components of ``y``, each ``low < high`` with the start inside."""
    bounds = dict(bounds or {})
    for index, (low, high) in bounds.items():
        if not low < high:
            raise InputError(f"bound on y[{index}] must have low < high, got ({low:g}, {high:g})")
        if not low <= y0[index] <= high:
            raise InputError(
                f"the start has y[{index}] = {y0[index]:g} outside its bounds ({low:g}, {high:g})"
            )
    return bounds


class ContinuationIterator:
    """Pseudo-arclength continuation of the curve ``F(y) = 0`` of ``problem`` (module doc) as an
    iterator of its accepted points (:class:`ContinuationPoint`), in the manner of
    BifurcationKit.jl's ``ContIterable``: the caller decides when to stop and what to keep.

    ``direction`` orients the first step (e.g. ``+e_p``: increasing parameter), the first predictor
    being the tangent oriented along it; ``settings`` (default :class:`ContinuationSettings`) say
    how to step; ``bounds`` maps component indices to ``(low, high)``: leaving them ends the curve,
    at the bound itself when ``settings.clip``; ``events`` maps names to test functions ``g(y)``.
    The first point is the corrected start. Only the last two points are kept.

    ``stop`` says why the curve ends (``max_points``, ``bound``, ``event:<name>`` as soon as the
    last point is yielded, ``step_too_small`` once the iteration ended after a failed step),
    ``stop_event`` the bound or terminal event there; both are ``None`` before. Raises
    :class:`~fsistab.errors.ConvergenceError` when the start cannot be corrected onto the curve, has
    no tangent, or no step down to ``min_step`` converges from it. Single pass: iterate once.
    """

    def __init__(
        self,
        problem: CurveProblem,
        start: np.ndarray,
        direction: np.ndarray,
        settings: ContinuationSettings | None = None,
        *,
        bounds: Mapping[int, tuple[float, float]] | None = None,
        events: Mapping[str, TestFunction | Callable[[np.ndarray], float]] | None = None,
    ):
        self.settings = settings if settings is not None else ContinuationSettings()
        y0, weights, d0 = _checked_start(problem, start, direction)
        self.parameter = problem.parameter % y0.size
        self.bounds = _checked_bounds(bounds, y0)
        self.tests = {
            name: (g if isinstance(g, TestFunction) else TestFunction(g))
            for name, g in (events or {}).items()
        }
        self._curve = _Curve(
            problem, weights, self.settings.tol, self.settings.max_iterations, self.parameter
        )
        self._start, self._direction = y0, d0 / _wnorm(weights, d0)
        self._state: _State | None = None
        self.stop: str | None = None
        self.stop_event: Event | None = None

    def __iter__(self) -> ContinuationIterator:
        return self

    def __next__(self) -> ContinuationPoint:
        if self.stop is not None:
            raise StopIteration
        if self._state is None:
            return self._begin()
        accepted = self._advance()
        if accepted is None:
            self.stop = "step_too_small"
            raise StopIteration
        return self._accept(*accepted)

    def _begin(self) -> ContinuationPoint:
        """The start corrected onto the curve (``correct_start``) with its tangent."""
        curve, y0, d0 = self._curve, self._start, self._direction
        iterations = 0
        if self.settings.correct_start:
            try:
                y0, iterations = curve.correct(y0, y0, d0, 0.0)
            except _StepFailure as failure:
                raise ConvergenceError(
                    f"the start point is not on the curve F(y) = 0 ({failure}); give a start closer to "
                    "the curve, e.g. converged by Newton at fixed parameter"
                ) from failure
        try:
            t0 = curve.tangent(y0, d0, reuse=False)
        except _StepFailure as failure:
            raise ConvergenceError(
                f"no tangent at the start point ({failure}): the bordered Jacobian is singular there; "
                "start away from a bifurcation or choose another initial direction"
            ) from failure
        values = {name: float(test.function(y0)) for name, test in self.tests.items()}
        self._state = _State(y0, t0, 0.0, values, float(self.settings.step))
        if self.settings.max_points <= 1:
            self.stop = "max_points"
        return ContinuationPoint(0, y0, t0, 0.0, 0.0, iterations)

    def _advance(self) -> tuple[np.ndarray, np.ndarray, int, float] | None:
        """The next point ``(y, t, iterations, Δs)``, the step halved after each failure; None once
        it falls below ``min_step`` (ConvergenceError if that happens from the start)."""
        state, settings = self._state, self.settings
        h = state.step
        while True:
            try:
                return (*self._predict_correct(h), h)
            except _StepFailure as failure:
                h /= 2
                if h >= settings.min_step:
                    continue
                if state.count == 1:
                    raise ConvergenceError(
                        f"pseudo-arclength corrector failed from the start point down to Δs = "
                        f"{settings.min_step:g} ({failure}); try a smaller min_step, a larger "
                        "max_iterations or another initial direction"
                    ) from failure
                return None

    def _predict_correct(self, h: float) -> tuple[np.ndarray, np.ndarray, int]:
        """Predictor ``y + Δs t``, corrector, new direction; a failure (:class:`_StepFailure`) when
        the corrector fails or the direction turns by more than ``max_turn`` (with ``Δs`` above
        ``min_step``): a large turn, or a jump to another part of the curve."""
        curve, settings, state = self._curve, self.settings, self._state
        weights, y, t = curve.weights, state.point, state.tangent
        y_new, iterations = curve.correct(y + h * t, y, t, h)
        tangent = settings.predictor == "tangent"
        t_new = curve.tangent(y_new, t, reuse=True) if tangent else (y_new - y) / _wnorm(weights, y_new - y)
        chord = (y_new - y) / _wnorm(weights, y_new - y)
        if tangent:  # the chord and both end tangents within max_turn
            turn = min(_wdot(weights, t, t_new), _wdot(weights, t, chord), _wdot(weights, t_new, chord))
        elif state.count == 1:  # t is the tangent at the start
            turn = _wdot(weights, t, chord)
        else:  # t is the previous secant: its angle with the chord does not fall with Δs
            turn = 1.0
        if h > settings.min_step and turn < math.cos(settings.max_turn):
            raise _StepFailure(f"the direction turned by more than {settings.max_turn:g} rad")
        return y_new, t_new, iterations

    def _accept(self, y_new: np.ndarray, t_new: np.ndarray, iterations: int, h: float) -> ContinuationPoint:
        """The events on the step to ``y_new`` (folds, test functions, bounds), the curve ended at
        a bound or terminal event, the state moved on and the step grown after a fast corrector."""
        state, settings = self._state, self.settings
        k, s_k = state.count - 1, state.arclength  # the step goes from point k to point k + 1
        bracket = _Bracket(state.point, k, s_k, y_new, s_k + h)
        found = self._fold_events(bracket, t_new)
        values = {name: float(test.function(y_new)) for name, test in self.tests.items()}
        found += self._test_events(bracket, values)
        terminal = self._terminal(bracket, found)
        if terminal is not None:
            found = [e for e in found if e.arclength <= terminal.arclength and e is not terminal]
            self.stop = "bound" if terminal.kind == "bound" else f"event:{terminal.kind}"
            self.stop_event = terminal
            if terminal.localised:  # the curve ends at the located point
                y_new, h = terminal.point, terminal.arclength - s_k
                t_new = self._end_tangent(y_new, t_new)
        found.sort(key=lambda e: e.arclength)
        events = tuple(found) + ((terminal,) if terminal is not None else ())
        point = ContinuationPoint(state.count, y_new, t_new, h, s_k + h, iterations, events)
        state.previous, state.previous_arclength = state.point, s_k
        state.point, state.tangent, state.arclength, state.values = y_new, t_new, s_k + h, values
        state.count += 1
        if iterations <= settings.fast_iterations:
            h = min(settings.max_step, h * settings.growth)
        state.step = h
        if self.stop is None and state.count >= settings.max_points:
            self.stop = "max_points"
        return point

    def _end_tangent(self, y_end: np.ndarray, t_new: np.ndarray) -> np.ndarray:
        """The direction at a located end point: the secant to it, or its tangent (that of the
        overshooting point if it fails)."""
        state = self._state
        if self.settings.predictor == "secant":
            return (y_end - state.point) / _wnorm(self._curve.weights, y_end - state.point)
        try:
            return self._curve.tangent(y_end, state.tangent, reuse=True)
        except _StepFailure:
            return t_new

    def _fold_events(self, step: _Bracket, t_new: np.ndarray) -> list[Event]:
        """A turning point in the parameter on the step (``detect_folds``): where ``t_p`` changes
        sign, located on the curve (``locate_folds``) between the points whose exact tangents
        bracket ``τ_p = 0`` (for the secant predictor, from the point before the step's start);
        without such a bracket the sampled extremum of ``p``."""
        settings, state, curve, p = self.settings, self._state, self._curve, self.parameter
        if not settings.detect_folds or _sign(state.tangent[p]) * _sign(t_new[p]) >= 0:
            return []
        y, k, s_k, y_new = step.start, step.index, step.start_arclength, step.end
        sampled = Event("fold", k, y, s_k, math.nan, False, 0, p)
        if not settings.locate_folds:
            return [sampled]
        if settings.predictor == "tangent" or k == 0:
            bracket = step
        else:
            bracket = _Bracket(state.previous, k - 1, state.previous_arclength, y_new, step.end_arclength, y)
        try:
            ends = (
                curve.fold_test(bracket.start, y_new - bracket.start),
                curve.fold_test(y_new, y_new - bracket.start),
            )
        except _StepFailure:
            ends = (0.0, 0.0)
        if _sign(ends[0]) * _sign(ends[1]) >= 0:  # no bracket in the tangents
            return [sampled]
        locating = (settings.locate_tol, settings.max_locate_iterations)
        return [bracket.locate(curve, "fold", curve.fold_test, ends, p, True, *locating)]

    def _test_events(self, step: _Bracket, values: dict[str, float]) -> list[Event]:
        """The sign changes of the test functions on the step, each located (``localise``)."""
        locating = (self.settings.locate_tol, self.settings.max_locate_iterations)
        found = []
        for name, test in self.tests.items():
            pair = (self._state.values[name], values[name])
            if _sign(pair[0]) * _sign(pair[1]) < 0:
                g = _event_test(test.function)
                found.append(step.locate(self._curve, name, g, pair, None, test.localise, *locating))
        return found

    def _terminal(self, step: _Bracket, found: list[Event]) -> Event | None:
        """The first (in arclength) of the bounds left on the step (located, on the bound itself
        with ``clip``) and the terminal events found on it."""
        locating = (self.settings.locate_tol, self.settings.max_locate_iterations)
        y, y_new = step.start, step.end
        terminal: Event | None = None
        for index, (low, high) in self.bounds.items():
            if low <= y_new[index] <= high:
                continue
            bound = high if y_new[index] > high else low
            values = (y[index] - bound, y_new[index] - bound)
            event = step.locate(
                self._curve, "bound", _excess(index, bound), values, index, self.settings.clip, *locating
            )
            if terminal is None or event.arclength < terminal.arclength:
                terminal = event
        for event in found:
            if event.kind in self.tests and self.tests[event.kind].terminal:
                if terminal is None or event.arclength < terminal.arclength:
                    terminal = event
        return terminal


def _with_overrides(settings: ContinuationSettings | None, overrides: dict) -> ContinuationSettings:
    """``settings`` (default :class:`ContinuationSettings`) with single fields replaced."""
    settings = settings if settings is not None else ContinuationSettings()
    if not overrides:
        return settings
    unknown = sorted(set(overrides) - {f.name for f in fields(ContinuationSettings)})
    if unknown:
        raise InputError(f"unknown continuation settings {unknown}")
    return replace(settings, **overrides)


def continuation(
    problem: CurveProblem,
    start: np.ndarray,
    direction: np.ndarray,
    settings: ContinuationSettings | None = None,
    *,
    bounds: Mapping[int, tuple[float, float]] | None = None,
    events: Mapping[str, TestFunction | Callable[[np.ndarray], float]] | None = None,
    record: Callable[[np.ndarray], np.ndarray] | None = None,
    on_point: Callable[[np.ndarray, int], None] | None = None,
    on_event: Callable[[Event], None] | None = None,
    **overrides,
) -> ContinuationBranch:
    """The whole curve of a :class:`ContinuationIterator` (``problem``, ``start``, ``direction``,
    ``settings``, ``bounds``, ``events`` as there) as a :class:`ContinuationBranch`.

    Keyword ``overrides`` (``step=0.05``, ...) replace single fields of ``settings``.
    ``record(y)`` selects what is stored per point and tangent (default all of ``y``);
    ``on_point(y, iterations)`` is called for every accepted point after the start, after
    ``on_event`` for the events found on its step. Raises
    :class:`~fsistab.errors.ConvergenceError` as the iterator does; a failure later ends the curve
    with ``stop = "step_too_small"``.
    """
    iterator = ContinuationIterator(
        problem, start, direction, _with_overrides(settings, overrides), bounds=bounds, events=events
    )
    record = record or (lambda y: y)
    points, tangents, steps, counts, found = [], [], [], [], []
    for accepted in iterator:
        for event in accepted.events:
            found.append(event)
            if on_event:
                on_event(event)
        points.append(record(accepted.point))
        tangents.append(record(accepted.tangent))
        counts.append(accepted.iterations)
        if accepted.index > 0:
            steps.append(accepted.step)
            if on_point:
                on_point(accepted.point, accepted.iterations)
    return ContinuationBranch(
        np.array(points),
        np.array(tangents),
        np.array(steps),
        np.array(counts),
        tuple(found),
        iterator.stop,
        iterator.parameter,
        iterator.stop_event,
    )


def polyline_intersections(
    first: Sequence, second: Sequence
) -> list[tuple[np.ndarray, int, float, int, float]]:
    """Crossings of two polylines in the plane (piecewise-linear interpolants of point sequences).

    Returns ``(point, i, a, j, b)`` for every crossing ``point = P_i + a (P_{i+1} - P_i) =
    Q_j + b (Q_{j+1} - Q_j)`` with ``a, b ∈ [0, 1)`` (the last segment's end included), in the order
    of the first polyline. Parallel overlapping segments are not reported.
    """
    p = np.asarray(first, dtype=float)
    q = np.asarray(second, dtype=float)
    if p.ndim != 2 or q.ndim != 2 or p.shape[1] != 2 or q.shape[1] != 2:
        raise InputError("polylines are sequences of points (x, y)")
    if len(p) < 2 or len(q) < 2:
        return []
    # vectorised over the segments of the second polyline: map curves have thousands of points
    dq = np.diff(q, axis=0)
    b_end = np.full(len(dq), np.nextafter(1.0, 0.0))
    b_end[-1] = 1.0
    crossings = []
    for i in range(len(p) - 1):
        dp = p[i + 1] - p[i]
        det = dp[0] * (-dq[:, 1]) - dp[1] * (-dq[:, 0])
        r = q[:-1] - p[i]
        with np.errstate(divide="ignore", invalid="ignore"):
            a = (r[:, 0] * (-dq[:, 1]) - r[:, 1] * (-dq[:, 0])) / det
            b = (dp[0] * r[:, 1] - dp[1] * r[:, 0]) / det
        a_end = 1.0 if i == len(p) - 2 else np.nextafter(1.0, 0.0)
        hit = (det != 0) & (a >= 0.0) & (a <= a_end) & (b >= 0.0) & (b <= b_end)
        for j in np.nonzero(hit)[0]:
            crossings.append((p[i] + a[j] * dp, i, float(a[j]), int(j), float(b[j])))
    return crossings
