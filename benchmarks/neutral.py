"""Benchmark of the neutral-map paths: plate, Re = 2900, α0 = 0, m in [1, 1e4].

Both methods on the same mesh in one run (``--method both``, the default):

* **transfer** (``fsistab.transfer_map``): ``G(iω)`` sampled and refined until every neutral curve
  is resolved, whatever the number of (m, U*) points; where the sampling is refined ``G`` comes from
  reduced fluid models (``fsistab.reduced_model``, one factorisation each, ``--reduced-blocks``
  Krylov blocks), elsewhere from exact samples (one factorisation each; ``--reduced-blocks 0``:
  exact samples only);
* **continuation** (``fsistab.neutral``): sweeps in U* at m = 1000, 100, 10 and a VIV sweep at the
  lowest m, every threshold continued by pseudo-arclength in (m, U*).

Prints unknowns, factorisations, wall time and peak memory of each, their ratios, and the largest
relative difference in U* between every continuation point and the transfer map at the same m.
Results are saved in --out (a rerun resumes: delete it for a fresh measurement). With
``--curve-only`` the continuation stops after the flutter curve from m = 1000.

``--workers 0 2`` (transfer only): the same map from empty samples in this process (0) and on a
dask LocalCluster of 2 single-threaded workers, one after the other in this session; for each,
the wall time of the sampling phase (the batches of exact samples) and of the map, the CPU time of
this process and of the workers, the factorisations, the peak memory of this process and of each
worker, and the ratios to the in-process run.
Usage: python benchmarks/neutral.py [coarse|medium|fine] [--method both|transfer|continuation]
"""

import argparse
import resource
import time
from pathlib import Path

from ngsolve import SetNumThreads

from fsistab.bodies import Plate
from fsistab.critical import wake_mode_near
from fsistab.linalg import FactorCounter
from fsistab.mesh import mesh_spec
from fsistab.neutral import map_seeds, trace_neutral_map
from fsistab.operators import fluid_operators
from fsistab.params import Flow, Solid
from fsistab.reduced_model import ReducedModels
from fsistab.steady import solve_steady
from fsistab.transfer_map import nearest_on_map, transfer_neutral_map


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _worker_usage() -> tuple[float, float]:
    """CPU seconds and peak memory [MB] of this (worker) process: VmHWM, since ``ru_maxrss`` keeps
    the peak of the process the worker was forked from."""
    with open("/proc/self/status") as status:
        peak = next(int(line.split()[1]) for line in status if line.startswith("VmHWM")) / 1024
    return _cpu_seconds(), peak


def on_workers(fluid, template, args, out: Path, workers: int, wake: float) -> dict:
    """The exact-sample map from empty samples in this process (``workers`` 0) or on a new
    LocalCluster of ``workers`` single-threaded processes: its figures (module docstring)."""
    import shutil

    from distributed import Client, LocalCluster

    from fsistab.study import _without_malloc_trim

    where = out / f"workers{workers}"
    shutil.rmtree(where, ignore_errors=True)
    cluster = None
    if workers:
        with _without_malloc_trim():  # as `fsistab neutral --workers N` starts them
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, dashboard_address=None)
    client = Client(cluster) if cluster else None
    try:
        before = client.run(_worker_usage) if client else {}
        counter, cpu0, t0 = FactorCounter(), _cpu_seconds(), time.perf_counter()
        tmap = transfer_neutral_map(
            fluid, template, mass_range=(args.mass_low, args.mass_high), wake_frequency=wake,
            tolerance=args.tolerance, samples_path=where / "transfer_samples.nc", counter=counter,
            client=client,
        )  # fmt: skip
        wall, cpu = time.perf_counter() - t0, _cpu_seconds() - cpu0
        after = client.run(_worker_usage) if client else {}
    finally:
        if client:
            client.close()
            cluster.close()
    worker_cpu = sum(after[w][0] - before[w][0] for w in after)
    return {
        "workers": workers,
        "sampling": tmap.sampling_seconds,
        "wall": wall,
        "cpu": cpu,
        "worker_cpu": worker_cpu,
        "factorisations": counter.count,
        "frequencies": len(tmap.frequencies),
        "onsets": [round(u, 6) for u, rate, _ in tmap.crossings_at(1000.0) if rate > 0],
        "peak": _peak_mb(),
        "worker_peaks": sorted(round(a[1]) for a in after.values()),
    }


def print_workers(results: list[dict]) -> None:
    base = results[0]
    for r in results:
        name = f"workers {r['workers']}" if r["workers"] else "in-process"
        ratio = base["sampling"] / r["sampling"]
        print(f"{name}: sampling phase [s]        {r['sampling']:.1f} (ratio {ratio:.2f})")
        print(f"{name}: map wall time [s]         {r['wall']:.1f} (ratio {base['wall'] / r['wall']:.2f})")
        print(f"{name}: CPU [s]                   {r['cpu']:.1f} here + {r['worker_cpu']:.1f} on workers")
        print(f"{name}: factorisations            {r['factorisations']} ({r['frequencies']} frequencies)")
        print(f"{name}: onsets at m = 1000        {r['onsets']}")
        print(f"{name}: peak memory [MB]          {r['peak']:.0f} here, workers {r['worker_peaks']}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("preset", nargs="?", default="medium")
    parser.add_argument("--method", choices=("both", "transfer", "continuation"), default="both")
    parser.add_argument("--cache", default=None)
    parser.add_argument("--out", default="benchmark-neutral")
    parser.add_argument("--far", type=float, default=None, help="far-field element size (chords)")
    parser.add_argument("--mass-low", type=float, default=1.0)
    parser.add_argument("--mass-high", type=float, default=1e4)
    parser.add_argument("--points", type=int, default=24)
    parser.add_argument("--tolerance", type=float, default=None, help="default 3e-3, exact samples 1e-2")
    parser.add_argument("--reduced-blocks", type=int, default=60, help="0: exact samples only")
    parser.add_argument("--reduced-tolerance", type=float, default=1e-7)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument(
        "--no-fit-first", action="store_true", help="exact samples: rational fits only below min_step"
    )
    parser.add_argument("--curve-only", action="store_true", help="continuation: first flutter curve only")
    parser.add_argument("--wake-frequency", type=float, default=11.0, help="guess, refined by Arnoldi")
    parser.add_argument(
        "--workers",
        type=int,
        nargs="+",
        default=None,
        help="exact-sample maps on N dask workers (0: in process)",
    )
    args = parser.parse_args()
    SetNumThreads(args.threads)
    out = Path(args.out) / (args.preset + (f"_far{args.far:g}" if args.far else ""))
    spec = mesh_spec(Plate(), args.preset, 2900, **({"far": args.far} if args.far else {}))
    t0 = time.perf_counter()
    fluid = fluid_operators(solve_steady(spec, Flow(2900), cache_dir=args.cache))
    t_steady = time.perf_counter() - t0
    template = Solid(mass_ratio=1000, reduced_velocity=2.0)
    mass_range = (args.mass_low, args.mass_high)
    wake_counter = FactorCounter()
    t0 = time.perf_counter()
    wake = wake_mode_near(fluid, args.wake_frequency, counter=wake_counter)
    t_wake = time.perf_counter() - t0
    print(f"preset                         {args.preset} (far field {spec.sizes.far:g})")
    print(f"unknowns                       {fluid.n_fluid + 4}")
    print(f"steady state + operators [s]   {t_steady:.1f}")
    print(
        f"wake mode                      {wake.value:.5f}",
        f"({wake_counter.count} factorisations, {t_wake:.1f} s)",
    )
    results = {}
    if args.workers:
        print_workers([on_workers(fluid, template, args, out, n, wake.frequency) for n in args.workers])
        return

    if args.method in ("both", "transfer"):
        samples = out / "transfer_samples.nc"
        if samples.exists() or (out / "reduced_models.nc").exists():
            print(f"note: reusing saved samples and models in {out}: only new factorisations are counted")
        counter = FactorCounter()
        t0 = time.perf_counter()
        reduced = None
        if args.reduced_blocks:
            reduced = ReducedModels(
                fluid,
                tolerance=args.reduced_tolerance,
                blocks=args.reduced_blocks,
                path=out / "reduced_models.nc",
                counter=counter,
            )
        tmap = transfer_neutral_map(
            fluid,
            template,
            mass_range=mass_range,
            wake_frequency=wake.frequency,
            tolerance=args.tolerance,
            samples_path=samples,
            reduced=reduced,
            counter=counter,
            fit_first=not args.no_fit_first,
        )
        elapsed = time.perf_counter() - t0
        results["transfer"] = (counter.count, elapsed)
        turning = [
            t for c in tmap.curves for t in c.turning_points() if mass_range[0] <= t[0] <= mass_range[1]
        ]
        print(
            f"transfer: frequencies          {len(tmap.frequencies)}",
            f"({len(tmap.unresolved)} intervals unresolved)",
        )
        print(f"transfer: curves               {[(c.kind, len(c.roots)) for c in tmap.curves]}")
        print(f"transfer: turning points       {len(turning)}")
        onsets = [round(u, 5) for u, rate, _ in tmap.crossings_at(1000.0) if rate > 0]
        print(f"transfer: onsets at m = 1000   {onsets}")
        # with exact samples: the models at sharp resonances and at s = 0
        models = len(reduced.models) if reduced else tmap.resonance_models
        print(f"transfer: factorisations       {counter.count} ({models} reduced models, rest exact)")
        if reduced:
            print(f"transfer: reduced model sizes  {sorted({m.size for m in reduced.models})}")
        print(f"transfer: wall time [s]        {elapsed:.1f}")
        print(f"transfer: peak memory [MB]     {_peak_mb():.0f}")

    if args.method in ("both", "continuation"):
        attrs = {"reynolds": 2900.0, "mesh_key": spec.key(), "benchmark": 1}
        counter = FactorCounter()
        t0 = time.perf_counter()
        masses = () if args.curve_only else (100.0, 10.0)
        seeds = map_seeds(
            1000.0,
            (2.0, 10.0),
            args.points,
            masses,
            None if args.curve_only else wake.frequency,
            args.mass_low,
        )
        cmap = trace_neutral_map(
            fluid, template, seeds, out, "bench", attrs, mass_range=mass_range, counter=counter
        )
        elapsed = time.perf_counter() - t0
        results["continuation"] = (counter.count, elapsed)
        print(f"continuation: curves           {[(c.kind, len(c.points)) for c in cmap.curves]}")
        print(f"continuation: turning points   {sum(len(c.turning_points) for c in cmap.curves)}")
        print(f"continuation: stops            {[c.stops for c in cmap.curves]}")
        print(f"continuation: factorisations   {counter.count} (+ {wake_counter.count} for the wake mode)")
        print(f"continuation: wall time [s]    {elapsed:.1f}")
        print(f"continuation: peak memory [MB] {_peak_mb():.0f}")

    if len(results) == 2:
        (n_t, t_t), (n_c, t_c) = results["transfer"], results["continuation"]
        print(
            f"ratio continuation/transfer    factorisations {n_c / max(n_t, 1):.2f},",
            f"wall time {t_c / t_t:.2f}",
        )
        worst, compared = 0.0, 0
        for curve in cmap.curves:
            for p in curve.points:
                near = nearest_on_map(tmap, p.mass_ratio, p.reduced_velocity, p.frequency)
                if near is not None:
                    worst = max(worst, abs(near[0] / p.reduced_velocity - 1))
                    compared += 1
        print(f"agreement in U*                {worst:.2e} (largest relative difference, {compared} points)")


if __name__ == "__main__":
    main()
