"""The C allocator's settings against one ``fsistab`` command (docs/performance.md, "The memory
allocator").

Every factorisation of a large mesh allocates and frees some gigabytes. glibc serves blocks over
32 MB (and, in threads other than the main one, every block a thread's 64 MB heap cannot hold)
with ``mmap`` and returns them at ``free``; the next factorisation faults the same amount in again,
page by page, and the kernel zeroes every page. This benchmark runs one command line in child
processes under three environments of glibc's allocator and prints, per run, the wall time, the
user and system CPU time, the minor page faults and the peak resident memory of the child (from
``wait4``), the factorisations the command reports, and the ratios against the default run of the
same round:

* ``default``: glibc's defaults (every ``MALLOC_*`` variable and ``GLIBC_TUNABLES`` removed);
* ``heap``: one arena, no ``mmap``, no trimming (``MALLOC_ARENA_MAX=1 MALLOC_MMAP_MAX_=0
  MALLOC_TRIM_THRESHOLD_=10^12 MALLOC_TOP_PAD_=256 MiB``): freed memory stays in the process and
  the next factorisation reuses it without faults;
* ``hugepages``: ``GLIBC_TUNABLES=glibc.malloc.hugetlb=1``, glibc's blocks advised for transparent
  huge pages (2 MB faults instead of 4 kB ones; needs ``madvise`` or ``always`` in
  ``/sys/kernel/mm/transparent_hugepage/enabled``).

The rounds alternate the order of the environments, so that a change of the machine's load during
the benchmark falls on each of them. ``OMP_NUM_THREADS`` and its kin are set to 1, as the
``fsistab`` command sets them.

Usage: python benchmarks/allocator.py [--rounds N] [--environments default heap hugepages] --
COMMAND ARGS (an ``fsistab`` command line without ``fsistab``, e.g. ``critical --mass-ratio 1000``)
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import time

ENVIRONMENTS = {
    "default": {},
    "heap": {
        "MALLOC_ARENA_MAX": "1",
        "MALLOC_MMAP_MAX_": "0",
        "MALLOC_TRIM_THRESHOLD_": str(10**12),
        "MALLOC_TOP_PAD_": str(256 << 20),
    },
    "hugepages": {"GLIBC_TUNABLES": "glibc.malloc.hugetlb=1"},
}
THREADS = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def child_environment(name: str) -> dict[str, str]:
    """This process's environment without allocator settings, plus those of ``name``."""
    base = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_") and k != "GLIBC_TUNABLES"}
    return {**base, **THREADS, **ENVIRONMENTS[name]}


def run(command: list[str], name: str) -> dict[str, float | str]:
    """One run of ``fsistab COMMAND`` under environment ``name``: its resource usage and output."""
    start = time.perf_counter()
    process = subprocess.Popen(
        [shutil.which("fsistab") or "fsistab", *command],
        env=child_environment(name),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    output = process.stdout.read()
    _, status, usage = os.wait4(process.pid, 0)
    wall = time.perf_counter() - start
    process.returncode = os.waitstatus_to_exitcode(status)
    if process.returncode:
        sys.exit(f"{name}: fsistab {' '.join(command)} failed:\n{output[-2000:]}")
    found = re.findall(r"(\d+) factorisations", output)  # the command's last count is its total
    return {
        "environment": name,
        "wall": wall,
        "user": usage.ru_utime,
        "system": usage.ru_stime,
        "faults": usage.ru_minflt,
        "peak_gb": usage.ru_maxrss / 1e6,
        "factorisations": found[-1] if found else "?",
    }


def report(row: dict, default: dict) -> str:
    cpu, cpu0 = row["user"] + row["system"], default["user"] + default["system"]
    return (
        f"{row['environment']:10s} wall {row['wall']:7.1f} s  user {row['user']:7.1f} s  "
        f"system {row['system']:6.1f} s  faults {row['faults']:>9d}  peak {row['peak_gb']:5.2f} GB  "
        f"factorisations {row['factorisations']:>3s}  | default/this: "
        f"wall {default['wall'] / row['wall']:.2f}, CPU {cpu0 / cpu:.2f}, "
        f"peak {row['peak_gb'] / default['peak_gb']:.2f}x"
    )


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--rounds", type=int, default=1)
    parser.add_argument("--environments", nargs="+", choices=list(ENVIRONMENTS), default=list(ENVIRONMENTS))
    parser.add_argument("command", nargs=argparse.REMAINDER, help="the fsistab command line (after --)")
    args = parser.parse_args()
    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    if not command:
        parser.error("give the fsistab command line after --, e.g. -- critical --mass-ratio 1000")
    names = ["default"] + [n for n in args.environments if n != "default"]
    print(f"fsistab {' '.join(command)}; {args.rounds} round(s)", flush=True)
    for round_ in range(args.rounds):
        order = names if round_ % 2 == 0 else names[::-1]
        rows = {name: run(command, name) for name in order}
        print(f"round {round_ + 1} (order: {', '.join(order)})")
        for name in names:
            print("  " + report(rows[name], rows["default"]), flush=True)


if __name__ == "__main__":
    main()
