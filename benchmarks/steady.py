"""Benchmark of the steady solver: plate at Re = 2900, α0 = 0, from rest (no cache).

Prints unknowns, triangles, mesh time, the steady solve's wall and CPU time, Newton iterations at
the target, continuation steps, factorisations (one per Newton iteration, failed attempts included)
and peak memory. Usage: python benchmarks/steady.py [coarse medium fine] [--backend ngsolve]
[--threads 1] [--middle SIZE] [--shift 11.2j]. ``--middle`` overrides the preset's element size
(chords) in the middle box (e.g. ``fine --middle 0.5`` for about a million unknowns);
``--shift`` adds one factorisation of ``J_ff + s M_f`` after the steady state (the memory of the
eigenvalue and transfer paths). ``--backend`` chooses the factorisation of the Newton matrices
(``fsistab.umfpack.BACKENDS``); without it the package's default is used, so that the script
also measures an older version of the package (``PYTHONPATH=<old tree>/src``).
"""

import argparse
import resource
import time

from ngsolve import SetNumThreads

from fsistab.bodies import Plate
from fsistab.mesh import build_mesh, mesh_spec, mesh_statistics
from fsistab.params import Flow
from fsistab.steady import solve_steady


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("presets", nargs="*", default=["medium"])
    parser.add_argument("--reynolds", type=float, default=2900.0)
    parser.add_argument("--backend", default=None, help="umfpack | ngsolve (default: the package's)")
    parser.add_argument("--threads", type=int, default=2, help="NGSolve threads (default 2)")
    parser.add_argument("--middle", type=float, default=None, help="middle-box element size (chords)")
    parser.add_argument("--shift", type=complex, default=None, help="then factorise J_ff + s M_f")
    args = parser.parse_args()
    SetNumThreads(args.threads)
    options = {} if args.backend is None else {"backend": args.backend}
    for preset in args.presets:
        spec = mesh_spec(Plate(), preset, args.reynolds, **({"middle": args.middle} if args.middle else {}))
        t0 = time.perf_counter()
        stats = mesh_statistics(build_mesh(spec))
        t_mesh = time.perf_counter() - t0
        wall, cpu = time.perf_counter(), time.process_time()
        steady = solve_steady(spec, Flow(args.reynolds), **options)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        print(f"preset {preset}: {stats['ndof']} unknowns, {stats['triangles']} triangles")
        print(f"  backend                {args.backend or 'default'}")
        print(f"  mesh [s]               {t_mesh:.1f}")
        print(f"  steady solve wall [s]  {wall:.2f}")
        print(f"  steady solve CPU [s]   {cpu:.2f}")
        print(f"  Newton at target       {steady.newton_iterations} (residual {steady.history[-1]:.1e})")
        path = ", ".join(f"{r:.4g} ({n})" for r, _, n in steady.path)
        print(f"  continuation steps     {len(steady.path)} (Re (iterations): {path})")
        print(f"  factorisations         {steady.factorisations}")
        print(f"  per factorisation [s]  {wall / max(steady.factorisations, 1):.3f} (incl. assembly)")
        print(f"  peak memory [MB]       {peak:.0f}")
        if args.shift is not None:
            from fsistab.linalg import FluidFactor
            from fsistab.operators import fluid_operators

            fluid = fluid_operators(steady)
            t0 = time.perf_counter()
            FluidFactor(fluid, args.shift)
            peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
            print(
                f"  factorisation at s = {args.shift}: {time.perf_counter() - t0:.1f} s (analysis included)"
            )
            print(f"  peak memory [MB]       {peak:.0f} (steady state and one complex factorisation)")


if __name__ == "__main__":
    main()
