"""Every threshold along U* at one mass ratio from the exact transfer function swept in frequency:
an exact p–k method (MODEL.md §7–§8).

On the imaginary axis ``s = iω`` the characteristic function of :mod:`fsistab.transfer_map`,

    ``F(u; ω) = det(m W(iω, u) − A(iω))``,   ``u = 1/U*``,

is, at fixed ``m``, a complex polynomial in ``u`` (degree 2 per active dof; :func:`velocity_roots`).
At each frequency its roots ``u_k(ω)`` with ``Re u_k > 0`` are the speeds at which the coupled
system would have a neutral mode of frequency ``ω`` if they were real: a real root is a neutral
point, ``U*_c = 1/u_k``, ``ω_c = ω``. Elsewhere they are complex, and near the in-vacuo relations
(``u ≈ ω/Ω`` in heave, ``u ≈ ω`` in pitch, MODEL.md §2) at large ``m``. Where ``G`` is smooth in
``ω`` so are they: each root is followed from sample to sample, predicted by its exact derivative
``du/dω = −i F_s/F_u`` (implicit differentiation, with ``dG/ds``), and the interval between two
samples is bisected until every root is matched without ambiguity (:func:`_match`: mutual nearest
predictions, prediction error below a fifth of the distance to the other roots and a tenth of
``|u|``) and the sign of ``Im u`` is decided (:func:`_sign_certain`: the linear predictions of
``Im u`` miss by no more than ``|Im u|`` itself, so that a narrow window of instability between
two samples shows and is bisected until it is sampled). A change of sign of ``Im u_k`` across an
interval brackets a neutral point; the cubic Hermite interpolant of ``u_k(ω)`` starts Newton on
the exact ``det T(iω; U*) = 0`` (:func:`fsistab.transfer.transfer_flutter_point`: two or three
factorisations from such a start), and the sign of the crossing rate ``∂(Re σ)/∂(log U*)`` at
the converged point says onset (> 0) or restabilisation as U* grows. Divergence (``ω = 0``) comes
from ``G(0)`` exactly, ``U*_D = √(m/λ)`` (:func:`fsistab.transfer_map.divergence_lines`), one real
factorisation.

The sweep covers the frequencies where a root can lie in the velocity range: it starts from the
in-vacuo frequencies of the range's ends widened by ``BAND_MARGIN`` and widens the band (at most
``MAX_WIDENINGS`` times at each end) until, at its high end, every root is above ``1/U*_min`` and,
at its low end, no root but those tending to the divergence speeds is below ``1/U*_max``. The
samples need no refined solves (they only bracket) and are factorised two at a time
(:func:`fsistab.transfer.transfer_samples`); each costs one factorisation of ``K_ff(iω)``,
independent of ``m`` and ``U*``, against an eigenvalue problem per U* point and branch for the
branch tracking of :func:`fsistab.critical.track_thresholds`. A narrow window is resolved only down
to a relative step ``MIN_STEP`` in ω; intervals left unresolved there are reported.

Units: frequencies in ``U∞/L``, U* and m in the generic conventions of
:class:`fsistab.params.Solid` (MODEL.md §2, §10).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import numpy.polynomial.polynomial as npoly

from fsistab.errors import ConvergenceError, InputError
from fsistab.linalg import FactorCounter, FluidFactor
from fsistab.operators import FluidOperators
from fsistab.params import Solid
from fsistab.transfer import TransferSample, transfer_flutter_point, transfer_sample, transfer_samples
from fsistab.transfer_map import (
    AxisSample,
    characteristic_function,
    divergence_lines,
    scaled_polynomials,
    second_order_loads,
)

INITIAL_RATIO = 1.7  # ratio of neighbouring frequencies of the initial grid
MIN_STEP = 1e-6  # relative step below which an interval is left unresolved
MATCH_SEPARATION = 0.2  # prediction error allowed, relative to the distance to the other roots
MATCH_SIZE = 0.1  # prediction error allowed, relative to |u|
MAX_WIDENINGS = 2  # times the band may grow at each end (by INITIAL_RATIO² each)
MAX_SAMPLES = 200
BAND_MARGIN = 1.3  # the initial band: in-vacuo frequencies of the range, widened by this factor
# Newton on det T stops after a relative step below this: converging quadratically from the
# interpolated start, the next step (not taken) would be below NEWTON_STEP² ~ 1e-16
NEWTON_STEP = 1e-8
RESOLVED = 1.0  # misfit of the linear predictions of Im u allowed, relative to |Im u| (no crossing)
RELEVANT_MARGIN = 1.5  # roots with 1/Re u within this factor of the velocity range are followed closely


@dataclass(frozen=True)
class SweepSample:
    """The roots ``u_k`` (``Re u_k > 0``, sorted by ``Re u``) of ``F(u; ω) = 0`` at one frequency
    and their derivatives ``du_k/dω``; ``sample`` the transfer data they come from."""

    frequency: float
    roots: np.ndarray
    slopes: np.ndarray
    sample: TransferSample


@dataclass(frozen=True)
class SweepThreshold:
    """A threshold of the sweep: ``kind`` flutter, viv or divergence; ``boundary`` onset
    (unstable above ``reduced_velocity`` at fixed m) or restabilisation; ``branch`` the dof with
    most of the critical mode's solid kinetic energy (``static`` for divergence); ``mode`` the
    coupled critical mode; ``residuals`` ``σ_min(T)/‖T‖`` at the Newton iterates."""

    kind: str
    boundary: str
    branch: str
    mass_ratio: float
    reduced_velocity: float
    frequency: float
    mode: np.ndarray
    residuals: tuple[float, ...]
    factorisations: int


@dataclass(frozen=True)
class SweepResult:
    """What :func:`sweep_thresholds` found: the thresholds sorted by U*, the sampled frequencies,
    the intervals left unresolved and the factorisations made."""

    thresholds: tuple[SweepThreshold, ...]
    frequencies: np.ndarray
    unresolved: tuple[tuple[float, float], ...]
    factorisations: int


def velocity_roots(sample: TransferSample, solid: Solid, theta0: float, loads0: np.ndarray) -> SweepSample:
    """The roots ``u`` of ``det(m W(iω, u) − A(iω)) = 0`` at ``solid.mass_ratio`` with ``Re u > 0``
    and ``du/dω = −i (∂F/∂s)/(∂F/∂u)`` (module docstring). With ``m̂ = m ω²`` and ``v = u/ω`` the
    determinant is ``Σ P_k(v) m̂^k`` (:func:`fsistab.transfer_map.scaled_polynomials`)."""
    omega = sample.s.imag
    if omega <= 0:
        raise InputError("velocity roots are for ω > 0; divergence (ω = 0) is divergence_lines")
    loads, rate = second_order_loads(AxisSample(omega, sample.value, sample.rate), theta0, loads0)
    scaled_mass = solid.mass_ratio * omega**2
    polynomial = np.zeros(1, dtype=complex)
    for k, p in enumerate(scaled_polynomials(loads, solid)):
        polynomial = npoly.polyadd(polynomial, p * scaled_mass**k)
    roots = [omega * v for v in npoly.polyroots(npoly.polytrim(polynomial, tol=0.0)) if v.real > 0]
    roots.sort(key=lambda u: u.real)
    slopes = []
    for u in roots:
        _, _, f_u, f_s = characteristic_function(loads, rate, solid, 1j * omega, solid.mass_ratio, u)
        slopes.append(-1j * f_s / f_u)
    return SweepSample(omega, np.array(roots, dtype=complex), np.array(slopes, dtype=complex), sample)


def _match(
    left: SweepSample, right: SweepSample, band: tuple[float, float] = (0.0, math.inf)
) -> list[tuple[int, int]] | None:
    """Pairs ``(i, j)`` of the same root at two frequencies, or None if the identification is not
    certain: the root counts differ, or a forward prediction ``u_i + h u_i'`` and the backward one
    ``u_j − h u_j'`` are not mutual nearest, or a prediction misses by more than ``MATCH_SEPARATION``
    of the distance to the other roots or ``MATCH_SIZE`` of ``|u|``. Only roots with ``Re u`` in
    ``band`` at either end (those that can bracket a threshold of the velocity range) must pass
    the last test."""
    if len(left.roots) != len(right.roots):
        return None
    h = right.frequency - left.frequency
    forward = left.roots + h * left.slopes
    backward = right.roots - h * right.slopes
    pairs = []
    for i, predicted in enumerate(forward):
        j = int(np.argmin(np.abs(right.roots - predicted)))
        if int(np.argmin(np.abs(left.roots - backward[j]))) != i:
            return None
        others = np.delete(right.roots, j)
        separation = float(np.min(np.abs(others - right.roots[j]))) if len(others) else math.inf
        error = max(abs(predicted - right.roots[j]), abs(backward[j] - left.roots[i]))
        relevant = any(band[0] <= u.real <= band[1] for u in (left.roots[i], right.roots[j]))
        if relevant and (error > MATCH_SEPARATION * separation or error > MATCH_SIZE * abs(right.roots[j])):
            return None
        pairs.append((i, j))
    return pairs


def _hermite(y0: complex, d0: complex, y1: complex, d1: complex, h: float) -> np.ndarray:
    """Cubic Hermite coefficients in ``τ ∈ [0, 1]`` (ascending; complex values)."""
    d = y1 - y0
    return np.array([y0, h * d0, 3 * d - h * (2 * d0 + d1), -2 * d + h * (d0 + d1)])


def _crossings(left: SweepSample, right: SweepSample, i: int, j: int) -> list[tuple[float, float]]:
    """``(ω, U*)`` starts where the Hermite interpolant of ``u`` from root ``i`` to root ``j`` is
    real (``Im u = 0``), ``Re u > 0``."""
    h = right.frequency - left.frequency
    coef = _hermite(left.roots[i], left.slopes[i], right.roots[j], right.slopes[j], h)
    imaginary = npoly.polytrim(coef.imag, tol=0.0)
    starts = []
    for tau in npoly.polyroots(imaginary) if len(imaginary) > 1 else []:
        if abs(tau.imag) < 1e-9 and -1e-12 <= tau.real <= 1 + 1e-12:
            u = npoly.polyval(float(tau.real), coef.real)
            if u > 0:
                starts.append((left.frequency + float(tau.real) * h, 1.0 / u))
    return starts


def _sign_certain(left: SweepSample, right: SweepSample, i: int, j: int) -> bool:
    """Whether the interpolant decides the sign of ``Im u`` across the interval: it crosses zero
    at most once, and ``Im u`` is resolved — the linear predictions of ``Im u`` from each end
    (value and exact slope) miss the other end by at most ``RESOLVED`` of the larger ``|Im u|``
    of the two ends. A narrow unstable window between two samples, where ``Im u`` dips through
    zero and back, shows as such a miss and is bisected until it is sampled."""
    if len(_crossings(left, right, i, j)) > 1:
        return False
    if np.sign(left.roots[i].imag) != np.sign(right.roots[j].imag):
        return True  # one crossing, bracketed
    h = right.frequency - left.frequency
    misfit = max(
        abs((left.roots[i] + h * left.slopes[i] - right.roots[j]).imag),
        abs((right.roots[j] - h * right.slopes[j] - left.roots[i]).imag),
    )
    return misfit <= RESOLVED * max(abs(left.roots[i].imag), abs(right.roots[j].imag))


def _branch(mode: np.ndarray, solid: Solid) -> str:
    """``heave`` or ``pitch``: the dof with the larger kinetic energy ``|ḣ|²`` or ``r_θ²|θ'|²`` in
    the critical mode's solid part (active states ``h, θ, ḣ, θ'``)."""
    if len(solid.dofs) == 1:
        return solid.dofs[0]
    velocities = mode[2:4]  # (ḣ, θ') of a two-dof body
    return "heave" if abs(velocities[0]) ** 2 >= solid.r_theta**2 * abs(velocities[1]) ** 2 else "pitch"


def frequency_band(solid: Solid, velocity_range: tuple[float, float]) -> tuple[float, float]:
    """Initial frequency band: the in-vacuo frequencies (``Ω/U*`` heave, ``1/U*`` pitch) of the
    active dofs over the velocity range, widened by ``BAND_MARGIN`` (the sweep widens it further
    where roots still lie in the range at an end)."""
    rates = [solid.freq_ratio if dof == "heave" else 1.0 for dof in solid.dofs]
    return min(rates) / velocity_range[1] / BAND_MARGIN, BAND_MARGIN * max(rates) / velocity_range[0]


def sweep_thresholds(
    fluid: FluidOperators,
    solid: Solid,
    velocity_range: tuple[float, float],
    *,
    wake_frequency: float | None = None,
    static_factor: FluidFactor | None = None,
    counter: FactorCounter | None = None,
    progress: Callable[[str], None] | None = None,
    threads: int | None = None,
) -> SweepResult:
    """Every threshold with ``U*`` in ``velocity_range`` at ``solid.mass_ratio`` (module docstring),
    each converged on the exact transfer function, with its critical mode. A dynamic threshold is
    ``viv`` if its frequency is within 30 % of ``wake_frequency`` (when given), ``flutter``
    otherwise; ``divergence`` from ``G(0)`` when pitch is active (``static_factor``: a factorisation
    of ``J_ff`` to reuse). ``threads``: samples factorised at once
    (:func:`fsistab.transfer.transfer_samples`)."""
    low, high = (float(v) for v in velocity_range)
    if not (0 < low < high and math.isfinite(high)):
        raise InputError(f"the velocity range must satisfy 0 < low < high, got {velocity_range}")
    counter = counter if counter is not None else FactorCounter()
    say = progress or (lambda message: None)
    start = counter.count
    theta0, loads0 = fluid.theta0, fluid.loads0
    samples: dict[float, SweepSample] = {}

    def add(*frequencies: float) -> None:
        new = [float(w) for w in dict.fromkeys(frequencies) if w not in samples]
        if len(samples) + len(new) > MAX_SAMPLES:
            raise ConvergenceError(f"the frequency sweep needed more than {MAX_SAMPLES} samples")
        data = transfer_samples(fluid, [1j * w for w in new], counter, refine=False, threads=threads)
        samples.update((w, velocity_roots(d, solid, theta0, loads0)) for w, d in zip(new, data, strict=True))
        if new:
            made = counter.count - start
            say(f"frequency sweep: {len(samples)} samples up to ω = {max(new):.5g}, {made} factorisations")

    omega_low, omega_high = frequency_band(solid, (low, high))
    grid = np.geomspace(
        omega_low,
        omega_high,
        max(3, math.ceil(math.log(omega_high / omega_low) / math.log(INITIAL_RATIO)) + 1),
    )
    if wake_frequency is not None and omega_low < wake_frequency < omega_high:
        grid = np.concatenate([grid, wake_frequency * np.array([0.9, 0.95, 1.0, 1.05, 1.1])])
    add(*np.unique(grid))
    # widen the band until no root can put a neutral point of the range beyond it; at low
    # frequency the roots of the static branches tend to the divergence speeds 1/U*_D (ω = 0,
    # found exactly below), which may lie in the range: those do not call for a wider band
    # (G(0) only where there is a static branch: pitch active; a heave-only body has none)
    static = _static_sample(fluid, static_factor, counter) if "pitch" in solid.dofs else None
    static_roots = [1.0 / v for v, _ in _divergence_velocities(static, solid, fluid)] if static else []
    for _ in range(MAX_WIDENINGS):
        lowest = samples[min(samples)]
        in_range = [u for u in lowest.roots if 1.0 / high <= u.real <= 1.0 / low]
        if len(in_range) <= sum(1.0 / high <= u <= 1.0 / low for u in static_roots):
            break
        add(min(samples) / INITIAL_RATIO**2)
    for _ in range(MAX_WIDENINGS):
        highest = samples[max(samples)]
        if not np.any(highest.roots.real <= 1.0 / low):
            break
        add(max(samples) * INITIAL_RATIO**2)
    # bisect until every root is followed without ambiguity and crossings are single
    relevant = (1.0 / (RELEVANT_MARGIN * high), RELEVANT_MARGIN / low)  # u of the velocity range, widened
    unresolved: list[tuple[float, float]] = []
    while True:
        frequencies = sorted(samples)
        todo = []
        for w0, w1 in zip(frequencies[:-1], frequencies[1:], strict=True):
            if (w0, w1) in unresolved:
                continue
            left, right = samples[w0], samples[w1]
            pairs = _match(left, right, relevant)
            ok = pairs is not None and all(
                _sign_certain(left, right, i, j)
                for i, j in pairs
                if any(relevant[0] <= u.real <= relevant[1] for u in (left.roots[i], right.roots[j]))
            )
            if ok:
                continue
            if w1 - w0 < MIN_STEP * w1:
                unresolved.append((w0, w1))
            else:
                todo.append(0.5 * (w0 + w1))
        if not todo:
            break
        add(*todo)
    if unresolved:
        where = ", ".join(f"[{a:.6g}, {b:.6g}]" for a, b in unresolved)
        say(f"frequency sweep: {len(unresolved)} interval(s) of ω not resolved down to {MIN_STEP:g}: {where}")
    # converge each bracketed crossing on the exact transfer function
    found = []
    frequencies = sorted(samples)
    for w0, w1 in zip(frequencies[:-1], frequencies[1:], strict=True):
        left, right = samples[w0], samples[w1]
        pairs = _match(left, right, relevant) or []
        for i, j in pairs:
            for omega, velocity in _crossings(left, right, i, j):
                if not low / 1.1 <= velocity <= high * 1.1:
                    continue
                point = transfer_flutter_point(
                    fluid, replace(solid, reduced_velocity=velocity), omega, counter=counter,
                    tolerance=NEWTON_STEP,
                )  # fmt: skip
                u_c = point.reduced_velocity
                if not low <= u_c <= high or any(
                    abs(u_c - p.reduced_velocity) < 1e-7 * u_c and abs(point.frequency - p.frequency) < 1e-7
                    for p in found
                ):
                    continue
                critical = replace(solid, reduced_velocity=u_c)
                mode = point.sample.mode(critical, theta0, loads0)
                rate = _crossing_rate(point.sample, critical, theta0, loads0)
                is_viv = (
                    wake_frequency is not None
                    and abs(point.frequency - wake_frequency) < 0.3 * wake_frequency
                )
                kind = "viv" if is_viv else "flutter"
                boundary = "onset" if rate > 0 else "restabilisation"
                found.append(
                    SweepThreshold(
                        kind, boundary, _branch(mode, solid), solid.mass_ratio, u_c, point.frequency, mode,
                        point.residuals, point.factorisations,
                    )
                )  # fmt: skip
    if static is not None:
        found += _divergence(static, solid, fluid, (low, high))
    found.sort(key=lambda t: t.reduced_velocity)
    return SweepResult(tuple(found), np.array(sorted(samples)), tuple(unresolved), counter.count - start)


def _crossing_rate(sample: TransferSample, solid: Solid, theta0: float, loads0: np.ndarray) -> float:
    """``∂(Re σ)/∂(log U*)`` at fixed m of the neutral mode at ``sample``'s frequency: from
    ``F_s dσ + F_u du = 0`` and ``du = −u d(log U*)``, ``(u F_u/F_s).real`` (> 0: onset)."""
    omega = sample.s.imag
    loads, rate = second_order_loads(AxisSample(omega, sample.value, sample.rate), theta0, loads0)
    u = 1.0 / solid.reduced_velocity
    _, _, f_u, f_s = characteristic_function(loads, rate, solid, 1j * omega, solid.mass_ratio, u)
    return float((u * f_u / f_s).real)


def _static_sample(fluid, static_factor, counter) -> TransferSample:
    """``G(0)``, ``dG/ds(0)`` and the static response: one real factorisation of ``J_ff`` (or
    ``static_factor``)."""
    factor = static_factor if static_factor is not None else FluidFactor(fluid, 0.0, counter)
    return transfer_sample(fluid, 0.0, factor=factor)


def _divergence_velocities(static: TransferSample, solid: Solid, fluid) -> list[tuple[float, float]]:
    """``(U*_D, crossing rate)`` of each divergence line at ``solid.mass_ratio``: ``U*_D = √(m/λ)``
    (:func:`fsistab.transfer_map.divergence_lines`); none for a heave-only body."""
    from fsistab.neutral_point import divergence_velocity

    if "pitch" not in solid.dofs:
        return []
    axis = AxisSample(0.0, static.value, static.rate)
    lambdas, rates = divergence_lines(axis, solid, fluid.theta0, fluid.loads0)
    return [
        (float(divergence_velocity(lam, 1.0, solid.mass_ratio)), float(rate))
        for lam, rate in zip(lambdas, rates, strict=True)
    ]


def _divergence(static: TransferSample, solid: Solid, fluid, velocity_range) -> list:
    """The divergence thresholds in the range, each with its critical mode, the null vector of
    ``T(0)`` (no further factorisation)."""
    found = []
    for velocity, rate in _divergence_velocities(static, solid, fluid):
        if velocity_range[0] <= velocity <= velocity_range[1]:
            critical = replace(solid, reduced_velocity=velocity)
            mode = static.mode(critical, fluid.theta0, fluid.loads0)
            boundary = "onset" if rate > 0 else "restabilisation"
            found.append(
                SweepThreshold("divergence", boundary, "static", solid.mass_ratio, velocity, 0.0, mode, (), 0)
            )
    return found
