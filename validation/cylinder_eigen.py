"""Leading wake mode of the fixed cylinder against StabFem's values (diameter-based units).

For Re = 50, 60, 100 and each requested domain, prints the eigenvalue nearest the reference, the
growth-rate difference and the relative frequency difference, unknowns and wall time.
Usage: python validation/cylinder_eigen.py [--preset medium] [--domain UP DOWN LAT ...]
"""

import argparse
import time

from ngsolve import SetNumThreads

from fsistab.bodies import Cylinder
from fsistab.coupled import CoupledSystem
from fsistab.eigen import eigenpairs_near
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators
from fsistab.params import Domain, Flow, Solid
from fsistab.steady import solve_steady

# σ = λ + iω of the leading global mode (StabFem, Fabre et al.; half domain [-40, 80] × [0, 40],
# adapted mesh; docs/validation.md, "Fixed cylinder: leading global mode")
REFERENCE = {
    50: 0.013206 + 0.73761j,
    60: 0.046839 + 0.74518j,
    80: 0.093519 + 0.74271j,
    100: 0.12265 + 0.72595j,
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--preset", default="medium")
    parser.add_argument("--domain", nargs=3, type=float, action="append", metavar=("UP", "DOWN", "LAT"))
    parser.add_argument("--reynolds", nargs="+", type=int, default=[50, 60, 100])
    parser.add_argument("--cache", default=None)
    args = parser.parse_args()
    SetNumThreads(2)
    print("| domain | Re | unknowns | σ computed | Δλ | Δω/ω | time [s] |")
    print("|---|---|---|---|---|---|---|")
    for extents in args.domain or [None]:
        domain = Domain(*extents) if extents else None
        for reynolds in args.reynolds:
            reference = REFERENCE[reynolds]
            t0 = time.perf_counter()
            spec = mesh_spec(Cylinder(), args.preset, reynolds, domain)
            steady = solve_steady(spec, Flow(reynolds), cache_dir=args.cache)
            system = CoupledSystem(fluid_operators(steady), Solid(dofs=()))
            pairs = eigenpairs_near(system, [reference + 0.01j], 3)
            sigma = min(pairs, key=lambda p: abs(p.value - reference)).value
            d = spec.domain
            print(
                f"| [-{d.upstream:g}, {d.downstream:g}] × [-{d.lateral:g}, {d.lateral:g}] | {reynolds} | "
                f"{system.size} | {sigma.real:.5f} + {sigma.imag:.5f}i | "
                f"{sigma.real - reference.real:+.5f} | "
                f"{sigma.imag / reference.imag - 1:+.2%} | {time.perf_counter() - t0:.0f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
