"""Benchmark of the neutral-map path (continuation method): plate, Re = 2900, α0 = 0.

Prints unknowns, factorisations and wall time of (1) the sweep at m = 1000 and the flutter curve
traced from its threshold over the whole m range, (2) the rest of the map (sweeps at m = 100 and 10,
the VIV sweep at the lowest m around the wake frequency, their curves), and peak memory. Curves
are saved in --out, so a rerun resumes (delete the directory for a fresh measurement).
Usage: python benchmarks/neutral.py [coarse|medium|fine] [--cache DIR] [--out DIR]
"""

import argparse
import resource
import time
from pathlib import Path

from ngsolve import SetNumThreads

from fsistab.critical import wake_mode_near
from fsistab.linalg import FactorCounter
from fsistab.mesh import mesh_spec
from fsistab.neutral import map_seeds, trace_neutral_map
from fsistab.operators import fluid_operators
from fsistab.params import Flow, Plate, Solid
from fsistab.steady import solve_steady


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("preset", nargs="?", default="medium")
    parser.add_argument("--cache", default=None)
    parser.add_argument("--out", default="benchmark-neutral")
    parser.add_argument("--mass-low", type=float, default=1.0)
    parser.add_argument("--mass-high", type=float, default=1e4)
    parser.add_argument("--points", type=int, default=24)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--curve-only", action="store_true", help="stop after the first flutter curve")
    parser.add_argument("--wake-frequency", type=float, default=11.0, help="guess, refined by Arnoldi")
    args = parser.parse_args()
    SetNumThreads(args.threads)
    out = Path(args.out) / args.preset
    spec = mesh_spec(Plate(), args.preset, 2900)
    t0 = time.perf_counter()
    fluid = fluid_operators(solve_steady(spec, Flow(2900), cache_dir=args.cache))
    t_steady = time.perf_counter() - t0
    template = Solid(mass_ratio=1000, reduced_velocity=2.0)
    attrs = {"reynolds": 2900.0, "mesh_key": spec.key(), "benchmark": 1}
    mass_range = (args.mass_low, args.mass_high)
    seeds = map_seeds(1000.0, (2.0, 10.0), args.points)

    one = FactorCounter()
    t0 = time.perf_counter()
    first = trace_neutral_map(fluid, template, seeds, out, "bench", attrs, mass_range=mass_range, counter=one)
    t_one = time.perf_counter() - t0

    if args.curve_only:
        print(f"preset                         {args.preset}")
        print(f"unknowns                       {fluid.n_fluid + 4}")
        print(f"steady state + operators [s]   {t_steady:.1f}")
        print(f"flutter curve: points          {[len(c.points) for c in first.curves]} in m {mass_range}")
        print(f"flutter curve: factorisations  {one.count} (sweep of {args.points} U* included)")
        print(f"flutter curve: wall time [s]   {t_one:.1f}")
        print(
            f"peak memory [MB]               {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f}"
        )
        return
    rest = FactorCounter()
    t0 = time.perf_counter()
    wake = wake_mode_near(fluid, args.wake_frequency, counter=rest)
    seeds = map_seeds(1000.0, (2.0, 10.0), args.points, (100.0, 10.0), wake.frequency, args.mass_low)
    full = trace_neutral_map(fluid, template, seeds, out, "bench", attrs, mass_range=mass_range, counter=rest)
    t_rest = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"preset                         {args.preset}")
    print(f"unknowns                       {fluid.n_fluid + 4}")
    print(f"steady state + operators [s]   {t_steady:.1f}")
    print(f"flutter curve: points          {sum(len(c.points) for c in first.curves)}")
    print(f"flutter curve: factorisations  {one.count} (sweep of {args.points} U* included)")
    print(f"flutter curve: wall time [s]   {t_one:.1f}")
    print(f"wake mode                      {wake.value:.5f}")
    print(f"whole map: curves              {[(c.kind, len(c.points)) for c in full.curves]}")
    print(f"whole map: turning points      {sum(len(c.turning_points) for c in full.curves)}")
    print(f"whole map: crossings           {len(full.crossings)}")
    print(f"whole map: factorisations      {one.count + rest.count}")
    print(f"whole map: wall time [s]       {t_one + t_rest:.1f}")
    print(f"peak memory [MB]               {peak:.0f}")


if __name__ == "__main__":
    main()
