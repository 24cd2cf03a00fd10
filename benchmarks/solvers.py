"""Sparse direct solvers on the plate's fluid Jacobian ``K = J_ff + s M_f`` (docs/performance.md).

Re = 2900, the steady state of the chosen preset (cached), shift ``s`` (``0`` real; ``11.2i``
complex, the wake mode's frequency). Each solver runs in its own process, so that its peak memory
is its own; one thread each. Prints, per solver: factorisation time, the time of one solve (best of
five), the relative residual ``‖Kx − b‖/‖b‖`` of a random right-hand side, peak RSS of the process.

Solvers: ``ngsolve-umfpack`` (``Inverse(inverse="umfpack")`` on the form assembled anew by NGSolve,
UMFPACK's own iterative refinement in every solve), ``umfpack`` (fsistab.umfpack on the SciPy
matrix: plain solve, and with one refinement step; a second factorisation at another shift reusing
the symbolic analysis), ``ngsolve-pardiso`` (needs ``pip install mkl``), ``superlu`` (SciPy).
MUMPS and PETSc are not among them: neither installs from PyPI as a binary wheel that works with
NumPy 2.

Usage: python benchmarks/solvers.py [coarse|medium|fine] [--shift 11.2j] [--solvers ...]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time

SOLVERS = ("ngsolve-umfpack", "umfpack", "ngsolve-pardiso", "superlu")


def run_one(preset: str, shift: complex, solver: str) -> dict:
    import numpy as np
    import scipy.sparse.linalg as spla
    from ngsolve import SetNumThreads

    from fsistab import umfpack
    from fsistab.bodies import Plate
    from fsistab.mesh import mesh_spec
    from fsistab.operators import fluid_operators, shifted_fluid_matrix
    from fsistab.params import Flow
    from fsistab.steady import solve_steady
    from fsistab.store import default_cache_dir

    SetNumThreads(1)
    fluid = fluid_operators(
        solve_steady(mesh_spec(Plate(), preset, 2900), Flow(2900), cache_dir=default_cache_dir())
    )
    value = shift if shift.imag else shift.real
    matrix = (fluid.jff + value * fluid.mff).tocsc()
    rng = np.random.default_rng(0)
    b = rng.standard_normal(fluid.n_fluid) + (1j * rng.standard_normal(fluid.n_fluid) if shift.imag else 0)
    record = {"solver": solver, "unknowns": fluid.n_fluid, "nonzeros": int(matrix.nnz)}

    def timed_solves(solve) -> tuple[float, np.ndarray]:
        times = []
        for _ in range(5):
            t0 = time.perf_counter()
            x = solve(b)
            times.append(time.perf_counter() - t0)
        return min(times), x

    def residual(x) -> float:
        return float(np.linalg.norm(matrix @ x - b) / np.linalg.norm(b))

    if solver.startswith("ngsolve-"):
        t0 = time.perf_counter()
        form, free = shifted_fluid_matrix(fluid, shift)
        record["assembly_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        inverse = form.mat.Inverse(free, inverse=solver.removeprefix("ngsolve-"))
        record["factor_s"] = time.perf_counter() - t0
        rhs, sol, index = form.mat.CreateColVector(), form.mat.CreateColVector(), fluid.free_dofs

        def solve(v):
            rhs.FV().NumPy()[:] = 0
            rhs.FV().NumPy()[index] = v
            sol.data = inverse * rhs
            return sol.FV().NumPy()[index].copy()

        record["solve_s"], x = timed_solves(solve)
        record["residual"] = residual(x)
    elif solver == "umfpack":
        if not umfpack.available():
            return {**record, "error": "NGSolve's library exports no UMFPACK symbols"}
        t0 = time.perf_counter()
        lu = umfpack.LU(matrix)
        record["factor_s"] = time.perf_counter() - t0
        record["solve_s"], x = timed_solves(lambda v: lu.solve(v, refine=False))
        record["residual"] = residual(x)
        record["solve_refined_s"], x = timed_solves(lambda v: lu.solve(v, refine=True))
        record["residual_refined"] = residual(x)
        other = (fluid.jff + (value * 1.01) * fluid.mff).tocsc()
        t0 = time.perf_counter()
        umfpack.LU(other, lu.analysis)
        record["factor_reusing_analysis_s"] = time.perf_counter() - t0
    elif solver == "superlu":
        t0 = time.perf_counter()
        lu = spla.splu(matrix)
        record["factor_s"] = time.perf_counter() - t0
        record["solve_s"], x = timed_solves(lu.solve)
        record["residual"] = residual(x)
    record["peak_rss_gb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
    return record


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("preset", nargs="?", default="medium")
    parser.add_argument("--shift", default="11.2j")
    parser.add_argument("--solvers", nargs="+", default=["ngsolve-umfpack", "umfpack"], choices=SOLVERS)
    parser.add_argument("--one", default=None, help=argparse.SUPPRESS)  # the child process
    args = parser.parse_args()
    shift = complex(args.shift)
    if args.one:
        print(json.dumps(run_one(args.preset, shift, args.one)))
        return
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    for solver in args.solvers:
        command = [sys.executable, __file__, args.preset, "--shift", args.shift, "--one", solver]
        done = subprocess.run(command, capture_output=True, text=True, env=env)
        lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
        if done.returncode or not lines:
            print(f"{solver}: failed ({done.stderr.strip().splitlines()[-1:]})")
            continue
        r = json.loads(lines[-1])
        extra = ""
        if "solve_refined_s" in r:
            extra = (
                f", refined solve {r['solve_refined_s'] * 1e3:.0f} ms (residual {r['residual_refined']:.1e}),"
                f" factorisation reusing the analysis {r['factor_reusing_analysis_s']:.2f} s"
            )
        print(
            f"{solver:16s} {r['unknowns']} unknowns, {r['nonzeros']} nonzeros: factorisation "
            f"{r['factor_s']:.2f} s, solve {r['solve_s'] * 1e3:.0f} ms "
            f"(residual {r['residual']:.1e}){extra}, "
            f"peak RSS {r['peak_rss_gb']:.2f} GB"
        )


if __name__ == "__main__":
    main()
