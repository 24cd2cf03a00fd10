"""Onset of a fixed body's wake instability: the flow parameter where its leading global mode
becomes neutral (docs/model.md §6, §7).

With the body held fixed (no solid unknowns), the eigenvalues ``σ(p) = λ(p) + iω(p)`` of the
fluid Jacobian about the steady state (``σ M q + J q = 0``, docs/model.md §7) depend on the flow
parameter ``p``: the Reynolds number on the body length, or the steady angle of attack ``α0``
(degrees, nose-up positive) at fixed Re. The onset is the root of the growth rate of the leading
mode, ``λ(p) = Re σ(p) = 0`` (a Hopf bifurcation of the steady wake when ``ω ≠ 0``), found by the
secant method (:func:`secant_onset`)::

    p_{k+1} = p_k - λ_k (p_k - p_{k-1}) / (λ_k - λ_{k-1}),

from ``p_0 = guess`` and ``p_1 = guess + step``. The secant needs no derivative: Newton would
need ``dλ/dp``, a finite difference costing a second steady state and eigenvalue per iterate, so
its order 2 per two evaluations (√2 ≈ 1.41 per evaluation) loses to the secant's order 1.62 per
evaluation. At each iterate the steady state is continued from the previous one
(:func:`fsistab.steady.solve_steady` with ``initial``, cached, so a rerun reuses them) and the
leading mode is followed: shift-invert Arnoldi (:func:`fsistab.eigen.eigenpairs_near`, one
factorisation) near the user's shift at the first iterate (a guess of the eigenvalue, e.g.
``0.75i`` for the cylinder's wake), then near the eigenvalue predicted by linear extrapolation of
the last two, each time at a target :data:`LOOKAHEAD` to the right, keeping the least stable of
the eigenvalues found there (:func:`leading_eigenpair`, as
:func:`fsistab.critical.wake_mode_near`). Before two iterates bracket the root, steps are limited
(:func:`safeguarded_step`).

The iteration stops when ``|λ_k| < tol`` or when the next secant step falls below ``step_tol``
(relative to ``max(1, |p|)``); the critical value is the secant root of the last two iterates and
the critical frequency ``ω_c`` is interpolated linearly in ``p`` between them. Each new iterate is
rounded (:func:`rounded`, ten significant digits of Re, 1e-9 degree of α0) so that a rerun, whose
eigenvalues may differ in their last bits (another BLAS or thread count), meets the same parameter values
and so the steady states it cached. Time is in units of ``L/U∞`` (``ω`` in ``U∞/L``),
``L`` the body length (chord or diameter).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from fsistab.bodies import body_type
from fsistab.errors import ConvergenceError, InputError
from fsistab.params import MAX_REYNOLDS, Flow
from fsistab.progress import Progress

PARAMETERS = ("reynolds", "alpha0")
MAX_ALPHA0 = 45.0  # degrees, as fsistab.params.Flow
# the Arnoldi target lies this far right of the predicted eigenvalue (U∞/L): in a dense cluster
# of modes near the frequency, the eigenvalues nearest it are the least stable ones rather than
# those on either side (on the medium plate at Re 500, α0 = 16°, the six nearest the on-axis
# prediction missed the unstable +0.0648 + 2.4896i and the search wandered); it also keeps the
# shift off the eigenvalue (a shift on an eigenvalue makes J + sM singular)
LOOKAHEAD = 0.1


@dataclass(frozen=True)
class OnsetIterate:
    """One evaluation of the growth rate: the parameter ``value`` (Re, or α0 in degrees), the
    leading ``eigenvalue`` σ with its relative ``residual``, the ``shift`` used, and the cost
    (seconds of the steady state and of the eigenvalue solve, factorisations of both; a steady
    state read from the cache costs none)."""

    value: float
    eigenvalue: complex
    residual: float = 0.0
    shift: complex = 0j
    steady_seconds: float = 0.0
    eigen_seconds: float = 0.0
    factorisations: int = 0
    steady_from_cache: bool = False
    unknowns: int = 0

    @property
    def growth_rate(self) -> float:
        return float(self.eigenvalue.real)

    @property
    def frequency(self) -> float:
        return float(self.eigenvalue.imag)


@dataclass(frozen=True)
class OnsetResult:
    """The critical value of ``parameter`` (``reynolds``, or ``alpha0`` in degrees) where the
    leading mode's growth rate vanishes, its frequency ``ω_c`` there (``U∞/L``), and the iterates
    in order of computation."""

    parameter: str
    critical_value: float
    frequency: float
    iterates: tuple[OnsetIterate, ...]

    @property
    def iterations(self) -> int:
        """Evaluations of the growth rate (a steady state and an eigenvalue solve each)."""
        return len(self.iterates)

    @property
    def factorisations(self) -> int:
        return sum(i.factorisations for i in self.iterates)

    @property
    def strouhal(self) -> float:
        """``St = ω_c/(2π)``: frequency over ``U∞/L``."""
        return self.frequency / (2 * math.pi)


def in_range(parameter: str, value: float) -> bool:
    """Whether ``value`` is a valid ``parameter`` of :class:`fsistab.params.Flow`: Re in
    ``(0, 1e7]``, α0 within ±45°."""
    if not math.isfinite(value):
        return False
    if check_parameter(parameter) == "reynolds":
        return 0 < value <= MAX_REYNOLDS
    return abs(value) <= MAX_ALPHA0


def check_parameter(parameter: str) -> str:
    if parameter not in PARAMETERS:
        raise InputError(f"--parameter must be one of {', '.join(PARAMETERS)}, got {parameter!r}")
    return parameter


def check_onset(kind: str, parameter: str, guess: float, shift: complex | None) -> tuple[float, complex]:
    """The validated ``(guess, shift)`` of an onset search for body ``kind``, before any work.

    The guess must lie in the parameter's range (Re in ``(0, 1e7]``, α0 within ±45°). The shift
    (a guess of the eigenvalue, i.e. mainly of the frequency) must be finite with ``ω >= 0``
    (eigenvalues come in conjugate pairs); None is the cylinder's wake mode ``0.75i`` and is refused
    for the plate, whose wake frequency varies with Re and α0 (``fsistab spectrum`` finds it). The
    cylinder's critical α0 is refused: the cylinder is round, so α0 only turns the free stream
    relative to the body axes and changes no eigenvalue (except by the mesh's lack of rotational
    symmetry): there is no onset in α0 to find.
    """
    try:
        guess = float(guess)
    except (TypeError, ValueError):
        raise InputError(f"--guess must be a number, got {guess!r}") from None
    _check_guess(parameter, guess)
    body = body_type(kind)
    if parameter == "alpha0" and body.axisymmetric:
        raise InputError(
            "the cylinder is round: alpha0 only turns the flow, no eigenvalue depends on it; "
            "use --parameter reynolds"
        )
    if shift is None:
        if not body.wake_shifts:
            raise InputError(
                f"give --shift for the {kind}: a guess of the leading mode's eigenvalue, e.g. 0+11j for "
                "the plate's wake at Re 2900 (fsistab spectrum finds it)"
            )
        shift = body.wake_shifts[0]
    shift = complex(shift)
    if not (math.isfinite(shift.real) and math.isfinite(shift.imag)):
        raise InputError(f"the shift must be finite, got {shift}")
    if shift.imag < 0:
        raise InputError(
            f"the shift's frequency must be >= 0 (eigenvalues come in conjugate pairs), got {shift}"
        )
    return guess, shift


def _check_guess(parameter: str, guess: float) -> None:
    if in_range(parameter, guess):
        return
    if parameter == "reynolds":
        raise InputError(
            f"--guess of the critical Reynolds number must be in (0, {MAX_REYNOLDS:g}], got {guess:g}"
        )
    raise InputError(f"--guess of the critical alpha0 must be within ±{MAX_ALPHA0:g} degrees, got {guess:g}")


def fitted_case(case, parameter: str, guess: float):
    """The case whose mesh serves every iterate: its ``mesh_reynolds`` when given; else for the
    critical Re the mesh is fitted to the guess (the preset's wall size follows ``Re^-1/2``, and the
    onset lies near the guess; the case's own Re is the unknown, not a flow to resolve), for the
    critical α0 to the case's Re."""
    from dataclasses import replace

    if check_parameter(parameter) == "reynolds":
        return replace(case, flow=Flow(guess, case.flow.alpha0_deg))
    return case


def default_step(parameter: str, guess: float) -> float:
    """Distance of the secant's second point from the guess: 2 % of Re, or half a degree of α0
    (away from 0: the growth rate is even in α0, the plate being symmetric)."""
    if check_parameter(parameter) == "reynolds":
        return 0.02 * guess
    return 0.5 if guess >= 0 else -0.5


def rounded(parameter: str, value: float) -> float:
    """``value`` to ten significant digits (Re) or to 1e-9 degree (α0): far below any secant step
    that is taken (``step_tol``), and reproducible from run to run."""
    if check_parameter(parameter) == "reynolds":
        return float(f"{value:.10g}")
    return round(float(value), 9)


def flow_at(base: Flow, parameter: str, value: float) -> Flow:
    """``base`` with ``parameter`` set to ``value`` (Re, or α0 in degrees)."""
    if check_parameter(parameter) == "reynolds":
        return Flow(value, base.alpha0_deg)
    return Flow(base.reynolds, value)


def secant_onset(
    evaluate: Callable[[float, complex], OnsetIterate],
    parameter: str,
    guess: float,
    step: float,
    eigenvalue_guess: complex,
    *,
    tol: float = 1e-7,
    step_tol: float = 1e-6,
    max_iterations: int = 12,
    max_expansion: float = 4.0,
) -> OnsetResult:
    """The root of ``λ(p) = Re σ(p)`` by the secant method from ``guess`` and ``guess + step``.

    ``evaluate(p, predicted)`` returns the iterate at ``p``; ``predicted`` is the eigenvalue
    expected there (``eigenvalue_guess`` at the first point, then the last eigenvalue, then the
    linear extrapolation of the last two), for the caller to follow its mode. Converged when
    ``|λ_k| < tol`` or when the next step ``|p_{k+1} - p_k| < step_tol · max(1, |p_k|)``; the
    values evaluated are :func:`rounded`.

    Safeguards (:func:`safeguarded_step`): until two iterates bracket the root (growth rates of
    opposite signs) a step is at most ``max_expansion`` times the previous one, because a growth
    rate that is flat below the onset and steep near it (the plate's wake mode against α0 at Re 500
    on the default mesh: λ = -0.0745 at 8°, -0.0734 at 8.5°, whose secant step is 42°) would throw
    the plain secant out of the range; once bracketed, a secant step that leaves the bracket is replaced
    by its midpoint. Near a simple root the secant steps stay inside, so its order 1.62 is kept. Raises
    :class:`~fsistab.errors.ConvergenceError` when the growth rate does not change between two
    iterates (no secant), when a step leaves the parameter's range, or after ``max_iterations``
    evaluations.
    """
    if not (math.isfinite(step) and step != 0):
        raise InputError(f"the secant step must be finite and non-zero, got {step}")
    iterates = [evaluate(guess, complex(eigenvalue_guess))]
    value, predicted = rounded(parameter, guess + step), iterates[0].eigenvalue
    while True:
        if not in_range(parameter, value):
            raise ConvergenceError(
                f"the secant on the growth rate left the range of {parameter} ({value:.6g}; last "
                f"iterates {_describe(iterates[-2:])}): give a guess closer to the onset"
            )
        if len(iterates) >= max_iterations:
            raise ConvergenceError(
                f"no onset in {parameter} after {max_iterations} iterates (last {_describe(iterates[-2:])})"
            )
        iterates.append(evaluate(value, predicted))
        previous, last = iterates[-2], iterates[-1]
        if last.growth_rate == previous.growth_rate:
            raise ConvergenceError(
                f"the growth rate does not change between {parameter} = {previous.value:.6g} and "
                f"{last.value:.6g} ({last.growth_rate:.3e}): no onset to find along {parameter}"
            )
        slope = (last.growth_rate - previous.growth_rate) / (last.value - previous.value)
        root = last.value - last.growth_rate / slope
        small = abs(root - last.value) < step_tol * max(1.0, abs(last.value))
        if abs(last.growth_rate) < tol or small:
            # ω at the root, linear between the last two iterates
            rate = (last.frequency - previous.frequency) / (last.value - previous.value)
            frequency = last.frequency + rate * (root - last.value)
            return OnsetResult(parameter, float(root), float(frequency), tuple(iterates))
        step_to = safeguarded_step(iterates, root, max_expansion)
        ratio = (step_to - last.value) / (last.value - previous.value)
        value = rounded(parameter, step_to)
        predicted = last.eigenvalue + ratio * (last.eigenvalue - previous.eigenvalue)


def bracket(iterates) -> tuple[float, float] | None:
    """The narrowest interval between the last iterate and an earlier one of opposite growth-rate
    sign (the root lies inside), or None while every growth rate has the same sign."""
    last = iterates[-1]
    others = [i.value for i in iterates[:-1] if (i.growth_rate > 0) != (last.growth_rate > 0)]
    if not others:
        return None
    nearest = min(others, key=lambda v: abs(v - last.value))
    return (min(nearest, last.value), max(nearest, last.value))


def safeguarded_step(iterates, root: float, max_expansion: float) -> float:
    """The next parameter value from the secant ``root`` of the last two ``iterates``: inside the
    :func:`bracket` when there is one (its midpoint if the secant leaves it), else at most
    ``max_expansion`` times the last step away from the last iterate."""
    last, previous = iterates[-1], iterates[-2]
    interval = bracket(iterates)
    if interval is not None:
        low, high = interval
        return root if low < root < high else 0.5 * (low + high)
    limit = max_expansion * abs(last.value - previous.value)
    return last.value + max(-limit, min(limit, root - last.value))


def _describe(iterates) -> str:
    return ", ".join(f"λ({i.value:.6g}) = {i.growth_rate:.3e}" for i in iterates)


def leading_eigenpair(pairs):
    """The leading mode among ``pairs`` (the eigenpairs nearest the shift): the least stable one.

    Not the one nearest the predicted eigenvalue: where two modes of nearby frequencies exchange
    the lead (the plate's wake at Re 500 between α0 = 9.5° and 10° on the coarse mesh: the mode
    followed by proximity, -0.062 + 4.128i, goes on to -0.145 + 4.057i while the other turns
    unstable, +0.069 + 3.877i), following one branch misses the onset. The growth rate of the
    least stable mode is continuous in the parameter, with a kink where the lead changes hands
    (which the bracketing of :func:`safeguarded_step` copes with)."""
    return max(pairs, key=lambda p: p.growth_rate)


def fixed_body_evaluator(
    spec,
    base: Flow,
    parameter: str,
    *,
    cache_dir: Path | None = None,
    n_eigenvalues: int = 6,
    progress: Progress = None,
) -> Callable[[float, complex], OnsetIterate]:
    """``evaluate(p, predicted)`` for :func:`secant_onset` on the mesh of ``spec``: the steady
    state at ``p`` continued from the previous evaluation's (cached in ``cache_dir``), the fixed
    body's ``n_eigenvalues`` eigenpairs nearest a target :data:`LOOKAHEAD` to the right of the
    predicted eigenvalue (one factorisation), and the least stable of them
    (:func:`leading_eigenpair`)."""
    from fsistab.coupled import CoupledSystem
    from fsistab.eigen import eigenpairs_near
    from fsistab.linalg import FactorCounter
    from fsistab.operators import fluid_operators
    from fsistab.params import Solid
    from fsistab.steady import solve_steady

    say = progress if progress is not None else (lambda message: None)
    previous: list = []  # the last steady state, to continue from

    def evaluate(value: float, predicted: complex) -> OnsetIterate:
        flow = flow_at(base, parameter, value)
        t0 = time.perf_counter()
        say(f"steady state at {parameter} = {value:.8g}")
        steady = solve_steady(spec, flow, cache_dir=cache_dir, initial=previous[-1] if previous else None)
        t_steady = time.perf_counter() - t0
        previous[:] = [steady]
        t0 = time.perf_counter()
        counter = FactorCounter()
        shift = predicted + LOOKAHEAD
        system = CoupledSystem(fluid_operators(steady), Solid(dofs=()))
        say(f"eigenvalues near {shift.real:.4g}{shift.imag:+.4g}i ({system.size} unknowns)")
        pairs = eigenpairs_near(system, [shift], n_eigenvalues, counter=counter)
        pair = leading_eigenpair(pairs)
        steady_factorisations = 0 if steady.from_cache else steady.factorisations
        say(f"{parameter} = {value:.8g}: σ = {pair.growth_rate:+.4e} {pair.frequency:+.6f}i")
        return OnsetIterate(
            value=float(value),
            eigenvalue=complex(pair.value),
            residual=float(pair.residual),
            shift=complex(shift),
            steady_seconds=t_steady,
            eigen_seconds=time.perf_counter() - t0,
            factorisations=counter.count + steady_factorisations,
            steady_from_cache=bool(steady.from_cache),
            unknowns=int(system.size),
        )

    return evaluate


def critical_onset(
    spec,
    base: Flow,
    parameter: str,
    guess: float,
    shift: complex,
    *,
    step: float | None = None,
    tol: float = 1e-7,
    step_tol: float = 1e-6,
    max_iterations: int = 12,
    cache_dir: Path | None = None,
    progress: Progress = None,
) -> OnsetResult:
    """The fixed body's critical ``parameter`` (``reynolds``, or ``alpha0`` in degrees at
    ``base.reynolds``; the other flow parameter is ``base``'s) on the mesh of ``spec``: the
    secant of :func:`secant_onset` on :func:`fixed_body_evaluator`, from ``guess`` and
    ``guess + step`` (:func:`default_step` when None), the leading mode picked near ``shift``."""
    _check_guess(check_parameter(parameter), guess)
    step = default_step(parameter, guess) if step is None else float(step)
    evaluate = fixed_body_evaluator(spec, base, parameter, cache_dir=cache_dir, progress=progress)
    return secant_onset(
        evaluate,
        parameter,
        float(guess),
        step,
        complex(shift),
        tol=tol,
        step_tol=step_tol,
        max_iterations=max_iterations,
    )


def onset_dataset(result: OnsetResult, attrs: dict | None = None):
    """The iterates along dimension ``iterate`` (``value`` of the parameter, ``growth_rate``,
    ``frequency``, residual, shift, cost) and, in attributes, the critical value and frequency,
    the iterations and factorisations, and the units."""
    import numpy as np
    import xarray as xr

    its = result.iterates

    def column(name, dtype=float):
        return ("iterate", np.array([getattr(i, name) for i in its], dtype=dtype))

    units = "Re on the body length" if result.parameter == "reynolds" else "alpha0 in degrees, nose-up +"
    return xr.Dataset(
        {
            "growth_rate": column("growth_rate"),
            "frequency": column("frequency"),
            "residual": column("residual"),
            "shift_real": ("iterate", np.array([i.shift.real for i in its])),
            "shift_imag": ("iterate", np.array([i.shift.imag for i in its])),
            "steady_seconds": column("steady_seconds"),
            "eigen_seconds": column("eigen_seconds"),
            "factorisations": column("factorisations", int),
            "steady_from_cache": column("steady_from_cache", int),
        },
        coords={"iterate": np.arange(len(its)), "value": column("value")},
        attrs={
            "parameter": result.parameter,
            "critical_value": result.critical_value,
            "frequency": result.frequency,
            "strouhal": result.strouhal,
            "iterations": result.iterations,
            "factorisations": result.factorisations,
            "units": f"{units}; sigma = growth_rate + i frequency, time unit L/U (L the body length)",
            **(attrs or {}),
        },
    )
