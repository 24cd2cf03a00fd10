"""Steady Navier–Stokes in the body frame (docs/model.md §4, §6): Newton with automatic continuation.

Unknowns are the absolute velocity written in the body axes ``U`` and the pressure ``P``
(Taylor–Hood P2–P1). The steady state is the flow around the body held at ``θ0 = -α0`` with the
uniform wall velocity ``W⁰ = R(θ0)ᵀ(-1, 0)ᵀ``; ``U = 0`` upstream and laterally, ``σN = 0``
downstream (or ``Re⁻¹(∇U)N − PN = 0``: the mesh specification's ``outlet``). It depends on ``Re``
and ``α0`` only, so one steady state serves every solid parameter.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from fsistab import store
from fsistab.bodies import WALL
from fsistab.errors import CacheError, ConvergenceError, InputError
from fsistab.geometry import DIRICHLET
from fsistab.mesh import MeshSpec, build_mesh
from fsistab.params import Flow
from fsistab.progress import Progress

NEWTON_TOL = 1e-9  # Euclidean norm of the residual on free dofs


def wall_velocity(theta: float) -> tuple[float, float]:
    """Translational grid velocity ``R(θ)ᵀ(-1, 0)ᵀ = (-cos θ, sin θ)`` (docs/model.md §4, ḣ = 0)."""
    return (-math.cos(theta), math.sin(theta))


def taylor_hood_space(mesh, complex: bool = False):
    """P2 velocity × P1 pressure with ``U`` Dirichlet on inlet, lateral sides and wall."""
    from ngsolve import H1, VectorH1

    return VectorH1(mesh, order=2, dirichlet=DIRICHLET, complex=complex) * H1(mesh, order=1, complex=complex)


def momentum_form(velocity, pressure, test_velocity, test_pressure, grid_velocity, inv_reynolds):
    """Weak steady residual of docs/model.md §4 (``∂U/∂t = θ' = 0``) as an integrand.

    ``((∇U)(U - W), v) + (σ(U, P), ∇v) - (∇·U, q)`` with ``σ = -P I + Re⁻¹(∇U + ∇Uᵀ)``: the
    symmetric stress makes ``σN = 0`` the natural downstream condition and gives the forces.
    """
    from ngsolve import Grad, InnerProduct, div

    u, p, v, q = velocity, pressure, test_velocity, test_pressure
    strain = Grad(u) + Grad(u).trans
    return (
        InnerProduct(Grad(u) * (u - grid_velocity), v)
        + inv_reynolds * InnerProduct(strain, Grad(v))
        - p * div(v)
        - q * div(u)
    )


def outlet_form(velocity, test_velocity, inv_reynolds):
    """``−Re⁻¹((∇U)ᵀN, v)`` on the outlet (docs/model.md §4, "Outlet"): added to
    :func:`momentum_form`, it turns the natural condition ``σN = 0`` into ``Re⁻¹(∇U)N − PN = 0``
    (the ``"gradient"`` outlet of :class:`fsistab.mesh.MeshSpec`), the condition of a residual
    written with ``Re⁻¹(∇U, ∇v)``, without changing the interior equations or the wall loads.
    Linear in ``U``: the same integrand in the residual and in every linearisation."""
    from ngsolve import Grad, InnerProduct, specialcf

    return -inv_reynolds * InnerProduct(Grad(velocity).trans * specialcf.normal(2), test_velocity)


def outlet_integral(outlet: str, velocity, test_velocity, inv_reynolds):
    """:func:`outlet_form` over the outlet for the ``"gradient"`` outlet, None for ``"stress"``."""
    from ngsolve import ds

    if outlet == "stress":
        return None
    # on the skeleton: the trial function's gradient is that of the element beside the outlet
    return outlet_form(velocity, test_velocity, inv_reynolds) * ds("outlet", skeleton=True)


def momentum_linearisation(
    velocity, pressure, test_velocity, test_pressure, base_velocity, grid_velocity, inv_reynolds
):
    """Derivative of :func:`momentum_form` at ``U⁰`` in the direction ``(u, p)`` (docs/model.md §7, ``J_ff``).

    ``((∇u)(U⁰ - W), v) + ((∇U⁰) u, v) + (Re⁻¹(∇u + ∇uᵀ), ∇v) - (p, ∇·v) - (q, ∇·u)``: written out,
    its assembly costs less than half of NGSolve's ``AssembleLinearization``, which differentiates
    the nonlinear integrand element by element.
    """
    from ngsolve import Grad, InnerProduct, div

    u, p, v, q = velocity, pressure, test_velocity, test_pressure
    return (
        InnerProduct(Grad(u) * (base_velocity - grid_velocity), v)
        + InnerProduct(Grad(base_velocity) * u, v)
        + inv_reynolds * InnerProduct(Grad(u) + Grad(u).trans, Grad(v))
        - p * div(v)
        - q * div(u)
    )


def check_backend(backend: str) -> str:
    """``backend`` if it names a factorisation of the Newton matrices, else a one-line InputError."""
    from fsistab import umfpack

    return umfpack.check_backend(backend, "steady factorisation")


class _JacobianGather:
    """Where the free-dof block of an NGSolve sparse matrix sits in its CSR values, as a SciPy CSC
    pattern: one gather per Newton step instead of a COO export and two sparse slicings."""

    def __init__(self, matrix, free: np.ndarray):
        import scipy.sparse as sp

        values, columns, pointers = matrix.CSR()
        self.columns, self.pointers = np.array(columns), np.array(pointers)
        n = len(self.pointers) - 1
        # positions + 1 as values, so that an entry at position 0 is not mistaken for a zero
        positions = sp.csr_matrix((np.arange(1, len(values) + 1), self.columns, self.pointers), shape=(n, n))
        block = positions[free][:, free].tocsc()
        block.sort_indices()
        self.take = block.data - 1
        self.indices, self.indptr, self.shape = block.indices, block.indptr, block.shape

    def fits(self, matrix) -> bool:
        _, columns, pointers = matrix.CSR()
        return np.array_equal(self.pointers, pointers) and np.array_equal(self.columns, columns)

    def block(self, matrix):
        import scipy.sparse as sp

        values = np.asarray(matrix.CSR()[0])
        return sp.csc_matrix((values[self.take], self.indices, self.indptr), shape=self.shape)


@dataclass
class SteadyProblem:
    """The nonlinear steady form on one mesh, with ``Re`` and ``α0`` as adjustable parameters.

    Built once per mesh; continuation only changes the parameters and the wall values. The Newton
    matrix is the explicit linearisation (:func:`momentum_linearisation`) at ``base``, restricted
    to the free dofs and factorised by :mod:`fsistab.umfpack` with one symbolic analysis
    (``analysis``, UMFPACK's symmetric strategy) for every Newton step and continuation step, the
    sparsity pattern being that of the mesh; ``backend="ngsolve"`` (or a wheel without UMFPACK's
    symbols) factorises with NGSolve's ``Inverse(inverse="umfpack")`` instead, whose every call
    repeats the analysis. ``factorisations`` counts the (numeric) factorisations.
    """

    mesh: object
    space: object
    form: object
    inv_reynolds: object
    grid_velocity: object
    backend: str = "umfpack"
    outlet: str = "stress"
    factorisations: int = 0
    analysis: object = field(default=None, repr=False)  # fsistab.umfpack.Analysis of the pattern
    _gather: _JacobianGather | None = field(default=None, repr=False)

    @classmethod
    def on(cls, mesh, space=None, backend: str = "umfpack", outlet: str = "stress") -> SteadyProblem:
        """The problem on ``mesh`` with the outlet condition ``outlet`` (:func:`outlet_integral`)."""
        from ngsolve import CF, BilinearForm, Parameter, dx

        check_backend(backend)
        space = space if space is not None else taylor_hood_space(mesh)
        (u, p), (v, q) = space.TnT()
        inv_reynolds = Parameter(1.0)
        wx, wy = Parameter(-1.0), Parameter(0.0)
        grid_velocity = CF((wx, wy))
        form = BilinearForm(space)
        form += momentum_form(u, p, v, q, grid_velocity, inv_reynolds) * dx
        boundary = outlet_integral(outlet, u, v, inv_reynolds)
        if boundary is not None:
            form += boundary
        return cls(mesh, space, form, inv_reynolds, (wx, wy), backend, outlet)

    # made on first use: a problem built for its residual alone (forces) does not pay for them
    @cached_property
    def free(self) -> np.ndarray:
        """Indices of the free dofs, the unknowns of the Newton systems."""
        return np.nonzero(np.array(list(self.space.FreeDofs()), dtype=bool))[0]

    @cached_property
    def base(self):
        """The state at which :attr:`jacobian` is assembled."""
        from ngsolve import GridFunction

        return GridFunction(self.space)

    @cached_property
    def jacobian(self):
        """The Newton matrix's form, :func:`momentum_linearisation` at :attr:`base`."""
        from ngsolve import CF, BilinearForm, dx

        (u, p), (v, q) = self.space.TnT()
        integrand = momentum_linearisation(
            u, p, v, q, self.base.components[0], CF(self.grid_velocity), self.inv_reynolds
        )
        form = BilinearForm(self.space)
        form += integrand * dx
        boundary = outlet_integral(self.outlet, u, v, self.inv_reynolds)
        if boundary is not None:
            form += boundary
        return form

    def set_flow(self, flow: Flow) -> None:
        self.inv_reynolds.Set(1.0 / flow.reynolds)
        wx, wy = wall_velocity(flow.theta0)
        self.grid_velocity[0].Set(wx)
        self.grid_velocity[1].Set(wy)

    def impose_wall(self, state, flow: Flow) -> None:
        """Set the Dirichlet values of ``state`` (U = W⁰ on the wall, 0 on the far field)."""
        from ngsolve import CF

        velocity = state.components[0]
        lifting = velocity.vec.CreateVector()
        saved = velocity.vec.CreateVector()
        saved.data = velocity.vec
        # Set(definedon=...) zeroes every other dof: set a copy, then copy the wall dofs only
        velocity.Set(CF(wall_velocity(flow.theta0)), definedon=self.mesh.Boundaries(WALL))
        lifting.data = velocity.vec
        velocity.vec.data = saved
        values, lifted = velocity.vec.FV().NumPy(), lifting.FV().NumPy()
        dirichlet = ~np.array(list(velocity.space.FreeDofs()), dtype=bool)
        values[dirichlet] = lifted[dirichlet]

    def residual_norm(self, state) -> float:
        residual = state.vec.CreateVector()
        self.form.Apply(state.vec, residual)
        return float(np.linalg.norm(residual.FV().NumPy()[self.free]))

    def newton_solver(self, state) -> Callable[[np.ndarray], np.ndarray]:
        """Assemble the Jacobian at ``state``, factorise it (one count), and return the map
        ``r ↦ J⁻¹ r`` on free-dof vectors."""
        from fsistab import umfpack

        self.base.vec.data = state.vec
        self.jacobian.Assemble()
        matrix = self.jacobian.mat
        self.factorisations += 1
        if self.backend == "umfpack" and umfpack.available():
            if self._gather is None or not self._gather.fits(matrix):
                self._gather, self.analysis = _JacobianGather(matrix, self.free), None
            block = self._gather.block(matrix)
            if self.analysis is None:  # once per sparsity pattern, i.e. per mesh
                self.analysis = umfpack.symmetric_analysis(block)
            # LU.solve refines once, as NGSolve's UMFPACK does (relative residual ~1e-14)
            return umfpack.LU(block, self.analysis).solve
        inverse = matrix.Inverse(self.space.FreeDofs(), inverse="umfpack")
        rhs, solution = matrix.CreateColVector(), matrix.CreateColVector()

        def solve(b: np.ndarray) -> np.ndarray:
            rhs.FV().NumPy()[:] = 0
            rhs.FV().NumPy()[self.free] = b
            solution.data = inverse * rhs
            return solution.FV().NumPy()[self.free].copy()

        return solve

    def newton(
        self,
        state,
        flow: Flow,
        *,
        tol: float = NEWTON_TOL,
        maxit: int = 12,
        growth_limit: float = 1e3,
        force: np.ndarray | None = None,
    ) -> list[float]:
        """Newton iterations on ``state`` in place; returns the residual history.

        ``force``: a steady volume force on the free dofs (``R_f(q⁰) = F``; adjoint checks,
        :func:`fsistab.sensitivity.forced_steady`). Raises ConvergenceError when the residual grows
        by ``growth_limit`` over its best value, becomes NaN, or ``maxit`` iterations do not reach
        ``tol``.
        """
        self.set_flow(flow)
        self.impose_wall(state, flow)
        residual = state.vec.CreateVector()
        values = state.vec.FV().NumPy()
        history: list[float] = []
        for _ in range(maxit + 1):
            self.form.Apply(state.vec, residual)
            free_residual = residual.FV().NumPy()[self.free]
            if force is not None:
                free_residual = free_residual - force
            norm = float(np.linalg.norm(free_residual))
            history.append(norm)
            if not math.isfinite(norm) or norm > growth_limit * min(history):
                break
            if norm < tol:
                return history
            if len(history) > maxit:
                break
            values[self.free] -= self.newton_solver(state)(free_residual)
        raise ConvergenceError(
            f"Newton did not converge at Re = {flow.reynolds:g}, alpha0 = {flow.alpha0_deg:g} deg "
            f"(residuals {', '.join(f'{r:.1e}' for r in history[-4:])})"
        )


@dataclass(frozen=True)
class SteadyState:
    """A converged steady flow: the fields and how they were obtained.

    ``state`` is an NGSolve GridFunction on ``space`` (components ``U``, ``P`` in body axes,
    body-length and ``U∞`` units). ``history`` holds the Newton residuals at the target
    parameters, ``path`` the (Re, α0, iterations) of every continuation step.
    """

    mesh_spec: MeshSpec
    flow: Flow
    mesh: object
    space: object
    state: object
    history: tuple[float, ...]
    path: tuple[tuple[float, float, int], ...] = ()
    factorisations: int = 0
    seconds: float = 0.0
    from_cache: bool = False
    meta: dict = field(default_factory=dict)

    @property
    def ndof(self) -> int:
        return int(self.space.ndof)

    @property
    def velocity(self):
        return self.state.components[0]

    @property
    def pressure(self):
        return self.state.components[1]

    @property
    def newton_iterations(self) -> int:
        """Newton iterations at the target parameters (excluding the continuation path)."""
        return len(self.history) - 1


def _path_flow(start: Flow, target: Flow, s: float) -> Flow:
    """Homotopy from ``start`` to ``target``: geometric in Re, linear in α0."""
    if s >= 1.0:
        return target
    log_re = (1 - s) * math.log(start.reynolds) + s * math.log(target.reynolds)
    return Flow(math.exp(log_re), (1 - s) * start.alpha0_deg + s * target.alpha0_deg)


def continuation(
    problem: SteadyProblem,
    state,
    start: Flow,
    target: Flow,
    *,
    first_step: float = 0.25,
    min_step: float = 1e-3,
    path_tol: float = NEWTON_TOL,
    progress: Progress = None,
) -> tuple[list[float], list[tuple[float, float, int]]]:
    """Follow the steady branch from ``start`` (where ``state`` converged) to ``target``.

    Secant predictor in the homotopy parameter, step doubled after an easy step and halved after
    a failure; below ``min_step`` a ConvergenceError says where the branch was lost. Newton
    converges to ``path_tol`` on the way and to :data:`NEWTON_TOL` at ``target``. A looser
    ``path_tol`` saves the last Newton step of most intermediate steps, but the state at the target
    then depends on the path within the accuracy that NEWTON_TOL gives it; the default keeps every
    step at NEWTON_TOL, so that the target's state, and its cache entry, do not depend on the path's
    tolerance.
    """
    s, ds = 0.0, first_step
    current = state.vec.CreateVector()
    current.data = state.vec
    previous = None  # (s, vector) of the step before, for the secant predictor
    path: list[tuple[float, float, int]] = []
    while s < 1.0:
        s_next = min(1.0, s + ds)
        flow = _path_flow(start, target, s_next)
        if previous is None:
            state.vec.data = current
        else:
            factor = (s_next - s) / (s - previous[0])
            state.vec.data = (1 + factor) * current - factor * previous[1]
        try:
            tol = NEWTON_TOL if s_next >= 1.0 else path_tol
            history = problem.newton(state, flow, tol=tol, maxit=8, growth_limit=1e2)
        except ConvergenceError:
            ds /= 2
            if ds < min_step:
                raise ConvergenceError(
                    f"steady continuation lost the branch near Re = {flow.reynolds:g}, "
                    f"alpha0 = {flow.alpha0_deg:g} deg; try a finer mesh, a smaller target Re, or a "
                    f"steady state at nearby parameters as initial guess"
                ) from None
            continue
        path.append((flow.reynolds, flow.alpha0_deg, len(history) - 1))
        if progress:
            progress(
                f"continuation: Re = {flow.reynolds:.4g}, alpha0 = {flow.alpha0_deg:.3g} deg "
                f"converged in {len(history) - 1} Newton iterations"
            )
        previous_vector = previous[1] if previous else current.CreateVector()
        previous_vector.data = current
        previous = (s, previous_vector)
        current.data = state.vec
        s = s_next
        if len(history) <= 4:
            ds = min(2 * ds, 1.0)
    return history, path


START_REYNOLDS = 40.0  # a direct Newton from rest converges below about 50


def solve_steady(
    spec: MeshSpec,
    flow: Flow,
    *,
    cache_dir: Path | None = None,
    initial: SteadyState | None = None,
    progress: Progress = None,
    backend: str = "umfpack",
) -> SteadyState:
    """Steady state for ``flow`` on the mesh of ``spec`` (docs/model.md §6), cached under its key.

    From ``initial`` (a steady state on the same mesh) or from rest: a direct Newton, then, if it
    fails, continuation in Re (geometric) and α0 (linear) from the initial parameters — from
    ``Re = min(Re, 40)`` at rest. ``backend`` factorises the Newton matrices (:class:`SteadyProblem`);
    the result does not depend on it beyond round-off, so it is not part of the cache key.
    """
    check_backend(backend)
    path = None if cache_dir is None else steady_path(spec, flow, cache_dir)
    if path is not None:
        # a damaged entry (checksum, key or size) is reported, moved aside and recomputed
        cached = store.read_cached(path, expect={"key": steady_key(spec, flow)})
        if cached is not None:
            try:
                return _steady_from_dataset(cached, path, spec, flow, cache_dir)
            except CacheError as exc:
                store.discard_damaged(path, exc)
    if initial is not None and initial.mesh_spec.key() != spec.key():
        raise InputError("the initial steady state is on another mesh")

    t0 = time.perf_counter()
    mesh = initial.mesh if initial is not None else build_mesh(spec, cache_dir)
    problem = SteadyProblem.on(mesh, backend=backend, outlet=spec.outlet)
    from ngsolve import GridFunction

    state = GridFunction(problem.space)
    if initial is not None:
        state.vec.data = initial.state.vec
        start = initial.flow
    else:
        start = Flow(min(flow.reynolds, START_REYNOLDS), flow.alpha0_deg)
        history = problem.newton(state, start, maxit=15)
    path_steps: list[tuple[float, float, int]] = []
    if start != flow or initial is not None:
        # a full step first (direct Newton) when starting from a converged state nearby
        near = initial is not None or flow.reynolds <= 4 * start.reynolds
        first_step = 1.0 if near else 0.25
        history, path_steps = continuation(
            problem, state, start, flow, first_step=first_step, progress=progress
        )
    result = SteadyState(
        mesh_spec=spec,
        flow=flow,
        mesh=mesh,
        space=problem.space,
        state=state,
        history=tuple(history),
        path=tuple(path_steps),
        factorisations=problem.factorisations,
        seconds=time.perf_counter() - t0,
    )
    if path is not None:
        save_steady(result, path)
    return result


def steady_key(spec: MeshSpec, flow: Flow) -> str:
    inputs = {"mesh": spec.key(), "flow": asdict(flow), "tol": NEWTON_TOL}
    if spec.outlet != "stress":  # the default outlet keeps the keys it always had
        inputs["outlet"] = spec.outlet
    return store.cache_key("steady", inputs)


def steady_path(spec: MeshSpec, flow: Flow, cache_dir: Path) -> Path:
    return Path(cache_dir) / "steady" / f"{steady_key(spec, flow)}.nc"


def save_steady(result: SteadyState, path: Path) -> Path:
    """Write the dof vector and its metadata as NetCDF (atomically)."""
    import xarray as xr

    ds = xr.Dataset(
        {"state": ("dof", result.state.vec.FV().NumPy().copy())},
        attrs={
            "key": steady_key(result.mesh_spec, result.flow),
            "mesh_key": result.mesh_spec.key(),
            "mesh": store.json_attr(result.mesh_spec.describe()),
            "reynolds": result.flow.reynolds,
            "alpha0_deg": result.flow.alpha0_deg,
            "ndof": result.ndof,
            "residual_history": store.json_attr(list(result.history)),
            "continuation_path": store.json_attr([list(p) for p in result.path]),
            "factorisations": result.factorisations,
            "seconds": result.seconds,
            "versions": store.json_attr(store.software_versions()),
        },
    )
    return store.write_dataset(ds, path)


def load_steady(path: Path, spec: MeshSpec, flow: Flow, cache_dir: Path | None = None) -> SteadyState:
    """Read a cached steady state, refusing (CacheError) one whose checksum, key, size or values do
    not match."""
    ds = store.read_dataset(path, expect={"key": steady_key(spec, flow)})
    return _steady_from_dataset(ds, path, spec, flow, cache_dir)


def _steady_from_dataset(ds, path: Path, spec: MeshSpec, flow: Flow, cache_dir: Path | None) -> SteadyState:
    """The steady state of a verified cache dataset, on the mesh of ``spec``."""
    import json

    from ngsolve import GridFunction

    mesh = build_mesh(spec, cache_dir)
    space = taylor_hood_space(mesh)
    values = ds["state"].values if "state" in ds else None
    if values is None or values.shape != (space.ndof,) or not np.all(np.isfinite(values)):
        raise CacheError(
            f"cached steady state {path} does not fit its mesh (damaged)" + store.DELETE_AND_RERUN
        )
    state = GridFunction(space)
    state.vec.FV().NumPy()[:] = values
    return SteadyState(
        mesh_spec=spec,
        flow=flow,
        mesh=mesh,
        space=space,
        state=state,
        history=tuple(json.loads(ds.attrs["residual_history"])),
        path=tuple(tuple(p) for p in json.loads(ds.attrs["continuation_path"])),
        factorisations=int(ds.attrs["factorisations"]),
        seconds=float(ds.attrs["seconds"]),
        from_cache=True,
    )
