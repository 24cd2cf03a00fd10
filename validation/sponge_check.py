"""Does a sponge layer remove the spurious neutral curves of the truncated domain (issue 14)?

The plate at Re = 2900 (cached steady state of ``--preset``), solid parameters of MODEL.md. A
sponge ``σ(x, y) u`` is added to the linearised momentum equation only (the steady state is not
changed): ``σ = σ_max s`` with ``s`` a smooth step (``3t² - 2t³``) over the last quarter of the
domain downstream and upstream and the outer 30 % laterally. The thresholds at each mass ratio
come from the frequency sweep (``fsistab.frequency_sweep.sweep_thresholds``) with and without it.

Usage: python validation/sponge_check.py [coarse|medium] [--sigma 1.0] [--mass-ratios 1000 10 30]
"""

import argparse
import time
from dataclasses import replace

from fsistab.frequency_sweep import sweep_thresholds
from fsistab.linalg import FactorCounter
from fsistab.mesh import mesh_spec
from fsistab.operators import _to_scipy, fluid_operators
from fsistab.params import Flow, Plate, Solid
from fsistab.steady import solve_steady
from fsistab.store import default_cache_dir


def with_sponge(fluid, spec, sigma_max: float):
    """``fluid`` with ``∫ σ u·v`` added to ``J_ff`` (profile in the module docstring)."""
    from ngsolve import BilinearForm, IfPos, InnerProduct, dx, x, y

    up, down, lat = spec.domain.upstream, spec.domain.downstream, spec.domain.lateral

    def step(distance, width):  # 0 inside, rising smoothly to 1 at the boundary
        t = IfPos(distance, distance / width, 0.0)
        return t * t * (3 - 2 * t)

    sx = step(x - 0.75 * down, 0.25 * down)
    su = step(-(x + 0.75 * up), 0.25 * up)
    sy = step(y * y - (0.7 * lat) ** 2, lat**2 - (0.7 * lat) ** 2)
    sigma = sigma_max * (sx + su + sy - sx * sy - su * sy)
    space = fluid.steady.space
    (u, _), (v, _) = space.TnT()
    form = BilinearForm(space)
    form += sigma * InnerProduct(u, v) * dx
    form.Assemble()
    index = fluid.free_dofs
    block = _to_scipy(form.mat, space.ndof)[index][:, index]
    return replace(fluid, jff=(fluid.jff + block).tocsr(), analyses={})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("preset", nargs="?", default="coarse")
    parser.add_argument("--sigma", type=float, default=1.0)
    parser.add_argument("--mass-ratios", type=float, nargs="+", default=[1000.0, 10.0, 30.0])
    args = parser.parse_args()
    spec = mesh_spec(Plate(), args.preset, 2900)
    fluid = fluid_operators(solve_steady(spec, Flow(2900), cache_dir=default_cache_dir()))
    for label, operators in (
        ("no sponge", fluid),
        (f"sponge {args.sigma:g}", with_sponge(fluid, spec, args.sigma)),
    ):
        for mass in args.mass_ratios:
            low, high = (2.0, 10.0) if mass >= 100 else (1.5, 6.0)
            counter, t0 = FactorCounter(), time.perf_counter()
            result = sweep_thresholds(
                operators, Solid(mass_ratio=mass, reduced_velocity=low), (low, high), counter=counter
            )
            elapsed = time.perf_counter() - t0
            samples = len(result.frequencies)
            print(
                f"{label}, m = {mass:g}: {samples} samples, {counter.count} factorisations, {elapsed:.0f} s"
            )
            for t in result.thresholds:
                print(
                    f"    {t.kind:10s} {t.boundary:16s} U* = {t.reduced_velocity:.6f}  ω = {t.frequency:.6f}"
                )


if __name__ == "__main__":
    main()
