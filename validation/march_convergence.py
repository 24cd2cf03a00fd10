"""Time-step and mesh convergence of a march's amplitude (docs/model.md §12; issue 47, check d).

Given time series of the same march (``simulate_*.nc``: the same case and start, on different time
steps or meshes), prints one Markdown row per half period: the time and the peak of the signal
(``pitch`` in degrees, or ``heave`` in body lengths, about ``--level``) of each series, placed
between samples (:func:`fsistab.lco.half_period_peaks`), and each series' relative difference from
the first one given (give the finest first). Half periods are matched by their order, and a
series' peak is only compared while the two are within a tenth of a period of each other. A last
row gives each series' time step, unknowns, chord iterations per step (over the series read) and
wall time per step (of the march's last run, ``seconds_per_step``).

Usage: python validation/march_convergence.py FINEST.nc OTHER.nc [...] [--signal pitch|heave]
       [--level 0] [--labels "dt 0.025" "dt 0.05" ...] [--until T]
"""

import argparse
import math

import numpy as np

from fsistab.lco import half_period_peaks
from fsistab.store import read_dataset


def peaks(path: str, signal: str, level: float, until: float) -> tuple[np.ndarray, np.ndarray, dict]:
    """The half-period peaks of ``signal`` up to ``until`` (degrees for the pitch) and the march's
    cost attributes."""
    ds = read_dataset(path)
    keep = ds.time.values <= until
    values = ds[signal].values[keep]
    if signal == "pitch":
        values = np.degrees(values)
    at, peak = half_period_peaks(ds.time.values[keep], values, level)
    iterations = ds["chord_iterations"].values[keep][1:] if "chord_iterations" in ds else np.array([math.nan])
    cost = {
        "time_step": float(ds.attrs["time_step"]),
        "ndof": int(ds.attrs["ndof"]),
        "iterations": float(np.mean(iterations)),
        "seconds": float(ds.attrs.get("seconds_per_step", math.nan)),
    }
    return at, peak, cost


def table(series: list[tuple[np.ndarray, np.ndarray, dict]], labels: list[str]) -> list[str]:
    """Markdown rows: per half period, each series' time and peak and its difference from the first."""
    reference_at, reference = series[0][0], series[0][1]
    period = 2 * float(np.median(np.diff(reference_at))) if len(reference_at) > 1 else math.inf
    head = " | ".join(f"{label}: t, peak | − {labels[0]}" for label in labels[1:])
    lines = [f"| half period | {labels[0]}: t, peak | {head} |", "|---" * (2 + 2 * (len(labels) - 1)) + "|"]
    for k, (t0, p0) in enumerate(zip(reference_at, reference, strict=True)):
        cells = []
        for at, peak, _ in series[1:]:
            if k < len(peak) and abs(at[k] - t0) < 0.1 * period:
                cells.append(f"{at[k]:.2f}, {peak[k]:.4f} | {peak[k] / p0 - 1:+.2e}")
            else:
                cells.append("— | —")
        lines.append(f"| {k + 1} | {t0:.2f}, {p0:.4f} | " + " | ".join(cells) + " |")
    costs = [
        f"Δt {c['time_step']:g}, {c['ndof']} unknowns, {c['iterations']:.1f} it/step, "
        f"{c['seconds']:.2f} s/step"
        for _, _, c in series
    ]
    lines.append(f"| march | {costs[0]} | " + " | ".join(f"{c} | " for c in costs[1:]) + "|")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("series", nargs="+", help="simulate_*.nc time series, the finest first")
    parser.add_argument("--signal", choices=("pitch", "heave"), default="pitch")
    parser.add_argument("--level", type=float, default=0.0, help="the level the half periods cross")
    parser.add_argument("--labels", nargs="+", default=None, help="one label per series")
    parser.add_argument("--until", type=float, default=math.inf, help="read the series up to this time")
    args = parser.parse_args()
    if len(args.series) < 2:
        parser.error("give at least two series of the same march")
    labels = args.labels or [f"series {k + 1}" for k in range(len(args.series))]
    if len(labels) != len(args.series):
        parser.error(f"give one label per series ({len(args.series)}), got {len(labels)}")
    series = [peaks(path, args.signal, args.level, args.until) for path in args.series]
    print("\n".join(table(series, labels)))


if __name__ == "__main__":
    main()
