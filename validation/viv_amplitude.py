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

For the spread among solvers the same repository's own immersed-boundary marches of the case are
drawn too (``scripts/validation/combined_viv.py``, commit ed2b4fcbf398928c0d011a764e72944d8f018cd2:
labelled external or embedded, loose or strong coupling; maximum displacement, not published in a
paper).

Reads the diagram of ``fsistab lco`` (its NetCDF, ``data`` of the JSON output) and prints one
Markdown row per U*: A/D (the mean period amplitude, with the march's state: over the last periods,
or over the second half's for a modulated march, with the range of its period amplitudes), the
largest |h − mid-level| over the second half of the march (``heave_largest``, the references'
measure), the references and the differences; ``--figure`` draws both curves.

Several diagrams (e.g. marches of different durations) are read as one, by U*.

Usage: python validation/viv_amplitude.py LCO.nc [LCO.nc ...] [--figure viv.png]
"""

import argparse

import numpy as np
import xarray as xr

from fsistab.store import read_dataset

FIELDS = ("amplitude", "frequency", "state", "low", "high", "largest", "saturated")
# U*, A_max/D of Borazjani et al. (2008), of Ahn & Kallinderis (2006): cuIBM's digitisation
REFERENCE = (
    (3.0, 0.0714, 0.0714),
    (4.0, 0.5286, 0.5616),
    (5.0, 0.4894, 0.5234),
    (6.0, 0.435, 0.451),
    (7.0, 0.381, 0.371),
    (8.0, 0.0696, 0.0696),
)

# U*, A_max/D of cuIBM's own marches (external loose, external strong, embedded loose, embedded strong)
OTHER_SOLVER = (
    (3.0, 0.0704, 0.0743, 0.0716, 0.0741),
    (4.0, 0.5675, 0.5600, 0.5718, 0.5443),
    (5.0, 0.5202, 0.5069, 0.5344, 0.4823),
    (6.0, 0.4533, 0.4343, 0.4677, 0.3941),
    (7.0, 0.3880, 0.3535, 0.3887, 0.3100),
    (8.0, 0.1200, 0.1045, 0.1401, 0.0882),
)


def spread_rows(ds) -> list[str]:
    """One Markdown row per U* run: the range of cuIBM's four couplings and fsistab's largest |h|
    against its top."""
    out = []
    for u, *values in OTHER_SOLVER:
        near = np.isclose(ds.reduced_velocity.values, u)
        if near.any():
            peak = ds.heave_largest.values[int(np.argmax(near))]
            low, top = min(values), max(values)
            out.append(f"| {u:g} | {low:.3f}–{top:.3f} | {peak:.3f} | {peak - top:+.3f} |")
    return out


def rows(ds) -> list[str]:
    out = []
    for u, borazjani, ahn in REFERENCE:
        near = np.isclose(ds.reduced_velocity.values, u)
        if not near.any():
            continue
        i = int(np.argmax(near))
        a, w, state, low, high, peak = (
            ds[f"heave_{k}"].values[i] for k in ("amplitude", "frequency", "state", "low", "high", "largest")
        )
        state = f"{state} {low:.3f}–{high:.3f}" if state == "modulated" else state
        fn = 2 * np.pi / u
        out.append(
            f"| {u:g} | {borazjani:.3f} | {ahn:.3f} | {a:.3f} ({state}) | {peak:.3f} | "
            f"{peak - borazjani:+.3f} | {peak - ahn:+.3f} | {w:.4f} ({w / fn:.3f} ω_n) |"
        )
    return out


def draw(ds, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ref = np.array(REFERENCE)
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(ref[:, 0], ref[:, 1], "s--", mfc="none", label="Borazjani et al. 2008 (digitised)")
    ax.plot(ref[:, 0], ref[:, 2], "^--", mfc="none", label="Ahn & Kallinderis 2006 (digitised)")
    other = np.array(OTHER_SOLVER)
    ax.fill_between(other[:, 0], other[:, 1:].min(axis=1), other[:, 1:].max(axis=1), color="0.85",
                    label="cuIBM's own marches, four couplings (range)")  # fmt: skip
    ok = ds.heave_saturated.values.astype(bool)
    u, a = ds.reduced_velocity.values, ds.heave_amplitude.values
    ax.plot(u, a, "k-", lw=0.8)
    ax.plot(u[ok], a[ok], "ko", label="fsistab lco (saturated)")
    if (~ok).any():
        ax.plot(u[~ok], a[~ok], "ko", mfc="none", label="fsistab lco (not saturated)")
    modulated = ds.heave_state.values == "modulated"
    if modulated.any():
        ax.vlines(u[modulated], ds.heave_low.values[modulated], ds.heave_high.values[modulated], "k",
                  label="fsistab lco: range of a modulated march")  # fmt: skip
    ax.plot(u, ds.heave_largest.values, "kx", label="fsistab: largest |h| (second half)")
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
    parser.add_argument("diagrams", nargs="+", help="NetCDF files of fsistab lco")
    parser.add_argument("--figure", default=None, help="draw the comparison to this file")
    args = parser.parse_args()
    parts = []
    for path in args.diagrams:
        diagram = read_dataset(path)
        if "heave_largest" not in diagram:
            raise SystemExit(f"{path}: a diagram written before heave_largest; rerun its fsistab lco command")
        parts.append(diagram[[f"heave_{k}" for k in FIELDS]])
    ds = xr.concat(parts, "reduced_velocity", combine_attrs="drop_conflicts").sortby("reduced_velocity")
    print(
        "| U* | Borazjani et al. | Ahn & Kallinderis | fsistab: period amplitude (state) | "
        "fsistab: largest |h| | − Borazjani | − Ahn | ω (heave) |"
    )
    print("|---|---|---|---|---|---|---|---|")
    print("\n".join(rows(ds)))
    print("\n| U* | cuIBM's four couplings | fsistab: largest |h| | − their top |")
    print("|---|---|---|---|")
    print("\n".join(spread_rows(ds)))
    if args.figure:
        draw(ds, args.figure)


if __name__ == "__main__":
    main()
