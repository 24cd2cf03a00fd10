"""The fixed plate's wake onset in angle of attack at Re = 500 against the discretisation.

Reported in docs/discretisation.md ("The wake onset in α0 at Re 500"). Each variant is a mesh fitted
to Re 500 (a preset's sizes with some overridden) with its outlet layers and condition; on each the
script computes, with the library's own functions and one thread:

* the fixed plate's spectrum at ``α0 = 8, 10, 12, 14°`` (``--angles``): the eigenvalues nearest
  the shifts ``0.1 + iω`` for ``ω`` in ``SHIFTS`` (shift-invert Arnoldi,
  :func:`fsistab.eigen.eigenpairs_near`, one factorisation per shift), each with the share of its
  kinetic energy in the near wake ``NEAR_WAKE``, so that a mode that changes rank between meshes
  is seen (a wake mode resolved over a long wake box carries much of its energy downstream). On
  such meshes the eight eigenvalues nearest a fixed shift can all be weakly damped far-wake modes
  and miss the wake mode: check it with a shift at its frequency (docs/discretisation.md);
* the onset ``α0_c``, ``ω_c`` (:func:`fsistab.onset.critical_onset`, the secant on the leading growth
  rate), from the angle and frequency where the least stable eigenvalue of the spectra crosses the
  axis (linear interpolation between the two angles that bracket it; from the largest angle
  otherwise).

The steady states are continued in α0 from 8° and cached (``--cache``); each spectrum is appended
to ``OUT_spectra.jsonl`` beside ``--out`` and read back on a rerun. One JSON line per variant is
appended to ``--out`` (a variant already there is skipped, so a rerun resumes), with wall and CPU
times (of this run: spectra read back cost nothing), factorisations and the peak memory; an onset
that fails leaves the spectra and its error (``onset_error``).

Usage: python validation/alpha0_onset_study.py [VARIANT ...] [--out FILE] [--cache DIR]
       python validation/alpha0_onset_study.py VARIANT ... --targeted-onset ALPHA0 SHIFT [--out FILE]
       python validation/alpha0_onset_study.py VARIANT --wavemaker ALPHA0 OMEGA [--out FILE]
       python validation/alpha0_onset_study.py [VARIANT ...] --figure PNG [--wavemaker-maps NPZ ...]
       python validation/alpha0_onset_study.py --list
"""

from __future__ import annotations

import argparse
import json
import resource
import time
from pathlib import Path

import numpy as np
from ngsolve import SetNumThreads
from variant_runs import region_mass, run_variants

from fsistab.bodies import Plate
from fsistab.coupled import CoupledSystem
from fsistab.eigen import eigenpairs_near
from fsistab.linalg import FactorCounter
from fsistab.mesh import mesh_spec
from fsistab.onset import critical_onset
from fsistab.operators import fluid_operators
from fsistab.params import Domain, Flow, Solid
from fsistab.steady import solve_steady
from fsistab.store import default_cache_dir

REYNOLDS = 500.0
ANGLES = (8.0, 10.0, 12.0, 14.0)  # degrees
SHIFTS = (2.0, 2.8, 3.6, 4.4)  # frequencies of the Arnoldi shifts (the wake modes lie at ω 2.5-4.2)
N_EIGENVALUES = 8
NEAR_WAKE = (-1.0, 10.0, 4.0)  # the box [x0, x1] × [-h, h] of the energy share (chords)
WAKE_SHARE = 0.25  # the least near-wake share of a wake mode

# the near-body sizes (wall, corner, near) of the `fine` preset, and a level beyond it
NEAR2 = {"wall": 0.008, "corner": 0.0015, "near": 0.012}
NEAR3 = {"wall": 0.005, "corner": 0.001, "near": 0.008}

# the inner mesh of `coarse` (near-body sizes and wake box)
COARSE_INNER = {
    "wall": 0.03,
    "corner": 0.005,
    "near": 0.05,
    "wake": 0.15,
    "wake_length": 4.0,
    "wake_half_width": 0.6,
}
# the outer mesh of `coarse`: its far-field size, no middle box or band (its domain is in VARIANTS)
COARSE_OUTER = {"far": 4.0, "middle": None, "middle_box": None, "middle_band": None}

# name: (preset, size overrides, outlet layers of the preset (True) or none (False), outlet[, domain])
VARIANTS = {
    "coarse": ("coarse", {}, True, "stress"),
    "default": ("medium", {}, True, "stress"),
    # near-body resolution: the `fine` preset's near-body sizes, then finer; the corners alone
    "near2": ("medium", NEAR2, True, "stress"),
    "near3": ("medium", NEAR3, True, "stress"),
    "corner": ("medium", {"corner": 0.001}, True, "stress"),
    # a wake box wide enough for the wake tilted by α0 ≤ 16° over 12 chords (the default's, 1 chord
    # wide, holds it for 3.5-5.5 chords only)
    "wide-wake": ("medium", {"wake_length": 12.0, "wake_half_width": 3.5}, True, "stress"),
    # the outlet: no layers; the gradient condition (docs/model.md §4)
    "bare": ("medium", {}, False, "stress"),
    "gradient": ("medium", {}, True, "gradient"),
    # coarse with the default's near-body sizes, and with the default's wake box
    "coarse-near": ("coarse", {"wall": 0.015, "corner": 0.003, "near": 0.025}, True, "stress"),
    "coarse-wake": ("coarse", {"wake": 0.05, "wake_length": 20.0, "wake_half_width": 1.0}, True, "stress"),
    # the default's inner mesh in coarse's domain and far field, and coarse's inner mesh in the default's
    "coarse-outer": ("medium", COARSE_OUTER, False, "stress", Domain(20.0, 40.0, 20.0)),
    "coarse-inner": ("medium", COARSE_INNER, True, "stress"),
    # coarse's domain with 1-chord elements in the whole far field (the default's inner mesh)
    "small-domain": ("medium", {**COARSE_OUTER, "far": 1.0}, False, "stress", Domain(20.0, 40.0, 20.0)),
}


def variant_spec(name: str):
    """The mesh of a variant fitted to Re 500, with its outlet layers and outlet condition."""
    preset, sizes, layers, outlet, *domain = VARIANTS[name]
    sponge = "preset" if layers else None
    return mesh_spec(Plate(), preset, REYNOLDS, *domain, sponge=sponge, outlet=outlet, **sizes)


def spectrum(fluid, counter) -> list[list[float]]:
    """``[growth rate, frequency, near-wake share]`` of the fixed plate's eigenvalues nearest the
    shifts ``0.1 + iω`` (``ω`` in :data:`SHIFTS`), least stable first."""
    mass = region_mass(fluid, NEAR_WAKE)
    system = CoupledSystem(fluid, Solid(dofs=()))
    pairs = eigenpairs_near(system, [0.1 + 1j * w for w in SHIFTS], N_EIGENVALUES, counter=counter)
    rows = []
    for p in pairs:
        share = np.vdot(p.vector, mass @ p.vector).real / np.vdot(p.vector, fluid.mff @ p.vector).real
        rows.append([p.value.real, p.value.imag, float(share)])
    return sorted(rows, key=lambda r: -r[0])


def onset_start(spectra: dict[float, list[list[float]]]) -> tuple[float, complex]:
    """``(guess, shift)`` of the secant: where the least stable eigenvalue's growth rate changes
    sign between two angles (linear interpolation), the shift at the frequency of the unstable one
    (the mode that leads may change between the two); else the largest angle and its leading mode.
    The leading mode is whatever mode leads (``rows[0]``), wake mode or not: the onset is where
    the fixed plate first turns unstable."""
    angles = sorted(spectra)
    lead = {a: spectra[a][0] for a in angles}
    for a, b in zip(angles, angles[1:], strict=False):
        if lead[a][0] < 0 <= lead[b][0]:
            t = -lead[a][0] / (lead[b][0] - lead[a][0])
            return a + t * (b - a), 1j * lead[b][1]
    last = angles[-1] if lead[angles[-1]][0] < 0 else angles[0]
    return last, 1j * lead[last][1]


def cached_spectrum(name: str, angle: float, steady, counter, store: Path) -> list[list[float]]:
    """:func:`spectrum` at ``angle`` on the mesh of ``name``, read from ``store`` (JSON lines) when
    it is there, else computed and appended to it, so that a rerun resumes."""
    if store.exists():
        for line in store.read_text().splitlines():
            entry = json.loads(line) if line.strip() else {}
            if entry.get("variant") == name and entry.get("alpha0") == angle:
                return entry["rows"]
    rows = spectrum(fluid_operators(steady), counter)
    with store.open("a") as handle:
        handle.write(json.dumps({"variant": name, "alpha0": angle, "rows": rows}) + "\n")
    return rows


def run_variant(name: str, cache: Path, store: Path, angles=ANGLES) -> dict:
    """The spectra at ``angles`` (increasing, from 8°: the steady states are continued; kept in
    ``store``) and the onset on the mesh of ``name``; an onset that fails is recorded as such."""
    spec = variant_spec(name)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    counter = FactorCounter()
    spectra, steady_factorisations, steady = {}, 0, None
    for angle in angles:
        steady = solve_steady(spec, Flow(REYNOLDS, angle), cache_dir=cache, initial=steady)
        steady_factorisations += 0 if steady.from_cache else steady.factorisations
        spectra[angle] = cached_spectrum(name, angle, steady, counter, store)
        print(f"{name} α0 {angle:g}: {spectra[angle][:3]}", flush=True)
    record = {
        "variant": name,
        "reynolds": REYNOLDS,
        "mesh": spec.describe(),
        "unknowns": int(sum(steady.space.FreeDofs())),  # the fluid unknowns, without a new assembly
        "spectra": {f"{a:g}": rows for a, rows in spectra.items()},
        "spectra_wall_s": time.perf_counter() - wall0,
    }
    guess, shift = onset_start(spectra)
    record["onset_guess"] = [guess, shift.imag]
    try:
        result = critical_onset(spec, Flow(REYNOLDS), "alpha0", round(guess, 3), shift, cache_dir=cache)
    except Exception as exc:  # the spectra stand without the onset
        record["onset_error"] = f"{type(exc).__name__}: {exc}"
        onset_factorisations = 0
    else:
        record["critical_alpha0"] = result.critical_value
        record["critical_frequency"] = result.frequency
        record["onset_iterates"] = [[i.value, i.growth_rate, i.frequency] for i in result.iterates]
        onset_factorisations = result.factorisations
    record["factorisations"] = counter.count + steady_factorisations + onset_factorisations
    record["wall_s"] = time.perf_counter() - wall0
    record["cpu_s"] = time.process_time() - cpu0
    record["peak_rss_gb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
    return record


def targeted_onset(name: str, guess: float, shift: complex, cache: Path) -> dict:
    """The onset on the mesh of ``name`` by the secant from ``guess`` with the mode picked near
    ``shift`` (a shift at the wake mode, as found on another mesh), without the spectra: on meshes
    where a spectrum over fixed shifts costs an hour per angle and may miss the mode."""
    spec = variant_spec(name)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    result = critical_onset(spec, Flow(REYNOLDS), "alpha0", guess, shift, cache_dir=cache)
    steady = solve_steady(spec, Flow(REYNOLDS, guess), cache_dir=cache)  # cached by the secant
    return {
        "variant": name,
        "reynolds": REYNOLDS,
        "mesh": spec.describe(),
        "unknowns": int(sum(steady.space.FreeDofs())),
        "onset_guess": [guess, shift.imag],
        "onset_shift": [shift.real, shift.imag],
        "critical_alpha0": result.critical_value,
        "critical_frequency": result.frequency,
        "onset_iterates": [[i.value, i.growth_rate, i.frequency] for i in result.iterates],
        "factorisations": result.factorisations,
        "wall_s": time.perf_counter() - wall0,
        "cpu_s": time.process_time() - cpu0,
        "peak_rss_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6,
    }


def vertices(fluid, box) -> np.ndarray:
    """The mesh vertices in the box ``[x0, x1] × [y0, y1]`` (N × 2)."""
    x0, x1, y0, y1 = box
    points = np.array([p.p[:2] for p in fluid.steady.mesh.ngmesh.Points()])
    keep = (points[:, 0] >= x0) & (points[:, 0] <= x1) & (points[:, 1] >= y0) & (points[:, 1] <= y1)
    return points[keep]


WAVEMAKER_BOX = (-1.0, 4.0, -2.0, 2.0)


def wavemaker(name: str, angle: float, frequency: float, cache: Path, out: Path) -> dict:
    """The structural sensitivity ``‖û†‖‖û‖`` (Giannetti & Luchini 2007,
    :func:`fsistab.sensitivity.structural_sensitivity`) of the fixed plate's least stable wake
    mode near ``iω`` (of the six nearest ``0.05 + iω``) at ``angle`` on the mesh of ``name``: its
    peak, and the share of ``Σ S²`` over the vertices of :data:`WAVEMAKER_BOX` that lie within
    about 0.1 chord of the plate (``|X| ≤ 0.6, |Y| ≤ 0.125``). The values at those vertices are
    saved to ``out`` (NumPy ``.npz``)."""
    from fsistab.sensitivity import adjoint_mode, structural_sensitivity

    spec = variant_spec(name)
    steady = None
    # continued as in run_variant through the study's angles below, so the cached states are reused
    for a in [a for a in ANGLES if a < angle] + [angle]:
        steady = solve_steady(spec, Flow(REYNOLDS, a), cache_dir=cache, initial=steady)
    fluid = fluid_operators(steady)
    system = CoupledSystem(fluid, Solid(dofs=()))
    counter = FactorCounter()
    pairs = eigenpairs_near(system, [0.05 + 1j * frequency], 6, counter=counter)
    mass = region_mass(fluid, NEAR_WAKE)
    pairs = [
        p
        for p in pairs
        if np.vdot(p.vector, mass @ p.vector).real > WAKE_SHARE * np.vdot(p.vector, fluid.mff @ p.vector).real
    ]
    if not pairs:
        raise SystemExit(f"no wake mode among the six eigenvalues nearest 0.05+{frequency:g}i at {angle:g}°")
    pair = max(pairs, key=lambda p: p.value.real)  # the least stable wake mode near iω
    mode = adjoint_mode(system, pair.value, pair.vector, counter=counter)
    points = vertices(fluid, WAVEMAKER_BOX)
    values = structural_sensitivity(fluid, mode, points)
    np.savez_compressed(out, points=points, sensitivity=values, eigenvalue=pair.value)
    peak = points[np.argmax(values)]
    weight = values**2
    near_body = (np.abs(points[:, 0]) <= 0.6) & (np.abs(points[:, 1]) <= 0.125)
    return {
        "variant": name,
        "alpha0": angle,
        "eigenvalue": [pair.value.real, pair.value.imag],
        "peak": peak.tolist(),
        "near_body_share": float(weight[near_body].sum() / weight.sum()),
        "factorisations": counter.count,
    }


def growth_rates(record: dict) -> tuple[list[float], list[float]]:
    """``(α0, λ)`` of a record, increasing α0: the least stable of its spectra and ``targeted``
    eigenvalues at each angle; a record with neither (:func:`targeted_onset`) gives its secant's
    iterates."""
    spectra, targeted = record.get("spectra", {}), record.get("targeted", {})
    if not spectra and not targeted:
        iterates = sorted(record["onset_iterates"])
        return [i[0] for i in iterates], [i[1] for i in iterates]
    angles = sorted({float(a) for a in spectra} | {float(a) for a in targeted})
    rates = [max(row[0] for row in spectra.get(f"{a:g}", []) + targeted.get(f"{a:g}", [])) for a in angles]
    return angles, rates


def draw(records: list[dict], wavemakers: list[Path], path: Path) -> None:
    """The least stable growth rate against α0 on each mesh (:func:`growth_rates`; the onset
    marked), and the structural sensitivity maps given (``.npz`` of :func:`wavemaker`)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    columns = 1 + len(wavemakers)
    fig, axes = plt.subplots(1, columns, figsize=(5 * columns, 3.8), squeeze=False)
    ax = axes[0, 0]
    zoom = ax.inset_axes([0.56, 0.08, 0.41, 0.36])  # the onsets, magnified
    for r in records:
        angles, rates = growth_rates(r)
        (line,) = ax.plot(angles, rates, "o-", ms=4, label=f"{r['variant']} ({r['unknowns']:,})")
        zoom.plot(angles, rates, "o-", ms=3, color=line.get_color())
        if "critical_alpha0" in r:
            for axis in (ax, zoom):
                axis.plot([r["critical_alpha0"]], [0.0], "x", color=line.get_color(), markersize=8)
    zoom.set_xlim(9.6, 9.8)
    zoom.set_ylim(-0.02, 0.02)
    zoom.tick_params(labelsize=6)
    for axis in (ax, zoom):
        axis.axhline(0.0, color="k", lw=0.6)
    ax.set_xlabel(r"$\alpha_0$ (degrees)")
    ax.set_ylabel(r"leading growth rate $\lambda$ ($U_\infty/L$)")
    ax.set_title("fixed plate, Re 500: least stable mode")
    ax.legend(fontsize=7, loc="upper left")
    for ax, npz in zip(axes[0, 1:], wavemakers, strict=True):
        data = np.load(npz)
        points, values = data["points"], data["sensitivity"]
        contour = ax.tricontourf(points[:, 0], points[:, 1], values / values.max(), levels=20, cmap="viridis")
        ax.fill([-0.5, 0.5, 0.5, -0.5], [-0.025, -0.025, 0.025, 0.025], color="w", ec="k", lw=0.5)
        ax.set_xlim(-0.8, 2.5)
        ax.set_ylim(-0.8, 1.0)
        ax.set_aspect("equal")
        value = complex(data["eigenvalue"])
        ax.set_title(
            f"{npz.stem.split('_', 1)[1]}: $\\sigma$ = {value.real:+.3f} {value.imag:+.3f}i", fontsize=9
        )
        fig.colorbar(contour, ax=ax, shrink=0.7, label=r"$\|\hat u^\dagger\|\,\|\hat u\|$ / max")
    fig.tight_layout()
    fig.savefig(path, dpi=130)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("variants", nargs="*", default=[])
    parser.add_argument("--out", default="docs/data/alpha0_onset_Re500.jsonl")
    parser.add_argument("--cache", default=None)
    parser.add_argument("--list", action="store_true")
    parser.add_argument("--angles", nargs="+", type=float, default=list(ANGLES), help="the spectra's α0")
    parser.add_argument(
        "--wavemaker",
        nargs=2,
        type=float,
        metavar=("ALPHA0", "OMEGA"),
        help="the structural sensitivity of the wake mode nearest iOMEGA at ALPHA0 instead (prints it)",
    )
    parser.add_argument(
        "--targeted-onset",
        nargs=2,
        metavar=("ALPHA0", "SHIFT"),
        help="only the onset, by the secant from ALPHA0 with the mode nearest SHIFT (e.g. 0.07+3.877j)",
    )
    parser.add_argument("--figure", default=None, help="draw --out (and the --wavemaker-maps) to this PNG")
    parser.add_argument("--wavemaker-maps", nargs="*", default=[], help=".npz files of --wavemaker")
    args = parser.parse_args()
    if args.figure:
        records = [json.loads(line) for line in Path(args.out).read_text().splitlines() if line.strip()]
        chosen = [r for r in records if r["variant"] in args.variants] if args.variants else records
        draw(chosen, [Path(p) for p in args.wavemaker_maps], Path(args.figure))
        return
    if args.list:
        for name, variant in VARIANTS.items():
            print(name, variant)
        return
    args.variants = args.variants or list(VARIANTS)
    unknown = [name for name in args.variants if name not in VARIANTS]
    if unknown:
        parser.error(f"unknown variants {unknown}; --list shows them")
    SetNumThreads(1)
    out = Path(args.out)
    cache = Path(args.cache) if args.cache else default_cache_dir()
    store = out.with_name(out.stem + "_spectra.jsonl")
    if args.wavemaker:
        for name in args.variants:
            npz = out.with_name(f"wavemaker_{name}_a{args.wavemaker[0]:g}.npz")
            print(json.dumps(wavemaker(name, *args.wavemaker, cache, npz)), flush=True)
        return
    if args.targeted_onset:
        try:
            guess, shift = float(args.targeted_onset[0]), complex(args.targeted_onset[1])
        except ValueError:
            parser.error(f"--targeted-onset takes an angle and a complex shift, got {args.targeted_onset}")
        run_variants(args.variants, out, lambda name: targeted_onset(name, guess, shift, cache))
        return
    run_variants(args.variants, out, lambda name: run_variant(name, cache, store, sorted(args.angles)))


if __name__ == "__main__":
    main()
