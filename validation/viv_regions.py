"""The VIV regions of the default map at Re 2900 against the wake mode's damping (issue 45, item 3).

Draws the VIV curves of the default map (``docs/data/neutral_medium_far2_default``) in the
``(U*, m)`` plane and, as bars at their mass ratios, the VIV windows that
``discretisation_study.py VARIANT --viv M U_MIN U_MAX`` found on each variant (JSON lines, one
record per variant): the default mesh and the domain lengths that move the wake mode's critical Re
most (docs/discretisation.md, "The outlet condition and the domain length"). A window runs from an
``onset`` to the next ``restabilisation`` in U*.

Usage: python validation/viv_regions.py RECORDS.jsonl [...] --figure PNG [--variants NAME ...]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import xarray as xr  # noqa: E402

MAP = Path("docs/data/neutral_medium_far2_default/neutral_plate_Re2900_a0_map.nc")


def windows(thresholds: list) -> list[tuple[float, float]]:
    """``[(U*_low, U*_high)]`` where at least one mode is unstable, from a sweep's thresholds
    ``[U*, ω, kind, boundary]``: the count of unstable modes goes up at an ``onset`` and down at a
    ``restabilisation``. A restabilisation that finds the count at zero follows an onset the sweep
    missed (a crossing in an interval it left unresolved, or one of two crossings too close to
    separate): it extends the window before it."""
    found, count, start = [], 0, None
    for velocity, _, kind, boundary in sorted(thresholds):
        if kind != "viv":
            continue
        if boundary == "onset":
            count += 1
            start = velocity if count == 1 else start
        elif boundary == "restabilisation" and count > 0:
            count -= 1
            if count == 0:
                found.append((start, velocity))
        elif boundary == "restabilisation" and found:
            found[-1] = (found[-1][0], velocity)
    return found


def draw(records: list[dict], path: Path) -> None:
    """The map's VIV curves and each record's windows (offset in m so that they do not overlap)."""
    ds = xr.open_dataset(MAP)
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for k, kind in enumerate(ds.curve_kind.values):
        if kind != "viv":
            continue
        on = ds.curve.values == k
        ax.plot(ds.curve_reduced_velocity.values[on], ds.curve_mass_ratio.values[on], "k-", lw=0.8)
    for shift, record in enumerate(records):
        colour, label = f"C{shift}", f"{record['variant']} ({record['unknowns']:,})"
        for sweep in record["sweeps"]:
            level = sweep["mass_ratio"] * 1.08**shift
            for low, high in windows(sweep["thresholds"]):
                ax.plot([low, high], [level, level], "-", color=colour, lw=3, label=label)
                label = None
    ax.set_yscale("log")
    ax.set_xlim(0.035, 0.1)
    ax.set_xlabel(r"$U^*$")
    ax.set_ylabel(r"mass ratio $m$")
    ax.set_title("Re 2900: VIV curves of the default map (black), windows per mesh")
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=130)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("records", nargs="+", type=Path)
    parser.add_argument("--figure", type=Path, required=True)
    parser.add_argument(
        "--variants", nargs="*", default=None, help="draw these records only (all by default)"
    )
    args = parser.parse_args()
    records = [json.loads(line) for p in args.records for line in p.read_text().splitlines() if line.strip()]
    for record in records:
        for sweep in record["sweeps"]:
            print(record["variant"], sweep["mass_ratio"], windows(sweep["thresholds"]), sweep["unresolved"])
    draw([r for r in records if args.variants is None or r["variant"] in args.variants], args.figure)


if __name__ == "__main__":
    main()
