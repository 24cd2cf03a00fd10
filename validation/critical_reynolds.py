"""Critical Reynolds number of the fixed cylinder's wake (REFERENCE.md §A): λ(Re) = 0 by secant.

One mesh fitted at Re = 47 (medium preset, default domain [-50, 100] × [-50, 50]); each iterate
continues the steady state from the previous one (``solve_steady(..., initial=previous)``) and
takes the leading eigenvalue near the previous one (shift-invert Arnoldi). The secant iterations
stop when |λ| < ``--tol`` or the Re step is below 1e-4; ``ω_c`` is interpolated linearly in Re
from the last two iterates. Prints a markdown table of the iterates, writes a NetCDF of them.

Usage: python validation/critical_reynolds.py [--preset medium] [--start 46 48] [--cache DIR]
"""

import argparse
import time
from pathlib import Path

import numpy as np
import xarray as xr
from ngsolve import SetNumThreads

from fsistab.coupled import CoupledSystem
from fsistab.eigen import eigenpairs_near
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators
from fsistab.params import Cylinder, Domain, Flow, Solid
from fsistab.steady import solve_steady
from fsistab.store import default_cache_dir, json_attr, write_dataset

REFERENCE = {"reynolds": (46.6, 46.8), "frequency": (0.733, 0.744)}  # REFERENCE.md §A
FIT_REYNOLDS = 47.0


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--preset", default="medium")
    parser.add_argument("--domain", nargs=3, type=float, default=None, metavar=("UP", "DOWN", "LAT"))
    parser.add_argument("--start", nargs=2, type=float, default=[46.0, 48.0])
    parser.add_argument("--tol", type=float, default=1e-7)
    parser.add_argument("--max-iterations", type=int, default=10)
    parser.add_argument("--cache", type=Path, default=None)
    parser.add_argument("--out", type=Path, default=Path("docs"))
    args = parser.parse_args()
    SetNumThreads(2)
    cache = args.cache or default_cache_dir()
    spec = mesh_spec(Cylinder(), args.preset, FIT_REYNOLDS, Domain(*args.domain) if args.domain else None)
    d = spec.domain
    print(
        f"mesh {args.preset} fitted at Re = {FIT_REYNOLDS:g} (wall {spec.sizes.wall:.4f} D), domain "
        f"[-{d.upstream:g}, {d.downstream:g}] × [-{d.lateral:g}, {d.lateral:g}]",
        flush=True,
    )
    t_start = time.perf_counter()
    iterates: list[tuple[float, complex, float, int]] = []  # (Re, σ, seconds, unknowns)
    previous, guess = None, 0.0 + 0.74j
    reynolds = args.start[0]
    print("| iterate | Re | σ = λ + iω | unknowns | steady [s] | eigen [s] |")
    print("|---|---|---|---|---|---|")
    for k in range(args.max_iterations):
        t0 = time.perf_counter()
        steady = solve_steady(spec, Flow(reynolds), cache_dir=cache, initial=previous)
        t_steady = time.perf_counter() - t0
        t0 = time.perf_counter()
        system = CoupledSystem(fluid_operators(steady), Solid(dofs=()))
        pairs = eigenpairs_near(system, [guess + (0.0013 + 0.0017j)], 3)
        sigma = max((p for p in pairs if p.frequency > 0.3), key=lambda p: p.growth_rate).value
        t_eigen = time.perf_counter() - t0
        iterates.append((reynolds, sigma, t_steady + t_eigen, system.size))
        print(
            f"| {k} | {reynolds:.6f} | {sigma.real:+.3e} + {sigma.imag:.5f}i | {system.size} | "
            f"{t_steady:.0f} | {t_eigen:.0f} |",
            flush=True,
        )
        previous, guess = steady, sigma
        if abs(sigma.real) < args.tol:
            break
        if len(iterates) == 1:
            reynolds = args.start[1]
            continue
        (r0, s0, _, _), (r1, s1, _, _) = iterates[-2], iterates[-1]
        step = -s1.real * (r1 - r0) / (s1.real - s0.real)
        reynolds = r1 + step
        # predict the eigenvalue at the next Re for the shift
        guess = s1 + (s1 - s0) * step / (r1 - r0)
        if abs(step) < 1e-4:
            break

    (r0, s0, _, _), (r1, s1, _, _) = iterates[-2], iterates[-1]
    re_c = r1 - s1.real * (r1 - r0) / (s1.real - s0.real)
    omega_c = s1.imag + (s0.imag - s1.imag) * (re_c - r1) / (r0 - r1)
    total = time.perf_counter() - t_start
    lo, hi = REFERENCE["reynolds"]
    print(
        f"Re_c = {re_c:.4f}, ω_c = {omega_c:.5f} (Strouhal {omega_c / (2 * np.pi):.5f}); reference Re_c "
        f"{lo}-{hi}, ω_c {REFERENCE['frequency'][0]}-{REFERENCE['frequency'][1]}; {len(iterates)} iterates, "
        f"{total:.0f} s",
        flush=True,
    )
    ds = xr.Dataset(
        {
            "growth_rate": ("iterate", np.array([s.real for _, s, _, _ in iterates])),
            "frequency": ("iterate", np.array([s.imag for _, s, _, _ in iterates])),
            "seconds": ("iterate", np.array([t for _, _, t, _ in iterates])),
        },
        coords={"iterate": np.arange(len(iterates)), "reynolds": ("iterate", [r for r, _, _, _ in iterates])},
        attrs={
            "case": "fixed cylinder, critical Reynolds number of the wake (REFERENCE.md §A)",
            "critical_reynolds": re_c,
            "critical_frequency": omega_c,
            "ndof": iterates[-1][3],
            "mesh": json_attr(spec.describe()),
            "total_seconds": total,
        },
    )
    write_dataset(ds, args.out / "data" / "critical_reynolds.nc")


if __name__ == "__main__":
    main()
