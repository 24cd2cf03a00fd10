"""Spectrum of the spring-mounted plate at Re = 2900, m = 1000, U* = 4.7, and its three modes.

Shows the eigenvalues σ = λ + iω of the coupled fluid–solid system (docs/model.md §7) nearest the
flutter, anti-flutter and wake frequencies (whole spectrum and a close-up near the neutral axis,
coloured by the mode's label), then a pressure snapshot of each of the three modes of the
reference (the least stable solid-rich modes near ω = 0.17 and the least stable wake mode) with
the body's displacement drawn, and the heave and angle of attack h(t), -θ(t) of the two solid modes.

Command-line equivalent::

    fsistab spectrum --body plate --Re 2900 --mass-ratio 1000 --reduced-velocity 4.7 \\
        --shift 0.17j --shift 0.15j --shift 11.2j --mesh coarse

(it draws the two least stable modes; ``--mode-figures N`` draws more).

Mesh: ``--mesh`` preset (default coarse). Reference (Moulin & Marquet 2021): at m = 1000, U* = 4.7,
three eigenvalues lie near the neutral axis: an unstable coupled-mode flutter mode with ω ≈ 0.17
(close to Ω/U* = 0.170), a stable "anti-flutter" mode with ω ≈ 0.15 and the slightly stable wake
mode with ω ≈ 11.2.

Usage: python examples/plot_spectrum.py [--mesh coarse] [--out DIR] [--cache DIR]
"""

import argparse
from pathlib import Path

SHIFTS = (0.17j, 0.15j, 11.2j)  # Moulin & Marquet 2021: flutter, anti-flutter, wake
SOLID_RICH = 0.4  # solid share of the near-body kinetic energy of a flutter or anti-flutter mode


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
    from fsistab.coupled import CoupledSystem
    from fsistab.eigen import eigenpairs_near, spectrum_dataset
    from fsistab.mesh import spec_for
    from fsistab.operators import fluid_operators
    from fsistab.params import Case, solid_for
    from fsistab.plots import plot_mode_snapshot, plot_solid_motion, plot_spectrum
    from fsistab.steady import solve_steady
    from fsistab.store import default_cache_dir

    case = Case.create("plate", 2900.0, 0.0, args.mesh)
    steady = solve_steady(spec_for(case), case.flow, cache_dir=args.cache or default_cache_dir())
    fluid = fluid_operators(steady)
    system = CoupledSystem(fluid, solid_for("plate", mass_ratio=1000.0, reduced_velocity=4.7))
    pairs = sorted(eigenpairs_near(system, SHIFTS, n_eigenvalues=6), key=lambda p: -p.growth_rate)
    ds = spectrum_dataset(pairs, system)
    title = f"plate, Re = 2900, m = 1000, U* = 4.7, {args.mesh} mesh"
    figures = [plot_spectrum(ds, args.out / f"spectrum_{case.tag}.png", title=title)]
    print("growth rate λ   frequency ω   label     solid energy")
    for p in pairs:
        print(f"{p.growth_rate:+.6f}      {p.frequency:9.6f}     {p.label:8s}  {p.solid_energy_fraction:.2f}")

    # the three modes of Moulin & Marquet 2021: the least stable solid-rich modes near ω = 0.17 (flutter,
    # then anti-flutter: the solid modes share their energy with weakly damped wake modes there) and
    # the least stable mode near the wake frequency
    band = [p for p in pairs if 0.1 < p.frequency < 0.25 and p.solid_energy_fraction >= SOLID_RICH]
    wake = [p for p in pairs if abs(p.frequency - 11.2) < 1.5]
    modes = {"flutter": band[0], "anti-flutter": band[1], "wake": wake[0]}
    for name, pair in modes.items():
        print(f"{name}: σ = {pair.growth_rate:+.5f} + {pair.frequency:.5f}i ({pair.label})")
        stem = f"{name}_{case.tag}_m1000_U4.7"
        figures.append(plot_mode_snapshot(steady, fluid.free_dofs, pair, system, args.out / f"{stem}.png"))
        if name != "wake":
            figures.append(plot_solid_motion(pair, args.out / f"{stem}_motion.png").path)
    print("figures:", ", ".join(str(f) for f in figures))


def main(argv=None) -> None:
    args = parse_args(argv)
    from fsistab.plots import figure_format

    with figure_format(args.format):
        run(args)


if __name__ == "__main__":
    main()
