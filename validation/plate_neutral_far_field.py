"""Stability map of the plate at Re = 2900 on a mesh whose far field is refined (docs/model.md §8).

The `coarse` preset has far-field elements of 4 chords; there the truncated domain carries a cloud
of weakly damped modes that hybridise with the solid modes and make the flutter curve zig-zag
below m ≈ 600 (docs/stability_map.md). This script repeats the map with the coarse preset and only
the far-field size changed (``--far``, default 1.0 chord): seed sweep at m = 1000, flutter curve in
m over [1, 1e4], VIV sweep at m = 1 around the wake mode (refined from ``--wake-frequency``).
Writes ``neutral_far{far}_map.nc``, the curves and the figure to ``--out``; prints the curves,
turning points, crossings, factorisations and wall time. Rerunning resumes the saved curves.

Usage: python validation/plate_neutral_far_field.py [--far 1.0] [--out docs/data/neutral_far1]
"""

import argparse
import time
from pathlib import Path

from fsistab.bodies import Plate
from fsistab.critical import wake_mode_near
from fsistab.linalg import FactorCounter
from fsistab.mesh import mesh_spec
from fsistab.neutral import map_seeds, trace_neutral_map
from fsistab.neutral_map import neutral_map_dataset
from fsistab.operators import fluid_operators
from fsistab.params import Flow, Solid
from fsistab.plots import plot_stability_map
from fsistab.steady import solve_steady
from fsistab.store import default_cache_dir, write_dataset


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--far", type=float, default=1.0, help="far-field element size (chords)")
    parser.add_argument("--preset", default="coarse")
    parser.add_argument("--wake-frequency", type=float, default=11.0)
    parser.add_argument("--out", default="docs/data/neutral_far1")
    parser.add_argument("--figure", default="docs/figures/neutral_map_Re2900_coarse_far1.png")
    parser.add_argument("--cache", default=None)
    args = parser.parse_args()
    cache = Path(args.cache) if args.cache else default_cache_dir()
    spec = mesh_spec(Plate(), args.preset, 2900, far=args.far)
    t0 = time.perf_counter()
    fluid = fluid_operators(solve_steady(spec, Flow(2900), cache_dir=cache))
    counter = FactorCounter()
    wake = wake_mode_near(fluid, args.wake_frequency, counter=counter)
    seeds = map_seeds(1000.0, (2.0, 10.0), 24, (), wake.frequency, 1.0)
    tag = f"far{args.far:g}"
    attrs = {"mesh_key": spec.key()}
    result = trace_neutral_map(
        fluid,
        Solid(),
        seeds,
        Path(args.out),
        tag,
        attrs,
        mass_range=(1.0, 1e4),
        counter=counter,
        progress=print,
    )
    write_dataset(
        neutral_map_dataset(result, {**attrs, "wake": str(wake.value)}),
        Path(args.out) / f"neutral_{tag}_map.nc",
    )
    plot_stability_map(
        [
            (c.kind, [p.mass_ratio for p in c.points], [p.reduced_velocity for p in c.points])
            for c in result.curves
        ],
        (result.divergence_mass_ratios, result.divergence_velocities),
        Path(args.figure),
        title=f"plate, Re = 2900, {args.preset} mesh, far-field size {args.far:g} ({fluid.n_fluid} dofs)",
        turning_points=[(t.mass_ratio, t.reduced_velocity) for c in result.curves for t in c.turning_points],
        crossings=[(x.crossing.mass_ratio, x.crossing.reduced_velocity) for x in result.crossings],
    )
    print(f"unknowns {fluid.n_fluid}, wake mode {wake.value:.5f}, moment slope {result.moment_slope:.5f}")
    for i, curve in enumerate(result.curves):
        m = [p.mass_ratio for p in curve.points]
        u = [p.reduced_velocity for p in curve.points]
        folds = [(round(t.mass_ratio, 3), round(t.reduced_velocity, 5)) for t in curve.turning_points]
        print(
            f"curve {i} {curve.kind}: {len(m)} points, m {min(m):.4g}-{max(m):.4g}, "
            f"U* {min(u):.5g}-{max(u):.5g}, stops {curve.stops}, turning points {folds}"
        )
    print(
        "crossings",
        [
            (x.first, x.second, round(x.crossing.mass_ratio, 3), round(x.crossing.reduced_velocity, 5))
            for x in result.crossings
        ],
    )
    print(f"{counter.count} factorisations, {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
