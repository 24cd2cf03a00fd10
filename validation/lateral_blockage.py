"""Static slopes of the plate against the lateral extent of the domain (issue 14, item 3).

For each Reynolds number and lateral half-width ``L`` (domain ``[-20, 40] × [-L, L]`` chords,
``U = 0`` on the lateral sides, MODEL.md §4) the steady state and one real factorisation give
``dC_L/dα`` and ``d(-C_M)/dα`` about mid-chord (MODEL.md §9), on the preset's sizes fitted to
that Re (``--preset``, default ``medium``) with the far-field size ``--far``. One JSON line per
point is appended to ``--out``; a point already there is skipped (a rerun resumes).

Usage: python validation/lateral_blockage.py [--reynolds 500 2900 10000] [--lateral 20 40 80 160]
"""

import argparse
import json
import time
from pathlib import Path

from ngsolve import SetNumThreads

from fsistab.linalg import FactorCounter
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators
from fsistab.params import Domain, Flow, Plate
from fsistab.slopes import static_slopes
from fsistab.steady import solve_steady
from fsistab.store import default_cache_dir


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--reynolds", nargs="+", type=float, default=[500.0, 2900.0, 10000.0])
    parser.add_argument("--lateral", nargs="+", type=float, default=[20.0, 40.0, 80.0, 160.0])
    parser.add_argument("--preset", default="medium")
    parser.add_argument("--far", type=float, default=2.5)
    parser.add_argument("--out", default="docs/data/lateral_blockage.jsonl")
    parser.add_argument("--cache", default=None)
    args = parser.parse_args()
    SetNumThreads(1)
    out = Path(args.out)
    done = set()
    if out.exists():
        for line in out.read_text().splitlines():
            r = json.loads(line)
            done.add((r["reynolds"], r["lateral"], r["preset"], r["far"]))
    cache = Path(args.cache) if args.cache else default_cache_dir()
    for reynolds in args.reynolds:
        for lateral in args.lateral:
            if (reynolds, lateral, args.preset, args.far) in done:
                continue
            spec = mesh_spec(Plate(), args.preset, reynolds, Domain(20.0, 40.0, lateral), far=args.far)
            t0 = time.perf_counter()
            fluid = fluid_operators(solve_steady(spec, Flow(reynolds), cache_dir=cache))
            counter = FactorCounter()
            slopes = static_slopes(fluid, counter)
            record = {
                "reynolds": reynolds,
                "lateral": lateral,
                "preset": args.preset,
                "far": args.far,
                "unknowns": int(fluid.n_fluid),
                "lift_slope_alpha": slopes.lift_slope_alpha,
                "moment_slope_alpha": slopes.moment_slope_alpha,
                "drag_coefficient": float(2 * fluid.loads0[0]),
                "wall_s": time.perf_counter() - t0,
            }
            print(json.dumps(record), flush=True)
            with out.open("a") as handle:
                handle.write(json.dumps(record) + "\n")


if __name__ == "__main__":
    main()
