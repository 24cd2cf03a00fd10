"""The limit cycle a long march settles on, from its envelope (docs/simulation.md, check d; issue 47).

Near a stable limit cycle the half-period peaks of the pitch and the heave settle as a slow, decaying
modulation about the cycle's amplitude: ``A(t) → A∞ + Re(b e^{(λ + iΩ)t})``, the cycle's slowest
Floquet pair (:func:`fsistab.lco.envelope_limit`). Given a march's time series (``simulate_*.nc``,
or its checkpoint while it runs), this prints, for the pitch (degrees) and the heave (body lengths):

* the fit from each ``--since`` time to the end: ``A∞`` and its standard error, the modulation's
  rate λ and period ``2π/Ω``, the residual and the modulation's size at the end, so that the spread
  of ``A∞`` over windows shows how far the estimate depends on where the fit starts;
* with ``--predict-from T``: the fit from the first ``--since`` to ``T`` only, and its largest
  error on the peaks measured after ``T``: the extrapolation tested against the march itself.

``--figure`` draws the peaks of every series given (other meshes' marches, placed in time by
``--offsets`` as in ``validation/march_convergence.py``, or marches at other U*) with the first
series' envelope fitted from the first ``--since``; without ``--since``, the peaks alone (an
envelope that wanders rather than settles has no limit to fit).

Usage: python validation/march_envelope.py SERIES.nc [OTHER.nc ...] [--since 300 400 500]
       [--predict-from 600 700] [--labels ...] [--offsets 0 712.5 ...] [--figure F.png]
"""

import argparse
import math

import numpy as np

from fsistab.lco import envelope_limit, half_period_peaks
from fsistab.store import read_dataset

SIGNALS = {"pitch": ("θ peak (degrees)", np.degrees), "heave": ("|h| peak (chords)", lambda v: v)}


def peaks(path: str, offset: float = 0.0) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The half-period peaks of the pitch (degrees) and the heave, at the series' times plus
    ``offset``."""
    ds = read_dataset(path)
    times = ds.time.values + offset
    result = {}
    for name, (_, scale) in SIGNALS.items():
        at, peak = half_period_peaks(times, scale(ds[name].values))
        result[name] = (at, peak)
    return result


def fit_rows(series: dict, since: list[float]) -> list[str]:
    """One Markdown row per signal and fit window."""
    lines = [
        "| signal | peaks fitted (t) | A∞ ± standard error | λ | modulation period | rms | swing at end |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, (at, peak) in series.items():
        for start in since:
            keep = at >= start
            e = envelope_limit(at[keep], peak[keep])
            lines.append(
                f"| {name} | {e.count} ({e.start:.0f}–{e.end:.0f}) | {e.limit:.4f} ± {e.limit_error:.2g} "
                f"| {e.rate:+.2e} | {2 * math.pi / e.frequency:.0f} | {e.rms:.1e} | {e.swing:.4f} |"
            )
    return lines


def prediction_rows(series: dict, since: float, ends: list[float]) -> list[str]:
    """One Markdown row per signal and fit end: the fit's largest error on the later peaks."""
    lines = [
        "| signal | fitted (t) | A∞ | peaks predicted (t) | largest error | relative |",
        "|---|---|---|---|---|---|",
    ]
    for name, (at, peak) in series.items():
        for end in ends:
            fitted, later = (at >= since) & (at <= end), at > end
            if not later.any():
                continue
            e = envelope_limit(at[fitted], peak[fitted])
            error = e(at[later]) - peak[later]
            worst = int(np.argmax(np.abs(error)))
            lines.append(
                f"| {name} | {since:.0f}–{end:.0f} | {e.limit:.4f} | {later.sum()} ({at[later][0]:.0f}–"
                f"{at[later][-1]:.0f}) | {error[worst]:+.4f} | {error[worst] / peak[later][worst]:+.2%} |"
            )
    return lines


def draw(all_series: list[dict], labels: list[str], since: float | None, path: str) -> None:
    """The peaks of every series and, given ``since``, the first one's envelope fitted from it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for ax, (name, (ylabel, _)) in zip(axes, SIGNALS.items(), strict=True):
        for k, (series, label) in enumerate(zip(all_series, labels, strict=True)):
            at, peak = series[name]
            style = {"marker": ".", "lw": 0.8} if k == 0 else {"marker": "x", "lw": 0.4, "ms": 4}
            ax.plot(at, peak, label=label, **style)
        if since is not None:
            draw_envelope(ax, *all_series[0][name], since)
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("time (chords / U∞)")
    fig.tight_layout()
    fig.savefig(path, dpi=150)


def draw_envelope(ax, at: np.ndarray, peak: np.ndarray, since: float) -> None:
    """The envelope fitted to the peaks from ``since`` and its limit A∞."""
    keep = at >= since
    e = envelope_limit(at[keep], peak[keep])
    t = np.linspace(e.start, e.end, 400)
    ax.plot(t, e(t), "k--", lw=0.8, label=f"envelope fitted from t = {since:g}")
    ax.axhline(e.limit, color="grey", lw=0.6, ls=":")
    ax.annotate(f"A∞ = {e.limit:.4g}", (e.start, e.limit), ha="left", va="bottom", fontsize=8)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("series", nargs="+", help="simulate_*.nc time series; the first is fitted")
    parser.add_argument("--since", nargs="+", type=float, default=[], help="fit windows' start times")
    parser.add_argument(
        "--predict-from", nargs="+", type=float, default=[], help="fit up to T, predict after"
    )
    parser.add_argument("--labels", nargs="+", default=None, help="one label per series")
    parser.add_argument("--offsets", nargs="+", type=float, default=None, help="one time per series")
    parser.add_argument("--figure", default=None, help="draw the peaks and the envelope to this file")
    args = parser.parse_args()
    labels = args.labels or [f"series {k + 1}" for k in range(len(args.series))]
    offsets = args.offsets or [0.0] * len(args.series)
    if len(labels) != len(args.series) or len(offsets) != len(args.series):
        parser.error(f"give one label and one offset per series ({len(args.series)})")
    if not args.since and (args.predict_from or not args.figure):
        parser.error("give --since (fit windows; needed by --predict-from), --figure (the peaks), or both")
    all_series = [peaks(path, offset) for path, offset in zip(args.series, offsets, strict=True)]
    try:
        if args.since:
            print("\n".join(fit_rows(all_series[0], args.since)))
        if args.predict_from:
            print()
            print("\n".join(prediction_rows(all_series[0], args.since[0], args.predict_from)))
    except ValueError as error:  # a window with too few half periods
        parser.error(f"{error}: start the fit earlier, or march longer")
    if args.figure:
        draw(all_series, labels, args.since[0] if args.since else None, args.figure)


if __name__ == "__main__":
    main()
