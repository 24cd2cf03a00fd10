"""Time-step and mesh convergence of a march's amplitude (docs/model.md §12; issue 47, check d).

Given time series of the same march (``simulate_*.nc``: the same case and start, on different time
steps or meshes), prints one Markdown row per half period: the time and the peak of the signal
(``pitch`` in degrees, or ``heave`` in body lengths, about ``--level``) of each series, placed
between samples (:func:`fsistab.lco.half_period_peaks`), and each series' relative difference from
the first one given (give the finest first). ``--signal ratio``: the heave's peak over the pitch's
(radians) in each half period, divided by the heave/pitch ratio ``|ĥ/θ̂|`` of the linear mode the
march was released in (:func:`linear_mode_ratio`), so that marches on meshes whose flutter modes
differ in shape compare by what the march adds to the linear mode. Half periods are matched by
their order, and a series' peak is only compared while the two are within a tenth of a period of
each other (unless ``--by-order``). ``--offsets``: one time per series added to its times, for a
march started (``fsistab simulate --start``) from another's state at that time, on another mesh:
its time begins at zero; with ``--since`` the same time, the series are compared from there. A
last row gives each series' time step, unknowns, chord
iterations per step (over the series read) and wall time per step (of the march's last run,
``seconds_per_step``).

Usage: python validation/march_convergence.py FINEST.nc OTHER.nc [...] [--signal pitch|heave|ratio]
       [--level 0] [--labels "dt 0.025" "dt 0.05" ...] [--until T] [--by-order]
       [--offsets 0 712.5 ...] [--since 712.5]
"""

import argparse
import math

import numpy as np

from fsistab.lco import half_period_peaks
from fsistab.store import read_dataset


def linear_mode_ratio(ds) -> float:
    """``|ĥ/θ̂|`` of the mode a body released in pitch started in, from the first sample: the release
    sets ``(h, θ, ḣ, θ') = Re((ĥ, θ̂, σĥ, σθ̂))`` with ``θ̂`` real (the amplitude), so
    ``Re(ĥ/θ̂) = h/θ`` and ``Im(ĥ/θ̂) = (Re σ · h − ḣ)/(θ Im σ)`` for the mode's eigenvalue ``σ``
    (the series' ``start_growth_rate``, ``start_frequency``; a checkpoint's ``start_eigenvalue``)."""
    if ds.attrs.get("perturbation_of") != "pitch":
        raise SystemExit("--signal ratio needs marches released in pitch (--perturbation-of pitch)")
    if "start_eigenvalue" in ds:
        rate, frequency = (float(v) for v in ds["start_eigenvalue"].values)
    elif "start_growth_rate" in ds.attrs:
        rate, frequency = float(ds.attrs["start_growth_rate"]), float(ds.attrs["start_frequency"])
    else:
        raise SystemExit("--signal ratio needs marches released along an eigenmode, not from a state")
    h, theta, h_rate = (float(ds[name].values[0]) for name in ("heave", "pitch", "heave_rate"))
    return abs(complex(h / theta, (rate * h - h_rate) / (theta * frequency)))


def peaks(
    path: str, signal: str, level: float, until: float, offset: float = 0.0, since: float = -math.inf
) -> tuple[np.ndarray, np.ndarray, dict]:
    """The half-period peaks of ``signal`` over ``since``–``until`` of the series' time plus
    ``offset`` (degrees for the pitch; for ``ratio``, the heave's over the pitch's, over the linear
    mode's ratio) and the march's cost attributes."""
    ds = read_dataset(path)
    ds = ds.assign_coords(time=ds.time.values + offset)
    keep = (ds.time.values <= until) & (ds.time.values >= since - 1e-9)
    mode_ratio = linear_mode_ratio(ds) if signal == "ratio" else None
    if signal == "ratio":
        at, pitch = half_period_peaks(ds.time.values[keep], ds["pitch"].values[keep], level)
        heave = half_period_peaks(ds.time.values[keep], ds["heave"].values[keep])[1]
        n = min(len(pitch), len(heave))
        at, peak = at[:n], heave[:n] / pitch[:n] / mode_ratio
    else:
        values = ds[signal].values[keep]
        if signal == "pitch":
            values = np.degrees(values)
        at, peak = half_period_peaks(ds.time.values[keep], values, level)
    iterations = ds["chord_iterations"].values[keep][1:] if "chord_iterations" in ds else np.array([math.nan])
    cost = {
        "time_step": float(ds.attrs["time_step"]),
        # a march's checkpoint (an interrupted run) holds its state, whose length is the unknowns
        "ndof": int(ds.attrs["ndof"]) if "ndof" in ds.attrs else ds.sizes.get("current_state_0", 0),
        "iterations": float(np.mean(iterations)),
        "seconds": float(ds.attrs.get("seconds_per_step", math.nan)),
        "mode_ratio": mode_ratio,
    }
    return at, peak, cost


def table(
    series: list[tuple[np.ndarray, np.ndarray, dict]], labels: list[str], by_order: bool = False
) -> list[str]:
    """Markdown rows: per half period, each series' time and peak and its difference from the first
    (``by_order``: half periods matched by their order alone, for marches whose frequencies differ)."""
    reference_at, reference = series[0][0], series[0][1]
    period = (
        2 * float(np.median(np.diff(reference_at))) if len(reference_at) > 1 and not by_order else math.inf
    )
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
        + (f"{c['seconds']:.2f} s/step" if math.isfinite(c["seconds"]) else "s/step not recorded")
        + (f", mode's abs(h/θ) {c['mode_ratio']:.4f}" if c["mode_ratio"] else "")
        for _, _, c in series
    ]
    lines.append(f"| march | {costs[0]} | " + " | ".join(f"{c} | " for c in costs[1:]) + "|")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("series", nargs="+", help="simulate_*.nc time series, the finest first")
    parser.add_argument("--signal", choices=("pitch", "heave", "ratio"), default="pitch")
    parser.add_argument("--level", type=float, default=0.0, help="the level the half periods cross")
    parser.add_argument("--labels", nargs="+", default=None, help="one label per series")
    parser.add_argument("--until", type=float, default=math.inf, help="read the series up to this time")
    parser.add_argument("--offsets", nargs="+", type=float, default=None, help="one time per series")
    parser.add_argument("--since", type=float, default=-math.inf, help="read the series from this time")
    parser.add_argument(
        "--by-order",
        action="store_true",
        help="match half periods by their order alone (meshes or domains whose frequencies differ)",
    )
    args = parser.parse_args()
    if len(args.series) < 2:
        parser.error("give at least two series of the same march")
    labels = args.labels or [f"series {k + 1}" for k in range(len(args.series))]
    if len(labels) != len(args.series):
        parser.error(f"give one label per series ({len(args.series)}), got {len(labels)}")
    offsets = args.offsets or [0.0] * len(args.series)
    if len(offsets) != len(args.series):
        parser.error(f"give one offset per series ({len(args.series)}), got {len(offsets)}")
    series = [
        peaks(path, args.signal, args.level, args.until, offset, args.since)
        for path, offset in zip(args.series, offsets, strict=True)
    ]
    print("\n".join(table(series, labels, args.by_order)))


if __name__ == "__main__":
    main()
