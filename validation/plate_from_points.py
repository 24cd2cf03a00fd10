"""The plate given as a points file against the built-in plate: drag and static slopes (docs/validation.md,
"A plate read from points").

The built-in plate (rounded rectangle, chord/thickness 20, corner radius e/10) is written as points:
21 on each long side, 5 on each short side, 9 on each corner arc (the arcs' ends included), read as
a curve (fsistab.bodies.Curve: straight sides as lines, the arcs splined tangent to them) and meshed
with the same preset. Prints a markdown table of C_D at α0 = 0 and the static slopes dC_L/dθ,
dC_M/dθ (fsistab.slopes) of both bodies and their relative differences.

Usage: python validation/plate_from_points.py [--preset coarse] [--Re 1000 2900] [--cache DIR]
"""

import argparse
import math
import tempfile
from pathlib import Path

import numpy as np

from fsistab.bodies import Curve, Plate
from fsistab.forces import aerodynamic_coefficients
from fsistab.linalg import FactorCounter
from fsistab.mesh import build_mesh, mesh_spec, mesh_statistics
from fsistab.operators import fluid_operators
from fsistab.params import Flow
from fsistab.slopes import static_slopes
from fsistab.steady import solve_steady
from fsistab.store import default_cache_dir


def plate_points(aspect_ratio=20.0, corner_radius=0.1, side=21, short=5, arc=9) -> np.ndarray:
    """The plate's outline, counter-clockwise from its lower long side (as tests/test_bodies.py)."""
    e = 1 / aspect_ratio
    r, h = corner_radius * e, e / 2
    points = []
    for start, end, n, centre, angle in (
        ((-0.5 + r, -h), (0.5 - r, -h), side, (0.5 - r, -h + r), -math.pi / 2),
        ((0.5, -h + r), (0.5, h - r), short, (0.5 - r, h - r), 0.0),
        ((0.5 - r, h), (-0.5 + r, h), side, (-0.5 + r, h - r), math.pi / 2),
        ((-0.5, h - r), (-0.5, -h + r), short, (-0.5 + r, -h + r), math.pi),
    ):
        points += [np.array(start) + (np.array(end) - np.array(start)) * t for t in np.linspace(0, 1, n)[:-1]]
        points += [
            np.array(centre) + r * np.array([math.cos(a), math.sin(a)])
            for a in np.linspace(angle, angle + math.pi / 2, arc)[:-1]
        ]
    return np.array(points)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--preset", default="coarse")
    parser.add_argument("--Re", type=float, nargs="+", default=[1000.0, 2900.0])
    parser.add_argument("--cache", default=None)
    args = parser.parse_args()
    cache = args.cache or default_cache_dir()
    with tempfile.TemporaryDirectory() as scratch:
        path = Path(scratch) / "plate.csv"
        path.write_text("x,y\n" + "\n".join(f"{x!r},{y!r}" for x, y in plate_points().tolist()) + "\n")
        curve = Curve.read(path)
    print("| Re | body | unknowns | C_D | dC_L/dθ | dC_M/dθ |")
    print("|---|---|---|---|---|---|")
    for reynolds in args.Re:
        rows = []
        for name, body in (("plate", Plate()), ("points", curve)):
            spec = mesh_spec(body, args.preset, reynolds)
            steady = solve_steady(spec, Flow(reynolds, 0.0), cache_dir=cache)
            slopes = static_slopes(fluid_operators(steady), FactorCounter())
            values = (aerodynamic_coefficients(steady).drag, slopes.lift, slopes.moment)
            ndof = mesh_statistics(build_mesh(spec, cache))["ndof"]
            rows.append(values)
            print(f"| {reynolds:g} | {name} | {ndof} | {values[0]:.5f} | {values[1]:.4f} | {values[2]:.4f} |")
        change = " | ".join(f"{100 * (b / a - 1):+.2f} %" for a, b in zip(*rows, strict=True))
        print(f"| {reynolds:g} | difference | | {change} |")


if __name__ == "__main__":
    main()
