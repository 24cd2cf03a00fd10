"""Angle-of-attack study of the plate at Re = 2900: steady loads, static slopes, classified critical modes.

Shows, against the steady angle of attack α0 (degrees, nose-up positive), the steady C_L, C_M
(about G) and recirculation length, and every threshold along U* in [2, 10] at m = 1000 with its
critical mode classified (coupled-mode, pitch or heave single-mode flutter, divergence, VIV, from
the mode's energies; docs/how-to/studies.md), the pressure of each α0's first dynamic critical mode
at m = 1000 with the body's motion drawn (from the transfer function's null vector at the
threshold: one factorisation each, ``--no-modes`` to skip), and with ``--map`` the (m, U*) maps of
every α0 overlaid. Each α0 is one point of ``fsistab.study.run_study``, saved in ``OUT/points/`` as it
finishes (a rerun computes only what is missing); ``--workers N`` runs the points on a local dask
cluster. A point whose steady state is not cached starts from its nearest finished neighbour.

Command-line equivalent::

    fsistab study --Re 2900 --alpha0 0 1 2 3 4 5 6 --slopes --thresholds 1000 --mesh coarse

(add ``--map`` for the maps, ``--workers 2`` for two worker processes).

Mesh: ``--mesh`` preset (default coarse). Reference (Moulin & Marquet 2021): at α0 = 0 the steady flow is
symmetric (C_L = C_M = 0) and, at m = 1000, flutter sets in at U*_F ≈ 4.5 and divergence at
U*_D ≈ 7.4; the reference gives no values at α0 ≠ 0 (thin-airfoil slopes: C_L ≈ 2π α0 for small α0).

Usage: python examples/plot_alpha0_study.py [--mesh coarse] [--out DIR] [--alpha0 0 1 2 3 4 5 6]
       [--map] [--workers N]
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
    parser.add_argument("--Re", dest="reynolds", type=float, default=2900.0, help="Reynolds number")
    parser.add_argument("--alpha0", type=float, nargs="+", default=[0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    parser.add_argument("--map", action="store_true", help="also the whole (m, U*) map at each α0 (slow)")
    parser.add_argument("--workers", type=int, default=None, help="dask LocalCluster of N worker processes")
    parser.add_argument(
        "--no-modes", dest="modes", action="store_false", help="skip the critical-mode figures"
    )
    return parser.parse_args(argv)


def run(args: argparse.Namespace) -> None:
    import numpy as np

    from fsistab.params import Case
    from fsistab.plots import plot_study_coefficients, plot_study_maps, plot_study_thresholds
    from fsistab.store import default_cache_dir
    from fsistab.study import StudySettings, run_study, study_client

    settings = StudySettings(
        reynolds=(args.reynolds,), alpha0=tuple(args.alpha0), slopes=True, thresholds=(1000.0,), map=args.map
    )
    base = Case.create("plate", args.reynolds, 0.0, args.mesh)
    with study_client(workers=args.workers) as client:
        ds = run_study(
            base, settings, args.cache or default_cache_dir(), args.out, client=client, progress=print
        )
    for alpha0 in ds.alpha0.values:
        point = ds.sel(reynolds=args.reynolds, alpha0=alpha0)
        lift = point.lift_coefficient.item()
        per_radian = f", C_L/α0 = {lift / np.radians(alpha0):.3f} per radian" if alpha0 else ""
        print(
            f"α0 = {alpha0:g}°: {point.status.item()}, C_L = {lift:.4f}, "
            f"C_M = {point.moment_coefficient.item():.4f}{per_radian}"
        )
        sub = point.sel(mass_ratio=1000.0)
        for label, u, w in zip(sub.threshold_class.values, sub.threshold_reduced_velocity.values,
                               sub.threshold_frequency.values, strict=True):  # fmt: skip
            if label:
                print(f"    m = 1000: {label} at U* = {u:.4f}, ω = {w:.4f}")
    stem = Path(ds.attrs["data"]).with_suffix("")
    title = f"plate, Re = {args.reynolds:g}, {args.mesh} mesh"
    figures = [
        plot_study_coefficients(ds, Path(f"{stem}_coefficients.png"), title=title),
        plot_study_thresholds(ds, Path(f"{stem}_thresholds.png"), title=f"{title}, m = 1000"),
    ]
    if args.map:
        figures.append(plot_study_maps(ds, Path(f"{stem}_maps.png"), title=title))
    if args.modes:
        figures += critical_mode_figures(ds, settings, base, args.cache or default_cache_dir(), stem)
    print(
        f"{ds.attrs['computed']} points computed, {ds.attrs['seconds']:.0f} s; "
        f"figures: {', '.join(map(str, figures))}"
    )


def critical_mode_figures(ds, settings, base, cache: Path, stem: Path) -> list[Path]:
    """At each α0, the first dynamic onset at m = 1000 (flutter or VIV, the lowest U*): its critical
    mode ``σ = iω_c`` from one factorisation of ``K_ff(iω_c)`` (the null vector of the
    characteristic matrix, docs/model.md §7), its pressure at phase 0 with the body's displacement."""
    from dataclasses import replace

    import numpy as np

    from fsistab.coupled import CoupledSystem
    from fsistab.eigen import neutral_eigenpair
    from fsistab.mesh import spec_for
    from fsistab.operators import fluid_operators
    from fsistab.params import Flow
    from fsistab.plots import plot_mode_snapshot
    from fsistab.steady import solve_steady
    from fsistab.transfer import transfer_sample

    figures = []
    for alpha0 in ds.alpha0.values:
        point = ds.sel(reynolds=base.flow.reynolds, alpha0=alpha0, mass_ratio=1000.0)
        columns = ("reduced_velocity", "frequency", "class", "boundary")
        rows = zip(*(point[f"threshold_{name}"].values for name in columns), strict=True)
        onsets = [
            (u, w, label)
            for u, w, label, boundary in rows
            if boundary == "onset" and label and label != "divergence" and w > 0
        ]
        if point.status.item() != "done" or not onsets:
            continue
        velocity, frequency, label = min(onsets)
        case = replace(base, flow=Flow(base.flow.reynolds, float(alpha0)))
        steady = solve_steady(spec_for(case), case.flow, cache_dir=cache)  # the study's, from the cache
        fluid = fluid_operators(steady)
        solid = settings.solid("plate", 1000.0, float(velocity))
        system = CoupledSystem(fluid, solid)
        sample = transfer_sample(fluid, 1j * float(frequency))
        pair = neutral_eigenpair(system, float(frequency), sample.mode(solid, fluid.theta0, fluid.loads0))
        shares = pair.solid_energy_fraction
        print(
            f"α0 = {alpha0:g}°: critical mode of the {label} onset at U* = {velocity:.5f}, "
            f"ω = {frequency:.5f}: residual {pair.residual:.1e}, solid share {shares:.2f}, "
            f"|ĥ| = {np.abs(pair.solid[0]):.3g}, |θ̂| = {np.abs(pair.solid[1]):.3g}"
        )
        path = Path(f"{stem}_mode_alpha{alpha0:g}.png")
        figures.append(plot_mode_snapshot(steady, fluid.free_dofs, pair, system, path))
    return figures


def main(argv=None) -> None:
    args = parse_args(argv)
    from fsistab.plots import figure_format

    with figure_format(args.format):
        run(args)


if __name__ == "__main__":
    main()
