"""Where the CPU of ``fsistab neutral`` goes: the command as given (default: the plate at
Re = 2900 on ``quick``, 1 ≤ m ≤ 10⁴), with the CPU time of the threads in each part summed over
the threads that ran it (``time.thread_time``): UMFPACK's numeric factorisations, its solves
(one right-hand side each) and the METIS ordering (as in ``benchmarks/critical.py``), and the
reduced models' orthonormalisation and projections ``VᴴAV`` (:mod:`fsistab.reduced_model`), and
the writes of the samples' and models' files (:class:`fsistab.store.ResumableTable`).
Prints the map's wall and CPU time, peak memory, and the parts; with ``--phases``, also each batch
of exact samples (``MapEngine.prefetch``) and each reduced model: when it ran, its factorisations,
and how many cores the timed parts kept busy meanwhile (docs/performance.md, "Setup around the
factorisations, and idle cores in a map").

The steady state comes from the cache (``FSISTAB_CACHE``); the map is made from empty samples in
``--out`` (deleted first). BLAS runs on one thread unless set otherwise, as in ``fsistab``.
Usage: python benchmarks/map_breakdown.py [--out DIR] [--phases] [-- NEUTRAL OPTIONS ...]
(default options: ``--mesh quick``)
"""

import argparse
import resource
import shutil
import sys
import threading
import time

from critical import _Breakdown

from fsistab import map_engine, reduced_model, store, umfpack
from fsistab.cli import main as fsistab_main

# the timed parts (their threads' CPU counts as busy) and the phases (their wall intervals)
PARTS = {
    "factorisation": (umfpack.LU, "__init__"),
    "solve": (umfpack.LU, "_solve"),
    "orthonormalisation": (reduced_model, "_orthonormal_block"),
    "projection": (reduced_model, "_projected"),
}
PHASES = {"batch": (map_engine.MapEngine, "prefetch"), "model": (reduced_model, "krylov_model")}


class _Intervals:
    """``(name, start, end, thread CPU)`` of every call of the wrapped functions, from ``t0``."""

    def __init__(self, wrapped: dict):
        self.records, self._lock, self.t0 = [], threading.Lock(), time.perf_counter()
        for name, (owner, attribute) in wrapped.items():
            setattr(owner, attribute, self._timed(name, getattr(owner, attribute)))

    def _timed(self, name, function):
        def timed(*args, **kwargs):
            start, cpu = time.perf_counter(), time.thread_time()
            try:
                return function(*args, **kwargs)
            finally:
                end = time.perf_counter()
                with self._lock:
                    self.records.append((name, start - self.t0, end - self.t0, time.thread_time() - cpu))

        return timed


def _report_phases(phases: _Intervals, parts: _Intervals) -> None:
    """Each batch of exact samples and each model (wall); for a batch, the factorisations that ran
    within it (its own and a model's beside it) and the cores the timed parts kept busy."""
    print("phase   start [s]   end [s]   factorisations   cores busy (timed parts)")
    for name, start, end, _ in sorted(phases.records, key=lambda r: r[1]):
        if name == "model":
            print(f"{name:6s} {start:10.1f} {end:9.1f}")
            continue
        inside = [r for r in parts.records if start <= r[1] and r[2] <= end]
        if not inside:
            continue
        busy = sum(r[3] for r in inside) / (end - start)
        factorisations = sum(r[0] == "factorisation" for r in inside)
        print(f"{name:6s} {start:10.1f} {end:9.1f} {factorisations:16d} {busy:12.2f}")


def _cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default="benchmark-map-breakdown")
    parser.add_argument("--phases", action="store_true", help="time each batch and model (wall)")
    parser.add_argument("options", nargs="*", help="options of fsistab neutral (after --)")
    args = parser.parse_args()
    shutil.rmtree(args.out, ignore_errors=True)
    breakdown = _Breakdown()
    for name, label in (
        ("_orthonormal_block", "the models' orthonormalisation"),
        ("_projected", "the models' projections"),
    ):
        setattr(reduced_model, name, breakdown._timed(label, getattr(reduced_model, name)))
    # each write of the samples' and models' files (the whole file, checksummed: fsistab.store)
    store.ResumableTable.save = breakdown._timed("writing the map's files", store.ResumableTable.save)
    if args.phases:
        parts, phases = _Intervals(PARTS), _Intervals(PHASES)
    sys.argv = ["fsistab", "neutral", *(args.options or ["--mesh", "quick"]), "--out", args.out]
    t0, cpu0 = time.perf_counter(), _cpu_seconds()
    try:
        fsistab_main()
    except SystemExit as done:
        if done.code:
            raise
    wall, cpu = time.perf_counter() - t0, _cpu_seconds() - cpu0
    print(f"map wall time [s]   {wall:.1f}")
    print(f"map CPU time [s]    {cpu:.1f} (user + system, every thread)")
    print(f"peak memory [MB]    {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f}")
    breakdown.report()
    if args.phases:
        _report_phases(phases, parts)


if __name__ == "__main__":
    main()
