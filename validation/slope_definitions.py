"""What could move the plate's static slopes by a few per cent: definitions, geometry, method.

Issue 45, item 4; reported in docs/validation.md ("Plate: what moves the static slopes"). On one
mesh preset fitted to each Re, at α0 = 0 unless stated, each row changes one thing against the
tangent slopes of :func:`fsistab.slopes.static_slopes` (docs/model.md §9: the lift in the
free-stream axes, the moment about mid-chord, per radian of α = -θ):

* ``normal``: the slope of the body-axis normal force ``2F_Y`` instead of the lift. At α0 = 0
  ``dC_L/dα = dC_N/dα - C_D``: a paper that integrates the pressure normal to the plate, or
  takes the force in plate axes, reports the larger value;
* ``secant-ALPHA``: ``C_L(α)/α`` and ``-C_M(α)/α`` from the steady state at α = ALPHA degrees
  (continued from 0), the slope of a polar read at a finite angle; ``fit-4`` is the least-squares
  line through α = 0, 1, 2, 3, 4° (``C_L(0) = 0`` by symmetry);
* ``corner-R``: the plate with corner radius ``R`` (relative to the thickness; ours is 0.1; 0.45 is
  nearly a fully rounded end), tangent slopes.

Usage: python validation/slope_definitions.py [--preset coarse] [--Re 500 1000 2900] [--angles 1 2 ...]
       [--out FILE]
One JSON line per (Re, row) is appended to --out (rows already there are skipped, so a rerun
resumes); the markdown table is printed from the whole file.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np
from ngsolve import SetNumThreads

from fsistab.bodies import Plate
from fsistab.forces import aerodynamic_coefficients
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators
from fsistab.params import Flow
from fsistab.slopes import static_slopes
from fsistab.steady import solve_steady
from fsistab.store import default_cache_dir

SECANT_ANGLES = (1.0, 2.0, 3.0, 4.0, 6.0)  # degrees
CORNERS = (0.02, 0.45)


def tangent(body: Plate, preset: str, reynolds: float, cache: Path) -> dict:
    """Tangent slopes and the steady drag at α0 = 0 on ``body``."""
    steady = solve_steady(mesh_spec(body, preset, reynolds), Flow(reynolds), cache_dir=cache)
    slopes = static_slopes(fluid_operators(steady))
    return {
        "lift": slopes.lift_slope_alpha,
        "moment": slopes.moment_slope_alpha,
        "normal": -slopes.normal,
        "drag": slopes.steady_drag,
        "unknowns": int(sum(steady.space.FreeDofs())),
    }


def polar(preset: str, reynolds: float, cache: Path, angles) -> dict[float, tuple[float, float]]:
    """``α: (C_L, -C_M)`` at 0 and ``angles`` (degrees), steady states continued in α from 0."""
    spec, steady, loads = mesh_spec(Plate(), preset, reynolds), None, {}
    for angle in (0.0, *angles):
        steady = solve_steady(spec, Flow(reynolds, angle), cache_dir=cache, initial=steady)
        c = aerodynamic_coefficients(steady)
        loads[angle] = (c.lift, -c.moment)
    return loads


def rows_at(preset: str, reynolds: float, cache: Path, angles=SECANT_ANGLES) -> list[dict]:
    """Every row of the module docstring at ``reynolds``, the secants at ``angles``."""
    base = tangent(Plate(), preset, reynolds, cache)
    rows = [{"row": "tangent", **base}]
    rows.append({"row": "normal", "lift": base["normal"], "moment": base["moment"]})
    loads = polar(preset, reynolds, cache, angles)
    for angle in angles:
        radians = math.radians(angle)
        lift, moment = loads[angle]
        rows.append({"row": f"secant-{angle:g}", "lift": lift / radians, "moment": moment / radians})
    if {1.0, 2.0, 3.0, 4.0} <= set(loads):
        fit = [a for a in loads if a <= 4.0]
        x = np.radians(fit)
        lift, moment = (float(np.dot(x, [loads[a][i] for a in fit]) / np.dot(x, x)) for i in (0, 1))
        rows.append({"row": "fit-4", "lift": lift, "moment": moment})
    for radius in CORNERS:
        rows.append(
            {"row": f"corner-{radius:g}", **tangent(Plate(corner_radius=radius), preset, reynolds, cache)}
        )
    return rows


def table(records: list[dict]) -> str:
    """Markdown: each row's slopes and their change from the tangent slopes of its (preset, Re)."""
    lines = [
        "| Re | mesh | row | $dC_L/d\\alpha$ | change | $d(-C_M)/d\\alpha$ | change |",
        "|---|---|---|---|---|---|---|",
    ]
    base = {(r["preset"], r["reynolds"]): r for r in records if r["row"] == "tangent"}
    for r in records:
        ref = base[(r["preset"], r["reynolds"])]
        change = [100 * (r[k] / ref[k] - 1) for k in ("lift", "moment")]
        lines.append(
            f"| {r['reynolds']:g} | {r['preset']} | {r['row']} | {r['lift']:.4f} | {change[0]:+.2f} % "
            f"| {r['moment']:.4f} | {change[1]:+.2f} % |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--preset", default="coarse")
    parser.add_argument("--Re", dest="reynolds", type=float, nargs="+", default=[500.0, 1000.0, 2900.0])
    parser.add_argument("--out", type=Path, default=Path("docs/data/slope_definitions.jsonl"))
    parser.add_argument("--cache", type=Path, default=None)
    parser.add_argument("--angles", type=float, nargs="+", default=list(SECANT_ANGLES), help="the secants' α")
    args = parser.parse_args()
    if not all(re > 0 for re in args.reynolds) or not all(0 < a < 90 for a in args.angles):
        parser.error(
            f"--Re must be positive and --angles in (0, 90) degrees, got {args.reynolds}, {args.angles}"
        )
    SetNumThreads(1)
    cache = args.cache or default_cache_dir()
    records = [json.loads(line) for line in args.out.read_text().splitlines()] if args.out.exists() else []
    done = {(r["preset"], r["reynolds"]) for r in records}
    for reynolds in args.reynolds:
        if (args.preset, reynolds) in done:
            continue
        t0 = time.perf_counter()
        rows = [
            {"preset": args.preset, "reynolds": reynolds, **row}
            for row in rows_at(args.preset, reynolds, cache, args.angles)
        ]
        rows[0]["seconds"] = time.perf_counter() - t0
        with args.out.open("a") as handle:
            handle.writelines(json.dumps(row) + "\n" for row in rows)
        records += rows
        print(f"Re {reynolds:g}: {time.perf_counter() - t0:.0f} s", flush=True)
    print(table(records))


if __name__ == "__main__":
    main()
