"""Vortex-induced vibration of the spring-mounted cylinder at Re = 150, m* = 8/π, ζ = 0: limit cycles.

One nonlinear march per U* (``fsistab.lco.limit_cycles``, docs/model.md §10, §12: heave only,
``m* = 4m̃/(πρD²s)`` — the reduced mass m̃/(ρD²s) = 2 of the benchmark — and
``U* = 2πU∞/(Dω_n)``, ω_n in vacuum), each from the body released at h = 0.1 D in the solid
state of the eigenmode nearest 0.15 + 0.66i, the fluid at its steady state
(``--perturbation-of heave``); the saturated heave amplitude A/D and frequency against U* (filled:
saturated by the stated test, open: not), the linear thresholds of the same mesh dashed, and the
time series of the march with the largest amplitude.

Command-line equivalent::

    fsistab lco --body cylinder --Re 150 --mass-ratio 2.546479 --dofs heave --zeta-h 0 \\
        --mesh coarse --reduced-velocity-range 3 8 --points 6 --duration 80 --time-step 0.1 \\
        --shift 0.15+0.66j --perturbation-of heave --perturbation 0.1 --step-tolerance 1e-7 \\
        --max-step-iterations 60 --workers 2

Mesh: ``--mesh`` preset (default coarse). Reference: the amplitude curve of the same case by
Borazjani et al. (2008) and Ahn & Kallinderis (2006); the comparison, its source and its errors
are in docs/simulation.md (``validation/viv_amplitude.py``).

Usage: python examples/plot_limit_cycles.py [--mesh coarse] [--out DIR] [--points 6] [--workers 2]
"""

import argparse
from pathlib import Path

REYNOLDS = 150.0
MASS_RATIO = 2.546479  # m* = 4 M_red/π with the benchmark's reduced mass M_red = m/(ρD²) = 2 (§10)


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
    parser.add_argument("--range", type=float, nargs=2, default=(3.0, 8.0), help="first and last U*")
    parser.add_argument("--points", type=int, default=6, help="marches, equally spaced in U*")
    parser.add_argument("--duration", type=float, default=80.0, help="simulated time of each march")
    parser.add_argument("--workers", type=int, default=None, help="dask LocalCluster workers")
    return parser.parse_args(argv)


def run(args: argparse.Namespace) -> None:
    import numpy as np

    from fsistab.lco import limit_cycles
    from fsistab.params import Case, LcoSettings, SimulationSettings, solid_for
    from fsistab.plots import plot_lco, plot_time_series
    from fsistab.store import default_cache_dir, read_dataset
    from fsistab.study import study_client

    case = Case.create("cylinder", REYNOLDS, 0.0, args.mesh)
    solid = solid_for("cylinder", MASS_RATIO, args.range[0], zeta_h=0.0, dofs=("heave",))
    march = SimulationSettings(
        args.duration, 0.1, 0.1, 0.15 + 0.66j, perturbation_of="heave", tolerance=1e-7, max_iterations=60
    )
    settings = LcoSettings(tuple(args.range), args.points, march)
    args.out.mkdir(parents=True, exist_ok=True)
    with study_client(args.workers, None) as client:
        cache = args.cache or default_cache_dir()
        ds = limit_cycles(case, solid, settings, MASS_RATIO, cache, args.out, client=client, progress=print)
    for i, u in enumerate(ds.reduced_velocity.values):
        a, w, state = (ds[f"heave_{k}"].values[i] for k in ("amplitude", "frequency", "state"))
        print(f"U* = {u:g}: A/D = {a:.4f}, ω = {w:.4f} ({state})")
    print(f"linear thresholds: {ds.threshold_velocity.values}")
    title = f"cylinder in heave, Re = {REYNOLDS:g}, m* = {MASS_RATIO:.3g}, {args.mesh} mesh"
    print(f"figure: {plot_lco(ds, args.out / f'lco_cylinder_Re150_m2.5_{args.mesh}.png', title=title)}")
    largest = int(np.nanargmax(ds.heave_amplitude.values))
    runs = sorted((args.out / "lco_runs").glob(f"*_u{ds.reduced_velocity.values[largest]:g}_*/simulate_*.nc"))
    if runs:
        series = read_dataset(runs[-1])
        name = f"lco_series_cylinder_Re150_m2.5_{args.mesh}.png"
        where = f"{title}, U* = {ds.reduced_velocity.values[largest]:g}"
        print(f"figure: {plot_time_series(series, args.out / name, title=where)}")


def main(argv=None) -> None:
    args = parse_args(argv)
    from fsistab.plots import figure_format

    with figure_format(args.format):
        run(args)


if __name__ == "__main__":
    main()
