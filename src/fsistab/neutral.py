"""Neutral curves in the (m, U*) plane by pseudo-arclength continuation (MODEL.md §8).

A point of a dynamic neutral curve solves, in the unknowns ``(q̂, ω, U*, μ = log m)``::

    (iω M(m) + J(U*, m)) q̂ = 0,   Re(ĥ) = 0,   q̂ᴴ M q̂ = 1,
    t_U (U* - U*_k) + t_μ (μ - μ_k) = Δs                       (arclength in the parameter plane)

with ``(t_U, t_μ)`` the unit tangent of the curve at the previous point ``k`` (secant). Because the
arclength is measured in the plane (log m, U*), the continuation passes turning points where the
curve folds back in ``m``. Every aerodynamic term of the solid rows, and their inertia, scale with
``1/m``: ``∂(J + iωM)/∂μ q̂ = -(aerodynamic solid rows)(q̂)`` is explicit. Each Newton step needs one
factorisation of the fluid block at ``iω`` (:mod:`fsistab.linalg`), three extra solves and a 3×3
real border. The divergence curve is ``U*_D(m) = √(m r_θ²/(dC_M/dθ))`` exactly (static moment
independent of ``h``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from fsistab.coupled import CoupledSystem, solid_stiffness
from fsistab.critical import CriticalPoint, _phase_index, velocity_derivative
from fsistab.errors import ConvergenceError, InputError
from fsistab.linalg import FactorCounter, ShiftedSolver
from fsistab.operators import FluidOperators
from fsistab.params import Solid


@dataclass(frozen=True)
class NeutralPoint:
    mass_ratio: float
    reduced_velocity: float
    frequency: float
    mode: np.ndarray
    newton_iterations: int


@dataclass(frozen=True)
class NeutralCurve:
    """Points of one neutral curve in order of arclength; ``folds`` are indices after which
    ``d(log m)/ds`` changes sign (turning points in m); ``stop`` says why the continuation ended."""

    points: tuple[NeutralPoint, ...]
    folds: tuple[int, ...]
    stop: str
    factorisations: int

    @property
    def mass_ratios(self) -> np.ndarray:
        return np.array([p.mass_ratio for p in self.points])

    @property
    def reduced_velocities(self) -> np.ndarray:
        return np.array([p.reduced_velocity for p in self.points])

    @property
    def frequencies(self) -> np.ndarray:
        return np.array([p.frequency for p in self.points])


def _aero_rows(system: CoupledSystem, q: np.ndarray, omega: float) -> np.ndarray:
    """``∂(J + iωM)/∂(log m) q``: minus the aerodynamic part of the solid rows applied to ``q``."""
    ns = system.n_solid
    full = system.jacobian @ q + 1j * omega * (system.mass @ q)
    in_vacuo = np.zeros_like(full)
    active = system.active
    in_vacuo[:ns] = solid_stiffness(system.solid)[np.ix_(active, active)] @ q[:ns] + 1j * omega * q[:ns]
    d = np.zeros_like(full)
    d[:ns] = -(full[:ns] - in_vacuo[:ns])
    return d


def _newton_arclength(
    fluid: FluidOperators,
    template: Solid,
    q: np.ndarray,
    omega: float,
    velocity: float,
    log_mass: float,
    anchor: tuple[float, float],
    tangent: tuple[float, float],
    step: float,
    counter: FactorCounter,
    tol: float = 1e-10,
    maxit: int = 12,
):
    """Chord-Newton corrector: the fluid factorisation at the first ``iω`` is kept while the
    residual falls at least tenfold per iteration (the matrix differs from Newton's only by
    ``i δω M``), and renewed otherwise."""
    factor, previous = None, np.inf
    for iteration in range(maxit + 1):
        if not (math.isfinite(velocity) and velocity > 0 and math.isfinite(log_mass)):
            break
        solid = replace(template, reduced_velocity=float(velocity), mass_ratio=float(math.exp(log_mass)))
        system = CoupledSystem(fluid, solid)
        k = _phase_index(system)
        mq = system.mass @ q
        matrix_q = system.jacobian @ q + 1j * omega * mq
        arclength = tangent[0] * (velocity - anchor[0]) + tangent[1] * (log_mass - anchor[1]) - step
        residual = np.concatenate([matrix_q, [q[k].real, np.vdot(q, mq).real - 1.0, arclength]])
        norm = float(np.linalg.norm(residual))
        if norm < tol:
            return q, omega, velocity, log_mass, iteration
        if iteration == maxit:
            break
        if factor is None or norm > 0.1 * previous:
            factor = None
        previous = norm
        solver = ShiftedSolver(
            system, factor.shift if factor else 1j * omega, fluid_factor=factor, counter=counter
        )
        factor = solver.fluid_factor
        d_velocity = velocity_derivative(system, q)
        a = solver.solve(-matrix_q)
        b = solver.solve(-1j * mq)
        c = solver.solve(-d_velocity)
        d = solver.solve(-_aero_rows(system, q, omega))
        border = np.array(
            [
                [b[k].real, c[k].real, d[k].real],
                [2 * np.vdot(mq, b).real, 2 * np.vdot(mq, c).real, 2 * np.vdot(mq, d).real],
                [0.0, tangent[0], tangent[1]],
            ]
        )
        rhs = np.array([-(q[k] + a[k]).real, 1.0 - np.vdot(q, mq).real - 2 * np.vdot(mq, a).real, -arclength])
        d_omega, d_u, d_mu = np.linalg.solve(border, rhs)
        q = q + a + d_omega * b + d_u * c + d_mu * d
        omega, velocity, log_mass = omega + d_omega, velocity + d_u, log_mass + d_mu
    raise ConvergenceError("neutral-curve corrector did not converge")


def continue_neutral_curve(
    fluid: FluidOperators,
    start: CriticalPoint,
    template: Solid,
    *,
    mass_range: tuple[float, float] = (1.0, 1e4),
    velocity_range: tuple[float, float] = (1e-2, 20.0),
    direction: float = -1.0,
    step: float = 0.2,
    min_step: float = 1e-3,
    max_step: float = 0.5,
    max_points: int = 200,
    counter: FactorCounter | None = None,
    on_point: Callable[[NeutralPoint], None] | None = None,
) -> NeutralCurve:
    """Follow the flutter/VIV neutral curve through ``start`` (a flutter CriticalPoint).

    Arclength in the plane ``(U*, log m)``; ``direction`` −1 starts towards smaller m. Steps grow
    after quick convergence and halve after a failure; the curve stops when it leaves
    ``mass_range``/``velocity_range`` or the frequency reaches zero (a codimension-two point with
    the divergence curve), or after ``max_points``. ``on_point`` is called for every accepted
    point (to save progress).
    """
    if start.kind != "flutter":
        raise InputError("continue_neutral_curve follows dynamic (ω > 0) neutral curves")
    if not 0 < mass_range[0] < mass_range[1] or not 0 < velocity_range[0] < velocity_range[1]:
        raise InputError("mass and velocity ranges must be positive and increasing")
    counter = counter if counter is not None else FactorCounter()
    first = counter.count
    log_bounds = (math.log(mass_range[0]), math.log(mass_range[1]))
    q, omega = start.mode.astype(complex), start.frequency
    velocity, log_mass = start.reduced_velocity, math.log(start.mass_ratio)
    points = [NeutralPoint(start.mass_ratio, velocity, omega, q, 0)]
    # initial tangent: move along log m, the corrector adjusts U*
    tangent = (0.0, float(np.sign(direction)))
    folds: list[int] = []
    stop = "max_points"
    last_step = None  # (Δs, Δq, Δω) of the previous accepted step, for the secant predictor
    while len(points) < max_points:
        anchor = (velocity, log_mass)
        predicted = (velocity + step * tangent[0], log_mass + step * tangent[1])
        q_guess, omega_guess = q, omega
        if last_step is not None:
            ratio = step / last_step[0]
            q_guess, omega_guess = q + ratio * last_step[1], omega + ratio * last_step[2]
        try:
            q_new, omega_new, u_new, mu_new, iterations = _newton_arclength(
                fluid,
                template,
                q_guess,
                omega_guess,
                predicted[0],
                predicted[1],
                anchor,
                tangent,
                step,
                counter,
            )
        except ConvergenceError:
            step /= 2
            if step < min_step:
                stop = "step_too_small"
                break
            continue
        secant = np.array([u_new - velocity, mu_new - log_mass])
        new_tangent = tuple(secant / np.linalg.norm(secant))
        if tangent[1] * new_tangent[1] < 0 and len(points) > 1:
            folds.append(len(points) - 1)
        tangent = new_tangent
        last_step = (step, q_new - q, omega_new - omega)
        q, omega, velocity, log_mass = q_new, omega_new, u_new, mu_new
        point = NeutralPoint(math.exp(log_mass), velocity, omega, q, iterations)
        points.append(point)
        if on_point:
            on_point(point)
        if not log_bounds[0] <= log_mass <= log_bounds[1]:
            stop = "mass_bound"
            break
        if not velocity_range[0] <= velocity <= velocity_range[1]:
            stop = "velocity_bound"
            break
        if omega <= 1e-4 * max(1.0, 1.0 / velocity):
            stop = "zero_frequency"
            break
        step = min(max_step, step * 1.5) if iterations <= 4 else step
    return NeutralCurve(tuple(points), tuple(folds), stop, counter.count - first)


def divergence_curve(moment_slope: float, r_theta: float, mass_ratios: np.ndarray) -> np.ndarray:
    """``U*_D(m) = √(m r_θ² / (dC_M/dθ))`` (MODEL.md §8); NaN where the slope is not positive."""
    mass_ratios = np.asarray(mass_ratios, dtype=float)
    if moment_slope <= 0:
        return np.full_like(mass_ratios, np.nan)
    return np.sqrt(mass_ratios * r_theta**2 / moment_slope)


def curve_dataset(curve_points: list[NeutralPoint], attrs: dict, complete: bool):
    """Points of a neutral curve (and the last point's mode, to resume) as an xarray Dataset."""
    import xarray as xr

    last = curve_points[-1]
    return xr.Dataset(
        {
            "mass_ratio": ("point", np.array([p.mass_ratio for p in curve_points])),
            "reduced_velocity": ("point", np.array([p.reduced_velocity for p in curve_points])),
            "frequency": ("point", np.array([p.frequency for p in curve_points])),
            "last_mode_real": ("unknown", last.mode.real),
            "last_mode_imag": ("unknown", last.mode.imag),
        },
        attrs={**attrs, "complete": int(complete)},
    )


def trace_curve_resumable(
    fluid: FluidOperators,
    start: CriticalPoint,
    template: Solid,
    path,
    attrs: dict,
    **options,
) -> list[NeutralPoint]:
    """:func:`continue_neutral_curve` writing ``path`` (NetCDF) after every point.

    If ``path`` holds a curve with the same ``attrs`` that was interrupted, or stopped at fewer
    than ``max_points`` points, it continues from its last point; a mismatched file is refused."""
    from fsistab.store import read_dataset, write_dataset

    points: list[NeutralPoint] = []
    if path.exists():
        ds = read_dataset(path, expect=attrs)
        points = [
            NeutralPoint(m, u, w, np.zeros(0), 0)
            for m, u, w in zip(
                ds.mass_ratio.values, ds.reduced_velocity.values, ds.frequency.values, strict=True
            )
        ]
        mode = ds.last_mode_real.values + 1j * ds.last_mode_imag.values
        points[-1] = replace(points[-1], mode=mode)
        wanted = options.get("max_points", 200)
        if ds.attrs.get("complete") and (ds.attrs.get("stop") != "max_points" or len(points) >= wanted):
            return points
        options = {**options, "max_points": wanted - len(points) + 1}
        last = points[-1]
        start = CriticalPoint("flutter", last.mass_ratio, last.reduced_velocity, last.frequency, mode, (), 0)
    else:
        points = [NeutralPoint(start.mass_ratio, start.reduced_velocity, start.frequency, start.mode, 0)]

    def save(point: NeutralPoint) -> None:
        points.append(point)
        write_dataset(curve_dataset(points, attrs, complete=False), path)

    curve = continue_neutral_curve(fluid, start, template, on_point=save, **options)
    write_dataset(curve_dataset(points, {**attrs, "stop": curve.stop}, complete=True), path)
    return points
