"""Reynolds-number study of the plate at α0 = 0: steady coefficients, static slopes, classified thresholds.

Shows, against Re, the steady drag and recirculation length with the static slopes dC_L/dα and
d(-C_M)/dα (docs/model.md §9), and every threshold along U* in [2, 10] at m = 1000 (``--thresholds``
and ``--reduced-velocity-range`` for others), classified
(coupled-mode, pitch or heave single-mode flutter, divergence, VIV; docs/how-to/studies.md), and
with ``--map`` the (m, U*) maps of every Re overlaid. Each Re is one point of
``fsistab.study.run_study``, saved in ``OUT/points/`` as it finishes: a rerun computes only what is
missing, and ``--workers N`` runs the points on a local dask cluster.

Command-line equivalent::

    fsistab study --Re 100 300 1000 2900 --slopes --thresholds 1000 --mesh coarse

(add ``--map`` for the maps, ``--workers 2`` for two worker processes).

Mesh: ``--mesh`` preset (default coarse; one mesh per Re, fitted to it). Reference (Moulin & Marquet 2021): at
Re = 2900 flutter sets in at U*_F ≈ 4.5 and divergence at U*_D ≈ 7.4 (m = 1000); the
thin-airfoil limits of the slopes are dC_L/dα = 2π and d(-C_M)/dα = π/2 about mid-chord
(Moulin & Marquet 2021); the reference gives no values at other Re.

The gallery's default-mesh study::

    python examples/plot_reynolds_study.py --mesh medium --Re 10 110 500 2900 --thresholds 100 1000
        --reduced-velocity-range 1 16

Usage: python examples/plot_reynolds_study.py [--mesh coarse] [--out DIR] [--Re 100 300 1000 2900]
       [--thresholds 1000] [--reduced-velocity-range 2 10] [--map] [--workers N]
"""

import argparse
from pathlib import Path


def parse_args(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--mesh", default="coarse", choices=("coarse", "medium", "fine"), help="mesh preset")
    parser.add_argument(
        "--out", type=Path, default=Path("gallery-out"), help="directory for figures and data"
    )
    parser.add_argument("--cache", type=Path, default=None, help="cache (default $FSISTAB_CACHE)")
    parser.add_argument("--format", default="png", choices=("png", "pdf", "svg"), help="figure format")
    parser.add_argument(
        "--Re", dest="reynolds", type=float, nargs="+", default=[100.0, 300.0, 1000.0, 2900.0]
    )
    parser.add_argument("--thresholds", type=float, nargs="+", default=[1000.0], help="mass ratios")
    parser.add_argument(
        "--reduced-velocity-range", type=float, nargs=2, default=[2.0, 10.0], help="U* range of the sweeps"
    )
    parser.add_argument("--map", action="store_true", help="also the whole (m, U*) map at each Re (slow)")
    parser.add_argument("--workers", type=int, default=None, help="dask LocalCluster of N worker processes")
    return parser.parse_args(argv)


def run(args: argparse.Namespace) -> None:
    from fsistab.params import Case
    from fsistab.plots import plot_study_maps, plot_study_thresholds
    from fsistab.store import default_cache_dir
    from fsistab.study import StudySettings, run_study, study_client

    settings = StudySettings(
        reynolds=tuple(args.reynolds),
        slopes=True,
        thresholds=tuple(args.thresholds),
        velocity_range=tuple(args.reduced_velocity_range),
        map=args.map,
    )
    base = Case.create("plate", settings.reynolds[0], 0.0, args.mesh)
    with study_client(workers=args.workers) as client:
        ds = run_study(
            base, settings, args.cache or default_cache_dir(), args.out, client=client, progress=print
        )
    for re in ds.reynolds.values:
        point = ds.sel(reynolds=re, alpha0=0.0)
        print(
            f"Re = {re:g}: {point.status.item()}, C_D = {point.drag_coefficient.item():.4f}, "
            f"dC_L/dα = {point.lift_slope_alpha.item():.3f}, "
            f"d(-C_M)/dα = {point.moment_slope_alpha.item():.3f}"
        )
        for mass in ds.mass_ratio.values:
            sub = point.sel(mass_ratio=mass)
            for label, boundary, u, w in zip(sub.threshold_class.values, sub.threshold_boundary.values,
                                             sub.threshold_reduced_velocity.values,
                                             sub.threshold_frequency.values, strict=True):  # fmt: skip
                if label:
                    print(f"    m = {mass:g}: {label} {boundary} at U* = {u:.5f}, ω = {w:.5f}")
    stem = Path(ds.attrs["data"]).with_suffix("")
    title = f"plate, α0 = 0°, {args.mesh} mesh"
    figures = [
        draw_coefficients(ds, Path(f"{stem}_slopes.png"), title=title),
        plot_study_thresholds(ds, Path(f"{stem}_thresholds.png"), title=title),
    ]
    if args.map:
        figures.append(plot_study_maps(ds, Path(f"{stem}_maps.png"), title=title))
    print(
        f"{ds.attrs['computed']} points computed, {ds.attrs['seconds']:.0f} s; "
        f"figures: {', '.join(map(str, figures))}"
    )


def draw_coefficients(ds, path: Path, title: str) -> Path:
    """C_D, the recirculation length and the static slopes against Re (at α0 = 0 the lift and the
    moment vanish by symmetry: the slopes carry the aerodynamics), thin-airfoil limits dashed."""
    import math

    import matplotlib.pyplot as plt

    from fsistab.plots import figure_style, save_figure

    point = ds.sel(alpha0=0.0)
    re = point.reynolds.values
    with figure_style():
        fig, axes = plt.subplots(1, 3, figsize=(13, 3.8), layout="constrained")
        axes[0].plot(re, point.drag_coefficient, "o-")
        axes[0].set_ylabel("drag coefficient C_D")
        axes[1].plot(re, point.recirculation_length, "o-")
        axes[1].set_ylabel("recirculation length / chord")
        axes[2].plot(re, point.lift_slope_alpha, "o-", label="dC_L/dα")
        axes[2].plot(re, point.moment_slope_alpha, "s-", label="d(-C_M)/dα (mid-chord)")
        axes[2].axhline(2 * math.pi, ls="--", color="0.4", lw=1, label="thin airfoil 2π, π/2")
        axes[2].axhline(math.pi / 2, ls="--", color="0.4", lw=1)
        axes[2].set_ylabel("static slope per radian")
        axes[2].legend()
        for ax in axes:
            ax.set_xscale("log")
            ax.set_xlabel("Re")
            ax.grid(alpha=0.3, which="both")
        fig.suptitle(title)
        return save_figure(fig, path)


def main(argv=None) -> None:
    args = parse_args(argv)
    from fsistab.plots import figure_format

    with figure_format(args.format):
        run(args)


if __name__ == "__main__":
    main()
