"""Where the fixed plate's weakly damped low-frequency fluid modes live, and what a lateral sponge
does to them (these modes fold the map's low-mass-ratio neutral curves; docs/discretisation.md).

Plate at Re 2900 (``--reynolds``) on a mesh preset (default ``medium``, its steady state cached):
the eigenvalues nearest each ``--shift`` of the fixed body (shift-invert Arnoldi,
:func:`fsistab.eigen.eigenpairs_near`), and for each mode the fraction of its kinetic energy
``½∫|û|²`` in regions of the domain: the band ``|Y| < 20``, ``20 < |Y| < 40`` and ``|Y| > 40``,
each split along X, and within 5 chords of the body's centre (``r<5``: how much of the mode the
body feels). With ``--lateral-sponge SIGMA START`` the term ``∫ σ(Y) u·v`` is added to ``J_ff``
first (test only; docs/model.md §7), ``σ`` rising from 0 at ``|Y| = START`` to ``SIGMA`` at the lateral
boundary by the smooth step ``3t² − 2t³`` in
``t = (Y² − START²)/(l² − START²)``. With ``--viscosity NU START`` the term ``NU ∫ s(X) ∇u:∇v``
is added instead (test only), ``s`` rising by the same step from 0 at ``X = START`` to 1 at
``START + 20``: whether the modes' damping is viscous downstream.

Usage: python validation/far_field_modes.py [--preset medium] [--shift 0.2j 0.6j] [--count 8]
           [--lateral-sponge 0.2 40] [--viscosity 0.02 40] [--far SIZE] [--sponge SPEC]
           [--size NAME=VALUE] [--far-wake H END HALF]
           [--reynolds 2900] [--cache DIR]

``--far 4 --sponge 0.2,0.25`` is an earlier ``medium`` preset (4-chord outer elements, no far-field
layer), whose modes docs/discretisation.md lists; ``--sponge`` takes fsistab's ``--sponge`` values.
"""

import argparse
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from sponge_check import add_size_option, size_overrides  # the sibling script's (run from validation/)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--preset", default="medium")
    parser.add_argument("--shift", nargs="+", type=complex, default=[0.2j, 0.6j])
    parser.add_argument("--count", type=int, default=8, help="eigenvalues per shift")
    parser.add_argument("--lateral-sponge", type=float, nargs=2, metavar=("SIGMA", "START"))
    parser.add_argument("--viscosity", type=float, nargs=2, metavar=("NU", "START"))
    parser.add_argument("--far", type=float, help="outer element size (default: the preset's)")
    parser.add_argument(
        "--sponge",
        default="preset",
        help="the sponge, as fsistab's --sponge: preset, none, SIGMA_MAX,ZONE[,FAR_SIGMA,FAR_RAMP]",
    )
    parser.add_argument("--reynolds", type=float, default=2900.0)
    parser.add_argument("--cache", type=Path, default=None)
    add_size_option(parser)
    args = parser.parse_args()

    from ngsolve import BilinearForm, Grad, IfPos, InnerProduct, dx, x, y

    from fsistab.bodies import Plate
    from fsistab.coupled import CoupledSystem
    from fsistab.eigen import eigenpairs_near
    from fsistab.errors import InputError
    from fsistab.mesh import mesh_spec
    from fsistab.operators import _to_scipy, fluid_operators
    from fsistab.params import Flow, Solid, parse_sponge
    from fsistab.steady import solve_steady
    from fsistab.store import default_cache_dir

    sizes = size_overrides(args)  # bad input refused before any mesh
    if args.far is not None:
        sizes["far"] = args.far
    try:
        spec = mesh_spec(Plate(), args.preset, args.reynolds, sponge=parse_sponge(args.sponge), **sizes)
    except InputError as exc:
        parser.error(str(exc))
    print(f"Re {args.reynolds:g}, far-field size {spec.sizes.far:g}, sponge: {spec.sponge}")
    steady = solve_steady(spec, Flow(args.reynolds), cache_dir=args.cache or default_cache_dir())
    fluid = fluid_operators(steady)
    space, index = steady.space, fluid.free_dofs
    lateral = steady.mesh_spec.domain.lateral
    (u, _), (v, _) = space.TnT()

    def velocity_mass(weight, gradients=False):
        form = BilinearForm(space)
        form += weight * (InnerProduct(Grad(u), Grad(v)) if gradients else InnerProduct(u, v)) * dx
        form.Assemble()
        return _to_scipy(form.mat, space.ndof)[index][:, index].tocsr()

    def inside(low, high, coordinate):
        return IfPos(coordinate - low, 1.0, 0.0) * IfPos(high - coordinate, 1.0, 0.0)

    far = 1e4
    strips = {"|Y|<20": (0.0, 20.0), "20<|Y|<40": (20.0, 40.0), "|Y|>40": (40.0, far)}
    stretches = {"X<0": (-far, 0.0), "0<X<80": (0.0, 80.0), "80<X<120": (80.0, 120.0), "X>120": (120.0, far)}
    masses = {
        f"{strip}, {stretch}": velocity_mass(inside(*band, IfPos(y, y, -y)) * inside(*span, x))
        for strip, band in strips.items()
        for stretch, span in stretches.items()
    }
    near_body = velocity_mass(IfPos(25.0 - x * x - y * y, 1.0, 0.0))
    if args.lateral_sponge:
        sigma, start = args.lateral_sponge
        t = (y * y - start**2) / (lateral**2 - start**2)
        step = IfPos(t, IfPos(1 - t, 3 * t * t - 2 * t * t * t, 1.0), 0.0)
        fluid = replace(fluid, jff=(fluid.jff + velocity_mass(sigma * step)).tocsr(), analyses={})
        print(f"lateral sponge: sigma_max {sigma} from |Y| = {start} to {lateral}")
    if args.viscosity:
        nu, start = args.viscosity
        t = IfPos(x - start, IfPos(start + 20 - x, (x - start) / 20, 1.0), 0.0)
        extra = velocity_mass(nu * t * t * (3 - 2 * t), gradients=True)
        fluid = replace(fluid, jff=(fluid.jff + extra).tocsr(), analyses={})
        print(f"viscosity {nu} from X = {start} to {start + 20} and beyond")
    t0 = time.perf_counter()
    pairs = eigenpairs_near(CoupledSystem(fluid, Solid(dofs=())), args.shift, args.count)
    print(f"{fluid.n_fluid} unknowns, {len(pairs)} modes in {time.perf_counter() - t0:.0f} s")
    for pair in sorted(pairs, key=lambda p: p.value.imag):
        q = pair.vector
        total = float(np.vdot(q, fluid.mff @ q).real)
        shares = {name: float(np.vdot(q, m @ q).real) / total for name, m in masses.items()}
        strip_shares = {s: sum(v for k, v in shares.items() if k.startswith(s + ",")) for s in strips}
        body = float(np.vdot(q, near_body @ q).real) / total
        print(
            f"{pair.value.real:+.5f}{pair.value.imag:+.5f}i  r<5 {body:.1e}  "
            + "  ".join(f"{s} {v:.2f}" for s, v in strip_shares.items())
            + "  |  "
            + "  ".join(f"{k} {v:.2f}" for k, v in shares.items() if v >= 0.05)
        )


if __name__ == "__main__":
    main()
