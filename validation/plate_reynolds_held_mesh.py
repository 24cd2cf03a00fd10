"""A Re study of the plate's thresholds at m = 1000 on one held mesh, against the adjoint derivative.

The library code of ``fsistab study --thresholds 1000 --mesh-reynolds 2900`` (:func:`fsistab.study.run_study`)
at ``--reynolds`` (default 2842 2871 2885.5 2900 2914.5 2929 2958: steps of 14.5 and 29 about 2900),
once on the mesh fitted to ``--held`` for every point, once on meshes fitted to each Re (the
default, at 2871, 2900, 2929 only), and the adjoint derivatives ``dU*_c/dRe`` of ``fsistab
sensitivity`` (:func:`fsistab.workflows.sensitivity`) on the held mesh at ``--held``. Prints the
thresholds, their first and second differences, the centred differences against the adjoint
derivative, and the second differences at steps h and h/2 (a smooth threshold has
``Δ²_h ≈ 4 Δ²_{h/2}``), and a quartic in Re through the held points: its largest residual (the
thresholds' scatter about a smooth curve) and its slope at ``--held``. Writes the numbers as JSON in
``{out}/data/plate_reynolds_held_mesh.json`` (the studies' own files under the cache).

Usage: python validation/plate_reynolds_held_mesh.py [--preset coarse] [--held 2900] [--cache DIR]
[--out docs]
"""

import argparse
import json
import time
from pathlib import Path

import numpy as np

from fsistab.bodies import Plate
from fsistab.params import Case, Flow, SweepSettings, solid_for
from fsistab.store import default_cache_dir
from fsistab.study import StudySettings, run_study
from fsistab.workflows import sensitivity

MASS_RATIO = 1000.0
KINDS = ("flutter", "divergence")
STEPS = (14.5, 29.0)  # the steps of the default grid about 2900


def _thresholds(ds) -> dict[str, np.ndarray]:
    """U*_c per kind (coupled-mode flutter, divergence) at each Re of a study dataset."""
    sub = ds.sel(alpha0=0.0, mass_ratio=MASS_RATIO)
    out = {}
    for kind in KINDS:
        values = []
        for re in ds.reynolds.values:
            row = sub.sel(reynolds=re)
            found = [
                float(u)
                for k, u in zip(row.threshold_kind.values, row.threshold_reduced_velocity.values, strict=True)
                if str(k) == kind
            ]
            values.append(found[0] if found else np.nan)
        out[kind] = np.array(values)
    return out


def _second_differences(reynolds, values, centre: float, step: float) -> list[float]:
    """``U(Re + h) - 2 U(Re) + U(Re - h)`` at every Re of the grid ``centre + k step`` whose two
    neighbours are in ``reynolds``."""
    at = dict(zip(np.round(reynolds, 9).tolist(), values, strict=True))
    grid = [re for re in at if abs((re - centre) / step - round((re - centre) / step)) < 1e-9]
    return [
        float(at[round(re + step, 9)] - 2 * at[re] + at[round(re - step, 9)])
        for re in sorted(grid)
        if round(re + step, 9) in at and round(re - step, 9) in at
    ]


def _study(case: Case, reynolds, cache: Path, out: Path) -> dict[str, np.ndarray]:
    settings = StudySettings(reynolds=tuple(reynolds), thresholds=(MASS_RATIO,))
    return _thresholds(run_study(case, settings, cache, out, progress=print))


def main() -> None:
    formatter = argparse.RawDescriptionHelpFormatter
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=formatter)
    parser.add_argument("--preset", default="coarse")
    parser.add_argument("--held", type=float, default=2900.0, help="Re the held mesh is fitted to")
    parser.add_argument(
        "--reynolds", nargs="+", type=float, default=[2842, 2871, 2885.5, 2900, 2914.5, 2929, 2958]
    )
    parser.add_argument("--cache", type=Path, default=None)
    parser.add_argument("--out", type=Path, default=Path("docs"))
    args = parser.parse_args()
    cache = args.cache or default_cache_dir()
    work = cache / "validation" / "plate_reynolds_held_mesh"  # the studies' own files
    reynolds = np.array(sorted(args.reynolds))
    t0 = time.perf_counter()
    held_case = Case(Plate(), Flow(args.held), args.preset, mesh_reynolds=args.held)
    held = _study(held_case, reynolds, cache, work / "held")
    coarse = reynolds[np.isin(reynolds, [args.held - 29, args.held, args.held + 29])]
    fitted = _study(Case(Plate(), Flow(args.held), args.preset), coarse, cache, work / "fitted")
    sweep = SweepSettings(mass_ratio=MASS_RATIO)
    solid = solid_for("plate", MASS_RATIO, sweep.velocity_range[0])
    adjoint = sensitivity(held_case, solid, sweep, cache, work / "sensitivity", progress=print).dataset
    derivative = {
        str(k): float(adjoint.d_reduced_velocity.isel(threshold=i).sel(parameter="reynolds"))
        for i, k in enumerate(adjoint.kind.values)
    }
    centre = int(np.argmin(abs(reynolds - args.held)))
    result = {"reynolds": reynolds.tolist(), "held": args.held, "preset": args.preset, "kinds": {}}
    for kind in KINDS:
        u = held[kind]
        row = {"held": u.tolist(), "fitted": dict(zip(coarse.tolist(), fitted[kind].tolist(), strict=True))}
        row["adjoint"] = derivative.get(kind)
        row["centred"] = {}
        for width in (1, 2):  # neighbours at ±1 and ±2 positions
            if centre - width >= 0 and centre + width < len(u):
                step = reynolds[centre + width] - reynolds[centre - width]
                row["centred"][f"{step / 2:g}"] = float((u[centre + width] - u[centre - width]) / step)
        row["second_differences"] = {f"{h:g}": _second_differences(reynolds, u, args.held, h) for h in STEPS}
        scaled = (reynolds - args.held) / 29.0
        quartic = np.polyfit(scaled, u, 4)
        row["quartic_largest_residual"] = float(abs(u - np.polyval(quartic, scaled)).max())
        row["quartic_slope"] = float(np.polyval(np.polyder(quartic), 0.0) / 29.0)
        row["fitted_second_difference"] = float(np.diff(fitted[kind], 2)[0]) if len(coarse) == 3 else None
        result["kinds"][kind] = row
        print(f"\n{kind}: Re, U*_c held mesh (Re {args.held:g}), fitted mesh")
        for re, value in zip(reynolds, u, strict=True):
            print(f"  {re:8g}  {value:.10f}  {row['fitted'].get(float(re), float('nan')):.10f}")
        for half, value in row["centred"].items():
            error = (value - row["adjoint"]) / row["adjoint"]
            adjoint_value = row["adjoint"]
            print(f"  centred ±{half}: {value:.8e}  adjoint {adjoint_value:.8e}  error {error:+.2e}")
        for h, values in row["second_differences"].items():
            print(f"  second differences at step {h} (held mesh): {np.array(values)}")
        print(f"  second difference (fitted meshes): {row['fitted_second_difference']}")
        print(f"  quartic through the held points: largest residual {row['quartic_largest_residual']:.2e},")
        print(f"  slope at {args.held:g} {row['quartic_slope']:.10e} (adjoint {row['adjoint']:.10e})")
    path = args.out / "data" / "plate_reynolds_held_mesh.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(result, indent=1))
    print(f"\n{time.perf_counter() - t0:.1f} s; written {path}")


if __name__ == "__main__":
    main()
