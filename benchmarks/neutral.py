"""Benchmark of the neutral-curve path (continuation method): plate, Re = 2900, α0 = 0.

Prints unknowns, the factorisations and wall time of the threshold sweep at m = 1000, of one
flutter curve traced over m in [--mass-low, --mass-high], and peak memory.
Usage: python benchmarks/neutral.py [coarse|medium|fine] [--cache DIR]
"""

import argparse
import resource
import time

import numpy as np
from ngsolve import SetNumThreads

from fsistab.critical import find_thresholds
from fsistab.linalg import FactorCounter
from fsistab.mesh import mesh_spec
from fsistab.neutral import continue_neutral_curve
from fsistab.operators import fluid_operators
from fsistab.params import Flow, Plate, Solid
from fsistab.steady import solve_steady


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("preset", nargs="?", default="medium")
    parser.add_argument("--cache", default=None)
    parser.add_argument("--mass-low", type=float, default=100.0)
    parser.add_argument("--mass-high", type=float, default=1e4)
    parser.add_argument("--points", type=int, default=16)
    args = parser.parse_args()
    SetNumThreads(2)
    steady = solve_steady(mesh_spec(Plate(), args.preset, 2900), Flow(2900), cache_dir=args.cache)
    fluid = fluid_operators(steady)
    solid = Solid(mass_ratio=1000, reduced_velocity=3.0)

    sweep = FactorCounter()
    t0 = time.perf_counter()
    thresholds, _ = find_thresholds(fluid, solid, np.geomspace(3, 9, args.points), counter=sweep)
    t_sweep = time.perf_counter() - t0
    flutter = next(t for t in thresholds if t.kind == "flutter")

    curve_counter = FactorCounter()
    t0 = time.perf_counter()
    n_points = 0
    for direction in (-1, 1):
        curve = continue_neutral_curve(
            fluid,
            flutter.point,
            solid,
            direction=direction,
            mass_range=(args.mass_low, args.mass_high),
            counter=curve_counter,
        )
        n_points += len(curve.points)
    t_curve = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"preset                   {args.preset}")
    print(f"unknowns                 {fluid.n_fluid + 4}")
    print(f"sweep: U* points         {args.points}")
    print(f"sweep: factorisations    {sweep.count}")
    print(f"sweep: wall time [s]     {t_sweep:.1f}")
    print(f"thresholds               {[(t.kind, round(t.reduced_velocity, 5)) for t in thresholds]}")
    print(f"curve: points            {n_points} (m in [{args.mass_low:g}, {args.mass_high:g}])")
    print(f"curve: factorisations    {curve_counter.count}")
    print(f"curve: wall time [s]     {t_curve:.1f}")
    print(f"peak memory [MB]         {peak:.0f}")


if __name__ == "__main__":
    main()
