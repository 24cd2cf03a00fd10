"""Critical points: flutter (Hopf, ``ω_c ≠ 0``) and divergence (``ω_c = 0``) (docs/model.md §8).

Dynamic instability: the neutral-point problem of :mod:`fsistab.neutral_point` in its augmented
sparse formulation (:class:`AugmentedProblem`, unknowns ``(q̂, ω, U*, log m)``; the neutral curves
of :mod:`fsistab.neutral` continue the same problem), solved by the one Newton
(:func:`fsistab.continuation.newton`) at fixed ``m``::

    (iω M + J(U*)) q̂ = 0,     Re(ĥ) = 0 (phase),     q̂ᴴ M q̂ = 1 (amplitude)

(for a pitch-only system the phase is fixed on ``θ̂``). Each Newton step solves three systems with
the same matrix ``iωM + J(U*)`` — one factorisation of the fluid block at ``iω`` (independent of
``U*``) reused through the bordered solver of :mod:`fsistab.linalg` — and a 2×2 real system for
``(δω, δU*)``. Static instability: ``J(U*) q̂ = 0`` with ``θ̂ = 1``, real (:class:`DivergenceProblem`,
unknowns ``(q̂, 1/U*²)``), solved by the same Newton, where the fluid block ``J_ff`` is factorised
once for all iterations.

``U*`` enters ``J`` only through the in-vacuo solid rows, so ``∂J/∂U*`` is explicit.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from fsistab.continuation import CurveProblem, SquareProblem, newton
from fsistab.coupled import CoupledSystem, active_states, solid_mass, solid_stiffness, velocity_derivative
from fsistab.eigen import eigenpairs_near
from fsistab.errors import ConvergenceError, InputError
from fsistab.frequency_sweep import sweep_thresholds
from fsistab.linalg import FactorCounter, FluidFactor, ShiftedSolver
from fsistab.neutral_point import STATIC_FREQUENCY, NeutralPoint, divergence_velocity, unit_index
from fsistab.operators import FluidOperators, fluid_operators
from fsistab.params import THRESHOLD_METHODS, Solid
from fsistab.progress import Progress
from fsistab.slopes import static_slopes
from fsistab.steady import solve_steady
from fsistab.tracking import track_branches
from fsistab.transfer import transfer_flutter_point


def phase_index(system: CoupledSystem) -> int:
    """Index in the coupled vector of ``h`` (or ``θ`` for a pitch-only system): the phase condition
    ``Re(q̂_k) = 0`` of docs/model.md §8."""
    labels = system.state_labels()
    for name in ("h", "theta"):
        if name in labels:
            return labels.index(name)
    raise InputError("a critical point of the coupled system needs at least one solid degree of freedom")


def mass_derivative(system: CoupledSystem, q: np.ndarray, omega: float) -> np.ndarray:
    """``∂(J + iωM)/∂(log m) q``: every aerodynamic term of the solid rows (and its inertia) scales
    with ``1/m`` (docs/model.md §3), so this is minus the aerodynamic part of the solid rows applied to
    ``q`` (the in-vacuo part, the springs and the solid mass with its unbalance, §3.1, does not)."""
    ns = system.n_solid
    full = system.jacobian @ q + 1j * omega * (system.mass @ q)
    in_vacuo = np.zeros_like(full)
    active = system.active
    in_vacuo[:ns] = (
        solid_stiffness(system.solid)[np.ix_(active, active)]
        + 1j * omega * solid_mass(system.solid, system.fluid.theta0)[np.ix_(active, active)]
    ) @ q[:ns]
    d = np.zeros_like(full)
    d[:ns] = -(full[:ns] - in_vacuo[:ns])
    return d


class AugmentedProblem:
    """The augmented sparse system of docs/model.md §8 (module doc) in ``y = (Re q̂, Im q̂, ω, U*, μ)``,
    ``μ = log m``, for the solid parameters of ``template`` otherwise.

    The bordered solve eliminates ``δq̂ = a + δω b + δU* c + δμ d`` with
    ``(J + iωM)(a, b, c, d) = (r_q, -iMq̂, -∂J/∂U* q̂, -∂(J + iωM)/∂μ q̂)`` — one factorisation of
    the fluid block at ``iω`` (:mod:`fsistab.linalg`), four back-substitutions — and solves the
    3×3 real border of the phase, amplitude and bordering rows; the border may weigh ``U*`` and
    ``μ`` only. With ``μ`` held (border ``e_μ``, a point at fixed m) ``d`` is not needed and the
    border is 2×2. With ``reuse`` the last fluid factorisation is kept (its shift ``iω_f`` differs
    from ``iω`` by the Newton updates of ``ω``: chord Newton)."""

    def __init__(self, fluid: FluidOperators, template: Solid, counter: FactorCounter | None = None):
        self.fluid, self.template = fluid, template
        self.counter = counter if counter is not None else FactorCounter()
        system = CoupledSystem(fluid, template)
        self.n, self.phase = system.size, phase_index(system)
        self._system: tuple[tuple[float, float], CoupledSystem] | None = None
        self._solver: tuple[tuple, ShiftedSolver] | None = None
        self._factor = None

    @property
    def size(self) -> int:
        return 2 * self.n + 3

    @property
    def mass_index(self) -> int:
        return self.size - 1

    def pack(self, q: np.ndarray, omega: float, velocity: float, log_mass: float) -> np.ndarray:
        return np.concatenate([q.real, q.imag, [omega, velocity, log_mass]])

    def unpack(self, y: np.ndarray) -> tuple[np.ndarray, float, float, float]:
        n = self.n
        return y[:n] + 1j * y[n : 2 * n], float(y[-3]), float(y[-2]), float(y[-1])

    def start(self, mode: np.ndarray, omega: float, velocity: float, mass_ratio: float) -> np.ndarray:
        """``y`` from a guess of the mode, normalised: ``Re(q̂_k) = 0`` and ``q̂ᴴ M q̂ = 1``."""
        system = self.system(velocity, math.log(mass_ratio))
        q = np.asarray(mode, dtype=complex)
        q = q * np.exp(-1j * (np.angle(q[self.phase]) - np.pi / 2))
        q /= np.sqrt(np.vdot(q, system.mass @ q).real)
        return self.pack(q, omega, velocity, math.log(mass_ratio))

    def system(self, velocity: float, log_mass: float) -> CoupledSystem:
        if not (math.isfinite(velocity) and velocity > 0 and math.isfinite(log_mass)):
            raise ConvergenceError(
                f"the neutral-point Newton left the admissible range (U* = {velocity:g}); "
                "start closer to the crossing (a finer sweep in U*)"
            )
        key = (velocity, log_mass)
        if self._system is None or self._system[0] != key:
            # the template's own m where it is held (exp(log m) may differ from it in the last bit)
            held = log_mass == math.log(self.template.mass_ratio)
            mass = self.template.mass_ratio if held else math.exp(log_mass)
            solid = replace(self.template, reduced_velocity=velocity, mass_ratio=mass)
            self._system = (key, CoupledSystem(self.fluid, solid))
        return self._system[1]

    def residual(self, y: np.ndarray) -> np.ndarray:
        q, omega, velocity, log_mass = self.unpack(y)
        system = self.system(velocity, log_mass)
        mq = system.mass @ q
        r = system.jacobian @ q + 1j * omega * mq
        return np.concatenate([r.real, r.imag, [q[self.phase].real, np.vdot(q, mq).real - 1.0]])

    def solve(self, y: np.ndarray, border: np.ndarray, rhs: np.ndarray, reuse: bool) -> np.ndarray:
        n, k = self.n, self.phase
        if np.any(border[: 2 * n + 1]):
            raise InputError("the neutral-point border has weight on (U*, log m) only")
        q, omega, velocity, log_mass = self.unpack(y)
        system = self.system(velocity, log_mass)
        factor = self._factor if reuse else None
        shift = factor.shift if factor is not None else 1j * omega
        key = (velocity, log_mass, shift, id(factor))
        if self._solver is None or self._solver[0] != key or factor is None:
            solver = ShiftedSolver(system, shift, fluid_factor=factor, counter=self.counter)
            self._factor = solver.fluid_factor
            self._solver = ((velocity, log_mass, shift, id(self._factor)), solver)
        solver = self._solver[1]
        mq = system.mass @ q
        r_q = rhs[:n] + 1j * rhs[n : 2 * n]
        a = solver.solve(r_q) if np.any(r_q) else np.zeros(n, dtype=complex)
        b = solver.solve(-1j * mq)
        c = solver.solve(-velocity_derivative(system, q))
        small = np.array([rhs[2 * n] - a[k].real, rhs[2 * n + 1] - 2 * np.vdot(mq, a).real, rhs[2 * n + 2]])
        if unit_index(border) == self.mass_index and small[2] == 0:  # m held: δμ = 0
            matrix = np.array([[b[k].real, c[k].real], [2 * np.vdot(mq, b).real, 2 * np.vdot(mq, c).real]])
            d_omega, d_velocity = np.linalg.solve(matrix, small[:2])
            return self.pack(a + d_omega * b + d_velocity * c, d_omega, d_velocity, 0.0)
        d = solver.solve(-mass_derivative(system, q, omega))
        matrix = np.array(
            [
                [b[k].real, c[k].real, d[k].real],
                [2 * np.vdot(mq, b).real, 2 * np.vdot(mq, c).real, 2 * np.vdot(mq, d).real],
                [0.0, border[-2], border[-1]],
            ]
        )
        d_omega, d_velocity, d_log_mass = np.linalg.solve(matrix, small)
        return self.pack(a + d_omega * b + d_velocity * c + d_log_mass * d, d_omega, d_velocity, d_log_mass)

    def curve(self) -> CurveProblem:
        """The neutral curve in the ``(m, U*)`` plane: arclength weights on ``(U*, log m)`` only,
        turning points in ``m``."""
        weights = np.zeros(self.size)
        weights[-2:] = 1.0
        return CurveProblem(self.residual, self.solve, parameter=-1, weights=weights)

    def at_mass_ratio(self, mass_ratio: float) -> SquareProblem:
        """The neutral point at fixed ``mass_ratio`` (unknowns ``q̂, ω, U*``)."""
        return self.curve().pinned(self.mass_index, math.log(mass_ratio))


def _with_velocity(solid: Solid, reduced_velocity: float) -> Solid:
    if not np.isfinite(reduced_velocity) or reduced_velocity <= 0:
        raise ConvergenceError(
            f"critical-point Newton left the admissible range (U* = {reduced_velocity:g}); "
            "start closer to the crossing (a finer sweep in U*)"
        )
    return replace(solid, reduced_velocity=float(reduced_velocity))


def flutter_point(
    fluid: FluidOperators,
    solid: Solid,
    frequency: float,
    mode: np.ndarray,
    *,
    tol: float = 1e-10,
    maxit: int = 12,
    counter: FactorCounter | None = None,
) -> NeutralPoint:
    """The neutral point of docs/model.md §8 at ``solid.mass_ratio``: :func:`fsistab.continuation.newton`
    on the augmented sparse system (:class:`AugmentedProblem`, ``m`` held)
    from ``(mode, frequency, solid.reduced_velocity)``.

    ``mode`` is a coupled vector of the system for ``solid`` (e.g. the eigenvector of the
    eigenvalue closest to the axis). Converges quadratically; raises ConvergenceError otherwise.
    """
    counter = counter if counter is not None else FactorCounter()
    start = counter.count
    problem = AugmentedProblem(fluid, solid, counter)
    y0 = problem.start(mode, float(frequency), float(solid.reduced_velocity), solid.mass_ratio)
    result = newton(problem.at_mass_ratio(solid.mass_ratio), y0, tol=tol, max_iterations=maxit)
    q, omega, velocity, _ = problem.unpack(result.point)
    if result.converged:
        return NeutralPoint(
            solid.mass_ratio,
            velocity,
            omega,
            kind="flutter",
            mode=q,
            residuals=result.residuals,
            iterations=result.iterations,
            factorisations=counter.count - start,
        )
    raise ConvergenceError(
        f"flutter Newton did not converge near U* = {velocity:.4g}, omega = {omega:.4g} "
        f"({result.reason}; residuals {', '.join(f'{r:.1e}' for r in result.residuals[-4:])}); "
        "start closer to the crossing"
    )


class DivergenceProblem:
    """Static instability (``ω_c = 0``, docs/model.md §8) as a real square system in ``y = (q̂, κ)``,
    ``κ = 1/U*²``, for the solid parameters of ``solid`` otherwise::

        J(U*) q̂ = 0,     θ̂ = 1

    ``U*`` enters ``J`` only through the in-vacuo solid rows (stiffness ``∝ κ``; damping ``∝ √κ``
    multiplies ``ḣ = θ' = 0`` in a static mode), so the system is affine in ``κ`` and a Newton
    step can land on the root exactly, where ``J(U*)`` is singular: the problem says so
    (``singular_is_root``). A step eliminates ``δq̂ = a + δκ c`` with
    ``J(a, c) = (r_q, -∂J/∂κ q̂)`` — the one real factorisation of ``J_ff`` (``fluid_factor``) and
    the solid Schur complement (:class:`~fsistab.linalg.ShiftedSolver`) — and fixes ``δκ`` by the
    row ``θ̂ = 1``, held exactly (so ``‖G‖ = ‖J q̂‖``)."""

    def __init__(self, fluid: FluidOperators, solid: Solid, fluid_factor: FluidFactor):
        if "pitch" not in solid.dofs:
            raise InputError("divergence needs the pitch degree of freedom")
        self.fluid, self.solid, self.fluid_factor = fluid, solid, fluid_factor
        self._initial = CoupledSystem(fluid, solid)
        self.n, self.pitch = self._initial.size, self._initial.state_labels().index("theta")
        self._system: tuple[float, CoupledSystem] | None = None

    @staticmethod
    def velocity(kappa: float) -> float:
        """``U* = 1/√κ``; a step past ``U* = ∞`` (``κ ≤ 0``) is held at ``U* = 10¹⁵⁰``, where the
        residual is still recorded and the next step is not finite: the Newton fails there."""
        return float(1.0 / np.sqrt(max(kappa, 1e-300)))

    def system(self, kappa: float) -> CoupledSystem:
        if self._system is None or self._system[0] != kappa:
            solid = _with_velocity(self.solid, self.velocity(kappa))
            self._system = (kappa, CoupledSystem(self.fluid, solid))
        return self._system[1]

    def start(self) -> np.ndarray:
        """``y`` at ``solid.reduced_velocity``: ``q̂ = J⁻¹ e_θ`` (one inverse-iteration step towards
        the null vector), scaled to ``θ̂ = 1``."""
        unit = np.zeros(self.n)
        unit[self.pitch] = 1.0
        q = ShiftedSolver(self._initial, 0.0, fluid_factor=self.fluid_factor).solve(unit)
        return np.append(q / q[self.pitch], float(self.solid.reduced_velocity) ** -2)

    def residual(self, y: np.ndarray) -> np.ndarray:
        q = y[:-1]
        return np.append(self.system(y[-1]).jacobian @ q, q[self.pitch] - 1.0)

    def solve(self, y: np.ndarray, rhs: np.ndarray, reuse: bool) -> np.ndarray:
        q, kappa, k = y[:-1], y[-1], self.pitch
        system = self.system(kappa)
        # LinAlgError where J(U*) is exactly singular: at the root (singular_is_root)
        solver = ShiftedSolver(system, 0.0, fluid_factor=self.fluid_factor)
        # ∂J/∂κ q̂ = ∂J/∂U* q̂ dU*/dκ; not finite near U* = ∞ (overflow): a failed step for newton
        with np.errstate(over="ignore", invalid="ignore"):
            d_kappa_q = velocity_derivative(system, q) * (-(np.float64(self.velocity(kappa)) ** 3) / 2)
        a = solver.solve(rhs[:-1])
        c = solver.solve(-d_kappa_q)
        d_kappa = (rhs[-1] - a[k]) / c[k]
        delta = np.append(a + d_kappa * c, d_kappa)
        delta[k] = rhs[-1]  # θ̂ = 1 held exactly, without round-off drift
        return delta

    def square(self) -> SquareProblem:
        return SquareProblem(self.residual, self.solve, singular_is_root=True)


def divergence_point(
    fluid: FluidOperators,
    solid: Solid,
    *,
    tol: float = 1e-10,
    maxit: int = 20,
    counter: FactorCounter | None = None,
    fluid_factor: FluidFactor | None = None,
) -> NeutralPoint:
    """Static instability ``J(U*) q̂ = 0`` (``θ̂ = 1``): :func:`fsistab.continuation.newton` on
    :class:`DivergenceProblem` in ``(q̂, 1/U*²)`` from ``solid.reduced_velocity``.

    Converged when ``‖J q̂‖ < tol``, after a step in ``κ = 1/U*²`` below ``1e-13 κ`` (the residual
    at the new point is recorded) or on a point where ``J(U*)`` is exactly singular. One real
    factorisation of ``J_ff`` (pass ``fluid_factor`` to share it between mass ratios).
    """
    counter = counter if counter is not None else FactorCounter()
    start = counter.count
    if "pitch" not in solid.dofs:
        raise InputError("divergence needs the pitch degree of freedom")
    problem = DivergenceProblem(fluid, solid, fluid_factor or FluidFactor(fluid, 0.0, counter))
    result = newton(
        problem.square(),
        problem.start(),
        tol=tol,
        max_iterations=maxit,
        small_step=lambda d, y: abs(d[-1]) < 1e-13 * y[-1],
        final_residual=True,
    )
    velocity = problem.velocity(result.point[-1])
    if result.converged:
        return NeutralPoint(
            solid.mass_ratio,
            velocity,
            0.0,
            kind="divergence",
            branch="static",
            mode=result.point[:-1].copy(),
            residuals=result.residuals,
            iterations=result.iterations,
            factorisations=counter.count - start,
        )
    raise ConvergenceError(
        f"divergence Newton did not converge near U* = {velocity:.4g} "
        f"(residuals {', '.join(f'{r:.1e}' for r in result.residuals[-4:])}); try another starting U*"
    )


def solid_mode_starts(
    system: CoupledSystem, wake_shift: complex | None = None, n_eigenvalues: int = 8
) -> dict:
    """Starting eigenpairs of the branches to follow: one per active solid dof (the eigenvalue near
    its in-vacuo frequency holding the most solid energy) and, if ``wake_shift`` is given, the
    least stable fluid mode near it."""
    solid = system.solid
    in_vacuo = {"heave": solid.freq_ratio / solid.reduced_velocity, "pitch": 1.0 / solid.reduced_velocity}
    starts = {}
    for dof in solid.dofs:
        pairs = eigenpairs_near(system, [0.002 + 1j * in_vacuo[dof]], n_eigenvalues)
        matching = [p for p in pairs if p.label in (dof, "coupled")] or pairs
        candidates = [p for p in matching if all(abs(p.value - s.value) > 1e-9 for s in starts.values())]
        starts[dof] = max(candidates, key=lambda p: p.solid_energy_fraction)
    if wake_shift is not None:
        pairs = eigenpairs_near(system, [wake_shift], n_eigenvalues)
        fluid = [p for p in pairs if p.label == "fluid"] or pairs
        starts["wake"] = max(fluid, key=lambda p: p.growth_rate)
    return starts


def _same_point(point, threshold, rtol: float = 1e-7) -> bool:
    """Whether ``point`` is ``threshold``'s neutral point (U* and ω within ``rtol``)."""
    other = threshold
    return abs(point.reduced_velocity - other.reduced_velocity) <= rtol * abs(other.reduced_velocity) and abs(
        point.frequency - other.frequency
    ) <= rtol * max(abs(other.frequency), 1.0)


def find_thresholds(
    fluid: FluidOperators,
    solid: Solid,
    velocities: np.ndarray,
    *,
    wake_shift: complex | None = None,
    counter: FactorCounter | None = None,
    progress: Progress = None,
    static_factor: FluidFactor | None = None,
    method: str = "transfer",
    client=None,
) -> tuple[list[NeutralPoint], dict]:
    """Every threshold with U* between ``velocities[0]`` and ``velocities[-1]`` (increasing) at
    ``solid.mass_ratio``; ``wake_shift`` a guess of the fixed body's wake eigenvalue; ``client``: a
    ``dask.distributed`` client whose workers factorise the sweep's samples (transfer only).

    ``method="transfer"`` (default): the exact transfer function swept in frequency
    (:func:`fsistab.frequency_sweep.sweep_thresholds`), every neutral point of the range, each
    converged by Newton on ``det T``; ``velocities`` only give the range. Each dynamic threshold is
    labelled ``viv`` or ``flutter`` by the local frequency following of its neutral curve (the
    map's rule, :func:`fsistab.frequency_sweep.local_following`), with or without ``wake_shift``:
    the wake mode refined from it (one eigen-solve) only adds samples near its frequency.
    ``method="tracking"``: the eigenvalue branches of the solid modes (and, with ``wake_shift``, the
    wake mode) followed over ``velocities`` (:func:`track_thresholds`); a crossing of a mode no
    branch follows is missed, and VIV is recognised only with ``wake_shift`` (a crossing of the
    wake branch or within 30 % of its frequency: the tangent of the local rule would cost a
    factorisation per threshold there). Both converge each threshold to the same equation
    (docs/model.md §8).

    Returns the thresholds sorted by U* and details: ``wake_frequency`` (None without
    ``wake_shift``), and ``frequencies`` sampled (transfer) or the tracked ``branches``.
    """
    if method not in THRESHOLD_METHODS:
        raise InputError(f"unknown threshold method {method!r}: choose {', '.join(THRESHOLD_METHODS)}")
    counter = counter if counter is not None else FactorCounter()
    velocities = np.asarray(velocities, dtype=float)
    if velocities.ndim != 1 or len(velocities) < 2 or np.any(np.diff(velocities) <= 0) or velocities[0] <= 0:
        raise InputError("the reduced velocities must be positive and increasing (at least two)")
    if method == "tracking":
        if client is not None:
            raise InputError("--workers and --scheduler spread the samples of --method transfer only")
        return track_thresholds(
            fluid, solid, velocities, wake_shift=wake_shift, counter=counter, progress=progress,
            static_factor=static_factor,
        )  # fmt: skip

    wake = None
    if wake_shift is not None:
        wake = wake_mode_near(fluid, float(complex(wake_shift).imag), counter=counter).frequency
    result = sweep_thresholds(
        fluid, solid, (float(velocities[0]), float(velocities[-1])), wake_frequency=wake,
        static_factor=static_factor, counter=counter, progress=progress, client=client,
    )  # fmt: skip
    thresholds = []
    for t in result.thresholds:
        at = replace(solid, reduced_velocity=t.reduced_velocity)
        if t.kind == "divergence":  # real, θ̂ = 1 (as divergence_point)
            mode = (t.mode / t.mode[active_states(at).index(1)]).real  # state 1 of (h, θ, ḣ, θ') is θ
        else:  # Re(ĥ) = 0, q̂ᴴMq̂ = 1 (as flutter_point: the curves of fsistab.neutral start from it)
            problem = AugmentedProblem(fluid, at)
            mode = problem.unpack(problem.start(t.mode, t.frequency, t.reduced_velocity, t.mass_ratio))[0]
        thresholds.append(replace(t, mode=mode))
    return thresholds, {
        "wake_frequency": wake,
        "frequencies": result.frequencies,
        "unresolved": result.unresolved,
    }


def track_thresholds(
    fluid: FluidOperators,
    solid: Solid,
    velocities: np.ndarray,
    *,
    wake_shift: complex | None = None,
    counter: FactorCounter | None = None,
    progress: Progress = None,
    static_factor: FluidFactor | None = None,
) -> tuple[list[NeutralPoint], dict]:
    """Every threshold along ``velocities`` (increasing U*) at ``solid.mass_ratio`` by branch
    tracking.

    Branches are tracked (:mod:`fsistab.tracking`); each sign change of a growth rate is refined by
    :func:`flutter_point` from the interpolated crossing; divergence comes from
    :func:`divergence_point` when pitch is active. A crossing is ``viv`` when its branch is the
    wake mode or its frequency is within 30 % of the wake frequency, ``flutter`` otherwise.
    Returns the thresholds sorted by U* and ``{"branches", "wake_frequency"}``.
    """
    counter = counter if counter is not None else FactorCounter()
    velocities = np.asarray(velocities, dtype=float)
    say = progress or (lambda message: None)

    def system_at(velocity: float) -> CoupledSystem:
        return CoupledSystem(fluid, replace(solid, reduced_velocity=float(velocity)))

    starts = solid_mode_starts(system_at(velocities[0]), wake_shift)

    branches = track_branches(
        system_at, velocities, starts, inverse_scaling=solid.dofs, counter=counter, progress=say
    )
    wake_frequency = starts["wake"].frequency if "wake" in starts else None
    found: list[NeutralPoint] = []
    for name, branch in branches.items():
        found += _branch_crossings(fluid, solid, name, branch, wake_frequency, counter)
    if "pitch" in solid.dofs:
        point = _tracked_divergence(fluid, solid, static_factor, counter)
        if point is not None and velocities[0] <= point.reduced_velocity <= velocities[-1]:
            found.append(replace(point, boundary="onset"))
    return sorted(found, key=lambda t: t.reduced_velocity), {
        "branches": branches,
        "wake_frequency": wake_frequency,
    }


def _branch_crossings(fluid, solid: Solid, name: str, branch, wake_frequency, counter) -> list[NeutralPoint]:
    """The dynamic thresholds where the growth rate of the tracked ``branch`` (named ``name``)
    changes sign, each converged by :func:`flutter_point` from the interpolated crossing, each
    once per boundary."""
    found: list[NeutralPoint] = []
    growth = np.array([v.real for v in branch.values])
    for i in np.nonzero(np.sign(growth[1:]) != np.sign(growth[:-1]))[0]:
        u0, u1 = branch.parameters[i], branch.parameters[i + 1]
        weight = growth[i] / (growth[i] - growth[i + 1])
        guess_velocity = u0 + weight * (u1 - u0)
        guess = branch.values[i] + weight * (branch.values[i + 1] - branch.values[i])
        if abs(guess.imag) < 1e-6:
            continue  # a static crossing: divergence, found apart
        point = flutter_point(
            fluid,
            replace(solid, reduced_velocity=guess_velocity),
            guess.imag,
            branch.vectors[i + 1],
            counter=counter,
        )
        if abs(point.frequency) <= STATIC_FREQUENCY:
            continue  # the branch met ω = 0 on the way: the divergence point, found apart
        boundary = "onset" if growth[i] < 0 else "restabilisation"
        if any(_same_point(point, t) and t.boundary == boundary for t in found):
            continue  # the same threshold found twice; an onset and a restabilisation at one
            # point stay both: the growth rate touches zero there (or one crossing is unresolved)
        is_viv = name == "wake" or (
            wake_frequency is not None and abs(point.frequency - wake_frequency) < 0.3 * wake_frequency
        )
        found.append(replace(point, kind="viv" if is_viv else "flutter", boundary=boundary, branch=name))
    return found


def _tracked_divergence(fluid, solid: Solid, static_factor, counter) -> NeutralPoint | None:
    """The divergence point by :func:`divergence_point`, started a little below the
    torsional-divergence estimate ``√(m r_θ²/(dC_M/dθ))`` (exact at α0 = 0; at the root itself the
    static system is singular); None without a positive moment slope."""
    factor = static_factor or FluidFactor(fluid, 0.0, counter)
    slope = static_slopes(fluid, factor=factor).moment
    if not slope > 0:
        return None
    estimate = 0.98 * divergence_velocity(slope, solid.r_theta, solid.mass_ratio)
    return divergence_point(
        fluid, replace(solid, reduced_velocity=estimate), counter=counter, fluid_factor=factor
    )


def critical_points_along_flow(
    spec,
    flows,
    solid: Solid,
    flutter_frequency: float,
    *,
    cache_dir=None,
    initial=None,
    counter: FactorCounter | None = None,
    progress: Progress = None,
):
    """Neutral curves in the ``(Re, U*)`` or ``(α0, U*)`` plane (docs/model.md §8) at fixed solid
    parameters: natural continuation along ``flows`` (ordered), on one mesh ``spec``. A generator
    of ``(flutter, divergence)`` neutral points, one pair per flow, each with its ``reynolds``,
    ``alpha0_deg`` and the factorisations of that flow (counted once, on the flutter point), so
    that a caller keeps the points computed before a failure
    (:class:`~fsistab.errors.ConvergenceError`: try smaller steps in the flow parameter).

    Each steady state continues from the previous one; the flutter point is converged by Newton on
    ``det T(iω; U*) = 0`` (:func:`fsistab.transfer.transfer_flutter_point`), started from a secant
    extrapolation of the last two points in ``(ω, log U*)`` (``solid.reduced_velocity`` and
    ``flutter_frequency`` at the first flow, e.g. a threshold of :func:`find_thresholds`); the
    divergence point by :func:`divergence_point`, started from the previous one.
    """
    flows = list(flows)
    if not flows:
        raise InputError("give at least one flow")
    counter = counter if counter is not None else FactorCounter()
    previous_state = initial
    guesses = [(float(flutter_frequency), float(np.log(solid.reduced_velocity)))]
    divergence_guess = float(solid.reduced_velocity)
    for i, flow in enumerate(flows):
        start = counter.count
        steady = solve_steady(spec, flow, cache_dir=cache_dir, initial=previous_state)
        previous_state = steady
        fluid = fluid_operators(steady)
        if len(guesses) >= 2 and i >= 2:
            (w1, u1), (w2, u2) = guesses[-2], guesses[-1]
            x0, x1, x2 = (_flow_parameter(flows[j], flows) for j in (i - 2, i - 1, i))
            ratio = (x2 - x1) / (x1 - x0) if x1 != x0 else 0.0
            omega, log_u = w2 + ratio * (w2 - w1), u2 + ratio * (u2 - u1)
        else:
            omega, log_u = guesses[-1]
        flutter, _ = transfer_flutter_point(
            fluid, replace(solid, reduced_velocity=float(np.exp(log_u))), omega, counter=counter
        )
        guesses.append((flutter.frequency, float(np.log(flutter.reduced_velocity))))
        divergence = divergence_point(
            fluid, replace(solid, reduced_velocity=divergence_guess), counter=counter
        )
        # restart a little below the last root: at the root itself the static system is singular
        divergence_guess = 0.95 * divergence.reduced_velocity
        if progress:
            progress(f"flow {i + 1}/{len(flows)}: Re = {flow.reynolds:g}, alpha0 = {flow.alpha0_deg:g} deg")
        at_flow = {"reynolds": flow.reynolds, "alpha0_deg": flow.alpha0_deg}
        yield (
            replace(flutter, kind="flutter", factorisations=counter.count - start, **at_flow),
            replace(divergence, factorisations=0, **at_flow),
        )


def _flow_parameter(flow, flows) -> float:
    """The parameter that varies along ``flows``: log Re if Re varies, else α0."""
    if len({f.reynolds for f in flows}) > 1:
        return float(np.log(flow.reynolds))
    return float(flow.alpha0_deg)


def wake_mode_near(
    fluid: FluidOperators, frequency: float, n_eigenvalues: int = 6, counter: FactorCounter | None = None
):
    """The least stable fixed-body mode among the ``n_eigenvalues`` nearest ``iω`` (``frequency``
    a guess in ``U∞/L``, e.g. from a Strouhal number): the wake mode that drives vortex-induced
    vibration, refined from a guess. (A global search for "the least stable mode" is ambiguous
    here: the truncated domain has a cloud of weakly damped modes advected through its far field
    at every frequency, on the coarse plate mesh less damped than the wake mode itself.)"""
    if not (np.isfinite(frequency) and frequency > 0):
        raise InputError(f"the wake-frequency guess must be positive, got {frequency}")
    pairs = eigenpairs_near(
        CoupledSystem(fluid, Solid(dofs=())), [1j * frequency], n_eigenvalues, counter=counter
    )
    return max(pairs, key=lambda p: p.growth_rate)
