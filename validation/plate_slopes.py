"""Static slopes of the plate against Re on the mesh presets, and their mesh convergence (docs/validation.md).

Plate of docs/model.md §1 (chord/thickness 20, corner radius e/10), α0 = 0: steady state, fluid
operators and one linear solve per (mesh, Re) (docs/model.md §9, :func:`fsistab.slopes.static_slopes`).
Reported: ``dC_L/dα`` and ``d(-C_M)/dα`` (``α = -θ``, per radian, moment about mid-chord), their
ratio to the thin-airfoil values 2π and π/2, and the relative change from the next coarser mesh,
``(s_fine - s_coarse) / s_fine``.

Each preset's results go to ``OUT/data/plate_slopes_{preset}.nc``, rewritten after every Re, so an
interrupted run keeps what it finished and a rerun skips the Re already there (``--recompute`` to
redo them). The report (markdown table and ``OUT/figures/plate_slopes_vs_re.png``) reads every
preset file present, so presets run in separate processes end up in one table.

Usage: python validation/plate_slopes.py [--presets coarse medium fine] [--Re 10 100 1000 2900 10000]
       python validation/plate_slopes.py --report-only
"""

import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402
from ngsolve import SetNumThreads  # noqa: E402

from fsistab.bodies import Plate  # noqa: E402
from fsistab.mesh import mesh_spec  # noqa: E402
from fsistab.operators import fluid_operators  # noqa: E402
from fsistab.params import Flow  # noqa: E402
from fsistab.plots import save_figure  # noqa: E402
from fsistab.slopes import THIN_AIRFOIL_LIFT_SLOPE, THIN_AIRFOIL_MOMENT_SLOPE, static_slopes  # noqa: E402
from fsistab.steady import solve_steady  # noqa: E402
from fsistab.store import default_cache_dir, read_dataset, write_dataset  # noqa: E402

PRESETS = ("coarse", "medium", "fine")
REYNOLDS = (10.0, 100.0, 1000.0, 2900.0, 10000.0)
VARIABLES = (
    "lift_slope_alpha",
    "moment_slope_alpha",
    "drag_slope_theta",
    "unknowns",
    "wall_size",
    "steady_seconds",
    "steady_from_cache",
    "slope_seconds",
    "run_seconds",
)


def data_path(out: Path, preset: str) -> Path:
    return out / "data" / f"plate_slopes_{preset}.nc"


def load_results(out: Path, preset: str) -> dict[float, dict]:
    """Results already stored for ``preset``: {Re: {variable: value}}."""
    path = data_path(out, preset)
    if not path.exists():
        return {}
    ds = read_dataset(path)
    return {
        float(re): {name: ds[name].values[i].item() for name in VARIABLES if name in ds}
        for i, re in enumerate(ds["reynolds"].values)
    }


def save_results(out: Path, preset: str, results: dict[float, dict]) -> Path:
    values = sorted(results)
    ds = xr.Dataset(
        {name: ("reynolds", np.array([results[re][name] for re in values])) for name in VARIABLES},
        coords={"reynolds": np.array(values)},
        attrs={
            "body": "plate, chord/thickness 20, corner radius 0.1 thickness",
            "mesh": preset,
            "alpha0_deg": 0.0,
            "convention": "dC_L/dalpha and d(-C_M)/dalpha per radian, alpha = -theta, moment about mid-chord",
            "thin_airfoil_lift_slope": THIN_AIRFOIL_LIFT_SLOPE,
            "thin_airfoil_moment_slope": THIN_AIRFOIL_MOMENT_SLOPE,
            "unknowns": "fluid unknowns (free dofs of the P2-P1 space)",
            "steady_seconds": "time of the steady solve when it was computed (also for cached states)",
            "slope_seconds": "operator assembly and the one linear solve of the slopes",
            "run_seconds": "wall time of this (mesh, Re) point in the run that stored it",
        },
    )
    return write_dataset(ds, data_path(out, preset))


def compute(preset: str, reynolds: float, cache: Path, initial=None):
    """Slopes at one (mesh, Re), with the steady state (reusable as an initial guess)."""
    t0 = time.perf_counter()
    spec = mesh_spec(Plate(), preset, reynolds)
    if initial is not None and initial.mesh_spec.key() != spec.key():
        initial = None
    steady = solve_steady(spec, Flow(reynolds), cache_dir=cache, initial=initial)
    t1 = time.perf_counter()
    fluid = fluid_operators(steady)
    slopes = static_slopes(fluid)
    t2 = time.perf_counter()
    row = {
        "lift_slope_alpha": slopes.lift_slope_alpha,
        "moment_slope_alpha": slopes.moment_slope_alpha,
        "drag_slope_theta": slopes.drag,
        "unknowns": fluid.n_fluid,
        "wall_size": spec.sizes.wall,
        "steady_seconds": steady.seconds if steady.from_cache else t1 - t0,
        "steady_from_cache": int(steady.from_cache),
        "slope_seconds": t2 - t1,
        "run_seconds": t2 - t0,
    }
    return row, steady


def relative(fine: float, coarse: float) -> float:
    return (fine - coarse) / fine


def report(out: Path) -> None:
    """Markdown table and figure from every preset file in ``out``."""
    results = {p: r for p in PRESETS if (r := load_results(out, p))}
    if not results:
        print("no results yet")
        return
    print(
        "| Re | mesh | unknowns | dC_L/dα | /2π | Δ vs coarser | d(−C_M)/dα | /(π/2) | Δ vs coarser "
        "| steady [s] | slopes [s] |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for re in sorted({re for r in results.values() for re in r}):
        previous = None
        for preset in PRESETS:
            row = results.get(preset, {}).get(re)
            if row is None:
                continue
            lift, moment = row["lift_slope_alpha"], row["moment_slope_alpha"]
            if previous is None:
                d_lift = d_moment = "—"
            else:
                d_lift = f"{100 * relative(lift, previous['lift_slope_alpha']):+.2f} %"
                d_moment = f"{100 * relative(moment, previous['moment_slope_alpha']):+.2f} %"
            steady = f"{row['steady_seconds']:.0f}" + (" (cache)" if row["steady_from_cache"] else "")
            unknowns = f"{int(row['unknowns']):,}".replace(",", " ")
            print(
                f"| {re:g} | {preset} | {unknowns} | {lift:.4f} | "
                f"{lift / THIN_AIRFOIL_LIFT_SLOPE:.3f} | {d_lift} | {moment:.4f} | "
                f"{moment / THIN_AIRFOIL_MOMENT_SLOPE:.3f} | {d_moment} | {steady} | "
                f"{row['slope_seconds']:.0f} |"
            )
            previous = row
    lift, moment = THIN_AIRFOIL_LIFT_SLOPE, THIN_AIRFOIL_MOMENT_SLOPE
    print(f"| thin airfoil | | | {lift:.4f} | 1 | | {moment:.4f} | 1 | | | |")
    path = plot(results, out / "figures" / "plate_slopes_vs_re.png")
    print(f"figure {path}")


def plot(results: dict[str, dict[float, dict]], path: Path) -> Path:
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    styles = {"coarse": ("o", ":"), "medium": ("s", "--"), "fine": ("^", "-")}
    panels = (
        ("lift_slope_alpha", THIN_AIRFOIL_LIFT_SLOPE, r"$dC_L/d\alpha$", r"$2\pi$"),
        ("moment_slope_alpha", THIN_AIRFOIL_MOMENT_SLOPE, r"$d(-C_M)/d\alpha$", r"$\pi/2$"),
    )
    all_re = sorted({re for r in results.values() for re in r})
    for ax, (name, thin, label, thin_label) in zip(axes, panels, strict=True):
        for preset, rows in results.items():
            re = sorted(rows)
            marker, line = styles[preset]
            ax.plot(re, [rows[r][name] for r in re], marker=marker, ls=line, label=f"{preset} mesh")
        ax.axhline(thin, color="k", lw=0.8, label=f"thin airfoil {thin_label}")
        ax.set_xscale("log")
        ax.set_xlim(min(all_re) / 1.5, max(all_re) * 1.5)
        ax.set_xlabel("Re")
        ax.set_ylabel(f"{label} [1/rad]")
        ax.grid(True, which="both", lw=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(r"plate, chord/thickness 20, $\alpha_0 = 0$: static slopes (moment about mid-chord)")
    return save_figure(fig, path)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--presets", nargs="*", default=list(PRESETS), choices=PRESETS)
    parser.add_argument("--Re", dest="reynolds", type=float, nargs="*", default=list(REYNOLDS))
    parser.add_argument("--recompute", action="store_true", help="redo the Re already stored")
    parser.add_argument("--report-only", action="store_true", help="table and figure from stored files")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--cache", type=Path, default=None)
    parser.add_argument("--out", type=Path, default=Path("docs"))
    args = parser.parse_args()
    if not args.report_only:
        SetNumThreads(args.threads)
        cache = args.cache or default_cache_dir()
        t_start = time.perf_counter()
        for preset in args.presets:
            results = {} if args.recompute else load_results(args.out, preset)
            steady = None
            for re in sorted(args.reynolds):
                if re in results:
                    print(f"{preset} Re {re:g}: stored, skipped", flush=True)
                    continue
                row, steady = compute(preset, re, cache, initial=steady)
                results[re] = row
                save_results(args.out, preset, results)
                print(
                    f"{preset} Re {re:g}: {int(row['unknowns'])} unknowns, "
                    f"dC_L/dα {row['lift_slope_alpha']:.5f}, "
                    f"d(-C_M)/dα {row['moment_slope_alpha']:.5f}; steady {row['steady_seconds']:.0f} s"
                    f"{' (cache)' if row['steady_from_cache'] else ''}, slopes {row['slope_seconds']:.0f} s, "
                    f"point {row['run_seconds']:.0f} s, total {time.perf_counter() - t_start:.0f} s",
                    flush=True,
                )
    report(args.out)


if __name__ == "__main__":
    main()
