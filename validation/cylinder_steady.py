"""Steady flow past the fixed cylinder against published values (diameter-based units).

Drag coefficient at Re = 40 ≈ 1.50–1.54 (Fornberg; Dennis & Chang), recirculation length from the
rear ≈ 2.2–2.3 at Re = 40 and 2.9–3.0 at Re = 50 (Giannetti & Luchini 2007); docs/validation.md,
"Fixed cylinder: steady flow".

Mesh convergence (presets on the default domain) and domain convergence (medium preset): drag
coefficient at Re = 40 (reaction force and surface integral) and recirculation length at Re = 40
and 50. Prints a Markdown table; ``--write docs/validation.md`` puts it between the markers
``<!-- cylinder-steady:begin -->`` and ``<!-- cylinder-steady:end -->``.
"""

import argparse
import re
import time
from pathlib import Path

from ngsolve import SetNumThreads

from fsistab.bodies import Cylinder
from fsistab.forces import aerodynamic_coefficients, recirculation_length, surface_coefficients
from fsistab.mesh import mesh_spec
from fsistab.params import Domain, Flow
from fsistab.steady import solve_steady


def row(preset: str, domain: Domain | None) -> str:
    t0 = time.perf_counter()
    spec40 = mesh_spec(Cylinder(), preset, 40, domain)
    at40 = solve_steady(spec40, Flow(40))
    at50 = solve_steady(mesh_spec(Cylinder(), preset, 50, domain), Flow(50))
    d = spec40.domain
    return (
        f"| {preset} | [-{d.upstream:g}, {d.downstream:g}] × [-{d.lateral:g}, {d.lateral:g}] | {at40.ndof} | "
        f"{aerodynamic_coefficients(at40).drag:.4f} | {surface_coefficients(at40).drag:.4f} | "
        f"{recirculation_length(at40):.3f} | {recirculation_length(at50):.3f} | "
        f"{time.perf_counter() - t0:.0f} |"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="coarse and medium meshes, two domains")
    parser.add_argument("--write", type=Path, default=None)
    args = parser.parse_args()
    SetNumThreads(2)
    lines = [
        "Steady cylinder, `python validation/cylinder_steady.py` (reference: C_D 1.50–1.54 at Re 40;",
        "L_r 2.2–2.3 at Re 40 and 2.9–3.0 at Re 50, from the rear of the cylinder).",
        "",
        "| mesh | domain | unknowns (Re 40) | C_D reaction | C_D surface | L_r Re 40 | L_r Re 50 | t [s] |",
        "|---|---|---|---|---|---|---|---|",
    ]
    presets = ["coarse", "medium"] if args.quick else ["coarse", "medium", "fine"]
    domains = [Domain(25, 50, 25), None] if args.quick else [Domain(25, 50, 25), None, Domain(80, 160, 80)]
    for preset in presets:
        lines.append(row(preset, None))
        print(lines[-1], flush=True)
    for domain in domains:
        if domain is not None:
            lines.append(row("medium", domain))
            print(lines[-1], flush=True)
    table = "\n".join(lines)
    if args.write:
        text = args.write.read_text()
        block = f"<!-- cylinder-steady:begin -->\n{table}\n<!-- cylinder-steady:end -->"
        text = re.sub(
            r"<!-- cylinder-steady:begin -->.*?<!-- cylinder-steady:end -->", block, text, flags=re.S
        )
        args.write.write_text(text)


if __name__ == "__main__":
    main()
