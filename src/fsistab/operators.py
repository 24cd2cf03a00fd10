"""Linear operators of the fluid at a steady state (docs/model.md §5, §7), exported as SciPy matrices.

The fluid unknowns ``q_f`` are the free dofs of the Taylor–Hood space (velocity off the Dirichlet
boundaries, all pressure dofs). The wall velocity dofs are not unknowns: they follow the solid,
``u_Γ(q_s) = a_x(θ, ḣ) ℓ_x + a_y(θ, ḣ) ℓ_y + θ' ℓ_rot`` with ``(a_x, a_y) = R(θ)ᵀ(-1, ḣ)ᵀ``
(docs/model.md §4 wall condition, lifted with the discrete fields ``ℓ`` of :mod:`fsistab.forces`).
Hence the discrete Jacobian has, besides the shape derivatives ``D_θ, D_ḣ, D_θ'`` of docs/model.md §7,
the wall-coupling columns ``A_{fΓ} ∂u_Γ/∂q_s`` and a mass coupling ``M_{fΓ} ∂u_Γ/∂q_s``.

Solid columns are ordered ``SOLID_STATE = (h, θ, ḣ, θ')``; ``h`` never enters the fluid.
Loads are the reaction loads ``(F_x, F_y, M)`` in body axes, ``F·ℓ = -(ℓᵀ M u̇ + R(q; ℓ))``:
their derivatives are rows ``-ℓᵀ A`` and their inertia rows ``-ℓᵀ M`` (the wall-adjacent fluid
mass that the lifting puts into the force, consistent with the discrete equations).
Everything here depends on (mesh, Re, α0) only, never on the solid parameters.

Every term of the momentum equation is written once, as a :class:`Term` (``TERMS``: Navier–Stokes in
the moving frame, the time derivative, the frame's rotation, the sponge); ``J_ff``, ``M_f``, the
solid columns, the shifted matrix ``J_ff + s M_f``, the nonlinear residual of the finite-difference
checks and the base-flow variation of the sensitivities are sums over them.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from fsistab import umfpack
from fsistab.bodies import frame_offset
from fsistab.forces import RIGID_MOTIONS, reaction_loads, wall_liftings
from fsistab.mesh import NGSOLVE_LOCK
from fsistab.steady import (
    SteadyState,
    momentum_form,
    momentum_linearisation,
    outlet_form,
    taylor_hood_space,
    wall_velocity,
)

SOLID_STATE = ("h", "theta", "hdot", "thetadot")
NEAR_RADIUS = 1.0  # body lengths around mid-chord (the centre of the plate and the cylinder)


def rotation_matrix(theta: float) -> np.ndarray:
    """``R(θ)`` of docs/model.md §4 (counter-clockwise rotation)."""
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s], [s, c]])


def grid_velocity_derivatives(theta: float) -> dict[str, tuple[float, float]]:
    """Uniform parts of ``∂W/∂θ = R'(θ)ᵀ(-1, 0)ᵀ`` and ``∂W/∂ḣ = R(θ)ᵀ(0, 1)ᵀ`` (at ḣ = θ' = 0),
    the ``W_θ`` and ``W_ḣ`` of docs/model.md §7."""
    c, s = math.cos(theta), math.sin(theta)
    return {"theta": (s, c), "hdot": (s, c)}


def wall_coefficients(q_solid: np.ndarray) -> np.ndarray:
    """Coefficients of ``(ℓ_x, ℓ_y, ℓ_rot)`` in ``u_Γ(q_s)``: ``(R(θ)ᵀ(-1, ḣ)ᵀ, θ')``, the wall
    velocity ``W`` of docs/model.md §4."""
    _, theta, hdot, thetadot = q_solid
    ax, ay = rotation_matrix(theta).T @ np.array([-1.0, hdot])
    return np.array([ax, ay, thetadot])


def wall_coefficients_jacobian(q_solid: np.ndarray) -> np.ndarray:
    """``∂(a_x, a_y, θ')/∂(h, θ, ḣ, θ')`` (3 × 4)."""
    _, theta, hdot, _ = q_solid
    c, s = math.cos(theta), math.sin(theta)
    d_theta = np.array([[-s, c], [-c, -s]]) @ np.array([-1.0, hdot])  # R'(θ)ᵀ(-1, ḣ)ᵀ
    d_hdot = rotation_matrix(theta).T @ np.array([0.0, 1.0])
    jac = np.zeros((3, 4))
    jac[:2, 1] = d_theta
    jac[:2, 2] = d_hdot
    jac[2, 3] = 1.0
    return jac


def _to_scipy(matrix, n: int) -> sp.csr_matrix:
    """NGSolve's assembled sparse matrix as a SciPy CSR matrix, from its own CSR arrays (copied):
    the same entries in the same order as through ``COO()``, without SciPy's COO-to-CSR sort, which
    dominates the export's time."""
    values, columns, starts = matrix.CSR()
    arrays = np.array(values), np.array(columns), np.array(starts, dtype=np.int64)
    return sp.csr_matrix(arrays, shape=(n, n))


def _linear_form_vector(space, integrand_of_test) -> np.ndarray:
    from ngsolve import LinearForm, dx

    (_, _), (v, q) = space.TnT()
    form = LinearForm(space)
    # compiled: several times faster to assemble with the sponge's term, the vector identical
    form += integrand_of_test(v, q).Compile() * dx
    form.Assemble()
    return form.vec.FV().NumPy().copy()


@dataclass(frozen=True)
class FluidOperators:
    """Fluid blocks at one steady state, SciPy sparse, independent of the solid parameters.

    Attributes (``n`` = number of fluid unknowns, the free dofs ``free_dofs`` of the space):

    * ``jff``, ``mff`` (n × n): ``J_ff`` and ``M_f`` (velocity mass, zero on pressure);
    * ``jfs``, ``mfs`` (n × 4): fluid rows, solid columns ``(h, θ, ḣ, θ')`` of ``J`` and ``M``;
    * ``load_f`` (3 × n), ``load_s`` (3 × 4): derivatives of the loads ``(F_x, F_y, M)`` in body
      axes (units ``ρU∞²L``) with respect to the fluid and solid unknowns;
    * ``load_mass_f`` (3 × n), ``load_mass_s`` (3 × 4): the loads' inertia, ``L = -(Mf q̇) - ...``;
    * ``loads0``: steady ``(F_x, F_y, M)``; ``theta0``: steady pitch;
    * ``mff_near``: velocity mass restricted to the disc of radius ``NEAR_RADIUS`` about mid-chord
      (the frame's origin unless the section pitches about an elastic axis elsewhere; to label modes:
      global wake modes grow downstream, so whole-domain energies say little about the body);
    * ``basis``: None, or the blocks are restricted to a subspace of the fluid unknowns and this is
      its orthonormal basis (``free dofs × n``): a fluid vector ``q`` of these operators is
      ``basis @ q`` on the free dofs (the antisymmetric fields of a symmetric section,
      :mod:`fsistab.symmetry`; ``steady``, ``free_dofs``, the solid blocks and ``loads0`` stay the
      whole space's).
    """

    steady: SteadyState
    free_dofs: np.ndarray
    jff: sp.csr_matrix
    mff: sp.csr_matrix
    jfs: np.ndarray
    mfs: np.ndarray
    load_f: sp.csr_matrix
    load_s: np.ndarray
    load_mass_f: sp.csr_matrix
    load_mass_s: np.ndarray
    loads0: np.ndarray
    theta0: float
    mff_near: sp.csr_matrix
    basis: sp.csr_matrix | None = None
    # UMFPACK symbolic analyses of J_ff + s M_f by arithmetic (float, complex): the pattern is the
    # same at every shift, so the analysis is made once per operators (fsistab.linalg.FluidFactor)
    analyses: dict = field(default_factory=dict, compare=False, repr=False)

    @functools.cached_property
    def pencil(self) -> umfpack.Pencil:
        """``J_ff`` and ``M_f`` as one UMFPACK pencil, made at the first factorisation and kept (not a
        field: operators made by ``dataclasses.replace``, with other blocks, start without it)."""
        return umfpack.Pencil(self.jff, self.mff)

    @property
    def n_fluid(self) -> int:
        return int(self.jff.shape[0])

    @property
    def reynolds(self) -> float:
        return self.steady.flow.reynolds

    def near_energy(self, fluid: np.ndarray) -> float:
        """``½ Re(q_fᴴ M_near q_f)``: a mode's fluid kinetic energy within ``NEAR_RADIUS`` of
        mid-chord (units ``ρL²U∞²``), the fluid share of the mode labels (docs/model.md §7)."""
        return 0.5 * float(np.vdot(fluid, self.mff_near @ fluid).real)


def free_dof_indices(space) -> np.ndarray:
    """Indices of the fluid unknowns: free dofs of the space, in dof order."""
    return np.nonzero(np.array(list(space.FreeDofs()), dtype=bool))[0]


def full_dof_vector(
    lifting: np.ndarray, index: np.ndarray, q_solid: np.ndarray, q_fluid: np.ndarray
) -> np.ndarray:
    """The fluid state on every dof: ``q_fluid`` on the free dofs ``index``, the wall velocity
    ``u_Γ(q_s)`` through the ``lifting`` (:func:`wall_lifting_matrix`) on the wall's, zero on the
    inlet's and the sides' (docs/model.md §7)."""
    values = lifting @ wall_coefficients(q_solid)  # zero off the wall
    values[index] = q_fluid
    return values


def wall_lifting_matrix(steady: SteadyState) -> np.ndarray:
    """Dof vectors of ``ℓ_x, ℓ_y, ℓ_rot`` as columns (ndof × 3)."""
    liftings = wall_liftings(steady.space, steady.mesh)
    return np.column_stack([liftings[k].vec.FV().NumPy().copy() for k in RIGID_MOTIONS])


def sponge_coefficient(steady: SteadyState):
    """``σ(X)`` of the mesh's outlet sponge (:class:`fsistab.params.Sponge`) as an NGSolve
    coefficient function, or None without a sponge."""
    from ngsolve import IfPos, x

    spec = steady.mesh_spec
    if spec.sponge is None:
        return None
    shift = frame_offset(spec.body)  # the domain's mid-chord (-a about an elastic axis, §3.1)
    start, end = shift + spec.sponge.start(spec.domain), shift + spec.domain.downstream
    t = IfPos(x - start, (x - start) / (end - start), 0.0)  # 0 before the layer, 1 at the outlet
    sigma = spec.sponge.sigma_max * t * t * (3 - 2 * t)
    if spec.sponge.far_sigma > 0:
        sigma = sigma + far_layer(spec.sponge, spec.sizes, shift)
    return sigma


def _positive_part(value):
    from ngsolve import IfPos

    return IfPos(value, value, 0.0)


def _distance_outside(upstream: float, downstream: float, lateral: float, shift: float = 0.0):
    """Distance from ``(X, Y)`` to the box ``[shift - upstream, shift + downstream] × [-lateral,
    lateral]`` (0 inside). The square root is taken outside the box only: NGSolve linearises a form
    by automatic differentiation, and ``√r²`` at ``r² = 0`` gives ``∞ · 0 = NaN`` there (the time
    march's iteration matrix, :meth:`FluidResidual.linearisation`); the values are the same."""
    from ngsolve import IfPos, sqrt, x, y

    dx = _positive_part(shift - upstream - x) + _positive_part(x - shift - downstream)
    dy = _positive_part(y - lateral) + _positive_part(-y - lateral)
    squared = dx * dx + dy * dy
    return IfPos(squared, sqrt(squared), 0.0)


def far_layer(sponge, sizes, shift: float = 0.0):
    """``σ_far(X, Y)`` of the far-field layer (:class:`fsistab.params.Sponge`): 0 in the mesh's
    middle box and band (``sizes.middle_box``, ``middle_band``), rising by ``3t² − 2t³`` over
    ``far_ramp`` body lengths of distance from them to ``far_sigma``; ``shift``: the abscissa of
    the domain's mid-chord (:func:`fsistab.bodies.frame_offset`)."""
    from ngsolve import IfPos

    u, d, l = sizes.middle_box
    distance = _distance_outside(u, d, l, shift)
    if sizes.middle_band is not None:
        end, width = sizes.middle_band
        band = _distance_outside(0.0, end, width, shift)
        distance = IfPos(distance - band, band, distance)
    t = IfPos(sponge.far_ramp - distance, distance / sponge.far_ramp, 1.0)
    return sponge.far_sigma * t * t * (3 - 2 * t)


def rotation_target(steady: SteadyState):
    """``u_θ = (∇U⁰)(−Y, X) − e_z∧U⁰``: the steady field carried by a pitch ``δθ`` when the far
    field stays fixed in the laboratory, ``R(δθ)ᵀ U⁰(R(δθ) X) = U⁰ + δθ u_θ + O(δθ²)`` (docs/model.md §4,
    §7). In body axes the steady wake turns by ``−δθ`` when the body pitches, a perturbation growing
    like ``X δθ`` downstream that is kinematics, not shed vorticity: the sponge relaxes towards it."""
    from ngsolve import CF, Grad, x, y

    base = steady.velocity
    return Grad(base) * CF((-y, x)) - CF((-base[1], base[0]))


# ---------------------------------------------------------------------------------------------
# the terms of the fluid's momentum equation (docs/model.md §4) and of its linearisation (§7)


def _dot(a, b):
    """``a·b`` of two 2-vector CoefficientFunctions, without conjugation."""
    return a[0] * b[0] + a[1] * b[1]


def _total(parts):
    """The sum of the integrands that are not None, in order (None if there is none)."""
    total = None
    for part in parts:
        if part is not None:
            total = part if total is None else total + part
    return total


@dataclass(frozen=True)
class SteadyFields:
    """What the terms need of the steady state ``q⁰`` (docs/model.md §6): ``U⁰``, ``θ0``, ``Re⁻¹``, the
    grid velocity ``W⁰ = R(θ0)ᵀ(-1, 0)ᵀ`` and the sponge's ``σ(X)`` (None without a sponge)."""

    steady: SteadyState
    sigma: object

    @property
    def velocity(self):
        return self.steady.velocity

    @property
    def theta0(self) -> float:
        return self.steady.flow.theta0

    @property
    def inv_reynolds(self) -> float:
        return 1.0 / self.steady.flow.reynolds

    @property
    def grid_velocity(self):
        from ngsolve import CF

        return CF(wall_velocity(self.theta0))


def steady_fields(steady: SteadyState) -> SteadyFields:
    """The :class:`SteadyFields` of ``steady``, with the sponge of its mesh specification."""
    return SteadyFields(steady, sponge_coefficient(steady))


@dataclass(frozen=True)
class Motion:
    """The solid state ``(θ, ḣ, θ')`` as NGSolve parameters, for the nonlinear residual: the grid
    velocity ``W = R(θ)ᵀ(-1, ḣ)ᵀ + θ'(-Y, X)ᵀ`` of docs/model.md §4 (``h`` never enters the fluid)."""

    theta: object
    hdot: object
    thetadot: object

    @classmethod
    def at_rest(cls) -> Motion:
        from ngsolve import Parameter

        return cls(Parameter(0.0), Parameter(0.0), Parameter(0.0))

    def set(self, q_solid: np.ndarray) -> None:
        """Set the parameters to the solid state ``(h, θ, ḣ, θ')``."""
        self.theta.Set(q_solid[1])
        self.hdot.Set(q_solid[2])
        self.thetadot.Set(q_solid[3])

    @property
    def grid_velocity(self):
        from ngsolve import CF, cos, sin, x, y

        ct, st = cos(self.theta), sin(self.theta)
        return CF((-ct + st * self.hdot, st + ct * self.hdot)) + self.thetadot * CF((-y, x))


def motion_coefficients(q_solid: np.ndarray) -> np.ndarray:
    """``(1, W_x, W_y, θ')``: the weights with which the solid state ``(h, θ, ḣ, θ')`` enters the
    residual, affinely in the fluid state and in these (docs/model.md §4, §12): the grid velocity is
    ``W = (W_x, W_y) + θ'(-Y, X)`` with ``(W_x, W_y) = R(θ)ᵀ(-1, ḣ)`` (:attr:`Motion.grid_velocity`),
    and the frame's rotation ``θ' e_z∧U``."""
    ct, st = math.cos(q_solid[1]), math.sin(q_solid[1])
    return np.array([1.0, -ct + st * q_solid[2], st + ct * q_solid[2], q_solid[3]])


def grid_velocity_direction(theta0: float, state: str):
    """``∂W/∂q_s`` for ``state`` in ``("theta", "hdot", "thetadot")`` at ``ḣ = θ' = 0``: the uniform
    ``W_θ``, ``W_ḣ`` of :func:`grid_velocity_derivatives` and the rotation ``(-Y, X)`` (docs/model.md §7)."""
    from ngsolve import CF, x, y

    if state == "thetadot":
        return CF((-y, x))
    return CF(grid_velocity_derivatives(theta0)[state])


def grid_velocity_perturbation(theta0: float, q_solid: np.ndarray):
    """``ŵ = W_θ θ̂ + W_ḣ ḣ̂ + θ̂'(-Y, X)`` for a real solid perturbation ``(ĥ, θ̂, ḣ̂, θ̂')``
    (docs/model.md §7)."""
    from ngsolve import CF, x, y

    dw = grid_velocity_derivatives(theta0)
    z = q_solid
    return CF(tuple(dw["theta"][i] * z[1] + dw["hdot"][i] * z[2] for i in range(2))) + z[3] * CF((-y, x))


class Term:
    """One term of the fluid's momentum equation, ``R_f(q) = Σ terms`` (docs/model.md §4, §7), by its parts:

    * ``residual``: its integrand in the nonlinear residual, for the trial state ``(U, P)`` and the
      solid :class:`Motion` (the finite-difference checks of :class:`FluidResidual`): affine in the
      fluid state and in the weights of :func:`motion_coefficients`, but for its part of degree two
      in the fluid state, which is ``quadratic`` (the time march evaluates it so,
      :class:`fsistab.simulation.InertialFluidResidual`);
    * ``sources``: its parts that do not depend on the fluid state, as ``(weight(q_s), integrand of
      the test function)`` pairs, subtracted from the residual;
    * ``stiffness``, ``mass``: its integrands in ``J_ff`` and ``M_f`` at the steady state;
    * ``solid_column``: its explicit derivative with respect to ``θ``, ``ḣ`` or ``θ'`` (the fluid rows
      of the solid columns of ``J``, before the wall coupling);
    * ``base_variation``: the derivative of ``(v, J q)`` with respect to the steady velocity in the
      direction ``δ``, for the direct velocity ``u``, the test field ``v`` and a real solid
      perturbation ``q_s`` (the base-flow gradient of :mod:`fsistab.sensitivity`);
    * ``outlet``: an integrand over the outlet boundary, linear in the fluid state and independent
      of the solid's, hence the same in the residual, ``J_ff`` and ``K_ff(s)``.

    A part a term lacks is None. A new term (a PML, a forcing) is one subclass added to ``TERMS``:
    every operator, the residual and the base-flow gradient are sums over the terms. A term that is
    not part of the steady problem (:mod:`fsistab.steady`) must vanish at the steady state, whose
    loads ``loads0`` are the steady problem's reaction loads.
    """

    def residual(self, fields: SteadyFields, motion: Motion, trial, test):
        return None

    def quadratic(self, fields: SteadyFields, trial, test):
        return None

    def sources(self, fields: SteadyFields, v) -> list:
        return []

    def stiffness(self, fields: SteadyFields, trial, test):
        return None

    def mass(self, fields: SteadyFields, trial, test):
        return None

    def solid_column(self, fields: SteadyFields, state: str, v):
        return None

    def base_variation(self, fields: SteadyFields, delta, u, v, q_solid: np.ndarray):
        return None

    def outlet(self, fields: SteadyFields, trial, test):
        return None


class NavierStokes(Term):
    """Convection relative to the grid, stress and continuity, ``(∇U)(U − W) − ∇·σ(U, P)``, ``∇·U``
    (docs/model.md §4; :func:`fsistab.steady.momentum_form` and its linearisation): the grid
    velocity ``W`` carries the solid state, hence the shape derivatives ``-(∇U⁰) ∂W/∂q_s``."""

    def residual(self, fields, motion, trial, test):
        return momentum_form(*trial, *test, motion.grid_velocity, fields.inv_reynolds)

    def quadratic(self, fields, trial, test):
        """The convection ``((∇U)U, v)``."""
        from ngsolve import Grad, InnerProduct

        return InnerProduct(Grad(trial[0]) * trial[0], test[0])

    def stiffness(self, fields, trial, test):
        return momentum_linearisation(
            *trial, *test, fields.velocity, fields.grid_velocity, fields.inv_reynolds
        )

    def solid_column(self, fields, state, v):
        from ngsolve import Grad, InnerProduct

        return -InnerProduct(Grad(fields.velocity) * grid_velocity_direction(fields.theta0, state), v)

    def base_variation(self, fields, delta, u, v, q_solid):
        """``((∇u)δ + (∇δ)u − (∇δ)ŵ, v)``."""
        from ngsolve import Grad

        w = grid_velocity_perturbation(fields.theta0, q_solid)
        return _dot(Grad(u) * delta, v) + _dot(Grad(delta) * u, v) - _dot(Grad(delta) * w, v)


class TimeDerivative(Term):
    """``∂U/∂t``: the velocity mass ``(u, v)`` of ``M_f`` (docs/model.md §5, §7)."""

    def mass(self, fields, trial, test):
        from ngsolve import InnerProduct

        return InnerProduct(trial[0], test[0])


class FrameRotation(Term):
    """``θ' e_z∧U`` of the rotating body frame (docs/model.md §4): zero in ``J_ff`` (``θ'⁰ = 0``), the
    column ``(e_z∧U⁰, v)`` on ``θ'``."""

    def residual(self, fields, motion, trial, test):
        from ngsolve import CF, InnerProduct

        u = trial[0]
        return motion.thetadot * InnerProduct(CF((-u[1], u[0])), test[0])

    def solid_column(self, fields, state, v):
        from ngsolve import CF, InnerProduct

        if state != "thetadot":
            return None
        base = fields.velocity
        return InnerProduct(CF((-base[1], base[0])), v)

    def base_variation(self, fields, delta, u, v, q_solid):
        """``θ̂' (e_z∧δ, v)``."""
        from ngsolve import CF

        return q_solid[3] * _dot(CF((-delta[1], delta[0])), v)


class SpongeLayer(Term):
    """The outlet sponge and its far-field layer, ``σ (U − U⁰ − (θ − θ0) u_θ)``
    (:class:`fsistab.params.Sponge`, :func:`sponge_coefficient`): ``σ u`` in ``J_ff``, ``-σ u_θ`` on the
    ``θ`` column (its target turns with the body, :func:`rotation_target`); nothing without a sponge."""

    def residual(self, fields, motion, trial, test):
        from ngsolve import InnerProduct

        return None if fields.sigma is None else fields.sigma * InnerProduct(trial[0], test[0])

    def sources(self, fields, v):
        """``∫ σ U⁰·v`` and ``(θ − θ0) ∫ σ u_θ·v``, the sponge's target."""
        from ngsolve import InnerProduct

        if fields.sigma is None:
            return []
        theta0, sigma = fields.theta0, fields.sigma
        return [
            (lambda q_solid: 1.0, sigma * InnerProduct(fields.velocity, v)),
            (lambda q_solid: q_solid[1] - theta0, sigma * InnerProduct(rotation_target(fields.steady), v)),
        ]

    def stiffness(self, fields, trial, test):
        return self.residual(fields, None, trial, test)

    def solid_column(self, fields, state, v):
        from ngsolve import InnerProduct

        if fields.sigma is None or state != "theta":
            return None
        return -(fields.sigma * InnerProduct(rotation_target(fields.steady), v))

    def base_variation(self, fields, delta, u, v, q_solid):
        """``-θ̂ σ ((∇δ)(-Y, X) − e_z∧δ, v)``: the target ``θ̂ u_θ`` is linear in ``U⁰``."""
        from ngsolve import CF, Grad, x, y

        pitch = q_solid[1]
        if fields.sigma is None or pitch == 0:
            return None
        return -(pitch * fields.sigma * _dot(Grad(delta) * CF((-y, x)) - CF((-delta[1], delta[0])), v))


class GradientOutlet(Term):
    """The ``"gradient"`` outlet condition ``Re⁻¹(∇U)N − PN = 0`` (docs/model.md §4, "Outlet";
    :func:`fsistab.steady.outlet_form`), ``−Re⁻¹((∇u)ᵀN, v)`` on the outlet; nothing on the
    default ``"stress"`` outlet, the natural condition of :class:`NavierStokes`."""

    def outlet(self, fields, trial, test):
        if fields.steady.mesh_spec.outlet != "gradient":
            return None
        return outlet_form(trial[0], test[0], fields.inv_reynolds)


TERMS: tuple[Term, ...] = (NavierStokes(), TimeDerivative(), FrameRotation(), SpongeLayer(), GradientOutlet())


def stiffness_integrand(fields: SteadyFields, trial, test, terms=TERMS):
    """``J_ff``'s integrand, the sum of the terms' linearisations at the steady state (docs/model.md §7)."""
    return _total(term.stiffness(fields, trial, test) for term in terms)


def mass_integrand(fields: SteadyFields, trial, test, terms=TERMS):
    """``M_f``'s integrand (docs/model.md §7)."""
    return _total(term.mass(fields, trial, test) for term in terms)


def shifted_integrand(fields: SteadyFields, trial, test, shift, terms=TERMS):
    """``K_ff(s) = J_ff + s M_f``'s integrand, term by term (docs/model.md §7)."""

    def part(term):
        mass = term.mass(fields, trial, test)
        return _total([term.stiffness(fields, trial, test), None if mass is None else shift * mass])

    return _total(part(term) for term in terms)


def solid_column_integrand(fields: SteadyFields, state: str, v, terms=TERMS):
    """``∂R_f/∂q_s`` at fixed fluid dofs for ``state`` in ``("theta", "hdot", "thetadot")``: the
    explicit dependence of the residual on the solid state (docs/model.md §7), None if no term has one."""
    return _total(term.solid_column(fields, state, v) for term in terms)


def residual_integrand(fields: SteadyFields, motion: Motion, trial, test, terms=TERMS):
    """The nonlinear residual's integrand in the fluid state, for the solid :class:`Motion`
    (docs/model.md §4), without the terms' sources (:func:`residual_sources`)."""
    return _total(term.residual(fields, motion, trial, test) for term in terms)


def quadratic_integrand(fields: SteadyFields, trial, test, terms=TERMS):
    """The residual's part of degree two in the fluid state (docs/model.md §12): the rest of
    :func:`residual_integrand` is affine in it and in :func:`motion_coefficients`."""
    return _total(term.quadratic(fields, trial, test) for term in terms)


def outlet_integrand(fields: SteadyFields, trial, test, terms=TERMS):
    """The terms' integrand over the outlet (None if no term has one)."""
    return _total(term.outlet(fields, trial, test) for term in terms)


def integrals(volume, fields: SteadyFields, trial, test, terms=TERMS, compile: bool = True):
    """The form of the domain integrand ``volume`` (compiled unless ``compile`` is False) plus the
    terms' outlet integrand over the outlet (:func:`outlet_integrand`): what every bilinear form
    of the operators and the residual adds to its ``BilinearForm``."""
    from ngsolve import ds, dx

    form = (volume.Compile() if compile else volume) * dx
    boundary = outlet_integrand(fields, trial, test, terms)
    # on the skeleton: the trial function's gradient is that of the element beside the outlet
    return form if boundary is None else form + boundary * ds("outlet", skeleton=True)


def residual_sources(fields: SteadyFields, v, terms=TERMS) -> list:
    """The residual's parts independent of the fluid state, ``(weight(q_s), integrand)`` pairs."""
    return [source for term in terms for source in term.sources(fields, v)]


def base_flow_variation(fields: SteadyFields, delta, u, v, q_solid: np.ndarray, terms=TERMS):
    """``∂(v, J q)/∂U⁰`` in the direction ``δ`` (the test function of a linear form), for the direct
    velocity ``u`` (wall values of the solid motion included), the test field ``v`` and the real
    solid perturbation ``q_s = (ĥ, θ̂, ḣ̂, θ̂')``, summed over the terms (docs/model.md §7): the
    integrand of :func:`fsistab.sensitivity.base_flow_gradient`, one real part at a time."""
    return _total(term.base_variation(fields, delta, u, v, q_solid) for term in terms)


# ---------------------------------------------------------------------------------------------
# the assembled operators


def _solid_columns(fields: SteadyFields, terms=TERMS) -> np.ndarray:
    """The explicit solid columns ``(h, θ, ḣ, θ')`` of the residual's derivative (ndof × 4), one
    compiled linear form each (zero for ``h``, which never enters the fluid)."""
    space = fields.steady.space
    columns = [np.zeros(space.ndof)]
    for state in SOLID_STATE[1:]:
        columns.append(
            _linear_form_vector(
                space, lambda v, q, state=state: solid_column_integrand(fields, state, v, terms)
            )
        )
    return np.column_stack(columns)


def _bilinear_matrices(fields: SteadyFields, terms=TERMS) -> tuple[sp.csr_matrix, ...]:
    """``J_ff``, ``M_f`` and the near-body mass on the whole space, SciPy CSR (one assembly each)."""
    from ngsolve import BilinearForm, IfPos, dx, x, y

    space, n_all = fields.steady.space, fields.steady.space.ndof
    (u, p), (v, q) = space.TnT()
    jacobian = BilinearForm(space)
    # compiled: the sum of the terms assembles several times faster than uncompiled, the matrix
    # identical to the bit
    jacobian += integrals(stiffness_integrand(fields, (u, p), (v, q), terms), fields, (u, p), (v, q), terms)
    jacobian.Assemble()
    mass_term = mass_integrand(fields, (u, p), (v, q), terms)
    mass = BilinearForm(space)
    mass += mass_term * dx
    mass.Assemble()
    near = BilinearForm(space)
    # about mid-chord, whichever point of the section is the frame's origin (docs/model.md §3.1)
    centre = frame_offset(fields.steady.mesh_spec.body)
    along = x - centre if centre else x
    near += IfPos(NEAR_RADIUS**2 - along * along - y * y, 1.0, 0.0) * mass_term * dx
    near.Assemble()
    return tuple(_to_scipy(form.mat, n_all) for form in (jacobian, mass, near))


def fluid_operators(steady: SteadyState, terms=TERMS) -> FluidOperators:
    """Assemble every fluid block of docs/model.md §7 once at ``steady`` (one real assembly each): the
    sum of ``terms``, with the mesh's outlet sponge ``σ (u − θ u_θ)`` if it has one
    (:class:`fsistab.params.Sponge`), and the wall coupling of the solid state. The element loops
    run on every core (NGSolve's task manager), the blocks those of one thread to the bit: every
    command waits for them before its first factorisation (docs/performance.md, "The fluid
    operators"). Under :data:`fsistab.mesh.NGSOLVE_LOCK`: no other thread of the process may call
    NGSolve meanwhile."""
    from ngsolve import TaskManager

    with NGSOLVE_LOCK, TaskManager():
        return _fluid_operators(steady, terms)


def _fluid_operators(steady: SteadyState, terms) -> FluidOperators:
    fields = steady_fields(steady)
    theta0 = steady.flow.theta0
    a_all, m_all, near_all = _bilinear_matrices(fields, terms)
    explicit = _solid_columns(fields, terms)

    # wall coupling: u_Γ(q_s) = L a(q_s), so ∂u/∂q_s = L ∂a/∂q_s
    lifting = wall_lifting_matrix(steady)
    q0 = np.array([0.0, theta0, 0.0, 0.0])
    wall_columns = lifting @ wall_coefficients_jacobian(q0)  # ndof × 4
    j_all_s = a_all @ wall_columns + explicit
    m_all_s = m_all @ wall_columns

    index = free_dof_indices(steady.space)
    loads = reaction_loads(steady)
    lift_t = sp.csr_matrix(lifting.T)
    return FluidOperators(
        steady=steady,
        free_dofs=index,
        jff=a_all[index][:, index].tocsr(),
        mff=m_all[index][:, index].tocsr(),
        jfs=j_all_s[index],
        mfs=m_all_s[index],
        # the three load rows first, then their fluid columns: no copy of A's fluid columns
        load_f=-(lift_t @ a_all).tocsr()[:, index],
        load_s=-(lifting.T @ j_all_s),
        load_mass_f=-(lift_t @ m_all).tocsr()[:, index],
        load_mass_s=-(lifting.T @ m_all_s),
        loads0=np.array([loads["force_x"], loads["force_y"], loads["moment"]]),
        theta0=theta0,
        mff_near=near_all[index][:, index].tocsr(),
    )


def shifted_fluid_matrix(fluid: FluidOperators, shift: complex, terms=TERMS):
    """``K_ff(s) = J_ff + s M_f`` (docs/model.md §7) as NGSolve's assembled matrix on the whole space
    (real for a real ``s``) and the mask of the fluid unknowns, ``(form, free dofs)``: the form of
    :func:`fluid_operators`' ``jff`` and ``mff`` assembled in one pass in the arithmetic of ``s``,
    for a factorisation by NGSolve's sparse solvers (:class:`fsistab.linalg.FluidFactor`; SciPy's
    complex sparse matrices cannot be handed to them). The caller keeps ``form`` alive while it
    uses the matrix ``form.mat``."""
    from ngsolve import BilinearForm

    steady = fluid.steady
    shift = complex(shift)
    is_complex = shift.imag != 0
    space = taylor_hood_space(steady.mesh, complex=is_complex)
    (u, p), (v, q) = space.TnT()
    form = BilinearForm(space)
    value = shift if is_complex else shift.real
    fields = steady_fields(steady)
    integrand = shifted_integrand(fields, (u, p), (v, q), value, terms)
    form += integrals(integrand, fields, (u, p), (v, q), terms)  # as in fluid_operators
    form.Assemble()
    return form, space.FreeDofs()


class FluidResidual:
    """The discrete nonlinear fluid residual ``R_f(q_s, q_f)`` and reaction loads (docs/model.md §5).

    For finite-difference checks of every block of :func:`fluid_operators`: the sum of the same
    ``terms``' residuals. The wall dofs are set from the solid state by the nonlinear lifting, the
    grid velocity is ``W = R(θ)ᵀ(-1, ḣ)ᵀ + θ'(-Y, X)ᵀ`` and the rotation term ``θ' e_z∧U`` is
    included; with a sponge, ``σ (U − U⁰ − (θ − θ0) u_θ)`` (its target, the steady field turned with
    the body to first order, :func:`rotation_target`; zero at the steady state).
    """

    def __init__(self, steady: SteadyState, terms=TERMS):
        from ngsolve import BilinearForm

        self.steady = steady
        space = steady.space
        (u, p), (v, q) = space.TnT()
        fields = steady_fields(steady)
        self.motion = Motion.at_rest()
        form = BilinearForm(space)
        integrand = residual_integrand(fields, self.motion, (u, p), (v, q), terms)
        form += integrals(integrand, fields, (u, p), (v, q), terms, compile=False)
        self.form = form
        # the parts independent of the fluid state as (weight(q_s), load vector) pairs
        self._sources = [
            (weight, _linear_form_vector(space, lambda v, q, integrand=integrand: integrand))
            for weight, integrand in residual_sources(fields, v, terms)
        ]
        self.lifting = wall_lifting_matrix(steady)
        self.index = free_dof_indices(space)
        self._vector = steady.state.vec.CreateVector()
        self._residual = steady.state.vec.CreateVector()

    def full_state(self, q_solid: np.ndarray, q_fluid: np.ndarray) -> np.ndarray:
        return full_dof_vector(self.lifting, self.index, q_solid, q_fluid)

    def __call__(self, q_solid: np.ndarray, q_fluid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(R_f on the free dofs, loads (F_x, F_y, M) = -ℓᵀ R)`` for solid state ``(h, θ, ḣ, θ')``."""
        return self.rows_and_loads(q_solid, self.state_residual(q_solid, self.full_state(q_solid, q_fluid)))

    def rows_and_loads(self, q_solid: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(free-dof rows, -ℓᵀ R)`` of the residual ``r`` on every dof, its sources subtracted."""
        for weight, vector in self._sources:
            r = r - weight(q_solid) * vector
        return r[self.index].copy(), -(self.lifting.T @ r)

    def state_residual(self, q_solid: np.ndarray, values: np.ndarray) -> np.ndarray:
        """The residual's form on every dof at the full dof vector ``values`` and the solid state
        ``q_solid``, without the sources (a view, overwritten by the next call)."""
        self.motion.set(q_solid)
        self._vector.FV().NumPy()[:] = values
        self.form.Apply(self._vector, self._residual)
        return self._residual.FV().NumPy()

    def linearisation(self, q_solid: np.ndarray, values: np.ndarray) -> sp.csr_matrix:
        """``∂R_f/∂U`` on every dof at the full dof vector ``values`` and the solid state ``q_solid``
        (SciPy CSR): NGSolve's linearisation of the residual's form, so with the current grid
        velocity ``W(θ, ḣ, θ')`` and rotation term ``θ' e_z∧u`` (docs/model.md §4), which ``J_ff``
        at the steady state lacks (there ``θ' = ḣ = 0``): the time march's rebuilt iteration matrix."""
        self.motion.set(q_solid)
        self._vector.FV().NumPy()[:] = values
        self.form.AssembleLinearization(self._vector)
        return _to_scipy(self.form.mat, self.steady.space.ndof)

    def steady_point(self) -> tuple[np.ndarray, np.ndarray]:
        """The steady state as ``(q_s⁰, q_f⁰)``."""
        q_solid = np.array([0.0, self.steady.flow.theta0, 0.0, 0.0])
        return q_solid, self.steady.state.vec.FV().NumPy()[self.index].copy()
