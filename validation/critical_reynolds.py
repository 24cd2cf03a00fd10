"""Critical Reynolds number of the fixed cylinder's wake: λ(Re) = 0 by secant.

Published values (docs/validation.md, "Critical Reynolds number of the wake"): Re_c ≈ 46.6–46.8,
ω_c ≈ 0.733–0.744 (Sipp & Lebedev 2007; Giannetti & Luchini 2007; StabFem, Fabre et al.).

A thin driver of :func:`fsistab.onset.critical_onset` (the library code of ``fsistab onset``):
one mesh fitted at Re = ``--fit`` (default 47; medium preset, default domain [-50, 100] × [-50, 50]);
each iterate continues the steady state from the previous one and follows the leading eigenvalue
(shift-invert Arnoldi near the predicted one). The secant starts from the two values of ``--start``
and stops when |λ| < ``--tol`` or the next Re step is below 1e-6 Re; ``ω_c`` is interpolated
linearly in Re between the last two iterates. Prints a markdown table of the iterates, writes them
as NetCDF (``{out}/data/critical_reynolds.nc``).

``fsistab onset --body cylinder --mesh medium --guess 47`` computes the same critical point (the
mesh fitted to the guess) from the starts 47 and 47.94.

Usage: python validation/critical_reynolds.py [--preset medium] [--start 46 48] [--cache DIR] [--out docs]
"""

import argparse
import time
from pathlib import Path

import numpy as np
from ngsolve import SetNumThreads

from fsistab.bodies import Cylinder
from fsistab.mesh import mesh_spec
from fsistab.onset import critical_onset, onset_dataset
from fsistab.params import Domain, Flow
from fsistab.store import default_cache_dir, json_attr, write_dataset

REFERENCE = {"reynolds": (46.6, 46.8), "frequency": (0.733, 0.744)}  # the published range above


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--preset", default="medium")
    parser.add_argument("--fit", type=float, default=47.0, help="Re the mesh is fitted to")
    parser.add_argument("--domain", nargs=3, type=float, default=None, metavar=("UP", "DOWN", "LAT"))
    parser.add_argument("--start", nargs=2, type=float, default=[46.0, 48.0])
    parser.add_argument("--shift", type=complex, default=0.74j, help="guess of the wake mode's eigenvalue")
    parser.add_argument("--tol", type=float, default=1e-7)
    parser.add_argument("--max-iterations", type=int, default=10)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--cache", type=Path, default=None)
    parser.add_argument("--out", type=Path, default=Path("docs"))
    args = parser.parse_args()
    SetNumThreads(args.threads)
    cache = args.cache or default_cache_dir()
    spec = mesh_spec(Cylinder(), args.preset, args.fit, Domain(*args.domain) if args.domain else None)
    d = spec.domain
    print(
        f"mesh {args.preset} fitted at Re = {args.fit:g} (wall {spec.sizes.wall:.4f} D), domain "
        f"[-{d.upstream:g}, {d.downstream:g}] × [-{d.lateral:g}, {d.lateral:g}]",
        flush=True,
    )
    t_start = time.perf_counter()
    first, second = args.start
    result = critical_onset(
        spec,
        Flow(first),
        "reynolds",
        first,
        args.shift,
        step=second - first,
        tol=args.tol,
        max_iterations=args.max_iterations,
        cache_dir=cache,
    )
    total = time.perf_counter() - t_start
    print("| iterate | Re | σ = λ + iω | unknowns | steady [s] | eigen [s] |")
    print("|---|---|---|---|---|---|")
    for k, it in enumerate(result.iterates):
        print(
            f"| {k} | {it.value:.6f} | {it.growth_rate:+.3e} + {it.frequency:.5f}i | {it.unknowns} | "
            f"{it.steady_seconds:.0f} | {it.eigen_seconds:.0f} |"
        )
    lo, hi = REFERENCE["reynolds"]
    print(
        f"Re_c = {result.critical_value:.4f}, ω_c = {result.frequency:.5f} (Strouhal "
        f"{result.frequency / (2 * np.pi):.5f}); reference Re_c {lo}-{hi}, ω_c "
        f"{REFERENCE['frequency'][0]}-{REFERENCE['frequency'][1]}; {result.iterations} iterates, "
        f"{result.factorisations} factorisations, {total:.0f} s",
        flush=True,
    )
    ds = onset_dataset(
        result,
        {
            "case": "fixed cylinder, critical Reynolds number of the wake (docs/validation.md)",
            "critical_reynolds": result.critical_value,
            "critical_frequency": result.frequency,
            "ndof": result.iterates[-1].unknowns,
            "mesh": json_attr(spec.describe()),
            "total_seconds": total,
        },
    )
    write_dataset(ds, args.out / "data" / "critical_reynolds.nc")


if __name__ == "__main__":
    main()
