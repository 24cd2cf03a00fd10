"""Heaving spring-mounted cylinder at Re = 60, m = 20: the fluid and solid eigenvalue branches against U*.

Shows the growth rate and frequency of the two branches of the heaving cylinder (docs/model.md §10:
heave only, ``m = 4m̃/(πρD²s)``, ``U* = 2πU∞/(Dω_n)``) followed along U* in [3, 12]
(``fsistab.critical.find_thresholds``: the solid branch from the in-vacuo frequency, the fluid
branch from the wake mode near 0.75i), with the potential-flow estimate (2π/U*)√(m/(m+1)) of the
solid frequency and the fixed cylinder's wake frequency dashed, and the thresholds where a branch
changes stability.

Command-line equivalent (thresholds only, no figure)::

    fsistab critical --body cylinder --Re 60 --mass-ratio 20 --reduced-velocity-range 3 12 \\
        --points 36 --wake-shift 0.75j --method tracking --mesh coarse

Mesh: ``--mesh`` preset (default coarse). Reference (the cylinder references of docs/validation.md; for the
fixed cylinder: σ = 0.046839 + 0.74518i at Re = 60): two branches, a fluid mode tending to the fixed
cylinder's mode as U* → 0 and a solid mode near (2π/U*)√(m/(m+1)) away from the coincidence
U* ≈ 8; near coincidence the branches interact and one of them is unstable over a range of U*.

Usage: python examples/plot_heaving_cylinder.py [--mesh coarse] [--out DIR] [--points 36]
"""

import argparse
import math
from pathlib import Path

MASS_RATIO = 20.0  # docs/model.md §10 convention


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
    parser.add_argument("--points", type=int, default=36, help="values of U* in [3, 12] (log-spaced)")
    return parser.parse_args(argv)


def run(args: argparse.Namespace) -> None:
    import numpy as np
    import xarray as xr

    from fsistab.critical import find_thresholds
    from fsistab.linalg import FactorCounter
    from fsistab.mesh import spec_for
    from fsistab.operators import fluid_operators
    from fsistab.params import Case, Solid, body_velocity_scale
    from fsistab.plots import plot_branches
    from fsistab.steady import solve_steady
    from fsistab.store import default_cache_dir

    case = Case.create("cylinder", 60.0, 0.0, args.mesh)
    steady = solve_steady(spec_for(case), case.flow, cache_dir=args.cache or default_cache_dir())
    fluid = fluid_operators(steady)
    velocities = np.geomspace(3.0, 12.0, args.points)  # docs/model.md §10 convention
    scale = body_velocity_scale("cylinder")  # the generic U* of fsistab.params.Solid is U*/2π
    solid = Solid.cylinder(MASS_RATIO, velocities[0])
    counter = FactorCounter()
    thresholds, details = find_thresholds(  # tracking: the two branches are drawn
        fluid, solid, velocities / scale, wake_shift=0.75j, counter=counter, method="tracking"
    )
    branches = details["branches"]

    names = {"heave": "solid", "wake": "fluid"}
    values = np.array([branches[name].values for name in names]).T  # (velocity, branch)
    ds = xr.Dataset(
        {"growth_rate": (("reduced_velocity", "branch"), values.real),
         "frequency": (("reduced_velocity", "branch"), values.imag)},
        coords={"reduced_velocity": velocities, "branch": list(names.values())},
    )  # fmt: skip
    for t in thresholds:
        print(
            f"{t.branch:6s} branch: {t.boundary:15s} at U* = {t.reduced_velocity * scale:.4f}, "
            f"ω = {t.frequency:.5f}"
        )
    fixed = values[0, 1]
    print(f"fluid branch at U* = {velocities[0]:g}: σ = {fixed.real:+.5f} + {fixed.imag:.5f}i")
    print(f"{counter.count} factorisations")
    args.out.mkdir(parents=True, exist_ok=True)
    figure = plot_branches(
        ds,
        args.out / f"heaving_cylinder_Re60_m20_{args.mesh}.png",
        reference_lines={
            "(2π/U*)√(m/(m+1))": 2 * np.pi / velocities * math.sqrt(MASS_RATIO / (MASS_RATIO + 1)),
            "fixed cylinder, the fixed-cylinder references of docs/validation.md": 0.74518,
        },
        title=f"heaving cylinder, Re = 60, m = 20, {args.mesh} mesh (filled: unstable)",
    )
    print(f"figure: {figure}")


def main(argv=None) -> None:
    args = parse_args(argv)
    from fsistab.plots import figure_format

    with figure_format(args.format):
        run(args)


if __name__ == "__main__":
    main()
