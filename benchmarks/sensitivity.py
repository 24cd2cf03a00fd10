"""Benchmark of the adjoint sensitivities: plate, Re = 2900, α0 = 2°, m = 1000.

From a flutter point found by the neutral-point Newton (not timed), measures: the complex
factorisation of ``K_ff(iω_c)``, a direct and an adjoint (transposed) fluid back-substitution with
the same factors, the adjoint mode at the neutral point, the real factorisation of ``J_ff``, the
steady adjoint of the force sensitivity (one transposed solve, ``fsistab.sensitivity.
force_sensitivity``), all 7 threshold derivatives, and the maps (force, control cylinder,
structural) at every mesh vertex. Prints unknowns, wall and CPU seconds (best of ``--repeat``),
factorisations, and each solve's cost as a fraction of a factorisation.

Usage: python benchmarks/sensitivity.py [coarse|medium] [--repeat 5] [--threads 1]
(medium only on a quiet machine.)
"""

import argparse
import time
from dataclasses import replace

import numpy as np
from ngsolve import SetNumThreads

from fsistab.bodies import Plate
from fsistab.coupled import CoupledSystem
from fsistab.critical import flutter_point
from fsistab.eigen import eigenpairs_near
from fsistab.linalg import FactorCounter, FluidFactor
from fsistab.mesh import mesh_spec
from fsistab.operators import fluid_operators
from fsistab.params import Flow, Solid
from fsistab.sensitivity import (
    AdjointSolver,
    adjoint_mode,
    force_sensitivity,
    maps_dataset,
    sensitivity_maps,
    steady_factor,
    threshold_sensitivity,
)
from fsistab.steady import solve_steady

SOLID = Solid(mass_ratio=1000, reduced_velocity=4.4, zeta_h=0.001)


def best(function, repeat: int) -> tuple[float, float, object]:
    """(wall, CPU) seconds of the fastest of ``repeat`` calls, and the last result."""
    walls, cpus = [], []
    for _ in range(repeat):
        wall, cpu = time.perf_counter(), time.process_time()
        result = function()
        walls.append(time.perf_counter() - wall)
        cpus.append(time.process_time() - cpu)
    return min(walls), min(cpus), result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("preset", nargs="?", default="coarse", choices=("coarse", "medium"))
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--cache", default=None)
    args = parser.parse_args()
    SetNumThreads(args.threads)
    spec = mesh_spec(Plate(), args.preset, 2900)
    level = solve_steady(spec, Flow(2900, 0.0), cache_dir=args.cache)
    steady = solve_steady(spec, Flow(2900, 2.0), cache_dir=args.cache, initial=level)
    fluid = fluid_operators(steady)
    system = CoupledSystem(fluid, SOLID)
    pair = max(
        (p for p in eigenpairs_near(system, [0.003 + 0.18j], 4) if p.label != "fluid"),
        key=lambda p: p.growth_rate,
    )
    point = flutter_point(fluid, SOLID, pair.frequency, pair.vector)
    at_point = replace(SOLID, reduced_velocity=point.reduced_velocity)
    critical = CoupledSystem(fluid, at_point)
    shift = 1j * point.frequency
    rng = np.random.default_rng(0)
    b = rng.standard_normal(fluid.n_fluid) + 1j * rng.standard_normal(fluid.n_fluid)

    rows = []
    counter = FactorCounter()
    wall, cpu, factor = best(lambda: FluidFactor(fluid, shift, counter), args.repeat)
    rows.append(("complex factorisation of K_ff(iω_c)", wall, cpu))
    factorisation = wall
    for name, kwargs in (
        ("direct fluid solve, refined", {}),
        ("adjoint fluid solve, refined", {"transpose": True}),
        ("adjoint fluid solve, unrefined", {"transpose": True, "refine": False}),
    ):
        wall, cpu, _ = best(lambda kwargs=kwargs: factor.solve(b, **kwargs), args.repeat)
        rows.append((name, wall, cpu))
    wall, cpu, solver = best(lambda: AdjointSolver(critical, shift, fluid_factor=factor), args.repeat)
    rows.append((f"adjoint bordered setup (n_s = {critical.n_solid} adjoint solves)", wall, cpu))
    wall, cpu, mode = best(lambda: adjoint_mode(critical, shift, point.mode, solver=solver), args.repeat)
    rows.append((f"adjoint mode at the neutral point ({mode.iterations} step)", wall, cpu))
    wall, cpu, real_factor = best(lambda: steady_factor(fluid, counter), args.repeat)
    rows.append(("real factorisation of J_ff", wall, cpu))
    real_factorisation = wall
    g = rng.standard_normal(fluid.n_fluid) + 1j * rng.standard_normal(fluid.n_fluid)
    wall, cpu, _ = best(lambda: real_factor.solve(g, transpose=True), args.repeat)
    rows.append(("steady adjoint solve J_ffᵀ (complex right-hand side)", wall, cpu))
    steady_adjoint = wall
    wall, cpu, _ = best(lambda: force_sensitivity(critical, mode, real_factor), args.repeat)
    rows.append(("force sensitivity (base-flow gradient + steady adjoint)", wall, cpu))
    factors = {shift: factor, 0j: real_factor}
    wall, cpu, _ = best(
        lambda: threshold_sensitivity(fluid, SOLID, point, factors=dict(factors)), args.repeat
    )
    rows.append(("threshold_sensitivity, 7 parameters, factorisations given", wall, cpu))

    def maps():
        m = sensitivity_maps(critical, mode, "flutter", factor=real_factor, slope=-0.01 + 0j)
        return maps_dataset([m], steady.mesh)

    wall, cpu, ds = best(maps, args.repeat)
    rows.append((f"maps at {ds.sizes['vertex']} vertices (force, control, structural)", wall, cpu))

    print(f"plate, Re 2900, alpha0 2 deg, mesh {args.preset}: {fluid.n_fluid} fluid unknowns")
    print(f"flutter point U*_c = {point.reduced_velocity:.6g}, omega_c = {point.frequency:.6g}")
    print(f"{'operation':62s} {'wall s':>9s} {'CPU s':>9s} {'/ factorisation':>16s}")
    for name, wall, cpu in rows:
        reference = real_factorisation if "J_ff" in name or "force" in name else factorisation
        print(f"{name:62s} {wall:9.4f} {cpu:9.4f} {wall / reference:16.3f}")
    print(f"factorisations made by the timed calls: {counter.count} ({args.repeat} repeats of 2)")
    print(f"steady adjoint / real factorisation: {steady_adjoint / real_factorisation:.3f}")


if __name__ == "__main__":
    main()
