"""The amplitude law σ(A) of the plate's flutter mode past its threshold (docs/model.md §12).

At Re 2900, m = 1000 the flutter mode grows at σ ≈ 1.6e-3 just past U*_F (an e-folding time of
about 640 L/U∞, 17 periods): a march from a small perturbation would need thousands of time
units to reach a limit cycle. Instead each march releases the body at a chosen pitch amplitude
(``fsistab simulate --perturbation-of pitch --perturbation A``: the flutter mode's solid state
scaled to θ = A, the fluid at its steady state) and measures how fast the oscillation grows or
decays there. Where σ(A) crosses zero is a limit cycle, stable where dσ/dA < 0; σ(A) rising from
the linear rate σ(0) means a subcritical onset, falling a supercritical one.

For each time series given (``simulate_*.nc`` of such marches), after the release's transient
(``--skip`` time units) the pitch is fitted by one damped oscillation (Prony's method,
:func:`fsistab.simulation.damped_oscillation`), and the envelope's rate is read between successive
periods (:func:`fsistab.lco.envelope_growth`) and half periods (:func:`half_period_rates`).
Prints one Markdown row per march, with the start mode's eigenvalue (σ(0), the same mesh) and
the cost; ``--figure`` draws σ against A.

Usage: python validation/plate_flutter_amplitude.py SERIES.nc [SERIES.nc ...] [--skip 20]
       [--figure sigma.png]
"""

import argparse
import math

import numpy as np

from fsistab.lco import envelope_growth, half_period_peaks, period_amplitudes
from fsistab.simulation import damped_oscillation
from fsistab.store import read_dataset


def half_period_rates(times: np.ndarray, values: np.ndarray) -> list[tuple[float, float]]:
    """``(A, σ)`` between successive half periods: the largest ``|θ|`` between zero crossings of
    ``θ`` (about θ₀ = 0; :func:`fsistab.lco.half_period_peaks`), ``σ = ln(A_{k+1}/A_k)/(t_{k+1} −
    t_k)`` at ``A = √(A_k A_{k+1})``: twice as many samples of σ(A) as the whole periods give, for a
    slowly growing cycle."""
    peaks = list(zip(*half_period_peaks(times, values), strict=True))
    return [
        (math.sqrt(a0 * a1), math.log(a1 / a0) / (t1 - t0))
        for (t0, a0), (t1, a1) in zip(peaks[:-1], peaks[1:], strict=True)
    ]


def measure(path: str, skip: float) -> dict:
    """σ and ω fitted to θ(t) − θ₀ after ``skip``, the mean period amplitude there, the envelope rates."""
    ds = read_dataset(path)
    times, pitch = ds.time.values, ds.pitch.values
    late = times >= skip
    fit = damped_oscillation(times[late], pitch[late])
    _, amplitudes, _ = period_amplitudes(times[late], pitch[late])
    at, rates = envelope_growth(times[late], pitch[late])
    return {
        "start": abs(math.degrees(float(pitch[0])) - float(ds.attrs.get("alpha0_deg", 0.0))),
        "amplitude": math.degrees(float(np.mean(amplitudes))) if len(amplitudes) else math.nan,
        "fit": fit,
        "envelope": [(math.degrees(a), r) for a, r in zip(at, rates, strict=True)],
        "half_periods": [(math.degrees(a), r) for a, r in half_period_rates(times[late], pitch[late])],
        "linear": complex(
            ds.attrs.get("start_growth_rate", math.nan), ds.attrs.get("start_frequency", math.nan)
        ),
        "velocity": float(ds.attrs["reduced_velocity"]),
        "end": float(times[-1]),
        "steps": int(ds.attrs["steps"]),
        "seconds": float(ds.attrs["seconds_per_step"]),
        "ndof": int(ds.attrs["ndof"]),
    }


def row(m: dict) -> str:
    fit, linear = m["fit"], m["linear"]
    envelope = ", ".join(f"{r:+.2e} at {a:.2f}°" for a, r in m["envelope"])
    halves = ", ".join(f"{r:+.2e} at {a:.2f}°" for a, r in m["half_periods"])
    return (
        f"| {m['velocity']:g} | {m['start']:.2f}° | {m['amplitude']:.2f}° | {fit.real:+.3e} | "
        f"{fit.imag:.5f} | {linear.real:+.3e}, {linear.imag:.5f} | {envelope} | {halves} | "
        f"{m['end']:g}, {m['steps']} steps, {m['seconds']:.2f} s/step, {m['ndof']} unknowns |"
    )


def draw(measured: list[dict], path: str) -> None:
    """σ against A: the eigenvalue's rate at A = 0 and each march's half-period rates, one colour per
    U* (a march's rates joined in time order)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for index, u in enumerate(sorted({m["velocity"] for m in measured})):
        colour = f"C{index}"
        group = [m for m in measured if m["velocity"] == u]
        ax.plot([0.0], [group[0]["linear"].real], "o", color=colour, label=f"U* = {u:g}: eigenvalue")
        for m in group:
            if m["half_periods"]:
                ha, hr = zip(*m["half_periods"], strict=True)
                ax.plot(ha, hr, "x-", color=colour, alpha=0.8, lw=0.8)
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_xlabel("pitch amplitude A (degrees)")
    ax.set_ylabel("growth rate σ per half period (U∞/L)")
    ax.set_title("plate, Re 2900, m = 1000: flutter amplitude law σ(A)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=150)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("series", nargs="+", help="simulate_*.nc time series of released marches")
    parser.add_argument("--skip", type=float, default=20.0, help="time units of release transient left out")
    parser.add_argument("--figure", default=None, help="draw σ(A) to this file")
    args = parser.parse_args()
    measured = [measure(path, args.skip) for path in args.series]
    print(
        "| U* | released at | mean amplitude | σ fitted | ω fitted | σ(0), ω (eigenvalue) | "
        "envelope rate per period | rate per half period | march |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for m in sorted(measured, key=lambda m: (m["velocity"], m["amplitude"])):
        print(row(m))
    if args.figure:
        draw(measured, args.figure)


if __name__ == "__main__":
    main()
