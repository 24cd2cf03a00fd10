"""Where the CPU of ``fsistab neutral`` goes: the command as given (default: the plate at
Re = 2900 on ``quick``, 1 ≤ m ≤ 10⁴), with the CPU time of the threads in each part summed over
the threads that ran it (``time.thread_time``): UMFPACK's numeric factorisations, its solves
(one right-hand side each) and the METIS ordering (as in ``benchmarks/critical.py``), and the
reduced models' orthonormalisation and projections ``VᴴAV`` (:mod:`fsistab.reduced_model`).
Prints the map's wall and CPU time, peak memory, and the parts.

The steady state comes from the cache (``FSISTAB_CACHE``); the map is made from empty samples in
``--out`` (deleted first). BLAS runs on one thread unless set otherwise, as in ``fsistab``.
Usage: python benchmarks/map_breakdown.py [--out DIR] [-- NEUTRAL OPTIONS ...]
(default options: ``--mesh quick``)
"""

import argparse
import resource
import shutil
import sys
import time

from critical import _Breakdown

from fsistab import reduced_model
from fsistab.cli import main as fsistab_main


def _cpu_seconds() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default="benchmark-map-breakdown")
    parser.add_argument("options", nargs="*", help="options of fsistab neutral (after --)")
    args = parser.parse_args()
    shutil.rmtree(args.out, ignore_errors=True)
    breakdown = _Breakdown()
    for name, label in (
        ("_orthonormal_block", "the models' orthonormalisation"),
        ("_projected", "the models' projections"),
    ):
        setattr(reduced_model, name, breakdown._timed(label, getattr(reduced_model, name)))
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


if __name__ == "__main__":
    main()
