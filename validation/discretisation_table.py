"""Tables of the discretisation study (validation/discretisation_study.py): one row per variant,
each quantity with its change against a reference variant (the last argument, default the most
refined one in the file).

Usage: python validation/discretisation_table.py [FILE] [--reference VARIANT]
"""

import argparse
import json
from pathlib import Path

QUANTITIES = (
    ("flutter_velocity_m1000", "U*_F (m=1000)"),
    ("flutter_frequency_m1000", "ω_F"),
    ("divergence_velocity_m1000", "U*_D (m=1000)"),
    ("lift_slope_alpha", "dC_L/dα"),
    ("moment_slope_alpha", "d(-C_M)/dα"),
    ("drag_coefficient", "C_D"),
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("file", nargs="?", default="docs/data/discretisation_Re2900.jsonl")
    parser.add_argument("--reference", default=None)
    args = parser.parse_args()
    records = [json.loads(line) for line in Path(args.file).read_text().splitlines() if line.strip()]
    by_name = {r["variant"]: r for r in records}
    reference = by_name[args.reference] if args.reference else max(records, key=lambda r: r["unknowns"])
    print(f"reference: {reference['variant']} ({reference['unknowns']} unknowns)\n")
    header = "| variant | unknowns | " + " | ".join(label for _, label in QUANTITIES)
    print(header + " | wake mode σ | factorisations | wall (s) |")
    print("|" + "---|" * (len(QUANTITIES) + 5))
    for r in records:
        cells = []
        for key, _ in QUANTITIES:
            if r[key] != r[key]:  # NaN: the flutter Newton did not converge on this mesh
                cells.append("no convergence")
                continue
            change = (r[key] - reference[key]) / abs(reference[key]) * 100
            cells.append(f"{r[key]:.5g} ({change:+.2f} %)")
        # a wake mode only from the runs that identify it by its energy in the wake box
        wake = complex(*r["wake_mode"]) if r.get("wake_mode") else None
        wake_cell = "—" if wake is None else f"{wake.real:+.4f} {wake.imag:+.4f}i"
        print(
            f"| {r['variant']} | {r['unknowns']} | "
            + " | ".join(cells)
            + f" | {wake_cell} | {r['factorisations']} | {r['wall_s']:.0f} |"
        )


if __name__ == "__main__":
    main()
