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
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from fsistab.forces import RIGID_MOTIONS, reaction_loads, wall_liftings
from fsistab.steady import (
    SteadyState,
    momentum_form,
    momentum_linearisation,
    taylor_hood_space,
    wall_velocity,
)

SOLID_STATE = ("h", "theta", "hdot", "thetadot")
NEAR_RADIUS = 1.0  # body lengths around G


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
    * ``mff_near``: velocity mass restricted to the disc ``|X| < NEAR_RADIUS`` (to label modes:
      global wake modes grow downstream, so whole-domain energies say little about the body).
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
    # UMFPACK symbolic analyses of J_ff + s M_f by arithmetic (float, complex): the pattern is the
    # same at every shift, so the analysis is made once per operators (fsistab.linalg.FluidFactor)
    analyses: dict = field(default_factory=dict, compare=False, repr=False)

    @property
    def n_fluid(self) -> int:
        return int(self.jff.shape[0])

    @property
    def reynolds(self) -> float:
        return self.steady.flow.reynolds


def free_dof_indices(space) -> np.ndarray:
    """Indices of the fluid unknowns: free dofs of the space, in dof order."""
    return np.nonzero(np.array(list(space.FreeDofs()), dtype=bool))[0]


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
    start, end = spec.sponge.start(spec.domain), spec.domain.downstream
    t = IfPos(x - start, (x - start) / (end - start), 0.0)  # 0 before the layer, 1 at the outlet
    sigma = spec.sponge.sigma_max * t * t * (3 - 2 * t)
    if spec.sponge.far_sigma > 0:
        sigma = sigma + far_layer(spec.sponge, spec.sizes)
    return sigma


def _positive_part(value):
    from ngsolve import IfPos

    return IfPos(value, value, 0.0)


def _distance_outside(upstream: float, downstream: float, lateral: float):
    """Distance from ``(X, Y)`` to the box ``[-upstream, downstream] × [-lateral, lateral]`` (0 inside)."""
    from ngsolve import sqrt, x, y

    dx = _positive_part(-upstream - x) + _positive_part(x - downstream)
    dy = _positive_part(y - lateral) + _positive_part(-y - lateral)
    return sqrt(dx * dx + dy * dy)


def far_layer(sponge, sizes):
    """``σ_far(X, Y)`` of the far-field layer (:class:`fsistab.params.Sponge`): 0 in the mesh's
    middle box and band (``sizes.middle_box``, ``middle_band``), rising by ``3t² − 2t³`` over
    ``far_ramp`` body lengths of distance from them to ``far_sigma``."""
    from ngsolve import IfPos

    u, d, l = sizes.middle_box
    distance = _distance_outside(u, d, l)
    if sizes.middle_band is not None:
        end, width = sizes.middle_band
        band = _distance_outside(0.0, end, width)
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


def _with_sponge(sigma, integrand, u, v):
    """``integrand + σ u·v``, the sponge's part of the linearised momentum equation added (the
    integrand itself without a sponge, ``sigma`` None)."""
    from ngsolve import InnerProduct

    return integrand if sigma is None else integrand + sigma * InnerProduct(u, v)


def fluid_operators(steady: SteadyState) -> FluidOperators:
    """Assemble every fluid block of docs/model.md §7 once at ``steady`` (one real assembly each), with
    the mesh's outlet sponge ``σ (u − θ u_θ)`` if it has one (:class:`fsistab.params.Sponge`)."""
    from ngsolve import CF, BilinearForm, Grad, IfPos, InnerProduct, dx, x, y

    space, n_all = steady.space, steady.space.ndof
    theta0 = steady.flow.theta0
    base = steady.velocity
    grid_velocity = CF(wall_velocity(theta0))
    (u, p), (v, q) = space.TnT()
    sigma = sponge_coefficient(steady)

    jacobian = BilinearForm(space)
    linearisation = momentum_linearisation(u, p, v, q, base, grid_velocity, 1.0 / steady.flow.reynolds)
    # compiled: the sum of the linearisation and the sponge's term assembles several times faster
    # than uncompiled, the matrix identical to the bit
    jacobian += _with_sponge(sigma, linearisation, u, v).Compile() * dx
    jacobian.Assemble()
    mass = BilinearForm(space)
    mass += InnerProduct(u, v) * dx
    mass.Assemble()
    near = BilinearForm(space)
    near += IfPos(NEAR_RADIUS**2 - x * x - y * y, 1.0, 0.0) * InnerProduct(u, v) * dx
    near.Assemble()
    a_all, m_all = _to_scipy(jacobian.mat, n_all), _to_scipy(mass.mat, n_all)

    # shape derivatives: the residual's explicit dependence on (θ, ḣ, θ') through W and θ' e_z∧U
    dw = grid_velocity_derivatives(theta0)

    def theta_column(v, q):
        term = -InnerProduct(Grad(base) * CF(dw["theta"]), v)
        if sigma is not None:  # the sponge's target turns with the body: -σ u_θ
            term = term - sigma * InnerProduct(rotation_target(steady), v)
        return term

    d_theta = _linear_form_vector(space, theta_column)
    d_hdot = _linear_form_vector(space, lambda v, q: -InnerProduct(Grad(base) * CF(dw["hdot"]), v))
    d_thetadot = _linear_form_vector(
        space,
        lambda v, q: -InnerProduct(Grad(base) * CF((-y, x)), v) + InnerProduct(CF((-base[1], base[0])), v),
    )
    explicit = np.column_stack([np.zeros(n_all), d_theta, d_hdot, d_thetadot])

    # wall coupling: u_Γ(q_s) = L a(q_s), so ∂u/∂q_s = L ∂a/∂q_s
    lifting = wall_lifting_matrix(steady)
    q0 = np.array([0.0, theta0, 0.0, 0.0])
    wall_columns = lifting @ wall_coefficients_jacobian(q0)  # ndof × 4
    j_all_s = a_all @ wall_columns + explicit
    m_all_s = m_all @ wall_columns

    index = free_dof_indices(space)
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
        mff_near=_to_scipy(near.mat, n_all)[index][:, index].tocsr(),
    )


def shifted_fluid_matrix(fluid: FluidOperators, shift: complex):
    """``K_ff(s) = J_ff + s M_f`` (docs/model.md §7) as NGSolve's assembled matrix on the whole space
    (real for a real ``s``) and the mask of the fluid unknowns, ``(form, free dofs)``: the form of
    :func:`fluid_operators`' ``jff`` and ``mff`` assembled in one pass in the arithmetic of ``s``,
    for a factorisation by NGSolve's sparse solvers (:class:`fsistab.linalg.FluidFactor`; SciPy's
    complex sparse matrices cannot be handed to them). The caller keeps ``form`` alive while it
    uses the matrix ``form.mat``."""
    from ngsolve import CF, BilinearForm, InnerProduct, dx

    steady = fluid.steady
    shift = complex(shift)
    is_complex = shift.imag != 0
    space = taylor_hood_space(steady.mesh, complex=is_complex)
    (u, p), (v, q) = space.TnT()
    grid_velocity = CF(wall_velocity(fluid.theta0))
    form = BilinearForm(space)
    value = shift if is_complex else shift.real
    linearisation = momentum_linearisation(
        u, p, v, q, steady.velocity, grid_velocity, 1.0 / steady.flow.reynolds
    )
    integrand = _with_sponge(sponge_coefficient(steady), linearisation + value * InnerProduct(u, v), u, v)
    form += integrand.Compile() * dx  # as in fluid_operators
    form.Assemble()
    return form, space.FreeDofs()


class FluidResidual:
    """The discrete nonlinear fluid residual ``R_f(q_s, q_f)`` and reaction loads (docs/model.md §5).

    For finite-difference checks of every block of :func:`fluid_operators`: the wall dofs are set
    from the solid state by the nonlinear lifting, the grid velocity is
    ``W = R(θ)ᵀ(-1, ḣ)ᵀ + θ'(-Y, X)ᵀ`` and the rotation term ``θ' e_z∧U`` is included; with a
    sponge, ``σ (U − U⁰ − (θ − θ0) u_θ)`` (its target, the steady field turned with the body to first
    order, :func:`rotation_target`; zero at the steady state).
    """

    def __init__(self, steady: SteadyState):
        from ngsolve import CF, BilinearForm, InnerProduct, Parameter, cos, dx, sin, x, y

        self.steady = steady
        space = steady.space
        (u, p), (v, q) = space.TnT()
        self.theta, self.hdot, self.thetadot = Parameter(0.0), Parameter(0.0), Parameter(0.0)
        ct, st = cos(self.theta), sin(self.theta)
        grid_velocity = CF((-ct + st * self.hdot, st + ct * self.hdot)) + self.thetadot * CF((-y, x))
        form = BilinearForm(space)
        residual = momentum_form(u, p, v, q, grid_velocity, 1.0 / steady.flow.reynolds)
        sigma = sponge_coefficient(steady)
        form += _with_sponge(sigma, residual + self.thetadot * InnerProduct(CF((-u[1], u[0])), v), u, v) * dx
        self.form = form
        # the sponge's target as load vectors ∫ σ U⁰·v and ∫ σ u_θ·v (None without a sponge)
        self._target = (
            None
            if sigma is None
            else [
                _linear_form_vector(space, lambda v, q, f=field: sigma * InnerProduct(f, v))
                for field in (steady.velocity, rotation_target(steady))
            ]
        )
        self.lifting = wall_lifting_matrix(steady)
        self.index = free_dof_indices(space)
        self._vector = steady.state.vec.CreateVector()
        self._residual = steady.state.vec.CreateVector()

    def full_state(self, q_solid: np.ndarray, q_fluid: np.ndarray) -> np.ndarray:
        values = self.lifting @ wall_coefficients(q_solid)  # zero off the wall
        values[self.index] = q_fluid
        return values

    def __call__(self, q_solid: np.ndarray, q_fluid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(R_f on the free dofs, loads (F_x, F_y, M) = -ℓᵀ R)`` for solid state ``(h, θ, ḣ, θ')``."""
        self.theta.Set(q_solid[1])
        self.hdot.Set(q_solid[2])
        self.thetadot.Set(q_solid[3])
        self._vector.FV().NumPy()[:] = self.full_state(q_solid, q_fluid)
        self.form.Apply(self._vector, self._residual)
        r = self._residual.FV().NumPy()
        if self._target is not None:
            r = r - self._target[0] - (q_solid[1] - self.steady.flow.theta0) * self._target[1]
        return r[self.index].copy(), -(self.lifting.T @ r)

    def steady_point(self) -> tuple[np.ndarray, np.ndarray]:
        """The steady state as ``(q_s⁰, q_f⁰)``."""
        q_solid = np.array([0.0, self.steady.flow.theta0, 0.0, 0.0])
        return q_solid, self.steady.state.vec.FV().NumPy()[self.index].copy()
