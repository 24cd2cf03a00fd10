"""Static aerodynamic slopes ``dC_L/dθ`` and ``dC_M/dθ`` at a steady state (docs/model.md §9).

The steady flow's response to a small pitch ``δθ`` solves ``J_ff δq_f = -J_fs[:, θ] δθ``: one real
linear solve, where ``J_fs[:, θ]`` holds both the shape derivative ``D_θ`` and the wall condition
``∂U⁰/∂θ = W_θ`` on the wall. Then

``dC_L/dθ = ∂C_L/∂θ + ∂C_L/∂q_f · δq_f/δθ`` (``∂C_L/∂θ = 2{R'(θ0)F⁰}·e_y``: the rotated drag),
``dC_M/dθ = ∂C_M/∂q_f · δq_f/δθ + ∂C_M/∂θ|_explicit``.

Thin-airfoil values: ``dC_L/dθ = -2π``, ``dC_M/dθ = π/2`` about mid-chord; papers quote
``dC_L/d(-θ) = 2π`` and ``d(-C_M)/d(-θ) = π/2`` (``α = -θ``), given here as ``lift_slope_alpha`` and
``moment_slope_alpha``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fsistab.coupled import lift_and_moment_rows
from fsistab.linalg import FactorCounter, FluidFactor
from fsistab.operators import FluidOperators

THIN_AIRFOIL_LIFT_SLOPE = 2 * np.pi  # dC_L/dα
THIN_AIRFOIL_MOMENT_SLOPE = np.pi / 2  # d(-C_M)/dα about mid-chord


@dataclass(frozen=True)
class StaticSlopes:
    """Steady slopes with respect to the pitch ``θ`` (rad⁻¹), at ``(Re, α0)``; body-length units."""

    reynolds: float
    alpha0_deg: float
    lift: float  # dC_L/dθ
    moment: float  # dC_M/dθ (moment about G, counter-clockwise +)
    drag: float  # dC_D/dθ
    steady_drag: float = 0.0  # C_D of the steady state (moves a moment slope, docs/model.md §3.1)
    normal: float | None = None  # d(2F_Y)/dθ, the body-axis normal force's slope (idem, any θ₀)

    @property
    def lift_slope_alpha(self) -> float:
        """``dC_L/dα = -dC_L/dθ`` (thin airfoil: 2π)."""
        return -self.lift

    @property
    def moment_slope_alpha(self) -> float:
        """``d(-C_M)/dα = dC_M/dθ`` (thin airfoil about mid-chord: π/2)."""
        return self.moment


def static_response(
    fluid: FluidOperators, counter: FactorCounter | None = None, factor: FluidFactor | None = None
) -> np.ndarray:
    """``∂q_f⁰/∂θ``: the steady flow's derivative with respect to the pitch angle."""
    factor = factor if factor is not None else FluidFactor(fluid, 0.0, counter)
    return factor.solve(-fluid.jfs[:, 1])


def static_slopes(
    fluid: FluidOperators, counter: FactorCounter | None = None, factor: FluidFactor | None = None
) -> StaticSlopes:
    """Slopes of docs/model.md §9 from one factorisation of ``J_ff`` (``factor``, if given, is reused)."""
    response = static_response(fluid, counter, factor)
    d_loads = fluid.load_f @ response + fluid.load_s[:, 1]  # d(F_x, F_y, M)/dθ in body axes
    rows, d_lift_rotation = lift_and_moment_rows(fluid.theta0, fluid.loads0)
    d_lift, d_moment = rows @ d_loads
    c, s = np.cos(fluid.theta0), np.sin(fluid.theta0)
    fx, fy = fluid.loads0[:2]
    # C_D = 2(cos θ F_x - sin θ F_y)
    d_drag = 2 * (c * d_loads[0] - s * d_loads[1]) - 2 * (s * fx + c * fy)
    flow = fluid.steady.flow
    return StaticSlopes(
        reynolds=flow.reynolds,
        alpha0_deg=flow.alpha0_deg,
        lift=float(d_lift + d_lift_rotation),
        moment=float(d_moment),
        drag=float(d_drag),
        steady_drag=float(2 * (c * fx - s * fy)),
        normal=float(2 * d_loads[1]),
    )
