"""Eigenvalue branches along a parameter, keeping each branch's identity (ARCHITECTURE `tracking`).

Each branch is followed by a secant predictor of its eigenvalue, one factorisation at the
predicted shift, and inverse iterations started from the previous mode (cheap: a few solves with
that factorisation). If they stall — another eigenvalue nearly as close to the shift — a small
shift-invert Arnoldi with the same factorisation takes over and the eigenvalue whose mode best
matches the previous one (largest |q_prevᴴ M q|/(‖q_prev‖_M‖q‖_M)) continues the branch.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse.linalg as spla

from fsistab.coupled import CoupledSystem
from fsistab.eigen import Eigenpair, label_mode
from fsistab.errors import ConvergenceError
from fsistab.linalg import FactorCounter, ShiftedSolver, residual_norm, shift_invert_operator
from fsistab.progress import Progress


@dataclass
class EigenBranch:
    """One eigenvalue followed along ``parameters``; ``values[i]`` is σ at ``parameters[i]``."""

    name: str
    parameters: list[float] = field(default_factory=list)
    values: list[complex] = field(default_factory=list)
    labels: list[str] = field(default_factory=list)
    vectors: list[np.ndarray] = field(default_factory=list)

    inverse_scaling: bool = False  # σ ∝ 1/parameter (solid modes along U*): extrapolate σ·p

    def predict(self, parameter: float) -> complex:
        scale = np.array(self.parameters[-2:]) if self.inverse_scaling else np.ones(min(2, len(self.values)))
        w = np.array(self.values[-2:]) * scale
        if len(self.values) < 2:
            guess = w[-1]
        else:
            p0, p1 = self.parameters[-2], self.parameters[-1]
            guess = w[1] + (w[1] - w[0]) * (parameter - p1) / (p1 - p0)
        return guess / parameter if self.inverse_scaling else guess


def _correlation(system: CoupledSystem, a: np.ndarray, b: np.ndarray) -> float:
    """|cos| of the angle between two modes: on their solid states when they have any (the fluid
    parts of low-frequency modes look alike), else in the M inner product."""
    ns = system.n_solid
    if ns and np.linalg.norm(b[:ns]) > 1e-3 * np.linalg.norm(b):
        sa, sb = a[:ns], b[:ns]
        na, nb = np.linalg.norm(sa), np.linalg.norm(sb)
        return float(abs(np.vdot(sa, sb)) / (na * nb)) if na > 0 and nb > 0 else 0.0
    ma, mb = system.mass @ a, system.mass @ b
    na, nb = np.sqrt(abs(np.vdot(a, ma))), np.sqrt(abs(np.vdot(b, mb)))
    return float(abs(np.vdot(a, mb)) / (na * nb)) if na > 0 and nb > 0 else 0.0


def refine_eigenpair(
    system: CoupledSystem,
    shift: complex,
    start: np.ndarray,
    *,
    tol: float = 1e-9,
    maxit: int = 25,
    counter: FactorCounter | None = None,
    fluid_factor=None,
) -> tuple[complex, np.ndarray, float, object]:
    """Eigenpair nearest ``shift`` continuing ``start``: inverse iteration, Arnoldi if it stalls.

    Returns ``(σ, q, residual, fluid factorisation used)``; ``fluid_factor`` (a
    :class:`fsistab.linalg.FluidFactor` at ``shift``) is reused if given.
    """
    counter = counter if counter is not None else FactorCounter()
    solver = ShiftedSolver(system, shift, fluid_factor=fluid_factor, counter=counter)
    q = np.asarray(start, dtype=complex)
    q = q / np.linalg.norm(q)
    sigma, residual = shift, np.inf
    for _ in range(maxit):
        z = solver.solve(system.mass @ q)
        mu = np.vdot(q, z) / np.vdot(q, q)
        sigma = shift - 1.0 / mu
        q = z / np.linalg.norm(z)
        residual = residual_norm(system, sigma, q)
        if residual < tol:
            if _correlation(system, q, start) > 0.9:
                return complex(sigma), q, residual, solver.fluid_factor
            break  # converged to another mode: let Arnoldi find the one that continues the branch
    # stalled: Arnoldi with the same factorisation, pick the best match to the start vector
    mu, vectors = spla.eigs(shift_invert_operator(solver), k=4, ncv=30, tol=1e-10, v0=start.astype(complex))
    candidates = [(shift - 1.0 / m, v) for m, v in zip(mu, vectors.T, strict=True) if abs(m) > 1e-12]
    sigma, q = max(candidates, key=lambda c: _correlation(system, c[1], start))
    residual = residual_norm(system, sigma, q)
    if residual > 1e-6:
        raise ConvergenceError(f"lost the eigenvalue branch near {shift:.4g}; use smaller parameter steps")
    return complex(sigma), q / np.linalg.norm(q), residual, solver.fluid_factor


def track_branches(
    system_at: Callable[[float], CoupledSystem],
    parameters: Sequence[float],
    starts: dict[str, Eigenpair],
    *,
    inverse_scaling: Sequence[str] = (),
    counter: FactorCounter | None = None,
    progress: Progress = None,
) -> dict[str, EigenBranch]:
    """Follow each eigenpair of ``starts`` (computed at ``parameters[0]``) along ``parameters``.

    ``system_at(p)`` builds the coupled system at parameter ``p`` (cheap: solid blocks only).
    Branches named in ``inverse_scaling`` are predicted with ``σ ∝ 1/p`` (solid modes along U*).
    Conjugates are folded to ``ω ≥ 0``.
    """
    counter = counter if counter is not None else FactorCounter()
    branches = {name: EigenBranch(name, inverse_scaling=name in inverse_scaling) for name in starts}
    for name, pair in starts.items():
        b = branches[name]
        b.parameters.append(parameters[0])
        b.values.append(pair.value)
        b.labels.append(pair.label)
        b.vectors.append(pair.vector)
    for i, parameter in enumerate(parameters[1:], start=1):
        system = system_at(parameter)
        for branch in branches.values():
            predicted = branch.predict(parameter)
            # a small offset keeps the shift off the eigenvalue itself
            shift = predicted + 1e-3 * (1 + abs(predicted))
            sigma, q, _, _ = refine_eigenpair(system, shift, branch.vectors[-1], counter=counter)
            if sigma.imag < 0:
                sigma, q = np.conj(sigma), np.conj(q)
            solid, fluid = system.split(q)
            label, _ = label_mode(solid, system.solid, system.fluid.near_energy(fluid), system.fluid.theta0)
            branch.parameters.append(parameter)
            branch.values.append(sigma)
            branch.labels.append(label)
            branch.vectors.append(q)
        if progress:
            progress(f"tracking branches: point {i + 1}/{len(parameters)}, {counter.count} factorisations")
    return branches
