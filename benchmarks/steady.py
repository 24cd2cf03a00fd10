"""Benchmark of the steady solver: plate at Re = 2900, α0 = 0, from rest (no cache).

Prints unknowns, triangles, mesh time, Newton iterations at the target, continuation steps,
factorisations, steady-solve wall time and peak memory. Usage: python benchmarks/steady.py [medium fine]
"""

import argparse
import resource
import time

from ngsolve import SetNumThreads

from fsistab.mesh import build_mesh, mesh_spec, mesh_statistics
from fsistab.params import Flow, Plate
from fsistab.steady import solve_steady


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("presets", nargs="*", default=["medium"])
    parser.add_argument("--reynolds", type=float, default=2900.0)
    args = parser.parse_args()
    SetNumThreads(2)
    for preset in args.presets:
        spec = mesh_spec(Plate(), preset, args.reynolds)
        t0 = time.perf_counter()
        stats = mesh_statistics(build_mesh(spec))
        t_mesh = time.perf_counter() - t0
        steady = solve_steady(spec, Flow(args.reynolds))
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(f"preset {preset}: {stats['ndof']} unknowns, {stats['triangles']} triangles")
        print(f"  mesh [s]               {t_mesh:.1f}")
        print(f"  steady solve [s]       {steady.seconds:.1f}")
        print(f"  Newton at target       {steady.newton_iterations} (residual {steady.history[-1]:.1e})")
        path = ", ".join(f"{r:.4g}" for r, _, _ in steady.path)
        print(f"  continuation steps     {len(steady.path)} (Re {path})")
        print(f"  factorisations         {steady.factorisations}")
        print(
            f"  per factorisation [s]  {steady.seconds / max(steady.factorisations, 1):.2f} (incl. assembly)"
        )
        print(f"  peak memory [MB]       {peak:.0f}")


if __name__ == "__main__":
    main()
