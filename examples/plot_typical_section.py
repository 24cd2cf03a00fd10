"""A NACA 0012 typical section at Re = 1000: its viscous stability map beside Theodorsen's.

Shows the neutral curves U*(m) of a NACA 0012 pitching about its quarter chord with its centre of
mass a tenth of a chord behind it (docs/model.md §3.1: a = −0.25, x_θ = 0.1, r_θ = 0.25 about the
axis, Ω = 0.5, no structural damping, α0 = 0), computed by the transfer-function method over
m in [50, 2000] (``fsistab neutral``, docs/model.md §8), beside the neutral curves of Theodorsen's
typical section with the same parameters (docs/model.md §9), with the airfoil's own static slopes at
Re = 1000 (``--slopes calibrated``), and the relative error of Theodorsen's lowest flutter boundary
along m. Prints the thresholds at m = 100 and m = 1000 of both models and of thin-airfoil theory.

Command-line equivalent::

    fsistab neutral --body naca0012 --Re 1000 --mesh quick --elastic-axis -0.25 \\
        --static-unbalance 0.1 --r-theta 0.25 --freq-ratio 0.5 --zeta-theta 0 \\
        --mass-ratio-range 50 2000 --frequency-range 0.05 0.6 --out DIR
    fsistab theodorsen --body naca0012 --Re 1000 --mesh quick --slopes calibrated \\
        --elastic-axis -0.25 --static-unbalance 0.1 --r-theta 0.25 --freq-ratio 0.5 \\
        --zeta-theta 0 --mass-ratio-range 50 2000 --out DIR

Mesh: ``--mesh`` preset (default coarse; the stored figure is ``quick``'s), in the frame of the
elastic axis (the mesh and steady state of the mid-chord section are kept apart, for the slopes).
Reference: Theodorsen's typical section (docs/model.md §9, checked against Hodges & Pierce's example
in the validation report); the viscous flutter speed of the same section on the plate approaches
Theodorsen's as Re grows (validation report, "The full typical section against Theodorsen"): at
m = 1000 and Re = 1000 the plate's is 10.8 % above thin-airfoil theory and 3.5 % above the
calibrated model.

Usage: python examples/plot_typical_section.py [--mesh coarse] [--out DIR] [--cache DIR]
"""

import argparse
from pathlib import Path

SECTION = {"elastic_axis": -0.25, "static_unbalance": 0.1}
SPRINGS = {"freq_ratio": 0.5, "zeta_h": 0.0, "zeta_theta": 0.0, "r_theta": 0.25}
MASS_RANGE, FREQUENCY_RANGE = (50.0, 2000.0), (0.05, 0.6)


def parse_args(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--mesh", default="coarse", choices=("coarse", "quick", "medium"), help="mesh preset")
    parser.add_argument(
        "--out", type=Path, default=Path("gallery-out"), help="directory for figures and data"
    )
    parser.add_argument("--cache", type=Path, default=None, help="cache (default $FSISTAB_CACHE)")
    parser.add_argument("--format", default="png", choices=("png", "pdf", "svg"), help="figure format")
    return parser.parse_args(argv)


def run(args: argparse.Namespace) -> None:
    import math

    import numpy as np

    from fsistab import workflows
    from fsistab.params import Case, MapSettings, TheodorsenSettings, solid_for
    from fsistab.plots import plot_map, plot_theodorsen_comparison
    from fsistab.store import default_cache_dir

    cache = args.cache or default_cache_dir()
    mid_chord = Case.create("naca0012", 1000.0, 0.0, args.mesh)  # the static slopes, about mid-chord
    case = Case.create("naca0012", 1000.0, 0.0, args.mesh, elastic_axis=SECTION["elastic_axis"])
    settings = MapSettings(mass_range=MASS_RANGE, frequency_range=FREQUENCY_RANGE)
    template = solid_for("plate", settings.template_mass, **SPRINGS, **SECTION)
    ds = workflows.stability_map(case, template, settings, cache, args.out, progress=print)
    title = f"NACA 0012, a = −0.25, x_θ = 0.1, Re = 1000, {args.mesh} mesh"
    print(f"map: {plot_map(ds, args.out / f'neutral_{case.tag}.png', title=title)}")
    print(f"{ds.attrs['factorisations_this_run']} factorisations this run")

    for slopes in ("thin-airfoil", "calibrated"):
        for mass in (100.0, 1000.0):
            point = TheodorsenSettings(mass_ratio=mass, slopes=slopes, **SECTION)
            section = workflows.typical_section(solid_for("plate", mass, **SPRINGS), point)
            section = workflows.section_slopes(section, point, mid_chord, cache)
            found = workflows.theodorsen_points(section, point)
            rows = zip(found.kind.values, found.reduced_velocity.values, found.frequency.values, strict=True)
            for kind, u, w in rows:
                print(f"Theodorsen ({slopes}), m = {mass:g}: {kind} U* = {u:.4f}, ω = {w:.4f}")
    compare = TheodorsenSettings(mass_range=MASS_RANGE, slopes="calibrated", **SECTION)
    section = workflows.typical_section(solid_for("plate", 1000.0, **SPRINGS), compare)
    section = workflows.section_slopes(section, compare, mid_chord, cache)
    comparison = workflows.theodorsen_comparison(section, compare, mid_chord, cache, args.out)
    print(comparison.attrs["viscous_comparison"])
    if "comparison_relative_error" in comparison:
        log_mass = np.log(comparison.comparison_mass_ratio.values)
        for mass in (100.0, 1000.0):
            viscous, theodorsen = (
                np.interp(math.log(mass), log_mass, comparison[name].values)
                for name in ("comparison_viscous", "comparison_theodorsen")
            )
            print(
                f"m = {mass:g}: lowest flutter boundary, viscous U* = {viscous:.4f}, Theodorsen "
                f"(calibrated) {theodorsen:.4f} ({100 * (theodorsen / viscous - 1):+.1f} %)"
            )
    title = f"Theodorsen (calibrated slopes) vs viscous NACA 0012 section, Re = 1000, {args.mesh} mesh"
    path = Path(comparison.attrs["netcdf"]).with_suffix(".png")
    print(f"comparison: {plot_theodorsen_comparison(comparison, path, title=title)}")


def main(argv=None) -> None:
    args = parse_args(argv)
    from fsistab.plots import figure_format

    with figure_format(args.format):
        run(args)


if __name__ == "__main__":
    main()
