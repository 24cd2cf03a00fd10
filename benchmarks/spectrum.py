"""Benchmark of the eigenvalue path: plate, Re = 2900, m = 1000, U* = 4.7 (docs/model.md §2 defaults).

Prints unknowns, wall time of the steady state (from cache if present), operator assembly, the
complex factorisation (one per shift), the Arnoldi solve and its matvec count, and peak memory.
Each stage also reports the CPU time of the process (all threads), which stays meaningful when other
jobs share the cores and inflate the wall times.
Usage: python benchmarks/spectrum.py [coarse|medium|fine] [--cache DIR] [--backend umfpack|ngsolve]
"""

import argparse
import resource
import time

import numpy as np
import scipy.sparse.linalg as spla
from ngsolve import SetNumThreads

from fsistab.bodies import Plate
from fsistab.coupled import CoupledSystem
from fsistab.linalg import FactorCounter, FluidFactor, ShiftedSolver, shift_invert_operator
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators
from fsistab.params import Flow, Solid
from fsistab.steady import solve_steady


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("preset", nargs="?", default="medium")
    parser.add_argument("--cache", default=None)
    parser.add_argument("--shift", default="0.05+0.2j")
    parser.add_argument("--nev", type=int, default=6)
    parser.add_argument(
        "--backend",
        default="umfpack",
        choices=("umfpack", "ngsolve"),
        help="fsistab.umfpack (default) or NGSolve's UMFPACK (the earlier solver)",
    )
    args = parser.parse_args()
    SetNumThreads(2)

    t0, c0 = time.perf_counter(), time.process_time()
    steady = solve_steady(mesh_spec(Plate(), args.preset, 2900), Flow(2900), cache_dir=args.cache)
    t_steady, c_steady = time.perf_counter() - t0, time.process_time() - c0
    t0, c0 = time.perf_counter(), time.process_time()
    fluid = fluid_operators(steady)
    system = CoupledSystem(fluid, Solid(mass_ratio=1000, reduced_velocity=4.7))
    _ = system.jacobian, system.mass
    t_assembly, c_assembly = time.perf_counter() - t0, time.process_time() - c0

    counter = FactorCounter()
    shift = complex(args.shift)
    t0, c0 = time.perf_counter(), time.process_time()
    factor = FluidFactor(fluid, shift, counter, backend=args.backend)
    solver = ShiftedSolver(system, shift, fluid_factor=factor, counter=counter)
    t_factor, c_factor = time.perf_counter() - t0, time.process_time() - c0
    operator = shift_invert_operator(solver)
    matvecs = [0]

    def counted(x):
        matvecs[0] += 1
        return operator.matvec(x)

    t0, c0 = time.perf_counter(), time.process_time()
    mu = spla.eigs(
        spla.LinearOperator(operator.shape, matvec=counted, dtype=complex),
        k=args.nev,
        ncv=max(2 * args.nev + 1, 20),
        tol=1e-10,
        return_eigenvectors=False,
    )
    t_eigs, c_eigs = time.perf_counter() - t0, time.process_time() - c0
    sigma = np.sort_complex(shift - 1 / mu)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"preset                 {args.preset} (solver {args.backend})")
    print(f"unknowns               {system.size}")
    print("stage                  wall [s] / CPU [s]")
    origin = "cache" if steady.from_cache else "computed"
    print(f"steady state           {t_steady:.1f} / {c_steady:.1f} ({origin})")
    print(f"assembly               {t_assembly:.2f} / {c_assembly:.2f}")
    print(f"factorisations         {counter.count}")
    print(f"complex LU             {t_factor:.2f} / {c_factor:.2f}")
    print(
        f"Arnoldi                {t_eigs:.2f} / {c_eigs:.2f} ({matvecs[0]} matvecs, "
        f"{t_eigs / max(matvecs[0], 1):.3f} / {c_eigs / max(matvecs[0], 1):.3f} s each)"
    )
    print(f"peak memory [MB]       {peak:.0f}")
    for s in sigma[np.argsort(-sigma.real)]:
        print(f"EIG {s.real:+.6f} {s.imag:+.6f}")


if __name__ == "__main__":
    main()
