"""The coupled fluid–solid system ``σ M q + J q = 0`` (docs/model.md §5, §7) for given solid parameters.

Unknowns ``q = (q_s, q_f)``: the active solid states first — a subset of ``(h, θ, ḣ, θ')`` chosen by
:attr:`fsistab.params.Solid.dofs` (heave: ``h, ḣ``; pitch: ``θ, θ'``) — then the fluid unknowns
of :class:`fsistab.operators.FluidOperators`. Inactive solid states stay at their steady value.
Only the small solid blocks depend on the solid parameters: building a system for new
``(m, U*, Ω, ζ, r_θ, x_θ)`` re-uses the fluid blocks as they are. The elastic axis ``a`` is the
origin of the mesh's frame (:class:`fsistab.bodies.Pivoted`, docs/model.md §3.1): the solid's ``a``
must be the mesh's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from fsistab.bodies import frame_offset
from fsistab.errors import InputError
from fsistab.operators import SOLID_STATE, FluidOperators, FluidResidual
from fsistab.params import Solid

_ACTIVE = {"heave": (0, 2), "pitch": (1, 3)}  # (displacement, velocity) in SOLID_STATE


def active_states(solid: Solid) -> list[int]:
    """Indices in ``(h, θ, ḣ, θ')`` of the active solid states, in that order."""
    return sorted(i for dof in solid.dofs for i in _ACTIVE[dof])


def lift_and_moment_rows(theta: float, loads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``∂(C_L, C_M)/∂(F_x, F_y, M)`` (2 × 3) and ``∂C_L/∂θ`` at fixed loads.

    ``C_L = 2{R(θ)F}·e_y = 2(sin θ F_x + cos θ F_y)``, ``C_M = 2M`` (docs/model.md §4).
    """
    c, s = math.cos(theta), math.sin(theta)
    rows = np.array([[2 * s, 2 * c, 0.0], [0.0, 0.0, 2.0]])
    return rows, 2 * (c * loads[0] - s * loads[1])


def solid_stiffness(solid: Solid) -> np.ndarray:
    """In-vacuo solid rows of ``J_ss`` (4 × 4, docs/model.md §7) without the aerodynamic terms."""
    w_h, w_t = solid.freq_ratio / solid.reduced_velocity, 1.0 / solid.reduced_velocity
    return np.array(
        [
            [0.0, 0.0, -1.0, 0.0],
            [0.0, 0.0, 0.0, -1.0],
            [w_h**2, 0.0, 2 * solid.zeta_h * w_h, 0.0],
            [0.0, w_t**2, 0.0, 2 * solid.zeta_theta * w_t],
        ]
    )


def solid_mass(solid: Solid, theta: float = 0.0) -> np.ndarray:
    """In-vacuo solid rows of ``M_s(θ)`` (4 × 4, docs/model.md §3.1, §7), the rows being divided by
    the solid inertia (``/m``, ``/(m r_θ²)``), before the fluid's load inertia: ``I₄`` plus the
    static unbalance's coupling ``x_θ cos θ`` (heave row, ``θ''`` column) and ``(x_θ/r_θ²) cos θ``
    (pitch row, ``h''`` column). At the steady ``θ₀`` it is the linear mass; ``I₄`` when the centre
    of mass is on the pitch axis."""
    mass = np.eye(4)
    if solid.static_unbalance:
        coupling = solid.static_unbalance * math.cos(theta)
        mass[2, 3] = coupling
        mass[3, 2] = coupling / solid.r_theta**2
    return mass


def in_vacuo_rates(solid: Solid) -> list[float]:
    """The undamped in-vacuo frequencies of heave and pitch with a static unbalance ``x_θ``, in units
    of ``1/U*``, lower first (docs/model.md §3.1): the roots ``w`` of
    ``(1 − x_θ²/r_θ²) w⁴ − (Ω² + 1) w² + Ω² = 0``."""
    beta = 1 - solid.static_unbalance**2 / solid.r_theta**2
    total, product = solid.freq_ratio**2 + 1, solid.freq_ratio**2
    root = math.sqrt(total * total - 4 * beta * product)
    return [math.sqrt((total - root) / (2 * beta)), math.sqrt((total + root) / (2 * beta))]


def solid_energies(solid: Solid, velocities, theta: float = 0.0) -> tuple[float, float]:
    """``(E_h, E_θ)``: the kinetic energy of a mode's solid velocities ``(ḣ, θ')`` (complex
    amplitudes, units ``ρL²U∞²``, docs/model.md §3.1), split by König's theorem: the heave of the
    centre of mass ``E_h = (m/4)|ḣ + x_θ cos θ θ'|²`` and the rest ``E_θ = (m/4)(r_θ² − x_θ² cos²θ)|θ'|²``
    (rotation about G and G's streamwise motion, both from pitch). Their sum is the energy of the
    linear solid mass ``M_s(θ)``; both are non-negative (``r_θ² > x_θ²``), which a split of the cross
    term between the dofs is not; without unbalance ``(m/4)|ḣ|²`` and ``(m/4) r_θ²|θ'|²``."""
    m, r = solid.mass_ratio, solid.r_theta
    coupling = solid.static_unbalance * math.cos(theta)
    heave = 0.25 * m * abs(velocities[0] + coupling * velocities[1]) ** 2
    pitch = 0.25 * m * (r**2 - coupling**2) * abs(velocities[1]) ** 2
    return float(heave), float(pitch)


def solid_inertia(solid: Solid, q_solid: np.ndarray, rate: np.ndarray) -> np.ndarray:
    """The nonlinear inertia of the solid rows (docs/model.md §3.1), ``M_s(θ) q̇_s`` plus the
    centripetal term ``-x_θ sin θ θ'²`` of the heave row (the centre of mass turning about the
    elastic axis): what ``fsistab simulate`` adds to ``R_s``. ``q_solid``, ``rate``: ``(h, θ, ḣ, θ')``
    and its time derivative."""
    out = solid_mass(solid, q_solid[1]) @ rate
    if solid.static_unbalance:
        out[2] -= solid.static_unbalance * math.sin(q_solid[1]) * q_solid[3] ** 2
    return out


def stiffness_derivative(solid: Solid) -> np.ndarray:
    """``∂J_ss/∂U*`` (4 × 4, docs/model.md §7): derivative of the in-vacuo rows of :func:`solid_stiffness`
    (``ω_h = Ω/U*``, ``ω_θ = 1/U*``); ``U*`` enters ``J`` nowhere else."""
    u = solid.reduced_velocity
    w_h, w_t = solid.freq_ratio / u, 1.0 / u
    d = np.zeros((4, 4))
    d[2, 0] = -2 * w_h**2 / u
    d[2, 2] = -2 * solid.zeta_h * w_h / u
    d[3, 1] = -2 * w_t**2 / u
    d[3, 3] = -2 * solid.zeta_theta * w_t / u
    return d


def solid_blocks(
    solid: Solid, theta0: float, loads0: np.ndarray, load_s: np.ndarray, load_mass_s: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Solid rows of ``J`` and ``M`` on the solid columns (4 × 4 each, docs/model.md §7) and the map
    ``C = ∂(C_L/m, C_M/(m r_θ²))/∂(F_x, F_y, M)`` (2 × 3) that turns loads into solid rows.

    ``load_s``, ``load_mass_s`` (3 × 4) are the loads' derivatives with respect to ``(h, θ, ḣ, θ')``
    and their rates. The rows of ``J``/``M`` on fluid columns are ``-C`` times the fluid ones.
    """
    rows, dcl_dtheta = lift_and_moment_rows(theta0, loads0)
    scale = np.array([1.0 / solid.mass_ratio, 1.0 / (solid.mass_ratio * solid.r_theta**2)])
    coefficient_rows = scale[:, None] * rows
    jss = solid_stiffness(solid).astype(np.result_type(load_s, float))
    jss[2:, :] -= coefficient_rows @ load_s
    jss[2, 1] -= dcl_dtheta / solid.mass_ratio  # the steady force rotated with the body
    mss = solid_mass(solid, theta0).astype(np.result_type(load_mass_s, float))
    mss[2:, :] -= coefficient_rows @ load_mass_s
    return jss, mss, coefficient_rows


@dataclass(frozen=True)
class CoupledSystem:
    """``J`` and ``M`` of docs/model.md §7 (E) for one set of solid parameters, as SciPy sparse matrices.

    Time unit ``L/U∞``; the solid rows are those of docs/model.md §3 divided as there (``/m``,
    ``/(m r_θ²)``). The blocks are kept separately (``jss``, ``jsf``, ``jfs``, ``mss``, ``msf``,
    ``mfs``, and the fluid's ``jff``, ``mff``) for bordered solvers.
    """

    fluid: FluidOperators
    solid: Solid

    def __post_init__(self):
        axis = self.fluid.steady.mesh_spec.body
        if "pitch" in self.solid.dofs and self.solid.elastic_axis != -frame_offset(axis):
            raise InputError(
                f"the solid's elastic axis a = {self.solid.elastic_axis:g} is not the pitch axis of the "
                f"mesh (a = {-frame_offset(axis):g}): build the case with the same --elastic-axis"
            )

    @cached_property
    def active(self) -> list[int]:
        return active_states(self.solid)

    @property
    def n_solid(self) -> int:
        return len(self.active)

    @property
    def size(self) -> int:
        return self.n_solid + self.fluid.n_fluid

    @cached_property
    def _solid_rows(self):
        """Full 4-state solid rows: (jss, jsf, mss, msf) before selecting the active states."""
        ops = self.fluid
        jss, mss, coefficient_rows = solid_blocks(
            self.solid, ops.theta0, ops.loads0, ops.load_s, ops.load_mass_s
        )
        jsf = sp.vstack([sp.csr_matrix((2, ops.n_fluid)), -sp.csr_matrix(coefficient_rows) @ ops.load_f])
        msf = sp.vstack([sp.csr_matrix((2, ops.n_fluid)), -sp.csr_matrix(coefficient_rows) @ ops.load_mass_f])
        return jss, jsf.tocsr(), mss, msf.tocsr()

    @property
    def jss(self) -> np.ndarray:
        return self._solid_rows[0][np.ix_(self.active, self.active)]

    @property
    def jsf(self) -> sp.csr_matrix:
        return self._solid_rows[1][self.active]

    @property
    def mss(self) -> np.ndarray:
        return self._solid_rows[2][np.ix_(self.active, self.active)]

    @property
    def msf(self) -> sp.csr_matrix:
        return self._solid_rows[3][self.active]

    @property
    def jfs(self) -> np.ndarray:
        return self.fluid.jfs[:, self.active]

    @property
    def mfs(self) -> np.ndarray:
        return self.fluid.mfs[:, self.active]

    @cached_property
    def jacobian(self) -> sp.csr_matrix:
        """``J`` (size × size)."""
        return sp.bmat(
            [[sp.csr_matrix(self.jss), self.jsf], [sp.csr_matrix(self.jfs), self.fluid.jff]]
        ).tocsr()

    @cached_property
    def mass(self) -> sp.csr_matrix:
        """``M`` (size × size), with the mass coupling of the wall lifting."""
        return sp.bmat(
            [[sp.csr_matrix(self.mss), self.msf], [sp.csr_matrix(self.mfs), self.fluid.mff]]
        ).tocsr()

    def state_labels(self) -> list[str]:
        return [SOLID_STATE[i] for i in self.active]

    def split(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(q_s as (h, θ, ḣ, θ') with zeros for inactive states, q_f)``."""
        full = np.zeros(4, dtype=q.dtype)
        full[self.active] = q[: self.n_solid]
        return full, q[self.n_solid :]


def velocity_derivative(system: CoupledSystem, q: np.ndarray) -> np.ndarray:
    """``∂J/∂U* q``: nonzero on the solid rows only."""
    ns = system.n_solid
    out = np.zeros(system.size, dtype=q.dtype)
    out[:ns] = stiffness_derivative(system.solid)[np.ix_(system.active, system.active)] @ q[:ns]
    return out


class CoupledResidual:
    """The discrete nonlinear residual ``R(q) = (R_s, R_f)`` of docs/model.md §5, for FD checks of ``J``.

    ``C_Fext`` and ``C_Mext`` are set so that the steady state is an equilibrium (docs/model.md §6).
    Inactive solid states are held at their steady values.
    """

    def __init__(self, system: CoupledSystem, fluid_residual: FluidResidual | None = None):
        self.system = system
        self.fluid = fluid_residual or FluidResidual(system.fluid.steady)
        q_s0, q_f0 = self.fluid.steady_point()
        self.q_solid0, self.q_fluid0 = q_s0, q_f0
        solid = system.solid
        lift0, moment0 = self._coefficients(q_s0[1], system.fluid.loads0)
        self.lift_ext = -lift0
        self.moment_ext = solid.mass_ratio * solid.r_theta**2 * q_s0[1] / solid.reduced_velocity**2 - moment0

    @staticmethod
    def _coefficients(theta: float, loads: np.ndarray) -> tuple[float, float]:
        rows, _ = lift_and_moment_rows(theta, loads)
        lift, moment = rows @ loads
        return float(lift), float(moment)

    def point(self) -> np.ndarray:
        """The steady state as a coupled vector."""
        return np.concatenate([self.q_solid0[self.system.active], self.q_fluid0])

    def solid_state(self, q: np.ndarray) -> np.ndarray:
        """``(h, θ, ḣ, θ')`` of a coupled vector, inactive states at their steady values."""
        q_solid = self.q_solid0.copy()
        q_solid[self.system.active] = q[: self.system.n_solid]
        return q_solid

    def __call__(self, q: np.ndarray) -> np.ndarray:
        solid = self.system.solid
        q_solid = self.solid_state(q)
        q_fluid = q[self.system.n_solid :]
        r_fluid, loads = self.fluid(q_solid, q_fluid)
        lift, moment = self._coefficients(q_solid[1], loads)
        r_solid = solid_stiffness(solid) @ q_solid
        r_solid[2] -= (lift + self.lift_ext) / solid.mass_ratio
        r_solid[3] -= (moment + self.moment_ext) / (solid.mass_ratio * solid.r_theta**2)
        return np.concatenate([r_solid[self.system.active], r_fluid])

    def inertia(self, q: np.ndarray, rate: np.ndarray) -> np.ndarray:
        """The solid rows' nonlinear inertia at ``q`` for the solid rates ``rate`` (the active
        states' time derivatives), :func:`solid_inertia` on the active states: ``M q̇ + R(q) = 0``
        with this in place of ``M_s q̇_s`` is the nonlinear system of docs/model.md §3.1, §5."""
        full = np.zeros(4, dtype=np.result_type(rate, float))
        full[self.system.active] = rate
        return solid_inertia(self.system.solid, self.solid_state(q), full)[self.system.active]
