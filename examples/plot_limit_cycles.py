"""Limit cycles past a threshold: the cylinder's vortex-induced vibration at Re = 150 and the plate's
flutter at Re = 2900, m = 1000.

One nonlinear march per U* (``fsistab.lco.limit_cycles``, docs/model.md §12), each from the body
released at a finite amplitude in the solid state of the eigenmode nearest a shift, the fluid at
its steady state (``--perturbation-of``); the saturated amplitudes and frequencies against U*
(filled: saturated by the stated test, open: not), the linear thresholds of the same mesh dashed,
and the time series of the march with the largest amplitude.

- ``--body cylinder`` (default): heave only, ``m* = 4m̃/(πρD²s)`` with the benchmark's reduced
  mass m̃/(ρD²s) = 2 (§10), ``U* = 2πU∞/(Dω_n)``, ω_n in vacuum, no damping; released at
  h = 0.1 D in the mode nearest 0.15 + 0.66i. Reference: the amplitude curve of the same case by
  Borazjani et al. (2008) and Ahn & Kallinderis (2006); the comparison, its source and its errors
  are in docs/simulation.md (``validation/viv_amplitude.py``).
- ``--body plate``: heave and pitch with the plate's defaults (§2), m = 1000, released at a pitch
  of 5° in the flutter mode (nearest 0.01 + 0.18i: the growing one of the coupled-mode pair past
  the threshold, docs/how-to/limit-cycles.md), Δt = 0.05, 250 time units per march.

Command-line equivalents::

    fsistab lco --body cylinder --Re 150 --mass-ratio 2.546479 --dofs heave --zeta-h 0 \\
        --mesh coarse --reduced-velocity-range 3 8 --points 6 --duration 80 --time-step 0.1 \\
        --shift 0.15+0.66j --perturbation-of heave --perturbation 0.1 --step-tolerance 1e-7 \\
        --max-step-iterations 60 --workers 2
    fsistab lco --body plate --Re 2900 --mass-ratio 1000 --mesh coarse \\
        --reduced-velocity-range 4.4 5.0 --points 4 --duration 250 --time-step 0.05 \\
        --shift 0.01+0.18j --perturbation-of pitch --perturbation 0.0873 --step-tolerance 1e-7 \\
        --max-step-iterations 60 --workers 2

Mesh: ``--mesh`` preset (default coarse).

Usage: python examples/plot_limit_cycles.py [--body cylinder|plate] [--mesh coarse] [--out DIR]
[--range A B] [--points N] [--duration T] [--workers 2]
"""

import argparse
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Sweep:
    """One body's case and march settings (the module docstring's command lines)."""

    reynolds: float
    mass_ratio: float  # body convention (§2, §10)
    dofs: tuple[str, ...]
    velocity_range: tuple[float, float]
    points: int
    duration: float
    time_step: float
    shift: complex
    released: str  # --perturbation-of
    perturbation: float
    tag: str


SWEEPS = {
    "cylinder": Sweep(
        reynolds=150.0,
        mass_ratio=2.546479,  # m* = 4 M_red/π with the benchmark's M_red = m/(ρD²) = 2 (§10)
        dofs=("heave",),
        velocity_range=(3.0, 8.0),
        points=6,
        duration=80.0,
        time_step=0.1,
        shift=0.15 + 0.66j,
        released="heave",
        perturbation=0.1,
        tag="cylinder_Re150_m2.5",
    ),
    "plate": Sweep(
        reynolds=2900.0,
        mass_ratio=1000.0,
        dofs=("heave", "pitch"),
        velocity_range=(4.4, 5.0),
        points=4,
        duration=250.0,
        time_step=0.05,
        shift=0.01 + 0.18j,  # the growing mode of the coupled-mode pair past U*_F
        released="pitch",
        perturbation=0.0873,  # 5°
        tag="plate_Re2900_m1000",
    ),
}


def parse_args(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--body", default="cylinder", choices=tuple(SWEEPS), help="the sweep to run")
    parser.add_argument("--mesh", default="coarse", choices=("coarse", "medium", "fine"), help="mesh preset")
    parser.add_argument(
        "--out", type=Path, default=Path("gallery-out"), help="directory for figures and data"
    )
    parser.add_argument("--cache", type=Path, default=None, help="cache (default $FSISTAB_CACHE)")
    parser.add_argument("--format", default="png", choices=("png", "pdf", "svg"), help="figure format")
    parser.add_argument("--range", type=float, nargs=2, default=None, help="first and last U* (body's sweep)")
    parser.add_argument("--points", type=int, default=None, help="marches, equally spaced in U*")
    parser.add_argument("--duration", type=float, default=None, help="simulated time of each march")
    parser.add_argument("--workers", type=int, default=None, help="dask LocalCluster workers")
    return parser.parse_args(argv)


def run(args: argparse.Namespace) -> None:
    import numpy as np

    from fsistab.lco import limit_cycles, signals
    from fsistab.params import Case, LcoSettings, SimulationSettings, solid_for
    from fsistab.plots import plot_lco, plot_time_series
    from fsistab.store import default_cache_dir, read_dataset
    from fsistab.study import study_client

    sweep = SWEEPS[args.body]
    velocity_range = tuple(args.range or sweep.velocity_range)
    case = Case.create(args.body, sweep.reynolds, 0.0, args.mesh)
    solid = solid_for(args.body, sweep.mass_ratio, velocity_range[0], zeta_h=0.0, dofs=sweep.dofs)
    march = SimulationSettings(
        args.duration or sweep.duration,
        sweep.time_step,
        sweep.perturbation,
        sweep.shift,
        perturbation_of=sweep.released,
        tolerance=1e-7,
        max_iterations=60,
    )
    settings = LcoSettings(velocity_range, args.points or sweep.points, march)
    args.out.mkdir(parents=True, exist_ok=True)
    with study_client(args.workers, None) as client:
        cache = args.cache or default_cache_dir()
        ds = limit_cycles(
            case, solid, settings, sweep.mass_ratio, cache, args.out, client=client, progress=print
        )
    leading = signals(ds)[0]
    for i, u in enumerate(ds.reduced_velocity.values):
        cells = ", ".join(f"{name} {ds[f'{name}_amplitude'].values[i]:.4f}" for name in signals(ds))
        w, state = (ds[f"{leading}_{k}"].values[i] for k in ("frequency", "state"))
        print(f"U* = {u:g}: amplitude {cells}, ω = {w:.4f} ({state})")
    print(f"linear thresholds: {ds.threshold_velocity.values}")
    title = f"{args.body}, Re = {sweep.reynolds:g}, m = {sweep.mass_ratio:.4g}, {args.mesh} mesh"
    print(f"figure: {plot_lco(ds, args.out / f'lco_{sweep.tag}_{args.mesh}.png', title=title)}")
    largest = int(np.nanargmax(ds[f"{leading}_amplitude"].values))
    runs = sorted((args.out / "lco_runs").glob(f"*_u{ds.reduced_velocity.values[largest]:g}_*/simulate_*.nc"))
    if runs:
        series = read_dataset(runs[-1])
        name = f"lco_series_{sweep.tag}_{args.mesh}.png"
        where = f"{title}, U* = {ds.reduced_velocity.values[largest]:g}"
        print(f"figure: {plot_time_series(series, args.out / name, title=where)}")


def main(argv=None) -> None:
    args = parse_args(argv)
    from fsistab.plots import figure_format

    with figure_format(args.format):
        run(args)


if __name__ == "__main__":
    main()
