"""Immutable, validated parameters and the conventions they carry.

Non-dimensionalisation (docs/model.md §1, §2, §10):

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

from fsistab.bodies import BODY_TYPES, Body, body_type, frame_offset, make_body
from fsistab.errors import InputError
from fsistab.validate import finite as _finite
from fsistab.validate import non_negative as _non_negative
from fsistab.validate import positive as _positive


@dataclass(frozen=True)
class Flow:
    """Flow parameters that the steady state depends on: ``Re`` and ``α0`` (docs/model.md §6).

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

    ``U = 0`` is imposed upstream and laterally, a stress-free condition downstream (docs/model.md §4).
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


@dataclass(frozen=True)
class Sponge:
    """An absorbing layer at the outlet, in the **linearised** momentum equation only (docs/model.md §7):

        ``∫ σ(X) (u − θ u_θ)·v``,   ``σ(X) = σ_max S((X − X_s)/(X_out − X_s))``,   ``S(t) = 3t² − 2t³``
        on ``[0, 1]`` (0 before, 1 after),   ``X_s = (1 − zone) X_out``,

    uniform in ``Y``, with ``X_out`` the domain's downstream extent and
    ``u_θ = (∇U⁰)(−Y, X) − e_z∧U⁰`` (:func:`fsistab.operators.rotation_target`): the steady field
    turned with the pitch, which the sponge leaves alone (it damps the shed perturbation, not the
    kinematics of a turning wake). The steady state is not changed (``σ (U⁰ − U⁰) = 0``). A
    perturbation advected at ``U∞`` through the layer loses ``exp(−σ_max zone X_out / 2)`` per pass.
    ``sigma_max`` in units ``U∞/L``; ``zone`` the fraction of ``[0, X_out]`` it covers.

    It removes the truncated domain's weakly damped convective modes (perturbations carried to the
    outlet and fed back), which otherwise put spurious folds into the low-mass-ratio neutral curves,
    while it leaves the thresholds at large mass ratio, the static slopes and the wake mode
    practically unchanged (docs/discretisation.md, "A sponge layer"). It must start more than one
    wake wavelength of the flutter mode (``2π/ω_F``) behind the body, and lie in elements that
    resolve the wake: the reflection where elements grow is not absorbed by a layer behind it.

    ``far_sigma > 0`` adds a **far-field layer** outside the mesh's middle box and band
    (:func:`fsistab.operators.far_layer`): ``σ_far = far_sigma S(d / far_ramp)``, ``d`` the distance
    to the nearer of the two, added to the outlet's ``σ``. It damps the weakly damped free-stream
    modes that the outer elements carry, which fold the low-mass-ratio neutral curves. It also acts
    on the body's own far field at low frequency, so the presets keep it on elements fine enough to
    carry that far field (docs/discretisation.md, "The far field at low mass ratio").
    """

    sigma_max: float = 0.2
    zone: float = 0.25
    far_sigma: float = 0.0
    far_ramp: float = 10.0

    def __post_init__(self):
        object.__setattr__(self, "sigma_max", _positive("sponge sigma_max", self.sigma_max))
        zone = _positive("sponge zone", self.zone)
        if zone > 0.5:
            raise InputError(
                f"the sponge zone is a fraction of the downstream extent in (0, 0.5], got {zone}"
            )
        object.__setattr__(self, "zone", zone)
        far_sigma = _finite("far-field sponge sigma", self.far_sigma)
        if far_sigma < 0:
            raise InputError(f"the far-field sponge's sigma must be >= 0, got {far_sigma}")
        object.__setattr__(self, "far_sigma", far_sigma)
        object.__setattr__(self, "far_ramp", _positive("far-field sponge ramp", self.far_ramp))

    def key_inputs(self) -> dict:
        """The layer as cache keys see it: without the far-field fields when there is no far-field
        layer, so that results made before it existed keep their keys."""
        inputs = asdict(self)
        if self.far_sigma == 0:
            del inputs["far_sigma"], inputs["far_ramp"]
        return inputs

    def start(self, domain: Domain) -> float:
        """``X_s``: where ``σ`` starts to rise (body lengths behind the body's centre)."""
        return (1 - self.zone) * domain.downstream


def parse_sponge(text: str) -> Sponge | None | Literal["preset"]:
    """``preset`` (the mesh preset's own), ``none``, ``SIGMA_MAX,ZONE`` (e.g. ``0.2,0.25``), or
    ``SIGMA_MAX,ZONE,FAR_SIGMA,FAR_RAMP`` with a far-field layer (e.g. ``0.2,0.25,0.2,10``)."""
    value = text.strip().lower()
    if value in ("preset", "none"):
        return None if value == "none" else "preset"
    parts = value.split(",")
    if len(parts) not in (2, 4):
        raise InputError(
            "--sponge must be 'preset', 'none', SIGMA_MAX,ZONE (e.g. 0.2,0.25) or "
            f"SIGMA_MAX,ZONE,FAR_SIGMA,FAR_RAMP (e.g. 0.2,0.25,0.2,10), got {text!r}"
        )
    names = ("sponge sigma_max", "sponge zone", "far-field sponge sigma", "far-field sponge ramp")
    return Sponge(*(_finite(name, part) for name, part in zip(names, parts, strict=False)))


#: The element sizes and refinement extents (body lengths) of a mesh preset that ``--mesh-sizes``
#: overrides (:class:`fsistab.mesh.MeshSizes`).
MESH_SIZE_NAMES = (
    "wall",
    "corner",
    "near",
    "wake",
    "far",
    "middle",
    "band",
    "near_margin",
    "wake_length",
    "wake_half_width",
)


def parse_mesh_sizes(text: str | None) -> tuple[tuple[str, float], ...]:
    """``NAME=VALUE,...`` (e.g. ``near=0.025,wake=0.1,wake_length=8``), names among
    :data:`MESH_SIZE_NAMES`; ``None`` or empty: none. Checked by :class:`Case`."""
    if text is None or not text.strip():
        return ()
    pairs = []
    for part in text.split(","):
        name, sep, value = part.partition("=")
        if not sep:
            example = "near=0.025,wake=0.1"
            raise InputError(f"--mesh-sizes is NAME=VALUE,... (e.g. {example}), got {part.strip()!r}")
        pairs.append((name.strip(), _finite(f"mesh size {name.strip()}", value)))
    return tuple(pairs)


def check_mesh_sizes(pairs) -> tuple[tuple[str, float], ...]:
    """The overrides sorted by name, each name known and given once, each value positive."""
    checked = [(str(name), value) for name, value in pairs]
    names = [name for name, _ in checked]
    unknown = [name for name in names if name not in MESH_SIZE_NAMES]
    if unknown:
        raise InputError(f"unknown mesh size {unknown[0]!r}: choose among {', '.join(MESH_SIZE_NAMES)}")
    if len(set(names)) != len(names):
        raise InputError(f"each mesh size may be given once, got {', '.join(names)}")
    return tuple(sorted((name, _positive(f"mesh size {name}", value)) for name, value in checked))


def default_sponge(body: Body, preset: str) -> Sponge | None:
    """The outlet and far-field layers of a mesh preset when none is chosen (the body's
    ``sponge_presets``), else none."""
    arguments = body.sponge_presets.get(preset)
    return None if arguments is None else Sponge(**arguments)


def default_domain(body: Body, preset: str) -> Domain:
    """The domain of a mesh preset when none is given (the body's ``domain_presets``)."""
    extents = body.domain_presets
    return Domain(*extents.get(preset, extents[None]))


SOLID_DOFS = ("heave", "pitch")


@dataclass(frozen=True)
class Solid:
    """Solid parameters (docs/model.md §2-§3); they change only small blocks of the coupled system.

    ``mass_ratio`` m = m̃/(½ρL²s), ``reduced_velocity`` U* = U∞/(L ω_θ), ``freq_ratio`` Ω = ω_h/ω_θ,
    ``zeta_h``/``zeta_theta`` damping ratios, ``r_theta`` radius of gyration about the pitch axis in
    body lengths, ``dofs`` the active degrees of freedom among ``heave`` and ``pitch`` (empty: fixed
    body). The full typical section (docs/model.md §3.1): ``elastic_axis`` ``a``, mid-chord → elastic
    axis (the pitch axis, where the springs act), and ``static_unbalance`` ``x_θ``, elastic axis →
    centre of mass, both in body lengths, downstream positive; ``r_theta`` is then about the
    elastic axis and must exceed ``|x_θ|`` (the inertia about the centre of mass, ``m(r_θ² - x_θ²)``,
    is positive). Both zero: the centre of mass is the pitch axis (docs/model.md §3).
    For the cylinder (docs/model.md §10) use :meth:`Solid.cylinder`, which converts its diameter-based
    ``m = 4m̃/(πρD²s)`` and ``U* = 2πU∞/(Dω_n)`` to this form.
    """

    mass_ratio: float = 1000.0
    reduced_velocity: float = 4.7
    freq_ratio: float = 0.8
    zeta_h: float = 0.0
    zeta_theta: float = 0.05
    r_theta: float = 0.289
    dofs: tuple[str, ...] = field(default=SOLID_DOFS)
    elastic_axis: float = 0.0
    static_unbalance: float = 0.0

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
        a, x = check_typical_section(self.elastic_axis, self.static_unbalance, self.r_theta)
        object.__setattr__(self, "elastic_axis", a)
        object.__setattr__(self, "static_unbalance", x)

    @classmethod
    def cylinder(cls, mass_ratio: float, reduced_velocity: float, zeta: float = 0.0) -> Solid:
        """Heave-only cylinder in docs/model.md §10 scalings: ``h'' + (2π/U*)² h = 2 C_L/(π m)``.

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


def check_typical_section(
    elastic_axis: float, static_unbalance: float, r_theta: float
) -> tuple[float, float]:
    """``(a, x_θ)`` checked (docs/model.md §3.1): the elastic axis inside the chord (``|a| < 1/2``),
    the centre of mass ``a + x_θ`` on it, and ``x_θ² < r_θ²`` (positive inertia about the centre of
    mass, hence a positive-definite solid mass)."""
    a = _finite("elastic axis (--elastic-axis)", elastic_axis)
    x = _finite("static unbalance (--static-unbalance)", static_unbalance)
    if abs(a) >= 0.5:
        raise InputError(f"the elastic axis must lie inside the chord, |a| < 1/2, got a = {a:g}")
    if abs(a + x) > 0.5:
        raise InputError(f"the centre of mass a + x_θ = {a + x:g} must lie on the chord, |a + x_θ| <= 1/2")
    if x * x >= r_theta**2:
        raise InputError(
            f"static unbalance |x_θ| = {abs(x):g} must be smaller than the radius of gyration about the "
            f"elastic axis r_θ = {r_theta:g} (inertia about the centre of mass m(r_θ² - x_θ²) > 0)"
        )
    return a, x


def as_dict(obj) -> dict:
    """Plain dict of a parameter dataclass (for cache keys and metadata)."""
    return asdict(obj)


# --- what a command computes: validated before any work --------------------------------------------

# the presets of fsistab.mesh (checked there too)
MESH_PRESETS = ("coarse", "quick", "fast", "medium", "fine")
# the outflow condition (docs/model.md §4, "Outlet"): the natural condition of the symmetric
# stress, σN = 0 (the default), or of the velocity gradient, Re⁻¹(∇U)N − PN = 0
OUTLETS = ("stress", "gradient")


def check_outlet(outlet: str) -> str:
    """``outlet`` if it is one of :data:`OUTLETS`, else a one-line InputError."""
    if outlet not in OUTLETS:
        raise InputError(f"unknown outlet condition {outlet!r}: choose one of {', '.join(OUTLETS)}")
    return outlet


def preset_message(body: Body, preset: str) -> str:
    """Why ``preset`` is refused for ``body``: the bodies it is fitted to, and the body's presets."""
    owners = [cls.__name__.lower() for cls in BODY_TYPES.values() if preset in cls.mesh_presets]
    return (
        f"the {preset} mesh preset is defined for the {', '.join(owners)} only, not the {body.kind}: "
        f"choose {', '.join(body.mesh_presets)}"
    )


# finite bounds on what a command accepts: beyond them a run is meaningless or unbounded in time
MAX_REYNOLDS = 1e7  # a 2-D laminar model; the machine's limit (fsistab.resources) is lower
MAX_MASS_RATIO = 1e9
MAX_REDUCED_VELOCITY = 1e6
MAX_FREQUENCY = 1e4  # in units U∞/L
MAX_SWEEP_POINTS = 500
MAX_CURVE_POINTS = 10_000


def _count(name: str, value: int, low: int, high: int) -> int:
    """An integer option within ``[low, high]``."""
    if isinstance(value, bool) or not isinstance(value, int):
        try:
            as_float = float(value)
        except (TypeError, ValueError):
            raise InputError(f"{name} must be an integer, got {value!r}") from None
        if not as_float.is_integer():
            raise InputError(f"{name} must be an integer, got {value!r}")
        value = int(as_float)
    if not low <= value <= high:
        raise InputError(f"{name} must be between {low} and {high}, got {value}")
    return int(value)


def _bounded(name: str, value: float, high: float) -> float:
    """A positive finite number at most ``high``."""
    value = _positive(name, value)
    if value > high:
        raise InputError(f"{name} must be at most {high:g}, got {value:g}")
    return value


def _interval(name: str, pair, high: float) -> tuple[float, float]:
    """``(low, high)`` with ``0 < low < high <= high bound``, both finite."""
    try:
        low, top = (float(v) for v in pair)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be two numbers, got {pair!r}") from None
    if not (math.isfinite(low) and math.isfinite(top) and 0 < low < top):
        raise InputError(f"{name} must be 0 < low < high, both finite, got {low:g} {top:g}")
    if top > high:
        raise InputError(f"{name} must end at most at {high:g}, got {top:g}")
    return low, top


def parse_complex(name: str, text: str, high: float = MAX_FREQUENCY) -> complex:
    """A complex number written like ``0.05+0.2j`` (``i`` accepted for ``j``), finite, ``|z| <= high``."""
    try:
        value = complex(str(text).replace(" ", "").replace("i", "j"))
    except ValueError:
        raise InputError(f"cannot read the {name} {text!r}: write it like 0.05+0.2j") from None
    if not (math.isfinite(value.real) and math.isfinite(value.imag)):
        raise InputError(f"the {name} must be finite, got {text!r}")
    if abs(value) > high:
        raise InputError(f"the {name} must be at most {high:g} in modulus, got {text!r}")
    return value


@dataclass(frozen=True)
class Case:
    """One body in one steady flow on one mesh preset: what a steady state (and everything
    linearised about it) depends on. ``domain`` None is the preset's default (:func:`default_domain`);
    ``sponge`` ``"preset"`` is the preset's outlet layer (:func:`default_sponge`), None none: it
    changes the linear operators only, not the mesh or the steady state. ``mesh_reynolds`` is the
    Reynolds number the preset's sizes are fitted to (:func:`fsistab.mesh.preset_sizes`), None the
    flow's own: held fixed, one mesh serves flows at several Re, so that a study in Re is not
    crossed by changes of mesh (docs/how-to/studies.md, "One mesh for a range of Re"). ``outlet``
    is the outflow condition (:data:`OUTLETS`), part of the steady state, not of the mesh.
    ``mesh_sizes`` are ``(name, value)`` pairs that replace the fitted preset's sizes
    (:data:`MESH_SIZE_NAMES`): the meshes of a convergence study (docs/how-to/meshes.md)."""

    body: Body
    flow: Flow
    preset: str = "medium"
    domain: Domain | None = None
    sponge: Sponge | None | Literal["preset"] = "preset"
    mesh_reynolds: float | None = None
    outlet: str = "stress"
    mesh_sizes: tuple[tuple[str, float], ...] = ()

    def __post_init__(self):
        check_outlet(self.outlet)
        object.__setattr__(self, "mesh_sizes", check_mesh_sizes(self.mesh_sizes))
        if self.mesh_reynolds is not None:
            value = _bounded("mesh Reynolds number (--mesh-reynolds)", self.mesh_reynolds, MAX_REYNOLDS)
            object.__setattr__(self, "mesh_reynolds", value)
        if not (self.sponge is None or self.sponge == "preset" or isinstance(self.sponge, Sponge)):
            raise InputError(f"sponge must be a Sponge, None or 'preset', got {self.sponge!r}")
        if self.preset not in MESH_PRESETS:
            raise InputError(f"unknown mesh preset {self.preset!r}: choose one of {', '.join(MESH_PRESETS)}")
        if self.preset not in self.body.mesh_presets:
            raise InputError(preset_message(self.body, self.preset))
        if self.flow.reynolds > MAX_REYNOLDS:
            raise InputError(f"Reynolds number must be at most {MAX_REYNOLDS:g}, got {self.flow.reynolds:g}")

    @classmethod
    def create(
        cls,
        body: str = "plate",
        reynolds: float = 2900.0,
        alpha0_deg: float = 0.0,
        preset: str = "medium",
        aspect_ratio: float = 20.0,
        corner_radius: float = 0.1,
        domain: tuple[float, float, float] | None = None,
        sponge: str = "preset",
        trailing_edge: str = "closed",
        body_file: str | None = None,
        reference_length: float | None = None,
        mesh_reynolds: float | None = None,
        elastic_axis: float = 0.0,
        outlet: str = "stress",
        mesh_sizes: str | None = None,
    ) -> Case:
        """From the command-line options (:func:`fsistab.bodies.make_body`). Every shape option is
        checked for every body: a value that makes no sense is refused even where it is not used.
        ``elastic_axis`` ``a``: the section in the frame of its elastic axis (docs/model.md §3.1)."""
        shape = make_body(
            body, aspect_ratio, corner_radius, trailing_edge, body_file, reference_length, elastic_axis
        )
        return cls(
            body=shape,
            flow=Flow(reynolds, alpha0_deg),
            preset=preset,
            domain=Domain(*domain) if domain is not None else None,
            sponge=parse_sponge(sponge),
            mesh_reynolds=mesh_reynolds,
            outlet=outlet,
            mesh_sizes=parse_mesh_sizes(mesh_sizes),
        )

    @property
    def kind(self) -> str:
        return self.body.kind

    @property
    def elastic_axis(self) -> float:
        """``a`` of the body's frame (docs/model.md §3.1): 0 unless the section pitches about an
        elastic axis away from mid-chord."""
        return 0.0 - frame_offset(self.body)

    @property
    def fitted_reynolds(self) -> float:
        """The Reynolds number the mesh is fitted to: ``mesh_reynolds``, or the flow's."""
        return self.flow.reynolds if self.mesh_reynolds is None else self.mesh_reynolds

    @property
    def tag(self) -> str:
        """``plate_Re2900_a0``: the stem of the files a command writes for this case, with
        ``_meshRe2900`` when the mesh is fitted to another Re than the flow's (another mesh; the
        same Re is the same mesh, whose files keep their names) and :attr:`mesh_tag` when the
        domain or sizes are not the preset's."""
        tag = f"{self.kind}_Re{self.flow.reynolds:g}_a{self.flow.alpha0_deg:g}"
        if self.elastic_axis:
            tag += f"_ea{self.elastic_axis:g}"
        if self.fitted_reynolds != self.flow.reynolds:
            tag += f"_meshRe{self.fitted_reynolds:g}"
        return tag + self.mesh_tag

    @property
    def mesh_tag(self) -> str:
        """``_domain40-80-40`` when the domain is not the preset's own and
        ``_sizes-near0.025-wake0.1`` when ``mesh_sizes`` override the preset's, else empty: the
        files of another mesh get other names (a domain study in one directory overwrites nothing)."""
        tag = ""
        if self.domain is not None and self.domain != default_domain(self.body, self.preset):
            d = self.domain
            tag += f"_domain{d.upstream:g}-{d.downstream:g}-{d.lateral:g}"
        if self.mesh_sizes:
            tag += "_sizes" + "".join(f"-{name}{value:g}" for name, value in self.mesh_sizes)
        return tag

    def require_plate(self, what: str) -> None:
        if "pitch" not in self.body.allowed_dofs:
            raise InputError(f"{what} are implemented for the plate (heave and pitch)")


def parse_dofs(text: str | None, kind: str) -> tuple[str, ...]:
    """``heave,pitch`` | ``heave`` | ``pitch`` | ``none``; None is the body's default."""
    body = body_type(kind)
    if text is None:
        return body.default_dofs
    if text.strip() == "none":
        return ()
    names = tuple(d.strip() for d in text.split(",") if d.strip())
    if not names:
        raise InputError(f"--dofs must be heave,pitch | heave | pitch | none, got {text!r}")
    bad = [d for d in names if d not in SOLID_DOFS]
    if bad or len(set(names)) != len(names):
        raise InputError(f"--dofs must be distinct names among heave, pitch (or none), got {text!r}")
    _check_dofs(body, names)
    return names


def _check_dofs(body: type[Body], names: tuple[str, ...]) -> None:
    extra = [d for d in names if d not in body.allowed_dofs]
    if extra:
        choices = " or ".join([*body.allowed_dofs, "none"])
        raise InputError(f"the {body.kind} has no {extra[0]} degree of freedom: use --dofs {choices}")


def solid_for(
    kind: str,
    mass_ratio: float | None = None,
    reduced_velocity: float | None = None,
    freq_ratio: float = 0.8,
    zeta_h: float = 0.0,
    zeta_theta: float = 0.05,
    r_theta: float = 0.289,
    dofs: tuple[str, ...] | None = None,
    elastic_axis: float = 0.0,
    static_unbalance: float = 0.0,
) -> Solid:
    """Solid parameters in the body's conventions (plate docs/model.md §2, cylinder §10), None
    meaning the body's default (never a falsy value: ``0`` is refused, not replaced), returned in
    the generic form of §3 (:meth:`fsistab.bodies.Cylinder.generic_solid`). Every value is
    checked, also those the cylinder ignores (Ω, ζ_θ, r_θ)."""
    body = body_type(kind)
    mass = (
        body.default_mass_ratio if mass_ratio is None else _bounded("mass ratio", mass_ratio, MAX_MASS_RATIO)
    )
    velocity = (
        body.default_reduced_velocity
        if reduced_velocity is None
        else _bounded("reduced velocity", reduced_velocity, MAX_REDUCED_VELOCITY)
    )
    checked = Solid(
        mass_ratio=mass,
        reduced_velocity=velocity,
        freq_ratio=_bounded("frequency ratio", freq_ratio, 1e3),
        zeta_h=zeta_h,
        zeta_theta=zeta_theta,
        r_theta=_bounded("radius of gyration", r_theta, 1e3),
        dofs=body.default_dofs if dofs is None else dofs,
        elastic_axis=elastic_axis,
        static_unbalance=static_unbalance,
    )
    if "pitch" not in body.allowed_dofs and (checked.elastic_axis or checked.static_unbalance):
        raise InputError(f"the {body.kind} does not pitch: it has no elastic axis or static unbalance")
    for name, value in (("heave damping ratio", checked.zeta_h), ("pitch damping ratio", checked.zeta_theta)):
        if value > 100:
            raise InputError(f"{name} must be at most 100, got {value:g}")
    _check_dofs(body, checked.dofs)
    return body.generic_solid(checked)


def body_mass_ratio(kind: str, solid: Solid) -> float:
    """The mass ratio in the body's own convention (inverse of ``generic_solid``)."""
    return body_type(kind).own_mass_ratio(solid)


def body_velocity_scale(kind: str) -> float:
    """Body-convention U* over the generic one (the body's ``velocity_scale``, docs/model.md §10)."""
    return body_type(kind).velocity_scale


@dataclass(frozen=True)
class SpectrumSettings:
    """Eigenvalues of ``fsistab spectrum``: ``n_eigenvalues`` nearest each shift; figures of the
    ``mode_figures`` least stable modes with the pressure at ``phase`` (rad); VTK of the modes."""

    shifts: tuple[complex, ...]
    n_eigenvalues: int = 6
    vtk: bool = True
    mode_figures: int = 2
    phase: float = 0.0

    def __post_init__(self):
        shifts = tuple(complex(z) for z in self.shifts)
        if not shifts or not all(math.isfinite(z.real) and math.isfinite(z.imag) for z in shifts):
            raise InputError("give at least one finite shift")
        if len(shifts) > 20:
            raise InputError(f"at most 20 shifts, got {len(shifts)}")
        object.__setattr__(self, "shifts", shifts)
        object.__setattr__(self, "n_eigenvalues", _count("--n-eigenvalues", self.n_eigenvalues, 1, 50))
        object.__setattr__(self, "mode_figures", _count("--mode-figures", self.mode_figures, 0, 50))
        phase = _finite("--phase", self.phase)
        if abs(phase) > 100:
            raise InputError(f"--phase must be within ±100 rad, got {phase:g}")
        object.__setattr__(self, "phase", phase)


@dataclass(frozen=True)
class SweepSettings:
    """A search for every threshold over ``velocity_range`` (body conventions) at one
    ``mass_ratio`` (body conventions) by ``method`` (``transfer``: the exact transfer function swept
    in frequency; ``tracking``: eigenvalue branches over ``points`` log-spaced values of U*), the
    wake mode near ``wake_shift`` labelling VIV (and followed too, by tracking)."""

    velocity_range: tuple[float, float] = (2.0, 10.0)
    points: int = 24
    wake_shift: complex | None = None
    mass_ratio: float = 1000.0
    method: str = "transfer"

    def __post_init__(self):
        if self.method not in THRESHOLD_METHODS:
            raise InputError(f"--method must be one of {', '.join(THRESHOLD_METHODS)}, got {self.method!r}")
        interval = _interval("--reduced-velocity-range", self.velocity_range, MAX_REDUCED_VELOCITY)
        object.__setattr__(self, "velocity_range", interval)
        object.__setattr__(self, "points", _count("--points", self.points, 2, MAX_SWEEP_POINTS))
        object.__setattr__(self, "mass_ratio", _bounded("mass ratio", self.mass_ratio, MAX_MASS_RATIO))


MAP_METHODS = ("transfer", "continuation")
THRESHOLD_METHODS = ("transfer", "tracking")  # fsistab.critical.find_thresholds


# The transfer map's reduced fluid models (fsistab.reduced_model) of REDUCED_BLOCKS Krylov blocks
# pay on small meshes; from EXACT_SAMPLES_FROM fluid unknowns on, G(iω) has structure on a scale
# that a model costs more to certify than exact samples cost to resolve, so the map samples exactly
# (docs/performance.md, "The whole map"; docs/transfer.md).
REDUCED_BLOCKS = 60
EXACT_SAMPLES_FROM = 100_000


@dataclass(frozen=True)
class MapSettings:
    """Settings of the stability map in ``(m, U*)`` (``fsistab neutral``, docs/model.md §8).

    Every value is checked whichever ``method`` uses it. ``seed_masses`` None means ``m/10`` and
    ``m/100`` of ``start_mass`` within the range; ``tolerance``, ``min_step`` and ``max_frequencies``
    None are the transfer method's defaults; ``reduced_blocks`` None chooses by the mesh
    (:meth:`krylov_blocks`).
    """

    mass_range: tuple[float, float] = (1.0, 1e4)
    start_mass: float = 1000.0
    velocity_range: tuple[float, float] = (2.0, 10.0)
    seed_masses: tuple[float, ...] | None = None
    wake_frequency: float | None = None
    points: int = 24
    max_points: int = 60
    method: str = "transfer"
    frequency_range: tuple[float, float] | None = None
    tolerance: float | None = None
    min_step: float | None = None
    max_frequencies: int | None = None
    reduced_blocks: int | None = None
    reduced_tolerance: float = 1e-7

    def __post_init__(self):
        if self.method not in MAP_METHODS:
            raise InputError(f"--method must be continuation or transfer, got {self.method!r}")
        lo_m, hi_m = _interval("--mass-ratio-range", self.mass_range, MAX_MASS_RATIO)
        object.__setattr__(self, "mass_range", (lo_m, hi_m))
        start = _bounded("--start-mass-ratio", self.start_mass, MAX_MASS_RATIO)
        if self.method == "continuation" and not lo_m <= start <= hi_m:
            raise InputError("--mass-ratio-range must contain --start-mass-ratio (the first sweep)")
        object.__setattr__(self, "start_mass", start)
        interval = _interval("--reduced-velocity-range", self.velocity_range, MAX_REDUCED_VELOCITY)
        object.__setattr__(self, "velocity_range", interval)
        if self.seed_masses is not None:
            seeds = tuple(_bounded("--seed-mass-ratio", m, MAX_MASS_RATIO) for m in self.seed_masses)
            if len(seeds) > 20:
                raise InputError(f"at most 20 --seed-mass-ratio, got {len(seeds)}")
            if self.method == "continuation" and any(not lo_m <= m <= hi_m for m in seeds):
                raise InputError(
                    f"every --seed-mass-ratio must lie in the mass-ratio range [{lo_m:g}, {hi_m:g}]"
                )
            object.__setattr__(self, "seed_masses", seeds)
        if self.wake_frequency is not None:
            object.__setattr__(
                self, "wake_frequency", _bounded("--wake-frequency", self.wake_frequency, MAX_FREQUENCY)
            )
        object.__setattr__(self, "points", _count("--points", self.points, 2, MAX_SWEEP_POINTS))
        object.__setattr__(self, "max_points", _count("--max-points", self.max_points, 1, MAX_CURVE_POINTS))
        if self.frequency_range is not None:
            object.__setattr__(
                self, "frequency_range", _interval("--frequency-range", self.frequency_range, MAX_FREQUENCY)
            )
        if self.tolerance is not None:
            tolerance = _finite("--tolerance", self.tolerance)
            if not 0 < tolerance < 0.5:
                raise InputError(f"--tolerance must be in (0, 0.5), got {tolerance:g}")
            object.__setattr__(self, "tolerance", tolerance)
        if self.min_step is not None:
            min_step = _finite("--min-step", self.min_step)
            if not 0 < min_step < 0.5:
                raise InputError(f"--min-step must be in (0, 0.5), got {min_step:g}")
            object.__setattr__(self, "min_step", min_step)
        if self.max_frequencies is not None:
            object.__setattr__(
                self, "max_frequencies", _count("--max-frequencies", self.max_frequencies, 4, 100_000)
            )
        if self.reduced_blocks is not None:
            blocks = _count("--reduced-blocks", self.reduced_blocks, 0, 10_000)
            if 0 < blocks < 3:
                raise InputError(f"--reduced-blocks must be 0 (exact samples) or at least 3, got {blocks}")
            object.__setattr__(self, "reduced_blocks", blocks)
        reduced_tolerance = _finite("--reduced-tolerance", self.reduced_tolerance)
        if not 0 < reduced_tolerance < 1e-2:
            raise InputError(f"--reduced-tolerance must be in (0, 1e-2), got {reduced_tolerance:g}")
        object.__setattr__(self, "reduced_tolerance", reduced_tolerance)

    @property
    def template_mass(self) -> float:
        """The solid template's m: the first sweep's (continuation); for the transfer method any
        value in the range works, so the start is clamped into it."""
        return min(max(self.start_mass, self.mass_range[0]), self.mass_range[1])

    def krylov_blocks(self, unknowns: int) -> int:
        """The Krylov blocks of the transfer map's reduced fluid models for a fluid of ``unknowns``
        (0: exact samples only): ``reduced_blocks`` if given, else ``REDUCED_BLOCKS`` below
        ``EXACT_SAMPLES_FROM`` unknowns and 0 from there (docs/performance.md, "The whole map")."""
        if self.reduced_blocks is not None:
            return self.reduced_blocks
        return REDUCED_BLOCKS if unknowns < EXACT_SAMPLES_FROM else 0

    @property
    def seeds(self) -> tuple[float, ...]:
        if self.seed_masses is not None:
            return self.seed_masses
        start = self.template_mass
        return tuple(m for m in (start / 10, start / 100) if m >= self.mass_range[0])


FLOW_PARAMETERS = ("reynolds", "alpha0")  # the flow parameters of fsistab.flow_neutral


@dataclass(frozen=True)
class FlowNeutralSettings:
    """Neutral curves in ``(parameter, U*)`` (``fsistab flow-neutral``): from the thresholds of a
    sweep in U* at ``start`` (the case's Re or α0), continued over ``parameter_range``."""

    parameter: str = "alpha0"
    parameter_range: tuple[float, float] = (0.0, 5.0)
    start: float = 0.0
    velocity_range: tuple[float, float] = (2.0, 10.0)
    points: int = 24
    max_points: int = 40

    def __post_init__(self):
        if self.parameter not in FLOW_PARAMETERS:
            raise InputError(
                f"--parameter must be one of {', '.join(FLOW_PARAMETERS)}, got {self.parameter!r}"
            )
        try:
            low, high = (_finite("--range", v) for v in self.parameter_range)
        except InputError:
            raise InputError(f"--range must be two finite numbers, got {self.parameter_range}") from None
        start = _finite(f"the starting {self.parameter}", self.start)
        if not low <= start <= high or not low < high:
            raise InputError(
                f"--range {low:g} {high:g} must be increasing and contain the starting {self.parameter}"
            )
        if self.parameter == "reynolds" and not (0 < low and high <= MAX_REYNOLDS):
            raise InputError(f"--range of Re must lie in (0, {MAX_REYNOLDS:g}], got {low:g} {high:g}")
        if self.parameter == "alpha0" and not (-45 <= low and high <= 45):
            raise InputError(f"--range of alpha0 must lie within ±45 degrees, got {low:g} {high:g}")
        object.__setattr__(self, "parameter_range", (low, high))
        object.__setattr__(self, "start", start)
        interval = _interval("--reduced-velocity-range", self.velocity_range, MAX_REDUCED_VELOCITY)
        object.__setattr__(self, "velocity_range", interval)
        object.__setattr__(self, "points", _count("--points", self.points, 2, MAX_SWEEP_POINTS))
        object.__setattr__(self, "max_points", _count("--max-points", self.max_points, 1, MAX_CURVE_POINTS))


SLOPE_SOURCES = ("thin-airfoil", "calibrated", "given")


@dataclass(frozen=True)
class TheodorsenSettings:
    """``fsistab theodorsen``: the typical section's critical points at ``mass_ratio`` over
    ``velocity_range``, or its neutral curves at ``points`` mass ratios over ``mass_range``, with
    the slopes ``slopes`` (thin airfoil, viscous ``calibrated`` at the case's Re, or ``given``:
    ``dC_L/dα`` and ``d(-C_M)/dα`` about mid-chord per radian, docs/model.md §9); ``elastic_axis`` and
    ``static_unbalance`` in chords (their bounds, which need r_θ, are checked by the section)."""

    mass_ratio: float = 1000.0
    mass_range: tuple[float, float] | None = None
    points: int = 40
    velocity_range: tuple[float, float] = (0.01, 100.0)
    slopes: str = "thin-airfoil"
    lift_slope_alpha: float | None = None
    moment_slope_alpha: float | None = None
    elastic_axis: float = 0.0
    static_unbalance: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "mass_ratio", _bounded("mass ratio", self.mass_ratio, MAX_MASS_RATIO))
        object.__setattr__(self, "elastic_axis", _finite("--elastic-axis", self.elastic_axis))
        object.__setattr__(self, "static_unbalance", _finite("--static-unbalance", self.static_unbalance))
        if self.mass_range is not None:
            object.__setattr__(
                self, "mass_range", _interval("--mass-ratio-range", self.mass_range, MAX_MASS_RATIO)
            )
        object.__setattr__(self, "points", _count("--points", self.points, 2, 2000))
        interval = _interval("--reduced-velocity-range", self.velocity_range, MAX_REDUCED_VELOCITY)
        object.__setattr__(self, "velocity_range", interval)
        if self.slopes not in SLOPE_SOURCES:
            raise InputError(f"unknown --slopes {self.slopes!r}: choose {', '.join(SLOPE_SOURCES)}")
        given = (self.lift_slope_alpha, self.moment_slope_alpha)
        if self.slopes != "given":
            if any(v is not None for v in given):
                raise InputError("--lift-slope-alpha and --moment-slope-alpha need --slopes given")
            return
        if any(v is None for v in given):
            raise InputError("--slopes given needs both --lift-slope-alpha and --moment-slope-alpha")
        lift = _finite("--lift-slope-alpha", self.lift_slope_alpha)
        moment = _finite("--moment-slope-alpha", self.moment_slope_alpha)
        if lift <= 0:
            raise InputError(
                f"--lift-slope-alpha must be positive, got {lift:g}: the circulatory lift grows with α, and "
                "without it the flutter determinant is degenerate (roots everywhere)"
            )
        if moment == 0:
            raise InputError(
                "--moment-slope-alpha 0 puts the aerodynamic centre at mid-chord, a degenerate section "
                "(no aerodynamic pitch stiffness): give the slope about mid-chord, π/2 for a thin airfoil"
            )
        if max(abs(lift), abs(moment)) > 1e3:
            raise InputError(f"the given slopes must be at most 1000 per radian, got {lift:g} {moment:g}")
        object.__setattr__(self, "lift_slope_alpha", lift)
        object.__setattr__(self, "moment_slope_alpha", moment)


@dataclass(frozen=True)
class TransferSettings:
    """``fsistab transfer``: ``points`` reduced frequencies ``k = ω L/(2U∞)``, log-spaced over ``k_range``."""

    k_range: tuple[float, float] = (0.01, 2.0)
    points: int = 24

    def __post_init__(self):
        object.__setattr__(
            self,
            "k_range",
            _interval(
                "the reduced-frequency range (--reduced-frequency-range)", self.k_range, MAX_FREQUENCY / 2
            ),
        )
        object.__setattr__(self, "points", _count("--points", self.points, 2, 2000))


MAX_STEPS = 10_000_000  # steps of one simulation
# what --perturbation measures: the start mode's largest entry, its heave or its pitch amplitude
PERTURBATION_SCALES = ("largest", "heave", "pitch")


@dataclass(frozen=True)
class SimulationSettings:
    """``fsistab simulate`` (docs/model.md §11): march for ``duration`` with steps ``time_step`` (the
    body's time unit ``L/U∞``) from the steady state plus ``perturbation`` times the eigenmode
    nearest ``shift`` (the body's spectrum shift when None; ``perturbation_of`` ``heave`` or
    ``pitch``: the body released from the mode's solid state with that heave or pitch, the fluid
    steady, :func:`fsistab.simulation.perturbed_state`), or from the state saved in ``start``
    (a simulation checkpoint); a checkpoint every ``checkpoint_every`` steps; VTK snapshots every
    ``snapshot_interval`` of simulated time (None: none); each step's chord iteration stopped at an
    update below ``tolerance`` (largest entry) or failed after ``max_iterations``."""

    duration: float
    time_step: float = 0.05
    perturbation: float = 1e-3
    shift: complex | None = None
    start: str | None = None
    perturbation_of: str = "largest"
    checkpoint_every: int = 100
    snapshot_interval: float | None = None
    tolerance: float = 1e-9
    max_iterations: int = 30

    def __post_init__(self):
        duration = _positive("--duration", self.duration)
        step = _positive("--time-step", self.time_step)
        if step > duration:
            raise InputError(f"--time-step ({step:g}) must not exceed --duration ({duration:g})")
        if duration / step > MAX_STEPS:
            raise InputError(f"at most {MAX_STEPS:g} steps, got --duration/--time-step {duration / step:.3g}")
        object.__setattr__(self, "duration", duration)
        object.__setattr__(self, "time_step", step)
        perturbation = _non_negative("--perturbation", self.perturbation)
        if self.perturbation_of not in PERTURBATION_SCALES:
            choices = " | ".join(PERTURBATION_SCALES)
            raise InputError(f"--perturbation-of must be {choices}, got {self.perturbation_of!r}")
        if perturbation > 1:
            unit = {"largest": "the mode's largest entry", "heave": "body lengths", "pitch": "radians"}
            raise InputError(
                f"--perturbation must be at most 1 ({unit[self.perturbation_of]}), got {perturbation:g}"
            )
        object.__setattr__(self, "perturbation", perturbation)
        if self.shift is not None:
            shift = complex(self.shift)
            if not (math.isfinite(shift.real) and math.isfinite(shift.imag)):
                raise InputError("the shift must be finite")
            object.__setattr__(self, "shift", shift)
        if self.start is not None and not str(self.start).strip():
            raise InputError("--start must name a simulation checkpoint file")
        every = _count("--checkpoint-every", self.checkpoint_every, 1, MAX_STEPS)
        object.__setattr__(self, "checkpoint_every", every)
        if self.snapshot_interval is not None:
            interval = _positive("--snapshot-interval", self.snapshot_interval)
            if not step <= interval <= duration:
                raise InputError(
                    f"--snapshot-interval ({interval:g}) must be between the step ({step:g}) and the "
                    f"duration ({duration:g})"
                )
            object.__setattr__(self, "snapshot_interval", interval)
        tolerance = _positive("--step-tolerance", self.tolerance)
        if tolerance >= 1e-2:
            raise InputError(f"--step-tolerance must be below 0.01, got {tolerance:g}")
        object.__setattr__(self, "tolerance", tolerance)
        iterations = _count("the step iterations", self.max_iterations, 1, 1000)
        object.__setattr__(self, "max_iterations", iterations)

    def identity(self) -> dict:
        """What the march's states depend on (a rerun with another duration resumes the same
        march; snapshots and checkpoints do not change it)."""
        shift = "none" if self.shift is None else f"{self.shift.real!r},{self.shift.imag!r}"
        return {
            "time_step": self.time_step,
            "perturbation": self.perturbation,
            "shift": shift,
            "start": "none" if self.start is None else str(self.start),
            "tolerance": self.tolerance,
            # only when not the default, so that the keys of earlier marches stay theirs
            **({} if self.perturbation_of == "largest" else {"perturbation_of": self.perturbation_of}),
        }

    def check_dofs(self, solid: Solid) -> None:
        """Refuse, before any work, a start scaled on a degree of freedom the solid lacks."""
        dof = self.perturbation_of
        if dof != "largest" and dof not in solid.dofs:
            raise InputError(f"--perturbation-of {dof}: the {dof} is not a degree of freedom (--dofs)")


@dataclass(frozen=True)
class LcoSettings:
    """``fsistab lco``: one march (``simulation``, :class:`SimulationSettings`) at each of ``points``
    equally spaced U* over ``velocity_range`` (body conventions; one point: its low end), the
    saturated amplitude taken over the last ``periods`` whole periods and called saturated when
    the envelope changes by less than ``saturation_tolerance`` (relative) per period; with
    ``hysteresis`` a second sweep by decreasing U*, each march started from the saturated state of
    the one before (docs/model.md §12)."""

    velocity_range: tuple[float, float]
    points: int
    simulation: SimulationSettings
    periods: int = 4
    saturation_tolerance: float = 0.01
    hysteresis: bool = False

    def __post_init__(self):
        low, high = _lco_range(self.velocity_range)
        object.__setattr__(self, "velocity_range", (low, high))
        points = _count("--points", self.points, 1, MAX_SWEEP_POINTS)
        if points > 1 and low == high:
            raise InputError(f"--points {points} needs a range of U*, got {low:g} {high:g}")
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "periods", _count("--periods", self.periods, 2, 1000))
        tolerance = _positive("--saturation-tolerance", self.saturation_tolerance)
        if tolerance >= 0.5:
            raise InputError(
                f"--saturation-tolerance must be below 0.5 (relative, per period), got {tolerance:g}"
            )
        object.__setattr__(self, "saturation_tolerance", tolerance)

    def velocities(self) -> tuple[float, ...]:
        """The U* of the marches, increasing (rounded to 12 digits: the same U* given twice is the
        same march)."""
        low, high = self.velocity_range
        if self.points == 1:
            return (low,)
        step = (high - low) / (self.points - 1)
        return tuple(float(round(low + k * step, 12)) for k in range(self.points))


# fsistab lco searches the linear thresholds beside its diagram over its range widened by this
# fraction each way (fsistab.lco.threshold_sweep): the range is checked with it before any march.
LCO_THRESHOLD_MARGIN = 0.2


def _lco_range(pair) -> tuple[float, float]:
    """``--reduced-velocity-range A B``: ``0 < A <= B`` (equal for one point), both finite, and
    ``B`` widened by :data:`LCO_THRESHOLD_MARGIN` (the thresholds' search) within the bound."""
    try:
        low, high = (float(v) for v in pair)
    except (TypeError, ValueError):
        raise InputError(f"--reduced-velocity-range must be two numbers, got {pair!r}") from None
    if not (math.isfinite(low) and math.isfinite(high) and 0 < low):
        raise InputError(f"--reduced-velocity-range must be positive and finite, got {low:g} {high:g}")
    if high < low:
        raise InputError(f"--reduced-velocity-range is reversed: {low:g} > {high:g} (give A <= B)")
    top = MAX_REDUCED_VELOCITY / (1 + LCO_THRESHOLD_MARGIN)
    if high > top:
        raise InputError(
            f"--reduced-velocity-range must end at most at {top:g} (the thresholds are searched "
            f"{LCO_THRESHOLD_MARGIN:.0%} beyond it), got {high:g}"
        )
    return low, high
