"""Aerodynamic coefficients and wake measures of a steady state (docs/model.md §4).

Forces are "reaction forces" of the discrete equations: the weak momentum residual tested with a
discrete field ``ℓ`` equal to a rigid motion on the wall and zero at every other dof. Since
``∫σ:∇ℓ = -∫(∇·σ)·ℓ - ∫_Γw σN·ℓ`` (``N`` out of the solid), ``F·ℓ = -R(U, P; ℓ)``: consistent with
the discrete Jacobian and more accurate than a surface integral of the discrete stress.
Coefficients use the body's length unit: ``C = F / (½ ρ U∞² L s)``, i.e. ``C = 2F`` here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fsistab.bodies import WALL, frame_offset
from fsistab.steady import SteadyProblem, SteadyState, wall_velocity

RIGID_MOTIONS = ("x", "y", "rotation")


def wall_liftings(space, mesh) -> dict[str, object]:
    """Discrete liftings ``ℓ_x, ℓ_y, ℓ_rotation`` of ``e_x``, ``e_y`` and ``(-Y, X)`` on the wall
    (the liftings of the wall data of docs/model.md §7).

    GridFunctions of the Taylor–Hood ``space`` whose velocity equals the rigid motion on the wall
    dofs and vanishes at every other dof (pressure included).
    """
    from ngsolve import CF, GridFunction, x, y

    motions = {"x": CF((1, 0)), "y": CF((0, 1)), "rotation": CF((-y, x))}
    liftings = {}
    for name, motion in motions.items():
        field = GridFunction(space)
        field.components[0].Set(motion, definedon=mesh.Boundaries(WALL))
        liftings[name] = field
    return liftings


def reaction_loads(steady: SteadyState) -> dict[str, float]:
    """Force ``(F_x, F_y)`` in body axes and moment ``M`` about G (counter-clockwise +), from the
    weak-form residual (docs/model.md §4).

    Dimensionless with ``ρ U∞² L s`` (multiply by 2 for coefficients).
    """
    problem = SteadyProblem.on(steady.mesh, steady.space, outlet=steady.mesh_spec.outlet)
    problem.set_flow(steady.flow)
    residual = steady.state.vec.CreateVector()
    problem.form.Apply(steady.state.vec, residual)
    r = residual.FV().NumPy()
    liftings = wall_liftings(steady.space, steady.mesh)
    loads = {name: -float(np.dot(r, liftings[name].vec.FV().NumPy())) for name in RIGID_MOTIONS}
    return {"force_x": loads["x"], "force_y": loads["y"], "moment": loads["rotation"]}


@dataclass(frozen=True)
class Coefficients:
    """Lift, drag and moment coefficients in the laboratory axes (docs/model.md §4).

    ``lift`` along ``e_y``, ``drag`` along ``e_x`` (the free-stream direction in the body frame),
    ``moment`` about G, counter-clockwise positive (nose-down for the plate; nose-up is ``C_M < 0``).
    """

    lift: float
    drag: float
    moment: float


def aerodynamic_coefficients(steady: SteadyState) -> Coefficients:
    """``C_L = 2{R(θ0)F}·e_y``, ``C_D = 2{R(θ0)F}·e_x``, ``C_M = 2M`` (docs/model.md §4)."""
    loads = reaction_loads(steady)
    theta = steady.flow.theta0
    fx, fy = loads["force_x"], loads["force_y"]
    return Coefficients(
        lift=2 * (math.sin(theta) * fx + math.cos(theta) * fy),
        drag=2 * (math.cos(theta) * fx - math.sin(theta) * fy),
        moment=2 * loads["moment"],
    )


def surface_coefficients(steady: SteadyState) -> Coefficients:
    """The same coefficients from a surface integral of the discrete stress (for comparison)."""
    from ngsolve import BoundaryFromVolumeCF, Grad, Id, IfPos, Integrate, ds, specialcf, x, y

    u, p = steady.velocity, steady.pressure
    stress = -p * Id(2) + (1 / steady.flow.reynolds) * (Grad(u) + Grad(u).trans)
    n = specialcf.normal(2)
    # element orientation flips on the mirrored half: orient N out of the (convex) body around G
    normal = IfPos(n[0] * x + n[1] * y, 1.0, -1.0) * n
    traction = BoundaryFromVolumeCF(stress) * normal
    fx = Integrate(traction[0] * ds(WALL), steady.mesh)
    fy = Integrate(traction[1] * ds(WALL), steady.mesh)
    moment = Integrate((x * traction[1] - y * traction[0]) * ds(WALL), steady.mesh)
    theta = steady.flow.theta0
    return Coefficients(
        lift=2 * (math.sin(theta) * fx + math.cos(theta) * fy),
        drag=2 * (math.cos(theta) * fx - math.sin(theta) * fy),
        moment=2 * moment,
    )


def streamwise_direction(theta0: float) -> np.ndarray:
    """Unit vector of the free stream seen from the body, ``-W⁰/|W⁰|``, in body axes."""
    return -np.array(wall_velocity(theta0))


def recirculation_length(steady: SteadyState, spacing: float = 2e-3, reach: float = 20.0) -> float:
    """Length of the recirculation region behind the body, from its rear, in body lengths.

    Along the ray from the rear point ``(1/2, 0)`` in the free-stream direction ``d``, the relative
    streamwise velocity ``(U - W⁰)·d`` vanishes on the wall, is negative in the recirculation
    bubble and positive beyond it; the length is the first crossing from negative to positive
    (0 if the velocity is never negative just behind the body).
    """
    d = streamwise_direction(steady.flow.theta0)
    body = steady.mesh_spec.body  # the outlet at downstream + frame_offset (docs/model.md §3.1)
    downstream = steady.mesh_spec.domain.downstream + frame_offset(body) - body.rear
    distance = np.arange(spacing, min(reach, 0.95 * downstream), spacing)
    points = np.array([steady.mesh_spec.body.rear, 0.0]) + distance[:, None] * d
    values = steady.velocity(steady.mesh(points[:, 0], points[:, 1]))
    relative = (np.asarray(values) - np.array(wall_velocity(steady.flow.theta0))) @ d
    if relative[0] >= 0:
        return 0.0
    positive = np.nonzero(relative > 0)[0]
    if positive.size == 0:
        return float(distance[-1])
    i = positive[0]
    # linear interpolation of the zero crossing between samples i-1 and i
    return float(distance[i - 1] + spacing * (-relative[i - 1]) / (relative[i] - relative[i - 1]))
