"""The stability map from the transfer function against the continuation map on the same mesh
(plate, Re = 2900, α0 = 0, m in [1, 1e4]; docs/model.md §7-§8).

Computes the map with `fsistab.transfer_map.transfer_neutral_map` (samples of G(iω) saved in --out,
so a rerun factorises nothing), then

1. compares every point of the continuation map (`--continuation`, a `neutral_*_map.nc` of
   `fsistab neutral` or `validation/plate_neutral_far_field.py` on the same mesh) with the transfer
   map at the same m: largest relative difference in U*, and a table at chosen mass ratios;
2. checks the number of unstable modes that the crossings give against the full eigen-solver
   (shift-invert Arnoldi at the solid and wake frequencies) at points of every region;
3. draws the map with the exact unstable regions and the continuation points.

Usage: python validation/plate_transfer_map.py [--far 1.0] \
    --continuation docs/data/neutral_far1/neutral_far1_map.nc
"""

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np
import xarray as xr

from fsistab.bodies import Plate
from fsistab.coupled import CoupledSystem
from fsistab.critical import wake_mode_near
from fsistab.eigen import eigenpairs_near
from fsistab.errors import ConvergenceError
from fsistab.linalg import FactorCounter
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators
from fsistab.params import Flow, Solid
from fsistab.plots import plot_stability_map
from fsistab.reduced_model import ReducedModels
from fsistab.steady import solve_steady
from fsistab.store import default_cache_dir, read_dataset, write_dataset
from fsistab.transfer_map import (
    as_neutral_map,
    nearest_on_map,
    transfer_neutral_map,
    unstable_counts,
    unstable_grid,
)


def eigen_count(fluid, mass_ratio: float, velocity: float, wake_frequency: float, reduced=None) -> int:
    """Unstable eigenvalues (ω ≥ 0) near the solid frequencies Ω/U*, 1/U*, the wake mode and 0,
    and near every unstable eigenvalue of the reduced models, certified or not (strongly unstable
    modes far from the axis, which the other shifts miss among the weakly damped fluid modes)."""
    solid = Solid(mass_ratio=mass_ratio, reduced_velocity=velocity)
    system = CoupledSystem(fluid, solid)
    shifts = [0.02, 0.01 + 0.8j / velocity, 0.01 + 1j / velocity, 0.01 + 1j * wake_frequency, 0.01 + 0.5j]
    if reduced is not None:
        shifts += [complex(v) for v in reduced.unstable_eigenvalues(solid, tolerance=1e-2)]
    values = set()
    for shift in shifts:
        try:
            pairs = eigenpairs_near(system, [shift], 6)
        except ConvergenceError:
            continue
        values |= {(round(p.value.real, 7), round(p.value.imag, 7)) for p in pairs if p.growth_rate > 1e-7}
    return len(values)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--far", type=float, default=None, help="far-field element size (chords)")
    parser.add_argument("--preset", default="coarse")
    parser.add_argument("--continuation", required=True, help="neutral_*_map.nc of the same mesh")
    parser.add_argument("--out", default="docs/data/transfer_map_coarse")
    parser.add_argument("--figure", default="docs/figures/transfer_map_Re2900_coarse.png")
    parser.add_argument("--tolerance", type=float, default=None, help="default 3e-3, exact samples 1e-2")
    parser.add_argument("--cache", default=None)
    parser.add_argument("--max-frequencies", type=int, default=None, help="default 400, reduced 4000")
    parser.add_argument(
        "--reduced-blocks",
        type=int,
        default=60,
        help="Krylov blocks of the reduced models (0: exact samples only)",
    )
    parser.add_argument("--reduced-tolerance", type=float, default=1e-7)
    parser.add_argument(
        "--count-masses",
        type=float,
        nargs="*",
        default=[3.0, 10.0, 40.0, 300.0, 1000.0],
        help="m of the unstable-count checks by the eigen-solver (none: skip)",
    )
    args = parser.parse_args()
    cache = Path(args.cache) if args.cache else default_cache_dir()
    spec = mesh_spec(Plate(), args.preset, 2900, **({"far": args.far} if args.far else {}))
    fluid = fluid_operators(solve_steady(spec, Flow(2900), cache_dir=cache))
    continuation = read_dataset(Path(args.continuation), expect={"mesh_key": spec.key()})
    counter = FactorCounter()
    wake = wake_mode_near(fluid, 11.0, counter=counter)
    t0 = time.perf_counter()
    reduced = None
    if args.reduced_blocks:
        reduced = ReducedModels(
            fluid,
            tolerance=args.reduced_tolerance,
            blocks=args.reduced_blocks,
            path=Path(args.out) / "reduced_models.nc",
            counter=counter,
            progress=print,
        )
    tmap = transfer_neutral_map(
        fluid,
        Solid(),
        wake_frequency=wake.frequency,
        tolerance=args.tolerance,
        max_samples=args.max_frequencies,
        samples_path=Path(args.out) / "transfer_samples.nc",
        reduced=reduced,
        counter=counter,
        progress=print,
    )
    elapsed = time.perf_counter() - t0
    result = as_neutral_map(tmap, Solid())

    # 1. every continuation point against the transfer map at its m
    rows = []
    for k, m, u, w in zip(
        continuation.curve.values,
        continuation.curve_mass_ratio.values,
        continuation.curve_reduced_velocity.values,
        continuation.curve_frequency.values,
        strict=True,
    ):
        near = nearest_on_map(tmap, float(m), float(u), float(w))
        rows.append((int(k), float(m), float(u), float(w), *(near or (math.nan, math.nan))))
    rows = np.array(rows)
    difference = np.abs(rows[:, 4] / rows[:, 2] - 1)
    print(
        f"{len(rows)} continuation points; largest |ΔU*|/U* = {np.nanmax(difference):.2e}, median "
        f"{np.nanmedian(difference):.1e}; {np.isnan(difference).sum()} without a transfer curve at their m"
    )
    table = []
    for target in (1.0, 3.0, 100.0, 240.0, 560.0, 1000.0, 3000.0, 1e4):
        k = int(np.argmin(np.abs(np.log(rows[:, 1] / target))))
        table.append(
            {
                "curve": int(rows[k, 0]),
                "kind": str(continuation.curve_kind.values[int(rows[k, 0])]),
                "mass_ratio": rows[k, 1],
                "continuation_U": rows[k, 2],
                "transfer_U": rows[k, 4],
                "continuation_omega": rows[k, 3],
                "transfer_omega": rows[k, 5],
                "relative_difference": difference[k],
            }
        )
        print(json.dumps(table[-1]))

    # 2. unstable counts against the eigen-solver, at points of each region
    checks = []
    for m in args.count_masses:
        crossings = [u for u, _, _ in tmap.crossings_at(m)]
        edges = np.array([min(crossings + [1.0]) / 1.3, *crossings, max(crossings + [1.0]) * 1.3])
        probes = np.sqrt(edges[:-1] * edges[1:])  # one U* inside every interval between crossings
        probes = probes[probes <= 30.0]  # beyond U*_D the static mode dominates; keep Arnoldi cheap
        counts = unstable_counts(tmap, m, probes)
        for u, c in zip(probes, counts, strict=True):
            found = eigen_count(fluid, m, float(u), wake.frequency, reduced)
            solid = Solid(mass_ratio=m, reduced_velocity=float(u))
            certified = len(reduced.unstable_eigenvalues(solid)) if reduced else -1
            checks.append((m, float(u), int(c), found, certified))
            print(
                f"m = {m:g}, U* = {u:.5g}: crossings give {c} unstable, eigen-solver {found}, "
                f"reduced models {certified if reduced else '-'} (certified, covered frequencies only)"
            )
    agree = sum(c == f for _, _, c, f, _ in checks)
    print(f"unstable counts: {agree}/{len(checks)} agree with the eigen-solver")
    if reduced:
        agree = sum(c == r for _, _, c, _, r in checks)
        print(f"unstable counts: {agree}/{len(checks)} agree with the reduced models' eigenvalues")

    masses = np.geomspace(1, 1e4, 160)
    velocities = np.geomspace(0.03, 100, 240)
    counts, incomplete = unstable_grid(tmap, masses, velocities)
    for kind, flags in incomplete.items():
        if flags.any():
            print(
                f"{kind}: a curve is missing (count below zero) for m in {masses[flags].min():.3g}-"
                f"{masses[flags].max():.3g} ({flags.sum()} of {len(masses)} columns); left out of the shading"
            )
    out = Path(args.out)
    write_dataset(
        xr.Dataset(
            {
                "unstable_modes": (("reduced_velocity", "mass_ratio"), counts),
                "continuation_mass_ratio": ("point", rows[:, 1]),
                "continuation_reduced_velocity": ("point", rows[:, 2]),
                "transfer_reduced_velocity": ("point", rows[:, 4]),
            },
            coords={"mass_ratio": masses, "reduced_velocity": velocities},
            attrs={
                "mesh_key": spec.key(),
                "ndof_fluid": fluid.n_fluid,
                "frequencies": len(tmap.frequencies),
                "factorisations": tmap.factorisations,
                "reduced_models": len(reduced.models) if reduced else 0,
                "wall_time_s": elapsed,
                "largest_relative_difference": float(np.nanmax(difference)),
                "count_checks": json.dumps(checks),
            },
        ),
        out / "transfer_vs_continuation.nc",
    )
    plot_stability_map(
        [
            (c.kind, [p.mass_ratio for p in c.points], [p.reduced_velocity for p in c.points])
            for c in result.curves
        ],
        (result.divergence_mass_ratios, result.divergence_velocities),
        Path(args.figure),
        title=f"plate, Re = 2900, {args.preset}{f' far {args.far:g}' if args.far else ''} "
        f"({fluid.n_fluid} dofs): transfer map from {len(tmap.frequencies)} frequencies",
        turning_points=[(t.mass_ratio, t.reduced_velocity) for c in result.curves for t in c.turning_points],
        unstable=(masses, velocities, counts),
        reference=list(zip(rows[:, 1], rows[:, 2], strict=True)),
    )
    turning = [
        (round(t.mass_ratio, 2), round(t.reduced_velocity, 4))
        for c in result.curves
        for t in c.turning_points
    ]
    print(
        f"unknowns {fluid.n_fluid}, frequencies {len(tmap.frequencies)}, "
        f"factorisations {tmap.factorisations} ({len(reduced.models) if reduced else 0} reduced models, "
        f"+{counter.count - tmap.factorisations} wake mode), "
        f"{elapsed:.0f} s; unresolved {len(tmap.unresolved)}"
    )
    print(f"curves {[(c.kind, len(c.points)) for c in result.curves]}")
    print(f"turning points {turning}")
    print(f"U*_D = {math.sqrt(Solid().r_theta ** 2 / result.moment_slope):.5f} √m")


if __name__ == "__main__":
    main()
