"""The fixed cylinder's saturated vortex shedding by the nonlinear time march (docs/model.md §12).

Marches ``fsistab simulate`` (its workflow, checkpointed in the cache: a rerun resumes or reuses the
march) from the steady state plus ``--perturbation`` times the leading wake mode, then prints:

* the growth phase: growth rate and frequency fitted to the lift while its amplitude is below
  ``--linear-limit`` (Prony's method, :func:`fsistab.simulation.damped_oscillation`), against the
  eigenvalue of the same mesh's spectrum (and against BDF2's image of it);
* the saturated cycle over the last ``--periods`` lift periods: Strouhal number ``St = ω/(2π)``
  (diameter-based units), mean drag, lift amplitude and drag amplitude;
* the cost: unknowns, steps, seconds per step, factorisations.

Usage: python validation/cylinder_shedding.py [--reynolds 100] [--preset coarse] [--time-step 0.1]
       [--duration 150] [--start CHECKPOINT]
"""

import argparse
import math
from pathlib import Path

import numpy as np

from fsistab.params import Case, SimulationSettings, solid_for
from fsistab.simulation import damped_oscillation, last_cycles, mean_over
from fsistab.store import default_cache_dir
from fsistab.workflows import simulate


def bdf2_image(sigma: complex, dt: float) -> complex:
    """``log(g)/Δt`` for the principal root ``g`` of ``(3/2 − σΔt) g² − 2g + 1/2 = 0``."""
    roots = np.roots([1.5 - sigma * dt, -2.0, 0.5])
    return complex(np.log(roots[np.argmax(np.abs(roots))]) / dt)


def growth_phase(ds, limit: float) -> None:
    """Fit the lift while it is small (after the first three steps) against the start eigenvalue."""
    lift = ds.lift_coefficient.values - ds.lift_coefficient.values[0]
    times = ds.time.values
    small = np.nonzero(np.abs(lift) > limit)[0]
    end = small[0] if len(small) else len(lift)
    fit = damped_oscillation(times[3:end], ds.lift_coefficient.values[3:end])
    sigma = complex(ds.attrs["start_growth_rate"], ds.attrs["start_frequency"])
    image = bdf2_image(sigma, float(ds.attrs["time_step"]))
    print(f"growth phase t = {times[3]:.3g} to {times[end - 1]:.4g} (|C_L| < {limit:g}):")
    print(f"  fitted        {fit.real:+.6f} {fit.imag:+.6f}i")
    print(
        f"  eigenvalue    {sigma.real:+.6f} {sigma.imag:+.6f}i   (growth {fit.real / sigma.real - 1:+.3%},"
        f" frequency {fit.imag / sigma.imag - 1:+.3%})"
    )
    print(f"  BDF2's image  {image.real:+.6f} {image.imag:+.6f}i   (|difference| {abs(fit - image):.2e})")


def saturated(ds, periods: int) -> None:
    """Strouhal number, mean drag and lift amplitude over the last periods."""
    times = ds.time.values
    lift = last_cycles(times, ds.lift_coefficient.values, periods)
    drag = ds.drag_coefficient.values
    inside = (times >= lift.start) & (times <= lift.end)
    print(f"saturated cycle, {lift.periods} periods from t = {lift.start:.4g} to {lift.end:.4g}:")
    print(f"  Strouhal number St = {lift.frequency / (2 * math.pi):.5f} (omega = {lift.frequency:.5f})")
    print(
        f"  mean drag C_D = {mean_over(times, drag, lift.start, lift.end):.5f}, drag amplitude "
        f"{0.5 * (drag[inside].max() - drag[inside].min()):.5f}"
    )
    print(f"  lift amplitude C_L' = {lift.amplitude:.5f} (mean {lift.mean:+.2e})")


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--reynolds", type=float, default=100.0)
    parser.add_argument("--preset", default="coarse")
    parser.add_argument("--time-step", type=float, default=0.1)
    parser.add_argument("--duration", type=float, default=150.0)
    parser.add_argument("--perturbation", type=float, default=1e-3)
    parser.add_argument("--shift", type=complex, default=0.1 + 0.75j)
    parser.add_argument("--start", default=None, help="a checkpoint to start from (no growth phase)")
    parser.add_argument("--periods", type=int, default=10)
    parser.add_argument("--linear-limit", type=float, default=3e-4)
    parser.add_argument("--cache", default=None)
    parser.add_argument("--out", default="fsistab-out")
    args = parser.parse_args()
    case = Case.create("cylinder", args.reynolds, preset=args.preset)
    settings = SimulationSettings(
        args.duration, args.time_step, args.perturbation, args.shift, args.start, checkpoint_every=50
    )
    cache = Path(args.cache) if args.cache else default_cache_dir()
    result = simulate(case, solid_for("cylinder", dofs=()), settings, cache, Path(args.out), lambda m: None)
    ds = result.dataset
    print(
        f"cylinder, Re = {args.reynolds:g}, {args.preset} mesh, {ds.attrs['ndof']} unknowns; "
        f"dt = {args.time_step:g}, {ds.attrs['steps']} steps to t = {ds.time.values[-1]:.4g}"
    )
    if args.start is None:
        growth_phase(ds, args.linear_limit)
    saturated(ds, args.periods)
    cost = ds.attrs["seconds_per_step"]
    print(
        f"cost this run: {ds.attrs['steps_this_run']} steps, {cost:.3g} s per step, "
        f"{ds.attrs['factorisations']} factorisations; mean chord iterations "
        f"{ds.chord_iterations.values[1:].mean():.2f}; data {ds.attrs['netcdf']}"
    )


if __name__ == "__main__":
    main()
