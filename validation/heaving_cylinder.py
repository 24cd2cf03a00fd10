"""Heaving spring-mounted cylinder: fluid and solid eigenvalue branches along U*.

The behaviour to reproduce (Navrose & Mittal 2016; Zhang et al. 2015; Sabino et al. 2020;
docs/validation.md, "Heaving cylinder"): a fluid and a structure branch, tending as U* → 0 to the
fixed-cylinder mode and to ``iω_n``, interacting near coincidence ``ω_n ≈ ω_wake``.

Re = 60, m = 20, heave only (docs/model.md §10 scalings, ``Solid.cylinder``). Both branches start at
the lowest U* from the fixed-cylinder mode and from ``iω_n √(m/(m+1))`` and are followed by
nearest-eigenvalue continuation: the next eigenvalue is predicted from the previous ones (secant
in σ for the fluid branch, in σU* for the solid branch, whose frequency scales with 1/U*) and
inverse iterations from the previous mode, shifted at the prediction, converge to the eigenvalue
there (``fsistab.tracking.refine_eigenpair``; it falls back on Arnoldi if they stall). At the
first U*, or if both branches land on one eigenvalue, shift-invert Arnoldi runs near each
prediction and the pair of distinct eigenvalues closest to the predictions continues the
branches. Shifts sit on a 0.01 grid and a factorisation is reused while the prediction stays
within ``--reuse-radius`` of an earlier shift (the fluid blocks do not depend on U*). Beyond
coincidence the structure mode sits among weakly damped wake modes that share the solid energy; if
the solid share of the solid branch drops by more than ``--share-drop`` from one U* to the next,
Arnoldi (six eigenvalues near the prediction) re-checks it and the most solid-rich eigenpair other
than the fluid branch's is kept. Writes a NetCDF of the branches and a figure, prints a markdown
table.

Usage: python validation/heaving_cylinder.py [--preset medium] [--cache DIR] [--out docs]
"""

import argparse
import itertools
import math
import time
from collections import OrderedDict
from pathlib import Path

import numpy as np
import xarray as xr
from ngsolve import SetNumThreads

from fsistab.bodies import Cylinder
from fsistab.coupled import CoupledSystem
from fsistab.eigen import Eigenpair, eigenpairs_near, label_mode
from fsistab.linalg import FactorCounter
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators
from fsistab.params import Flow, Solid
from fsistab.plots import plot_branches
from fsistab.steady import solve_steady
from fsistab.store import default_cache_dir, json_attr, write_dataset
from fsistab.tracking import refine_eigenpair

FIXED_REFERENCE = 0.046839 + 0.74518j  # fixed cylinder at Re = 60 (StabFem, Fabre et al.)
DEFAULT_VELOCITIES = [
    *np.arange(3.0, 6.0, 0.5),
    *np.arange(6.0, 9.0, 0.25),
    *np.arange(9.0, 12.01, 0.5),
]
BRANCHES = ("fluid", "solid")


class Factors:
    """Fluid factorisations by shift (at most ``size`` kept), reused within ``radius`` of a shift."""

    def __init__(self, radius: float, size: int = 4):
        self.radius, self.size = radius, size
        self.items: OrderedDict[complex, object] = OrderedDict()

    def shift_for(self, predicted: complex) -> complex:
        near = [s for s in self.items if abs(s - predicted) <= self.radius]
        if near:
            return min(near, key=lambda s: abs(s - predicted))
        # on a 0.01 grid, offset so that a shift never sits on an eigenvalue
        grid = complex(round(predicted.real, 2), round(predicted.imag, 2))
        return grid + (0.0013 + 0.0017j)

    def subset(self, shift: complex) -> dict:
        return {shift: self.items[shift]} if shift in self.items else {}

    def keep(self, found: dict) -> None:
        for shift, factor in found.items():
            self.items[shift] = factor
            self.items.move_to_end(shift)
        while len(self.items) > self.size:
            self.items.popitem(last=False)


def predict(branch: dict, velocity: float, inverse: bool) -> complex:
    """Secant extrapolation of σ (or of σU* when ``inverse``) from the last two points."""
    u, s = branch["velocity"], branch["value"]
    w = [s[i] * (u[i] if inverse else 1.0) for i in range(len(s))]
    if len(w) == 1:
        guess = w[-1]
    else:
        guess = w[-1] + (w[-1] - w[-2]) * (velocity - u[-1]) / (u[-1] - u[-2])
    return guess / velocity if inverse else guess


def assign(candidates, predictions: dict[str, complex]):
    """The distinct eigenpairs minimising the summed distance to the branch predictions."""
    names = list(predictions)
    best = min(
        itertools.permutations(candidates, len(names)),
        key=lambda combo: sum(abs(p.value - predictions[n]) for p, n in zip(combo, names, strict=True)),
    )
    return dict(zip(names, best, strict=True))


def zero_crossings(u: np.ndarray, growth: np.ndarray) -> list[float]:
    """U* where the growth rate changes sign (linear interpolation)."""
    out = []
    for i in range(len(u) - 1):
        if growth[i] == 0 or growth[i] * growth[i + 1] < 0:
            out.append(float(u[i] - growth[i] * (u[i + 1] - u[i]) / (growth[i + 1] - growth[i])))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--preset", default="medium")
    parser.add_argument("--reynolds", type=float, default=60.0)
    parser.add_argument("--mass-ratio", type=float, default=20.0)
    parser.add_argument("--velocities", type=float, nargs="+", default=DEFAULT_VELOCITIES)
    parser.add_argument("--n-eigenvalues", type=int, default=3, help="per shift, in Arnoldi solves")
    parser.add_argument("--reuse-radius", type=float, default=0.015)
    parser.add_argument(
        "--share-drop",
        type=float,
        default=0.15,
        help="re-check the solid branch by Arnoldi when its solid energy share drops by more than this",
    )
    parser.add_argument("--cache", type=Path, default=None)
    parser.add_argument("--out", type=Path, default=Path("docs"))
    args = parser.parse_args()
    SetNumThreads(2)
    cache = args.cache or default_cache_dir()
    m, reynolds = args.mass_ratio, args.reynolds
    velocities = sorted(float(round(u, 6)) for u in args.velocities)
    t_start = time.perf_counter()

    spec = mesh_spec(Cylinder(), args.preset, reynolds)
    steady = solve_steady(spec, Flow(reynolds), cache_dir=cache)
    t0 = time.perf_counter()
    fluid = fluid_operators(steady)
    t_operators = time.perf_counter() - t0
    d = spec.domain
    domain = f"[-{d.upstream:g}, {d.downstream:g}] × [-{d.lateral:g}, {d.lateral:g}]"
    steady_time = "cache" if steady.from_cache else f"{steady.seconds:.0f} s"
    print(
        f"mesh {args.preset} (wall {spec.sizes.wall:.4f} D), domain {domain}, "
        f"{fluid.n_fluid} fluid unknowns; steady {steady_time}, "
        f"operators {t_operators:.1f} s",
        flush=True,
    )

    counter = FactorCounter()
    factors = Factors(args.reuse_radius)

    def solve_near(system, predicted: complex):
        shift = factors.shift_for(predicted)
        found = factors.subset(shift)
        pairs = eigenpairs_near(system, [shift], args.n_eigenvalues, counter=counter, fluid_factors=found)
        factors.keep(found)
        return pairs, shift

    def refine(system, predicted: complex, start: np.ndarray):
        shift = factors.shift_for(predicted)
        sigma, q, residual, factor = refine_eigenpair(
            system, shift, start, counter=counter, fluid_factor=factors.items.get(shift)
        )
        factors.keep({shift: factor})
        if sigma.imag < 0:
            sigma, q = np.conj(sigma), np.conj(q)
        solid, fluid_part = system.split(q)
        energy = 0.5 * float(np.vdot(fluid_part, system.fluid.mff_near @ fluid_part).real)
        label, fraction = label_mode(solid, system.solid, energy)
        return Eigenpair(complex(sigma), q, residual, label, solid, fraction, shift), shift

    # fixed cylinder on the same mesh (the U* → 0 limit of the fluid branch)
    fixed_system = CoupledSystem(fluid, Solid(dofs=()))
    pairs, _ = solve_near(fixed_system, FIXED_REFERENCE)
    fixed = min(pairs, key=lambda p: abs(p.value - FIXED_REFERENCE)).value
    print(
        f"fixed cylinder: σ = {fixed.real:.5f} + {fixed.imag:.5f}i (reference {FIXED_REFERENCE})", flush=True
    )

    branches = {name: {"velocity": [], "value": [], "pair": [], "shift": []} for name in BRANCHES}
    seconds, factorisations = [], []
    print("| U* | ω_n | fluid branch σ | label | solid branch σ | label | ω_s/(ω_n√(m/(m+1))) | time [s] |")
    print("|---|---|---|---|---|---|---|---|")
    for velocity in velocities:
        t0 = time.perf_counter()
        before = counter.count
        omega_n = 2 * math.pi / velocity
        system = CoupledSystem(fluid, Solid.cylinder(m, velocity))
        if not branches["fluid"]["value"]:
            predictions = {"fluid": fixed, "solid": 1j * omega_n * math.sqrt(m / (m + 1))}
        else:
            predictions = {
                "fluid": predict(branches["fluid"], velocity, inverse=False),
                "solid": predict(branches["solid"], velocity, inverse=True),
            }
        chosen, shifts = {}, {}
        if branches["fluid"]["value"]:
            # inverse iterations from the previous modes, shift at the prediction
            for name, guess in predictions.items():
                chosen[name], shifts[name] = refine(system, guess, branches[name]["pair"][-1].vector)
        if not chosen or abs(chosen["fluid"].value - chosen["solid"].value) < 1e-6:
            # first point, or both branches fell on one eigenvalue: Arnoldi near each prediction
            candidates = {}
            for name, guess in predictions.items():
                pairs, shifts[name] = solve_near(system, guess)
                for p in pairs:
                    candidates.setdefault(complex(round(p.value.real, 9), round(p.value.imag, 9)), p)
            chosen = assign(list(candidates.values()), predictions)
        previous_share = (
            branches["solid"]["pair"][-1].solid_energy_fraction if branches["solid"]["pair"] else 0
        )
        if chosen["solid"].solid_energy_fraction < previous_share - args.share_drop:
            # the structure mode sits among weakly damped wake modes that share the solid energy:
            # if inverse iterations stepped onto one of them, take the most solid-rich eigenpair
            # that Arnoldi finds near the prediction
            wide = eigenpairs_near(system, [factors.shift_for(predictions["solid"])], 6, counter=counter)
            others = [p for p in wide if abs(p.value - chosen["fluid"].value) > 1e-6]
            best = max(others, key=lambda p: p.solid_energy_fraction, default=None)
            if best is not None and best.solid_energy_fraction > chosen["solid"].solid_energy_fraction:
                print(
                    f"U* = {velocity:g}: solid branch {chosen['solid'].value:.5f} (share "
                    f"{chosen['solid'].solid_energy_fraction:.2f}) replaced by {best.value:.5f} (share "
                    f"{best.solid_energy_fraction:.2f})",
                    flush=True,
                )
                chosen["solid"] = best
        for name, pair in chosen.items():
            b = branches[name]
            b["velocity"].append(velocity)
            b["value"].append(pair.value)
            b["pair"].append(pair)
            b["shift"].append(shifts[name])
        seconds.append(time.perf_counter() - t0)
        factorisations.append(counter.count - before)
        f, s = chosen["fluid"], chosen["solid"]
        print(
            f"| {velocity:g} | {omega_n:.4f} | {f.value.real:+.5f} + {f.value.imag:.5f}i | {f.label} | "
            f"{s.value.real:+.5f} + {s.value.imag:.5f}i | {s.label} | "
            f"{s.value.imag / (omega_n * math.sqrt(m / (m + 1))):.4f} | {seconds[-1]:.0f} |",
            flush=True,
        )

    u = np.array(velocities)
    values = np.column_stack([np.array(branches[n]["value"]) for n in BRANCHES])
    pairs_of = {n: branches[n]["pair"] for n in BRANCHES}
    ds = xr.Dataset(
        {
            "growth_rate": (("reduced_velocity", "branch"), values.real),
            "frequency": (("reduced_velocity", "branch"), values.imag),
            "residual": (("reduced_velocity", "branch"), _stack(pairs_of, lambda p: p.residual)),
            "label": (("reduced_velocity", "branch"), _stack(pairs_of, lambda p: p.label).astype(str)),
            "solid_energy_fraction": (
                ("reduced_velocity", "branch"),
                _stack(pairs_of, lambda p: p.solid_energy_fraction),
            ),
            "shift_real": (
                ("reduced_velocity", "branch"),
                np.array([branches[n]["shift"] for n in BRANCHES]).T.real,
            ),
            "shift_imag": (
                ("reduced_velocity", "branch"),
                np.array([branches[n]["shift"] for n in BRANCHES]).T.imag,
            ),
            "natural_frequency": ("reduced_velocity", 2 * np.pi / u),
            "seconds": ("reduced_velocity", np.array(seconds)),
            "factorisations": ("reduced_velocity", np.array(factorisations)),
        },
        coords={"reduced_velocity": u, "branch": list(BRANCHES)},
        attrs={
            "case": "heaving cylinder (docs/validation.md); docs/model.md §10 scalings",
            "convention": "sigma = growth_rate + i frequency of sigma M q + J q = 0; time unit D/U",
            "reynolds": reynolds,
            "mass_ratio": m,
            "mesh": json_attr(spec.describe()),
            "ndof": fluid.n_fluid + 2,
            "fixed_cylinder_growth_rate": fixed.real,
            "fixed_cylinder_frequency": fixed.imag,
            "total_seconds": time.perf_counter() - t_start,
            "total_factorisations": counter.count,
        },
    )
    data_path = write_dataset(ds, args.out / "data" / "heaving_cylinder.nc")
    figure = plot_branches(
        ds,
        args.out / "figures" / "heaving_cylinder.png",
        reference_lines={
            "(2π/U*)√(m/(m+1))": 2 * np.pi / u * math.sqrt(m / (m + 1)),
            f"fixed cylinder ω = {fixed.imag:.4f}": fixed.imag,
        },
        title=f"heaving cylinder, Re = {reynolds:g}, m = {m:g} ({args.preset} mesh; filled: unstable)",
    )
    for name in BRANCHES:
        crossings = zero_crossings(u, ds["growth_rate"].sel(branch=name).values)
        print(f"{name} branch: growth rate changes sign at U* = {', '.join(f'{c:.3f}' for c in crossings)}")
    print(
        f"{len(u)} values of U*, {counter.count} factorisations, {time.perf_counter() - t_start:.0f} s; "
        f"data {data_path}, figure {figure}"
    )


def _stack(pairs_of: dict, attribute) -> np.ndarray:
    return np.column_stack([np.array([attribute(p) for p in pairs_of[n]]) for n in BRANCHES])


if __name__ == "__main__":
    main()
