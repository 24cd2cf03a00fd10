"""The neutral points of the ``(m, U*)`` plane at one frequency, from the fluid's transfer function
``G(iω)`` and ``dG/ds`` there (docs/model.md §7-§8).

On the imaginary axis ``s = iω`` the solid velocities are eliminated from ``T(s)``
(:func:`fsistab.transfer.characteristic_matrix`), leaving, for the active dofs among heave and pitch,

    ``X(s; m, u) = m W(s, u) − A(s)``,   ``W = [[S_h, x_θ s²], [x_θ s², r_θ² S_θ]]``,   ``u = 1/U*``,
    ``S_h = s² + 2ζ_h Ω u s + Ω² u²``,   ``S_θ = s² + 2ζ_θ u s + u²``,

with ``A(s)`` the 2 × 2 loads ``(C_L, C_M)`` per unit ``(ĥ, θ̂)`` of :func:`fsistab.transfer.aerodynamic_loads`
(``det T = det X / (m² r_θ²)`` for both dofs; ``x_θ`` stands for the linear coupling
``x_θ cos θ₀`` of the static unbalance at the steady pitch ``θ₀``, docs/model.md §3.1,
:func:`linear_solid`). At a fixed frequency, ``F = det X`` is a polynomial
of degree ≤ 2 in ``m`` whose coefficients are polynomials in ``u``: with ``m̂ = m ω²``, ``v = u/ω``

    ``F = P₂(v) m̂² + P₁(v) m̂ + P₀``,   ``P₂ = r_θ² ŝ_h ŝ_θ − x_θ²``,
    ``P₁ = −(ŝ_h A_θθ + r_θ² ŝ_θ A_hh) − x_θ (A_hθ + A_θh)``,   ``P₀ = det A``,
    ``ŝ_h = −1 + 2iζ_h Ω v + Ω² v²``,   ``ŝ_θ = −1 + 2iζ_θ v + v²``.

A real ``m̂`` is a common root of ``Re F`` and ``Im F``: their resultant in ``m̂``, a real polynomial
of degree 8 in ``v`` (degree 2 for one dof), vanishes. Its positive roots give **every** neutral
point ``(m, U*)`` with frequency ``ω`` — no search, no starting guess — each polished by Newton on
``F``, with its tangent along the neutral curve from implicit differentiation (``dG/ds`` enters
there). Divergence (``ω = 0``): ``m u² = λ``, with ``λ`` the positive eigenvalues of ``A(0)``
relative to ``diag(Ω², r_θ²)``, i.e. ``U*_D = √(m/λ)`` (docs/model.md §8).

Units: chord-based (plate) or diameter-based (cylinder) time ``L/U∞`` (docs/model.md §2, §10);
``m``, ``U*`` as in :class:`fsistab.params.Solid`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import numpy.polynomial.polynomial as npoly

from fsistab.continuation import newton
from fsistab.coupled import active_states, in_vacuo_rates
from fsistab.errors import ConvergenceError, InputError
from fsistab.neutral_point import DeterminantProblem, divergence_velocity
from fsistab.params import Solid
from fsistab.transfer import aerodynamic_loads


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


def linear_solid(solid: Solid, theta0: float) -> Solid:
    """``solid`` with the static unbalance's linear coupling ``x_θ cos θ₀`` of ``M_s(θ₀)`` as its
    unbalance (docs/model.md §3.1): the solid whose ``W`` and polynomials are those of the steady
    pitch ``θ₀``. Only for ``W`` and the polynomials here: ``M_s(θ₀)`` itself is formed from the
    true solid and ``θ₀`` (:func:`fsistab.coupled.solid_mass`)."""
    if not solid.static_unbalance or theta0 == 0.0:
        return solid
    return replace(solid, static_unbalance=solid.static_unbalance * math.cos(theta0))


def _dof_indices(solid: Solid) -> list[int]:
    """Active dofs as indices into ``(h, θ)``."""
    return [i for i in (0, 1) if i in active_states(solid)]


def _weights(solid: Solid, s: complex, u: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``W = [[S_h, x_θ s²], [x_θ s², r_θ² S_θ]]`` and its derivatives in ``u`` and ``s`` (2 × 2
    each; the off-diagonal terms are the static unbalance's, docs/model.md §3.1: ``x_θ cos θ₀`` for
    the solid of :func:`linear_solid`)."""
    omega_h, r2, x = solid.freq_ratio, solid.r_theta**2, solid.static_unbalance
    zh, zt = solid.zeta_h, solid.zeta_theta
    w = np.array(
        [
            [s * s + 2 * zh * omega_h * u * s + omega_h**2 * u * u, x * s * s],
            [x * s * s, r2 * (s * s + 2 * zt * u * s + u * u)],
        ]
    )
    w_u = np.diag([2 * zh * omega_h * s + 2 * omega_h**2 * u, r2 * (2 * zt * s + 2 * u)])
    w_s = np.array([[2 * s + 2 * zh * omega_h * u, 2 * x * s], [2 * x * s, r2 * (2 * s + 2 * zt * u)]])
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
    w, w_u, w_s = (d[np.ix_(a, a)] for d in _weights(solid, s, u))
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
        x = solid.static_unbalance  # m W's off-diagonal m x_θ s² = -m̂ x_θ
        p2 = npoly.polysub(r2 * npoly.polymul(s_h, s_t), np.array([x * x]))
        p1 = -npoly.polyadd(s_h * loads[1, 1], r2 * s_t * loads[0, 0])
        p1 = npoly.polysub(p1, np.array([x * (loads[0, 1] + loads[1, 0])]))
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
    return roots_from_loads(loads, rate, sample.frequency, linear_solid(solid, theta0), mass_range)


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


def track_rates(
    tracks: np.ndarray, loads: np.ndarray, rate: np.ndarray, omega: float, solid: Solid
) -> np.ndarray:
    """How each resultant track (:func:`resultant_tracks`) moves with the frequency: ``(k, 2)`` rows
    ``(dv/dω, dε/dω)``, ``ε = 1/m``: ``F = det(m W − A) = 0`` differentiated along the track
    (:func:`characteristic_function`), ``[F_m, F_u] d(m, u) = −i F_s dω`` (real and imaginary
    parts), then ``dε = −dm/m²`` and ``v = u/ω`` (docs/model.md §8). ``ε`` rather than ``m``: smooth
    through ``m = ∞``, where a track changes the sign of its ``m``. NaN where the track folds in ω
    (the system is singular there)."""
    rows = []
    for v, m in tracks:
        _, f_m, f_u, f_s = characteristic_function(loads, rate, solid, 1j * omega, m, v * omega)
        jac = np.array([[f_m.real, f_u.real], [f_m.imag, f_u.imag]])
        if abs(np.linalg.det(jac)) <= 1e-14 * np.abs(jac).max() ** 2:
            rows.append((math.nan, math.nan))
            continue
        d_m, d_u = np.linalg.solve(jac, np.array([(-1j * f_s).real, (-1j * f_s).imag]))
        rows.append(((d_u - v) / omega, -d_m / (m * m)))
    return np.array(rows).reshape(-1, 2)


def undamped_resonances(solid: Solid) -> list[float]:
    """The ``v = u/ω`` where the highest power of ``m̂`` in ``Σ P_k(v) m̂^k`` vanishes for every
    ``ω``: the in-vacuo resonance of an undamped dof (``S_h = 0`` at ``v = 1/Ω`` when ``ζ_h = 0``,
    ``S_θ = 0`` at ``v = 1`` when ``ζ_θ = 0``), where the neutral mass is infinite. Each is a
    root of the resultant at every frequency and carries no curve."""
    dofs = _dof_indices(solid)
    roots = []
    if dofs == [0, 1] and solid.static_unbalance:
        # the coupled in-vacuo resonances, where P₂ = r_θ² ŝ_h ŝ_θ − x_θ² vanishes: v = 1/w
        if solid.zeta_h or solid.zeta_theta:
            return []  # no real root: with damping ŝ_h ŝ_θ is never real and positive
        return sorted(1.0 / w for w in in_vacuo_rates(solid))
    if 0 in dofs and solid.zeta_h == 0:
        roots.append(1.0 / solid.freq_ratio)
    if 1 in dofs and solid.zeta_theta == 0:
        roots.append(1.0)
    return roots


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
    """Static neutral curves ``U*_D = √(m/λ)`` (docs/model.md §8): ``λ`` the positive eigenvalues of
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
        _, _, f_u, f_s = characteristic_function(loads, rate, linear_solid(solid, theta0), 0.0, m, u)
        rates.append((f_u * u / f_s).real)
    return np.array(lambdas), np.array(rates)
