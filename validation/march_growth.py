"""Growth of a small eigenmode perturbation by the nonlinear time march, against the eigenvalue.

For each case, the leading (or the named) eigenpair of the coupled system on the coarse mesh, then
``fsistab.simulation`` from the steady state plus 1e-4 of its mode: the growth rate and frequency
fitted to a load or a solid signal (Prony's method from the third step on) against the eigenvalue
(the spectrum of the same mesh, an independent path: shift-invert Arnoldi on the Jacobian, where the
march evaluates the nonlinear residual) and against BDF2's image of it. Prints one Markdown row per
case and time step, with the march's cost.

Usage: python validation/march_growth.py [--cache DIR]
"""

import argparse
import time

import numpy as np

from fsistab.bodies import Cylinder, Plate
from fsistab.coupled import CoupledSystem
from fsistab.eigen import eigenpairs_near
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators
from fsistab.params import Flow, Solid, solid_for
from fsistab.simulation import MarchState, TimeStepper, damped_oscillation, march, perturbed_state
from fsistab.steady import solve_steady

# (name, body, Re, solid, shift, pick, signal, [(dt, steps)])
CASES = (
    (
        "fixed cylinder, Re 60, C_L",
        Cylinder(),
        60,
        solid_for("cylinder", dofs=()),
        0.05 + 0.75j,
        "nearest",
        "lift",
        [(0.2, 12), (0.1, 24), (0.05, 48), (0.025, 96)],
    ),
    (
        "cylinder in heave, Re 60, m = 1, U* = 5, h",
        Cylinder(),
        60,
        solid_for("cylinder", 1.0, 5.0, dofs=("heave",)),
        0.05 + 0.75j,
        "growth",
        "heave",
        [(0.1, 24), (0.05, 48)],
    ),
    (
        "plate, Re 2900, m = 1000, U* = 5, θ",
        Plate(),
        2900,
        Solid(mass_ratio=1000.0, reduced_velocity=5.0),
        0.01 + 0.17j,
        "solid",
        "pitch",
        [(0.2, 12), (0.1, 24)],
    ),
)
SIGNALS = {"lift": lambda s: s.lift, "heave": lambda s: s.solid[0], "pitch": lambda s: s.solid[1]}
PICK = {
    "nearest": lambda pairs, shift: min(pairs, key=lambda p: abs(p.value - shift)),
    "growth": lambda pairs, shift: max(pairs, key=lambda p: p.growth_rate),
    "solid": lambda pairs, shift: max(pairs, key=lambda p: p.solid_energy_fraction),
}


def bdf2_image(sigma: complex, dt: float) -> complex:
    roots = np.roots([1.5 - sigma * dt, -2.0, 0.5])
    return complex(np.log(roots[np.argmax(np.abs(roots))]) / dt)


def row(name, system, pair, dt, steps, signal) -> str:
    stepper = TimeStepper(system, dt)
    state = MarchState(0.0, 0, perturbed_state(stepper, pair.vector, 1e-4))
    t0 = time.perf_counter()
    samples = [s for _, s in march(stepper, state, steps * dt)][2:]
    seconds = (time.perf_counter() - t0) / steps
    fit = damped_oscillation([s.time for s in samples], [SIGNALS[signal](s) for s in samples])
    sigma = pair.value
    image = bdf2_image(sigma, dt)
    return (
        f"| {name} | {system.size} | {dt:g} | {sigma.real:+.6f}{sigma.imag:+.6f}i | "
        f"{fit.real:+.6f}{fit.imag:+.6f}i | {fit.real / sigma.real - 1:+.3%} | "
        f"{fit.imag / sigma.imag - 1:+.4%} | {abs(fit - image) / abs(sigma):.1e} | "
        f"{np.mean([s.iterations for s in samples]):.1f} | {seconds:.2f} |"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--cache", default=None)
    args = parser.parse_args()
    print(
        "| case | unknowns | Δt | eigenvalue σ | fitted | growth error | frequency error | "
        "\\|fit − BDF2(σ)\\|/\\|σ\\| | iterations per step | s per step |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name, body, reynolds, solid, shift, pick, signal, steps in CASES:
        steady = solve_steady(mesh_spec(body, "coarse", reynolds), Flow(reynolds), cache_dir=args.cache)
        system = CoupledSystem(fluid_operators(steady), solid)
        pair = PICK[pick](eigenpairs_near(system, [shift], 4), shift)
        for dt, count in steps:
            print(row(name, system, pair, dt, count, signal), flush=True)


if __name__ == "__main__":
    main()
