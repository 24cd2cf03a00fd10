"""Steady NACA 0012 at Re 1000: C_L and C_D against published values (docs/validation.md, "NACA 0012,
Re 1000: steady coefficients").

Reference: T. Kouser, Y. Xiong, D. Yang & S. Peng, "Direct numerical simulations on the
three-dimensional wake transition of flows over NACA0012 airfoil at Re = 1000", Int. J. Micro Air
Vehicles 13 (2021), doi:10.1177/17568293211055656 — their time-averaged C_L and C_D against α, as
digitised from their figure in the Lethe example "Flow around NACA0012 at low Reynolds number"
(chaos-polymtl/lethe, examples/incompressible-flow/2d-naca0012-low-reynolds/postprocessing.py).
Up to α ≈ 8° the flow is steady (Kurtulus 2015 observes shedding from about 8°), so the steady
solution is the time average.

Each α is continued from the previous one on one mesh (the preset fitted to Re 1000, closed
trailing edge). Prints a markdown table; writes nothing else.

Usage: python validation/naca0012_steady.py [--preset coarse] [--cache DIR]
"""

import argparse
import time

from fsistab.bodies import Airfoil
from fsistab.forces import aerodynamic_coefficients
from fsistab.mesh import build_mesh, mesh_spec, mesh_statistics
from fsistab.params import Flow
from fsistab.steady import solve_steady
from fsistab.store import default_cache_dir

# (α in degrees, C_L, C_D) of Kouser et al. (2021), digitised (see above); α ≤ 8°: steady flow
KOUSER_2021 = (
    (0.0, 0.0, 0.12118),
    (5.0530, 0.24741, 0.12959),
    (7.0233, 0.30295, 0.13801),
    (8.0403, 0.31978, 0.14137),
)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--preset", default="coarse")
    parser.add_argument("--cache", default=None)
    args = parser.parse_args()
    cache = args.cache or default_cache_dir()
    spec = mesh_spec(Airfoil("naca0012"), args.preset, 1000.0)
    ndof = mesh_statistics(build_mesh(spec, cache))["ndof"]
    print(f"NACA 0012, Re 1000, mesh {args.preset} ({ndof} unknowns)\n")
    print("| α (°) | C_L ref | C_L | error | C_D ref | C_D | error | s |")
    print("|---|---|---|---|---|---|---|---|")
    previous = None
    for alpha, lift, drag in KOUSER_2021:
        t0 = time.perf_counter()
        steady = solve_steady(spec, Flow(1000.0, alpha), cache_dir=cache, initial=previous)
        previous = steady
        c = aerodynamic_coefficients(steady)
        lift_error = "—" if lift == 0 else f"{100 * (c.lift / lift - 1):+.1f} %"
        print(
            f"| {alpha:.2f} | {lift:.4f} | {c.lift:.4f} | {lift_error} | {drag:.4f} | {c.drag:.4f} "
            f"| {100 * (c.drag / drag - 1):+.1f} % | {time.perf_counter() - t0:.0f} |"
        )


if __name__ == "__main__":
    main()
