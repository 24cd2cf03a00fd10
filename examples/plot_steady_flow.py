"""Steady flow around the plate at Re = 2900, α0 = 0 (the base state of every other result).

Shows the streamwise velocity of the steady Navier–Stokes solution (docs/model.md §6) around the plate
of chord/thickness 20, the recirculation behind the blunt trailing edge outlined, and prints the
coefficients C_L, C_D, C_M and the recirculation length.

Command-line equivalent::

    fsistab steady --body plate --Re 2900 --mesh coarse

Mesh: ``--mesh`` preset (default coarse). Reference (Moulin & Marquet 2021): the steady flow at
Re = 2900 is symmetric (C_L = C_M = 0), attached, with only a small recirculation behind the blunt
trailing edge.

Usage: python examples/plot_steady_flow.py [--mesh coarse] [--out DIR] [--cache DIR]
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
    return parser.parse_args(argv)


def run(args: argparse.Namespace) -> None:
    from fsistab import figures
    from fsistab.params import Case
    from fsistab.store import default_cache_dir
    from fsistab.workflows import steady_flow

    case = Case.create("plate", args.reynolds, 0.0, args.mesh)
    result = steady_flow(case, args.cache or default_cache_dir(), progress=print)
    ds = figures.steady(result, case.tag, args.out)
    a = ds.attrs
    print(
        f"C_L = {a['lift_coefficient']:.3g}, C_D = {a['drag_coefficient']:.5f}, "
        f"C_M = {a['moment_coefficient']:.3g}, recirculation length = {a['recirculation_length']:.4f} "
        f"({a['ndof']} unknowns; " + ("read from the cache)" if a["from_cache"] else f"{a['seconds']:.1f} s)")
    )
    print(f"figure: {a['figure']}")


def main(argv=None) -> None:
    args = parse_args(argv)
    from fsistab.plots import figure_format

    with figure_format(args.format):
        run(args)


if __name__ == "__main__":
    main()
