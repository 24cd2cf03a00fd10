"""Aerodynamic transfer functions: the fluid eliminated exactly from the coupled problem (docs/model.md §7).

With ``K(s) = J + sM``, eliminating the fluid unknowns from (E) leaves the solid's characteristic
matrix (``n_s ≤ 4`` active solid states)::

    T(s) = K_ss(s) - K_sf(s) K_ff(s)⁻¹ K_fs(s),      σ eigenvalue of (E)  ⇔  det T(σ) = 0

(for ``σ`` not an eigenvalue of the fixed-body fluid). All of the fluid enters ``T`` through the
aerodynamic transfer matrix, 3 × 4::

    G(s) = load_s + s load_mass_s - (load_f + s load_mass_f) K_ff(s)⁻¹ (J_fs + s M_fs)

the body-axis loads ``(F_x, F_y, M)`` (units ``ρU∞²L`` per unit span, ``M`` about G,
counter-clockwise +) for a unit amplitude of each solid state ``(h, θ, ḣ, θ')`` varying like
``e^{st}``, with the inertia of the wall lifting. ``G`` depends on the body, the mesh, ``Re`` and
``α0`` only, and ``T(s) = P(s; m, U*, Ω, ζ, r_θ) - E G(s)`` (:func:`fsistab.coupled.solid_blocks`)
is assembled from it for any solid parameters. It is the viscous counterpart of Theodorsen's loads
(docs/model.md §9) and of the flutter derivatives of wind engineering.

``G`` is evaluated exactly — one sparse factorisation of ``K_ff(s)`` and three back-substitutions
per point (:func:`exact_transfer`; the heave column is zero and not solved), with ``dG/ds`` three
more. At Re = 2900 weakly damped wake
modes close to the axis make ``G(iω)`` vary on the scale of their damping (~0.015): a global
rational fit (AAA) needed too many samples (docs/transfer.md), and the certified local models of
:mod:`fsistab.reduced_model` replaced it. Neutral points ``det T(iω; U*) = 0`` are converged
exactly by :func:`transfer_flutter_point` (the transfer-determinant formulation of
:mod:`fsistab.neutral_point`). Frequencies and growth rates are in the body's time unit ``L/U∞``
(chord for the plate, diameter for the cylinder, docs/model.md §1, §10).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import xarray as xr

from fsistab import umfpack
from fsistab.continuation import newton
from fsistab.coupled import (
    active_states,
    lift_and_moment_rows,
    solid_blocks,
    solid_mass,
    solid_stiffness,
    stiffness_derivative,
)
from fsistab.errors import ConvergenceError, InputError
from fsistab.linalg import FactorCounter, FluidFactor, sample_threads, shared_analysis
from fsistab.neutral_point import DeterminantProblem, NeutralPoint
from fsistab.operators import FluidOperators
from fsistab.params import Solid
from fsistab.progress import Progress
from fsistab.store import ResumableTable, complex_variable
from fsistab.symmetry import antisymmetric_operators

LOADS = ("force_x", "force_y", "moment")


@dataclass(frozen=True)
class TransferSample:
    """``G(s)``, ``dG/ds`` (3 × 4 each) and the fluid's response ``X = K_ff(s)⁻¹(J_fs + s M_fs)``
    (``n_fluid`` × 4, one column per solid state ``h, θ, ḣ, θ'``) at one ``s``: what one
    factorisation of ``K_ff(s)`` gives (:func:`transfer_sample`)."""

    s: complex
    value: np.ndarray
    rate: np.ndarray
    response: np.ndarray

    def mode(self, solid: Solid, theta0: float, loads0: np.ndarray) -> np.ndarray:
        """The coupled vector ``(q̂_s, q̂_f)`` of the eigenvalue ``σ = s`` for ``solid``, where
        ``det T(s) = 0`` (docs/model.md §7): ``q̂_s`` the null vector of ``T(s)`` on the active solid
        states, ``q̂_f = -X q̂_s`` (the fluid rows of (E)); unit norm. At a neutral point
        converged to a step δω, its residual is O(δω)."""
        t = characteristic_matrix(self.value, solid, self.s, theta0, loads0)
        solid_part = np.linalg.svd(t)[2][-1].conj()
        fluid_part = -self.response[:, active_states(solid)] @ solid_part
        vector = np.concatenate([solid_part, fluid_part])
        return vector / np.linalg.norm(vector)


def transfer_sample(
    fluid: FluidOperators,
    s: complex,
    counter: FactorCounter | None = None,
    factor: FluidFactor | None = None,
    refine: bool = True,
) -> TransferSample:
    """:class:`TransferSample` at ``s`` from one sparse factorisation of ``K_ff(s)`` (or ``factor``
    if given) and two block back-substitutions::

        X = K⁻¹(J_fs + s M_fs),   X' = K⁻¹(M_fs - M_f X),
        G = load_s + s load_mass_s - (load_f + s load_mass_f) X,
        dG/ds = load_mass_s - load_mass_f X - (load_f + s load_mass_f) X'

    ``refine=False``: solves without the refinement step (relative residual about 1e-12 instead of
    round-off, :meth:`fsistab.linalg.FluidFactor.solve`), for samples that only bracket a root."""
    factor = factor if factor is not None else FluidFactor(fluid, s, counter)
    response = factor.solve(fluid.jfs + s * fluid.mfs, refine)
    response_rate = factor.solve(fluid.mfs - fluid.mff @ response, refine)
    rate = fluid.load_mass_s - fluid.load_mass_f @ response - _load_rows(fluid, s, response_rate)
    return TransferSample(complex(s), _transfer_value(fluid, s, response), rate, response)


def _load_rows(fluid: FluidOperators, s: complex, x: np.ndarray) -> np.ndarray:
    """``(load_f + s load_mass_f) x``: the loads of fluid fields ``x``."""
    return fluid.load_f @ x + s * (fluid.load_mass_f @ x)


def _transfer_value(fluid: FluidOperators, s: complex, response: np.ndarray) -> np.ndarray:
    """``G(s) = load_s + s load_mass_s − (load_f + s load_mass_f) X`` from the response ``X``."""
    return fluid.load_s + s * fluid.load_mass_s - _load_rows(fluid, s, response)


@dataclass(frozen=True)
class Deferred:
    """Work known only once ``awaited`` (futures, e.g. reduced models being built) are done:
    ``items()`` gives it then (shifts, frequencies, ...), called once, in the thread that asked."""

    awaited: tuple
    items: Callable[[], Sequence]


def iter_transfer_samples(
    fluid: FluidOperators,
    shifts,
    counter: FactorCounter | None = None,
    *,
    refine: bool = True,
    threads: int | None = None,
    later: Deferred | None = None,
) -> Iterator[TransferSample]:
    """:func:`transfer_sample` at each of ``shifts``, ``threads`` at a time (default: the CPU count,
    at most 2; each holds one factorisation in memory), each yielded (and counted) as soon as it is
    done, in the order they finish: a thread that finishes starts the next shift at once instead of
    waiting for the other (factorisations at different ``s`` take different times), and a
    caller that saves each sample loses only those under way if interrupted. UMFPACK, called
    through ctypes, runs without the GIL, so threads factorise in parallel; the factorisations of an
    arithmetic share one symbolic analysis, made before them (:func:`fsistab.linalg.shared_analysis`).
    ``later``: shifts joining the queue as soon as they are known (:class:`Deferred`), so that no
    thread waits for the end of ``shifts`` to start them."""
    shifts = [complex(s) for s in shifts]
    threads = sample_threads(threads) if later else min(sample_threads(threads), max(len(shifts), 1))
    counter = counter if counter is not None else FactorCounter()

    def one(s: complex) -> TransferSample:
        return transfer_sample(fluid, s, refine=refine)  # counted as it is yielded

    if threads == 1:
        for s in itertools.chain(shifts, _later_shifts(later)):
            sample = one(s)
            counter.count += 1
            yield sample
        return
    if umfpack.available():
        for arithmetic in {s.imag != 0: s for s in shifts}.values():
            shared_analysis(fluid, arithmetic)
    pool = ThreadPoolExecutor(threads)
    queue, running = list(shifts), set()
    awaited = set(later.awaited) if later else set()
    try:
        while queue or running or later:
            while queue and len(running) < threads:
                running.add(pool.submit(one, queue.pop(0)))
            done, _ = wait(running | awaited, return_when=FIRST_COMPLETED)
            awaited -= done
            for future in done & running:
                running.discard(future)
                counter.count += 1
                yield future.result()
            if later and not awaited:
                queue += _later_shifts(later)
                later = None
    finally:  # interrupted: the shifts not started are dropped, not factorised
        pool.shutdown(wait=True, cancel_futures=True)


def _later_shifts(later: Deferred | None) -> Iterator[complex]:
    """The shifts of ``later`` once its futures are done (waited for when first asked)."""
    if later is not None:
        wait(later.awaited)
        yield from (complex(s) for s in later.items())


def transfer_samples(
    fluid: FluidOperators,
    shifts,
    counter: FactorCounter | None = None,
    *,
    refine: bool = True,
    threads: int | None = None,
) -> list[TransferSample]:
    """:func:`iter_transfer_samples` as a list in the order of ``shifts``."""
    shifts = [complex(s) for s in shifts]
    done = {x.s: x for x in iter_transfer_samples(fluid, shifts, counter, refine=refine, threads=threads)}
    return [done[s] for s in shifts]


def exact_transfer(
    fluid: FluidOperators,
    s: complex,
    counter: FactorCounter | None = None,
    factor: FluidFactor | None = None,
    derivative: bool = False,
    refine: bool = True,
):
    """``G(s)`` (3 × 4) from one sparse factorisation of ``K_ff(s)`` (or ``factor`` if given); with
    ``derivative``, also ``dG/ds`` from one more back-substitution with the same factorisation
    (the formulas of :func:`transfer_sample`); ``refine`` as in :func:`transfer_sample`."""
    factor = factor if factor is not None else FluidFactor(fluid, s, counter)
    if derivative:
        sample = transfer_sample(fluid, s, factor=factor, refine=refine)
        return sample.value, sample.rate
    return _transfer_value(fluid, s, factor.solve(fluid.jfs + s * fluid.mfs, refine))


def aerodynamic_loads(transfer: np.ndarray, theta0: float, loads0: np.ndarray, s: complex) -> np.ndarray:
    """``(C_L, C_M)`` per unit ``(ĥ, θ̂)`` for ``(h, θ) ∝ e^{st}`` (2 × 2): the viscous counterpart of
    Theodorsen's ``s² L₂ + s L₁ + L₀`` (:func:`fsistab.theodorsen.load_matrices`, ``a = 0``).

    ``C_L`` lab-frame lift, ``C_M`` about G counter-clockwise + (docs/model.md §4); the lift includes the
    steady force rotated with the body (``∂C_L/∂θ`` at fixed loads)."""
    rows, dcl_dtheta = lift_and_moment_rows(theta0, loads0)
    heave = rows @ (transfer[:, 0] + s * transfer[:, 2])
    pitch = rows @ (transfer[:, 1] + s * transfer[:, 3]) + np.array([dcl_dtheta, 0.0])
    return np.column_stack([heave, pitch])


def _solid_parts(
    solid: Solid, theta0: float, loads0: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[int]]:
    """``P0``, ``M_s`` and ``E`` of ``T(s) = P0 + s M_s - E G(s)[:, a]`` on the active states ``a``
    (``M_s`` the in-vacuo solid mass, ``I`` without a static unbalance, docs/model.md §3.1)."""
    zero = np.zeros((3, 4))
    jss, mss, rows = solid_blocks(solid, theta0, loads0, zero, zero)
    a = active_states(solid)
    coupling = np.vstack([np.zeros((2, 3)), rows])[a]
    return jss[np.ix_(a, a)], mss[np.ix_(a, a)], coupling, a


def characteristic_matrix(
    transfer: np.ndarray, solid: Solid, s: complex, theta0: float, loads0: np.ndarray
) -> np.ndarray:
    """``T(s)`` on the active solid states (n_s × n_s) from ``G(s)`` (``transfer``, 3 × 4): ``σ`` is a
    coupled eigenvalue iff ``det T(σ) = 0``. Rows those of ``R_s`` (docs/model.md §5), columns the active
    ``(h, θ, ḣ, θ')``."""
    p0, mass, coupling, a = _solid_parts(solid, theta0, loads0)
    return p0 + s * mass - coupling @ transfer[:, a]


def determinant_on_axis(
    transfer: np.ndarray, rate: np.ndarray, solid: Solid, omega: float, theta0: float, loads0: np.ndarray
) -> tuple[np.ndarray, complex, complex, complex]:
    """``T(iω)``, ``det T`` and its derivatives ``∂/∂ω`` and ``∂/∂ log U*`` (docs/model.md §8) from
    ``G(iω)`` and ``dG/ds`` (``transfer``, ``rate``), by Jacobi's formula
    ``d det T = det T · tr(T⁻¹ dT)``; ``U*`` enters the in-vacuo rows only."""
    p0, mass, coupling, a = _solid_parts(solid, theta0, loads0)
    t = p0 + 1j * omega * mass - coupling @ transfer[:, a]
    dt_ds = mass - coupling @ rate[:, a]
    dt_dlogu = solid.reduced_velocity * stiffness_derivative(solid)[np.ix_(a, a)]
    det = np.linalg.det(t)
    inverse = np.linalg.inv(t)
    return t, det, det * np.trace(inverse @ (1j * dt_ds)), det * np.trace(inverse @ dt_dlogu)


def determinant_gradient(
    transfer: np.ndarray, rate: np.ndarray, solid: Solid, omega: float, theta0: float, loads0: np.ndarray
) -> tuple[np.ndarray, complex, np.ndarray]:
    """``T(iω)``, ``det T`` and its gradient ``∂/∂(ω, log U*, log m)`` (docs/model.md §8; three complex
    numbers) from ``G(iω)`` and ``dG/ds``. Every aerodynamic term of the solid rows scales with
    ``1/m``, so ``∂T/∂(log m) = -(T - T_vac)`` with ``T_vac = P_vac + iωM_s`` the in-vacuo part (the
    solid mass ``M_s`` of a static unbalance is a ratio of the solid's own inertias, independent of m)."""
    t, det, d_omega, d_logu = determinant_on_axis(transfer, rate, solid, omega, theta0, loads0)
    a = active_states(solid)
    mass = solid_mass(solid, theta0)[np.ix_(a, a)]
    in_vacuo = solid_stiffness(solid)[np.ix_(a, a)] + 1j * omega * mass
    d_log_mass = -det * np.trace(np.linalg.inv(t) @ (t - in_vacuo))
    return t, det, np.array([d_omega, d_logu, d_log_mass])


class TransferDeterminant:
    """The exact-transfer formulation of the neutral point in the ``(m, U*)`` plane (docs/model.md §8):
    ``f(y) = det T(iω; U*, m) / scale`` for :class:`fsistab.neutral_point.DeterminantProblem`, in
    ``y = (ω, log U*, log m)``. ``G(iω)`` and ``dG/ds`` are memoised per frequency: the residual
    and the Jacobian at one Newton iterate share one factorisation of ``K_ff(iω)``. ``refine``:
    refined solves (:func:`transfer_sample`)."""

    def __init__(
        self,
        fluid: FluidOperators,
        solid: Solid,
        counter: FactorCounter,
        scale: float = 1.0,
        refine: bool = True,
    ):
        self.fluid, self.solid, self.counter, self.scale = fluid, solid, counter, scale
        self.refine = refine
        self._samples: dict[float, TransferSample] = {}

    def sample(self, omega: float) -> TransferSample:
        if omega not in self._samples:
            self._samples[omega] = transfer_sample(self.fluid, 1j * omega, self.counter, refine=self.refine)
        return self._samples[omega]

    def matrix(self, y: np.ndarray) -> tuple[np.ndarray, complex, np.ndarray]:
        """``T``, ``det T`` and its gradient at ``y`` (unscaled)."""
        omega, log_u, log_mass = (float(v) for v in y)
        if not (abs(log_u) < 700 and abs(log_mass) < 700):  # also refuses NaN
            raise ConvergenceError(f"the neutral-point Newton left the admissible range (log U* = {log_u:g})")
        # the given mass ratio itself while m is held (exp(log m) may differ from it in the last bit)
        mass = self.solid.mass_ratio if log_mass == math.log(self.solid.mass_ratio) else math.exp(log_mass)
        solid = replace(self.solid, reduced_velocity=math.exp(log_u), mass_ratio=mass)
        sample = self.sample(omega)
        return determinant_gradient(
            sample.value, sample.rate, solid, omega, self.fluid.theta0, self.fluid.loads0
        )

    def characteristic(self, y: np.ndarray, gradient: bool):
        _, det, grad = self.matrix(y)
        return (det / self.scale, grad / self.scale) if gradient else det / self.scale

    def problem(self) -> DeterminantProblem:
        return DeterminantProblem(self.characteristic)


def transfer_flutter_point(
    fluid: FluidOperators,
    solid: Solid,
    frequency: float,
    *,
    tolerance: float = 1e-10,
    max_iterations: int = 12,
    counter: FactorCounter | None = None,
    refine: bool = True,
) -> tuple[NeutralPoint, TransferSample]:
    """Dynamic neutral point from the exact transfer function: :func:`fsistab.continuation.newton` on
    the two real equations ``det T(iω; U*) = 0`` in ``(ω, log U*)`` (:class:`TransferDeterminant`,
    ``m`` held), starting from ``(frequency, solid.reduced_velocity)``, until the step is below
    ``tolerance`` (relative in ω). ``residuals`` are ``σ_min(T)/‖T‖₂`` at the iterates.
    Returns the point and the last evaluation of ``G`` (its frequency within the last Newton step
    of ``ω_c``), from which the critical mode (:meth:`TransferSample.mode`) and the crossing rate
    follow with no further factorisation.
    ``refine=False``: solves without the refinement step (relative residual about 1e-12), which
    moves the root by about that much, far below a ``tolerance`` of 1e-8, for a third of the
    solve cost.

    Each iteration costs one factorisation of ``K_ff(iω)`` and two back-substitutions (``G`` and
    ``dG/ds``); ``∂T/∂U*`` touches the solid part only. The counterpart, with a 4 × 4 determinant in
    place of the augmented sparse system, of :func:`fsistab.critical.flutter_point` (docs/model.md §8).
    """
    counter = counter if counter is not None else FactorCounter()
    start = counter.count
    determinant = TransferDeterminant(fluid, solid, counter, refine=refine)
    log_mass = math.log(solid.mass_ratio)
    result = newton(
        determinant.problem().at(2, log_mass),
        np.array([float(frequency), math.log(solid.reduced_velocity), log_mass]),
        tol=0.0,
        max_iterations=max_iterations,
        small_step=lambda d, y: abs(d[0]) < tolerance * max(1.0, abs(y[0])) and abs(d[1]) < tolerance,
    )
    residuals = []
    for y in result.path:
        t = determinant.matrix(y)[0]
        residuals.append(float(np.linalg.svd(t, compute_uv=False)[-1] / np.linalg.norm(t, 2)))
    if not result.converged:
        raise ConvergenceError(
            f"Newton on det T(iω; U*) did not converge from ω = {frequency:.4g}, "
            f"U* = {solid.reduced_velocity:.4g} ({result.reason}; "
            f"last residuals {', '.join(f'{r:.1e}' for r in residuals[-3:])}); start closer to the crossing "
            "found by an eigenvalue sweep"
        )
    # after the test: a diverged iteration's last point may have no finite U* (exp overflows)
    omega, velocity = float(result.point[0]), math.exp(float(result.point[1]))
    if abs(omega) < 1e-6:
        raise ConvergenceError(
            f"Newton on det T(iω; U*) from ω = {frequency:.4g} converged to the static root "
            f"ω = 0 at U* = {velocity:.5g} (a divergence, not a flutter point); "
            "start closer to the dynamic crossing"
        )
    last = determinant.sample(float(result.path[-1][0]))  # the factorisation nearest the root
    point = NeutralPoint(
        solid.mass_ratio,
        velocity,
        omega,
        residuals=tuple(residuals),
        iterations=result.iterations,
        factorisations=counter.count - start,
    )
    return point, last


MOTIONS = ("heave", "pitch")
COEFFICIENTS = ("lift", "moment")


def flow_identity(fluid: FluidOperators) -> dict:
    """What saved samples of ``G`` depend on (Re, α0, mesh key, sponge): checked when they are
    reused."""
    steady = fluid.steady
    return {
        "reynolds": steady.flow.reynolds,
        "alpha0_deg": steady.flow.alpha0_deg,
        **steady.mesh_spec.linear_identity(),
    }


def viscous_theodorsen_dataset(
    fluid: FluidOperators,
    frequencies: Sequence[float],
    *,
    counter: FactorCounter | None = None,
    progress: Progress = None,
    samples_path: Path | None = None,
) -> xr.Dataset:
    """``G(iω)`` at ``frequencies`` (> 0, time unit ``L/U∞``) and the loads ``(C_L, C_M)`` per unit
    ``(ĥ, θ̂)`` it gives (:func:`aerodynamic_loads`), beside Theodorsen's loads (docs/model.md §9, ``a = 0``,
    ``k = ω/2``) with thin-airfoil slopes and with the viscous static slopes of the same steady state
    (calibrated): the viscous Theodorsen function. One factorisation per frequency, one more for the
    slopes. Complex values carry a ``part`` dimension (real, imag). With ``samples_path``, every
    sample is added to that NetCDF as soon as it is computed (atomically) and samples already there
    for the same mesh and flow are reused: an interrupted run resumes, a repeated one factorises
    nothing but the slopes."""
    from fsistab.slopes import static_slopes

    omega = np.asarray(frequencies, dtype=float)
    if omega.ndim != 1 or len(omega) == 0 or np.any(~np.isfinite(omega)) or np.any(omega <= 0):
        raise InputError("the frequencies must be positive finite numbers")
    counter = counter if counter is not None else FactorCounter()
    identity = flow_identity(fluid)
    # the same G from the antisymmetric fields of a symmetric section at zero incidence
    restricted = antisymmetric_operators(fluid)
    samples = _transfer_samples(restricted, omega, counter, progress, samples_path, identity)
    viscous = np.array(
        [
            aerodynamic_loads(g, fluid.theta0, fluid.loads0, 1j * w)
            for g, w in zip(samples, omega, strict=True)
        ]
    )
    static = static_slopes(fluid, counter)
    attrs = {
        **identity,
        "ndof_fluid": fluid.n_fluid,
        "factorisations": counter.count,
        "lift_slope_alpha": static.lift_slope_alpha,
        "moment_slope_alpha": static.moment_slope_alpha,
    }
    return _viscous_theodorsen(omega, samples, viscous, _theodorsen_loads(omega, static), attrs)


def _transfer_samples(
    fluid: FluidOperators,
    omega: np.ndarray,
    counter: FactorCounter,
    progress: Progress,
    samples_path: Path | None,
    identity: dict,
) -> np.ndarray:
    """``G(iω)`` at each of ``omega`` (:func:`exact_transfer`, one factorisation each). With
    ``samples_path``, every sample is added to that NetCDF as soon as it is computed (atomically)
    and samples already there for the same mesh and flow (``identity``) are reused."""
    # finished samples (checksummed; a damaged file is reported and recomputed, another flow's refused)
    table = None if samples_path is None else ResumableTable(samples_path, identity)
    stored = {float(r["frequency"]): r["transfer"] for r in table.records} if table is not None else {}
    samples = []
    for i, w in enumerate(omega):
        if float(w) not in stored:
            stored[float(w)] = exact_transfer(fluid, 1j * w, counter)
            if table is not None:
                table.append({"frequency": float(w), "transfer": stored[float(w)]})
        samples.append(stored[float(w)])
        if progress:
            progress(f"G(iω): {i + 1}/{len(omega)} frequencies ({fluid.n_fluid} fluid unknowns)")
    return np.array(samples)


def _theodorsen_loads(omega: np.ndarray, static) -> dict[str, np.ndarray]:
    """Theodorsen's loads ``(C_L, C_M)`` per unit ``(ĥ, θ̂)`` at ``s = iω``, ``s² L₂ + s L₁ + L₀``
    (docs/model.md §9, ``a = 0``, ``k = ω/2``): with thin-airfoil slopes (``thin_airfoil``) and with
    the viscous static slopes ``static`` of the steady state (``calibrated``)."""
    from fsistab.theodorsen import AirfoilSlopes, TypicalSection, load_matrices, theodorsen_function

    models = {}
    for name, slopes in (
        ("thin_airfoil", AirfoilSlopes.thin_airfoil()),
        ("calibrated", AirfoilSlopes.from_static(static)),
    ):
        l2, l1, l0 = load_matrices(TypicalSection.create(slopes=slopes), theodorsen_function(omega / 2))
        s = (1j * omega)[:, None, None]
        models[name] = s * s * l2 + s * l1 + l0
    return models


def _viscous_theodorsen(
    omega: np.ndarray, samples: np.ndarray, viscous: np.ndarray, models: dict, attrs: dict
) -> xr.Dataset:
    """The dataset of :func:`viscous_theodorsen_dataset`: ``G``, the viscous loads and Theodorsen's
    (``models``), complex values with a ``part`` dimension (real, imag); ``attrs`` and the
    conventions."""
    loads_dims = ("frequency", "coefficient", "motion")
    return xr.Dataset(
        {
            "transfer": complex_variable(("frequency", "load", "state"), samples),
            "viscous_loads": complex_variable(loads_dims, viscous),
            "theodorsen_thin_airfoil": complex_variable(loads_dims, models["thin_airfoil"]),
            "theodorsen_calibrated": complex_variable(loads_dims, models["calibrated"]),
        },
        coords={
            "frequency": omega,
            "reduced_frequency": ("frequency", omega / 2),
            "load": list(LOADS),
            "state": ["h", "theta", "hdot", "thetadot"],
            "coefficient": list(COEFFICIENTS),
            "motion": list(MOTIONS),
            "part": ["real", "imag"],
        },
        attrs={
            **attrs,
            "conventions": (
                "transfer: body-axis loads (F_x, F_y, M) [rho U^2 L] per unit (h, theta, hdot, thetadot) "
                "~ e^{st}, "
                "s = i*frequency, time unit L/U; loads: (C_L, C_M about G, counter-clockwise +) per unit "
                "(h, theta); reduced_frequency k = omega b/U with b = L/2 (docs/model.md §9)"
            ),
        },
    )
