"""Analytic typical section with Theodorsen's unsteady aerodynamics (docs/model.md §9).

A rigid flat plate on a heave spring and a pitch spring attached at the elastic axis, loaded by
Theodorsen's potential-flow lift and moment. Its flutter and divergence boundaries are the cheap
reference against which the viscous global-stability results are read (Theodorsen 1935; Hodges & Pierce;
Moulin & Marquet 2021).

Conventions (those of the project, docs/model.md §1–§3, never the textbooks'):

* length unit the chord ``c`` (semi-chord ``b = 1/2``), time unit ``c/U∞``; the plate spans
  ``X ∈ [-1/2, 1/2]`` with its leading edge at ``X = -1/2``;
* ``h`` heave of the elastic axis, positive up; ``θ`` pitch, counter-clockwise positive, so the
  angle of attack is ``α = -θ``; a point at ``X`` moves up by ``h + (X - a) θ``;
* ``elastic_axis`` ``a``: abscissa of the elastic axis, i.e. distance mid-chord → elastic axis, **in
  chords**, positive downstream (textbooks' ``a`` in semi-chords is ``2a`` here);
* ``static_unbalance`` ``x_θ``: distance elastic axis → centre of mass, in chords, positive
  downstream (textbooks' ``x_θ`` in semi-chords is ``2 x_θ`` here);
* ``m = m̃/(½ρc²)``, ``U* = U∞/(c ω_θ)``, ``Ω = ω_h/ω_θ``, ``ω_h = √(K_h/m̃)``,
  ``ω_θ = √(K_θ/I_EA)``, ``r_θ = √(I_EA/(m̃c²))`` the radius of gyration **about the elastic axis**
  (docs/model.md §2 defines it about G; the two coincide when ``x_θ = 0``, the plate of the paper);
* coefficients ``C_L = L/(½ρU∞²c)`` (up), ``C_M = M/(½ρU∞²c²)`` about the elastic axis,
  counter-clockwise positive; slopes ``dC_L/dθ`` and ``dC_M/dθ`` (thin airfoil ``-2π`` and ``π/2``
  about mid-chord), the moment slope about the elastic axis being ``dC_M/dθ - a (dC_L/dθ - C_D)``
  (thin airfoil, ``C_D = 0``: ``(π/2)(1 + 4a)``, docs/model.md §3.1, §9);
* eigenvalues ``σ = λ + iω`` of ``(h, θ) ∝ e^{σt}``, ``ω`` in units of ``U∞/c``; the reduced
  frequency on the semi-chord is ``k = ω/2``, and ``ω/ω_θ = ω U*``.

Solid equations with unbalance (docs/model.md §3 generalised). The centre of mass at ``X = a + x_θ``
moves up by ``h + x_θ θ``, so the kinetic energy is ``½m̃(ḣ + x_θ θ̇)² + ½I_G θ̇²`` and, divided by
``m̃`` and ``I_EA = m̃ r_θ² = I_G + m̃ x_θ²``::

    h'' + x_θ θ''          + 2ζ_h (Ω/U*) h' + (Ω/U*)² h = C_L / m
    (x_θ/r_θ²) h'' + θ''   + 2ζ_θ (1/U*) θ' + (1/U*)² θ = C_M / (m r_θ²)

Theodorsen's loads (docs/model.md §9 with ``C(k)``; ``dC_L/dθ``, ``dC_M/dθ`` about the elastic axis)::

    C_L = -(π/2)[θ' + h'' - a θ''] + C(k) dC_L/dθ [θ + h' + (1/4 - a) θ']
    C_M = (π/4)[2a h'' - (1/16 + 2a²) θ''] + (π/4)(2a - 1/2) θ'
          + C(k) dC_M/dθ [θ + h' + (1/4 - a) θ']

The non-circulatory ``h''`` term of ``C_M`` is ``(π/2) a h''`` (docs/model.md §9): the heave–pitch
added mass of a plate is ``(π/4)·a`` in units of ``ρc²``, times 2 for the coefficient, in both rows,
so that the added-mass matrix is symmetric. Converting Theodorsen's textbook loads (``h`` down, ``α`` nose-up,
``b``) with ``h → -h``, ``α → -θ``, ``b = 1/2``, ``a_b = 2a`` gives exactly the lines above (the test suite
checks the symmetry and the Hodges & Pierce case).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from fsistab.continuation import newton
from fsistab.errors import ConvergenceError, InputError
from fsistab.neutral_point import DeterminantProblem, NeutralPoint
from fsistab.neutral_point import divergence_velocity as divergence_velocity_formula
from fsistab.params import SOLID_DOFS, Solid, _finite, _interval, _positive

THIN_AIRFOIL_LIFT_SLOPE = -2 * math.pi  # dC_L/dθ (α = -θ: dC_L/dα = 2π)
THIN_AIRFOIL_MOMENT_SLOPE = math.pi / 2  # dC_M/dθ about mid-chord (d(-C_M)/dα = π/2)
_K_SMALL = 1e-100  # C(k) = 1 to double precision below this (correction ~ k log k)
_K_LARGE = 1e8  # C(k) = 1/2 - i/(8k) to double precision above this (correction ~ 1/k²)

CONVENTIONS = (
    "Theodorsen typical section (docs/model.md §9), project units: chord c = 1, time c/U, "
    "m = m_solid/(0.5 rho c^2), U* = U/(c omega_theta), Omega = omega_h/omega_theta, "
    "r_theta about the elastic axis, elastic_axis a and static_unbalance x_theta in chords "
    "(positive downstream, a from mid-chord, x_theta from the elastic axis to the centre of mass), "
    "h up, theta counter-clockwise, alpha = -theta, lift_slope = dC_L/dtheta, "
    "moment_slope = dC_M/dtheta about mid-chord, frequency omega in units of U/c, k = omega/2"
)


def theodorsen_function(k):
    """Theodorsen's function ``C(k) = H₁⁽²⁾(k) / (H₁⁽²⁾(k) + i H₀⁽²⁾(k))`` (docs/model.md §9,
    Theodorsen 1935, docs/validation.md).

    ``k`` is the reduced frequency on the semi-chord (``k = ω/2`` in chord units), a scalar or an
    array. Exact Hankel functions (SciPy) in between the limits ``C(0) = 1`` (returned exactly for
    ``k = 0`` and to double precision below 1e-100) and ``C(∞) = 1/2`` (with the ``-i/(8k)`` term
    above 1e8). Negative ``k`` uses ``C(-k) = conj C(k)`` (the load of ``e^{-i|ω|t}``).
    """
    from scipy.special import hankel2

    k_arr = np.asarray(k, dtype=float)
    if np.isnan(k_arr).any():
        raise InputError("the reduced frequency k must not be NaN")
    a = np.abs(k_arr)
    out = np.empty(a.shape, dtype=complex)
    small = a < _K_SMALL
    large = a > _K_LARGE
    mid = ~(small | large)
    out[small] = 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        out[large] = 0.5 - 0.125j / a[large]
    km = a[mid]
    h1, h0 = hankel2(1, km), hankel2(0, km)
    out[mid] = h1 / (h1 + 1j * h0)
    out = np.where(k_arr < 0, np.conj(out), out)
    return out[()] if out.ndim == 0 else out


@dataclass(frozen=True)
class AirfoilSlopes:
    """Static slopes used by the circulatory loads: ``lift`` = ``dC_L/dθ``, ``moment`` = ``dC_M/dθ``
    about **mid-chord** (the fields of :class:`fsistab.slopes.StaticSlopes`, per radian).

    ``source`` says where they come from (``thin-airfoil``, ``viscous Re=…``, ``given``).
    """

    lift: float = THIN_AIRFOIL_LIFT_SLOPE
    moment: float = THIN_AIRFOIL_MOMENT_SLOPE
    source: str = "thin-airfoil"
    drag: float = 0.0  # the steady C_D (none in thin-airfoil theory)
    normal: float | None = None  # d(2F_Y)/dθ of a viscous steady state, at its θ₀

    def __post_init__(self):
        object.__setattr__(self, "lift", _finite("lift slope dC_L/dθ", self.lift))
        object.__setattr__(self, "moment", _finite("moment slope dC_M/dθ", self.moment))
        object.__setattr__(self, "drag", _finite("steady drag coefficient", self.drag))
        if self.normal is not None:
            object.__setattr__(self, "normal", _finite("normal force slope d(2F_Y)/dθ", self.normal))

    @classmethod
    def thin_airfoil(cls) -> AirfoilSlopes:
        return cls()

    @classmethod
    def from_alpha(cls, lift_slope_alpha: float, moment_slope_alpha: float, source: str = "given"):
        """From the papers' ``dC_L/dα`` and ``d(-C_M)/dα`` about mid-chord (``α = -θ``)."""
        lift = _finite("lift slope dC_L/dα", lift_slope_alpha)
        moment = _finite("moment slope d(-C_M)/dα", moment_slope_alpha)
        return cls(lift=-lift, moment=moment, source=source)

    @classmethod
    def from_static(cls, slopes) -> AirfoilSlopes:
        """From a :class:`fsistab.slopes.StaticSlopes` (viscous slopes of docs/model.md §9)."""
        return cls(
            lift=slopes.lift,
            moment=slopes.moment,
            source=f"viscous Re={slopes.reynolds:g} alpha0={slopes.alpha0_deg:g}",
            drag=slopes.steady_drag,
            normal=slopes.normal,
        )

    def moment_about(self, elastic_axis: float) -> float:
        """``dC_M/dθ`` about the elastic axis ``X = a``: ``dC_M/dθ|_mid - a d(2F_Y)/dθ``, the moment of
        the body-axis normal force (docs/model.md §3.1). Its slope is the viscous steady state's own
        when known (exact at any ``θ₀``); otherwise, at ``θ₀ = 0``, the lift's less the steady drag
        turned with the body, ``dC_L/dθ - C_D`` (thin airfoil: ``C_D = 0``)."""
        normal = self.lift - self.drag if self.normal is None else self.normal
        return self.moment - elastic_axis * normal

    @property
    def lift_slope_alpha(self) -> float:
        return -self.lift

    @property
    def moment_slope_alpha(self) -> float:
        return self.moment


@dataclass(frozen=True)
class TypicalSection:
    """Spring-mounted flat plate with Theodorsen aerodynamics (immutable, validated).

    ``solid`` carries ``m``, ``U*``, ``Ω``, ``ζ_h``, ``ζ_θ`` and ``r_θ`` (here about the elastic
    axis; ``U*`` is the default of single-velocity functions, sweeps override it) and must have
    both heave and pitch. ``elastic_axis`` ``a`` (chords, mid-chord → elastic axis, downstream +,
    within the chord ``|a| ≤ 1/2``) and ``static_unbalance`` ``x_θ`` (chords, elastic axis → centre
    of mass, downstream +, with ``x_θ² < r_θ²`` so that ``I_G > 0``) follow the module conventions.
    """

    solid: Solid = field(default_factory=Solid)
    elastic_axis: float = 0.0
    static_unbalance: float = 0.0
    slopes: AirfoilSlopes = field(default_factory=AirfoilSlopes)

    def __post_init__(self):
        if not isinstance(self.solid, Solid):
            raise InputError(f"solid must be a fsistab.params.Solid, got {type(self.solid).__name__}")
        if self.solid.dofs != SOLID_DOFS:
            raise InputError(f"the typical section needs heave and pitch, got dofs {self.solid.dofs}")
        if not isinstance(self.slopes, AirfoilSlopes):
            raise InputError("slopes must be an AirfoilSlopes (use AirfoilSlopes.from_static)")
        a = _finite("elastic axis position", self.elastic_axis)
        if abs(a) > 0.5:
            raise InputError(f"elastic axis must lie on the chord, |a| <= 1/2 chord, got {a}")
        x = _finite("static unbalance", self.static_unbalance)
        if x * x >= self.solid.r_theta**2:
            raise InputError(
                f"static unbalance |x_θ| = {abs(x):g} must be smaller than the radius of gyration about "
                f"the elastic axis r_θ = {self.solid.r_theta:g} (I_G = m(r_θ² - x_θ²) > 0)"
            )
        object.__setattr__(self, "elastic_axis", a)
        object.__setattr__(self, "static_unbalance", x)

    @classmethod
    def create(
        cls,
        mass_ratio: float = 1000.0,
        reduced_velocity: float = 4.7,
        freq_ratio: float = 0.8,
        zeta_h: float = 0.0,
        zeta_theta: float = 0.05,
        r_theta: float = 0.289,
        elastic_axis: float = 0.0,
        static_unbalance: float = 0.0,
        slopes: AirfoilSlopes | None = None,
    ) -> TypicalSection:
        """Section from scalar parameters (defaults: the plate of docs/model.md §2, thin airfoil)."""
        solid = Solid(
            mass_ratio=mass_ratio,
            reduced_velocity=reduced_velocity,
            freq_ratio=freq_ratio,
            zeta_h=zeta_h,
            zeta_theta=zeta_theta,
            r_theta=r_theta,
        )
        return cls(solid, elastic_axis, static_unbalance, slopes or AirfoilSlopes())

    def with_mass_ratio(self, mass_ratio: float) -> TypicalSection:
        return replace(self, solid=replace(self.solid, mass_ratio=mass_ratio))

    def with_reduced_velocity(self, reduced_velocity: float) -> TypicalSection:
        return replace(self, solid=replace(self.solid, reduced_velocity=reduced_velocity))

    @property
    def mass_ratio(self) -> float:
        return self.solid.mass_ratio

    @property
    def moment_slope_elastic_axis(self) -> float:
        """``dC_M/dθ`` about the elastic axis (thin airfoil ``(π/2)(1 + 4a)``, docs/model.md §9)."""
        return self.slopes.moment_about(self.elastic_axis)

    @property
    def r_theta_centre_of_mass(self) -> float:
        """Radius of gyration about the centre of mass, ``√(r_θ² - x_θ²)`` (docs/model.md §2's r_θ)."""
        return math.sqrt(self.solid.r_theta**2 - self.static_unbalance**2)

    def attrs(self) -> dict:
        """Parameters and conventions as flat NetCDF attributes."""
        s = self.solid
        return {
            "model": "theodorsen",
            "conventions": CONVENTIONS,
            "freq_ratio": s.freq_ratio,
            "zeta_h": s.zeta_h,
            "zeta_theta": s.zeta_theta,
            "r_theta": s.r_theta,
            "elastic_axis": self.elastic_axis,
            "static_unbalance": self.static_unbalance,
            "lift_slope": self.slopes.lift,
            "moment_slope": self.slopes.moment,
            "moment_slope_elastic_axis": self.moment_slope_elastic_axis,
            "slopes_source": self.slopes.source,
        }


def _positive_velocity(value) -> float:
    return _positive("reduced velocity", value)


def _velocity_range(velocity_range) -> tuple[float, float]:
    return _interval("reduced-velocity range", velocity_range, math.inf)


def load_matrices(section: TypicalSection, theodorsen_value):
    """Theodorsen's loads ``(C_L, C_M)ᵀ = (s² L₂ + s L₁ + L₀)(ĥ, θ̂)ᵀ`` for ``(h, θ) ∝ e^{st}`` with
    ``C(k)`` frozen at ``theodorsen_value`` (docs/model.md §9, with the symmetric ``(π/2) a h''`` term of
    the module docstring; ``C_M`` about the elastic axis). Leading axes of ``theodorsen_value``
    broadcast."""
    a = section.elastic_axis
    lift, moment = section.slopes.lift, section.moment_slope_elastic_axis
    c = np.asarray(theodorsen_value, dtype=complex)
    shape = (*c.shape, 2, 2)
    l2, l1, l0 = (np.zeros(shape, dtype=complex) for _ in range(3))
    # non-circulatory: added mass (symmetric) and the pitch-rate terms
    l2[..., 0, 0] = -math.pi / 2
    l2[..., 0, 1] = l2[..., 1, 0] = (math.pi / 2) * a
    l2[..., 1, 1] = -(math.pi / 4) * (1 / 16 + 2 * a * a)
    l1[..., 0, 1] = -math.pi / 2
    l1[..., 1, 1] = (math.pi / 4) * (2 * a - 0.5)
    # circulatory: C(k) × slope × the three-quarter-chord angle θ + h' + (1/4 - a) θ'
    for row, slope in ((0, lift), (1, moment)):
        l0[..., row, 1] += c * slope
        l1[..., row, 0] += c * slope
        l1[..., row, 1] += c * slope * (0.25 - a)
    return l2, l1, l0


def structural_matrices(section: TypicalSection, reduced_velocity: float):
    """Solid inertia, damping and stiffness ``(S₂, S₁, S₀)`` of the module docstring's equations,
    heave row × ``m``, pitch row × ``m r_θ²`` (docs/model.md §3 with the unbalance ``x_θ``)."""
    s = section.solid
    m, x = s.mass_ratio, section.static_unbalance
    w = 1.0 / reduced_velocity
    mr2 = m * s.r_theta**2
    s2 = np.array([[m, m * x], [m * x, mr2]], dtype=complex)
    s1 = np.diag([2 * m * s.zeta_h * s.freq_ratio * w, 2 * mr2 * s.zeta_theta * w]).astype(complex)
    s0 = np.diag([m * (s.freq_ratio * w) ** 2, mr2 * w * w]).astype(complex)
    return s2, s1, s0


def quadratic_matrices(section: TypicalSection, theodorsen_value, reduced_velocity: float):
    """``(M₂, M₁, M₀)`` with ``D(s) = s² M₂ + s M₁ + M₀`` = solid − loads at fixed
    ``C = theodorsen_value``; columns ``(h, θ)``, rows heave × ``m`` and pitch × ``m r_θ²``."""
    loads = load_matrices(section, theodorsen_value)
    return tuple(
        sm - lm for sm, lm in zip(structural_matrices(section, reduced_velocity), loads, strict=True)
    )


def flutter_matrix(section: TypicalSection, frequency, reduced_velocity: float | None = None):
    """``D(iω; m, U*)`` of ``D (ĥ, θ̂)ᵀ = 0`` for ``(h, θ) ∝ e^{iωt}``, ``C = C(ω/2)`` (docs/model.md §9)."""
    u = _positive_velocity(section.solid.reduced_velocity if reduced_velocity is None else reduced_velocity)
    omega = np.asarray(frequency, dtype=float)
    m2, m1, m0 = quadratic_matrices(section, theodorsen_function(omega / 2), u)
    s = (1j * omega)[..., None, None]
    return s * s * m2 + s * m1 + m0


def flutter_determinant(section: TypicalSection, frequency, reduced_velocity: float | None = None):
    """``det D(iω; m, U*)``: zero for real ``ω > 0`` on a flutter boundary (docs/model.md §9)."""
    return np.linalg.det(flutter_matrix(section, frequency, reduced_velocity))


def divergence_velocity(section: TypicalSection) -> float:
    """Torsional divergence ``U*_D = √(m r_θ² / (dC_M/dθ))`` with the slope about the elastic axis
    (docs/model.md §8, §9, :func:`fsistab.neutral_point.divergence_velocity`); ``nan`` when the slope is
    not positive (no divergence)."""
    velocity = divergence_velocity_formula(
        section.moment_slope_elastic_axis, section.solid.r_theta, section.mass_ratio
    )
    return velocity if math.isfinite(velocity) else math.nan


def divergence_determinant(section: TypicalSection, reduced_velocity) -> np.ndarray:
    """``det D(0; m, U*)`` (real; ``C(0) = 1``), scaled by ``U*⁴`` to stay of order ``m²``."""
    u = np.asarray(reduced_velocity, dtype=float)
    return np.array([flutter_determinant(section, 0.0, float(v)).real * v**4 for v in np.ravel(u)]).reshape(
        u.shape
    )


def divergence_velocity_from_determinant(
    section: TypicalSection, velocity_range=(1e-2, 1e3), points: int = 400
) -> float:
    """Root of ``det D(0; U*)`` in ``velocity_range`` (sign change, then Brent); ``nan`` if none."""
    from scipy.optimize import brentq

    lo, hi = _velocity_range(velocity_range)
    grid = np.geomspace(lo, hi, points)
    values = divergence_determinant(section, grid)
    change = np.nonzero(np.sign(values[1:]) != np.sign(values[:-1]))[0]
    if len(change) == 0:
        return math.nan
    i = change[0]
    return float(
        brentq(
            lambda v: float(divergence_determinant(section, v)), grid[i], grid[i + 1], xtol=1e-14, rtol=1e-14
        )
    )


def _quartic_in_w(section: TypicalSection, omega: np.ndarray) -> np.ndarray:
    """Coefficients (highest first, shape (N, 5)) of ``det D(iω)`` as a polynomial in ``w = 1/U*``.

    The loads depend on ω only (time unit c/U∞) and the springs' damping and stiffness scale as
    ``w`` and ``w²``: ``D = A(ω) + w B(ω) + w² E`` with ``B = iω S₁(U*=1)`` and ``E = S₀(U*=1)``
    diagonal, ``A = -ω² S₂ - L(iω)``.
    """
    s2, s1, s0 = structural_matrices(section, 1.0)
    l2, l1, l0 = load_matrices(section, theodorsen_function(omega / 2))
    iw = (1j * omega)[:, None, None]
    a = iw * iw * (s2 - l2) - iw * l1 - l0
    h1, t1 = 1j * omega * s1[0, 0], 1j * omega * s1[1, 1]
    h2, t2 = s0[0, 0], s0[1, 1]
    h0, t0 = a[:, 0, 0], a[:, 1, 1]
    cross = a[:, 0, 1] * a[:, 1, 0]
    ones = np.ones_like(h0)
    return np.stack(
        [h2 * t2 * ones, h2 * t1 + h1 * t2, h2 * t0 + h1 * t1 + h0 * t2, h1 * t0 + h0 * t1, h0 * t0 - cross],
        axis=1,
    )


def _w_roots(section: TypicalSection, omega: np.ndarray) -> np.ndarray:
    """The four roots ``w = 1/U*`` of ``det D(iω) = 0`` at each ``ω`` (companion matrices)."""
    coeffs = _quartic_in_w(section, np.atleast_1d(np.asarray(omega, dtype=float)))
    monic = coeffs[:, 1:] / coeffs[:, :1]
    n = len(coeffs)
    companion = np.zeros((n, 4, 4), dtype=complex)
    companion[:, 0, :] = -monic
    companion[:, 1, 0] = companion[:, 2, 1] = companion[:, 3, 2] = 1.0
    return np.linalg.eigvals(companion)


def _indicator(roots: np.ndarray, band: tuple[float, float]) -> np.ndarray:
    """``∏ Im w_j / |w_j|`` over the roots with ``Re w_j`` in ``band``: it changes sign when one of
    them crosses the real axis. Over all four roots it would miss the undamped case (roots in pairs
    ``±w`` crossing together) and pick up rounding noise of the tiny roots ``w → 0`` at small ω; a
    root entering or leaving the band also flips it, and those spurious brackets are rejected by
    the polishing residual."""
    ratio = roots.imag / np.maximum(np.abs(roots), 1e-300)
    inside = (roots.real > band[0]) & (roots.real < band[1])
    return np.prod(np.where(inside, ratio, 1.0), axis=-1)


def _polish(section: TypicalSection, omega: float, w: float, tol: float = 1e-13, maxit: int = 30):
    """The neutral point at the section's m by the one Newton (:func:`fsistab.continuation.newton`)
    on ``Re det = Im det = 0`` in the real unknowns ``(ω, w = 1/U*)``
    (:class:`fsistab.neutral_point.DeterminantProblem`, ``y = (ω, w, log m)``, m held), the
    determinant scaled by its size ``m² r_θ² max(ω, w)⁴`` (central differences for the Jacobian).
    Returns ``(ω, w, scaled residual)``, the residual of the last admissible iterate."""
    log_mass = math.log(section.mass_ratio)

    def scaled(y: np.ndarray) -> complex:
        om, ww = float(y[0]), float(y[1])
        if not (om > 0 and ww > 0):
            raise ConvergenceError("the Theodorsen neutral-point Newton left ω > 0, U* > 0")
        at = section if y[2] == log_mass else section.with_mass_ratio(math.exp(float(y[2])))
        d = complex(flutter_determinant(at, om, 1.0 / ww))
        return d / (at.mass_ratio**2 * at.solid.r_theta**2 * max(om, ww) ** 4)

    def characteristic(y: np.ndarray, gradient: bool):
        value = scaled(y)
        if not gradient:
            return value
        steps = np.array([1e-7 * y[0], 1e-7 * y[1], 1e-7])
        columns = []
        for i, h in enumerate(steps):
            e = np.zeros(3)
            e[i] = h
            columns.append((scaled(y + e) - scaled(y - e)) / (2 * h))
        return value, np.array(columns)

    result = newton(
        DeterminantProblem(characteristic).at(2, log_mass),
        np.array([omega, w, log_mass]),
        tol=tol,
        max_iterations=maxit,
    )
    residual = result.residuals[-1] if result.residuals else math.inf  # (inf: the start was not admissible)
    return float(result.point[0]), float(result.point[1]), residual


def flutter_points(
    section: TypicalSection,
    velocity_range=(1e-2, 1e2),
    points_per_decade: int = 400,
) -> list[NeutralPoint]:
    """Every flutter boundary (real ``ω > 0``, ``U*`` in ``velocity_range``) at ``section``'s m.

    ``det D(iω; U*)`` (docs/model.md §9) is, for each ``ω``, a quartic in ``w = 1/U*`` (the loads depend
    on ω only); its four roots are computed on a log grid of ``ω`` (``points_per_decade``) covering
    the solid frequencies of the U* range, and a boundary is a real root ``w`` in the range. Sign
    changes of ``∏ Im w_j`` over the roots near the range locate them (no root matching); cells
    where a root comes close to the real axis without a sign change are resampled finely (two
    crossings in one cell); Brent refines ``ω`` and Newton on ``(Re det, Im det)`` polishes
    ``(ω, U*)``. Each boundary is labelled onset or restabilisation by the p–k growth rate just
    above and below it. Returns the boundaries sorted by U* (possibly none, possibly several).
    """
    from scipy.optimize import brentq

    lo, hi = _velocity_range(velocity_range)
    if not 4 <= points_per_decade <= 100_000:
        raise InputError(f"points per decade must be between 4 and 100000, got {points_per_decade}")
    s = section.solid
    band = (0.5 / hi, 2.0 / lo)
    f_lo, f_hi = min(s.freq_ratio, 1.0), max(s.freq_ratio, 1.0)
    omega_lo, omega_hi = 1e-3 * f_lo / hi, 20.0 * f_hi / lo
    n = max(16, int(points_per_decade * math.log10(omega_hi / omega_lo)))
    grid = np.geomspace(omega_lo, omega_hi, n)
    roots = _w_roots(section, grid)
    indicator = _indicator(roots, band)

    def indicator_at(omega):
        return _indicator(_w_roots(section, omega), band)

    change = np.nonzero(np.sign(indicator[1:]) != np.sign(indicator[:-1]))[0]
    brackets = [(grid[i], grid[i + 1]) for i in change]
    # two crossings in one cell: a root near the real axis at a local minimum, no sign change
    ratio = np.abs(roots.imag) / np.maximum(np.abs(roots), 1e-300)
    inside = (roots.real > band[0]) & (roots.real < band[1])
    closeness = np.min(np.where(inside, ratio, np.inf), axis=1)
    for i in range(1, n - 1):
        near = closeness[i] < 1e-2 and closeness[i] <= min(closeness[i - 1], closeness[i + 1])
        if near and np.sign(indicator[i - 1]) == np.sign(indicator[i]) == np.sign(indicator[i + 1]):
            fine = np.geomspace(grid[i - 1], grid[i + 1], 201)
            values = indicator_at(fine)
            brackets += [
                (fine[j], fine[j + 1]) for j in np.nonzero(np.sign(values[1:]) != np.sign(values[:-1]))[0]
            ]
    found: list[NeutralPoint] = []
    for a, b in brackets:
        omega = brentq(lambda om: float(indicator_at(om)[0]), a, b, xtol=1e-15, rtol=1e-14)
        w_all = _w_roots(section, omega)[0]
        w_all = w_all[(w_all.real > band[0]) & (w_all.real < band[1])]
        if len(w_all) == 0:
            continue
        w = w_all[np.argmin(np.abs(w_all.imag) / np.abs(w_all))]
        if abs(w.imag) > 1e-6 * abs(w):
            continue  # a root entering or leaving the band, not crossing the real axis
        omega, w_real, residual = _polish(section, omega, w.real)
        if not (residual < 1e-10 and w_real > 0 and omega > 0):
            continue
        velocity = 1.0 / w_real
        if not lo <= velocity <= hi:
            continue
        if any(
            abs(p.reduced_velocity - velocity) < 1e-8 * velocity and abs(p.frequency - omega) < 1e-8 * omega
            for p in found
        ):
            continue
        boundary = _boundary(section, velocity, omega)
        found.append(
            NeutralPoint(
                s.mass_ratio,
                float(velocity),
                float(omega),
                kind="flutter",
                boundary=boundary,
                residuals=(residual,),
            )
        )
    return sorted(found, key=lambda p: p.reduced_velocity)


def _boundary(section: TypicalSection, velocity: float, omega: float, delta: float = 1e-4) -> str:
    """``onset`` if the p–k root through ``iω`` grows just above ``U*``, else ``restabilisation``."""
    above = pk_root(section, velocity * (1 + delta), 1j * omega / (1 + delta))
    below = pk_root(section, velocity * (1 - delta), 1j * omega / (1 - delta))
    if above.real > 0 >= below.real:
        return "onset"
    if below.real > 0 >= above.real:
        return "restabilisation"
    return "onset" if above.real > below.real else "restabilisation"


def divergence_point(section: TypicalSection, velocity_range=(1e-2, 1e2)) -> NeutralPoint | None:
    """Torsional divergence as a neutral point (ω = 0) if its U* is in ``velocity_range``."""
    lo, hi = _velocity_range(velocity_range)
    velocity = divergence_velocity(section)
    if not (math.isfinite(velocity) and lo <= velocity <= hi):
        return None
    return NeutralPoint(
        section.mass_ratio, velocity, 0.0, kind="divergence", boundary="onset", branch="static"
    )


def critical_points(section: TypicalSection, velocity_range=(1e-2, 1e2)) -> list[NeutralPoint]:
    """Every flutter boundary and the divergence in ``velocity_range``, sorted by U*."""
    found = flutter_points(section, velocity_range)
    divergence = divergence_point(section, velocity_range)
    if divergence is not None:
        found.append(divergence)
    return sorted(found, key=lambda p: p.reduced_velocity)


def _quadratic_roots(m2, m1, m0) -> np.ndarray:
    """The four roots ``s`` of ``det(s² M₂ + s M₁ + M₀) = 0`` (first companion linearisation)."""
    inv = np.linalg.inv(m2)
    top = np.hstack([np.zeros((2, 2)), np.eye(2)])
    bottom = np.hstack([-inv @ m0, -inv @ m1])
    return np.linalg.eigvals(np.vstack([top, bottom]))


def _pk_root_near(section: TypicalSection, reduced_velocity: float, k: float, near: complex) -> complex:
    """The root of the quadratic problem with ``C(k)`` frozen (:func:`quadratic_matrices`) nearest
    ``near``."""
    roots = _quadratic_roots(*quadratic_matrices(section, theodorsen_function(k), reduced_velocity))
    return complex(roots[np.argmin(np.abs(roots - near))])


def pk_root(
    section: TypicalSection, reduced_velocity: float, guess: complex, tol: float = 1e-12, maxit: int = 60
) -> complex:
    """p–k method: the eigenvalue ``σ = λ + iω`` near ``guess`` of the quadratic problem
    ``det(σ² M₂ + σ M₁ + M₀) = 0`` with ``C(k)`` frozen at the reduced frequency ``k = ω/2`` of the
    root itself (:func:`quadratic_matrices`, docs/model.md §9).

    The fixed point ``k = Im σ(k)/2`` is found by a few plain iterations (the classical p–k loop),
    then by secant steps on ``Im σ(k)/2 - k``: the plain loop creeps when ``ω → 0`` (``C(k)`` has an
    infinite slope at ``k = 0``). A real root at ``k = 0`` (``C = 1``, the static problem) is a
    fixed point: after divergence the pitch branch is real. A root is exact (consistent with ``C``
    for ``e^{σt}``) only where ``λ = 0``, where it solves ``det D(iω) = 0``.
    """
    u = _positive_velocity(reduced_velocity)

    def mismatch(k: float, sigma: complex) -> float:  # φ(k) = k(σ(k)) - k
        return max(sigma.imag, 0.0) / 2 - k

    def done(k: float, sigma: complex) -> bool:
        return abs(mismatch(k, sigma)) <= tol * max(abs(sigma), 1e-300)

    near = complex(guess)
    k = max(near.imag, 0.0) / 2
    sigma = near = _pk_root_near(section, u, k, near)
    previous = None
    for iteration in range(maxit):
        if done(k, sigma):
            return sigma
        if iteration < 5 or previous is None:  # classical p-k loop
            previous = (k, mismatch(k, sigma))
            k = max(sigma.imag, 0.0) / 2
        else:  # secant on φ
            (k0, f0), f1 = previous, mismatch(k, sigma)
            previous = (k, f1)
            k = k - f1 * (k - k0) / (f1 - f0) if f1 != f0 else k + f1
            if k < 0:
                at_zero = near = _pk_root_near(section, u, 0.0, near)
                if done(0.0, at_zero):
                    return at_zero  # a real root of the static problem (C(0) = 1)
                k = previous[0] / 2
        sigma = near = _pk_root_near(section, u, k, near)
    raise ConvergenceError(
        f"p-k iteration did not converge at U* = {u:.6g} near sigma = {complex(guess):.4g}"
    )


def small_velocity_limit(section: TypicalSection) -> dict[str, complex]:
    """``lim_{U*→0} U* σ`` of the heave and pitch branches: springs, structural damping and the
    non-circulatory added mass (with ``s = Ŝ/U*`` every other load is of lower order in ``U*``). In
    vacuo (``m → ∞``) these are ``iΩ`` and ``-ζ_θ + i√(1 - ζ_θ²)``; the added mass lowers them by
    ``O(1/m)``."""
    s = section.solid
    s2, s1, s0 = structural_matrices(section, 1.0)
    l2 = load_matrices(section, 0.5)[0]
    roots = _quadratic_roots(s2 - l2, s1, s0)
    roots = roots[roots.imag >= 0]
    heave = roots[np.argmin(np.abs(roots - 1j * s.freq_ratio))]
    rest = roots[roots != heave] if len(roots) > 1 else roots
    pitch = rest[np.argmin(np.abs(rest - (-s.zeta_theta + 1j * math.sqrt(max(1 - s.zeta_theta**2, 0)))))]
    return {"heave": complex(heave), "pitch": complex(pitch)}


def pk_branches(section: TypicalSection, velocities):
    """Eigenvalue branches ``σ = λ + iω`` (heave-like and pitch-like) against U* by the p–k method.

    ``velocities`` increasing; each branch starts from its ``U* → 0`` limit
    (:func:`small_velocity_limit`) scaled by ``1/U*`` and follows the nearest root, predicted by
    ``σ ∝ 1/U*``. Returns an xarray Dataset with dims ``reduced_velocity`` and ``branch`` and
    variables ``growth_rate``, ``frequency`` (``ω``, units U∞/c) — the layout of
    :func:`fsistab.plots.plot_branches`.
    """
    import xarray as xr

    velocities = np.asarray(velocities, dtype=float)
    if velocities.ndim != 1 or len(velocities) < 1 or not np.all(np.isfinite(velocities)):
        raise InputError("the reduced velocities must be a 1-D array of finite numbers")
    if velocities[0] <= 0 or np.any(np.diff(velocities) <= 0):
        raise InputError("the reduced velocities must be positive and increasing")
    limits = small_velocity_limit(section)
    names = list(limits)
    values = np.empty((len(velocities), len(names)), dtype=complex)
    for j, name in enumerate(names):
        previous_u, previous = None, None
        for i, u in enumerate(velocities):
            guess = limits[name] / u if previous is None else previous * previous_u / u
            values[i, j] = previous = pk_root(section, float(u), guess)
            previous_u = u
    return xr.Dataset(
        {
            "growth_rate": (("reduced_velocity", "branch"), values.real),
            "frequency": (("reduced_velocity", "branch"), values.imag),
        },
        coords={"reduced_velocity": velocities, "branch": names},
        attrs={**section.attrs(), "mass_ratio": section.mass_ratio, "method": "p-k"},
    )


def neutral_curves(
    section: TypicalSection, mass_ratios, velocity_range=(1e-2, 1e2), points_per_decade: int = 400
):
    """Flutter and divergence neutral curves ``U*(m)`` over ``mass_ratios`` (docs/model.md §8, §9).

    Returns an xarray Dataset on the coordinate ``mass_ratio``: ``reduced_velocity`` and
    ``frequency`` of the flutter boundaries (dim ``boundary``, sorted by U* at each m, NaN-padded;
    ``onset`` = 1 where the boundary is an onset, 0 a restabilisation), ``divergence_velocity``
    (closed form) and, as in :func:`fsistab.neutral.curve_table`, names ``mass_ratio``,
    ``reduced_velocity``, ``frequency``; attributes state the conventions and parameters.
    """
    import xarray as xr

    masses = np.asarray(mass_ratios, dtype=float)
    if masses.ndim != 1 or len(masses) < 1 or not np.all(np.isfinite(masses)) or np.any(masses <= 0):
        raise InputError("mass ratios must be a 1-D array of positive finite numbers")
    lo, hi = _velocity_range(velocity_range)
    per_mass = [
        flutter_points(section.with_mass_ratio(float(m)), (lo, hi), points_per_decade) for m in masses
    ]
    n_boundaries = max([len(p) for p in per_mass] + [1])
    velocity = np.full((len(masses), n_boundaries), np.nan)
    frequency = np.full_like(velocity, np.nan)
    onset = np.full(velocity.shape, -1, dtype=np.int8)
    for i, found in enumerate(per_mass):
        for j, p in enumerate(found):
            velocity[i, j], frequency[i, j] = p.reduced_velocity, p.frequency
            onset[i, j] = 1 if p.boundary == "onset" else 0
    divergence = np.array([divergence_velocity(section.with_mass_ratio(float(m))) for m in masses])
    return xr.Dataset(
        {
            "reduced_velocity": (("mass_ratio", "boundary"), velocity),
            "frequency": (("mass_ratio", "boundary"), frequency),
            "onset": (("mass_ratio", "boundary"), onset),
            "divergence_velocity": ("mass_ratio", divergence),
        },
        coords={"mass_ratio": masses, "boundary": np.arange(n_boundaries)},
        attrs={
            **section.attrs(),
            "velocity_range": [lo, hi],
            "onset_flag": "1 onset (unstable just above U*), 0 restabilisation, -1 no boundary",
        },
    )


def lowest_flutter_velocity(section: TypicalSection, velocity_range=(1e-2, 1e2)) -> float:
    """Lowest flutter onset U* at ``section``'s m (``nan`` if none in the range)."""
    onsets = [p.reduced_velocity for p in flutter_points(section, velocity_range) if p.boundary == "onset"]
    return min(onsets) if onsets else math.nan


def lower_envelope(curves) -> list[tuple[float, float]]:
    """Points ``(m, U*)`` of polylines ``curves = [(masses, velocities), ...]`` that lie on the lowest
    U* among all curves at their m (a folded curve's upper part is left out)."""
    pieces = []
    for masses, velocities in curves:
        m, u = np.log(np.asarray(masses, dtype=float)), np.asarray(velocities, dtype=float)
        for i in range(len(m) - 1):
            pieces.append((m[i], m[i + 1], u[i], u[i + 1]))
    kept = []
    for masses, velocities in curves:
        for m, u in zip(masses, velocities, strict=True):
            lm = math.log(m)
            lower = False
            for m0, m1, u0, u1 in pieces:
                if min(m0, m1) <= lm <= max(m0, m1) and m0 != m1:
                    if u0 + (u1 - u0) * (lm - m0) / (m1 - m0) < u * (1 - 1e-9):
                        lower = True
                        break
            if not lower:
                kept.append((float(m), float(u)))
    return sorted(set(kept))


def viscous_curves(ds):
    """The viscous curves that :func:`fsistab.workflows.theodorsen_comparison` stores beside the
    Theodorsen curves, as ``{"flutter": [(m, U*), ...], "divergence": (m, U*)}`` (None without them)."""
    count = int(ds.attrs.get("viscous_flutter_curves", 0))
    if "viscous_divergence_mass_ratio" not in ds:
        return None
    flutter = [
        (ds[f"viscous_flutter{i}_mass_ratio"].values, ds[f"viscous_flutter{i}_reduced_velocity"].values)
        for i in range(count)
    ]
    divergence = (ds.viscous_divergence_mass_ratio.values, ds.viscous_divergence_reduced_velocity.values)
    return {"flutter": flutter, "divergence": divergence}
