"""The spring-mounted plate of Moulin & Marquet (2021, Phys. Fluids 33) on the three mesh presets.

Plate, Re = 2900, α0 = 0, m = 1000, U* = 4.7, heave and pitch (docs/model.md §2 defaults): eigenvalues
nearest the shifts 0.17i, 0.15i and 11.2i. Reported: the least stable mode with 0.1 < ω < 0.25
whose solid share of the near-body kinetic energy is at least 0.4 (flutter), the other such modes
(anti-flutter candidates: near the neutral axis the solid modes hybridise with weakly damped
low-frequency wake modes) and the least stable mode with |ω - 11.2| < 1.5 (wake). For the
finest preset run, the flutter mode is drawn (pressure snapshots at phases 0 and π/2, body
motion). Then the U* → 0 limits of the solid branches, ``(λ + iω)/ω_θ → 0.8i`` (heave) and
``-0.05 + 0.999i`` (pitch) with ``ω_θ = 1/U*``, at a small U*.

Writes NetCDF spectra to ``OUT/data``, figures to ``OUT/figures``, prints markdown tables.
Usage: python validation/plate_spectrum.py [--presets coarse medium fine] [--limit-presets coarse medium]
"""

import argparse
import time
from pathlib import Path

import numpy as np
from ngsolve import SetNumThreads

from fsistab.bodies import Plate
from fsistab.coupled import CoupledSystem
from fsistab.eigen import eigenpairs_near, spectrum_dataset
from fsistab.linalg import FactorCounter
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators
from fsistab.params import Flow, Solid
from fsistab.plots import plot_mode_snapshot, plot_solid_motion, plot_spectrum
from fsistab.steady import solve_steady
from fsistab.store import default_cache_dir, write_dataset

REYNOLDS = 2900.0
SHIFTS = (0.17j, 0.15j, 11.2j)
SOLID_RICH = 0.4  # solid share of the near-body kinetic energy of the modes listed
LIMITS = {"heave": 0.8j, "pitch": -0.05 + 0.99875j}  # σ/ω_θ of the undamped heave, ζ_θ = 0.05 pitch


def steady_and_operators(preset: str, cache: Path):
    spec = mesh_spec(Plate(), preset, REYNOLDS)
    steady = solve_steady(spec, Flow(REYNOLDS), cache_dir=cache)
    t0 = time.perf_counter()
    fluid = fluid_operators(steady)
    return spec, steady, fluid, time.perf_counter() - t0


def eigenpairs_per_shift(system, shifts, n: int):
    """Eigenpairs near each shift separately (own factorisation), with the time of each."""
    found, times = [], []
    for shift in shifts:
        t0 = time.perf_counter()
        pairs = eigenpairs_near(system, [shift], n, counter=FactorCounter())
        times.append(time.perf_counter() - t0)
        for p in pairs:
            if all(abs(p.value - q.value) > 1e-7 * max(1.0, abs(q.value)) for q in found):
                found.append(p)
    return sorted(found, key=lambda p: -p.growth_rate), times


def pick_modes(pairs):
    """(flutter, stable solid-rich modes, wake) as defined in the module docstring."""
    band = sorted(
        (p for p in pairs if 0.1 < p.frequency < 0.25 and p.solid_energy_fraction >= SOLID_RICH),
        key=lambda p: -p.growth_rate,
    )
    flutter = band[0] if band and band[0].label != "fluid" else None
    others = [p for p in band if p is not flutter]
    wake = max((p for p in pairs if abs(p.frequency - 11.2) < 1.5), key=lambda p: p.growth_rate, default=None)
    return flutter, others, wake


def fmt(p) -> str:
    if p is None:
        return "not found"
    return f"{p.growth_rate:+.5f} + {p.frequency:.5f}i ({p.label}, {p.solid_energy_fraction:.2f})"


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--presets", nargs="*", default=["coarse", "medium", "fine"])
    parser.add_argument("--limit-presets", nargs="*", default=["coarse", "medium"])
    parser.add_argument("--limit-velocity", type=float, default=0.05)
    parser.add_argument("--n-eigenvalues", type=int, default=4)
    parser.add_argument("--figures-preset", default=None, help="preset whose flutter mode is drawn (last)")
    parser.add_argument("--cache", type=Path, default=None)
    parser.add_argument("--out", type=Path, default=Path("docs"))
    args = parser.parse_args()
    SetNumThreads(2)
    cache = args.cache or default_cache_dir()
    solid = Solid(mass_ratio=1000.0, reduced_velocity=4.7)
    figures_preset = args.figures_preset or (args.presets[-1] if args.presets else None)

    rows = []
    for preset in args.presets:
        spec, steady, fluid, t_ops = steady_and_operators(preset, cache)
        system = CoupledSystem(fluid, solid)
        pairs, times = eigenpairs_per_shift(system, SHIFTS, args.n_eigenvalues)
        flutter, others, wake = pick_modes(pairs)
        ds = spectrum_dataset(pairs, system, {"preset": preset, "seconds_per_shift": times})
        write_dataset(ds, args.out / "data" / f"plate_spectrum_{preset}.nc")
        plot_spectrum(
            ds, args.out / "figures" / f"plate_spectrum_{preset}.png", title=f"plate, {preset} mesh"
        )
        steady_time = f"{steady.seconds:.0f}" + (" (cache)" if steady.from_cache else "")
        rows.append(
            f"| {preset} | {system.size} | {fmt(flutter)} | {'; '.join(fmt(p) for p in others)} | "
            f"{fmt(wake)} | {steady_time} | " + " / ".join(f"{t:.0f}" for t in times) + " |"
        )
        print(f"{preset}: {system.size} unknowns, operators {t_ops:.1f} s, shifts {times}", flush=True)
        for p in pairs:
            print(
                f"   {p.growth_rate:+.6f} {p.frequency:.6f} {p.label:8s} solid {p.solid_energy_fraction:.3f} "
                f"h {p.solid[0]:.3f} θ {p.solid[1]:.3f} residual {p.residual:.1e} shift {p.shift}"
            )
        print(rows[-1], flush=True)
        if preset == figures_preset and flutter is not None:
            for phase, name in ((0.0, "0"), (np.pi / 2, "pi2")):
                plot_mode_snapshot(
                    steady,
                    fluid.free_dofs,
                    flutter,
                    system,
                    args.out / "figures" / f"plate_flutter_{preset}_phase{name}.png",
                    phase=phase,
                )
            motion = plot_solid_motion(flutter, args.out / "figures" / f"plate_flutter_{preset}_motion.png")
            h, theta = flutter.solid[0], flutter.solid[1]
            print(
                f"flutter mode ({preset}): ĥ = {h:.4f}, θ̂ = {theta:.4f}, "
                f"phase of θ̂ relative to ĥ {np.degrees(np.angle(theta / h)):.1f} deg; figures "
                f"{motion.path.parent}",
                flush=True,
            )
        del system, fluid, steady

    print(
        "| mesh | unknowns | flutter σ (label, solid share) | other solid-rich modes | wake σ "
        "| steady [s] | eigen per shift [s] |"
    )
    print("|---|---|---|---|---|---|---|")
    for row in rows:
        print(row)

    if not args.limit_presets:
        return
    u = args.limit_velocity
    omega = 1.0 / u
    limit_solid = Solid(mass_ratio=1000.0, reduced_velocity=u)
    # offset so that no shift lands on the in-vacuo eigenvalue itself
    shifts = [omega * (LIMITS["heave"] + 0.002 + 0.002j), omega * (LIMITS["pitch"] + 0.002 + 0.002j)]
    print(
        f"\nU* = {u:g} (ω_θ = {omega:g}): σ/ω_θ of the solid branches; "
        "reference heave 0.8i, pitch -0.05+0.999i"
    )
    print("| mesh | unknowns | heave σ/ω_θ | pitch σ/ω_θ | eigen [s] |")
    print("|---|---|---|---|---|")
    for preset in args.limit_presets:
        spec, steady, fluid, _ = steady_and_operators(preset, cache)
        system = CoupledSystem(fluid, limit_solid)
        t0 = time.perf_counter()
        pairs, _ = eigenpairs_per_shift(system, shifts, 2)
        seconds = time.perf_counter() - t0
        ds = spectrum_dataset(pairs, system, {"preset": preset})
        write_dataset(ds, args.out / "data" / f"plate_small_velocity_{preset}.nc")
        found = {}
        for name, target in LIMITS.items():
            candidates = [p for p in pairs if p.label != "fluid"]
            best = min(candidates or pairs, key=lambda p, t=target: abs(p.value / omega - t))
            found[name] = f"{best.value.real / omega:+.5f} + {best.value.imag / omega:.5f}i ({best.label})"
        print(
            f"| {preset} | {system.size} | {found['heave']} | {found['pitch']} | {seconds:.0f} |", flush=True
        )


if __name__ == "__main__":
    main()
