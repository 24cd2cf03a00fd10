"""Vortex-induced vibration of a spring-mounted cylinder: the heave amplitude against U*, against
the published curve of the same case (docs/model.md §10, §12; issue 47, check c).

Case: 2-D circular cylinder free in heave only, Re = 150, reduced mass ``M_red = m/(ρD²) = 2``
(``m* = 4 M_red/π = 2.5465`` in fsistab's convention), no structural damping, ``U* = U/(f_n D)``
with ``f_n`` the natural frequency in vacuum. Reference amplitudes (maximum displacement over the
record, in D) of Borazjani, Ge & Sotiropoulos (2008, J. Comput. Phys. 227, 7587–7620) and Ahn &
Kallinderis (2006, J. Comput. Phys. 219, 671–696), as digitised from those papers' figures by the
cuIBM authors (repository ``Niemeyer-Research-Group/cuIBM``, ``scripts/validation/validate_viv.py``,
commit 883fc136837900a6d426473449129fea28e168d4; the case's Re and M_red read from cuIBM's set-up
of it, ``validation/osc/VIV``): a third party's digitisation, about ±0.02 D.

Reads the diagram of ``fsistab lco`` (its NetCDF, ``data`` of the JSON output) and prints one
Markdown row per U*: A/D (the mean period amplitude over the last periods, with the saturation
state), the largest |h − mean| over the second half of the march (the references' measure, read
from the march's time series in ``OUT/lco_runs``), the references and the differences; ``--figure``
draws both curves.

Usage: python validation/viv_amplitude.py LCO.nc [--runs OUT/lco_runs] [--figure viv.png]
"""

import argparse
from pathlib import Path

import numpy as np

from fsistab.store import read_dataset

# U*, A_max/D of Borazjani et al. (2008), of Ahn & Kallinderis (2006): cuIBM's digitisation
REFERENCE = (
    (3.0, 0.0714, 0.0714),
    (4.0, 0.5286, 0.5616),
    (5.0, 0.4894, 0.5234),
    (6.0, 0.435, 0.451),
    (7.0, 0.381, 0.371),
    (8.0, 0.0696, 0.0696),
)


def record_maxima(runs: Path | None) -> dict[float, float]:
    """U* → the largest |h − mean h| over the second half of each march in ``runs``."""
    maxima = {}
    for path in sorted(runs.glob("*/simulate_*.nc")) if runs else []:
        series = read_dataset(path)
        u = round(float(series.attrs["reduced_velocity"]) * 2 * np.pi, 6)  # the cylinder's U*
        t, h = series.time.values, series.heave.values
        late = h[t >= 0.5 * t[-1]]
        maxima[u] = float(np.max(np.abs(late - late.mean())))
    return maxima


def rows(ds, maxima: dict[float, float]) -> list[str]:
    out = []
    for u, borazjani, ahn in REFERENCE:
        near = np.isclose(ds.reduced_velocity.values, u)
        if not near.any():
            continue
        i = int(np.argmax(near))
        a, w, state = (ds[f"heave_{k}"].values[i] for k in ("amplitude", "frequency", "state"))
        peak = maxima.get(round(u, 6), np.nan)
        fn = 2 * np.pi / u
        out.append(
            f"| {u:g} | {borazjani:.3f} | {ahn:.3f} | {a:.3f} ({state}) | {peak:.3f} | "
            f"{peak - borazjani:+.3f} | {peak - ahn:+.3f} | {w:.4f} ({w / fn:.3f} ω_n) |"
        )
    return out


def draw(ds, maxima: dict[float, float], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ref = np.array(REFERENCE)
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(ref[:, 0], ref[:, 1], "s--", mfc="none", label="Borazjani et al. 2008 (digitised)")
    ax.plot(ref[:, 0], ref[:, 2], "^--", mfc="none", label="Ahn & Kallinderis 2006 (digitised)")
    ok = ds.heave_saturated.values.astype(bool)
    u, a = ds.reduced_velocity.values, ds.heave_amplitude.values
    ax.plot(u, a, "k-", lw=0.8)
    ax.plot(u[ok], a[ok], "ko", label="fsistab lco (saturated)")
    if (~ok).any():
        ax.plot(u[~ok], a[~ok], "ko", mfc="none", label="fsistab lco (not saturated)")
    if maxima:
        um = sorted(maxima)
        ax.plot(um, [maxima[v] for v in um], "kx", label="fsistab: largest |h| (second half)")
    ax.set_xlabel("U* = U/(f_n D)")
    ax.set_ylabel("A/D")
    ax.set_title(f"cylinder in heave, Re 150, M_red = 2, ζ = 0 ({ds.attrs.get('preset', '')} mesh)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=150)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("diagram", help="the NetCDF file of fsistab lco")
    parser.add_argument("--runs", type=Path, default=None, help="the lco_runs folder of the diagram")
    parser.add_argument("--figure", default=None, help="draw the comparison to this file")
    args = parser.parse_args()
    ds = read_dataset(args.diagram)
    print(
        "| U* | Borazjani et al. | Ahn & Kallinderis | fsistab: period amplitude (state) | "
        "fsistab: largest |h| | − Borazjani | − Ahn | ω (heave) |"
    )
    print("|---|---|---|---|---|---|---|---|")
    maxima = record_maxima(args.runs)
    print("\n".join(rows(ds, maxima)))
    if args.figure:
        draw(ds, maxima, args.figure)


if __name__ == "__main__":
    main()
