"""Stability map of the spring-mounted plate in the (m, U*) plane at Re = 2900, α0 = 0.

Shows every neutral curve of the plate (flutter and VIV) over m in [1, 10⁴], the divergence curve
U*_D = √(m r_θ²/(dC_M/dθ)), the unstable side of each curve, the regions with one, two or more
unstable eigenvalues, turning points and codimension-two points (docs/model.md §8), computed by the
transfer-function method (the fluid's load transfer G(iω) sampled along the imaginary axis, every
neutral (m, U*) at each ω from a polynomial; docs/transfer.md). Prints the curves, the divergence
law and the thresholds at m = 1000.

Command-line equivalent::

    fsistab neutral --body plate --Re 2900 --mesh coarse

Mesh: ``--mesh`` preset (default coarse). Reference (Moulin & Marquet 2021): at m = 1000 flutter sets
in at U*_F ≈ 4.5 and divergence at U*_D ≈ 7.4. The map's files (``neutral_plate_Re2900_a0_map.nc``
and the samples and reduced models) stay in ``--out``: a rerun resumes from them, and
``plot_theodorsen.py`` with the same ``--cache`` compares with this map.

Usage: python examples/plot_stability_map.py [--mesh coarse] [--out DIR] [--cache DIR]
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
    from fsistab.neutral_map import map_curves
    from fsistab.params import Case, MapSettings, solid_for
    from fsistab.plots import plot_map
    from fsistab.store import default_cache_dir
    from fsistab.workflows import divergence_coefficient, stability_map

    case = Case.create("plate", 2900.0, 0.0, args.mesh)
    settings = MapSettings(mass_range=(1.0, 1e4))
    template = solid_for("plate", mass_ratio=settings.template_mass)  # Ω, ζ_h, ζ_θ, r_θ of docs/model.md §2
    ds = stability_map(case, template, settings, args.cache or default_cache_dir(), args.out, progress=print)
    figure = plot_map(
        ds, args.out / f"neutral_{case.tag}.png", title=f"plate, Re = 2900, α0 = 0°, {args.mesh} mesh"
    )
    for kind, m, u, _ in map_curves(ds):
        print(f"{kind:8s} m in [{m.min():.4g}, {m.max():.4g}], U* in [{u.min():.4g}, {u.max():.4g}]")
        for velocity in crossings_at(m, u, 1000.0):
            print(f"         crosses m = 1000 at U* = {velocity:.5f}")
    coefficient = divergence_coefficient(ds)
    print(f"divergence: U*_D = {coefficient:.4f} √m, at m = 1000: {coefficient * 1000**0.5:.4f}")
    print(f"{ds.attrs['factorisations_this_run']} factorisations this run; figure {figure}")


def crossings_at(masses, velocities, mass: float) -> list[float]:
    """U* where the polyline (m, U*) crosses ``mass`` (linear in log m between the points)."""
    import numpy as np

    x = np.log(np.asarray(masses) / mass)
    found = []
    for k in np.nonzero(np.sign(x[1:]) != np.sign(x[:-1]))[0]:
        w = x[k] / (x[k] - x[k + 1])
        found.append(float(velocities[k] + w * (velocities[k + 1] - velocities[k])))
    return found


def main(argv=None) -> None:
    args = parse_args(argv)
    from fsistab.plots import figure_format

    with figure_format(args.format):
        run(args)


if __name__ == "__main__":
    main()
