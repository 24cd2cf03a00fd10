"""Static slopes of the plate against the lateral extent of the domain (docs/discretisation.md).

For each Reynolds number and lateral half-width ``L`` (domain ``[-U, D] × [-L, L]`` chords,
``--upstream U`` and ``--downstream D``, default 20 and 40; ``U = 0`` on the lateral sides,
docs/model.md §4) the steady state and one real factorisation give ``dC_L/dα`` and ``d(-C_M)/dα``
about mid-chord (docs/model.md §9), on the preset's sizes fitted to that Re (``--preset``, default
``medium``) with the far-field size ``--far`` (the preset's own sizes, middle box and wake band
included, with ``--far preset``), and any scalar size changed by ``--size NAME=VALUE`` (as in
``sponge_check.py``; the point's record keeps them under ``sizes``). ``--sponge`` gives every
domain the preset's outlet sponge (it enters the linear operator, hence the slopes): with
``--upstream 80 --downstream 160 --far preset --sponge`` the point ``L = 80`` is the default
``medium`` mesh itself.
One JSON line per point is appended to ``--out``; a point already there is skipped (a rerun resumes).

Usage: python validation/lateral_blockage.py [--reynolds 500 2900 10000] [--lateral 20 40 80 160]
       python validation/lateral_blockage.py --upstream 80 --downstream 160 --far preset --sponge \
           --lateral 80 160 320 640
"""

import argparse
import json
import time
from pathlib import Path

from ngsolve import SetNumThreads
from sponge_check import add_size_option, size_item  # the sibling script's (run from validation/)

from fsistab.bodies import Plate
from fsistab.linalg import FactorCounter
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators
from fsistab.params import Domain, Flow, default_sponge
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
    parser.add_argument("--far", default="2.5", help="far-field element size, or 'preset'")
    parser.add_argument("--upstream", type=float, default=20.0)
    parser.add_argument("--downstream", type=float, default=40.0)
    parser.add_argument("--sponge", action="store_true", help="the preset's outlet sponge on every domain")
    parser.add_argument("--out", default="docs/data/lateral_blockage.jsonl")
    parser.add_argument("--cache", default=None)
    add_size_option(parser)
    args = parser.parse_args()
    changed = dict(size_item(item) for item in args.size)  # bad input refused before any mesh
    SetNumThreads(1)
    out = Path(args.out)
    done = set()
    if out.exists():
        for line in out.read_text().splitlines():
            r = json.loads(line)
            shape = (r.get("upstream", 20.0), r.get("downstream", 40.0), r.get("sponge", False))
            done.add((r["reynolds"], r["lateral"], r["preset"], r["far"], *shape, str(r.get("sizes", {}))))
    cache = Path(args.cache) if args.cache else default_cache_dir()
    far_label = args.far if args.far == "preset" else float(args.far)
    sizes = {**({} if args.far == "preset" else {"far": float(args.far)}), **changed}
    for reynolds in args.reynolds:
        for lateral in args.lateral:
            shape = (args.upstream, args.downstream, args.sponge)
            if (reynolds, lateral, args.preset, far_label, *shape, str(changed)) in done:
                continue
            domain = Domain(args.upstream, args.downstream, lateral)
            sponge = default_sponge(Plate(), args.preset) if args.sponge else None
            spec = mesh_spec(Plate(), args.preset, reynolds, domain, sponge, **sizes)
            t0 = time.perf_counter()
            fluid = fluid_operators(solve_steady(spec, Flow(reynolds), cache_dir=cache))
            counter = FactorCounter()
            slopes = static_slopes(fluid, counter)
            record = {
                "reynolds": reynolds,
                "lateral": lateral,
                "preset": args.preset,
                "far": far_label,
                "upstream": args.upstream,
                "downstream": args.downstream,
                "sponge": args.sponge,
                **({"sizes": changed} if changed else {}),
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
