"""The spring-mounted cylinder of check c (Re 150, reduced mass 2, no damping; docs/simulation.md,
"Spring-mounted cylinder in heave") released at rest into the fixed cylinder's saturated wake,
instead of from the steady state: does the start pick the cycle?

Two marches of ``fsistab simulate`` (its workflow, checkpointed in the cache: a rerun reuses them):

1. the cylinder held: heave only with a mass ratio of ``--held-mass-ratio`` (10⁶: it moves by
   about 10⁻⁶ D; its U* is ``--held-reduced-velocity``, one march for every release), from the
   steady state plus ``--perturbation`` times the mode nearest ``--shift``, until the shedding
   has saturated (``--held-duration``);
2. for each ``--reduced-velocity``, the cylinder of check c (``m* = 4 M_red/π`` with
   ``M_red = 2``) started from the last state of march 1 (``--start``: the fluid shedding, the
   cylinder at rest), for ``--duration``.

Prints the held cylinder's shedding (Strouhal number, mean drag, lift amplitude over its last
periods) and, for each U*, the heave's cycle as ``fsistab lco`` reports it
(:func:`fsistab.lco.saturation`: mean period amplitude of the last four periods, state, largest
excursion from the mid-level over the second half, angular frequency), to set beside the releases
from the steady state in docs/simulation.md.

Usage: python validation/viv_from_shedding.py [--reduced-velocity 5 6] [--time-step 0.1]
       [--duration 80] [--cache DIR]
"""

import argparse
import math
import sys
from pathlib import Path

from fsistab.lco import saturation
from fsistab.params import Case, SimulationSettings, solid_for
from fsistab.simulation import last_cycles, mean_over
from fsistab.store import default_cache_dir
from fsistab.workflows import simulate

REDUCED_MASS = 2.0  # M_red = m / (ρ D²) of the benchmark (Ahn & Kallinderis 2006; Borazjani et al. 2008)


def _march(case, solid, settings, cache: Path, out: Path):
    """The march's time series; its progress (simulated time, steps per second) on stderr."""
    say = lambda message: print(message, file=sys.stderr, flush=True)  # noqa: E731
    return simulate(case, solid, settings, cache, out, say).dataset


def held_shedding(ds, periods: int = 6) -> str:
    """The held cylinder's shedding over its last ``periods`` lift periods."""
    times = ds.time.values
    lift = last_cycles(times, ds.lift_coefficient.values, periods)
    drag = mean_over(times, ds.drag_coefficient.values, lift.start, lift.end)
    return (
        f"held cylinder, t = {lift.start:.4g}-{lift.end:.4g}: St = {lift.frequency / (2 * math.pi):.4f}, "
        f"mean C_D = {drag:.4f}, C_L' = {lift.amplitude:.4f}; "
        f"largest heave {abs(ds.heave.values).max():.2e} D"
    )


def heave_cycle(ds) -> str:
    """The heave's cycle as ``fsistab lco`` reports it."""
    s = saturation(ds.time.values, ds.heave.values)
    return (
        f"period amplitude {s.amplitude:.4f} ({s.state}, {s.change:+.4f} per period), largest "
        f"{s.largest:.4f}, omega {s.frequency:.4f}; {ds.attrs['steps']} steps, "
        f"{ds.attrs['seconds_per_step']:.3g} s per step, {ds.attrs['factorisations']} factorisations"
    )


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--reduced-velocity", type=float, nargs="+", default=[5.0, 6.0])
    parser.add_argument("--preset", default="coarse")
    parser.add_argument("--time-step", type=float, default=0.1)
    parser.add_argument("--duration", type=float, default=80.0)
    parser.add_argument("--held-mass-ratio", type=float, default=1e6)
    parser.add_argument("--held-duration", type=float, default=150.0)
    parser.add_argument("--held-reduced-velocity", type=float, default=5.0, help="irrelevant at m = 10⁶")
    parser.add_argument("--perturbation", type=float, default=1e-3)
    parser.add_argument("--shift", type=complex, default=0.2 + 0.8j)
    parser.add_argument("--cache", default=None)
    parser.add_argument("--out", default="fsistab-out")
    args = parser.parse_args()
    case = Case.create("cylinder", 150.0, preset=args.preset)
    cache, out = Path(args.cache) if args.cache else default_cache_dir(), Path(args.out)
    iterations = {"tolerance": 1e-7, "max_iterations": 60}  # large cycles (docs/simulation.md)

    def solid(mass_ratio: float, velocity: float):
        return solid_for("cylinder", mass_ratio, velocity, zeta_h=0.0, dofs=("heave",))

    held = _march(
        case,
        solid(args.held_mass_ratio, args.held_reduced_velocity),
        SimulationSettings(args.held_duration, args.time_step, args.perturbation, args.shift, **iterations),
        cache,
        out / "held",
    )
    print(held_shedding(held))
    start = held.attrs["checkpoint"]
    for velocity in args.reduced_velocity:
        settings = SimulationSettings(args.duration, args.time_step, start=start, **iterations)
        mounted = solid(4 * REDUCED_MASS / math.pi, velocity)
        ds = _march(case, mounted, settings, cache, out / f"u{velocity:g}")
        print(f"U* = {velocity:g}, released at rest into the shedding: {heave_cycle(ds)}")


if __name__ == "__main__":
    main()
