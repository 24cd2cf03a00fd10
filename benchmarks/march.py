"""Benchmark of the time march: the plate at Re = 2900, m = 1000, released in its flutter mode.

Marches ``--steps`` BDF2 steps of ``--time-step`` from the plate released at ``--release``
degrees of pitch in the flutter mode's solid state (the fluid at its steady state), as
``fsistab simulate --perturbation-of pitch`` does, and prints the unknowns, the march's wall and
CPU time, chord iterations, factorisations, iteration-matrix rebuilds and peak memory, then the
cost of one residual evaluation and of one rebuild's linearisation, and the pitch reached (the
same march in two versions gives the same pitch to about the step tolerance). The steady state is
read from (or written to) ``--cache``. Only public names that older versions of the package also
have are used, so the script measures an older version too (``PYTHONPATH=<old tree>/src``).

Usage: python benchmarks/march.py [coarse] [--mesh-reynolds 5800] [--steps 400]
"""

import argparse
import math
import resource
import time

import numpy as np

from fsistab.bodies import Plate
from fsistab.coupled import CoupledSystem
from fsistab.eigen import eigenpairs_near
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators
from fsistab.params import Flow, Solid
from fsistab.simulation import MarchState, TimeStepper, march, perturbed_state
from fsistab.steady import solve_steady


def mean_seconds(call, repeats: int) -> float:
    call()
    start = time.perf_counter()
    for _ in range(repeats):
        call()
    return (time.perf_counter() - start) / repeats


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("preset", nargs="?", default="coarse")
    parser.add_argument("--mesh-reynolds", type=float, default=None)
    parser.add_argument("--reduced-velocity", type=float, default=5.0)
    parser.add_argument("--release", type=float, default=8.0, help="pitch at release, degrees")
    parser.add_argument("--time-step", type=float, default=0.025)
    parser.add_argument("--steps", type=int, default=400)
    parser.add_argument("--cache", default="fsistab-cache")
    args = parser.parse_args()
    spec = mesh_spec(Plate(), args.preset, args.mesh_reynolds or 2900.0)
    steady = solve_steady(spec, Flow(2900.0), cache_dir=args.cache)
    solid = Solid(mass_ratio=1000.0, reduced_velocity=args.reduced_velocity)
    system = CoupledSystem(fluid_operators(steady), solid)
    pair = max(eigenpairs_near(system, [0.0016 + 0.164j], 4), key=lambda p: p.solid_energy_fraction)
    wall, cpu = time.perf_counter(), time.process_time()
    stepper = TimeStepper(system, args.time_step, tolerance=1e-7, max_iterations=60)
    setup_wall = time.perf_counter() - wall
    start = perturbed_state(stepper, pair.vector, math.radians(args.release), "pitch")
    iterations, last = 0, None
    for _, sample in march(stepper, MarchState(0.0, 0, start), args.steps * args.time_step):
        iterations, last = iterations + sample.iterations, sample
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    q_solid, q_fluid = stepper.fluid.steady_point()
    values = stepper.fluid.full_state(q_solid, q_fluid)
    print(f"{args.preset} (mesh Re {args.mesh_reynolds or 2900:g}): {system.size} unknowns")
    print(f"  march: {args.steps} steps of {args.time_step:g}, released at {args.release:g} degrees")
    print(f"  wall [s]               {wall:.1f} (stepper set-up {setup_wall:.1f})")
    print(f"  CPU [s]                {cpu:.1f}")
    print(f"  per step, wall [s]     {wall / args.steps:.3f}")
    print(f"  chord iterations       {iterations} ({iterations / args.steps:.2f} per step)")
    print(f"  factorisations         {stepper.counter.count} ({stepper.refreshes} rebuilds)")
    print(f"  peak memory [MB]       {peak:.0f}")
    print(f"  residual call [ms]     {1e3 * mean_seconds(lambda: stepper.fluid(q_solid, q_fluid), 20):.1f}")
    linearise = mean_seconds(lambda: stepper.fluid.linearisation(q_solid, values), 3)
    print(f"  linearisation [ms]     {1e3 * linearise:.1f}")
    print(f"  pitch at the end [deg] {np.degrees(last.solid[1]):.10f}")


if __name__ == "__main__":
    main()
