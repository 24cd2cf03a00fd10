"""Adjoint modes and the sensitivity of eigenvalues and thresholds to every parameter (docs/model.md §5–§8).

**Adjoint mode.** For a simple eigenpair ``(σ, q)`` of ``σ M q + J q = 0`` (docs/model.md §7, (E)) the
adjoint mode ``q†`` solves ``(J + σM)ᴴ q† = 0``, normalised so that ``q†ᴴ M q = 1``. It is the
left eigenvector of the discrete problem: its fluid part holds the coefficients of the adjoint
velocity and pressure in the same finite-element basis (discretise-then-adjoint), so that
``q†ᴴ M q = ∫ ū†·û`` and the pointwise product ``‖û(x)‖‖û†(x)‖`` is the structural sensitivity of
Giannetti & Luchini (2007). ``q†`` is found by inverse iteration with the *adjoint* of the
factorisation already made for the direct problem at a shift ``s``:

    x ← (J + sM)⁻ᴴ Mᴴ x,     eigenvalue ``conj(1/(s − σ))``, converging at the rate ``|s − σ|/|s − σ'|``

(``σ'`` the next eigenvalue from ``s``). The coupled matrix is bordered as in :mod:`fsistab.linalg`:
with ``K = J + sM`` and ``Y = K_ff⁻ᴴ K_sfᴴ`` (``n_s`` adjoint fluid solves once per factorisation),

    x_s = (K_ssᴴ − K_fsᴴ Y)⁻¹ (b_s − K_fsᴴ z),   x_f = z − Y x_s,   z = K_ff⁻ᴴ b_f

so an adjoint solve costs one back-substitution with the transposed UMFPACK factors
(:meth:`fsistab.umfpack.LU.solve` ``transpose=True``) — no new factorisation.

**Eigenvalue derivative.** Differentiating ``(J + σM) q = 0`` and projecting on ``q†``,

    dσ/dp = −q†ᴴ (∂J/∂p + σ ∂M/∂p) q / (q†ᴴ M q)                                      (S1)

For the solid parameters ``p ∈ {m, U*, Ω, ζ_h, ζ_θ, r_θ}`` only the solid rows move (docs/model.md §3,
§7): their aerodynamic part scales with ``1/m`` (the pitch row with ``1/(m r_θ²)``), their in-vacuo
part is ``(Ω/U*)² h + 2ζ_h(Ω/U*) ḣ`` and ``(1/U*)² θ + 2ζ_θ(1/U*) θ'``. ``Re`` and ``α0`` move the
steady state too (docs/model.md §6): ``dJ/dp = ∂J/∂p + ∂J/∂q⁰ · dq⁰/dp`` with the steady tangent

    J_ff dq⁰_f/dp = −∂R_f/∂p                                                           (S2)

(``J_ff`` is the steady Jacobian — the fluid block at ``σ = 0``; for ``α0`` the right-hand side
is the ``θ`` column of ``J_fs``, the wall velocity included). The operators' derivative along
``(p, q⁰)`` is a central difference of :func:`fsistab.operators.fluid_operators` re-assembled at
``(p ± t, q⁰ ± t dq⁰/dp)``: every operator is a polynomial of degree at most two in
``(1/Re, q⁰)`` (the convective terms are linear in ``U⁰``, the steady loads quadratic), so the
difference in ``1/Re`` is exact up to rounding; in ``α0`` (step 10⁻³ degree) the rotation
matrices leave an ``O(t²)`` error (on the plate at α0 = 2°, dσ/dα0 moved by 1.5e-7 relative from
a step of 10⁻² to 10⁻³ degree, so about 1.5e-9 remains).

**Threshold derivative.** On a neutral point ``Re σ(U*_c; p) = 0`` (docs/model.md §8), by the implicit
function theorem,

    dU*_c/dp = −Re(∂σ/∂p) / Re(∂σ/∂U*),     dω_c/dp = Im(∂σ/∂p) + Im(∂σ/∂U*) dU*_c/dp      (S3)

both derivatives from (S1) with the critical mode and its adjoint at ``σ = iω_c``.

**Spatial maps** (Marquet, Sipp & Jacquin 2008). A steady force ``δf`` added to the steady
equations, ``R_f(q⁰) = (δf, φ)``, moves ``σ`` by

    δσ = ∫ δf·S_f dx,     S_f = Σ_j s_j φ_j,     s = −J_ff⁻ᵀ g / (q†ᴴ M q),   g_k = ∂(q†ᴴ J q)/∂q⁰_k      (S4)

(one transposed solve with the real factors of ``J_ff``: the steady adjoint). A small control
cylinder at ``x₀`` adds its drag ``−k|U_r|U_r`` (``k = C_d d/2``) to the steady flow and its
linearisation to the perturbation; :func:`sensitivity_maps` gives both, with the structural
sensitivity, as fields; for a threshold, ``δU*_c = −Re δσ / Re ∂σ/∂U*`` (S3).
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp

from fsistab.coupled import CoupledSystem, solid_blocks, solid_mass, solid_stiffness, stiffness_derivative
from fsistab.errors import ConvergenceError, InputError
from fsistab.linalg import FactorCounter, FluidFactor
from fsistab.operators import FluidOperators, fluid_operators
from fsistab.params import Flow, Solid

SOLID_PARAMETERS = ("mass_ratio", "reduced_velocity", "freq_ratio", "zeta_h", "zeta_theta", "r_theta")
FLOW_PARAMETERS = ("reynolds", "alpha0")
PARAMETERS = FLOW_PARAMETERS + SOLID_PARAMETERS
UNITS = {
    "reynolds": "1",
    "alpha0": "degree",
    "mass_ratio": "1",
    "reduced_velocity": "1",
    "freq_ratio": "1",
    "zeta_h": "1",
    "zeta_theta": "1",
    "r_theta": "L",
}
ALPHA0_STEP_DEG = 1e-3  # central difference of the operators in α0 (module doc): O(t²) error ~1e-9
INVERSE_RE_STEP = 1e-2  # relative step in 1/Re: the operators are quadratic along it, exact


def _check_parameters(parameters: Iterable[str]) -> tuple[str, ...]:
    parameters = tuple(parameters)
    unknown = [p for p in parameters if p not in PARAMETERS]
    if unknown:
        raise InputError(f"unknown parameter(s) {', '.join(unknown)}: choose among {', '.join(PARAMETERS)}")
    return parameters


# ---------------------------------------------------------------------------------------------
# adjoint solves and adjoint modes


class AdjointSolver:
    """Solves ``(J + sM)ᴴ x = b`` for a coupled system by the bordered elimination of the module
    doc, with the transposed factors of ``fluid_factor`` (made here if not given: one
    factorisation; UMFPACK's conjugate-transpose solve, which the NGSolve backend refuses). Setup:
    ``n_s`` adjoint fluid solves; each :meth:`solve`: one."""

    def __init__(
        self,
        system: CoupledSystem,
        shift: complex,
        fluid_factor: FluidFactor | None = None,
        counter: FactorCounter | None = None,
    ):
        shift = complex(shift)
        value = shift.real if shift.imag == 0 else shift
        if fluid_factor is None:
            fluid_factor = FluidFactor(system.fluid, shift, counter)
        elif fluid_factor.shift != shift:
            raise InputError("the fluid factorisation was made for another shift")
        self.system, self.shift, self.fluid_factor = system, shift, fluid_factor
        if system.n_solid:
            ksf_h = (system.jsf + value * system.msf).conj().T.toarray()  # n_f × n_s
            self._kfs_h = np.conj(system.jfs + value * system.mfs).T  # n_s × n_f
            self._y = fluid_factor.solve(ksf_h, transpose=True)
            schur_h = np.conj(system.jss + value * system.mss).T - self._kfs_h @ self._y
            self._schur_h = np.linalg.inv(schur_h)

    def solve(self, b: np.ndarray, refine: bool = True) -> np.ndarray:
        """``(J + sM)⁻ᴴ b``."""
        ns = self.system.n_solid
        z = self.fluid_factor.solve(b[ns:], refine, transpose=True)
        if not ns:
            return z
        x_s = self._schur_h @ (b[:ns] - self._kfs_h @ z)
        return np.concatenate([x_s, z - self._y @ x_s])


@dataclass(frozen=True)
class AdjointMode:
    """A direct eigenpair ``(σ, q)`` with its adjoint ``q†``: ``(J + σM)ᴴ q† = 0``, ``q†ᴴ M q = 1``.

    ``residual`` is ``‖(J + σM)ᴴ q†‖ / ‖q†‖`` and ``direct_residual`` ``‖(J + σM) q‖ / ‖q‖``
    (2-norms) at the given ``value``; ``rayleigh`` the two-sided Rayleigh quotient
    ``σ_R = −q†ᴴ J q / q†ᴴ M q`` (error quadratic in the vectors' errors) and
    ``rayleigh_residual`` ``‖(J + σ_R M)ᴴ q†‖ / ‖q†‖``, which measures the adjoint vector alone.
    ``iterations``: the inverse-iteration steps (one adjoint solve each) from the factorisation
    at ``shift``; ``seconds`` their cost (the solver's setup included).
    """

    value: complex
    direct: np.ndarray
    adjoint: np.ndarray
    residual: float
    direct_residual: float
    rayleigh: complex
    rayleigh_residual: float
    iterations: int
    shift: complex
    seconds: float = field(default=0.0, compare=False)

    @property
    def condition(self) -> float:
        """``‖q‖ ‖q†‖ / |q†ᴴ M q|``: the eigenvalue's condition number (2-norms), large for the
        non-normal wake modes."""
        return float(np.linalg.norm(self.direct) * np.linalg.norm(self.adjoint))


def adjoint_residual(system: CoupledSystem, sigma: complex, adjoint: np.ndarray) -> float:
    """``‖(J + σM)ᴴ q†‖ / ‖q†‖``."""
    r = system.jacobian.conj().T @ adjoint + np.conj(sigma) * (system.mass.conj().T @ adjoint)
    return float(np.linalg.norm(r) / np.linalg.norm(adjoint))


def _direct_residual(system: CoupledSystem, sigma: complex, vector: np.ndarray) -> float:
    r = system.jacobian @ vector + sigma * (system.mass @ vector)
    return float(np.linalg.norm(r) / np.linalg.norm(vector))


def adjoint_mode(
    system: CoupledSystem,
    value: complex,
    direct: np.ndarray,
    *,
    solver: AdjointSolver | None = None,
    deflate: Sequence[AdjointMode] = (),
    tol: float = 1e-10,
    maxit: int = 40,
    counter: FactorCounter | None = None,
) -> AdjointMode:
    """The adjoint of the eigenpair ``(value, direct)`` by inverse iteration with ``solver`` (the
    adjoint of a factorisation at a shift near ``value``; by default one made at ``value``
    itself, where a step or two suffice), normalised to ``q†ᴴ M q = 1``.

    Known pairs in ``deflate`` (adjoint modes of eigenvalues nearer the shift) are projected out
    of each iterate, ``x ← x − Σ_j q†_j (q_jᴴ Mᴴ x)``, so that the iteration can reach a mode
    that is not the nearest to the shift. Converged when ``‖(J + σ_R M)ᴴ q†‖/‖q†‖ < tol`` at the
    two-sided Rayleigh quotient ``σ_R``; raises ConvergenceError after ``maxit`` steps or if
    ``σ_R`` is not ``value`` (within ``1e-6 (1 + |σ|)``: the iteration found another mode).
    """
    value = complex(value)
    direct = np.asarray(direct, dtype=complex)
    if direct.shape != (system.size,):
        raise InputError(f"the direct mode has shape {direct.shape}, the system size {system.size}")
    if maxit < 1:
        raise InputError(f"the inverse iteration needs at least one step, got maxit = {maxit}")
    t0 = time.perf_counter()
    if solver is None:
        solver = AdjointSolver(system, value, counter=counter)
    jacobian, mass = system.jacobian, system.mass
    mass_h = mass.conj().T.tocsr()
    j_q, m_q = jacobian @ direct, mass @ direct
    x = m_q.copy()  # overlaps q† (q†ᴴ M q ≠ 0 for a simple eigenvalue)
    iterations = 0
    while True:
        iterations += 1
        x = solver.solve(mass_h @ x)
        for other in deflate:
            x = x - other.adjoint * np.vdot(other.direct, mass_h @ x)
        x /= np.linalg.norm(x)
        rayleigh = complex(-np.vdot(x, j_q) / np.vdot(x, m_q))
        rayleigh_residual = adjoint_residual(system, rayleigh, x)
        if rayleigh_residual < tol:
            break
        if iterations >= maxit:
            raise ConvergenceError(
                f"the adjoint of the eigenvalue {value:.6g} did not converge by inverse iteration from "
                f"the shift {solver.shift:.4g} (residual {rayleigh_residual:.1e} after {maxit} steps); "
                "factorise closer to the eigenvalue"
            )
    if abs(rayleigh - value) > 1e-6 * (1 + abs(value)):
        raise ConvergenceError(
            f"the inverse iteration for the adjoint of {value:.6g} found the eigenvalue {rayleigh:.6g}: "
            "factorise closer to the eigenvalue or deflate the modes nearer the shift"
        )
    x = x / np.conj(np.vdot(x, m_q))  # q†ᴴ M q = 1
    return AdjointMode(
        value,
        direct,
        x,
        adjoint_residual(system, value, x),
        _direct_residual(system, value, direct),
        rayleigh,
        rayleigh_residual,
        iterations,
        solver.shift,
        time.perf_counter() - t0,
    )


def adjoint_modes(
    system: CoupledSystem,
    pairs: Sequence,
    *,
    fluid_factors: dict[complex, FluidFactor] | None = None,
    counter: FactorCounter | None = None,
    tol: float = 1e-10,
    maxit: int = 40,
) -> list[AdjointMode]:
    """Adjoints of eigenpairs of :func:`fsistab.eigen.eigenpairs_near` (``value``, ``vector``,
    ``shift``), in the order of ``pairs``.

    At each Arnoldi shift (its factorisation from ``fluid_factors`` when given, else made once)
    the pairs are taken nearest first, each deflated of the ones before (:func:`adjoint_mode`):
    Arnoldi's eigenvalues are the nearest to the shift, so the iteration for ``σ_k`` converges to
    its own mode, at the rate ``|s − σ_k|/|s − σ_{k+1}|``. Where that is too slow (``maxit``
    steps) the mode gets a factorisation at its own eigenvalue (``AdjointMode.shift`` says which).
    """
    out: dict[int, AdjointMode] = {}
    by_shift: dict[complex, list[int]] = {}
    for i, pair in enumerate(pairs):
        by_shift.setdefault(complex(pair.shift), []).append(i)
    for shift, indices in by_shift.items():
        factor = (fluid_factors or {}).get(shift)
        solver = AdjointSolver(system, shift, fluid_factor=factor, counter=counter)
        done: list[AdjointMode] = []
        for i in sorted(indices, key=lambda i: abs(complex(pairs[i].value) - shift)):
            value, vector = pairs[i].value, pairs[i].vector
            try:
                mode = adjoint_mode(system, value, vector, solver=solver, deflate=done, tol=tol, maxit=maxit)
            except ConvergenceError:
                mode = adjoint_mode(system, value, vector, tol=tol, maxit=maxit, counter=counter)
            done.append(mode)
            out[i] = mode
    return [out[i] for i in range(len(pairs))]


def biorthogonality(system: CoupledSystem, modes: Sequence[AdjointMode]) -> np.ndarray:
    """``B_jk = |q†_jᴴ M q_k| / (‖Mᴴ q†_j‖ ‖q_k‖)``: zero off the diagonal for distinct
    eigenvalues (``(σ_j − σ_k) q†_jᴴ M q_k = 0``), the cosine of the angle between ``Mᴴq†_k`` and
    ``q_k`` on it (a small value flags an ill-conditioned eigenvalue)."""
    mass = system.mass
    n = len(modes)
    out = np.empty((n, n))
    for j, a in enumerate(modes):
        ma = mass.conj().T @ a.adjoint
        for k, d in enumerate(modes):
            out[j, k] = abs(np.vdot(ma, d.direct)) / (np.linalg.norm(ma) * np.linalg.norm(d.direct))
    return out


# ---------------------------------------------------------------------------------------------
# fields of the fluid part: where a mode lives, structural sensitivity


def _fluid_field(fluid: FluidOperators, values: np.ndarray):
    """A real GridFunction on the steady state's space with ``values`` on the fluid unknowns."""
    from ngsolve import GridFunction

    field_ = GridFunction(fluid.steady.space)
    vector = np.zeros(fluid.steady.space.ndof)
    vector[fluid.free_dofs] = values
    field_.vec.FV().NumPy()[:] = vector
    return field_


def velocity_magnitude(fluid: FluidOperators, fluid_vector: np.ndarray, points: np.ndarray) -> np.ndarray:
    """``‖û(x)‖ = (|û_x|² + |û_y|²)^½`` of a complex fluid vector at ``points`` (N × 2, in the
    fluid domain), the velocity on the wall dofs taken as zero (the fluid unknowns only)."""
    points = np.asarray(points, dtype=float)
    mesh = fluid.steady.mesh
    mapped = mesh(points[:, 0], points[:, 1])
    total = np.zeros(len(points))
    for part in (fluid_vector.real, fluid_vector.imag):
        values = np.asarray(_fluid_field(fluid, part).components[0](mapped)).reshape(len(points), 2)
        total += np.sum(values**2, axis=1)
    return np.sqrt(total)


def structural_sensitivity(fluid: FluidOperators, mode: AdjointMode, points: np.ndarray) -> np.ndarray:
    """``S(x) = ‖û†(x)‖ ‖û(x)‖`` at ``points`` (Giannetti & Luchini 2007), ``q†ᴴ M q = 1``: where
    a localised feedback (a change of the linear operator concentrated at ``x``) moves ``σ``
    most, ``|δσ| ≤ S(x) ‖δ‖``. Fluid parts of the coupled vectors (solid states first)."""
    n = fluid.n_fluid
    return velocity_magnitude(fluid, mode.adjoint[-n:], points) * velocity_magnitude(
        fluid, mode.direct[-n:], points
    )


def energy_centroid(fluid: FluidOperators, fluid_vector: np.ndarray) -> tuple[float, float]:
    """``(∫X|û|², ∫Y|û|²) / ∫|û|²`` of a fluid vector (wall dofs zero): where the mode's kinetic
    energy lies."""
    from ngsolve import BilinearForm, InnerProduct, dx, x, y

    space = fluid.steady.space
    (u, _), (v, _) = space.TnT()
    index = fluid.free_dofs
    moments = []
    for weight in (x, y):
        form = BilinearForm(space)
        form += weight * InnerProduct(u, v) * dx
        form.Assemble()
        rows, cols, values = form.mat.COO()
        matrix = sp.csr_matrix(
            (np.asarray(values), (np.asarray(rows), np.asarray(cols))), shape=2 * (space.ndof,)
        )
        moments.append(np.vdot(fluid_vector, matrix[index][:, index] @ fluid_vector).real)
    energy = np.vdot(fluid_vector, fluid.mff @ fluid_vector).real
    return moments[0] / energy, moments[1] / energy


# ---------------------------------------------------------------------------------------------
# eigenvalue derivatives (S1)


def solid_parameter_derivative(
    system: CoupledSystem, sigma: complex, q: np.ndarray, parameter: str
) -> np.ndarray:
    """``(∂J/∂p + σ ∂M/∂p) q`` for a solid parameter ``p`` (docs/model.md §3, §7): non-zero on the solid
    rows only. The aerodynamic part ``a`` of the rows ``ḣ'``, ``θ''`` (all but the in-vacuo
    terms) is ``∝ 1/m`` and, for pitch, ``∝ 1/r_θ²``."""
    if parameter not in SOLID_PARAMETERS:
        raise InputError(f"{parameter!r} is not a solid parameter ({', '.join(SOLID_PARAMETERS)})")
    solid, active, ns = system.solid, system.active, system.n_solid
    out = np.zeros(system.size, dtype=np.result_type(q, complex(sigma)))
    if not ns:
        return out
    q_s, _ = system.split(q)
    rows = np.zeros(4, dtype=out.dtype)
    if parameter in ("mass_ratio", "r_theta"):
        full = system.jacobian[:ns] @ q + sigma * (system.mass[:ns] @ q)
        mass = solid_mass(solid, system.fluid.theta0)
        in_vacuo = (solid_stiffness(solid) + sigma * mass)[np.ix_(active, range(4))] @ q_s
        aerodynamic = np.zeros(4, dtype=out.dtype)
        aerodynamic[active] = full - in_vacuo
        if parameter == "mass_ratio":
            rows = -aerodynamic / solid.mass_ratio
        else:  # and the unbalance's coupling (x_θ/r_θ²) cos θ₀ ḣ' of the pitch row (docs/model.md §3.1)
            rows[3] = -2 * (aerodynamic[3] + sigma * mass[3, 2] * q_s[2]) / solid.r_theta
    elif parameter == "reduced_velocity":
        rows = stiffness_derivative(solid) @ q_s
    elif parameter == "freq_ratio":
        u = solid.reduced_velocity
        rows[2] = 2 * solid.freq_ratio / u**2 * q_s[0] + 2 * solid.zeta_h / u * q_s[2]
    elif parameter == "zeta_h":
        rows[2] = 2 * solid.freq_ratio / solid.reduced_velocity * q_s[2]
    else:  # zeta_theta
        rows[3] = 2 / solid.reduced_velocity * q_s[3]
    out[:ns] = rows[active]
    return out


@dataclass(frozen=True)
class FlowTangent:
    """The operators on both sides of a steady state along its tangent in one flow parameter
    (docs/model.md §6, (S2)): ``minus``/``plus`` at ``(c ∓ step, q⁰ ∓ step dq⁰/dc)`` in the coordinate
    ``c`` (``1/Re`` for ``reynolds``, ``α0`` in degrees for ``alpha0``), ``dc/dp`` = ``scale``."""

    parameter: str
    fluid: FluidOperators  # the operators at the steady state itself
    step: float
    scale: float
    minus: FluidOperators
    plus: FluidOperators
    steady_tangent: np.ndarray  # dq⁰/dp on every dof of the steady state's space

    def derivative(self, solid: Solid, sigma: complex, q: np.ndarray) -> np.ndarray:
        """``(dJ/dp + σ dM/dp) q`` with the steady state's own dependence (a difference exact up to
        rounding in ``1/Re``, ``O(step²)`` in ``α0``)."""
        values = []
        for fluid in (self.plus, self.minus):
            system = CoupledSystem(fluid, solid)
            values.append(system.jacobian @ q + sigma * (system.mass @ q))
        return (values[0] - values[1]) * (self.scale / (2 * self.step))


def steady_factor(fluid: FluidOperators, counter: FactorCounter | None = None) -> FluidFactor:
    """The real factorisation of the steady Jacobian ``J_ff`` (the fluid block at ``σ = 0``)."""
    return FluidFactor(fluid, 0.0, counter)


def flow_tangent(fluid: FluidOperators, parameter: str, factor: FluidFactor | None = None) -> FlowTangent:
    """The steady tangent ``dq⁰/dp`` (one solve with ``J_ff``, (S2)) and the operators re-assembled
    at ``q⁰ ± t dq⁰/dp`` (two assemblies, no factorisation). ``factor``: :func:`steady_factor`
    (made here if not given)."""
    from ngsolve import Grad, GridFunction, InnerProduct, LinearForm, dx

    from fsistab.operators import wall_coefficients_jacobian, wall_lifting_matrix
    from fsistab.steady import outlet_integral

    if parameter not in FLOW_PARAMETERS:
        raise InputError(f"{parameter!r} is not a flow parameter ({', '.join(FLOW_PARAMETERS)})")
    factor = factor if factor is not None else steady_factor(fluid)
    if factor.shift != 0:
        raise InputError("the steady tangent needs the factorisation of J_ff at the shift 0")
    steady = fluid.steady
    space, index, flow = steady.space, fluid.free_dofs, steady.flow
    direction = np.zeros(space.ndof)  # dq⁰/dc on every dof
    if parameter == "reynolds":
        # c = 1/Re: ∂R_f/∂c = (∇U⁰ + ∇U⁰ᵀ, ∇v), the viscous term, and the gradient outlet's
        # term (fsistab.steady.outlet_form) at c = 1; the wall values do not move
        (_, _), (v, _) = space.TnT()
        u0 = steady.velocity
        form = LinearForm(space)
        form += InnerProduct(Grad(u0) + Grad(u0).trans, Grad(v)) * dx
        outlet = outlet_integral(steady.mesh_spec.outlet, u0, v, 1.0)
        if outlet is not None:
            form += outlet
        form.Assemble()
        direction[index] = -factor.solve(form.vec.FV().NumPy()[index])
        centre = 1.0 / flow.reynolds
        step, scale = INVERSE_RE_STEP * centre, -(centre**2)  # dc/dRe = -1/Re²

        def flow_at(c: float) -> Flow:
            return Flow(1.0 / c, flow.alpha0_deg)

    else:
        # c = α0 in degrees, θ0 = −α0: the θ column of J_fs (grid velocity and the wall values,
        # which follow the body) drives the steady state
        d_theta = -math.pi / 180  # dθ0/dα0
        q0 = np.array([0.0, flow.theta0, 0.0, 0.0])
        direction = wall_lifting_matrix(steady) @ wall_coefficients_jacobian(q0)[:, 1] * d_theta
        direction[index] = -factor.solve(fluid.jfs[:, 1]) * d_theta
        centre, step, scale = flow.alpha0_deg, ALPHA0_STEP_DEG, 1.0

        def flow_at(c: float) -> Flow:
            return Flow(flow.reynolds, c)

    state0 = steady.state.vec.FV().NumPy().copy()
    sides = []
    for sign in (-1.0, 1.0):
        state = GridFunction(space)
        state.vec.FV().NumPy()[:] = state0 + sign * step * direction
        sides.append(fluid_operators(replace(steady, flow=flow_at(centre + sign * step), state=state)))
    return FlowTangent(parameter, fluid, step, scale, sides[0], sides[1], direction * scale)


def eigenvalue_derivatives(
    system: CoupledSystem,
    mode: AdjointMode,
    parameters: Iterable[str] = PARAMETERS,
    *,
    tangents: dict[str, FlowTangent] | None = None,
) -> dict[str, complex]:
    """``dσ/dp`` by (S1) for each parameter (``alpha0`` per degree). Flow parameters use
    ``tangents[p]`` (:func:`flow_tangent` at ``system.fluid``; computed here when missing, and
    stored in ``tangents`` when a dict is given, for the next mode of the same operators)."""
    parameters = _check_parameters(parameters)
    foreign = [p for p, t in (tangents or {}).items() if p in parameters and t.fluid is not system.fluid]
    if foreign:
        raise InputError(f"the flow tangent(s) {', '.join(foreign)} were made at other operators")
    norm = np.vdot(mode.adjoint, system.mass @ mode.direct)
    tangents = tangents if tangents is not None else {}
    missing = [p for p in parameters if p in FLOW_PARAMETERS and p not in tangents]
    if missing:
        factor = steady_factor(system.fluid)  # one factorisation of J_ff for both tangents
        tangents.update({p: flow_tangent(system.fluid, p, factor) for p in missing})
    out = {}
    for p in parameters:
        if p in FLOW_PARAMETERS:
            d = tangents[p].derivative(system.solid, mode.value, mode.direct)
        else:
            d = solid_parameter_derivative(system, mode.value, mode.direct, p)
        out[p] = complex(-np.vdot(mode.adjoint, d) / norm)
    return out


# ---------------------------------------------------------------------------------------------
# threshold derivatives (S3)


@dataclass(frozen=True)
class ThresholdSensitivity:
    """Derivatives of one neutral point ``(m, U*_c, ω_c)`` (docs/model.md §8) by (S3).

    ``eigenvalue`` holds ``dσ/dp`` at the neutral point (``reduced_velocity`` included),
    ``velocity`` ``dU*_c/dp`` and ``frequency`` ``dω_c/dp`` for every other parameter (``alpha0``
    per degree); ``adjoint`` the critical mode and its adjoint.
    """

    kind: str
    mass_ratio: float
    reduced_velocity: float
    frequency: float
    eigenvalue: dict[str, complex]
    velocity: dict[str, float]
    frequency_derivative: dict[str, float]
    adjoint: AdjointMode


def threshold_derivatives(eigenvalue: dict[str, complex]) -> tuple[dict[str, float], dict[str, float]]:
    """``(dU*_c/dp, dω_c/dp)`` from ``dσ/dp`` (which must hold ``reduced_velocity``) by (S3)."""
    if "reduced_velocity" not in eigenvalue:
        raise InputError("the threshold derivatives need dσ/dU*")
    d_u = eigenvalue["reduced_velocity"]
    if d_u.real == 0:
        raise InputError("the eigenvalue crosses the axis with zero speed in U*: no threshold derivative")
    velocity, frequency = {}, {}
    for p, d in eigenvalue.items():
        if p == "reduced_velocity":
            continue
        velocity[p] = -d.real / d_u.real
        frequency[p] = d.imag + d_u.imag * velocity[p]
    return velocity, frequency


def threshold_sensitivity(
    fluid: FluidOperators,
    solid: Solid,
    point,
    parameters: Iterable[str] = PARAMETERS,
    *,
    counter: FactorCounter | None = None,
    factors: dict[complex, FluidFactor] | None = None,
    tangents: dict[str, FlowTangent] | None = None,
) -> ThresholdSensitivity:
    """Derivatives of the neutral point ``point`` (a :class:`fsistab.neutral_point.NeutralPoint` of
    ``fluid`` with the other solid parameters of ``solid``) by (S1) and (S3).

    One factorisation at ``σ = iω_c`` (or reused from ``factors``), the adjoint by inverse
    iteration with its transposed factors, and for ``reynolds``/``alpha0`` one real factorisation
    of ``J_ff`` shared by both tangents (``factors[0]`` when given; for a divergence point it is
    the factorisation at ``σ = 0`` itself).
    """
    parameters = _check_parameters(parameters)
    factors = factors if factors is not None else {}
    tangents = tangents if tangents is not None else {}
    solid = replace(solid, reduced_velocity=float(point.reduced_velocity), mass_ratio=float(point.mass_ratio))
    system = CoupledSystem(fluid, solid)
    sigma = 1j * float(point.frequency) if point.frequency else 0.0
    shift = complex(sigma)
    if shift not in factors:
        factors[shift] = FluidFactor(fluid, shift, counter)
    solver = AdjointSolver(system, shift, fluid_factor=factors[shift])
    mode = adjoint_mode(system, sigma, point.mode, solver=solver)
    for p in parameters:
        if p in FLOW_PARAMETERS and p not in tangents:
            if 0j not in factors:
                factors[0j] = steady_factor(fluid, counter)
            tangents[p] = flow_tangent(fluid, p, factors[0j])
    wanted = tuple(dict.fromkeys((*parameters, "reduced_velocity")))
    eigenvalue = eigenvalue_derivatives(system, mode, wanted, tangents=tangents)
    velocity, frequency = threshold_derivatives(eigenvalue)
    return ThresholdSensitivity(
        point.kind,
        float(point.mass_ratio),
        float(point.reduced_velocity),
        float(point.frequency),
        eigenvalue,
        velocity,
        frequency,
        mode,
    )


def sensitivity_results(
    fluid: FluidOperators,
    solid: Solid,
    velocities: np.ndarray,
    parameters: Iterable[str] = PARAMETERS,
    *,
    wake_shift: complex | None = None,
    counter: FactorCounter | None = None,
    progress=None,
    factors: dict[complex, FluidFactor] | None = None,
) -> tuple[list, list[ThresholdSensitivity]]:
    """Every threshold along ``velocities`` at ``solid.mass_ratio``
    (:func:`fsistab.critical.find_thresholds`) and its :class:`ThresholdSensitivity`; the
    factorisations made are left in ``factors`` (``factors[0j]``: ``J_ff``, when a flow parameter
    was asked for), for the maps."""
    from fsistab.critical import find_thresholds

    parameters = tuple(p for p in _check_parameters(parameters) if p != "reduced_velocity")
    counter = counter if counter is not None else FactorCounter()
    thresholds, _ = find_thresholds(
        fluid, solid, velocities, wake_shift=wake_shift, counter=counter, progress=progress
    )
    factors = factors if factors is not None else {}
    tangents: dict[str, FlowTangent] = {}
    results = [
        threshold_sensitivity(
            fluid, solid, t, parameters, counter=counter, factors=factors, tangents=tangents
        )
        for t in thresholds
    ]
    return thresholds, results


def sensitivity_dataset(
    thresholds: Sequence, results: Sequence[ThresholdSensitivity], parameters: Sequence[str], attrs: dict
):
    """The thresholds and their derivatives as an ``xarray.Dataset`` (module doc of
    :func:`threshold_sensitivities`)."""
    import xarray as xr

    parameters = [p for p in parameters if p != "reduced_velocity"]

    def table(getter) -> np.ndarray:
        return np.array([[getter(r, p) for p in parameters] for r in results]).reshape(
            len(results), len(parameters)
        )

    dims = ("threshold", "parameter")
    return xr.Dataset(
        {
            "kind": ("threshold", np.array([t.kind for t in thresholds], dtype=str)),
            "boundary": ("threshold", np.array([t.boundary for t in thresholds], dtype=str)),
            "reduced_velocity": ("threshold", np.array([r.reduced_velocity for r in results])),
            "frequency": ("threshold", np.array([r.frequency for r in results])),
            "d_reduced_velocity": (dims, table(lambda r, p: r.velocity[p])),
            "d_frequency": (dims, table(lambda r, p: r.frequency_derivative[p])),
            "d_growth_rate": (dims, table(lambda r, p: r.eigenvalue[p].real)),
            "d_eigenfrequency": (dims, table(lambda r, p: r.eigenvalue[p].imag)),
            "adjoint_residual": ("threshold", np.array([r.adjoint.residual for r in results])),
            "adjoint_iterations": ("threshold", np.array([r.adjoint.iterations for r in results])),
        },
        coords={
            "threshold": np.arange(len(results)),
            "parameter": list(parameters),
            "unit": ("parameter", [UNITS[p] for p in parameters]),
        },
        attrs={
            "method": "adjoint dsigma/dp, implicit function theorem (docs/reference/sensitivity.md)",
            **attrs,
        },
    )


def threshold_sensitivities(
    fluid: FluidOperators,
    solid: Solid,
    velocities: np.ndarray,
    parameters: Iterable[str] = PARAMETERS,
    *,
    wake_shift: complex | None = None,
    counter: FactorCounter | None = None,
    progress=None,
):
    """Every threshold along ``velocities`` at ``solid.mass_ratio``
    (:func:`fsistab.critical.find_thresholds`) with its derivatives (:func:`threshold_sensitivity`),
    as an ``xarray.Dataset`` with dimensions ``threshold`` and ``parameter``: ``kind``,
    ``boundary``, ``reduced_velocity``, ``frequency``, ``d_reduced_velocity`` (``dU*_c/dp``),
    ``d_frequency`` (``dω_c/dp``), ``d_growth_rate``/``d_eigenfrequency`` (``Re``/``Im dσ/dp``),
    ``adjoint_residual`` and ``adjoint_iterations``. The ``alpha0`` derivatives are per degree."""
    parameters = _check_parameters(parameters)
    counter = counter if counter is not None else FactorCounter()
    thresholds, results = sensitivity_results(
        fluid, solid, velocities, parameters, wake_shift=wake_shift, counter=counter, progress=progress
    )
    attrs = {
        "mass_ratio": solid.mass_ratio,
        "reynolds": fluid.reynolds,
        "alpha0_deg": fluid.steady.flow.alpha0_deg,
        "factorisations": counter.count,
    }
    return sensitivity_dataset(thresholds, results, parameters, attrs)


# ---------------------------------------------------------------------------------------------
# spatial sensitivity maps (Marquet, Sipp & Jacquin 2008): a steady force, a control cylinder

CONTROL_DIAMETER = 0.05  # the control cylinder's diameter (body lengths): d = L/20
CONTROL_DRAG = 1.0  # its drag coefficient C_d (constant; the maps scale with C_d·d)


def _dot(a, b):
    """``a·b`` of two 2-vector CoefficientFunctions, without conjugation."""
    return a[0] * b[0] + a[1] * b[1]


def _real_field(space, values: np.ndarray):
    from ngsolve import GridFunction

    out = GridFunction(space)
    out.vec.FV().NumPy()[:] = values
    return out


def _mode_fields(system: CoupledSystem, mode: AdjointMode) -> dict[str, np.ndarray]:
    """Full-space dof vectors of the direct velocity ``u`` (fluid unknowns plus the wall values of
    the solid motion, ``L ∂a/∂q_s q_s``), of the test field ``V`` that pairs with ``J``'s rows
    (``conj(q†_f)`` plus the wall liftings weighted by the solid rows of ``conj(q†)``, which the
    loads reach through ``-ℓᵀ``), and the solid parts ``q_s``, ``conj(q†_s)`` as 4-vectors."""
    from fsistab.operators import wall_coefficients_jacobian, wall_lifting_matrix

    fluid = system.fluid
    steady, index = fluid.steady, fluid.free_dofs
    q_s, q_f = system.split(mode.direct)
    a_s, a_f = system.split(mode.adjoint)
    u = np.zeros(steady.space.ndof, dtype=complex)
    v = np.zeros(steady.space.ndof, dtype=complex)
    u[index], v[index] = q_f, np.conj(a_f)
    if system.n_solid:
        lifting = wall_lifting_matrix(steady)
        u += lifting @ (wall_coefficients_jacobian(np.array([0.0, fluid.theta0, 0.0, 0.0])) @ q_s)
        _, _, coefficient_rows = solid_blocks(
            system.solid, fluid.theta0, fluid.loads0, fluid.load_s, fluid.load_mass_s
        )
        v += lifting @ (coefficient_rows.T @ np.conj(a_s[2:]))
    return {"u": u, "v": v, "q_s": q_s, "a_s": np.conj(a_s)}


def _grid_velocity_perturbation(theta0: float, q_s: np.ndarray):
    """``ŵ = ∂W/∂θ θ̂ + ∂W/∂ḣ ḣ̂ + θ̂'(-Y, X)`` as (real, imaginary) CoefficientFunctions (docs/model.md §4)."""
    from ngsolve import CF, x, y

    from fsistab.operators import grid_velocity_derivatives

    dw = grid_velocity_derivatives(theta0)
    parts = []
    for z in (q_s.real, q_s.imag):
        parts.append(
            CF(tuple(dw["theta"][i] * z[1] + dw["hdot"][i] * z[2] for i in range(2))) + z[3] * CF((-y, x))
        )
    return parts


def base_flow_gradient(system: CoupledSystem, mode: AdjointMode) -> np.ndarray:
    """``g_k = ∂(q†ᴴ J q)/∂q⁰_k`` on the fluid unknowns (the steady velocity and pressure dofs).

    ``J`` depends on the steady state through every term's linearisation
    (:func:`fsistab.operators.base_flow_variation`: the convective terms of ``J_ff`` and ``J_fs``,
    ``((∇u)δ + (∇δ)u − (∇δ)ŵ, v)``, the rotation ``θ̂'(e_z∧δ, v)`` and the sponge's target
    ``-θ̂ σ u_θ(δ)``) and, on the solid rows, the loads ``-ℓᵀ`` of those terms and the steady force
    ``F⁰ = -ℓᵀ R(q⁰)`` rotated with the body (``∂C_L/∂θ``; its derivative is ``-ℓᵀ J_all δ``).
    Four real assemblies of one linear form (the real and imaginary parts of ``u`` and ``v``) and
    one for the steady force (docs/model.md §7)."""
    from ngsolve import CF, LinearForm, dx

    from fsistab.operators import base_flow_variation, steady_fields, wall_lifting_matrix
    from fsistab.steady import momentum_linearisation, wall_velocity

    fluid = system.fluid
    steady = fluid.steady
    space = steady.space
    fields = _mode_fields(system, mode)
    terms_at = steady_fields(steady)
    (phi, _) = space.TestFunction()

    def assemble(u_values, q_solid, v_values) -> np.ndarray:
        u = _real_field(space, u_values).components[0]
        v = _real_field(space, v_values).components[0]
        form = LinearForm(space)
        # compiled, as fluid_operators' forms: several times faster with the sponge's term
        form += base_flow_variation(terms_at, phi, u, v, q_solid).Compile() * dx
        form.Assemble()
        return form.vec.FV().NumPy().copy()

    u, v, q_s = fields["u"], fields["v"], fields["q_s"]
    parts = [(u.real, q_s.real), (u.imag, q_s.imag)]
    g = assemble(*parts[0], v.real) - assemble(*parts[1], v.imag)
    g = g + 1j * (assemble(*parts[0], v.imag) + assemble(*parts[1], v.real))
    weight = fields["a_s"][2] * fields["q_s"][1] * 2 / system.solid.mass_ratio if system.n_solid else 0.0
    if weight != 0:
        c, s = math.cos(fluid.theta0), math.sin(fluid.theta0)
        lifting = wall_lifting_matrix(steady) @ np.array([c, -s, 0.0])
        test = _real_field(space, lifting)
        (trial_u, trial_p) = space.TestFunction()
        form = LinearForm(space)
        form += (
            momentum_linearisation(
                trial_u,
                trial_p,
                test.components[0],
                test.components[1],
                steady.velocity,
                CF(wall_velocity(fluid.theta0)),
                1.0 / fluid.reynolds,
            )
            * dx
        )
        form.Assemble()
        g = g + weight * form.vec.FV().NumPy()
    return g[fluid.free_dofs]


def force_sensitivity(
    system: CoupledSystem, mode: AdjointMode, factor: FluidFactor | None = None
) -> np.ndarray:
    """The sensitivity of ``σ`` to a steady force ``δf`` added to the steady momentum equation
    (docs/model.md §6, ``R_f(q⁰) = (δf, v)``), as the coefficients ``s`` of a field on the fluid
    unknowns: ``δσ = Σ_j s_j (δf, φ_j) = ∫ δf·S_f dx`` with ``S_f = Σ s_j φ_j``.

    From ``J_ff δq⁰ = (δf, φ)`` and (S1), ``δσ = -gᵀ J_ff⁻¹ F / (q†ᴴ M q)``, so
    ``s = -J_ff⁻ᵀ g / (q†ᴴ M q)`` — the steady adjoint, one transposed solve with the real
    factors of ``J_ff`` (:func:`steady_factor`; made here if not given), ``g`` of
    :func:`base_flow_gradient`."""
    factor = factor if factor is not None else steady_factor(system.fluid)
    if factor.shift != 0:
        raise InputError("the force sensitivity needs the factorisation of J_ff at the shift 0")
    norm = np.vdot(mode.adjoint, system.mass @ mode.direct)
    g = base_flow_gradient(system, mode)
    return -factor.solve(g, transpose=True) / norm  # J_ff real: its conjugate transpose is Jᵀ


FORCE_QUADRATURE_BONUS = 6  # a force need not be a polynomial on the elements (a Gaussian)


def force_vector(steady, force) -> np.ndarray:
    """``F_j = (δf, φ_j)`` on the free dofs for a force CoefficientFunction ``force`` (body axes)."""
    from ngsolve import LinearForm, dx

    from fsistab.operators import free_dof_indices

    (phi, _) = steady.space.TestFunction()
    form = LinearForm(steady.space)
    form += _dot(force, phi) * dx(bonus_intorder=FORCE_QUADRATURE_BONUS)
    form.Assemble()
    return form.vec.FV().NumPy()[free_dof_indices(steady.space)].copy()


def gaussian_force(centre: tuple[float, float], radius: float, direction: tuple[float, float]):
    """``δf = e exp(-|x - x_c|²/r²)`` as a CoefficientFunction (a smooth localised force)."""
    from ngsolve import CF, exp, x, y

    bump = exp(-((x - centre[0]) ** 2 + (y - centre[1]) ** 2) / radius**2)
    return CF((direction[0] * bump, direction[1] * bump))


def forced_steady(steady, force: np.ndarray, *, tol: float = 1e-12, maxit: int = 12):
    """The steady state with the force ``F`` (:func:`force_vector`) added, ``R_f(q⁰) = F``, by
    Newton from ``steady`` with :class:`fsistab.steady.SteadyProblem`'s residual and Jacobian
    (docs/model.md §6; a copy of the state, ``steady`` untouched)."""
    from ngsolve import GridFunction

    from fsistab.steady import SteadyProblem

    problem = SteadyProblem.on(steady.mesh, steady.space, outlet=steady.mesh_spec.outlet)
    state = GridFunction(steady.space)
    state.vec.data = steady.state.vec
    try:
        history = problem.newton(state, steady.flow, tol=tol, maxit=maxit, force=force)
    except ConvergenceError as exc:
        raise ConvergenceError(f"the forced steady state did not converge: {exc}") from None
    return replace(steady, state=state, history=tuple(history), from_cache=False)


@dataclass(frozen=True)
class SensitivityMaps:
    """The spatial sensitivities of one eigenvalue as CoefficientFunctions (real, imaginary parts).

    ``force``: ``S_f`` (``δσ = ∫ δf·S_f``, per unit force density, body axes); ``control``:
    ``δσ`` from a control cylinder of diameter ``diameter`` and drag coefficient ``drag`` placed
    at ``x``; ``structural``: ``‖û†‖‖û‖`` (real). ``slope``: ``∂σ/∂U*`` for a threshold (then
    ``δU*_c = -Re δσ / Re ∂σ/∂U*``), None for a fixed body's mode.
    """

    kind: str
    value: complex
    force: tuple
    control: tuple
    structural: object
    slope: complex | None
    diameter: float
    drag: float


def sensitivity_maps(
    system: CoupledSystem,
    mode: AdjointMode,
    kind: str,
    *,
    factor: FluidFactor | None = None,
    slope: complex | None = None,
    diameter: float = CONTROL_DIAMETER,
    drag: float = CONTROL_DRAG,
) -> SensitivityMaps:
    """The maps of :class:`SensitivityMaps` for ``mode``.

    Control cylinder (Marquet, Sipp & Jacquin 2008; Hill 1992): a small cylinder fixed to the body
    at ``x₀`` exerts on the flow ``f = -k|U_r|U_r δ(x - x₀)``, ``k = C_d d/2``, ``U_r = U - W``
    the velocity relative to the body (docs/model.md §4); its drag is carried by its own support (the
    body's loads do not include it). It moves the steady state, ``δσ_b = S_f(x₀)·f⁰``, and acts
    on the perturbation with ``f' = -k(|U_r| I + U_r U_rᵀ/|U_r|)(û - ŵ)``, which adds ``-f'`` to
    ``J`` at ``x₀``: ``δσ_p = -conj(û†(x₀))·k(|U_r| I + U_r U_rᵀ/|U_r|)(û - ŵ)(x₀)``
    (``q†ᴴ M q = 1``)."""
    from ngsolve import CF, IfPos, sqrt

    from fsistab.steady import wall_velocity

    if not (diameter > 0 and drag > 0):
        raise InputError(f"the control cylinder needs a positive diameter and drag, got {diameter}, {drag}")
    fluid = system.fluid
    space = fluid.steady.space
    index = fluid.free_dofs
    norm = np.vdot(mode.adjoint, system.mass @ mode.direct)
    adjoint = mode.adjoint / np.conj(norm)  # q†ᴴ M q = 1
    fields = _mode_fields(system, replace(mode, adjoint=adjoint))
    s = np.zeros(space.ndof, dtype=complex)
    s[index] = force_sensitivity(system, mode, factor)

    def parts(values):
        return tuple(_real_field(space, part).components[0] for part in (values.real, values.imag))

    s_re, s_im = parts(s)
    u_re, u_im = parts(fields["u"])
    a = np.zeros(space.ndof, dtype=complex)
    a[index] = adjoint[system.n_solid :]
    a_re, a_im = parts(a)
    w_re, w_im = _grid_velocity_perturbation(fluid.theta0, fields["q_s"])
    relative = fluid.steady.velocity - CF(wall_velocity(fluid.theta0))
    speed = sqrt(_dot(relative, relative))
    k = 0.5 * drag * diameter

    def h(d):  # (|U_r| I + U_r U_rᵀ/|U_r|) d, the second term 0 where U_r = 0 (the wall)
        along = IfPos(speed - 1e-12, _dot(relative, d) / (speed + 1e-300), 0.0)
        return speed * d + along * relative

    hd_re, hd_im = h(u_re - w_re), h(u_im - w_im)
    control_re = -k * speed * _dot(s_re, relative) - k * (_dot(a_re, hd_re) + _dot(a_im, hd_im))
    control_im = -k * speed * _dot(s_im, relative) - k * (_dot(a_re, hd_im) - _dot(a_im, hd_re))
    direct = np.zeros(space.ndof, dtype=complex)
    direct[index] = mode.direct[system.n_solid :]
    d_re, d_im = parts(direct)
    structural = sqrt(_dot(a_re, a_re) + _dot(a_im, a_im)) * sqrt(_dot(d_re, d_re) + _dot(d_im, d_im))
    return SensitivityMaps(
        kind, complex(mode.value), (s_re, s_im), (control_re, control_im), structural, slope, diameter, drag
    )


MAP_FIELDS = ("force_x", "force_y", "control")


def maps_at(maps: SensitivityMaps, mesh, points: np.ndarray, scale: float = 1.0) -> dict[str, np.ndarray]:
    """The maps at ``points`` (N × 2): complex ``force_x``, ``force_y``, ``control`` and real
    ``structural``; for a threshold also ``d_reduced_velocity_control`` (``δU*_c`` of the control
    cylinder, IFT (S3)) and ``d_reduced_velocity_force_x``/``_y`` (per unit force density), times
    ``scale`` (:func:`fsistab.params.body_velocity_scale`: the body's convention of U*)."""
    points = np.asarray(points, dtype=float)
    mapped = mesh(points[:, 0], points[:, 1])

    def values(cf) -> np.ndarray:
        return np.asarray(cf(mapped)).reshape(len(points), -1)

    force = values(maps.force[0]) + 1j * values(maps.force[1])
    out = {
        "force_x": force[:, 0],
        "force_y": force[:, 1],
        "control": values(maps.control[0])[:, 0] + 1j * values(maps.control[1])[:, 0],
        "structural": values(maps.structural)[:, 0],
    }
    if maps.slope is not None:
        for name in MAP_FIELDS:
            out[f"d_reduced_velocity_{name}"] = -out[name].real / maps.slope.real * scale
    return out


def wall_distance(mesh, points: np.ndarray) -> np.ndarray:
    """Distance from each of ``points`` to the nearest vertex of the wall (body lengths)."""
    from ngsolve import BND
    from scipy.spatial import cKDTree

    from fsistab.bodies import WALL

    coords = np.asarray(mesh.ngmesh.Coordinates())[:, :2]
    wall = coords[np.unique([v.nr for e in mesh.Elements(BND) if e.mat == WALL for v in e.vertices])]
    return cKDTree(wall).query(np.asarray(points, dtype=float))[0]


def maps_dataset(maps: Sequence[SensitivityMaps], mesh, attrs: dict | None = None, scale: float = 1.0):
    """Every map at the mesh vertices as an ``xarray.Dataset`` (dims ``target``, ``vertex``):
    coordinates ``x``, ``y``; complex (``part``) ``force_x``, ``force_y``, ``control``,
    ``eigenvalue``, ``slope``; real ``structural`` and ``d_reduced_velocity_*`` (NaN for a fixed
    body's mode; U* in the body's convention by ``scale``); ``wall_distance`` (to the nearest wall
    vertex: where a control cylinder of diameter ``d`` clears the body, ``≥ d``)."""
    import xarray as xr

    from fsistab.store import complex_variable

    xy = np.asarray(mesh.ngmesh.Coordinates())[:, :2]
    sampled = [maps_at(m, mesh, xy, scale) for m in maps]
    clearance = wall_distance(mesh, xy)
    nan = np.full(len(xy), np.nan)
    data = {name: complex_variable(("target", "vertex"), [s[name] for s in sampled]) for name in MAP_FIELDS}
    data["structural"] = (("target", "vertex"), np.array([s["structural"] for s in sampled]))
    for name in MAP_FIELDS:
        key = f"d_reduced_velocity_{name}"
        data[key] = (("target", "vertex"), np.array([s.get(key, nan) for s in sampled]))
    data["eigenvalue"] = complex_variable("target", [m.value for m in maps])
    data["slope"] = complex_variable("target", [m.slope if m.slope is not None else np.nan for m in maps])
    data["wall_distance"] = ("vertex", clearance)
    return xr.Dataset(
        data,
        coords={"target": [m.kind for m in maps], "x": ("vertex", xy[:, 0]), "y": ("vertex", xy[:, 1])},
        attrs={
            "control_diameter": maps[0].diameter if maps else CONTROL_DIAMETER,
            "control_drag": maps[0].drag if maps else CONTROL_DRAG,
            "conventions": (
                "body axes, lengths in L, force density in rho U^2/L; force_*: dsigma per unit force "
                "density (dsigma = integral of df . S_f); control: dsigma of a control cylinder at the "
                "vertex; d_reduced_velocity_*: dU*_c by the implicit function theorem (docs/reference/"
                "sensitivity.md)"
            ),
            **(attrs or {}),
        },
    )


def _drag_steady_state(steady, strength, grid_velocity, quadrature, tol: float, maxit: int):
    """The steady state of ``R_f(q⁰) = (f(U⁰), φ)`` with the drag ``f = -strength |U_r| U_r`` of
    :func:`control_cylinder_operators` (``U_r`` the velocity relative to the grid), by Newton
    with the flow's Jacobian alone, from ``steady``."""
    from ngsolve import GridFunction, LinearForm, sqrt

    from fsistab.steady import SteadyProblem

    space = steady.space
    problem = SteadyProblem.on(steady.mesh, space, outlet=steady.mesh_spec.outlet)
    state = GridFunction(space)
    state.vec.data = steady.state.vec
    problem.set_flow(steady.flow)
    problem.impose_wall(state, steady.flow)
    _, (v, _) = space.TnT()
    residual, values = state.vec.CreateVector(), state.vec.FV().NumPy()
    solve = problem.newton_solver(state)
    for _ in range(maxit):
        relative = state.components[0] - grid_velocity
        force = LinearForm(space)
        force += -strength * sqrt(_dot(relative, relative)) * _dot(relative, v) * quadrature
        force.Assemble()
        problem.form.Apply(state.vec, residual)
        r = (residual.FV().NumPy() - force.vec.FV().NumPy())[problem.free]
        if np.linalg.norm(r) < tol:
            return state
        values[problem.free] -= solve(r)
    raise ConvergenceError(
        f"the steady state with the control cylinder did not converge ({np.linalg.norm(r):.1e})"
    )


def control_cylinder_operators(
    steady,
    centre: tuple[float, float],
    radius: float,
    *,
    diameter: float = CONTROL_DIAMETER,
    drag: float = CONTROL_DRAG,
    tol: float = 1e-12,
    maxit: int = 60,
) -> FluidOperators:
    """The operators with the control cylinder of :func:`sensitivity_maps` spread over a Gaussian
    ``w(x) = exp(-|x - x_c|²/r²)/(πr²)`` (a check of the maps at finite size, not a model of the
    cylinder's own flow): the steady state of ``R_f(q⁰) = (f(U⁰), φ)``,
    ``f = -k w |U_r| U_r`` (Newton with the flow's Jacobian alone, which converges for a small
    ``k = C_d d/2``), then ``J_ff`` and ``J_fs`` with ``+k w (|U_r| I + U_r U_rᵀ/|U_r|)`` acting on
    ``û - ŵ`` (the wall values of ``û`` included); the loads are those of the flow alone. A
    negative ``drag`` (a thrust) gives the other side of a central difference."""
    from ngsolve import CF, BilinearForm, LinearForm, dx, exp, sqrt, x, y

    from fsistab.operators import (
        grid_velocity_derivatives,
        wall_coefficients_jacobian,
        wall_lifting_matrix,
    )
    from fsistab.steady import wall_velocity

    if not radius > 0:
        raise InputError(f"the Gaussian's radius must be positive, got {radius}")
    k = 0.5 * drag * diameter
    weight = exp(-((x - centre[0]) ** 2 + (y - centre[1]) ** 2) / radius**2) / (math.pi * radius**2)
    space = steady.space
    quadrature = dx(bonus_intorder=FORCE_QUADRATURE_BONUS)
    grid_velocity = CF(wall_velocity(steady.flow.theta0))
    (u, _), (v, _) = space.TnT()
    state = _drag_steady_state(steady, k * weight, grid_velocity, quadrature, tol, maxit)
    forced = replace(steady, state=state, from_cache=False)
    fluid = fluid_operators(forced)
    relative = forced.velocity - grid_velocity
    speed = sqrt(_dot(relative, relative))

    def h(d, test):
        return k * weight * (speed * _dot(d, test) + _dot(relative, d) * _dot(relative, test) / speed)

    form = BilinearForm(space)
    form += h(u, v) * quadrature
    form.Assemble()
    rows, cols, entries = form.mat.COO()
    matrix = sp.csr_matrix(
        (np.asarray(entries), (np.asarray(rows), np.asarray(cols))), shape=2 * (space.ndof,)
    )
    index = fluid.free_dofs
    dw = grid_velocity_derivatives(steady.flow.theta0)
    columns = []
    for w in (CF((0.0, 0.0)), CF(dw["theta"]), CF(dw["hdot"]), CF((-y, x))):  # ŵ of (h, θ, ḣ, θ')
        load = LinearForm(space)
        load += -h(w, v) * quadrature
        load.Assemble()
        columns.append(load.vec.FV().NumPy()[index])
    walls = wall_lifting_matrix(forced) @ wall_coefficients_jacobian(np.array([0.0, fluid.theta0, 0.0, 0.0]))
    return replace(
        fluid,
        jff=(fluid.jff + matrix[index][:, index]).tocsr(),
        jfs=fluid.jfs + np.column_stack(columns) + (matrix @ walls)[index],
        analyses={},  # another matrix pattern than the flow's alone
    )
