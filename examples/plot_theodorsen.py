"""Theodorsen's typical section against the viscous plate: flutter and divergence boundaries, and the error.

Shows the neutral curves U*(m) of the analytic typical section with Theodorsen's aerodynamics
(docs/model.md §9; exact C(k)), with the static slopes calibrated on the viscous plate at Re = 2900
(one steady state and one linear solve), beside the viscous map of ``plot_stability_map.py``
(``fsistab neutral``), and the relative error of Theodorsen's lowest flutter boundary against the
viscous one along m. Prints the thresholds at m = 1000 with thin-airfoil and with calibrated slopes.

Command-line equivalent::

    fsistab theodorsen --mass-ratio 1000 --slopes thin-airfoil
    fsistab theodorsen --mass-ratio 1000 --slopes calibrated --Re 2900 --mesh coarse
    fsistab neutral --Re 2900 --mesh coarse --out DIR
    fsistab theodorsen --mass-ratio-range 1 1e4 --slopes calibrated --Re 2900 --mesh coarse --out DIR

Mesh: ``--mesh`` preset (default coarse), for the calibrated slopes and the viscous map (computed
here if the cache does not hold it yet). Reference (Moulin & Marquet 2021,
§D): the viscous plate at m = 1000 has U*_F ≈ 4.5 and U*_D ≈ 7.4; thin-airfoil slopes are
dC_L/dα = 2π and d(-C_M)/dα = π/2 about mid-chord.

Usage: python examples/plot_theodorsen.py [--mesh coarse] [--out DIR] [--cache DIR]
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
    return parser.parse_args(argv)


def run(args: argparse.Namespace) -> None:
    import numpy as np

    from fsistab import workflows
    from fsistab.params import Case, MapSettings, TheodorsenSettings, solid_for
    from fsistab.plots import plot_theodorsen_comparison
    from fsistab.store import default_cache_dir

    cache = args.cache or default_cache_dir()
    case = Case.create("plate", 2900.0, 0.0, args.mesh)
    solid = solid_for("plate", mass_ratio=1000.0)  # Ω = 0.8, ζ_h = 0, ζ_θ = 0.05, r_θ = 0.289
    for slopes in ("thin-airfoil", "calibrated"):
        settings = TheodorsenSettings(mass_ratio=1000.0, slopes=slopes)
        section = workflows.section_slopes(workflows.typical_section(solid, settings), settings, case, cache)
        ds = workflows.theodorsen_points(section, settings)
        print(
            f"{slopes} (dC_L/dα = {ds.attrs['lift_slope_alpha']:.4f}, "
            f"d(-C_M)/dα = {ds.attrs['moment_slope_alpha']:.4f}), m = 1000:"
        )
        for kind, u, w in zip(ds.kind.values, ds.reduced_velocity.values, ds.frequency.values, strict=True):
            print(f"    {kind:10s} U* = {u:.4f}, ω = {w:.4f}, ω/ω_θ = {w * u:.4f}")

    if not workflows.stored_map_path(cache, case.tag).is_file():
        print("the viscous map (fsistab neutral): computing it (kept in --out and in the cache)")
        workflows.stability_map(case, solid, MapSettings(), cache, args.out, progress=print)
    settings = TheodorsenSettings(mass_range=(1.0, 1e4), slopes="calibrated")
    section = workflows.section_slopes(workflows.typical_section(solid, settings), settings, case, cache)
    ds = workflows.theodorsen_comparison(section, settings, case, cache, args.out)
    print(ds.attrs["viscous_comparison"])
    if "comparison_relative_error" in ds:
        masses, errors = ds.comparison_mass_ratio.values, 100 * ds.comparison_relative_error.values
        for low, high in ((1.0, 10.0), (10.0, 100.0), (100.0, 1000.0), (1000.0, 2e4)):
            inside = (masses >= low) & (masses < high)
            known = inside & np.isfinite(errors)  # NaN: no Theodorsen flutter boundary at that m
            if known.any():
                print(
                    f"m in [{low:g}, {high:g}): relative error of Theodorsen's lowest flutter boundary "
                    f"{errors[known].min():+.1f} % to {errors[known].max():+.1f} % ({known.sum()} points, "
                    f"{(inside & ~known).sum()} without a Theodorsen flutter boundary)"
                )
    title = f"Theodorsen (calibrated slopes) vs viscous plate, Re = 2900, {args.mesh} mesh"
    figure = plot_theodorsen_comparison(ds, Path(ds.attrs["netcdf"]).with_suffix(".png"), title=title)
    print(f"figure: {figure}")


def main(argv=None) -> None:
    args = parse_args(argv)
    from fsistab.plots import figure_format

    with figure_format(args.format):
        run(args)


if __name__ == "__main__":
    main()
