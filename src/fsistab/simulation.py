"""Time march of the nonlinear coupled fluid–solid system (docs/model.md §5, §12).

``M q̇ + R(q) = 0`` with ``R`` the project's nonlinear residual (:class:`fsistab.coupled.CoupledResidual`
over :class:`fsistab.operators.FluidResidual`, the one every block of the Jacobian is checked
against) and ``M`` the mass of the operators' terms (``TERMS``) applied to the whole dof vector,
wall dofs included: the wall velocity follows the solid state through the nonlinear lifting, so
``M`` acts on the rate of the full velocity field and the loads carry the inertia of the discrete
wall lifting, exactly as in the linear mass ``M`` of docs/model.md §7.

Time discretisation: BDF2 (the first step from a state without history is BDF1),

    (c₀ qⁿ⁺¹ + c₁ qⁿ + c₂ qⁿ⁻¹)/Δt  in place of  q̇,   BDF2: (3/2, -2, 1/2),  BDF1: (1, -1, 0),

fully implicit in the fluid, the solid and their coupling (monolithic, hence free of the added-mass
instability of partitioned schemes at any mass ratio). Each step solves ``F(qⁿ⁺¹) = 0`` by a chord
(simplified Newton) iteration whose matrix is ``J + (c₀/Δt) M`` at the steady state: the shifted
coupled matrix of the eigenvalue solver, factorised once per ``(c₀, Δt)``
(:class:`fsistab.linalg.ShiftedSolver`, the solid unknowns bordered). Near the steady state it is
the exact Jacobian; far from it (a saturated wake) the iteration converges linearly, accelerated
by Anderson mixing, and the fluid block of its matrix is rebuilt about the current flow and
motion (:meth:`TimeStepper.refresh`) when the iterations it saves are expected to outweigh the
rebuild (:func:`rebuild_due`). A step stops when the update's largest
entry is below the tolerance, and fails (ConvergenceError, with the advice to reduce the step)
when it does not within the iterations allowed.
"""

from __future__ import annotations

import math
import time as clock
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp

from fsistab.coupled import CoupledResidual, CoupledSystem
from fsistab.errors import ConvergenceError, InputError
from fsistab.linalg import FactorCounter, ShiftedSolver
from fsistab.operators import (
    FluidResidual,
    _to_scipy,
    free_dof_indices,
    full_dof_vector,
    mass_integrand,
    motion_coefficients,
    quadratic_integrand,
    steady_fields,
    wall_lifting_matrix,
)

BDF_COEFFICIENTS = {1: (1.0, -1.0, 0.0), 2: (1.5, -2.0, 0.5)}


def full_mass_matrix(steady) -> sp.csr_matrix:
    """The mass of the operators' terms (:func:`fsistab.operators.mass_integrand`) on every dof of
    the space, wall dofs included (SciPy CSR): the ``M`` of ``M q̇`` before the wall dofs are
    eliminated (docs/model.md §5)."""
    from ngsolve import BilinearForm, dx

    space = steady.space
    (u, p), (v, q) = space.TnT()
    form = BilinearForm(space)
    form += mass_integrand(steady_fields(steady), (u, p), (v, q)) * dx
    form.Assemble()
    return _to_scipy(form.mat, space.ndof)


# solid states (h, θ, ḣ, θ') with independent weights (1, W_x, W_y, θ'): the affine parts' extraction
EXTRACTION_STATES = ((0, 0, 0, 0), (0, 0, 1, 0), (0, math.pi / 2, 0, 0), (0, 0, 0, 1))


def affine_parts(residual: FluidResidual) -> tuple[sp.csr_matrix, ...]:
    """The matrices ``L_k`` (every dof, SciPy CSR) of the residual's part affine in the fluid state:
    ``R(U; q_s) = Σ_k c_k(q_s) L_k U + Q(U)`` with ``c`` the weights of
    :func:`fsistab.operators.motion_coefficients` and ``Q`` the part of degree two
    (:func:`fsistab.operators.quadratic_integrand`), docs/model.md §12. The form's linearisation at
    ``U = 0``, where ``Q``'s vanishes, is ``Σ_k c_k(q_s) L_k``: made at the four
    :data:`EXTRACTION_STATES`, it gives the ``L_k`` by inverting their weights. So the terms
    are written once (:class:`fsistab.operators.Term`) and evaluated at the cost of sparse products."""
    zero = np.zeros(residual.steady.space.ndof)
    states = [np.array(q, dtype=float) for q in EXTRACTION_STATES]
    inverse = np.linalg.inv(np.array([motion_coefficients(q) for q in states]))
    linearised = [FluidResidual.linearisation(residual, q, zero) for q in states]
    return tuple(sum(w * m for w, m in zip(row, linearised, strict=True)).tocsr() for row in inverse)


class InertialFluidResidual(FluidResidual):
    """:class:`fsistab.operators.FluidResidual` plus the fluid's inertia ``M_all U̇`` (docs/model.md
    §5), called alike (free-dof rows, body-axis loads), so that
    :class:`fsistab.coupled.CoupledResidual` built on it is the residual of the time-discrete
    system. ``U̇ = (c₀/Δt) U(q_s, q_f) + history`` on the full dof vector, ``history`` the discrete
    rate's part from the previous steps (:meth:`set_rate`). The loads are the reaction loads with
    inertia, ``-ℓᵀ(M U̇ + R)``; the last ones computed are kept in ``loads``.

    The march evaluates the residual several times per step, so as ``Σ_k c_k(q_s) L_k U + Q(U)``
    (:func:`affine_parts`): sparse products and the convection's compiled form alone, instead of
    every term's form at every quadrature point; the same residual to round-off. Its
    linearisation likewise: ``Σ_k c_k L_k + Q'(U)``."""

    def __init__(self, steady):
        from ngsolve import BilinearForm, dx

        super().__init__(steady)
        (u, p), (v, q) = steady.space.TnT()
        self.parts = affine_parts(self)
        quadratic = BilinearForm(steady.space)
        quadratic += quadratic_integrand(steady_fields(steady), (u, p), (v, q)).Compile() * dx
        self.quadratic = quadratic
        self.mass = full_mass_matrix(steady)
        self.scale = 0.0
        self.history = np.zeros(self.mass.shape[0])
        self.loads = np.zeros(3)

    def state_residual(self, q_solid: np.ndarray, values: np.ndarray) -> np.ndarray:
        self._vector.FV().NumPy()[:] = values
        self.quadratic.Apply(self._vector, self._residual)
        r = self._residual.FV().NumPy().copy()
        for weight, part in zip(motion_coefficients(q_solid), self.parts, strict=True):
            if weight:
                r += weight * (part @ values)
        return r

    def linearisation(self, q_solid: np.ndarray, values: np.ndarray) -> sp.csr_matrix:
        self._vector.FV().NumPy()[:] = values
        self.quadratic.AssembleLinearization(self._vector)
        matrix = _to_scipy(self.quadratic.mat, self.steady.space.ndof)
        for weight, part in zip(motion_coefficients(q_solid), self.parts, strict=True):
            if weight:
                matrix = matrix + weight * part
        return matrix.tocsr()

    def set_rate(self, scale: float, history: np.ndarray) -> None:
        """``U̇ = scale·U + history`` for the next calls."""
        self.scale, self.history = float(scale), history

    def __call__(self, q_solid: np.ndarray, q_fluid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        values = self.full_state(q_solid, q_fluid)
        inertia = self.mass @ (self.scale * values + self.history)
        r_fluid, self.loads = self.rows_and_loads(q_solid, self.state_residual(q_solid, values) + inertia)
        return r_fluid, self.loads


def load_coefficients(theta: float, loads: np.ndarray) -> tuple[float, float, float]:
    """``(C_L, C_D, C_M)`` of body-axis loads ``(F_x, F_y, M)`` at pitch ``θ`` (docs/model.md §4):
    ``C_L = 2{R(θ)F}·e_y``, ``C_D = 2{R(θ)F}·e_x``, ``C_M = 2M``."""
    c, s = math.cos(theta), math.sin(theta)
    fx, fy, moment = loads
    return 2 * (s * fx + c * fy), 2 * (c * fx - s * fy), 2 * moment


@dataclass(frozen=True)
class Sample:
    """One time of the march: the solid state ``(h, θ, ḣ, θ')`` (steady values for inactive
    states), the load coefficients, and the step's chord iterations and last update (largest
    entry)."""

    time: float
    solid: np.ndarray
    lift: float
    drag: float
    moment: float
    iterations: int
    update: float


@dataclass
class MarchState:
    """Where a march is: ``time``, ``step``, the coupled vectors ``current`` (``qⁿ``) and
    ``previous`` (``qⁿ⁻¹``, None before the first step: the next step is then BDF1)."""

    time: float
    step: int
    current: np.ndarray
    previous: np.ndarray | None = None


@dataclass
class TimeStepper:
    """BDF2 steps of ``M q̇ + R(q) = 0`` for ``system`` (module docstring), ``time_step`` Δt in the
    body's time unit. ``tolerance``: largest entry of the last chord update; ``max_iterations`` per
    step. ``counter`` counts the factorisations (one per BDF order used); ``depth``: the previous
    iterates of the step's Anderson mixing (0: the plain chord iteration). After a step that needed
    more than ``refresh_after`` iterations the iteration matrix is rebuilt at the new state
    (:meth:`refresh`) when :func:`rebuild_due` says so; ``refresh_after = 0`` keeps the steady
    state's. ``rebuild_cost``: a rebuild's cost (a linearisation and a factorisation) in chord
    iterations for that rule, fixed so that a march takes the same path on any machine and load
    (its measured range and the rule's cost: docs/performance.md, "The time march")."""

    system: CoupledSystem
    time_step: float
    tolerance: float = 1e-9
    max_iterations: int = 30
    counter: FactorCounter = field(default_factory=FactorCounter)
    depth: int = 4
    refresh_after: int = 6
    rebuild_cost: float = 10.0

    def __post_init__(self):
        self.fluid = InertialFluidResidual(self.system.fluid.steady)
        self.residual = CoupledResidual(self.system, self.fluid)
        self._solvers: dict[int, ShiftedSolver] = {}
        self._linearised = self.system  # the system whose J + (c₀/Δt) M is factorised
        self.refreshes, self.steps, self._last_refresh = 0, 0, -1
        self._since_rebuild: list[int] = []  # chord iterations of the steps on the current matrix

    def steady_point(self) -> np.ndarray:
        """The steady state as a coupled vector."""
        return self.residual.point()

    def solid_state(self, q: np.ndarray) -> np.ndarray:
        """``(h, θ, ḣ, θ')`` of a coupled vector, inactive states at their steady values."""
        return self.residual.solid_state(q)

    def _full(self, q: np.ndarray) -> np.ndarray:
        return self.fluid.full_state(self.solid_state(q), q[self.system.n_solid :])

    def _solver(self, order: int) -> ShiftedSolver:
        if order not in self._solvers:
            shift = BDF_COEFFICIENTS[order][0] / self.time_step
            self._solvers[order] = ShiftedSolver(self._linearised, shift, counter=self.counter)
        return self._solvers[order]

    def _equations(self, order: int, current: np.ndarray, previous: np.ndarray | None):
        """``F(q)``: the residual of the time-discrete system (rates set in the fluid's inertia)."""
        c0, c1, c2 = BDF_COEFFICIENTS[order]
        dt, ns = self.time_step, self.system.n_solid
        history = c1 * current + (c2 * previous if c2 else 0.0)
        full_history = c1 * self._full(current) + (c2 * self._full(previous) if c2 else 0.0)
        self.fluid.set_rate(c0 / dt, full_history / dt)

        def equations(q: np.ndarray) -> np.ndarray:
            r = self.residual(q)
            # M_s(θ) q̇_s and the centripetal term of a static unbalance (docs/model.md §3.1)
            r[:ns] += self.residual.inertia(q, (c0 * q[:ns] + history[:ns]) / dt)
            return r

        return equations

    def step(self, state: MarchState) -> tuple[MarchState, Sample]:
        """One step from ``state``: BDF2, or BDF1 without a previous state. A step whose chord
        iteration does not converge on an iteration matrix made elsewhere is tried once more on
        one rebuilt at the step's start (:meth:`refresh`): a start whose flow is far from the steady
        state (a mode at a large amplitude, a saved state) may need it before its first step."""
        try:
            q, iterations, change = self._converge(state)
        except ConvergenceError:
            if self._last_refresh == self.steps:
                raise
            self.refresh(state.current)
            q, iterations, change = self._converge(state)
        # the loads are those of the last evaluation, at most the tolerance away from q
        new = MarchState(state.time + self.time_step, state.step + 1, q, state.current)
        self.steps += 1
        self._since_rebuild.append(iterations)
        if 0 < self.refresh_after < iterations and rebuild_due(self._since_rebuild, self.rebuild_cost):
            self.refresh(q)
        return new, self.sample(new.time, q, self.fluid.loads, iterations, change)

    def _converge(self, state: MarchState) -> tuple[np.ndarray, int, float]:
        """The chord iteration of one step (Anderson-mixed): ``(q, iterations, last update)``."""
        order = 1 if state.previous is None else 2
        equations = self._equations(order, state.current, state.previous)
        solver = self._solver(order)
        q = state.current.copy() if order == 1 else 2 * state.current - state.previous
        iterations, change, mixing = 0, math.inf, AndersonMixing(self.depth)
        while change > self.tolerance:
            if iterations == self.max_iterations:
                raise ConvergenceError(
                    f"the time step at t = {state.time:.6g} did not converge in {self.max_iterations} "
                    f"iterations (last update {change:.3g}); reduce --time-step"
                )
            # unrefined solves: the chord iteration corrects their error with the others'; a
            # diverging iterate is refused below, without NumPy's warnings on its way there
            with np.errstate(invalid="ignore", over="ignore"):
                update = solver.solve(-equations(q), refine=False)
            change, iterations = float(np.max(np.abs(update))), iterations + 1
            if not math.isfinite(change):  # diverged: no mixing of non-finite iterates
                raise ConvergenceError(
                    f"the time step at t = {state.time:.6g} diverged (a non-finite update at "
                    f"iteration {iterations}); reduce --time-step"
                )
            q = mixing.next(q, update)
        return q, iterations, change

    def refresh(self, q: np.ndarray) -> None:
        """Linearise the fluid block at ``q`` instead of the steady state: ``J_ff`` of the
        nonlinear residual about the current flow *and* motion
        (:meth:`fsistab.operators.FluidResidual.linearisation`: the grid velocity and the frame's
        rotation of a pitching body enter it), the coupling blocks kept, factorised anew at the
        next step (the same symbolic analysis). Only the iteration matrix changes, never the
        residual: a step converges to the same state."""
        fluid = self.system.fluid
        jff = self.fluid.linearisation(self.solid_state(q), self._full(q))
        if not np.isfinite(jff.data).all():  # said here, not later as a "singular" factorisation
            raise ConvergenceError("the iteration matrix rebuilt about the current state is not finite")
        index = fluid.free_dofs
        linearised = replace(
            fluid, jff=jff[index][:, index].tocsr(), analyses=dict(self._linearised.fluid.analyses)
        )
        self._linearised = CoupledSystem(linearised, self.system.solid)
        self._solvers.clear()
        self.refreshes += 1
        self._last_refresh = self.steps
        self._since_rebuild = []

    def sample(self, time: float, q: np.ndarray, loads: np.ndarray, iterations: int = 0, update=0.0):
        q_solid = self.solid_state(q)
        lift, drag, moment = load_coefficients(q_solid[1], loads)
        return Sample(time, q_solid, lift, drag, moment, iterations, update)

    def initial_sample(self, state: MarchState) -> Sample:
        """The sample at the start: loads with the inertia of the start's rate, taken as zero (a
        perturbed steady state starts from rest in the mode's phase: its rate is not part of the
        initial data)."""
        self.fluid.set_rate(0.0, np.zeros(self.fluid.mass.shape[0]))
        self.residual(state.current)
        return self.sample(state.time, state.current, self.fluid.loads)


def rebuild_due(iterations: list[int], cost: float) -> bool:
    """Whether to rebuild the chord iteration's matrix after the steps ``iterations`` (their chord
    iterations since the last rebuild, the newest last), a rebuild costing ``cost`` iterations.

    A renewal rule: the iterations per step since the last rebuild, the rebuild's cost included,
    ``(cost + Σ nᵢ)/k``, fall while the matrix is still good and rise once the steps grow dearer
    than that average; rebuild when the next step, predicted by the last two
    (``n_k + (n_k − n_{k−1})``), costs at least the average (docs/model.md §12). A matrix that
    ages within a few steps (a wake shedding vortices at a large amplitude) is rebuilt every other
    step or so; a steady count never is (its average stays above it by ``cost/k``)."""
    k, last = len(iterations), iterations[-1]
    predicted = last + (last - iterations[-2]) if k >= 2 else last
    return predicted >= (cost + sum(iterations)) / k


class AndersonMixing:
    """Anderson acceleration of a fixed-point iteration ``q ← q + g(q)`` (here ``g`` the chord
    update ``-(J + (c₀/Δt)M)⁻¹ F(q)``): the next iterate combines the last ``depth + 1`` iterates so
    that the combined update is smallest in the least-squares sense (Walker & Ni, SIAM J. Numer.
    Anal. 49, 2011). Near the steady state the chord update is already the Newton update and the
    mixing changes nothing; in a saturated wake, where the steady Jacobian is a poorer model, it
    cuts the iterations."""

    def __init__(self, depth: int):
        self.depth = depth
        self.iterates: list[np.ndarray] = []
        self.updates: list[np.ndarray] = []

    def next(self, q: np.ndarray, update: np.ndarray) -> np.ndarray:
        self.iterates.append(q.copy())
        self.updates.append(update)
        if self.depth == 0 or len(self.updates) < 2:
            return q + update
        self.iterates, self.updates = self.iterates[-self.depth - 1 :], self.updates[-self.depth - 1 :]
        d_updates = np.diff(np.array(self.updates), axis=0).T
        d_iterates = np.diff(np.array(self.iterates), axis=0).T
        gamma, *_ = np.linalg.lstsq(d_updates, update, rcond=None)
        return q + update - (d_iterates + d_updates) @ gamma


def perturbed_state(
    stepper: TimeStepper, mode: np.ndarray, amplitude: float, scale: str = "largest"
) -> np.ndarray:
    """The start of a march from the (coupled) eigenvector ``mode``, docs/model.md §12.

    ``scale="largest"``: ``q⁰ + ε Re(q̂)``, the steady state plus ``amplitude`` times the real part
    of the mode scaled so that its largest entry is real and of modulus one (a small perturbation
    that grows at the eigenvalue). ``"heave"`` or ``"pitch"``: the body *released* from the mode's
    solid state ``(ĥ, θ̂, ḣ̂, θ̂')`` scaled so that its heave (body lengths) or pitch (radians) is
    ``amplitude``, the fluid at its steady state (the wall moving with the body): a start at a
    chosen finite amplitude, for the envelope's growth rate σ(A). The whole mode scaled so is no
    start there: its fluid part is the solid's amplitude over the mode's solid share (many times
    the solid's amplitude near a plate's edges or in a cylinder's wake), far outside the linear
    range."""
    mode = np.asarray(mode, dtype=complex)
    if scale == "largest":
        return stepper.steady_point() + amplitude * (mode / mode[np.argmax(np.abs(mode))]).real
    names = stepper.system.state_labels()
    state = "h" if scale == "heave" else "theta"
    if state not in names:
        raise InputError(f"--perturbation-of {scale}: the {scale} is not a degree of freedom (--dofs)")
    peak = mode[names.index(state)]
    if abs(peak) <= 1e-12 * float(np.max(np.abs(mode))):
        raise InputError(
            f"--perturbation-of {scale}: the start mode has no {scale} component (the body is still "
            "in it); give a --shift nearer the body's mode (fsistab spectrum lists the modes)"
        )
    start = stepper.steady_point()
    start[: len(names)] += amplitude * (mode[: len(names)] / peak).real
    return start


def transferred_state(source, q: np.ndarray, stepper: TimeStepper) -> np.ndarray:
    """The coupled state ``q`` of a march on the mesh of the steady state ``source``, carried to
    ``stepper``'s mesh (docs/model.md §12, Start): the solid state kept; the fluid's velocity and
    pressure, whole (the wall values from the solid state through ``source``'s lifting), each
    interpolated onto the target's space (NGSolve's ``Set`` of the source field, found point by
    point in the source mesh); the target's wall values follow from the same solid state when it
    is marched. The interpolant is not discretely divergence-free on the target mesh: the first
    implicit step projects it, as it would a start at any finite amplitude. The source mesh must
    cover the target's (the same domain, or a larger one)."""
    from ngsolve import GridFunction

    solid, space = stepper.system.n_solid, source.space
    index = free_dof_indices(space)
    if q.size != solid + index.size:
        raise InputError(f"the start holds {q.size} unknowns, not the {solid + index.size} of its mesh")
    field = GridFunction(space)
    field.vec.FV().NumPy()[:] = full_dof_vector(
        wall_lifting_matrix(source), index, stepper.solid_state(q), q[solid:]
    )
    target = GridFunction(stepper.fluid.steady.space)
    for component, source_component in zip(target.components, field.components, strict=True):
        component.Set(source_component)
    return np.concatenate([q[:solid], target.vec.FV().NumPy()[stepper.fluid.index]])


def march(
    stepper: TimeStepper,
    state: MarchState,
    end_time: float,
    on_step: Callable[[MarchState, Sample], None] | None = None,
) -> Iterator[tuple[MarchState, Sample]]:
    """Steps from ``state`` until ``end_time`` (to within a thousandth of a step), yielding each
    new state and its sample; ``on_step`` is called with them first."""
    while state.time < end_time - 1e-3 * stepper.time_step:
        state, sample = stepper.step(state)
        if on_step is not None:
            on_step(state, sample)
        yield state, sample


@dataclass
class Rate:
    """Steps per second of wall-clock time since the start (a progress figure)."""

    start: float = field(default_factory=clock.perf_counter)
    steps: int = 0

    def add(self) -> float:
        self.steps += 1
        return self.steps / max(clock.perf_counter() - self.start, 1e-9)


def damped_oscillation(times: np.ndarray, values: np.ndarray) -> complex:
    """``σ = λ + iω`` of a signal ``a + Re(b e^{σt})`` sampled at equal steps, by Prony's method:
    the least-squares three-term recurrence of the samples, whose characteristic roots are ``1``
    and ``e^{±σΔt}`` (the root with ``ω ≥ 0`` is returned). Exact for such a signal; a
    perturbation growing from the steady state at an eigenvalue is one (docs/model.md §7, §12)."""
    times, values = np.asarray(times, dtype=float), np.asarray(values, dtype=float)
    step = np.diff(times)
    if len(values) < 6 or not np.allclose(step, step[0], rtol=1e-6):
        raise ValueError("Prony's fit needs at least six samples at equal time steps")
    columns = np.column_stack([values[2:-1], values[1:-2], values[:-3]])
    coefficients, *_ = np.linalg.lstsq(columns, values[3:], rcond=None)
    roots = np.roots([1.0, *(-coefficients)])
    root = roots[np.argmax(roots.imag)]
    return complex(np.log(root) / step[0])


@dataclass(frozen=True)
class Cycle:
    """A saturated oscillation over its last whole periods, from ``start`` to ``end``: angular
    ``frequency`` (time unit ``L/U∞``), ``mean`` and ``amplitude`` (half the peak-to-peak range)
    of the signal, and the number of ``periods``."""

    frequency: float
    mean: float
    amplitude: float
    periods: int
    start: float
    end: float


def mean_over(times: np.ndarray, values: np.ndarray, start: float, end: float) -> float:
    """The time average of a sampled signal over ``[start, end]`` (trapezoids on the samples
    inside and the values interpolated at the ends; e.g. the drag over the lift's whole periods)."""
    times, values = np.asarray(times, dtype=float), np.asarray(values, dtype=float)
    inside = (times > start) & (times < end)
    t = np.concatenate([[start], times[inside], [end]])
    v = np.interp(t, times, values)
    return float(np.sum(0.5 * (v[1:] + v[:-1]) * np.diff(t)) / (t[-1] - t[0]))


def last_cycles(times: np.ndarray, values: np.ndarray, periods: int = 10) -> Cycle:
    """The :class:`Cycle` of the last ``periods`` whole periods of an oscillating signal (fewer if
    the signal holds fewer), between upward crossings of the mid-range of its second half (where
    it is taken to be saturated), located by linear interpolation between samples. ValueError
    with fewer than two crossings."""
    times, values = np.asarray(times, dtype=float), np.asarray(values, dtype=float)
    late = values[len(values) // 2 :]
    centred = values - 0.5 * (late.max() + late.min())
    up = np.nonzero((centred[:-1] < 0) & (centred[1:] >= 0))[0]
    up = up[up >= len(values) // 2]
    if len(up) < 2:
        raise ValueError("the signal crosses its mean upwards fewer than twice: no whole period")
    up = up[-min(periods, len(up) - 1) - 1 :]
    weight = -centred[up] / (centred[up + 1] - centred[up])
    crossings = times[up] + weight * (times[up + 1] - times[up])
    start, end = float(crossings[0]), float(crossings[-1])
    count = len(crossings) - 1
    piece = values[(times >= start) & (times <= end)]
    amplitude = 0.5 * float(piece.max() - piece.min())
    mean = mean_over(times, values, start, end)
    return Cycle(2 * math.pi * count / (end - start), mean, amplitude, count, start, end)
