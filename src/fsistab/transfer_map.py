"""The stability map of the whole ``(m, U*)`` plane from the exact transfer function, one frequency
at a time (MODEL.md §7-§8; issue 6).

On the imaginary axis ``s = iω`` the solid velocities are eliminated from ``T(s)``
(:func:`fsistab.transfer.characteristic_matrix`), leaving, for the active dofs among heave and pitch,

    ``X(s; m, u) = m W(s, u) − A(s)``,   ``W = diag(S_h, r_θ² S_θ)``,   ``u = 1/U*``,
    ``S_h = s² + 2ζ_h Ω u s + Ω² u²``,   ``S_θ = s² + 2ζ_θ u s + u²``,

with ``A(s)`` the 2 × 2 loads ``(C_L, C_M)`` per unit ``(ĥ, θ̂)`` of :func:`fsistab.transfer.aerodynamic_loads`
(``det T = det X / (m² r_θ²)`` for both dofs). At a fixed frequency, ``F = det X`` is a polynomial
of degree ≤ 2 in ``m`` whose coefficients are polynomials in ``u``: with ``m̂ = m ω²``, ``v = u/ω``
(both O(1) where the solid frequencies meet ``ω``)

    ``F = P₂(v) m̂² + P₁(v) m̂ + P₀``,   ``P₂ = r_θ² ŝ_h ŝ_θ``,
    ``P₁ = −(ŝ_h A_θθ + r_θ² ŝ_θ A_hh)``,   ``P₀ = det A``,
    ``ŝ_h = −1 + 2iζ_h Ω v + Ω² v²``,   ``ŝ_θ = −1 + 2iζ_θ v + v²``.

A real ``m̂`` is a common root of ``Re F`` and ``Im F``: their resultant in ``m̂``, a real polynomial
of degree 8 in ``v`` (degree 2 for one dof), vanishes. Its positive roots give **every** neutral
point ``(m, U*)`` with frequency ``ω`` — no search, no starting guess — each polished by Newton on
``F``. The neutral curves are these points as ``ω`` varies; the fluid enters only through ``G(iω)``
and ``dG/ds`` at the sampled frequencies, independent of m and U*: exact samples (one sparse
factorisation each) or, where the sampling is refined, reduced fluid models certified on whole
frequency intervals (:mod:`fsistab.reduced_model`, one factorisation per model), so the cost of the
map is neither the number of points nor, with reduced models, the number of frequencies.

Frequencies are added where the curves are not yet resolved: between two samples every root is
predicted at the other sample from its exact tangent ``d(log m, log U*)/d log ω`` (implicit
differentiation of ``F``, with ``dG/ds``); the interval is bisected until each root in the mass
range is matched to one on the other side within ``tolerance`` in ``(log m, log U*)``. Between
samples the curves are cubic Hermite interpolants in ``log ω`` (values and exact tangents), whose
error is about the square of the matching tolerance. The parameter is ``log ω`` rather than ``ω``
because the curves are close to power laws at low frequency (the restabilisation branch, ``m ∝
ω⁻²``): with ``ω`` the tangents' errors on the log-spaced initial frequencies there exceed the
tolerance and every interval below ω ≈ 0.1 was bisected once more (on the `quick` of the time, 111 506
unknowns, at tolerance 1e-2: 30 exact samples
below ω = 0.1 instead of 16, 188 in all instead of 205, the same crossings to 3e-6 and both within
1e-5 of Newton's thresholds). Curves that end (folds in ``ω``, or curves too fast in ω, like lock-in
boundaries near the wake frequency) are located down to ``min_step``; two branches born (or dying)
together at a fold in ``ω`` are joined into one curve through it, by a Hermite cubic in a chord
parameter (the curve is smooth in the ``(m, U*)`` plane there; only its parametrisation by ``ω``
turns). A curve can also cross the whole mass range inside one interval (near the wake frequency a
lock-in onset spans m from 0.07 to 95 within Δω = 0.02) and leave no root at either end; the real
roots of the resultant are tracked with their ``m`` of any sign, and an interval where a pair of
them is born or dies, or one passes through ``m = 0`` or ``∞`` or across the range, is bisected down
to ``SWEEP_STEP`` until the curve shows up; at that step a root that changes sign beyond the range
(through ``m = ∞``, a pole of the neutral mass) or below it (through 0), or roots born outside the
range on one side, settle the interval without a curve (:func:`_swept`); a young pair born on one
side outside the range (close together in ``v`` where it exists) settles it already at ``min_step``
(:func:`_born_outside`). With an undamped dof the
resultant vanishes at its in-vacuo resonance at every frequency (:func:`undamped_resonances`, ``m =
∞``); that root is divided out. A weakly damped fluid mode between two samples much farther apart
than its damping (the wake mode, damped by 0.03 at ω ≈ 11, between initial frequencies 18 % apart)
may leave no root at either although its resonance holds whole VIV curves; the samples' values and
``dG/ds`` locate its pole (:func:`resonance`, a rational fit), and an interval whose pole lies
closer to the axis than half its half-width is sampled at the pole's frequency
(:func:`unresolved_resonance`), no wake-frequency hint needed. Within that resonance the VIV curves
move faster in ``ω`` than exact samples ``min_step`` apart resolve (at Re 2900 on the default mesh
30 such intervals at ω 10.78–11.26) while ``G`` itself is smooth there (its poles lie 0.03–0.2 from
the axis, several sample spacings). With exact samples, a resonance much narrower than the interval
that shows it, between two initial frequencies (:func:`sharp_resonance`: the wake mode) is sampled
by a reduced fluid model at its pole instead (:mod:`fsistab.reduced_model`, ``RESONANCE_BLOCKS``
Krylov blocks, one factorisation), whose certified interval then costs no factorisation: at Re 2900
on the default mesh one model certifies ω ∈ [10.29, 11.54], where the VIV curves had taken 56 exact
samples. Likewise ``G(0)`` and the lowest frequencies, out to the nearest weakly damped poles,
come from one real reduced model at ``s = 0`` (at Re 2900 on the default mesh it certifies ω ∈ [0,
0.045], where the initial grid and the restabilisation branch took 12 factorisations). Elsewhere,
a run of intervals that exact samples leave unresolved is refined on with a rational fit of the
exact samples around it, certified there out of sample and against the samples' exact ``dG/ds``
(:mod:`fsistab.rational_fit`), down to ``FIT_MIN_STEP``, with no factorisation. Such a fit is tried
first, before any exact bisection (``fit_first``): wherever the samples already certify one, the
refinement costs no factorisation (at Re 2900: 195 factorisations instead of 237 on the default
mesh, 205 instead of 240 on the `quick` of the time, for the same map; 172 and 188 with ``log ω``
as the parameter; 136 on the default mesh with ``EXACT_TOLERANCE``).
Divergence (``ω = 0``): ``m u² = λ``, with ``λ`` the positive eigenvalues of ``A(0)`` relative to
``diag(Ω², r_θ²)``, i.e. ``U*_D = √(m/λ)`` (MODEL.md §8).

The side that is unstable follows from the crossing rate ``∂(Re σ)/∂(log U*)`` at fixed ``m``
(``dσ = −F_u du / F_s``): positive is an onset of instability as U* grows, negative a
restabilisation. Counting crossings along U* from a U* where the coupled system is stable gives the
number of unstable modes in every region (:func:`unstable_counts`). Each curve is labelled
``flutter`` or ``viv`` from its own roots (:func:`fsistab.neutral_map.curve_kind`: a VIV curve's
frequency stays locked at the wake mode's while the solid's frequency scale ``1/U*`` varies), the
same rule as the continuation method's, with no wake-frequency hint; intervals of ω left unresolved
are reported with their reason (:class:`UnresolvedInterval`).

Units: chord-based (plate) or diameter-based (cylinder, via :meth:`fsistab.params.Solid.cylinder`)
time ``L/U∞`` (MODEL.md §2, §10); ``m``, ``U*`` as in :class:`fsistab.params.Solid`.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numpy as np
import numpy.polynomial.polynomial as npoly

from fsistab.continuation import newton
from fsistab.coupled import active_states
from fsistab.errors import ConvergenceError, InputError
from fsistab.linalg import FactorCounter
from fsistab.neutral_map import (
    MapCurve,
    NeutralMap,
    NeutralPoint,
    TurningPoint,
    curve_kind,
    divergence_curve,
    frequency_following,
    map_crossings,
)
from fsistab.neutral_point import DeterminantProblem, divergence_velocity
from fsistab.operators import FluidOperators
from fsistab.params import MAX_FREQUENCY, Solid
from fsistab.rational_fit import TransferFit, certified_transfer
from fsistab.reduced_model import ReducedModels
from fsistab.store import ResumableTable
from fsistab.transfer import (
    aerodynamic_loads,
    exact_transfer,
    flow_identity,
    iter_transfer_samples,
)

# root-matching tolerance in (log m, log U*) with exact samples (one factorisation each): the Hermite
# interpolants between samples are then good to about its square, 1e-3. The whole map at Re 2900 on
# the default mesh took 140 factorisations against 172 at 1e-2, its crossings at m = 10-10⁴ within
# 9e-4 of the Newton thresholds (5e-5 at 1e-2) and three small turning points at the nose moved by
# up to 0.2 % in m and 0.9 % in U*; on the `quick` of the time 143 against 188. 0.1 took 127 there
# but moved turning points by 0.7 % and split a VIV curve (docs/performance.md, "The whole map")
EXACT_TOLERANCE = 3e-2
# the exact samples' solves are not refined: with the symmetric nested-dissection analysis the plain
# solve's G differs from the refined one by at most 3e-13 (dG/ds 3e-12, relative) on the default
# mesh over ω 0-20, far below the certification of the fits (1e-6); it halves the solves' cost
SAMPLE_REFINE = False
SWEEP_STEP = 1e-5  # relative step down to which a curve crossing the mass range is looked for
YOUNG_PAIR = 0.05  # a pair of resultant roots this close in v (relative) was born just before (_born_outside)
REFINEMENT_RADIUS = 0.05  # before any reduced model: distance to an exact sample that calls for one
# an interval whose samples point to a fluid pole between them, closer to the axis than this many
# half-widths, is sampled at the pole's frequency (:func:`unresolved_resonance`)
RESONANCE_DAMPING = 0.5
RESONANCE_SHARE = 1e-3  # and whose residue makes at least this share of G at the samples
RESONANCE_STEP = 1e-3  # relative width below which no resonance is looked for
RESONANCE_MARGIN = 0.05  # a resonance sample stays this fraction of its interval from either end
# with exact samples, a sharp resonance is sampled by a reduced fluid model at its pole (one factorisation,
# fsistab.reduced_model) of this many Krylov blocks, certified to RESONANCE_TOLERANCE: on the plate at
# Re 2900 (default mesh) 40 blocks (205 vectors) at ω = 11.0 certify ω ∈ [10.38, 11.63], the whole
# wake band whose VIV curves took 56 exact samples (20 blocks: [10.82, 11.20])
RESONANCE_BLOCKS = 40
RESONANCE_TOLERANCE = 1e-7
# only for a resonance between two initial frequencies, this many times narrower than their
# half-width, whose residue makes at least SHARP_SHARE of G there: an isolated weakly damped mode
# the initial grid steps over. On the plate at Re 2900 the wake mode between 10.47 and 12.31 (0.005
# half-widths and share 0.047 on the default mesh, 0.053 and 0.040 on `quick`) and no other: the
# flutter band's resonances lie 0.10-0.40 half-widths from the axis with shares 0.002-0.019, and
# models built at them certified only ±0.04-0.05 in ω (its modes are dense there)
SHARP_RESONANCE = 0.1
SHARP_SHARE = 0.02
# with exact samples and a frequency range that starts below this, G(0) and the lowest frequencies
# come from one real reduced model at s = 0 (RESONANCE_BLOCKS, one real factorisation), built beside
# the initial exact samples above this reach (those below wait for it): at Re 2900 on the default
# mesh 40 blocks (205 real vectors, 64 s on one core) certify ω ∈ [0, 0.045] to 1e-7 (true error
# 4e-12-5e-9 against the exact samples there), where the initial grid and the restabilisation
# branch took 12 factorisations (G(0) and 11 complex samples, 12.7 s of one core each)
LOW_MODEL_REACH = 0.1
# the default frequency range is extended down, by halving, while a curve leaves it inside the mass
# range (the flutter curve's restabilisation branch: ω ∝ 1/U* falls as m grows), down to this
LOWEST_FREQUENCY = 1e-4
# an interval of exact samples unresolved (before an exact bisection, and at min_step) is refined on
# with a certified rational fit of the exact samples around it (fsistab.rational_fit), this many on
# each side (more on a retry),
FIT_MARGINS = (10, 16)
FIT_MIN_STEP = 1e-7  # down to this relative step (no factorisation: as with reduced models)
FIT_FIRST_SPAN = 2  # a fit before exact bisection is certified this many exact samples beyond its run
FITTED_SAMPLES = 4000  # and at most this many interpolated frequencies in one map


@dataclass(frozen=True)
class AxisSample:
    """``G(iω)`` and ``dG/ds`` at ``s = iω`` (3 × 4 each, :func:`fsistab.transfer.exact_transfer`);
    ``reduced`` if they come from a certified model, not a factorisation: a reduced fluid model
    (:mod:`fsistab.reduced_model`) or a rational fit of exact samples (:mod:`fsistab.rational_fit`)."""

    frequency: float
    transfer: np.ndarray
    rate: np.ndarray
    reduced: bool = False


@dataclass(frozen=True)
class NeutralRoot:
    """A neutral point with frequency ``frequency``: ``det T(iω; m, U*) = 0``, its tangent along
    the neutral curve (``d log m/dω``, ``d log U*/dω``) and the crossing rate
    ``∂(Re σ)/∂(log U*)`` at fixed m (> 0: onset as U* grows)."""

    frequency: float
    mass_ratio: float
    reduced_velocity: float
    dlog_mass: float
    dlog_velocity: float
    crossing_rate: float

    @property
    def plane(self) -> np.ndarray:
        return np.array([math.log(self.mass_ratio), math.log(self.reduced_velocity)])

    @property
    def tangent(self) -> np.ndarray:
        return np.array([self.dlog_mass, self.dlog_velocity])

    @property
    def log_tangent(self) -> np.ndarray:
        """The tangent along ``log ω``: ``ω d(log m, log U*)/dω``."""
        return self.frequency * self.tangent


def log_step(w0: float, w1: float) -> float:
    """The step in ``log ω`` between two sampled frequencies (> 0), the parameter of the map's
    curves: at low frequency they are close to power laws of ω (the restabilisation branch,
    ``m ∝ ω⁻²`` at large m), straight in ``(log ω, log m, log U*)`` but curved against ``ω``."""
    return math.log(w1 / w0)


def second_order_loads(
    sample: AxisSample, theta0: float, loads0: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``A(iω)`` and ``dA/ds`` (2 × 2, rows ``C_L, C_M``, columns ``ĥ, θ̂``)."""
    s = 1j * sample.frequency
    g, no_loads = sample.transfer, np.zeros(3)
    value = aerodynamic_loads(g, theta0, loads0, s)
    # d/ds [rows (G_x + s G_v)] = rows (dG_x + s dG_v) + rows G_v; the rotated steady force is constant
    velocity_columns = np.hstack([g[:, 2:], np.zeros((3, 2))])
    rate = aerodynamic_loads(sample.rate, theta0, no_loads, s) + aerodynamic_loads(
        velocity_columns, theta0, no_loads, 0.0
    )
    return value, rate


def _dof_indices(solid: Solid) -> list[int]:
    """Active dofs as indices into ``(h, θ)``."""
    return [i for i in (0, 1) if i in active_states(solid)]


def _weights(solid: Solid, s: complex, u: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``diag(S_h, r_θ² S_θ)`` and its derivatives in ``u`` and ``s`` (diagonals, 2 each)."""
    omega_h, r2 = solid.freq_ratio, solid.r_theta**2
    zh, zt = solid.zeta_h, solid.zeta_theta
    w = np.array(
        [s * s + 2 * zh * omega_h * u * s + omega_h**2 * u * u, r2 * (s * s + 2 * zt * u * s + u * u)]
    )
    w_u = np.array([2 * zh * omega_h * s + 2 * omega_h**2 * u, r2 * (2 * zt * s + 2 * u)])
    w_s = np.array([2 * s + 2 * zh * omega_h * u, r2 * (2 * s + 2 * zt * u)])
    return w, w_u, w_s


def _adjugate(x: np.ndarray) -> np.ndarray:
    if x.shape == (1, 1):
        return np.ones((1, 1), dtype=x.dtype)
    return np.array([[x[1, 1], -x[0, 1]], [-x[1, 0], x[0, 0]]])


def characteristic_function(
    loads: np.ndarray, rate: np.ndarray, solid: Solid, s: complex, mass_ratio: float, u: float
) -> tuple[complex, complex, complex, complex]:
    """``F = det(m W − A)`` and ``∂F/∂m``, ``∂F/∂u``, ``∂F/∂s`` (``dF = tr(adj X dX)``, valid at a
    root), on the active dofs; ``loads``/``rate`` are ``A(s)``/``dA/ds``."""
    a = _dof_indices(solid)
    w, w_u, w_s = (np.diag(d[a]) for d in _weights(solid, s, u))
    x = mass_ratio * w - loads[np.ix_(a, a)]
    adj = _adjugate(x)
    value = np.linalg.det(x) if len(a) > 1 else x[0, 0]
    d_mass = np.trace(adj @ w)
    d_u = np.trace(adj @ (mass_ratio * w_u))
    d_s = np.trace(adj @ (mass_ratio * w_s - rate[np.ix_(a, a)]))
    return complex(value), complex(d_mass), complex(d_u), complex(d_s)


def scaled_polynomials(loads: np.ndarray, solid: Solid) -> list[np.ndarray]:
    """``P₀, P₁[, P₂]`` of the module docstring (complex coefficient arrays in ``v``, ascending)."""
    omega_h, r2 = solid.freq_ratio, solid.r_theta**2
    s_h = np.array([-1.0, 2j * solid.zeta_h * omega_h, omega_h**2])
    s_t = np.array([-1.0, 2j * solid.zeta_theta, 1.0])
    a = _dof_indices(solid)
    if a == [0, 1]:
        p2 = r2 * npoly.polymul(s_h, s_t)
        p1 = -npoly.polyadd(s_h * loads[1, 1], r2 * s_t * loads[0, 0])
        p0 = np.array([loads[0, 0] * loads[1, 1] - loads[0, 1] * loads[1, 0]])
        return [p0, p1, p2]
    if a == [0]:
        return [np.array([-loads[0, 0]]), s_h]
    return [np.array([-loads[1, 1]]), r2 * s_t]


def _real_resultant(polys: list[np.ndarray]) -> np.ndarray:
    """Real polynomial in ``v`` that vanishes where ``Σ P_k(v) m̂^k`` has a real root ``m̂``."""
    re = [p.real for p in polys]
    im = [p.imag for p in polys]
    mul, sub = npoly.polymul, npoly.polysub
    if len(polys) == 2:  # m̂ = −P₀/P₁ real ⇔ Im(P₀ conj P₁) = 0
        return sub(mul(im[0], re[1]), mul(re[0], im[1]))
    (c1, b1, a1), (c2, b2, a2) = re, im
    ac = sub(mul(a1, c2), mul(a2, c1))
    ab = sub(mul(a1, b2), mul(a2, b1))
    bc = sub(mul(b1, c2), mul(b2, c1))
    return sub(mul(ac, ac), mul(ab, bc))


def neutral_roots(
    sample: AxisSample,
    solid: Solid,
    theta0: float,
    loads0: np.ndarray,
    mass_range: tuple[float, float],
) -> list[NeutralRoot]:
    """Every neutral point ``(m, U*)`` with frequency ``sample.frequency`` > 0 and ``m`` in
    ``mass_range`` (solid parameters other than ``m``, ``U*`` from ``solid``):
    :func:`roots_from_loads` of the sample's ``A(iω)``, ``dA/ds``."""
    if sample.frequency <= 0:
        raise InputError("neutral_roots is for ω > 0; divergence (ω = 0) is divergence_lines")
    loads, rate = second_order_loads(sample, theta0, loads0)
    return roots_from_loads(loads, rate, sample.frequency, solid, mass_range)


def roots_from_loads(
    loads: np.ndarray, rate: np.ndarray, omega: float, solid: Solid, mass_range: tuple[float, float]
) -> list[NeutralRoot]:
    """The real roots ``(m, U*)`` of ``det(m W(iω, 1/U*) − A) = 0`` with ``m`` in ``mass_range``:
    the positive-``m`` roots of the resultant (:func:`resultant_tracks`), each polished by Newton
    on ``F``."""
    return _roots_on_tracks(resultant_tracks(loads, omega, solid), loads, rate, omega, solid, mass_range)


def _roots_on_tracks(tracks, loads, rate, omega, solid, mass_range) -> list[NeutralRoot]:
    """:func:`roots_from_loads` from the resultant's roots already computed (``tracks``)."""
    roots = []
    for v, mass_ratio in tracks:
        if mass_ratio <= 0:
            continue
        root = _polish(loads, rate, solid, 1j * omega, mass_ratio, v * omega)
        if root is None:
            continue
        m, u = root
        if not mass_range[0] <= m <= mass_range[1]:
            continue
        if any(
            abs(m - r.mass_ratio) < 1e-9 * m and abs(1 / u - r.reduced_velocity) < 1e-9 / u for r in roots
        ):
            continue
        roots.append(_root_with_tangent(loads, rate, solid, omega, m, u))
    return roots


def resultant_tracks(loads: np.ndarray, omega: float, solid: Solid) -> np.ndarray:
    """Every real positive root ``v`` of the resultant with its real ``m`` (any sign, any size):
    ``(k, 2)`` rows ``(v, m)``. Between two frequencies a curve can sweep through the whole mass
    range (``m`` through ``∞`` or 0, a narrow window in ω, e.g. lock-in onsets near the wake
    frequency) without a root in range at either; its track still changes sign or side there."""
    polys = scaled_polynomials(loads, solid)
    resultant = npoly.polytrim(_real_resultant(polys), tol=0.0)
    for v0 in undamped_resonances(solid):
        # divided out exactly: found numerically, this root lies ~1e-9 off v0 with m ≈ ±1e9 of
        # either sign from one ω to the next, and every such flip looked like a curve sweeping
        # the mass range (587 unresolved intervals on the coarse plate at Re 500, α0 = 10°)
        resultant = npoly.polydiv(resultant, np.array([-v0, 1.0]))[0]
    rows = []
    for v in npoly.polyroots(resultant) if len(resultant) > 1 else []:
        if abs(v.imag) > 1e-6 * max(1.0, abs(v)) or v.real <= 0:
            continue
        coefficients = [complex(npoly.polyval(v.real, p)) for p in polys]
        if abs(coefficients[-1]) < 1e-9 * np.abs(polys[-1]).max():
            continue  # the leading coefficient vanishes (ζ_h = 0, v = 1/Ω): the resultant's trivial root
        if len(coefficients) == 3:
            candidates = np.roots(coefficients[::-1])
        else:
            candidates = np.array([-coefficients[0] / coefficients[1]])
        if len(candidates):
            best = candidates[np.argmin(np.abs(candidates.imag) / np.maximum(np.abs(candidates), 1e-300))]
            rows.append((v.real, best.real / omega**2))
    return np.array(rows).reshape(-1, 2)


def undamped_resonances(solid: Solid) -> list[float]:
    """The ``v = u/ω`` where the highest power of ``m̂`` in ``Σ P_k(v) m̂^k`` vanishes for every
    ``ω``: the in-vacuo resonance of an undamped dof (``S_h = 0`` at ``v = 1/Ω`` when ``ζ_h = 0``,
    ``S_θ = 0`` at ``v = 1`` when ``ζ_θ = 0``), where the neutral mass is infinite. Each is a
    root of the resultant at every frequency and carries no curve."""
    dofs = _dof_indices(solid)
    roots = []
    if 0 in dofs and solid.zeta_h == 0:
        roots.append(1.0 / solid.freq_ratio)
    if 1 in dofs and solid.zeta_theta == 0:
        roots.append(1.0)
    return roots


def _side(m: float, band: tuple[float, float]) -> int:
    """Where a resultant root's ``m`` lies: -1 at ``m ≤ 0``, 0 below ``band``, 1 in it, 2 above."""
    return -1 if m <= 0 else 0 if m < band[0] else 1 if m <= band[1] else 2


def _born(left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """Of two frequencies' resultant tracks, the longer, the shorter and the rows of the longer that
    are born or die in between: each root of the shorter is the nearest in ``v`` of the longer."""
    longer, shorter = (left, right) if len(left) > len(right) else (right, left)
    free = list(range(len(longer)))
    for v, _ in shorter:
        free.remove(min(free, key=lambda i: abs(longer[i, 0] - v)))
    return longer, shorter, free


def _swept(left: np.ndarray, right: np.ndarray, band: tuple[float, float], settled: bool = False) -> bool:
    """Whether a pair of real resultant roots is born or dies between two frequencies, or a root
    (matched by nearest ``v``) passes from one side of ``band`` to the other, or through
    ``m = 0``/``∞``, without being in the band at either frequency, or (unless ``settled``) a root
    changed sides other than across an edge of the band, matched or not (:func:`_side_jump`).
    ``settled``: the two
    frequencies are ``SWEEP_STEP`` apart, too close for a root to go round through the band, so a
    root that changes sign beyond the band at both (``|m| > band[1]``) passes through ``m = ∞``,
    one below it at both (``|m| < band[0]``) through ``m = 0``, and roots born or dying all on one
    side of the band (outside it) were born or died there: none of these is a sweep."""

    if len(left) != len(right):  # real roots born or dying in between
        if not settled:
            return True
        longer, _, free = _born(left, right)
        sides = {_side(m, band) for m in longer[free, 1]}
        if len(sides) > 1 or 1 in sides:
            return True
    elif not settled and _side_jump(left, right, band):
        # a root changed sides other than across an edge of the band, matched below or not: a
        # curve near-vertical in ω moves fast in v too (on the plate at Re 2900 with a resolved far
        # wake, from v = 1.21, m = −36.8 to v = 2.30, m = 0.91 in 0.017 of ω, through m = ∞ and
        # the whole band: a VIV curve within ω 11.25–11.26)
        return True
    for v, m in left:
        if not len(right):
            return False
        k = int(np.argmin(np.abs(right[:, 0] - v)))
        if abs(right[k, 0] - v) > 0.25 * v:
            continue
        a, b = _side(m, band), _side(right[k, 1], band)
        if a != b and 1 not in (a, b):
            low, high = sorted((abs(m), abs(right[k, 1])))
            if settled and (low > band[1] or high < band[0]):
                continue  # through ∞ or 0 next to where it was: a pole of the neutral mass
            return True
    return False


def _side_jump(left: np.ndarray, right: np.ndarray, band: tuple[float, float]) -> bool:
    """Whether the sides (:func:`_side`) of two frequencies' resultant roots differ by more than
    roots entering or leaving ``band`` across its edges (below ↔ in, in ↔ above), whichever root is
    whose: a root that went from ``m < 0`` into the band, or from one side of it to the other, went
    through ``m = 0`` or ``∞`` and may have crossed the whole band."""
    lost = Counter(_side(m, band) for m in left[:, 1])
    gained = Counter(_side(m, band) for m in right[:, 1])
    lost, gained = lost - gained, gained - lost
    for a, b in ((0, 1), (1, 0), (1, 2), (2, 1)):  # across an edge: the band's roots are matched
        k = min(lost[a], gained[b])
        lost[a] -= k
        gained[b] -= k
    return bool(+lost or +gained)


def _born_outside(left: np.ndarray, right: np.ndarray, band: tuple[float, float]) -> bool:
    """Whether the only change between two frequencies is a pair of real resultant roots born (or
    dying) on one side outside ``band``, close together at the frequency where they exist
    (``|Δv| ≤ YOUNG_PAIR v``), with every other root matched and not sweeping (:func:`_swept`).

    A pair is born where the track folds in ``ω`` (a double real root): from there both roots move
    as ``√(ω − ω_b)`` to leading order, in ``v`` and in ``m``, so between the birth and the sample
    where they exist their ``m`` stay between the two values there. A young pair that lies outside
    the band on one side there never entered it: no curve to look for. This settles an interval at
    ``min_step`` instead of bisecting it down to ``SWEEP_STEP`` (on the plate at Re 2900, default mesh,
    such a pair born at m ≈ −2.3 near ω = 9.14 was bisected by a chain of 13 samples; settled at
    ``min_step`` it costs 4 factorisations fewer, the same map)."""
    if abs(len(left) - len(right)) != 2:
        return False
    longer, shorter, free = _born(left, right)
    (v1, m1), (v2, m2) = longer[free]
    if abs(v1 - v2) > YOUNG_PAIR * max(v1, v2):
        return False
    side = _side(m1, band)
    if side != _side(m2, band) or side == 1:
        return False
    kept = np.delete(longer, free, axis=0)
    return not _swept(shorter, kept, band)


def _polish(loads, rate, solid, s, mass_ratio, u, iterations: int = 8):
    """The neutral point ``F = 0`` at the sampled frequency (``ω`` held) from ``(m, u)``: the one
    Newton (:func:`fsistab.continuation.newton`) on ``Re F = Im F = 0`` in ``(log m, log U*)``
    (:class:`fsistab.neutral_point.DeterminantProblem`, ``y = (ω, log U*, log m)``) until the step
    is below 1e-12 (or 1e-9 after ``iterations``); None if it does not converge."""
    omega = s.imag

    def characteristic(y: np.ndarray, gradient: bool):
        log_velocity, log_mass = float(y[1]), float(y[2])
        if not (abs(log_velocity) < 200 and abs(log_mass) < 200):  # diverged (exp would overflow)
            raise ConvergenceError("the neutral-point Newton left the admissible range")
        m, uu = math.exp(log_mass), math.exp(-log_velocity)
        f, f_m, f_u, f_s = characteristic_function(loads, rate, solid, s, m, uu)
        # ∂/∂(ω, log U*, log m) with u = 1/U*: ∂u/∂(log U*) = -u
        return (f, np.array([1j * f_s, -f_u * uu, f_m * m])) if gradient else f

    problem = DeterminantProblem(characteristic).at(0, omega)
    result = newton(
        problem,
        np.array([omega, -math.log(u), math.log(mass_ratio)]),
        tol=0.0,
        max_iterations=iterations,
        small_step=lambda d, y: np.max(np.abs(d)) < 1e-12,
    )
    y = result.point
    near = result.last_step is not None and np.max(np.abs(result.last_step)) < 1e-9
    if result.converged or (result.iterations == iterations and near and np.all(np.abs(y[1:]) < 200)):
        return math.exp(y[2]), math.exp(-y[1])
    return None


def _root_with_tangent(loads, rate, solid, omega, m, u) -> NeutralRoot:
    s = 1j * omega
    _, f_m, f_u, f_s = characteristic_function(loads, rate, solid, s, m, u)
    # F(log m, log U*, ω) = 0: [F_m m, −F_u u] d(log m, log U*) = −i F_s dω
    rhs = -1j * f_s
    jac = np.array([[(f_m * m).real, (-f_u * u).real], [(f_m * m).imag, (-f_u * u).imag]])
    dlog_mass, dlog_velocity = np.linalg.solve(jac, np.array([rhs.real, rhs.imag]))
    # fixed m: F_s dσ + F_u du = 0, du = −u d(log U*)
    crossing = (f_u * u / f_s).real
    return NeutralRoot(omega, m, 1.0 / u, float(dlog_mass), float(dlog_velocity), float(crossing))


def divergence_lines(
    static: AxisSample, solid: Solid, theta0: float, loads0: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Static neutral curves ``U*_D = √(m/λ)`` (MODEL.md §8): ``λ`` the positive eigenvalues of
    ``W₀⁻¹ A(0)``, ``W₀ = diag(Ω², r_θ²)`` on the active dofs (``det(m u² W₀ − A(0)) = 0``), and
    the crossing rate ``∂σ/∂(log U*)`` of the real eigenvalue on each (> 0: divergence as U* grows)."""
    if static.frequency != 0:
        raise InputError("divergence_lines needs the sample at ω = 0")
    a = _dof_indices(solid)
    loads, rate = second_order_loads(static, theta0, loads0)
    w0 = np.array([solid.freq_ratio**2, solid.r_theta**2])[a]
    values = np.linalg.eigvals(loads.real[np.ix_(a, a)] / w0[:, None])
    lambdas = np.sort([v.real for v in values if abs(v.imag) < 1e-12 * abs(v) and v.real > 0])
    rates = []
    for lam in lambdas:  # any m: the rate does not depend on where on the line
        m = 1.0
        u = 1.0 / divergence_velocity(lam, 1.0, m)  # u = 1/U*_D, λ the slope per unit r_θ² (see above)
        _, _, f_u, f_s = characteristic_function(loads, rate, solid, 0.0, m, u)
        rates.append((f_u * u / f_s).real)
    return np.array(lambdas), np.array(rates)


def _geometric(omega0: float, step: float, tau: float) -> float:
    """``ω`` at ``τ ∈ [0, 1]`` of a segment from ``omega0`` that is ``step`` long in ``log ω``."""
    return float(omega0 * math.exp(step * tau))


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
        constant across a fold) and ``rate/(d log m/dτ)`` at both ends."""
        folds = dict(self.folds)
        for k, (r0, r1) in enumerate(zip(self.roots[:-1], self.roots[1:], strict=True)):
            if k in folds:
                chord = float(np.linalg.norm(r1.plane - r0.plane))
                unit = lambda t: t / max(float(np.linalg.norm(t)), 1e-300)  # noqa: E731
                start, end = folds[k] * chord * unit(r0.tangent), -folds[k] * chord * unit(r1.tangent)
                plane = _hermite(r0.plane, start, r1.plane, end, 1.0)
                omega = partial(_geometric, r0.frequency, 0.0)
            else:
                step = log_step(r0.frequency, r1.frequency)
                plane = _hermite(r0.plane, r0.log_tangent, r1.plane, r1.log_tangent, step)
                omega = partial(_geometric, r0.frequency, step)
            slope = npoly.polyder(plane[:, 0])
            ends = (npoly.polyval(0.0, slope), npoly.polyval(1.0, slope))
            q = tuple(r.crossing_rate / d if d else 0.0 for r, d in zip((r0, r1), ends, strict=True))
            yield r0, r1, plane, omega, q

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
        found = []
        for _, _, coef, omega, (q0, q1) in self._segments():
            poly = coef[:, 0].copy()
            poly[0] -= target
            for tau in npoly.polyroots(npoly.polytrim(poly, tol=0.0)) if np.any(poly[1:]) else []:
                if abs(tau.imag) < 1e-9 and -1e-12 <= tau.real <= 1 + 1e-12:
                    tau = float(np.clip(tau.real, 0, 1))
                    log_u = npoly.polyval(tau, coef[:, 1])
                    rate = (q0 + tau * (q1 - q0)) * npoly.polyval(tau, npoly.polyder(coef[:, 0]))
                    found.append((math.exp(log_u), omega(tau), rate))
        unique = []
        for u, w, rate in found:  # a root at a shared sample is found from both sides
            if all(abs(u - v) > 1e-10 * u for v, _, _ in unique):
                unique.append((u, w, rate))
        return unique

    def turning_points(self) -> list[tuple[float, float, float]]:
        """``(m, U*, ω)`` where ``m`` is extremal along the curve (turning points of MODEL.md §8)."""
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

    def divergence_velocities(self, mass_ratio: float) -> np.ndarray:
        # λ is the static load slope per unit inertia r_θ² (MODEL.md §8): U*_D = √(m · 1 / λ)
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


SAMPLE_FIELDS = {"sample": ("frequency", "transfer", "transfer_rate", "reduced")}


def samples_table(path: Path, fluid: FluidOperators) -> ResumableTable:
    """The resumable table of ``G(iω)`` and ``dG/ds`` at the sampled frequencies of one mesh and
    flow (:func:`fsistab.transfer.flow_identity`): the fluid's whole contribution to the map,
    reusable for any solid parameters. Fields of each ``sample``: ``frequency``, ``transfer`` (G:
    body-axis loads (F_x, F_y, M) [ρ U² L] per unit (h, θ, ḣ, θ̇) ~ e^{st}, s = i·frequency, time
    unit L/U), ``transfer_rate`` (dG/ds), ``reduced`` (1 where G comes from a certified model, not
    a factorisation: :mod:`fsistab.reduced_model` or :mod:`fsistab.rational_fit`)."""
    return ResumableTable(path, flow_identity(fluid), SAMPLE_FIELDS)


def sample_record(sample: AxisSample) -> dict:
    return {
        "frequency": sample.frequency,
        "transfer": sample.transfer,
        "transfer_rate": sample.rate,
        "reduced": int(sample.reduced),
    }


def read_samples(table: ResumableTable) -> dict[float, AxisSample]:
    """The samples of a :func:`samples_table`, by frequency in increasing order."""
    samples = [
        AxisSample(float(r["frequency"]), r["transfer"], r["transfer_rate"], bool(r["reduced"]))
        for r in table.records
    ]
    return {s.frequency: s for s in sorted(samples, key=lambda s: s.frequency)}


def _match(
    left: list[NeutralRoot], right: list[NeutralRoot], step: float, limit: float
) -> list[tuple[int, int, float]]:
    """Pairs ``(i, j, d)`` of roots at two adjacent frequencies ``step`` apart in ``log ω``
    (:func:`log_step`), ``d`` the larger of the two tangent predictions' errors (∞-norm in
    ``(log m, log U*)``), greedy by ``d`` below ``limit``."""
    pairs = []
    for i, a in enumerate(left):
        for j, b in enumerate(right):
            forward = np.abs(a.plane + step * a.log_tangent - b.plane).max()
            backward = np.abs(b.plane - step * b.log_tangent - a.plane).max()
            pairs.append((max(forward, backward), i, j))
    used_left, used_right, matches = set(), set(), []
    for d, i, j in sorted(pairs):
        if d < limit and i not in used_left and j not in used_right:
            used_left.add(i)
            used_right.add(j)
            matches.append((i, j, d))
    return matches


def _resolved(left, right, step, tolerance, inner) -> bool:
    """Every root inside ``inner`` (a mass range) on either side is matched within ``tolerance``."""
    matches = _match(left, right, step, tolerance)
    done_left = {i for i, _, _ in matches}
    done_right = {j for _, j, _ in matches}
    need = lambda roots, done: all(  # noqa: E731
        k in done or not inner[0] <= r.mass_ratio <= inner[1] for k, r in enumerate(roots)
    )
    return need(left, done_left) and need(right, done_right)


def resonance(left: AxisSample, right: AxisSample) -> tuple[complex, float]:
    """The pole ``λ`` of the fluid's transfer function that two samples point to, and the share of
    ``G`` its residue makes at the samples: from one rational fit ``p_e(s)/(s − λ)`` (``p_e``
    quadratic, one per entry of ``G``) to the values and ``dG/ds`` of both samples, in least
    squares (48 equations, 37 unknowns); the share is ``‖p(λ)‖/‖G‖`` in the fit's variable
    ``t = (s − s_mid)/h`` (``h`` the half-width), the pole's part of ``G`` at the ends.

    A weakly damped fluid mode (the wake mode) between two frequencies far apart compared with its
    damping leaves no neutral root at either, but the tails of its pole ``R/(s − λ)`` in ``G`` and
    ``dG/ds`` show: on the plate at Re 2900 (default mesh), samples at ω = 10.47 and 12.31 give
    0.005 + 10.915i with share 0.047 for the wake mode −0.032 + 11.098i. A smooth ``G`` gives a
    pole anywhere with a small share (4e-4 for an exact quadratic in ``s``)."""
    a, b = 1j * left.frequency, 1j * right.frequency
    middle, half = 0.5 * (a + b), 0.5 * (b - a)
    entries = left.transfer.size
    rows, rhs = [], []
    for s, value, rate in ((a, left.transfer, left.rate), (b, right.transfer, right.rate)):
        t = (s - middle) / half  # unknowns: μ = (λ − middle)/half, then p_e's coefficients in t
        for e, (f, df) in enumerate(zip(value.ravel(), half * rate.ravel(), strict=True)):
            # (t − μ) f = p(t) and its t-derivative f + (t − μ) f' = p'(t), at both samples
            equations = ((-f, -t * f, (1, t, t * t)), (-df, -(f + t * df), (0, 1, 2 * t)))
            for coefficient, known, powers in equations:
                row = np.zeros(1 + 3 * entries, dtype=complex)
                row[0], row[1 + 3 * e : 4 + 3 * e] = coefficient, np.negative(powers)
                rows.append(row)
                rhs.append(known)
    matrix = np.array(rows)
    scale = np.linalg.norm(matrix, axis=0)
    scale[scale == 0] = 1.0
    solution = np.linalg.lstsq(matrix / scale, np.array(rhs), rcond=None)[0] / scale
    mu, numerators = solution[0], solution[1:].reshape(entries, 3)
    residue = numerators @ np.array([1.0, mu, mu * mu])
    size = max(np.linalg.norm(left.transfer), np.linalg.norm(right.transfer))
    return complex(middle + half * mu), float(np.linalg.norm(residue) / size) if size > 0 else 0.0


def sharp_resonance(left: AxisSample, right: AxisSample) -> bool:
    """Whether the :func:`resonance` pole between two samples lies closer to the axis than
    ``SHARP_RESONANCE`` half-widths of their interval with a residue of at least ``SHARP_SHARE``
    of ``G``: an isolated resonance that exact bisections would resolve only after many halvings."""
    pole, share = resonance(left, right)
    narrow = abs(pole.real) < SHARP_RESONANCE * 0.5 * (right.frequency - left.frequency)
    return narrow and share >= SHARP_SHARE


def unresolved_resonance(left: AxisSample, right: AxisSample) -> float | None:
    """The frequency at which to sample next if the two samples straddle a resonance they do not
    resolve: the :func:`resonance` pole lies between them, closer to the axis than
    ``RESONANCE_DAMPING`` half-widths, with a residue share above ``RESONANCE_SHARE``; its
    frequency, kept ``RESONANCE_MARGIN`` of the interval from either end. None otherwise, and for
    intervals narrower than ``RESONANCE_STEP`` (relative), where the fit is ill-conditioned."""
    low, high = left.frequency, right.frequency
    if not 0 < low < high or high - low < RESONANCE_STEP * high:
        return None
    pole, share = resonance(left, right)
    if not low < pole.imag < high or abs(pole.real) >= RESONANCE_DAMPING * 0.5 * (high - low):
        return None
    if share < RESONANCE_SHARE:
        return None
    margin = RESONANCE_MARGIN * (high - low)
    return float(min(max(pole.imag, low + margin), high - margin))


def default_frequency_range(wake_frequency: float | None) -> tuple[float, float]:
    """``ω`` from 0.01 to ``max(20, 1.5 ω_wake)``: flutter below ω ≈ 2 and VIV around the wake."""
    return (0.01, 20.0 if wake_frequency is None else max(20.0, 1.5 * wake_frequency))


def initial_frequencies(
    omega_range: tuple[float, float], count: int, wake_frequency: float | None
) -> np.ndarray:
    """Log-spaced frequencies over ``omega_range``, and 24 more within ±10 % of the wake frequency
    (VIV windows are narrow in ω)."""
    grid = np.geomspace(*omega_range, count)
    if wake_frequency is not None:
        grid = np.concatenate([grid, np.linspace(0.9, 1.1, 24) * wake_frequency])
    return np.unique(grid[(grid >= omega_range[0]) & (grid <= omega_range[1])])


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
    progress: Callable[[str], None] | None = None,
    threads: int | None = None,
    fit_first: bool = True,
    resonance_blocks: int = RESONANCE_BLOCKS,
) -> TransferMap:
    """Every neutral curve of the ``(m, U*)`` plane with ``m`` in ``mass_range`` and frequency in
    ``omega_range`` (module docstring), for the solid parameters of ``template`` other than ``m``
    and ``U*``; divergence from ``G(0)``. Without ``omega_range`` the range is
    :func:`default_frequency_range`. With ``follow_low`` (the default without ``omega_range``) the
    range is extended down by halving while a curve leaves it inside the mass range (down to
    ``LOWEST_FREQUENCY``): the flutter curve's restabilisation branch, whose frequency falls as m
    grows. A curve that leaves the final range inside the mass range is reported as an unresolved
    interval of reason ``range`` beyond that end. Each curve is labelled ``flutter`` or ``viv``
    from its own roots (:func:`fsistab.neutral_map.curve_kind`); ``wake_frequency``, if given, is only
    a guess that adds initial frequencies around it (:func:`initial_frequencies`) and widens the
    default range (:func:`default_frequency_range`).

    Starts from :func:`initial_frequencies`, samples every interval that straddles an unresolved
    resonance at its pole's frequency (:func:`unresolved_resonance`) — with exact samples, a sharp
    one (:func:`sharp_resonance`) by a reduced fluid model of ``resonance_blocks`` Krylov blocks
    built there (0: an exact sample), whose certified interval is then sampled at no factorisation
    (saved next to ``samples_path`` and reused); with exact samples and a range that starts below
    ``LOW_MODEL_REACH``, ``G(0)`` and the lowest frequencies likewise come from one real model at
    s = 0, built beside the initial exact samples — and bisects every interval
    whose roots are not matched within ``tolerance`` (in ``log m``, ``log U*``) by their tangents,
    down to a relative step ``min_step``. With exact samples, a run of intervals still unresolved
    there (not a fold in ``ω``) goes on with a certified rational fit of the exact samples around
    it (:func:`fsistab.rational_fit.certified_transfer`, ``FIT_MARGINS`` samples on each side),
    bisected down to ``FIT_MIN_STEP`` with no factorisation (at most ``FITTED_SAMPLES`` such
    frequencies). With ``fit_first`` (the default) such a fit is tried before each round's exact
    bisections too (unmatched roots or a possible sweep), on each run of intervals to bisect and
    ``FIT_FIRST_SPAN`` exact samples beyond it: where it is certified, the bisections there are made
    on it. Intervals still unresolved then (folds in ``ω``, or where no fit is certified) are
    listed in ``unresolved`` with their reasons, :class:`UnresolvedInterval`; two branches born or
    dying together at a fold are joined. Intervals where a curve may cross the whole mass range
    between the samples (:func:`resultant_tracks`) are bisected down to ``SWEEP_STEP``; at most
    ``max_samples`` frequencies. With exact samples only (one factorisation each) ``tolerance`` is
    ``EXACT_TOLERANCE``, ``min_step`` 1e-3 and ``max_samples`` 400 by default; ``max_samples`` then counts the
    exact samples, not the fitted ones. With ``samples_path`` each sample is saved as it is
    computed (atomically) and saved samples of the same mesh and flow are reused, for any solid
    parameters.

    With ``reduced`` (:class:`fsistab.reduced_model.ReducedModels`), a frequency inside the
    certified interval of a reduced model is evaluated from it (no factorisation); a frequency
    closer than two model half-widths to an exact sample (a region being refined) gets a new
    model, built there; an isolated one is sampled exactly. Factorisations then stop growing with
    the refinement, and the defaults are finer: ``tolerance`` 3e-3 (Hermite error ~1e-5),
    ``min_step`` 1e-7, ``max_samples`` 4000.

    The exact samples of each round (the initial frequencies, then each round's bisections) are
    factorised ``threads`` at a time, each saved as it finishes
    (:func:`fsistab.transfer.iter_transfer_samples`).
    """
    tolerance = tolerance if tolerance is not None else (3e-3 if reduced is not None else EXACT_TOLERANCE)
    min_step = min_step if min_step is not None else (1e-7 if reduced is not None else 1e-3)
    max_samples = max_samples if max_samples is not None else (4000 if reduced is not None else 400)
    follow = omega_range is None if follow_low is None else follow_low
    omega_range = default_frequency_range(wake_frequency) if omega_range is None else omega_range
    low, high = mass_range
    if not (0 < low < high and math.isfinite(high)):
        raise InputError(f"the mass-ratio range must satisfy 0 < low < high, got {mass_range}")
    if not (0 < omega_range[0] < omega_range[1] and math.isfinite(omega_range[1])):
        raise InputError(f"the frequency range must satisfy 0 < low < high, got {omega_range}")
    if not 0 < tolerance < 0.5 or not 0 < min_step < 0.5:
        raise InputError(f"tolerance and min_step must be in (0, 0.5), got {tolerance}, {min_step}")
    counter = counter if counter is not None else FactorCounter()
    say = progress or (lambda message: None)
    start = counter.count
    # finished samples (checksummed; a damaged file is reported and recomputed, another flow's refused)
    table = samples_table(Path(samples_path), fluid) if samples_path is not None else None
    stored = read_samples(table) if table is not None else {}
    wide = (low / 4, high * 4)  # roots followed; those in mass_range must be matched
    inner = (low, high)
    theta0, loads0 = fluid.theta0, fluid.loads0

    def refined(omega: float) -> bool:
        """Whether ``omega`` is close to an exact sample: a model there will serve the refinement."""
        radius = 2 * (reduced.half_width() or REFINEMENT_RADIUS)
        return any(0 < w and abs(w - omega) <= radius for w, x in stored.items() if not x.reduced)

    def keep(sample: AxisSample) -> AxisSample:
        """Store a new sample; an exact one is saved at once, a reduced one with the next save."""
        stored[sample.frequency] = sample
        if table is not None:
            table.append(sample_record(sample), save=not sample.reduced)
        return sample

    def save() -> None:
        if table is not None:
            table.save()

    fits: list[TransferFit] = []  # certified rational fits of the exact samples (below min_step)
    # with exact samples, reduced models at resonances (saved next to the samples: a rerun reuses them)
    # (their own counter: they are built beside the round's exact samples, added to ``counter`` after)
    resonances, built = None, FactorCounter()
    if reduced is None and resonance_blocks:
        samples = None if samples_path is None else Path(samples_path)
        path = None if samples is None else samples.with_name(samples.stem + "_resonance_models.nc")
        resonances = ReducedModels(
            fluid,
            tolerance=RESONANCE_TOLERANCE,
            blocks=resonance_blocks,
            path=path,
            counter=built,
            progress=say,
            refine=False,
        )
    models = [_model_cover(m, RESONANCE_TOLERANCE) for m in resonances.models] if resonances else []

    def fitted(omega: float) -> TransferFit | None:
        return next((f for f in (*models, *fits) if f.covers(omega)), None)

    def spanned(w0: float, w1: float) -> bool:
        """Whether one certified fit (or resonance model) covers both ends of ``[w0, w1]``."""
        return any(f.covers(w0) and f.covers(w1) for f in (*models, *fits))

    def resonance_model(omega: float) -> TransferFit | None:
        """A reduced model at the resonance ``omega`` (or at s = 0 for ``omega`` = 0, real;
        ``resonance_blocks``, plain solves: their residual, 5e-13, is far below the model's
        tolerance), whose certified interval is then sampled at no factorisation; None if it
        certifies nothing."""
        try:
            model = resonances.build(omega)
        except ConvergenceError as error:  # no certified interval: exact samples there
            say(str(error))
            return None
        return _model_cover(model, RESONANCE_TOLERANCE)

    def prefetch_beside_models(batch: list[float], sharp: list[tuple[float, float, float]]) -> None:
        """:func:`prefetch` of ``batch`` while the reduced models at the ``sharp`` resonances
        ``(w0, w1, pole)`` are built in another thread: the frequencies inside their intervals wait
        for them (a model may cover them), the others are factorised meanwhile."""
        waiting = [w for w in batch if any(w0 <= w <= w1 for w0, w1, _ in sharp)]
        with ThreadPoolExecutor(1) as builder:
            futures = [builder.submit(resonance_model, pole) for *_, pole in sharp]
            prefetch([w for w in batch if w not in waiting])
            models.extend(fit for future in futures if (fit := future.result()) is not None)
        counter.count += built.count
        built.count = 0
        prefetch(waiting)

    def fit_around(low_end: float, high_end: float, beyond: int = 0) -> TransferFit | None:
        """A rational fit of the exact samples around ``[low_end, high_end]``, certified there,
        the interval first widened to the ``beyond``-th exact sample outside it on each side."""
        exact = np.array(sorted(w for w, x in stored.items() if w > 0 and not x.reduced))
        first, last = np.searchsorted(exact, low_end, "right") - 1, np.searchsorted(exact, high_end, "left")
        if beyond:
            first, last = max(first - beyond, 0), min(last + beyond, len(exact) - 1)
            low_end, high_end = float(exact[first]), float(exact[last])
        for margin in FIT_MARGINS:
            window = exact[max(first - margin, 0) : last + margin + 1]
            data = [stored[w] for w in window]
            fit = certified_transfer(
                window, [x.transfer for x in data], [x.rate for x in data], (low_end, high_end)
            )
            if fit is not None:
                return fit
        return None

    def certify(low_end: float, high_end: float, beyond: int = 0) -> bool:
        """Whether a fit of the exact samples is certified around ``[low_end, high_end]`` (kept;
        :func:`fit_around`)."""
        fit = fit_around(low_end, high_end, beyond)
        if fit is not None:
            fits.append(fit)
            say(f"a rational fit certified on ω ∈ [{fit.low:.5g}, {fit.high:.5g}] (error {fit.error:.1e})")
        return fit is not None

    def sample(omega: float) -> AxisSample:
        if omega not in stored and (fit := fitted(omega)) is not None:
            g, dg = fit.transfer(omega)
            keep(AxisSample(omega, g, dg, reduced=True))
        if omega not in stored and reduced is not None:
            model = reduced.covering(omega)
            if model is None and omega > 0 and refined(omega):
                try:
                    model = reduced.build(omega)
                except ConvergenceError as error:  # no certified interval here: sample exactly
                    say(str(error))
            if model is not None:  # saved with the next exact sample or at the end of the round
                g, dg = model.transfer(1j * omega if omega > 0 else 0.0, derivative=True)
                keep(AxisSample(omega, g, dg, reduced=True))
        if omega not in stored:
            s = 1j * omega if omega > 0 else 0.0
            g, dg = exact_transfer(fluid, s, counter, derivative=True, refine=SAMPLE_REFINE)
            keep(AxisSample(omega, g, dg))
        return stored[omega]

    def prefetch(frequencies) -> None:
        """The exact samples among ``frequencies`` (those no reduced model covers or will cover),
        factorised ``threads`` at a time (:func:`fsistab.transfer.iter_transfer_samples`)."""
        exact = [
            float(w)
            for w in dict.fromkeys(frequencies)
            if w > 0
            and w not in stored
            and fitted(w) is None
            and (reduced is None or (reduced.covering(w) is None and not refined(w)))
        ]
        frequency = {complex(1j * w): w for w in exact}
        shifts = list(frequency)
        samples = iter_transfer_samples(fluid, shifts, counter, refine=SAMPLE_REFINE, threads=threads)
        for sample in samples:  # each saved as it finishes: an interruption loses those under way only
            keep(AxisSample(frequency[sample.s], sample.value, sample.rate))

    roots: dict[float, list[NeutralRoot]] = {}
    tracks: dict[float, np.ndarray] = {}

    def add(omega: float) -> None:
        if any(abs(omega - w) <= 1e-9 * omega for w in roots):
            return  # the same frequency up to rounding (saved grids, bisections)
        near = [w for w in stored if abs(omega - w) <= 1e-9 * omega]
        omega = near[0] if near else omega
        loads, rate = second_order_loads(sample(omega), theta0, loads0)
        tracks[omega] = resultant_tracks(loads, omega, template)
        roots[omega] = _roots_on_tracks(tracks[omega], loads, rate, omega, template, wide)

    lowest = LOWEST_FREQUENCY if follow else omega_range[0]
    saved = [w for w in stored if lowest <= w <= omega_range[1]]  # free: use them all
    first = sorted({*initial_frequencies(omega_range, initial, wake_frequency).tolist(), *saved})
    if (
        resonances is not None
        and omega_range[0] < LOW_MODEL_REACH
        and 0.0 not in stored
        and fitted(0.0) is None
    ):
        # G is smooth near ω = 0 out to the nearest weakly damped fluid poles: one real model at
        # s = 0 gives G(0) (to 1e-10) and every frequency up to its certified edge; the initial
        # frequencies below LOW_MODEL_REACH wait for it, the others are sampled meanwhile
        prefetch_beside_models(first, [(0.0, LOW_MODEL_REACH, 0.0)])
    else:
        prefetch(first)
    static = sample(0.0)
    for omega in first:
        add(float(omega))
    unresolved: dict[tuple[float, float], str] = {}  # interval -> reason (UNRESOLVED_REASONS)
    interpolated = sum(stored[w].reduced for w in roots) if reduced is None else 0
    first_round = True  # the intervals of the initial frequencies (and of saved samples)
    while True:
        grid = sorted(roots)
        todo, stuck, pending, sharp = [], [], [], []
        for w0, w1 in zip(grid[:-1], grid[1:], strict=True):
            if (w0, w1) in unresolved:
                continue
            if not _resolved(roots[w0], roots[w1], log_step(w0, w1), tolerance, inner):
                # a fold in ω (a pair of roots of the range born or dying together, as the
                # resultant's real roots) is no step's to resolve; curves too fast for the step are
                # refined on with a rational fit
                fold = min(abs(len(roots[w0]) - len(roots[w1])), abs(len(tracks[w0]) - len(tracks[w1]))) >= 2
                covered = not fold and spanned(w0, w1)
                if not covered and not fold and reduced is None and w1 - w0 < min_step * w1:
                    stuck.append((w0, w1))  # a rational fit of the samples around may go on
                    continue
                if fit_first and not covered and not fold and reduced is None:
                    pending.append((w0, w1))
                smallest, reason = (FIT_MIN_STEP if covered else min_step), "min_step"
            elif _swept(tracks[w0], tracks[w1], wide):
                # a curve may cross the whole range in between: find it
                smallest, reason = SWEEP_STEP, "sweep"
                if w1 - w0 < smallest * w1 and not _swept(tracks[w0], tracks[w1], wide, settled=True):
                    continue  # at the finest step: a pole of m, or roots born outside the range
                if w1 - w0 < min_step * w1 and _born_outside(tracks[w0], tracks[w1], wide):
                    continue  # a young pair born outside the range on one side: it never entered it
                if fit_first and reduced is None and not spanned(w0, w1):
                    pending.append((w0, w1))
            elif (pole := unresolved_resonance(stored[w0], stored[w1])) is not None:
                # a weakly damped fluid mode between the samples (the wake mode's VIV curves lie
                # within its resonance and may leave no root at either sample): sample at its pole,
                # with exact samples from a reduced model there, which certifies the resonance
                # around it (its curves are then refined at no factorisation)
                if (
                    resonances is not None
                    and first_round
                    and fitted(pole) is None
                    and sharp_resonance(stored[w0], stored[w1])
                ):
                    sharp.append((w0, w1, pole))
                todo.append((w1 - w0, w0, w1, pole))
                continue
            else:
                continue
            if w1 - w0 < smallest * w1:
                unresolved[(w0, w1)] = reason
            else:
                todo.append((w1 - w0, w0, w1, 0.5 * (w0 + w1)))
        for run in _runs(stuck):
            # exact samples min_step apart that do not resolve a curve (a VIV curve near the wake
            # mode moves faster in ω than they are apart) while G is smooth there: refine on with
            # a certified rational fit of the samples around, no factorisation
            if interpolated < FITTED_SAMPLES and certify(run[0][0], run[-1][1]):
                todo += [(w1 - w0, w0, w1, 0.5 * (w0 + w1)) for w0, w1 in run]
            else:
                unresolved.update({interval: "min_step" for interval in run})
        for run in _runs(pending):
            # before bisecting exactly (the midpoints are in todo): a fit of the samples around,
            # certified over the run and FIT_FIRST_SPAN exact samples on each side, makes these
            # midpoints and the refinement around them free
            if interpolated < FITTED_SAMPLES and fitted(0.5 * (run[0][0] + run[0][1])) is None:
                certify(run[0][0], run[-1][1], FIT_FIRST_SPAN)
        if follow and grid[0] / 2 >= LOWEST_FREQUENCY and _leaves(roots[grid[0]], inner):
            todo.append((grid[0] / 2, 0.0, grid[0], grid[0] / 2))  # the curve goes on below: follow it
        if not todo:
            break
        # max_samples counts the frequencies whose sample costs a factorisation (or a reduced
        # model); those from a rational fit cost none and have their own cap
        spent = len(roots) if reduced is not None else len(roots) - interpolated
        room = max(max_samples - spent, 0)
        free = [item for item in todo if fitted(item[-1]) is not None]
        costly = [item for item in sorted(todo, reverse=True) if fitted(item[-1]) is None]
        over = costly[room:] + (free if interpolated >= FITTED_SAMPLES else [])
        if over:
            unresolved.update({(w0, w1): "budget" for _, w0, w1, _ in over})
            say(f"stopped at {spent} sampled frequencies with {len(over)} intervals unresolved")
        batch = [omega for *_, omega in costly[:room] + (free if interpolated < FITTED_SAMPLES else [])]
        if not batch:
            break
        if sharp:
            prefetch_beside_models(batch, sharp)
        else:
            prefetch(batch)
        for omega in batch:
            add(omega)
        interpolated = sum(stored[w].reduced for w in roots) if reduced is None else 0
        first_round = False
        save()  # the round's reduced samples: a rerun samples the same frequencies
        say(f"{len(roots)} frequencies, {len(todo)} intervals refined")
    if any(x.reduced for x in stored.values()):
        save()
    grid = sorted(roots)
    if _leaves(roots[grid[0]], inner):
        unresolved[(0.0, grid[0])] = "range"
    if _leaves(roots[grid[-1]], inner):
        unresolved[(grid[-1], max(MAX_FREQUENCY, 2 * grid[-1]))] = "range"
    curves = _assemble(roots, tracks, mass_range)
    lambdas, rates = divergence_lines(static, template, theta0, loads0)
    return TransferMap(
        tuple(curves),
        lambdas,
        rates,
        np.array(sorted({0.0, *roots})),
        (float(low), float(high)),
        counter.count - start,
        unresolved_intervals(unresolved, curves),
        len(fits),
        interpolated,
        len(models),
    )


class _AxisModel:
    """A reduced fluid model (:class:`fsistab.reduced_model.KrylovModel`) called as the model of a
    :class:`fsistab.rational_fit.TransferFit` is: ``G(s)`` and, with ``derivative``, ``dG/ds``."""

    def __init__(self, model):
        self.model = model

    def __call__(self, s: complex, derivative: bool = False):
        return self.model.transfer(s, derivative=derivative)


def _model_cover(model, tolerance: float) -> TransferFit:
    """A reduced model as a certified local model of ``G`` on its certified interval."""
    return TransferFit(model.interval[0], model.interval[1], _AxisModel(model), tolerance)


def _runs(intervals: list[tuple[float, float]]) -> list[list[tuple[float, float]]]:
    """Adjacent intervals (each starting where the last ends) grouped into runs, in order."""
    runs: list[list[tuple[float, float]]] = []
    for interval in sorted(intervals):
        if runs and runs[-1][-1][1] == interval[0]:
            runs[-1].append(interval)
        else:
            runs.append([interval])
    return runs


def _leaves(roots: list[NeutralRoot], inner: tuple[float, float]) -> bool:
    """Whether a curve crosses the end of the sampled range at one of ``roots`` (those at the
    lowest or highest frequency): a root with its mass inside ``inner``."""
    return any(inner[0] <= r.mass_ratio <= inner[1] for r in roots)


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
    JSON as the continuation method): each curve's exact roots inside the mass range (and the next
    one outside, so that lines reach the edges) with, per root, the unstable side (the sign of its
    crossing rate), and its frequency following (:func:`fsistab.neutral_map.frequency_following`, on
    the roots in the mass range, as its kind), turning points from the Hermite
    interpolants, the divergence line of the largest ``λ`` (lowest ``U*_D``, ``moment_slope =
    λ r_θ²``: the torsional formula's slope), crossings of all curves and the unresolved
    intervals."""

    low, high = tmap.mass_range
    curves = []
    for curve in tmap.curves:
        inside = [low <= r.mass_ratio <= high for r in curve.roots]
        keep = [
            r
            for k, r in enumerate(curve.roots)
            if inside[k] or (k > 0 and inside[k - 1]) or (k + 1 < len(inside) and inside[k + 1])
        ]
        neutral = tuple(
            NeutralPoint(r.mass_ratio, r.reduced_velocity, r.frequency, np.zeros(0), 0) for r in keep
        )
        folds = tuple(
            TurningPoint(m, u, w, -1, True) for m, u, w in curve.turning_points() if low <= m <= high
        )
        onset = np.mean([r.crossing_rate > 0 for r in keep]) >= 0.5
        inside_roots = [r for r in keep if low <= r.mass_ratio <= high]
        curves.append(
            MapCurve(
                curve.kind,
                float("nan"),
                "onset" if onset else "restabilisation",
                neutral,
                folds,
                ("", ""),
                unstable_sides=tuple(int(np.sign(r.crossing_rate)) for r in keep),
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
    for kind in ("divergence", "flutter", "viv"):
        counts = np.column_stack([unstable_counts(tmap, m, velocities, kinds=(kind,)) for m in masses])
        incomplete[kind] = counts.min(axis=0) < 0
        total += np.where(incomplete[kind][None, :], 0, counts)
    return total, incomplete
