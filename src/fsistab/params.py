"""Immutable, validated parameters and the conventions they carry.

Non-dimensionalisation (MODEL.md §1, §2, §10):

* plate: length unit the chord ``c``, time unit ``c/U∞``; the plate spans ``X ∈ [-1/2, 1/2]``
  with its leading edge at ``X = -1/2`` (the fluid comes from the left in the body frame);
* cylinder: length unit the diameter ``D``, time unit ``D/U∞``.

Force coefficients are ``F / (½ ρ U∞² L s)`` with ``L`` the body's length unit. Heave ``h`` is
positive upwards (``+e_y``), pitch ``θ`` counter-clockwise positive, so the angle of attack is
``α = -θ`` (positive nose-up); the steady pitch is ``θ0 = -α0``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Literal

from fsistab.errors import InputError

CONVENTIONS = {
    "plate": "chord-based: length c, time c/U, coefficients F/(0.5 rho U^2 c s); "
    "h up, theta counter-clockwise, alpha = -theta (MODEL.md §1-§4)",
    "cylinder": "diameter-based: length D, time D/U, coefficients F/(0.5 rho U^2 D s) (MODEL.md §10)",
}


def _finite(name: str, value: float) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(value):
        raise InputError(f"{name} must be finite, got {value}")
    return value


def _positive(name: str, value: float) -> float:
    value = _finite(name, value)
    if value <= 0:
        raise InputError(f"{name} must be positive, got {value}")
    return value


def _non_negative(name: str, value: float) -> float:
    value = _finite(name, value)
    if value < 0:
        raise InputError(f"{name} must be non-negative, got {value}")
    return value


@dataclass(frozen=True)
class Plate:
    """Thin rectangular plate with rounded corners (MODEL.md §1), chord = 1.

    ``aspect_ratio`` is chord/thickness (default 20); ``corner_radius`` is relative to the
    thickness (default 1/10, i.e. radius e/10).
    """

    aspect_ratio: float = 20.0
    corner_radius: float = 0.1
    kind: Literal["plate"] = "plate"

    def __post_init__(self):
        ar = _finite("chord/thickness ratio", self.aspect_ratio)
        if ar <= 1:
            raise InputError(f"chord/thickness ratio must be > 1, got {ar}")
        rc = _finite("corner radius (relative to the thickness)", self.corner_radius)
        if not 0 <= rc < 0.5:
            raise InputError(f"corner radius must be in [0, 0.5) times the thickness, got {rc}")
        object.__setattr__(self, "aspect_ratio", ar)
        object.__setattr__(self, "corner_radius", rc)

    @property
    def thickness(self) -> float:
        return 1.0 / self.aspect_ratio

    @property
    def rear(self) -> float:
        """Abscissa of the rear (trailing edge) in the body frame."""
        return 0.5

    @property
    def radius_of_gyration(self) -> float:
        """``r_θ = sqrt((1 + (e/c)²)/12)`` of a homogeneous rectangle about its centre."""
        return math.sqrt((1 + self.thickness**2) / 12)


@dataclass(frozen=True)
class Cylinder:
    """Circular cylinder of diameter 1 (MODEL.md §10)."""

    kind: Literal["cylinder"] = "cylinder"

    @property
    def rear(self) -> float:
        return 0.5


Body = Plate | Cylinder


def make_body(kind: str, **kwargs) -> Body:
    """Body from its name (``plate`` or ``cylinder``) and shape parameters."""
    if kind == "plate":
        return Plate(**kwargs)
    if kind == "cylinder":
        if kwargs:
            raise InputError(f"the cylinder takes no shape parameters, got {sorted(kwargs)}")
        return Cylinder()
    raise InputError(f"unknown body {kind!r}: choose 'plate' or 'cylinder'")


@dataclass(frozen=True)
class Flow:
    """Flow parameters that the steady state depends on: ``Re`` and ``α0`` (MODEL.md §6).

    ``reynolds = ρ U∞ L / μ`` with ``L`` the body's length unit; ``alpha0_deg`` is the steady
    angle of attack in degrees, positive nose-up (``θ0 = -α0``).
    """

    reynolds: float
    alpha0_deg: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "reynolds", _positive("Reynolds number", self.reynolds))
        a = _finite("alpha0", self.alpha0_deg)
        if abs(a) > 45:
            raise InputError(f"alpha0 must be within ±45 degrees, got {a}")
        object.__setattr__(self, "alpha0_deg", a)

    @property
    def theta0(self) -> float:
        """Steady pitch angle in radians, ``θ0 = -α0``."""
        return -math.radians(self.alpha0_deg)


@dataclass(frozen=True)
class Domain:
    """Rectangular fluid domain ``[-upstream, downstream] × [-lateral, lateral]`` (body lengths).

    ``U = 0`` is imposed upstream and laterally, a stress-free condition downstream (MODEL.md §4).
    """

    upstream: float
    downstream: float
    lateral: float

    def __post_init__(self):
        for name in ("upstream", "downstream", "lateral"):
            value = _positive(f"domain {name} extent", getattr(self, name))
            if value < 2:
                raise InputError(f"domain {name} extent must be at least 2 body lengths, got {value}")
            object.__setattr__(self, name, value)


DEFAULT_DOMAINS = {
    "plate": Domain(upstream=20.0, downstream=40.0, lateral=20.0),
    # blockage: [-25, 50] x [-25, 25] raises the wake-mode frequency by 1.2 %, this one by 0.13 %
    "cylinder": Domain(upstream=50.0, downstream=100.0, lateral=50.0),
}


SOLID_DOFS = ("heave", "pitch")


@dataclass(frozen=True)
class Solid:
    """Solid parameters (MODEL.md §2-§3); they change only small blocks of the coupled system.

    ``mass_ratio`` m = m̃/(½ρL²s), ``reduced_velocity`` U* = U∞/(L ω_θ), ``freq_ratio`` Ω = ω_h/ω_θ,
    ``zeta_h``/``zeta_theta`` damping ratios, ``r_theta`` radius of gyration about G in body lengths,
    ``dofs`` the active degrees of freedom among ``heave`` and ``pitch`` (empty: fixed body).
    For the cylinder (MODEL.md §10) use :meth:`Solid.cylinder`, which converts its diameter-based
    ``m = 4m̃/(πρD²s)`` and ``U* = 2πU∞/(Dω_n)`` to this form.
    """

    mass_ratio: float = 1000.0
    reduced_velocity: float = 4.7
    freq_ratio: float = 0.8
    zeta_h: float = 0.0
    zeta_theta: float = 0.05
    r_theta: float = 0.289
    dofs: tuple[str, ...] = field(default=SOLID_DOFS)

    def __post_init__(self):
        object.__setattr__(self, "mass_ratio", _positive("mass ratio", self.mass_ratio))
        object.__setattr__(self, "reduced_velocity", _positive("reduced velocity", self.reduced_velocity))
        object.__setattr__(self, "freq_ratio", _positive("frequency ratio", self.freq_ratio))
        object.__setattr__(self, "zeta_h", _non_negative("heave damping ratio", self.zeta_h))
        object.__setattr__(self, "zeta_theta", _non_negative("pitch damping ratio", self.zeta_theta))
        object.__setattr__(self, "r_theta", _positive("radius of gyration", self.r_theta))
        dofs = tuple(self.dofs)
        bad = [d for d in dofs if d not in SOLID_DOFS]
        if bad or len(set(dofs)) != len(dofs):
            raise InputError(f"dofs must be distinct names among {SOLID_DOFS}, got {dofs}")
        object.__setattr__(self, "dofs", tuple(d for d in SOLID_DOFS if d in dofs))

    @classmethod
    def cylinder(cls, mass_ratio: float, reduced_velocity: float, zeta: float = 0.0) -> Solid:
        """Heave-only cylinder in MODEL.md §10 scalings: ``h'' + (2π/U*)² h = 2 C_L/(π m)``.

        In the generic form ``h'' + (Ω/U*_g)² h = C_L / m_g`` this is ``m_g = π m / 2`` and
        ``Ω/U*_g = 2π/U*`` (with ``Ω = 1``).
        """
        m = _positive("mass ratio", mass_ratio)
        u = _positive("reduced velocity", reduced_velocity)
        return cls(
            mass_ratio=math.pi * m / 2,
            reduced_velocity=u / (2 * math.pi),
            freq_ratio=1.0,
            zeta_h=zeta,
            zeta_theta=0.0,
            r_theta=1.0,
            dofs=("heave",),
        )


def as_dict(obj) -> dict:
    """Plain dict of a parameter dataclass (for cache keys and metadata)."""
    return asdict(obj)
