"""Onset of the fixed plate's wake instability in angle of attack at Re = 500, and its critical mode.

Shows the growth rate λ and frequency ω of the fixed plate's leading wake mode at the iterates of the
secant on λ(α0) (:mod:`fsistab.onset`; α0 in degrees, nose-up positive), the critical angle α0_c
where λ = 0 (a Hopf bifurcation of the steady flow), the steady streamwise velocity at α0_c and the
pressure of the critical mode there (snapshot at phase 0; the body is fixed). The critical mode is
the eigenpair nearest ``iω_c`` of the fixed plate at α0_c (one more steady state, continued from
the last iterate's, and one factorisation).

Command-line equivalent::

    fsistab onset --body plate --parameter alpha0 --Re 500 --guess 9.5 --shift 0+3.9j --mesh coarse

(the growth-rate figure and the iterates; this script adds the critical mode). The shift is a guess
of the wake mode's eigenvalue: ``fsistab spectrum --dofs none --Re 500 --alpha0 10 --shift 0+4j``
finds it (about 3.9i at α0 = 10°). The mode followed from ``--shift 0+1.8j``, whose growth rate the
coarse mesh puts at 0 near 17°, is not a wake mode: with the coarse mesh's wake box widened to
5 chords it is damped (λ = -0.08 at 15°; docs/gallery/index.md).

Mesh: ``--mesh`` preset (default coarse), fitted to Re = 500. The coarse mesh gives α0_c = 9.77°,
ω_c = 3.947; the default mesh (``--mesh medium --guess 10 --shift 0.07+3.877j``) gives the same
mode's onset at 9.725°, ω_c 3.966. A second mode crosses at 14.0° (ω 2.82) on the default mesh,
the first being unstable by then (docs/discretisation.md, "The wake onset in α0 at Re 500").
Reference: Moulin & Marquet 2021 gives the plate's flutter and divergence at α0 = 0 only, nothing on the
fixed plate's onset in α0.

Usage: python examples/plot_wake_onset.py [--mesh coarse] [--out DIR] [--cache DIR] [--guess 9.5]
       [--shift 0+3.9j]
"""

import argparse
from pathlib import Path

REYNOLDS = 500.0
# the wake leaves the trailing edge upwards in the body frame (α0 > 0)
MODE_WINDOW = ((-1.0, 6.0), (-1.0, 2.0))
SHIFT_OFFSET = 0.0013 + 0.0017j  # the critical mode's shift, just off its neutral eigenvalue


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
    parser.add_argument("--Re", dest="reynolds", type=float, default=REYNOLDS, help="Reynolds number")
    parser.add_argument("--guess", type=float, default=9.5, help="first guess of the critical α0 [deg]")
    parser.add_argument("--shift", type=complex, default=3.9j, help="guess of the wake mode's eigenvalue")
    return parser.parse_args(argv)


def run(args: argparse.Namespace) -> None:
    from fsistab.coupled import CoupledSystem
    from fsistab.eigen import eigenpairs_near
    from fsistab.mesh import spec_for
    from fsistab.onset import rounded
    from fsistab.operators import fluid_operators
    from fsistab.params import Case, Flow, Solid
    from fsistab.plots import plot_mode_snapshot, plot_onset, plot_streamwise_velocity
    from fsistab.steady import solve_steady
    from fsistab.store import default_cache_dir
    from fsistab.workflows import fixed_body_onset

    cache = args.cache or default_cache_dir()
    case = Case.create("plate", args.reynolds, 0.0, args.mesh)
    ds = fixed_body_onset(case, "alpha0", args.guess, args.shift, cache, args.out)
    critical, frequency = float(ds.attrs["critical_value"]), float(ds.attrs["frequency"])
    print(f"fixed plate, Re = {args.reynolds:g}, {args.mesh} mesh ({ds.attrs['ndof']} unknowns)")
    print("alpha0 [deg]   growth rate λ   frequency ω")
    for value, rate, omega in zip(ds.value.values, ds.growth_rate.values, ds.frequency.values, strict=True):
        print(f"{value:12.6f}   {rate:+.6e}   {omega:.6f}")
    print(
        f"critical alpha0 = {critical:.6f} deg, ω_c = {frequency:.6f} (Strouhal {ds.attrs['strouhal']:.5f}); "
        f"{ds.attrs['iterations']} iterates, {ds.attrs['factorisations']} factorisations"
    )
    title = f"fixed plate, Re = {args.reynolds:g}, {args.mesh} mesh"
    figures = [plot_onset(ds, args.out / f"wake_onset_Re{args.reynolds:g}_{args.mesh}.png", title=title)]

    # the critical mode: the steady state at α0_c continued from the last iterate's (both cached)
    spec = spec_for(case)
    last = solve_steady(spec, Flow(args.reynolds, float(ds.value.values[-1])), cache_dir=cache)
    steady = solve_steady(
        spec, Flow(args.reynolds, rounded("alpha0", critical)), cache_dir=cache, initial=last
    )
    system = CoupledSystem(fluid_operators(steady), Solid(dofs=()))
    # the shift off the neutral eigenvalue (a shift on it makes the shifted matrix singular)
    pairs = eigenpairs_near(system, [1j * frequency + SHIFT_OFFSET], 3)
    pair = min(pairs, key=lambda p: abs(p.value - 1j * frequency))
    at = steady.flow.alpha0_deg
    print(f"critical mode at alpha0 = {at:.6f}: σ = {pair.growth_rate:+.2e} + {pair.frequency:.6f}i")
    stem = f"Re{args.reynolds:g}_a{steady.flow.alpha0_deg:.2f}_{args.mesh}"
    figures.append(
        plot_streamwise_velocity(steady, args.out / f"wake_onset_steady_{stem}.png", streamlines=True)
    )
    figures.append(
        plot_mode_snapshot(
            steady,
            system.fluid.free_dofs,
            pair,
            system,
            args.out / f"wake_onset_mode_{stem}.png",
            window=MODE_WINDOW,
        )
    )
    print("figures:", ", ".join(str(f) for f in figures))


def main(argv=None) -> None:
    args = parse_args(argv)
    from fsistab.plots import figure_format

    with figure_format(args.format):
        run(args)


if __name__ == "__main__":
    main()
