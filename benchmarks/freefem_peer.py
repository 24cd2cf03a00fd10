"""The peer comparison: fsistab against FreeFEM on the identical mesh (docs/performance.md).

Fixed plate, Re = 2900, the preset's mesh (default ``medium``) with straight-sided wall elements
(``curve_order = 1``, as FreeFEM's triangles: the curved wall alone changes the wake mode's growth
rate more than the solvers differ). Both sides start from rest and compute the steady state, then the
10 eigenvalues nearest ``11.2i`` (shift-invert Arnoldi, tolerance 1e-9 in FreeFEM, 1e-10 here),
one thread each, with no outlet sponge on our side (FreeFEM's script has none):

* FreeFEM: ``../shared/bench/freefem_samemesh.edp`` (UMFPACK, Newton with a geometric Re ramp
  ``--ramp-start`` → 2900 in ``--ramp-steps`` steps) on the mesh converted by
  ``../shared/bench/ngs2ff.py``; needs ``FreeFem++`` (Debian package ``freefem++``);
* fsistab: :func:`fsistab.steady.solve_steady` (its own Re continuation from 40) and
  :func:`fsistab.eigen.eigenpairs_near`, in a fresh cache holding only the mesh.

Prints, for each, wall and CPU time of the whole run, factorisations where known, peak memory, the
leading eigenvalue, and the wall-time ratio FreeFEM / fsistab; the leading eigenvalues must agree
to 6 digits (same problem, same mesh).

Usage: python benchmarks/freefem_peer.py [coarse|medium|fine] [--nev 10]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SHARED = Path(__file__).resolve().parents[2] / "shared" / "bench"
REYNOLDS, SHIFT = 2900.0, 11.2


def ours(preset: str, nev: int, cache: str) -> dict:
    """fsistab's run (in a child process, so that its peak memory is its own)."""
    from fsistab.bodies import Plate
    from fsistab.coupled import CoupledSystem
    from fsistab.eigen import eigenpairs_near
    from fsistab.linalg import FactorCounter
    from fsistab.mesh import mesh_spec
    from fsistab.operators import fluid_operators
    from fsistab.params import Flow, Solid
    from fsistab.steady import solve_steady

    wall0, cpu0 = time.perf_counter(), time.process_time()
    steady = solve_steady(
        mesh_spec(Plate(), preset, REYNOLDS, sponge=None, curve_order=1), Flow(REYNOLDS), cache_dir=cache
    )
    t_steady = time.perf_counter() - wall0
    counter = FactorCounter()
    pairs = eigenpairs_near(
        CoupledSystem(fluid_operators(steady), Solid(dofs=())), [SHIFT * 1j], nev, counter=counter
    )
    values = sorted((p.value for p in pairs), key=lambda z: -z.real)
    return {
        "unknowns": steady.ndof,
        "steady_s": t_steady,
        "wall_s": time.perf_counter() - wall0,
        "cpu_s": time.process_time() - cpu0,
        "factorisations": steady.factorisations + counter.count,
        "eigenvalues": [[z.real, z.imag] for z in values],
        "peak_rss_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6,
    }


def freefem(mesh_vol: Path, work: Path, nev: int, ramp_start: float, ramp_steps: int) -> dict:
    labels = json.loads(
        subprocess.run(
            [sys.executable, str(SHARED / "ngs2ff.py"), str(mesh_vol), str(work / "mesh.msh")],
            capture_output=True, text=True, check=True,
        ).stdout.strip().splitlines()[-1]
    )  # fmt: skip
    command = ["FreeFem++", "-nw", str(SHARED / "freefem_samemesh.edp"), "-mesh", str(work / "mesh.msh")]
    command += ["-Re", str(REYNOLDS), "-shifti", str(SHIFT), "-nev", str(nev), "-Re0", str(ramp_start)]
    command += ["-steps", str(ramp_steps), "-inlet", str(labels["inlet"]), "-lateral", str(labels["lateral"])]
    command += ["-body", str(labels["wall"])]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    log = done.stdout + done.stderr
    eigenvalues = [[float(a), float(b)] for a, b in re.findall(r"^EIG (\S+) (\S+)$", log, re.M)]
    newton = re.search(r"TIME newton_total (\S+) iterations (\d+)", log)
    if done.returncode or not eigenvalues or newton is None:
        # e.g. FreeFEM's 32-bit UMFPACK out of memory on a large complex factorisation: report how
        # far it got and still time our side
        errors = sorted({line.strip() for line in log.splitlines() if "rror" in line})
        print(f"FreeFEM failed (exit {done.returncode}) after {wall:.1f} s: {'; '.join(errors)[:600]}")
        if newton:
            seconds, iterations = float(newton.group(1)), newton.group(2)
            print(f"FreeFEM's steady Newton had finished: {seconds:.1f} s, {iterations} iterations")
        return None
    return {
        "unknowns": int(re.search(r"^ndof (\d+)", log, re.M).group(1)),
        "wall_s": wall,
        "cpu_s": (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime),
        "newton_s": float(newton.group(1)),
        "factorisations": int(newton.group(2)) + 1,
        "eigenvalues": sorted(eigenvalues, key=lambda z: -z[0]),
        "peak_rss_gb": after.ru_maxrss / 1e6,
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("preset", nargs="?", default="medium")
    parser.add_argument("--nev", type=int, default=10)
    parser.add_argument("--ramp-start", type=float, default=100.0)
    parser.add_argument("--ramp-steps", type=int, default=5)
    parser.add_argument("--ours", default=None, help=argparse.SUPPRESS)  # the child process: its cache
    args = parser.parse_args()
    if args.ours:
        print(json.dumps(ours(args.preset, args.nev, args.ours)))
        return
    from fsistab.bodies import Plate
    from fsistab.mesh import build_mesh, mesh_path, mesh_spec

    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    with tempfile.TemporaryDirectory() as scratch:
        work = Path(scratch)
        spec = mesh_spec(Plate(), args.preset, REYNOLDS, curve_order=1)
        build_mesh(spec, work / "cache")  # the only entry of our fresh cache: the run starts from rest
        mesh_vol = work / "mesh.vol"
        subprocess.run(["sh", "-c", f"zcat '{mesh_path(spec, work / 'cache')}' > '{mesh_vol}'"], check=True)
        peer = freefem(mesh_vol, work, args.nev, args.ramp_start, args.ramp_steps)
        command = [
            sys.executable,
            __file__,
            args.preset,
            "--nev",
            str(args.nev),
            "--ours",
            str(work / "cache"),
        ]
        t0 = time.perf_counter()
        child = subprocess.run(command, capture_output=True, text=True, env=env)
        wall = time.perf_counter() - t0
        if child.returncode:
            raise SystemExit(f"fsistab failed:\n{child.stderr[-2000:]}")
        us = json.loads(child.stdout.strip().splitlines()[-1])
    for name, r in (("FreeFEM", peer), ("fsistab", us)):
        if r is None:
            continue
        leading = complex(*r["eigenvalues"][0])
        print(
            f"{name:8s} {r['unknowns']} unknowns: wall {r['wall_s']:.1f} s, CPU {r['cpu_s']:.1f} s, "
            f"{r['factorisations']} factorisations, peak RSS {r['peak_rss_gb']:.2f} GB, "
            f"leading eigenvalue {leading.real:+.6f} {leading.imag:+.6f}i"
        )
    print(f"fsistab process wall time including start-up: {wall:.1f} s (steady state {us['steady_s']:.1f} s)")
    if peer is None:
        return
    theirs = [complex(*z) for z in peer["eigenvalues"]]
    mine = [complex(*z) for z in us["eigenvalues"]]
    print("eigenvalues (FreeFEM | nearest of fsistab | relative difference):")
    for a in theirs:
        b = min(mine, key=lambda z: abs(z - a))
        print(f"  {a.real:+.6f} {a.imag:+.6f}i | {b.real:+.6f} {b.imag:+.6f}i | {abs(a - b) / abs(a):.1e}")
    wall_ratio, cpu_ratio = peer["wall_s"] / us["wall_s"], peer["cpu_s"] / us["cpu_s"]
    print(f"ratio FreeFEM / fsistab: wall {wall_ratio:.2f}, CPU {cpu_ratio:.2f}")


if __name__ == "__main__":
    main()
