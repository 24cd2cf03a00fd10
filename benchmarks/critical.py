"""Benchmark of the threshold search at one mass ratio (``fsistab critical``): plate, Re = 2900,
α0 = 0, m = 1000, U* in [2, 10].

* **transfer** (the default, ``fsistab.frequency_sweep``): ``G(iω)`` sampled over the frequencies of
  the velocity range (``--threads`` samples factorised at once), each crossing converged by Newton
  on ``det T``, divergence from ``G(0)``;
* **tracking** (``--method tracking``): eigenvalue branches over 24 values of U*, each crossing
  converged by Newton on the augmented sparse system.

Prints the fluid operators' assembly time (wall, CPU; once per command, not in the methods'
times), then per method: unknowns, wall and CPU time, factorisations, samples, peak memory of the
process, the thresholds (to 10 digits), the CPU time of the threads in UMFPACK's numeric
factorisations, its solves and the METIS ordering; with both, their largest relative difference.
The steady state comes from the cache (``FSISTAB_CACHE`` or ``--cache``) or is computed first (not timed).
BLAS runs on one thread unless ``OMP_NUM_THREADS``, ``OPENBLAS_NUM_THREADS`` or ``MKL_NUM_THREADS``
is set, as in the ``fsistab`` command (:func:`fsistab.progress.blas_threads`).
Usage: python benchmarks/critical.py [coarse|quick|fast|medium|fine] [--method both|transfer|tracking]
[--mass-ratio M] [--velocity-range LOW HIGH] [--size NAME=VALUE ...] (a preset's mesh sizes
overridden, e.g. ``--size far=4 --size far_wake=0.1,20,1``, or ``--size far_wake=none``:
:class:`fsistab.mesh.MeshSizes`)
"""

import argparse
import collections
import resource
import threading
import time

import numpy as np

from fsistab import umfpack
from fsistab.bodies import Plate
from fsistab.critical import find_thresholds
from fsistab.linalg import FactorCounter
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators
from fsistab.params import Flow, Solid
from fsistab.progress import blas_threads
from fsistab.steady import solve_steady
from fsistab.store import default_cache_dir


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


class _Breakdown:
    """CPU time of the threads in UMFPACK's numeric factorisations, its solves and the METIS
    ordering (``time.thread_time`` around :class:`fsistab.umfpack.LU`, its solve and
    :func:`fsistab.umfpack.nested_dissection`), summed over the threads that ran them."""

    def __init__(self):
        self.seconds, self.calls, self._lock = (
            collections.defaultdict(float),
            collections.Counter(),
            threading.Lock(),
        )
        umfpack.LU.__init__ = self._timed("numeric factorisations", umfpack.LU.__init__)
        umfpack.LU._solve = self._timed("solves (one right-hand side each)", umfpack.LU._solve)
        umfpack.nested_dissection = self._timed("METIS ordering", umfpack.nested_dissection)

    def _timed(self, name: str, function):
        def timed(*args, **kwargs):
            start = time.thread_time()
            try:
                return function(*args, **kwargs)
            finally:
                with self._lock:
                    self.seconds[name] += time.thread_time() - start
                    self.calls[name] += 1

        return timed

    def report(self) -> None:
        for name, seconds in self.seconds.items():
            print(f"  CPU in {name}: {seconds:.1f} s ({self.calls[name]} calls)")
        self.seconds.clear()
        self.calls.clear()


def _size(text: str) -> tuple[str, float | tuple[float, ...] | None]:
    """``NAME=VALUE``, ``NAME=V1,V2,...`` or ``NAME=none`` (no such box) as a mesh-size override."""
    name, _, value = text.partition("=")
    if value.strip().lower() == "none":
        return name.strip(), None
    values = tuple(float(v) for v in value.split(","))
    return name.strip(), values[0] if len(values) == 1 else values


@blas_threads()  # as the command line: BLAS on one thread beside the two factorisation threads
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("preset", nargs="?", default="medium")
    parser.add_argument("--method", choices=("both", "transfer", "tracking"), default="transfer")
    parser.add_argument("--mass-ratio", type=float, default=1000.0)
    parser.add_argument("--reynolds", type=float, default=2900.0)
    parser.add_argument("--velocity-range", type=float, nargs=2, default=[2.0, 10.0], metavar=("LOW", "HIGH"))
    parser.add_argument("--threads", type=int, default=2, help="samples factorised at once (transfer)")
    parser.add_argument("--cache", default=None)
    parser.add_argument("--size", action="append", type=_size, default=[], help="NAME=VALUE[,VALUE...]")
    args = parser.parse_args()
    spec = mesh_spec(Plate(), args.preset, args.reynolds, **dict(args.size))
    steady = solve_steady(spec, Flow(args.reynolds), cache_dir=args.cache or default_cache_dir())
    wall, cpu = time.perf_counter(), time.process_time()
    fluid = fluid_operators(steady)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    breakdown = _Breakdown()  # from here on: the methods' factorisations only
    solid = Solid(mass_ratio=args.mass_ratio, reduced_velocity=2.0)
    velocities = np.geomspace(*args.velocity_range, 24)
    print(f"preset {args.preset}, Re {args.reynolds:g}, m {args.mass_ratio:g}: {fluid.n_fluid + 4} unknowns")
    print(f"fluid operators (assembly, once per command): wall {wall:.1f} s, CPU {cpu:.1f} s")
    found = {}
    for method in ("transfer", "tracking") if args.method == "both" else (args.method,):
        counter = FactorCounter()
        wall, cpu = time.perf_counter(), time.process_time()
        if method == "transfer":
            from fsistab.frequency_sweep import sweep_thresholds

            result = sweep_thresholds(
                fluid, solid, tuple(args.velocity_range), counter=counter, threads=args.threads
            )
            thresholds = [(t.kind, t.boundary, t.reduced_velocity, t.frequency) for t in result.thresholds]
            extra = f", {len(result.frequencies)} samples, {len(result.unresolved)} unresolved"
        else:
            tracked, _ = find_thresholds(fluid, solid, velocities, counter=counter, method="tracking")
            thresholds = [(t.kind, t.boundary, t.reduced_velocity, t.frequency) for t in tracked]
            extra = ", 24 values of U*"
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        found[method] = thresholds
        print(f"{method}: wall {wall:.1f} s, CPU {cpu:.1f} s, {counter.count} factorisations{extra}")
        for kind, boundary, velocity, frequency in thresholds:
            print(f"  {kind:10s} {boundary:16s} U* = {velocity:.10f}  ω = {frequency:.10f}")
        breakdown.report()
        print(f"  peak memory {_peak_mb():.0f} MB")
    if len(found) == 2 and len(found["transfer"]) == len(found["tracking"]):
        difference = max(
            abs(a[2] - b[2]) / b[2] for a, b in zip(found["transfer"], found["tracking"], strict=True)
        )
        print(f"largest relative difference in U*: {difference:.1e}")


if __name__ == "__main__":
    main()
