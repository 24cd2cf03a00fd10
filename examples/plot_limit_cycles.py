"""Vortex-induced vibration of the spring-mounted cylinder at Re = 100, m = 10, ζ = 0: limit cycles.

One nonlinear march per U* (``fsistab.lco.limit_cycles``, docs/model.md §10, §12: heave only,
``m = 4m̃/(πρD²s)``, ``U* = 2πU∞/(Dω_n)``) from the steady state plus the wake mode near
0.1 + 0.75i; the saturated heave amplitude A/D and frequency against U* (filled: saturated by the
stated test, open: not), the linear thresholds of the same mesh dashed, and the time series of the
march with the largest amplitude.

Command-line equivalent::

    fsistab lco --body cylinder --Re 100 --mass-ratio 10 --zeta-h 0 --mesh coarse \\
        --reduced-velocity-range 5 6 --points 2 --duration 100 --time-step 0.2 \\
        --perturbation 0.1 --shift 0.1+0.75j --step-tolerance 1e-6 --max-step-iterations 80 \\
        --workers 2

Mesh: ``--mesh`` preset (default coarse). Reference: the fixed cylinder's saturated shedding at
Re 100 (docs/simulation.md: St 0.164), whose frequency 2π·0.164 ≈ 1.03 meets the in-vacuo natural
frequency 2π/U* at U* ≈ 6.1, where lock-in is expected; the numbers and their comparison are in
docs/simulation.md.

Usage: python examples/plot_limit_cycles.py [--mesh coarse] [--out DIR] [--points 2] [--workers 2]
"""

import argparse
from pathlib import Path

MASS_RATIO = 10.0  # docs/model.md §10 convention


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
    parser.add_argument("--range", type=float, nargs=2, default=(5.0, 6.0), help="first and last U*")
    parser.add_argument("--points", type=int, default=2, help="marches, equally spaced in U*")
    parser.add_argument("--duration", type=float, default=100.0, help="simulated time of each march")
    parser.add_argument("--workers", type=int, default=None, help="dask LocalCluster workers")
    return parser.parse_args(argv)


def run(args: argparse.Namespace) -> None:
    import numpy as np

    from fsistab.lco import limit_cycles
    from fsistab.params import Case, LcoSettings, SimulationSettings, solid_for
    from fsistab.plots import plot_lco, plot_time_series
    from fsistab.store import default_cache_dir, read_dataset
    from fsistab.study import study_client

    case = Case.create("cylinder", 100.0, 0.0, args.mesh)
    solid = solid_for("cylinder", MASS_RATIO, args.range[0], zeta_h=0.0, dofs=("heave",))
    march = SimulationSettings(
        args.duration, 0.2, 0.1, 0.1 + 0.75j, checkpoint_every=25, tolerance=1e-6, max_iterations=80
    )  # fmt: skip
    settings = LcoSettings(tuple(args.range), args.points, march)
    args.out.mkdir(parents=True, exist_ok=True)
    with study_client(args.workers, None) as client:
        cache = args.cache or default_cache_dir()
        ds = limit_cycles(case, solid, settings, MASS_RATIO, cache, args.out, client=client, progress=print)
    for i, u in enumerate(ds.reduced_velocity.values):
        a, w, state = (ds[f"heave_{k}"].values[i] for k in ("amplitude", "frequency", "state"))
        print(f"U* = {u:g}: A/D = {a:.4f}, ω = {w:.4f} ({state})")
    print(f"linear thresholds: {ds.threshold_velocity.values}")
    title = f"cylinder in heave, Re = 100, m = {MASS_RATIO:g}, {args.mesh} mesh"
    print(f"figure: {plot_lco(ds, args.out / f'lco_cylinder_Re100_m10_{args.mesh}.png', title=title)}")
    largest = int(np.nanargmax(ds.heave_amplitude.values))
    runs = sorted((args.out / "lco_runs").glob(f"*_u{ds.reduced_velocity.values[largest]:g}_*/simulate_*.nc"))
    if runs:
        series = read_dataset(runs[-1])
        name = f"lco_series_cylinder_Re100_m10_{args.mesh}.png"
        where = f"{title}, U* = {ds.reduced_velocity.values[largest]:g}"
        print(f"figure: {plot_time_series(series, args.out / name, title=where)}")


def main(argv=None) -> None:
    args = parse_args(argv)
    from fsistab.plots import figure_format

    with figure_format(args.format):
        run(args)


if __name__ == "__main__":
    main()
