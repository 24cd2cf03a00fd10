"""A smaller domain for the linear operators, with its outer layer stretched (issue #44's far-field lever).

The `quick` mesh's element sizes on a domain ``--domain UPSTREAM DOWNSTREAM LATERAL`` smaller than
its own ``[-80, 160] × [-80, 80]`` (outlet and far-field layers as the preset's, docs/model.md §7.1),
and optionally its outer ``--width`` chords upstream and to the sides stretched in the linear
operators only (the steady state is that of the small domain)::

    ∂/∂x → γ_x⁻¹ ∂/∂x,   ∂/∂y → γ_y⁻¹ ∂/∂y,   dx dy → γ_x γ_y dx dy,
    γ = 1 + (β − 1 + iα) S(t),   S(t) = 3t² − 2t³,   t ∈ [0, 1] across the layer,

in every term of ``J_ff`` and ``M_f`` (docs/model.md §7; the base flow's gradient too). A real
``β`` maps the layer onto ``(β + 1)/2`` times its width, so that the potential far field, which
decays like ``1/r``, sees a larger domain; ``α`` (a complex stretching, a PML) damps waves in it.
Prints each mass ratio's thresholds from fsistab's frequency sweep and its factorisations; the
variants are compared with the same sweep on `quick` itself (no ``--domain``) in
docs/performance.md ("The `quick` map: where its time goes").

With ``α ≠ 0`` the operators are complex and ``G(0)`` (divergence, and the sweep's band) is taken
from the unstretched operators: only the dynamic thresholds are compared. With a real stretching
``G(0)`` is the stretched operators'.

``--factorisations N``: first time N complex factorisations of the antisymmetric fields' ``K_ff(0.3i)``
(wall and CPU time of each), the cost of one exact sample of a map on this domain.

Usage: python validation/far_field_stretching.py [--domain 50 160 50] [--beta 7] [--alpha 0]
       [--width 10] [--far-sigma 0.2] [--masses 1000 10] [--factorisations 0]
"""

import argparse
import time
from dataclasses import replace

import numpy as np

import fsistab.frequency_sweep as frequency_sweep
from fsistab.bodies import Plate
from fsistab.frequency_sweep import sweep_thresholds
from fsistab.linalg import FactorCounter, FluidFactor
from fsistab.mesh import mesh_spec
from fsistab.operators import _to_scipy, fluid_operators, sponge_coefficient
from fsistab.params import Domain, Flow, Solid, Sponge
from fsistab.steady import solve_steady, taylor_hood_space
from fsistab.store import default_cache_dir
from fsistab.symmetry import antisymmetric_operators

RANGES = {1000.0: (3.0, 8.0), 10.0: (0.6, 4.0)}  # U* ranges holding quick's flutter thresholds


def layer_factors(domain: Domain, width: float, beta: float, alpha: float):
    """``(γ_x, γ_y)`` as coefficient functions: 1 inside, the stretching in the outer ``width``
    chords upstream (``X < −(upstream − width)``) and to the sides (``|Y| > lateral − width``)."""
    from ngsolve import IfPos, x, y

    def ramp(t):
        t = IfPos(t, IfPos(1 - t, t, 1.0), 0.0)
        return t * t * (3 - 2 * t)

    c = complex(beta - 1.0, alpha) if alpha else beta - 1.0
    across_x = ramp((-(domain.upstream - width) - x) / width)
    across_y = ramp((IfPos(y, y, -y) - (domain.lateral - width)) / width)
    return 1 + c * across_x, 1 + c * across_y


def _oseen(steady, gamma, u, p, v, q):
    """``(J_ff, M_f)`` integrands of docs/model.md §7 at ``θ0 = 0`` in stretched coordinates, the
    sponge included, each times the area factor ``γ_x γ_y``."""
    from ngsolve import CF, Grad

    def grad(w):
        g = Grad(w)
        return [[g[i, j] / gamma[j] for j in range(2)] for i in range(2)]

    base, nu, sigma = steady.velocity, 1.0 / steady.flow.reynolds, sponge_coefficient(steady)
    relative = base - CF((-1.0, 0.0))
    gu, gv, gb = grad(u), grad(v), grad(base)
    pairs = [(i, j) for i in range(2) for j in range(2)]
    mass = u[0] * v[0] + u[1] * v[1]
    stiffness = (
        sum(gu[i][j] * relative[j] * v[i] + gb[i][j] * u[j] * v[i] for i, j in pairs)
        + nu * sum((gu[i][j] + gu[j][i]) * gv[i][j] for i, j in pairs)
        - p * (gv[0][0] + gv[1][1])
        - q * (gu[0][0] + gu[1][1])
        + (0 if sigma is None else sigma * mass)
    )
    area = gamma[0] * gamma[1]
    return stiffness * area, mass * area


def stretched_operators(fluid, width: float, beta: float, alpha: float):
    """``fluid`` with ``J_ff`` and ``M_f`` stretched in the outer layer: the stretched integrands
    minus the same integrands unstretched, added to fsistab's blocks (zero outside the layer)."""
    from ngsolve import BilinearForm, TaskManager, dx

    steady = fluid.steady
    space = taylor_hood_space(steady.mesh, complex=bool(alpha))
    (u, p), (v, q) = space.TnT()
    stretched = _oseen(steady, layer_factors(steady.mesh_spec.domain, width, beta, alpha), u, p, v, q)
    plain = _oseen(steady, (1.0, 1.0), u, p, v, q)
    index = fluid.free_dofs

    def assembled(integrand):
        form = BilinearForm(space)
        form += integrand * dx
        form.Assemble()
        return _to_scipy(form.mat, space.ndof)[index][:, index]

    blocks = []
    with TaskManager():
        for new, old, block in zip(stretched, plain, (fluid.jff, fluid.mff), strict=True):
            # the unstretched integrands must be fsistab's own blocks
            difference = abs(assembled(old) - block).max()
            print(f"unstretched against fsistab's block: largest difference {difference:.1e}")
            blocks.append((block + assembled(new - old)).tocsr())
    return replace(fluid, jff=blocks[0], mff=blocks[1], analyses={})


def _static_from(unstretched):
    """Make the sweep take ``G(0)`` from ``unstretched`` (complex blocks have no real ``G(0)``)."""

    class Static(frequency_sweep._StaticSample):
        def __init__(self, _fluid, *rest, **options):
            super().__init__(unstretched, *rest, **options)

    frequency_sweep._StaticSample = Static


def time_factorisations(fluid, count: int) -> None:
    """Wall and CPU time of ``count`` factorisations of the antisymmetric ``K_ff(0.3i)`` (after the
    symbolic analysis, made once per operators)."""
    if count < 1:
        return
    antisymmetric = antisymmetric_operators(fluid)
    FluidFactor(antisymmetric, 0.3j)
    for _ in range(count):
        wall, cpu = time.perf_counter(), time.thread_time()
        FluidFactor(antisymmetric, 0.3j)
        print(f"factorisation of {antisymmetric.n_fluid} unknowns: {time.perf_counter() - wall:.2f} s wall, "
              f"{time.thread_time() - cpu:.2f} s CPU")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--domain", type=float, nargs=3, default=None)
    parser.add_argument("--beta", type=float, default=1.0)
    parser.add_argument("--alpha", type=float, default=0.0)
    parser.add_argument("--width", type=float, default=10.0)
    parser.add_argument("--far-sigma", type=float, default=0.2)
    parser.add_argument("--masses", type=float, nargs="*", default=[1000.0, 10.0], choices=list(RANGES))
    parser.add_argument("--factorisations", type=int, default=0)
    args = parser.parse_args()
    domain = None if args.domain is None else Domain(*args.domain)
    sponge = "preset" if domain is None else Sponge(0.2, 0.25, args.far_sigma, 10.0)
    spec = mesh_spec(Plate(), "quick", 2900.0, domain, sponge=sponge)
    steady = solve_steady(spec, Flow(2900.0), cache_dir=default_cache_dir())
    fluid = fluid_operators(steady)
    time_factorisations(fluid, args.factorisations)
    unstretched = fluid
    if args.beta != 1.0 or args.alpha:
        if args.alpha:
            _static_from(unstretched)
        fluid = stretched_operators(fluid, args.width, args.beta, args.alpha)
    counter = FactorCounter()
    # G(0)'s factorisation, shared by the mass ratios: of the operators swept (real stretching),
    # or of the unstretched ones whose G(0) the sweep then takes (complex stretching)
    static = FluidFactor(unstretched if args.alpha else fluid, 0.0, counter) if args.masses else None
    print(f"domain {spec.domain}, {steady.space.ndof} unknowns; β = {args.beta}, α = {args.alpha}, "
          f"layer {args.width} chords, far-field layer σ {args.far_sigma}")  # fmt: skip
    for mass_ratio in args.masses:
        start, clock = counter.count, time.perf_counter()
        solid = Solid(mass_ratio=mass_ratio)
        result = sweep_thresholds(fluid, solid, RANGES[mass_ratio], static_factor=static, counter=counter)
        found = ", ".join(
            f"{t.kind} {t.reduced_velocity:.5f} (ω {t.frequency:.4f})" for t in result.thresholds
        )
        unresolved = f"; unresolved ω {np.round(result.unresolved, 4).tolist()}" if result.unresolved else ""
        print(f"m = {mass_ratio:g}: {found}; {counter.count - start} factorisations, "
              f"{time.perf_counter() - clock:.0f} s{unresolved}")  # fmt: skip


if __name__ == "__main__":
    main()
