"""Discretisation study of the plate at Re = 2900: far field, domain, wake, near body.

Reported in docs/discretisation.md. Each variant is a mesh (a preset's sizes with some overridden,
a domain) on which the script computes, with the library's own functions and one thread:

* the steady state (cached): unknowns, drag coefficient, recirculation length;
* the static slopes ``dC_L/dα`` and ``d(-C_M)/dα`` (one real factorisation), hence the divergence
  velocity ``U*_D = √(m r_θ²/(dC_M/dθ))`` at m = 1000 (docs/model.md §8, §9);
* the fixed plate's wake mode (shift-invert Arnoldi near ``11.2i``; of the 8 nearest
  eigenvalues the one with the largest kinetic-energy share in the wake box ``WAKE_BOX``);
* the flutter point at m = 1000 (Newton on ``det T(iω; U*) = 0``, docs/model.md §8) from a guess.

Solid parameters are the defaults of docs/model.md §2 (Ω = 0.8, ζ_h = 0, ζ_θ = 0.05, r_θ = 0.289, pitch
axis at mid-chord); units chord-based. One JSON line per variant is appended to ``--out`` (a
variant already there is skipped, so a rerun resumes), with wall and CPU times and factorisations.

With ``--wake-onset`` the script computes instead the fixed plate's critical Reynolds number of the
wake mode on each variant's mesh (``fsistab.onset``; one JSON line per variant in ``--out``); with
``--viv`` the thresholds at given mass ratios over given ranges of U* (the VIV windows); with
``--wake-spectrum`` the fixed plate's ten eigenvalues nearest the wake mode.

A variant named ``VARIANT+gradient`` is ``VARIANT`` with the gradient outlet (docs/model.md §4).

Usage: python validation/discretisation_study.py [VARIANT ...] [--out FILE] [--cache DIR]
       python validation/discretisation_study.py VARIANT --wake-onset --out FILE
       python validation/discretisation_study.py VARIANT --viv M U_MIN U_MAX [--viv ...] --out FILE
       python validation/discretisation_study.py VARIANT --wake-spectrum --out FILE
       python validation/discretisation_study.py --list
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import resource
import time
from pathlib import Path

import numpy as np
from ngsolve import SetNumThreads
from variant_runs import region_mass, run_variants

from fsistab.bodies import Plate
from fsistab.coupled import CoupledSystem
from fsistab.eigen import eigenpairs_near
from fsistab.errors import ConvergenceError
from fsistab.linalg import FactorCounter
from fsistab.mesh import mesh_spec
from fsistab.neutral_point import divergence_velocity
from fsistab.operators import fluid_operators
from fsistab.params import OUTLETS, Domain, Flow, Solid, Sponge, default_sponge
from fsistab.slopes import static_slopes
from fsistab.steady import solve_steady
from fsistab.store import default_cache_dir
from fsistab.transfer import transfer_flutter_point

REYNOLDS = 2900.0
MASS_RATIO = 1000.0

# The variants start from the presets' sizes before this study (BASE: `medium` with 2.5-chord
# far-field elements, an 8-chord wake box, no middle box nor band), so that they are the meshes the
# study measured; the presets take their values from its results.
BASE = {
    "medium": {
        "far": 2.5,
        "wake_length": 8.0,
        "middle": None,
        "middle_box": None,
        "middle_band": None,
        "far_wake": None,
    }
}

CANDIDATE = {"far": 4.0, "middle": 1.0, "middle_box": (20, 40, 20)}
FINE_NEAR = {"wall": 0.008, "corner": 0.0015, "near": 0.012}

# name: (preset, size overrides, domain (upstream, downstream, lateral))
# the far field of `d1-dom80` (the study's first choice of `medium`), and the same with a 1-chord
# band across the wake to the outlet (its next choice)
D1_DOM80 = {"wake_length": 20.0, "far": 4.0, "middle": 1.0, "middle_box": (40, 80, 40)}
BAND20 = {**D1_DOM80, "middle_band": (160, 20)}
QUICK = {"far": 1.0, "wake": 0.1, "wake_length": 8.0}

VARIANTS = {
    "medium": ("medium", {}, (20, 40, 20)),
    "far1": ("medium", {"far": 1.0}, (20, 40, 20)),
    "far0.5": ("medium", {"far": 0.5}, (20, 40, 20)),
    "far1-lat40": ("medium", {"far": 1.0}, (20, 40, 40)),
    "far1-lat80": ("medium", {"far": 1.0}, (20, 40, 80)),
    "far1-up40": ("medium", {"far": 1.0}, (40, 40, 20)),
    "far1-down80": ("medium", {"far": 1.0}, (20, 80, 20)),
    "far1-wake20": ("medium", {"far": 1.0, "wake_length": 20.0}, (20, 40, 20)),
    "far1-wake0.03": ("medium", {"far": 1.0, "wake": 0.03}, (20, 40, 20)),
    "far1-nearfine": ("medium", {"far": 1.0, "wall": 0.008, "corner": 0.0015, "near": 0.012}, (20, 40, 20)),
    "coarse-far1": ("coarse", {"far": 1.0}, (20, 40, 20)),
    "far1-all40": ("medium", {"far": 1.0}, (40, 80, 40)),
    # graded far field: a middle box of 1-chord elements, larger elements beyond it
    "nested-40": ("medium", {"far": 4.0, "middle": 1.0, "middle_box": (20, 40, 20)}, (40, 80, 40)),
    "nested-80": ("medium", {"far": 8.0, "middle": 1.0, "middle_box": (20, 40, 20)}, (80, 160, 80)),
    "nested-160": ("medium", {"far": 16.0, "middle": 1.0, "middle_box": (20, 40, 20)}, (160, 320, 160)),
    "nested-80-far4": ("medium", {"far": 4.0, "middle": 1.0, "middle_box": (20, 40, 20)}, (80, 160, 80)),
    "nested-160-far4": ("medium", {"far": 4.0, "middle": 1.0, "middle_box": (20, 40, 20)}, (160, 320, 160)),
    "coarse-nested-80-far4": (
        "coarse",
        {"far": 4.0, "middle": 1.0, "middle_box": (20, 40, 20)},
        (80, 160, 80),
    ),
    # candidate default: wake box to 20 chords, 1-chord middle box, 4-chord far field to 80 chords
    "cand": ("medium", {"wake_length": 20.0, **CANDIDATE}, (80, 160, 80)),
    "cand-wake40": ("medium", {"wake_length": 40.0, **CANDIDATE}, (80, 160, 80)),
    "cand-middle0.5": ("medium", {"wake_length": 20.0, **CANDIDATE, "middle": 0.5}, (80, 160, 80)),
    "cand-dom160": ("medium", {"wake_length": 20.0, **CANDIDATE}, (160, 320, 160)),
    "cand-nearfine": ("medium", {"wake_length": 20.0, **CANDIDATE, **FINE_NEAR}, (80, 160, 80)),
    # candidate default (nested-40 with a 20-chord wake box) and its refinements
    "d1": ("medium", {"wake_length": 20.0, **CANDIDATE}, (40, 80, 40)),
    "d1-dom80": (
        "medium",
        {"wake_length": 20.0, "far": 4.0, "middle": 1.0, "middle_box": (40, 80, 40)},
        (80, 160, 80),
    ),
    # d1-dom80 with the outlet sponge (fsistab.params.Sponge) but no band
    "d1-dom80-sponge": ("medium", D1_DOM80, (80, 160, 80)),
    # `medium` after the low-mass-ratio study: d1-dom80 with a 1-chord band
    # |Y| < 20 to the outlet, without and with the outlet sponge, and its refinements
    "band20": ("medium", BAND20, (80, 160, 80)),
    "band20-sponge": ("medium", BAND20, (80, 160, 80)),
    "band20-wake40-sponge": ("medium", {**BAND20, "wake_length": 40.0}, (80, 160, 80)),
    # the `medium` preset, chosen by the far-field study at low mass ratio (docs/discretisation.md):
    # band20 with 2-chord outer elements, the outlet sponge and the far-field layer
    "far2-layer": ("medium", {**BAND20, "far": 2.0}, (80, 160, 80)),
    # far2-layer with its wake box graded: 0.05-chord elements to 5 chords, 0.1-chord ones to 20
    # (docs/performance.md, "Fewer unknowns")
    "far2-graded-layer": (
        "medium",
        {**BAND20, "far": 2.0, "wake_length": 5.0, "far_wake": (0.1, 20.0, 1.0)},
        (80, 160, 80),
    ),
    # the same with the 0.05-chord elements to 10 chords
    "far2-graded10-layer": (
        "medium",
        {**BAND20, "far": 2.0, "wake_length": 10.0, "far_wake": (0.1, 20.0, 1.0)},
        (80, 160, 80),
    ),
    "d1-wake40": ("medium", {"wake_length": 40.0, **CANDIDATE}, (40, 80, 40)),
    "d1-nearfine": ("medium", {"wake_length": 20.0, **CANDIDATE, **FINE_NEAR}, (40, 80, 40)),
    "d1-dom80-wake40": (
        "medium",
        {"wake_length": 40.0, "far": 4.0, "middle": 1.0, "middle_box": (40, 80, 40)},
        (80, 160, 80),
    ),
    "coarse": ("coarse", {}, (20, 40, 20)),
    "coarse-d1": ("coarse", CANDIDATE, (40, 80, 40)),
    "nested-80-box30": ("medium", {"far": 8.0, "middle": 1.0, "middle_box": (30, 60, 30)}, (80, 160, 80)),
    # candidates for a quick preset: 1-chord elements everywhere on a
    # narrow, long domain (clean at m = 10 on coarse near-body sizes, docs/discretisation.md), with
    # coarse or medium near-body and wake sizes, to find which of them the wake mode needs
    "quick-sponge": ("coarse", QUICK, (20, 160, 20)),
    "quick-wake-sponge": ("coarse", {**QUICK, "wake": 0.05}, (20, 160, 20)),
    # an earlier `quick` preset (medium's near body with QUICK's wake and far field)
    "quick-near-sponge": ("medium", {**QUICK, "wake_half_width": 0.6}, (20, 160, 20)),
    # the `quick` preset: `medium` (far2-layer) with 0.1-chord wake elements
    "far2-wake0.1-layer": ("medium", {**BAND20, "far": 2.0, "wake": 0.1}, (80, 160, 80)),
    # the wake mode's convergence (issue: the wake mode at Re 2900): the default (far2-layer)
    # with its domain and band 2 and 4 times longer, its wake box twice as long, no layers
    "far2-dom320-layer": ("medium", {**BAND20, "far": 2.0, "middle_band": (320, 20)}, (80, 320, 80)),
    "far2-dom640-layer": ("medium", {**BAND20, "far": 2.0, "middle_band": (640, 20)}, (80, 640, 80)),
    "far2-wake40-layer": ("medium", {**BAND20, "far": 2.0, "wake_length": 40.0}, (80, 160, 80)),
    "far2-bare": ("medium", {**BAND20, "far": 2.0}, (80, 160, 80)),
}


def split_variant(name: str) -> tuple[str, str]:
    """``(variant, outlet)`` of a name ``VARIANT`` or ``VARIANT+OUTLET`` (docs/model.md §4, "Outlet":
    ``far2-layer+gradient`` is the default mesh with the gradient outlet)."""
    variant, _, outlet = name.partition("+")
    return variant, outlet or "stress"


def variant_spec(name: str, reynolds: float = REYNOLDS):
    """The mesh of a variant, fitted to ``reynolds``: its preset's sizes before the study (``BASE``)
    with the variant's overrides; the outlet sponge (:class:`fsistab.params.Sponge`, the `medium`
    preset's) only on the ``-sponge`` variants, with the far-field layer of the `medium` preset
    (:func:`fsistab.params.default_sponge`) on the ``-layer`` ones; the outlet condition after a
    ``+`` (:func:`split_variant`)."""
    name, outlet = split_variant(name)
    preset, sizes, (up, down, lateral) = VARIANTS[name]
    sponge = {"-sponge": Sponge(), "-layer": default_sponge(Plate(), "medium")}.get(name[name.rfind("-") :])
    return mesh_spec(
        Plate(),
        preset,
        reynolds,
        Domain(up, down, lateral),
        sponge=sponge,
        outlet=outlet,
        **{**BASE.get(preset, {}), **sizes},
    )


WAKE_BOX = (0.5, 20.0, 1.5)  # x from the trailing edge to 20 chords, |y| < 1.5


def wake_mass(fluid):
    """Velocity mass restricted to the wake box ``WAKE_BOX`` (fluid unknowns)."""
    return region_mass(fluid, WAKE_BOX)


def wake_modes(fluid, counter) -> list[tuple[complex, float]]:
    """The 8 fixed-plate eigenvalues nearest ``11.2i`` (shift-invert Arnoldi) with the share of
    their kinetic energy in the wake box: near 1 for the wake mode, a few per cent for the weakly
    damped modes of the truncated domain (docs/stability_map.md)."""
    mass = wake_mass(fluid)
    pairs = eigenpairs_near(CoupledSystem(fluid, Solid(dofs=())), [11.2j], 8, counter=counter)
    shares = [
        float(np.vdot(p.vector, mass @ p.vector).real / np.vdot(p.vector, fluid.mff @ p.vector).real)
        for p in pairs
    ]
    return sorted(zip((p.value for p in pairs), shares, strict=True), key=lambda t: -t[0].real)


def wake_mode(modes) -> list[float]:
    """The least stable of ``modes`` with at least half its energy in the wake box."""
    value = next(v for v, share in modes if share >= 0.5)
    return [value.real, value.imag]


def run_variant(
    name: str, cache: Path, flutter_guess: tuple[float, float], reynolds: float = REYNOLDS
) -> dict:
    """The quantities of the module docstring on one variant at ``reynolds`` (the wake mode near
    11.2i only at Re 2900, where it is near neutral)."""
    preset, sizes, (up, down, lateral) = VARIANTS[split_variant(name)[0]]
    spec = variant_spec(name, reynolds)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    steady = solve_steady(spec, Flow(reynolds), cache_dir=cache)
    fluid = fluid_operators(steady)
    counter = FactorCounter()
    slopes = static_slopes(fluid, counter)
    solid = Solid(mass_ratio=MASS_RATIO, reduced_velocity=flutter_guess[1])
    modes = wake_modes(fluid, counter) if reynolds == REYNOLDS else []
    try:
        flutter, _ = transfer_flutter_point(
            fluid, solid, flutter_guess[0], counter=counter, max_iterations=40
        )
        flutter_velocity, flutter_frequency, flutter_error = flutter.reduced_velocity, flutter.frequency, None
    except ConvergenceError as exc:  # e.g. the flutter mode hybridised with free-stream modes
        flutter_velocity, flutter_frequency, flutter_error = math.nan, math.nan, str(exc)
    return {
        "variant": name,
        "reynolds": reynolds,
        "preset": preset,
        "sizes": sizes,
        "domain": [up, down, lateral],
        "sponge": None if spec.sponge is None else dataclasses.asdict(spec.sponge),
        "unknowns": int(fluid.n_fluid),
        "drag_coefficient": float(2 * fluid.loads0[0]),
        "lift_slope_alpha": slopes.lift_slope_alpha,
        "moment_slope_alpha": slopes.moment_slope_alpha,
        "divergence_velocity_m1000": float(
            divergence_velocity(slopes.moment_slope_alpha, solid.r_theta, 1000)
        ),
        "wake_mode": wake_mode(modes) if modes else None,
        "wake_modes": [[v.real, v.imag, share] for v, share in modes],
        "flutter_velocity_m1000": flutter_velocity,
        "flutter_frequency_m1000": flutter_frequency,
        "flutter_error": flutter_error,
        "factorisations": counter.count,
        "wall_s": time.perf_counter() - wall0,
        "cpu_s": time.process_time() - cpu0,
        "peak_rss_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6,
    }


def wake_onset(name: str, cache: Path) -> dict:
    """The fixed plate's critical Reynolds number of the wake mode on the mesh of ``name`` (fitted
    to Re 2900): :func:`fsistab.onset.critical_onset` from Re = 2900 and the eigenvalue near 11.2i."""
    from fsistab.onset import critical_onset

    spec = variant_spec(name)
    wall0 = time.perf_counter()
    result = critical_onset(spec, Flow(REYNOLDS), "reynolds", REYNOLDS, 11.2j, cache_dir=cache)
    return {
        "variant": name,
        "critical_reynolds": result.critical_value,
        "critical_frequency": result.frequency,
        "iterations": result.iterations,
        "factorisations": result.factorisations,
        "wall_s": time.perf_counter() - wall0,
    }


def wake_spectrum(name: str, cache: Path, count: int = 10) -> dict:
    """The fixed plate's ``count`` eigenvalues nearest ``11.15i`` at Re 2900 on the mesh of ``name``
    (one factorisation): the wake mode and its neighbours, whose distance tells whether the wake
    mode couples with other modes of the domain (docs/discretisation.md)."""
    wall0 = time.perf_counter()
    steady = solve_steady(variant_spec(name), Flow(REYNOLDS), cache_dir=cache)
    pairs = eigenpairs_near(CoupledSystem(fluid_operators(steady), Solid(dofs=())), [11.15j], count)
    values = sorted((complex(p.value) for p in pairs), key=lambda v: -v.real)
    return {
        "variant": name,
        "eigenvalues": [[v.real, v.imag] for v in values],
        "wall_s": time.perf_counter() - wall0,
    }


def viv_thresholds(name: str, cache: Path, sweeps) -> dict:
    """The thresholds of the spring-mounted plate at each ``(m, U*_min, U*_max)`` of ``sweeps`` on the
    mesh of ``name`` at Re 2900 (:func:`fsistab.frequency_sweep.sweep_thresholds`, as in
    ``fsistab critical``, with the wake mode's 11.2 as the hint): the VIV windows against the wake
    mode's damping, which the domain length moves (docs/discretisation.md)."""
    from fsistab.frequency_sweep import sweep_thresholds

    wall0, cpu0 = time.perf_counter(), time.process_time()
    steady = solve_steady(variant_spec(name), Flow(REYNOLDS), cache_dir=cache)
    fluid = fluid_operators(steady)
    record = {"variant": name, "unknowns": fluid.n_fluid, "sweeps": []}
    for mass_ratio, low, high in sweeps:
        counter = FactorCounter()
        result = sweep_thresholds(
            fluid, Solid(mass_ratio=mass_ratio), (low, high), wake_frequency=11.2, counter=counter, threads=1
        )
        thresholds = [[t.reduced_velocity, t.frequency, t.kind, t.boundary] for t in result.thresholds]
        record["sweeps"].append(
            {
                "mass_ratio": mass_ratio,
                "range": [low, high],
                "thresholds": thresholds,
                "unresolved": [list(i) for i in result.unresolved],
                "factorisations": counter.count,
            }
        )
        print(name, mass_ratio, thresholds, flush=True)
    record["wall_s"] = time.perf_counter() - wall0
    record["cpu_s"] = time.process_time() - cpu0
    record["peak_rss_gb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
    return record


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("variants", nargs="*", default=list(VARIANTS))
    parser.add_argument("--out", default="docs/data/discretisation_Re2900.jsonl")
    parser.add_argument("--cache", default=None)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--flutter-guess", nargs=2, type=float, default=(0.19, 4.5), metavar=("OMEGA", "U"))
    parser.add_argument("--reynolds", type=float, default=REYNOLDS, help="flow and mesh fit (default 2900)")
    parser.add_argument("--list", action="store_true")
    parser.add_argument(
        "--wake-onset", action="store_true", help="the wake mode's critical Re instead (writes --out)"
    )
    parser.add_argument(
        "--wake-spectrum",
        action="store_true",
        help="the ten eigenvalues nearest 11.15i instead (writes --out)",
    )
    parser.add_argument(
        "--viv",
        nargs=3,
        type=float,
        action="append",
        metavar=("M", "U_MIN", "U_MAX"),
        help="the thresholds at mass ratio M for U* in [U_MIN, U_MAX] instead (repeatable; writes --out)",
    )
    args = parser.parse_args()
    if args.list:
        for name, variant in VARIANTS.items():
            print(name, variant)
        return
    parts = {name: split_variant(name) for name in args.variants}
    unknown = [name for name, (v, outlet) in parts.items() if v not in VARIANTS or outlet not in OUTLETS]
    if unknown:
        parser.error(f"unknown variants {unknown}; --list shows them")
    bad = [sweep for sweep in args.viv or [] if not (sweep[0] > 0 and 0 < sweep[1] < sweep[2])]
    if bad:
        parser.error(f"--viv takes M > 0 and 0 < U_MIN < U_MAX, got {bad}")
    SetNumThreads(args.threads)
    out = Path(args.out)
    cache = Path(args.cache) if args.cache else default_cache_dir()

    def compute(name: str) -> dict:
        if args.wake_onset:
            return wake_onset(name, cache)
        if args.viv:
            return viv_thresholds(name, cache, args.viv)
        if args.wake_spectrum:
            return wake_spectrum(name, cache)
        return run_variant(name, cache, tuple(args.flutter_guess), args.reynolds)

    run_variants(args.variants, out, compute)


if __name__ == "__main__":
    main()
