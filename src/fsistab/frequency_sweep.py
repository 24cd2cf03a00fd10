"""Every threshold along U* at one mass ratio from the exact transfer function swept in frequency:
an exact p–k method (docs/model.md §7–§8).

On the imaginary axis ``s = iω`` the characteristic function of :mod:`fsistab.transfer_map`,

    ``F(u; ω) = det(m W(iω, u) − A(iω))``,   ``u = 1/U*``,

is, at fixed ``m``, a complex polynomial in ``u`` (degree 2 per active dof; :func:`velocity_roots`).
At each frequency its roots ``u_k(ω)`` with ``Re u_k > 0`` are the speeds at which the coupled
system would have a neutral mode of frequency ``ω`` if they were real: a real root is a neutral
point, ``U*_c = 1/u_k``, ``ω_c = ω``. Elsewhere they are complex, and near the in-vacuo relations
(``u ≈ ω/Ω`` in heave, ``u ≈ ω`` in pitch, docs/model.md §2) at large ``m``. Where ``G`` is smooth in
``ω`` so are they, and so is the 2 × 2 load matrix ``A(iω)``, whose derivative ``dA/dω`` each
sample gives too (with ``dG/ds``). Between two samples the roots are followed on the cubic
Hermite interpolant of ``A`` (exact at both ends; :func:`_follow`: each root continued in small
steps of ``ω``, never an ambiguous identification), and the cubic is checked against the
quintics through a neighbouring sample on either side: the distance ``e`` of their root paths
estimates the cubic's error. An interval is split (in two, or in more parts when fewer intervals
than threads need it) until ``e`` is below ``MAX_ROOT_ERROR |u|`` and ``1/ERROR_SAFETY`` of the
distance to the other roots, and until ``Im u`` of every root that can reach the velocity range
is either ``ERROR_SAFETY e`` clear of zero or crosses zero transversally (enters the band
``|Im u| ≤ ERROR_SAFETY e`` on one side and leaves it on the other): a near tangency, which the
error could turn into a narrow window of instability or hide one, is sampled until decided.
A change of sign of ``Im u_k`` on the interpolated path brackets a neutral point. Two exact samples
a quarter of the interval apart are then made around it (the interpolant's error falls by about
``4⁴``), and Newton on the exact ``det T(iω; U*) = 0``
(:func:`fsistab.transfer.transfer_flutter_point`, unrefined solves) converges it from the start
found on them; the sign of the crossing rate ``∂(Re σ)/∂(log U*)`` at the converged point says
onset (> 0) or restabilisation as U* grows. The loads of the last Newton iterate also give, with
no further factorisation, the exact tangent ``d(log m, log U*)/dω`` of the neutral curve through
the point (m and U* varying, the other solid parameters fixed;
:func:`fsistab.transfer_map._root_with_tangent`), hence its local frequency following
``|d log ω / d log U*|`` (:func:`local_following`): the threshold is ``viv``
(the fixed body's wake mode locked onto a solid frequency, its frequency held while the solid's
scale ``1/U*`` moves) when that is below ``VIV_FOLLOWING`` = 1/2, ``flutter`` otherwise: the rule
that labels the curves of a map (:func:`fsistab.neutral_map.curve_kind`), taken at the point rather
than over the curve's range (without its mass term, :func:`local_following`), with no hint of the
wake frequency. Divergence (``ω = 0``) comes from
``G(0)`` exactly, ``U*_D = √(m/λ)`` (:func:`fsistab.transfer_map.divergence_lines`), one real
factorisation, made when the band's low end first needs it, or else in a second thread during the
serial Newton iterations.

The sweep covers the frequencies where a root can lie in the velocity range: it starts from the
in-vacuo frequencies of the range's ends widened by ``BAND_MARGIN`` and widens the band (at most
``MAX_WIDENINGS`` times at each end) until, at its high end, every root is above ``1/U*_min`` and,
at its low end, no root but those tending to the divergence speeds is below ``1/U*_max``. The
samples need no refined solves (they only bracket) and are factorised two at a time
(:func:`fsistab.transfer.transfer_samples`); each costs one factorisation of ``K_ff(iω)``,
independent of ``m`` and ``U*``, against an eigenvalue problem per U* point and branch for the
branch tracking of :func:`fsistab.critical.track_thresholds`. A narrow window is resolved only down
to a relative step ``MIN_STEP`` in ω; intervals left unresolved there are reported, not fatal. A
crossing whose Newton iteration does not converge from the cubic's estimate (near a sharp wake
resonance, or beside another crossing) is tried again from the cubics between exact samples
``RETRY_PARTS`` times closer, ``RETRY_DEPTH`` times at most; then it is reported, not fatal.

The error estimate is itself an estimate: near the wake resonance the cubic and the quintics can
agree with each other and not with ``G``, and a root path that the exact samples show crossing
zero three times is followed crossing it once. So the crossings are audited against what is
exact (:func:`_audit`): between every two neighbouring exact samples, the number of neutral
points converged on a root must have the parity of the change of sign of its exact ``Im u``.
Where it does not, a crossing was missed (or Newton converged onto its neighbour): Newton is run
from the cubic's crossings away from the points found there, then the interval is cut into
``RETRY_PARTS`` by exact samples and each part audited, ``RETRY_DEPTH`` times at most; an
interval still at odds is reported unresolved. A sweep whose crossings agree costs nothing more.
Parity cannot see a pair: a window whose two edges both lie between two samples, where the cubic
shows neither and its error estimate fails, is still missed.

Units: frequencies in ``U∞/L``, U* and m in the generic conventions of
:class:`fsistab.params.Solid` (docs/model.md §2, §10).
"""

from __future__ import annotations

import contextlib
import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace

import numpy as np
import numpy.polynomial.polynomial as npoly

from fsistab.coupled import in_vacuo_rates, solid_energies
from fsistab.errors import ConvergenceError, InputError
from fsistab.linalg import FactorCounter, FluidFactor
from fsistab.map_distributed import DistributedExactSource, worker_count
from fsistab.map_roots import linear_solid
from fsistab.map_sources import ExactSource
from fsistab.neutral_map import following_kind, following_ratio
from fsistab.neutral_point import NeutralPoint, divergence_velocity
from fsistab.operators import FluidOperators
from fsistab.params import Solid
from fsistab.progress import Progress
from fsistab.symmetry import antisymmetric_operators, whole_mode
from fsistab.transfer import (
    TransferSample,
    sample_threads,
    transfer_flutter_point,
    transfer_sample,
)
from fsistab.transfer_map import (
    AxisSample,
    NeutralRoot,
    _root_with_tangent,
    characteristic_function,
    divergence_lines,
    scaled_polynomials,
    second_order_loads,
)

INITIAL_RATIO = 1.7  # ratio of neighbouring frequencies of the initial grid
MIN_STEP = 1e-6  # relative step below which an interval is left unresolved
PATH_POINTS = 32  # points per interval at which the interpolated roots are followed (at least)
PATH_STEP = 0.3  # a root may move this fraction of its distance to the others between two points
MIN_PATH_STEP = 1.0 / 4096
# the cubic's error estimate e (distance of its root paths to the quintics'): beyond
# MAX_ROOT_ERROR |u| the interval is bisected; Im u must stay ERROR_SAFETY e clear of zero except
# across a transversal crossing, and the roots ERROR_SAFETY e apart
MAX_ROOT_ERROR = 0.02
ERROR_SAFETY = 3.0
MAX_WIDENINGS = 2  # times the band may grow at each end (by INITIAL_RATIO² each)
MAX_SAMPLES = 200
BAND_MARGIN = 1.3  # the initial band: in-vacuo frequencies of the range, widened by this factor
# Newton on det T stops after a relative step below this: converging quadratically from the
# interpolated start, the next step (not taken) would be below NEWTON_STEP² ~ 1e-16
NEWTON_STEP = 1e-8
# a crossing whose Newton does not converge: its bracket cut into this many parts (their exact
# samples factorised together) and each part's crossings tried, this many times at most
RETRY_PARTS = 4
RETRY_DEPTH = 2
RELEVANT_MARGIN = 1.5  # roots with 1/Re u within this factor of the velocity range are followed closely


@dataclass(frozen=True)
class SweepSample:
    """The roots ``u_k`` (``Re u_k > 0``, sorted by ``Re u``) of ``F(u; ω) = 0`` at one frequency
    and their derivatives ``du_k/dω``; ``loads`` ``A(iω)`` and ``loads_slope`` ``dA/dω`` (2 × 2),
    which the sweep interpolates between samples. The fluid response of the sample is not kept
    (a 4-column field per sample, 22 MB on the medium plate)."""

    frequency: float
    roots: np.ndarray
    slopes: np.ndarray
    loads: np.ndarray
    loads_slope: np.ndarray


@dataclass(frozen=True)
class SweepResult:
    """What :func:`sweep_thresholds` found: the thresholds sorted by U*, the sampled frequencies,
    the intervals left unresolved (narrower than ``MIN_STEP`` and still ambiguous, or holding a
    crossing whose Newton iteration did not converge) and the factorisations made."""

    thresholds: tuple[NeutralPoint, ...]
    frequencies: np.ndarray
    unresolved: tuple[tuple[float, float], ...]
    factorisations: int


def _all_roots(loads: np.ndarray, solid: Solid, omega: float) -> np.ndarray:
    """Every root ``u`` of ``det(m W(iω, u) − A(iω)) = 0`` (any sign of ``Re u``): with
    ``m̂ = m ω²`` and ``v = u/ω`` the determinant is ``Σ P_k(v) m̂^k``
    (:func:`fsistab.transfer_map.scaled_polynomials`)."""
    scaled_mass = solid.mass_ratio * omega**2
    polynomial = np.zeros(1, dtype=complex)
    for k, p in enumerate(scaled_polynomials(loads, solid)):
        polynomial = npoly.polyadd(polynomial, p * scaled_mass**k)
    return omega * npoly.polyroots(npoly.polytrim(polynomial, tol=0.0))


def velocity_roots(sample: TransferSample, solid: Solid, theta0: float, loads0: np.ndarray) -> SweepSample:
    """The roots ``u`` of ``det(m W(iω, u) − A(iω)) = 0`` at ``solid.mass_ratio`` with ``Re u > 0``
    and ``du/dω = −i (∂F/∂s)/(∂F/∂u)`` (module docstring), from one sample on the axis."""
    return axis_roots(AxisSample(sample.s.imag, sample.value, sample.rate), solid, theta0, loads0)


def axis_roots(sample: AxisSample, solid: Solid, theta0: float, loads0: np.ndarray) -> SweepSample:
    """:func:`velocity_roots` of ``G(iω)``, ``dG/ds`` as a map's sample sources give them."""
    omega = sample.frequency
    if omega <= 0:
        raise InputError("velocity roots are for ω > 0; divergence (ω = 0) is divergence_lines")
    solid = linear_solid(solid, theta0)  # W at the steady pitch (docs/model.md §3.1)
    loads, rate = second_order_loads(sample, theta0, loads0)
    roots = sorted((u for u in _all_roots(loads, solid, omega) if u.real > 0), key=lambda u: u.real)
    slopes = []
    for u in roots:
        _, _, f_u, f_s = characteristic_function(loads, rate, solid, 1j * omega, solid.mass_ratio, u)
        slopes.append(-1j * f_s / f_u)
    return SweepSample(
        omega, np.array(roots, dtype=complex), np.array(slopes, dtype=complex), loads, 1j * rate
    )


def _loads_interpolant(points: list[SweepSample], origin: float, h: float) -> np.ndarray:
    """Hermite coefficients (ascending in ``τ = (ω − origin)/h``, one column per entry of ``A``)
    of the polynomial through the loads and their ``ω``-derivatives at ``points``: a cubic from two
    samples, a quintic from three."""
    powers = np.arange(2 * len(points))
    rows, values = [], []
    for p in points:
        t = (p.frequency - origin) / h
        rows += [t**powers, powers * t ** np.maximum(powers - 1, 0)]
        values += [p.loads.ravel(), h * p.loads_slope.ravel()]
    return np.linalg.solve(np.array(rows, dtype=float), np.array(values))


def _paths(coef: np.ndarray, left: float, h: float, solid: Solid) -> tuple[np.ndarray, np.ndarray] | None:
    """The roots of ``F`` with the loads of the interpolant ``coef`` followed from ``τ = 0`` to 1:
    ``(taus, roots)`` with ``roots[k, i]`` root ``i`` at ``taus[k]``, the step halved where a root
    moves by more than ``PATH_STEP`` of its distance to the others; None if that cannot be done."""

    def at(tau: float) -> np.ndarray:
        loads = npoly.polyval(tau, coef).reshape(2, 2)
        return _all_roots(loads, solid, left + tau * h)

    taus, rows = [0.0], [at(0.0)]
    step = 1.0 / PATH_POINTS
    while taus[-1] < 1.0:
        tau = min(1.0, taus[-1] + step)
        new, previous = at(tau), rows[-1]
        order = _nearest(previous, new)
        if order is None:
            if step < MIN_PATH_STEP:
                return None
            step /= 2
            continue
        taus.append(tau)
        rows.append(new[order])
        step = min(1.0 / PATH_POINTS, 2 * step)
    return np.array(taus), np.array(rows)


def _nearest(previous: np.ndarray, new: np.ndarray) -> np.ndarray | None:
    """``order`` with ``new[order][i]`` the continuation of ``previous[i]``, or None unless each
    root moved by less than ``PATH_STEP`` of its distance to the others' new positions."""
    if len(previous) != len(new):
        return None
    order = []
    for i, u in enumerate(previous):
        distances = np.abs(new - u)
        j = int(np.argmin(distances))
        others = np.delete(distances, j)
        spacing = float(np.min(np.abs(np.delete(previous, i) - u))) if len(previous) > 1 else math.inf
        if j in order or (len(others) and distances[j] > PATH_STEP * min(float(np.min(others)), spacing)):
            return None
        order.append(j)
    return np.array(order)


def _follow(
    left: SweepSample, right: SweepSample, neighbours: list[SweepSample], solid: Solid, relevant, strict=True
) -> list[tuple[float, float]] | None:
    """Follow every root across ``[left, right]`` on the cubic Hermite interpolant of the loads
    (exact at both ends), and check it (``strict``) against the quintics through each of
    ``neighbours``: their root paths' distance ``e`` estimates the cubic's error. None (bisect) if
    a root followed in ``relevant`` (``Re u`` in that band somewhere) has ``e`` above
    ``MAX_ROOT_ERROR |u|`` or ``1/ERROR_SAFETY`` of its distance to the other roots, or if its
    ``Im u`` comes within ``ERROR_SAFETY e`` of zero and leaves on the side it came from (a
    tangency the error could turn into a narrow window, or hide one); else the Newton starts
    ``(ω, U*)`` where a followed root's interpolated ``Im u`` changes sign."""
    h = right.frequency - left.frequency
    path = _paths(_loads_interpolant([left, right], left.frequency, h), left.frequency, h, solid)
    if path is None or (strict and not neighbours):
        return None
    taus, roots = path
    error = _path_error(taus, roots, left, right, neighbours if strict else [], solid)
    starts = []
    for i in range(roots.shape[1]):
        u, e = roots[:, i], error[:, i]
        if not np.any((relevant[0] <= u.real) & (u.real <= relevant[1])):
            continue
        if strict:
            spacing = np.min(np.abs(np.delete(roots, i, axis=1) - u[:, None]), axis=1, initial=math.inf)
            if np.any(e > MAX_ROOT_ERROR * np.abs(u)) or np.any(ERROR_SAFETY * e > spacing):
                return None
            if not _crossings_certain(u.imag, ERROR_SAFETY * e):
                return None
        for k in np.flatnonzero(np.sign(u[:-1].imag) * np.sign(u[1:].imag) < 0):
            weight = u[k].imag / (u[k].imag - u[k + 1].imag)
            tau = taus[k] + weight * (taus[k + 1] - taus[k])
            velocity = (u[k] + weight * (u[k + 1] - u[k])).real
            if velocity > 0:
                starts.append((left.frequency + tau * h, 1.0 / velocity))
    return starts


def _path_error(
    taus: np.ndarray, roots: np.ndarray, left: SweepSample, right: SweepSample, neighbours, solid: Solid
) -> np.ndarray:
    """``e[k, i]``: the distance from root ``i`` of the cubic's path at ``taus[k]`` to the nearest
    root of the quintic through ``left``, ``right`` and each of ``neighbours`` (the largest), an
    estimate of the cubic's error (0 at both ends, where the interpolants agree exactly)."""
    h = right.frequency - left.frequency
    error = np.zeros(roots.shape)
    for other in neighbours:
        points = sorted([left, right, other], key=lambda p: p.frequency)
        coef = _loads_interpolant(points, left.frequency, h)
        for k, tau in enumerate(taus):
            check = _all_roots(npoly.polyval(tau, coef).reshape(2, 2), solid, left.frequency + tau * h)
            error[k] = np.maximum(error[k], np.min(np.abs(roots[k][:, None] - check[None, :]), axis=1))
    return error


def _crossings_certain(values: np.ndarray, margin: np.ndarray) -> bool:
    """Whether the zeros of a function known as ``values ± margin`` on a path (exact at its ends,
    where ``margin`` is 0) are certain: every run of points within the margin of zero is entered
    and left with opposite signs (one transversal crossing), never on the same side."""
    certain = np.abs(values) > margin
    signs = np.sign(values)
    k = 0
    while k < len(values):
        if certain[k]:
            k += 1
            continue
        run_end = k
        while run_end < len(values) and not certain[run_end]:
            run_end += 1
        before = signs[k - 1] if k > 0 else 0.0
        after = signs[run_end] if run_end < len(values) else 0.0
        if before == 0.0 or after == 0.0 or before == after:
            return False
        k = run_end
    return True


def _branch(mode: np.ndarray, solid: Solid, theta0: float) -> str:
    """``heave`` or ``pitch``: the dof with the larger kinetic energy ``(m/4)|ḣ|²`` or
    ``(m/4) r_θ²|θ'|²`` in the critical mode's solid part (active states ``h, θ, ḣ, θ'``); with a
    static unbalance, the heave of the centre of mass and the rest
    (:func:`fsistab.coupled.solid_energies`)."""
    if len(solid.dofs) == 1:
        return solid.dofs[0]
    heave, pitch = solid_energies(solid, mode[2:4], theta0)  # (ḣ, θ') of a two-dof body
    return "heave" if heave >= pitch else "pitch"


def frequency_band(solid: Solid, velocity_range: tuple[float, float]) -> tuple[float, float]:
    """Initial frequency band: the in-vacuo frequencies (``Ω/U*`` heave, ``1/U*`` pitch) of the
    active dofs over the velocity range, widened by ``BAND_MARGIN`` (the sweep widens it further
    where roots still lie in the range at an end)."""
    rates = [solid.freq_ratio if dof == "heave" else 1.0 for dof in solid.dofs]
    if len(rates) == 2 and solid.static_unbalance:  # the coupled in-vacuo frequencies (docs/model.md §3.1)
        rates = in_vacuo_rates(solid)
    return min(rates) / velocity_range[1] / BAND_MARGIN, BAND_MARGIN * max(rates) / velocity_range[0]


class _Samples:
    """The sweep's samples, by frequency (:class:`SweepSample`): :meth:`add` has ``source`` make
    new frequencies (:class:`fsistab.map_sources.ExactSource`: ``threads`` at a time in this process;
    :class:`fsistab.map_distributed.DistributedExactSource`: on dask workers), at most
    ``MAX_SAMPLES`` in all, and reports progress."""

    def __init__(self, fluid: FluidOperators, solid: Solid, counter: FactorCounter, source: ExactSource, say):
        self.fluid, self.solid, self.counter, self.source, self.say = fluid, solid, counter, source, say
        self.start = counter.count
        self.by_frequency: dict[float, SweepSample] = {}

    def add(self, *frequencies: float) -> None:
        samples, fluid = self.by_frequency, self.fluid
        new = [float(w) for w in dict.fromkeys(frequencies) if w not in samples]
        if len(samples) + len(new) > MAX_SAMPLES:
            raise ConvergenceError(f"the frequency sweep needed more than {MAX_SAMPLES} samples")
        for found in self.source.samples(new):
            samples[found.frequency] = axis_roots(found, self.solid, fluid.theta0, fluid.loads0)
        if new:
            made = self.counter.count - self.start
            self.say(
                f"frequency sweep: {len(samples)} samples up to ω = {max(new):.5g}, {made} factorisations"
            )


def _initial_grid(solid: Solid, low: float, high: float, wake_frequency: float | None) -> np.ndarray:
    """The initial frequencies: log-spaced at ratio ``INITIAL_RATIO`` over :func:`frequency_band`,
    with five more at 0.9–1.1 times ``wake_frequency`` inside it."""
    omega_low, omega_high = frequency_band(solid, (low, high))
    grid = np.geomspace(
        omega_low,
        omega_high,
        max(3, math.ceil(math.log(omega_high / omega_low) / math.log(INITIAL_RATIO)) + 1),
    )
    if wake_frequency is not None and omega_low < wake_frequency < omega_high:
        grid = np.concatenate([grid, wake_frequency * np.array([0.9, 0.95, 1.0, 1.05, 1.1])])
    return np.unique(grid)


def _widen_band(samples: _Samples, static, low: float, high: float) -> None:
    """Widen the band until no root can put a neutral point of the range beyond it. At low
    frequency the roots of the static branches tend to the divergence speeds ``1/U*_D`` (ω = 0,
    found exactly from ``G(0)``), which may lie in the range: those do not call for a wider band."""
    by_frequency, solid = samples.by_frequency, samples.solid
    for _ in range(MAX_WIDENINGS):
        lowest = by_frequency[min(by_frequency)]
        in_range = [u for u in lowest.roots if 1.0 / high <= u.real <= 1.0 / low]
        if not in_range:
            break
        static_roots = (
            [1.0 / v for v, _ in _divergence_velocities(static.get(), solid, samples.fluid)] if static else []
        )
        if len(in_range) <= sum(1.0 / high <= u <= 1.0 / low for u in static_roots):
            break
        samples.add(min(by_frequency) / INITIAL_RATIO**2)
    for _ in range(MAX_WIDENINGS):
        highest = by_frequency[max(by_frequency)]
        if not np.any(highest.roots.real <= 1.0 / low):
            break
        samples.add(max(by_frequency) * INITIAL_RATIO**2)


def _newton_starts(intervals, low: float, high: float) -> list[tuple[float, float, float, float, tuple]]:
    """``(ω, U*, a, b, (w0, w1))`` for each crossing bracketed by ``[w0, w1]`` with U* near the
    range: its interpolated position and two frequencies a quarter of its interval apart around it,
    whose exact samples bring the interpolant's error down by about ``4⁴`` so that Newton on
    ``det T`` starts closer."""
    starts = []
    for w0, w1, crossings in intervals:
        for omega, velocity in crossings or []:
            if low / 1.1 <= velocity <= high * 1.1:
                eighth = 0.125 * (w1 - w0)
                starts.append((omega, velocity, max(w0, omega - eighth), min(w1, omega + eighth), (w0, w1)))
    return starts


def _converge_crossings(samples: _Samples, starts, relevant, unresolved: list) -> list[NeutralPoint]:
    """Each crossing of ``starts`` converged on the exact transfer function (:func:`_converge`)
    from its start on the cubic between the two closer samples, or from closer samples
    (:func:`_converge_bracket`); one that does not converge even so (e.g. two crossings about to
    merge) is added to ``unresolved`` and reported, not fatal. Each neutral point once."""
    found: list[NeutralPoint] = []
    for omega, velocity, a, b, interval in starts:
        try:
            thresholds = _converge_bracket(
                samples, (omega, velocity), (a, b), relevant, RETRY_DEPTH, interval
            )
        except ConvergenceError as error:
            unresolved.append((a, b))
            samples.say(f"frequency sweep: the crossing in ω ∈ [{a:.6g}, {b:.6g}] is unresolved: {error}")
            continue
        found += [t for t in thresholds if not _known(t, found)]
    return found


def _known(point: NeutralPoint, found) -> bool:
    """Whether ``point`` is one of ``found`` (U* and ω within 1e-7: Newton's tolerance)."""
    return any(
        abs(point.reduced_velocity - p.reduced_velocity) < 1e-7 * p.reduced_velocity
        and abs(point.frequency - p.frequency) < 1e-7
        for p in found
    )


def _parity_mismatch(left: SweepSample, right: SweepSample, found, solid: Solid, band) -> bool:
    """Whether a root's exact ``Im u`` changes sign between the two samples an odd (even) number of
    times while an even (odd) number of the neutral points ``found`` in ``[left, right)`` lie on it:
    a crossing was missed, or converged onto its neighbour. Only roots whose cubic path keeps
    ``Re u`` inside ``band`` (``1/U*`` of the range) are checked, so that every crossing of theirs
    was to be converged; a point is put on the root whose path passes nearest ``1/U*`` at its
    frequency."""
    h = right.frequency - left.frequency
    path = _paths(_loads_interpolant([left, right], left.frequency, h), left.frequency, h, solid)
    if path is None:
        return False
    taus, roots = path
    on_root = np.zeros(roots.shape[1], dtype=int)
    for p in found:
        if left.frequency <= p.frequency < right.frequency:
            k = int(np.argmin(np.abs(taus - (p.frequency - left.frequency) / h)))
            on_root[int(np.argmin(np.abs(roots[k] - 1.0 / p.reduced_velocity)))] += 1
    for i in range(roots.shape[1]):
        u = roots[:, i]  # exact at both ends
        if np.all((band[0] <= u.real) & (u.real <= band[1])):
            if on_root[i] % 2 != int(np.sign(u[0].imag) != np.sign(u[-1].imag)):
                return True
    return False


def _audit(samples: _Samples, interval, found, relevant, band, depth: int, unresolved: list) -> list:
    """The neutral points missing from ``found`` in ``interval`` (two exact samples), by the
    parity of the exact signs of ``Im u`` at its ends (:func:`_parity_mismatch`): Newton from the
    cubic's crossings in the range away from the points found there, then, while a mismatch
    remains, the interval cut into ``RETRY_PARTS`` by exact samples and each part audited,
    ``depth`` times at most; an interval still mismatched then is added to ``unresolved``."""
    (w0, w1), by_frequency = interval, samples.by_frequency
    linear = linear_solid(samples.solid, samples.fluid.theta0)
    if not _parity_mismatch(by_frequency[w0], by_frequency[w1], found, linear, band):
        return []
    new: list[NeutralPoint] = []
    near = 0.125 * (w1 - w0)
    crossings = _follow(by_frequency[w0], by_frequency[w1], [], linear, relevant, strict=False) or []
    for omega, velocity in crossings:
        if band[0] <= 1.0 / velocity <= band[1] and not any(
            abs(p.frequency - omega) < near for p in found if w0 <= p.frequency < w1
        ):
            with contextlib.suppress(ConvergenceError):
                point = _converge(samples.fluid, samples.solid, omega, velocity, samples.counter)
                new += [] if _known(point, found + new) else [point]
    if not _parity_mismatch(by_frequency[w0], by_frequency[w1], found + new, linear, band):
        return new
    if depth == 0:
        unresolved.append((w0, w1))
        samples.say(
            f"frequency sweep: the crossings found in ω ∈ [{w0:.6g}, {w1:.6g}] disagree with the"
            " signs of Im u at its ends; it is unresolved"
        )
        return new
    for part in _cut(samples, w0, w1):
        new += _audit(samples, part, found + new, relevant, band, depth - 1, unresolved)
    return new


def _cut(samples: _Samples, w0: float, w1: float) -> list[tuple[float, float]]:
    """``[w0, w1]`` cut into ``RETRY_PARTS`` equal parts, the exact samples at the cuts made (and
    factorised) together."""
    cuts = [w0 + (w1 - w0) * k / RETRY_PARTS for k in range(RETRY_PARTS + 1)]
    samples.add(*cuts[1:-1])
    return list(zip(cuts[:-1], cuts[1:], strict=True))


def _audited(samples: _Samples, found, relevant, band, unresolved: list) -> list[NeutralPoint]:
    """``found`` and the neutral points its audit adds (:func:`_audit`) in every interval between
    the exact samples made so far (the bisection's and the Newton brackets') that does not
    overlap one already reported unresolved."""
    frequencies = sorted(samples.by_frequency)
    reported = list(unresolved)
    for w0, w1 in zip(frequencies[:-1], frequencies[1:], strict=True):
        if not any(a < w1 and w0 < b for a, b in reported):
            found = found + _audit(samples, (w0, w1), found, relevant, band, RETRY_DEPTH, unresolved)
    return found


def _converge_bracket(
    samples: _Samples, start, bracket, relevant, depth: int, interval=None
) -> list[NeutralPoint]:
    """The crossing of ``bracket = (a, b)`` (two exact samples) converged by Newton from the
    cubic's crossing nearest ``start = (ω, U*)``; if Newton does not converge there, ``interval``
    (exact samples at its ends; default the bracket: the cubic's estimate may lie outside the
    bracket around it) cut into ``RETRY_PARTS`` (their samples factorised together) and every
    crossing of each part's cubic converged the same way, ``depth`` times at most. Raises the first
    ConvergenceError when none converges."""
    (omega, velocity), (a, b) = start, bracket
    by_frequency, solid = samples.by_frequency, samples.solid
    linear = linear_solid(solid, samples.fluid.theta0)  # the cubics' roots: W at the steady pitch
    closer = _follow(by_frequency[a], by_frequency[b], [], linear, relevant, strict=False)
    if closer:
        omega, velocity = min(closer, key=lambda s: abs(s[0] / omega - 1) + abs(s[1] / velocity - 1))
    try:
        return [_converge(samples.fluid, solid, omega, velocity, samples.counter)]
    except ConvergenceError as error:
        if depth == 0:
            raise
        first = error
    found = []
    for part in _cut(samples, *(interval or bracket)):
        ends = by_frequency[part[0]], by_frequency[part[1]]
        for crossing in _follow(*ends, [], linear, relevant, strict=False) or []:
            with contextlib.suppress(ConvergenceError):
                found += _converge_bracket(samples, crossing, part, relevant, depth - 1)
    if not found:
        raise first
    return found


def sweep_thresholds(
    fluid: FluidOperators,
    solid: Solid,
    velocity_range: tuple[float, float],
    *,
    wake_frequency: float | None = None,
    static_factor: FluidFactor | None = None,
    counter: FactorCounter | None = None,
    progress: Progress = None,
    threads: int | None = None,
    client=None,
) -> SweepResult:
    """Every threshold with ``U*`` in ``velocity_range`` at ``solid.mass_ratio`` (module docstring),
    each converged on the exact transfer function, with its critical mode. A dynamic threshold is
    ``viv`` or ``flutter`` by the local frequency following of its neutral curve
    (:func:`local_following`, the rule of the map's curves), with or without ``wake_frequency``:
    that guess (e.g. of the fixed body's wake mode) only adds initial samples at 0.9–1.1 times it,
    where a narrow lock-in window may hide. One rule everywhere, so that a threshold's kind does
    not depend on whether a hint was given, and is that of the rule labelling its curve on a map.
    ``divergence`` from ``G(0)`` when pitch is active (``static_factor``: a factorisation of
    ``J_ff`` to reuse). ``threads``: samples factorised at once
    (:func:`fsistab.transfer.transfer_samples`); ``client``: a ``dask.distributed`` client whose
    workers factorise the samples of each round instead (:func:`_sample_source`); the Newton
    iterations and ``G(0)`` stay in this process."""
    low, high = (float(v) for v in velocity_range)
    if not (0 < low < high and math.isfinite(high)):
        raise InputError(f"the velocity range must satisfy 0 < low < high, got {velocity_range}")
    counter = counter if counter is not None else FactorCounter()
    say = progress or (lambda message: None)
    # the antisymmetric fields only, for a symmetric section at zero incidence (fsistab.symmetry):
    # the same G from half the unknowns; G(0) from the whole space where its factor is given
    whole, fluid = fluid, antisymmetric_operators(fluid)
    source, parallel = _sample_source(fluid, counter, threads, client, say)
    samples = _Samples(fluid, solid, counter, source, say)
    linear = linear_solid(solid, fluid.theta0)  # the polynomials' W at the steady pitch (model §3.1)
    grid = _initial_grid(linear, low, high, wake_frequency)
    static_fluid = whole if static_factor is not None else fluid
    with ThreadPoolExecutor(1) as pool, _releasing(source):
        static = _StaticSample(static_fluid, static_factor, counter, pool) if "pitch" in solid.dofs else None
        samples.add(*grid)
        _widen_band(samples, static, low, high)
        relevant = (1.0 / (RELEVANT_MARGIN * high), RELEVANT_MARGIN / low)  # u of the range, widened
        intervals, unresolved = _bisect(samples.by_frequency, samples.add, linear, relevant, parallel)
        if unresolved:
            where = ", ".join(f"[{a:.6g}, {b:.6g}]" for a, b in unresolved)
            say(f"frequency sweep: {len(unresolved)} interval(s) of ω unresolved at {MIN_STEP:g}: {where}")
        # the exact samples around every crossing factorised together; G(0) is made meanwhile in
        # the other thread
        starts = _newton_starts(intervals, low, high)
        samples.add(*(w for _, _, a, b, _ in starts for w in (a, b)))
        if static is not None:
            static.prefetch()
        found = _converge_crossings(samples, starts, relevant, unresolved)
        found = _audited(samples, found, relevant, (1.0 / high, 1.0 / low), unresolved)
        found = [t for t in found if low <= t.reduced_velocity <= high]
        if static is not None:
            found += _divergence(static.get(), solid, static_fluid, (low, high))
    found.sort(key=lambda t: t.reduced_velocity)
    frequencies = np.array(sorted(samples.by_frequency))
    return SweepResult(tuple(found), frequencies, tuple(unresolved), counter.count - samples.start)


def _sample_source(fluid: FluidOperators, counter: FactorCounter, threads, client, say):
    """``(source, parallel)``: where the sweep's samples are factorised, and how many at once (a
    bisection round splits its intervals into that many samples at least): ``threads`` in this
    process, or the workers of ``client`` (:mod:`fsistab.map_distributed`: each gets the operators
    once and returns ``G``, ``dG/ds`` bit for bit as this process makes them)."""
    if client is None:
        return ExactSource(fluid, counter, threads), sample_threads(threads)
    return DistributedExactSource(fluid, counter, client, say), max(worker_count(client), 1)


@contextlib.contextmanager
def _releasing(source: ExactSource):
    """Free what ``source`` holds on its workers when the sweep ends, however it ends."""
    try:
        yield source
    finally:
        source.release()


class _StaticSample:
    """``G(0)`` (:func:`_static_sample`) made at first need, or beforehand in ``pool``'s thread once
    :meth:`prefetch` is called (a real factorisation, its symbolic analysis on the complex one's
    ordering, overlapped with the serial Newton iterations); counted in ``counter`` when first got."""

    def __init__(self, fluid, static_factor, counter: FactorCounter, pool: ThreadPoolExecutor):
        self._args, self._counter, self._pool = (fluid, static_factor), counter, pool
        self._job, self._sample = None, None

    def prefetch(self) -> None:
        if self._job is None:
            self._job = self._pool.submit(_static_sample, *self._args)

    def get(self) -> TransferSample:
        if self._sample is None:
            self.prefetch()
            self._sample = self._job.result()
            self._counter.count += 0 if self._args[1] is not None else 1
        return self._sample


def _bisect(samples: dict, add, solid: Solid, relevant, threads: int):
    """Split the intervals between ``samples`` (``add`` makes new ones) until each is resolved
    (:func:`_follow`) or narrower than ``MIN_STEP``: the final ``(w0, w1, starts)`` list (the
    Newton starts in each interval) and the intervals left unresolved (their starts from the
    unchecked cubic)."""
    unresolved: list[tuple[float, float]] = []
    while True:
        frequencies = sorted(samples)
        todo, intervals = [], []
        for k, (w0, w1) in enumerate(zip(frequencies[:-1], frequencies[1:], strict=True)):
            neighbours = [samples[frequencies[n]] for n in (k - 1, k + 2) if 0 <= n < len(frequencies)]
            strict = (w0, w1) not in unresolved
            crossings = _follow(samples[w0], samples[w1], neighbours, solid, relevant, strict=strict)
            if crossings is None and strict:
                if w1 - w0 < MIN_STEP * w1:
                    unresolved.append((w0, w1))
                    crossings = _follow(samples[w0], samples[w1], [], solid, relevant, strict=False)
                else:
                    todo.append((w0, w1))
            intervals.append((w0, w1, crossings))
        if not todo:
            return intervals, unresolved
        # samples are factorised `threads` at a time: a round that splits fewer intervals than
        # that splits each into more parts for the same wall time
        parts = max(2, threads // len(todo) + 1)
        add(*(w0 + (w1 - w0) * k / parts for w0, w1 in todo for k in range(1, parts)))


def _converge(fluid, solid: Solid, omega: float, velocity: float, counter) -> NeutralPoint:
    """The neutral point from the start ``(ω, U*)`` by Newton on ``det T``
    (:func:`fsistab.transfer.transfer_flutter_point`), labelled from the loads of its last iterate
    (no further factorisation, :func:`neutral_root`): ``viv`` when the local frequency following
    of its neutral curve is below ``VIV_FOLLOWING``, ``flutter`` otherwise
    (:func:`local_following`); onset or restabilisation by the sign of the crossing rate."""
    point, sample = transfer_flutter_point(
        fluid, replace(solid, reduced_velocity=velocity), omega, counter=counter,
        tolerance=NEWTON_STEP, refine=False,
    )  # fmt: skip
    critical = replace(solid, reduced_velocity=point.reduced_velocity)
    mode = whole_mode(fluid, sample.mode(critical, fluid.theta0, fluid.loads0))
    root = neutral_root(sample, critical, fluid.theta0, fluid.loads0)
    following = local_following(root)
    return replace(
        point,
        kind=following_kind(following),
        boundary="onset" if root.crossing_rate > 0 else "restabilisation",
        branch=_branch(mode, solid, fluid.theta0),
        frequency_following=following,
        mode=mode,
    )


def neutral_root(sample: TransferSample, solid: Solid, theta0: float, loads0: np.ndarray) -> NeutralRoot:
    """The neutral point at ``sample``'s frequency and ``solid``'s ``(m, U*)`` with the exact tangent
    of its neutral curve, ``d(log m, log U*)/dω`` from ``F(log m, log U*, ω) = 0``, and the crossing
    rate ``∂(Re σ)/∂(log U*)`` at fixed m, ``(u F_u/F_s).real`` (> 0: onset)
    (:func:`fsistab.transfer_map._root_with_tangent`, docs/model.md §7–§8). Where the tangent is not
    defined (``F_m m`` and ``F_u u`` parallel: a fold of the curve in ω, where ``ω`` is stationary
    along it) its derivatives are infinite."""
    solid = linear_solid(solid, theta0)  # W at the steady pitch (docs/model.md §3.1)
    omega = sample.s.imag
    loads, rate = second_order_loads(AxisSample(omega, sample.value, sample.rate), theta0, loads0)
    m, u = solid.mass_ratio, 1.0 / solid.reduced_velocity
    try:
        return _root_with_tangent(loads, rate, solid, omega, m, u)
    except np.linalg.LinAlgError:
        _, _, f_u, f_s = characteristic_function(loads, rate, solid, 1j * omega, m, u)
        return NeutralRoot(omega, m, 1.0 / u, math.inf, math.inf, float((u * f_u / f_s).real))


def local_following(root: NeutralRoot) -> float:
    """The frequency following of the neutral curve through ``root``, at that point:
    ``|d log ω / d log U*|`` along its exact tangent (:func:`fsistab.neutral_map.following_ratio` with
    ``d log ω/dω = 1/ω`` and no mass term): how far the threshold's frequency moves with the solid's
    frequency scale ``1/U*``. The ranges over a whole curve (:func:`fsistab.neutral_map.frequency_following`)
    add ``½ |Δ log m|`` to the denominator, for flat curves whose U* and ω barely change over m;
    at one point the derivatives stay finite and the mass term would call ``viv`` a flutter curve
    where m swings at nearly fixed U* (the zig-zags of the coarse plate's flutter curve below
    m ≈ 30, 0.14–0.42 with it, 0.69–2.4 without). Default mesh, Re 2900 (map points): 0.003–0.26
    on the VIV curves for m = 3–5000, 1.00–1.03 on the flutter curve; coarse plate: 1.4e-4 and
    4.5e-3 at the VIV onset (ω = 11.24) and restabilisation (ω = 10.49) at m = 10."""
    return following_ratio(1.0 / root.frequency, root.dlog_velocity, 0.0)


def _static_sample(fluid, static_factor) -> TransferSample:
    """``G(0)``, ``dG/ds(0)`` and the static response: one real factorisation of ``J_ff`` (or
    ``static_factor``), not counted here (the caller counts it)."""
    factor = static_factor if static_factor is not None else FluidFactor(fluid, 0.0)
    return transfer_sample(fluid, 0.0, factor=factor)


def _divergence_velocities(static: TransferSample, solid: Solid, fluid) -> list[tuple[float, float]]:
    """``(U*_D, crossing rate)`` of each divergence line at ``solid.mass_ratio``: ``U*_D = √(m/λ)``
    (:func:`fsistab.transfer_map.divergence_lines`); none for a heave-only body."""

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
            mode = whole_mode(fluid, static.mode(critical, fluid.theta0, fluid.loads0))
            boundary = "onset" if rate > 0 else "restabilisation"
            found.append(
                NeutralPoint(
                    solid.mass_ratio,
                    velocity,
                    0.0,
                    kind="divergence",
                    boundary=boundary,
                    branch="static",
                    mode=mode,
                )
            )
    return found
