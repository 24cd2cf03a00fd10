"""Neutral curves of the plate in the (Re, U*) and (α0, U*) planes at fixed m (docs/model.md §8).

Plate, solid defaults of docs/model.md §2 (Ω = 0.8, ζ_h = 0, ζ_θ = 0.05, r_θ = 0.289), m = 1000 by default.
Starting from the flutter onset at Re = 2900, α0 = 0 (Newton on det T(iω; U*) = 0 from a guess near
U*_F ≈ 4.5 (Moulin & Marquet 2021), ω ≈ 0.18), the flutter and divergence thresholds
are continued along decreasing Re and along increasing α0 on one mesh (fitted to Re = 2900) with
``fsistab.critical.critical_points_along_flow``: steady states continued from one flow to the next,
flutter by the exact-transfer Newton, divergence by the static Newton. Writes NetCDF and a figure,
prints markdown tables with factorisations and wall times.

Usage: python validation/plate_flow_sweep.py [--preset coarse] [--mass-ratio 1000] [--out docs]
"""

import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from fsistab.bodies import Plate
from fsistab.critical import critical_points_along_flow  # noqa: E402
from fsistab.errors import ConvergenceError  # noqa: E402
from fsistab.linalg import FactorCounter  # noqa: E402
from fsistab.mesh import mesh_spec  # noqa: E402
from fsistab.params import Flow, Solid  # noqa: E402
from fsistab.plots import save_figure  # noqa: E402
from fsistab.store import default_cache_dir, write_dataset  # noqa: E402

REYNOLDS = [2900.0, 2400.0, 2000.0, 1600.0, 1300.0, 1000.0, 800.0, 650.0, 500.0, 400.0, 300.0]
ALPHA0 = [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0]


def sweep(spec, flows, solid, cache, label):
    """Points continued along ``flows``; a convergence failure keeps what was done."""
    counter, points = FactorCounter(), []
    t0 = time.perf_counter()
    try:
        for point in critical_points_along_flow(spec, flows, solid, 0.18, cache_dir=cache, counter=counter):
            points.append(point)
            print(
                f"| {point[0].reynolds:g} | {point[0].alpha0_deg:g} | {point[0].reduced_velocity:.5f} | "
                f"{point[0].frequency:.5f} | {point[1].reduced_velocity:.5f} | {point[0].factorisations} |",
                flush=True,
            )
    except ConvergenceError as exc:
        print(f"{label}: stopped after {len(points)} points: {exc}")
    return points, counter.count, time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--preset", default="coarse")
    parser.add_argument("--mass-ratio", type=float, default=1000.0)
    parser.add_argument("--out", type=Path, default=Path("docs"))
    parser.add_argument("--cache", type=Path, default=None)
    args = parser.parse_args()
    cache = args.cache or default_cache_dir()
    spec = mesh_spec(Plate(), args.preset, 2900.0)
    solid = Solid(args.mass_ratio, 4.5)
    results = {}
    for name, flows in (
        ("reynolds", [Flow(re) for re in REYNOLDS]),
        ("alpha0", [Flow(2900.0, a) for a in ALPHA0]),
    ):
        print(f"\n{name} sweep, mesh {args.preset}, m = {args.mass_ratio:g}")
        print("| Re | α0 [°] | U*_F | ω_F | U*_D | factorisations |\n|---|---|---|---|---|---|")
        results[name] = sweep(spec, flows, solid, cache, name)
        points, factorisations, seconds = results[name]
        print(f"{len(points)} points, {factorisations} factorisations, {seconds:.0f} s")
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, (name, (points, _, _)) in zip(axes, results.items(), strict=True):
        x = [p[0].reynolds if name == "reynolds" else p[0].alpha0_deg for p in points]
        ax.plot(x, [p[0].reduced_velocity for p in points], "o-", color="tab:red", label="flutter U*_F")
        ax.plot(x, [p[1].reduced_velocity for p in points], "s-", color="k", label="divergence U*_D")
        ax.set_xlabel("Re" if name == "reynolds" else "α0 [deg]")
        ax.set_ylabel("U*")
        if name == "reynolds":
            ax.set_xscale("log")
        ax.grid(alpha=0.3, which="both")
        ax.legend()
    fig.suptitle(f"plate, m = {args.mass_ratio:g}, {args.preset} mesh: unstable above the curves")
    fig.tight_layout()
    figure = save_figure(fig, args.out / "figures" / f"plate_flow_sweep_{args.preset}.png")
    for name, (points, factorisations, seconds) in results.items():
        ds = xr.Dataset(
            {
                "flutter_velocity": ("point", np.array([p[0].reduced_velocity for p in points])),
                "flutter_frequency": ("point", np.array([p[0].frequency for p in points])),
                "divergence_velocity": ("point", np.array([p[1].reduced_velocity for p in points])),
            },
            coords={
                "reynolds": ("point", np.array([p[0].reynolds for p in points])),
                "alpha0_deg": ("point", np.array([p[0].alpha0_deg for p in points])),
            },
            attrs={
                "mass_ratio": args.mass_ratio,
                "mesh": args.preset,
                "factorisations": factorisations,
                "seconds": seconds,
            },
        )
        write_dataset(ds, args.out / "data" / f"plate_flow_sweep_{name}_{args.preset}.nc")
    print(f"figure {figure}")


if __name__ == "__main__":
    main()
