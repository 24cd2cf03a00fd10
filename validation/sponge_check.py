"""Does a sponge layer give the large-domain answer and remove the spurious neutral curves?

The plate at Re = 2900 (steady state of the mesh, cached), solid parameters of docs/model.md §2. A sponge
``σ(X, Y) u`` is added to the linearised momentum equation only, i.e. ``∫ σ u·v`` to ``J_ff``
(docs/model.md §7; the steady state is not changed). On the domain ``[-a, d] × [-l, l]``

    ``σ = σ_max (1 - (1 - s_d)(1 - s_u)(1 - s_l))``,  ``S(t) = 3t² - 2t³`` for ``0 ≤ t ≤ 1``,
    ``s_d = S((X - (1 - z_d) d) / (z_d d))``  (downstream: the last fraction ``z_d`` of ``[0, d]``),
    ``s_u = S((-X - (1 - z_u) a) / (z_u a))`` (upstream: the first fraction ``z_u`` of ``[-a, 0]``),
    ``s_l = S((Y² - ((1 - z_l) l)²) / (l² - ((1 - z_l) l)²))`` (laterally: the outer fraction ``z_l``),

each part present only if its region is selected (``--regions``). A wave advected at ``U∞`` through
the downstream part loses the factor ``exp(-∫σ dX) = exp(-σ_max z_d d / 2)`` (units ``U∞ = L = 1``).
With ``--rotation-target`` the sponge term is ``σ (u - θ u_θ)``, ``u_θ = (∇U⁰)(-Y, X) - e_z∧U⁰``
(:func:`fsistab.operators.rotation_target`): in the plate's axes the steady wake turns by ``-θ``
when the plate pitches, a perturbation growing like ``X θ`` downstream that is kinematics, not shed
vorticity. The library's sponge (:class:`fsistab.params.Sponge`, on the ``medium`` and ``fine``
presets) is this one's downstream part with the rotation target; this script builds its meshes
without it (``sponge=None``) and adds its own, unless ``--library-sponge SPEC`` gives the mesh the
library's sponge (with its far-field layer if SPEC has one), for the baseline's sweeps only.
The thresholds at each mass ratio come from the frequency sweep
(``fsistab.frequency_sweep.sweep_thresholds``), without the sponge (unless ``--no-baseline``) and
with each combination of ``--sigma`` and ``--zone``.

Usage:
    python validation/sponge_check.py [coarse|medium] [--regions all|downstream upstream lateral]
        [--sigma 1.0 ...] [--zone 0.25 ...] [--upstream-zone 0.25] [--lateral-zone 0.3]
        [--mass-ratios 1000 10 30] [--velocity-range LOW HIGH] [--domain UP DOWN LAT] [--far SIZE]
        [--middle SIZE UP DOWN LAT] [--band END HALF] [--size NAME=VALUE ...]
        [--far-wake H END HALF] [--slip]
        [--no-baseline | --no-sponge]
        [--library-sponge SIGMA_MAX,ZONE[,FAR_SIGMA,FAR_RAMP]] [--out records.jsonl]

``--zone`` is ``z_d`` (and ``z_u`` unless ``--upstream-zone`` is given); ``--domain`` overrides the
preset's domain, ``--far`` its far-field element size, ``--middle`` adds (or replaces) the graded
far field's middle box (``fsistab.mesh.MeshSizes``), ``--band`` its band behind the body,
``--size NAME=VALUE`` any other of its sizes (``wall``, ``corner``, ``near``, ``wake``, ...),
``--far-wake H END HALF`` elements of size ``H`` from the wake box's end to ``END`` (``far_wake``);
``--velocity-range`` replaces the default U* range of every sweep (``[2, 10]`` for m ≥ 100,
``[1.5, 6]`` below). ``--slip`` imposes only ``U·N = 0`` on the inlet and lateral sides for the
perturbation (on ``coarse`` the sweeps then need many more samples). Examples
(docs/discretisation.md, "A sponge layer"):

    python validation/sponge_check.py coarse --regions upstream --no-baseline
    python validation/sponge_check.py coarse --far 1 --domain 20 160 20 --no-sponge --mass-ratios 1000 10
    python validation/sponge_check.py medium --regions downstream --sigma 0.2 --zone 0.25 \
        --rotation-target --no-baseline --mass-ratios 1000     # the recommended sponge
"""

import argparse
import json
import math
import time
from dataclasses import dataclass, fields, replace

from fsistab.bodies import Plate
from fsistab.errors import ConvergenceError, InputError
from fsistab.frequency_sweep import sweep_thresholds
from fsistab.linalg import FactorCounter
from fsistab.mesh import MeshSizes, MeshSpec, mesh_spec
from fsistab.operators import FluidOperators, _to_scipy, fluid_operators, rotation_target
from fsistab.params import Domain, Flow, Solid, parse_sponge
from fsistab.steady import solve_steady
from fsistab.store import default_cache_dir

REYNOLDS = 2900.0
REGIONS = ("downstream", "upstream", "lateral")


@dataclass(frozen=True)
class Sponge:
    """The sponge of the module docstring: ``sigma_max`` (units ``U∞/L``), the selected ``regions``
    and the zone fractions ``downstream_zone`` (z_d), ``upstream_zone`` (z_u), ``lateral_zone`` (z_l)."""

    sigma_max: float
    regions: tuple[str, ...] = REGIONS
    downstream_zone: float = 0.25
    upstream_zone: float = 0.25
    lateral_zone: float = 0.3
    rotation_target: bool = False

    def __post_init__(self):
        if not self.sigma_max > 0:
            raise InputError(f"sponge σ_max must be positive, got {self.sigma_max}")
        unknown = set(self.regions) - set(REGIONS)
        if unknown or not self.regions:
            raise InputError(f"sponge regions must be among {', '.join(REGIONS)}, got {self.regions}")
        for name in ("downstream_zone", "upstream_zone", "lateral_zone"):
            if not 0 < getattr(self, name) <= 1:
                raise InputError(f"sponge {name} must be in (0, 1], got {getattr(self, name)}")

    def label(self) -> str:
        parts = {
            "downstream": f"d{self.downstream_zone:g}",
            "upstream": f"u{self.upstream_zone:g}",
            "lateral": f"l{self.lateral_zone:g}",
        }
        zones = "+".join(parts[r] for r in REGIONS if r in self.regions)
        return f"sponge σ={self.sigma_max:g} {zones}" + (" rot" if self.rotation_target else "")


def sponge_coefficient(domain: Domain, sponge: Sponge):
    """``σ(X, Y)`` of the module docstring as an NGSolve coefficient function."""
    from ngsolve import IfPos, x, y

    def step(distance, width):  # 0 inside, rising smoothly to 1 at the boundary
        t = IfPos(distance, distance / width, 0.0)
        return t * t * (3 - 2 * t)

    up, down, lat = domain.upstream, domain.downstream, domain.lateral
    inner = (1 - sponge.lateral_zone) * lat
    parts = {
        "downstream": step(x - (1 - sponge.downstream_zone) * down, sponge.downstream_zone * down),
        "upstream": step(-x - (1 - sponge.upstream_zone) * up, sponge.upstream_zone * up),
        "lateral": step(y * y - inner**2, lat**2 - inner**2),
    }
    outside = 1.0
    for region in sponge.regions:
        outside = outside * (1 - parts[region])
    return sponge.sigma_max * (1 - outside)


def with_sponge(fluid: FluidOperators, spec: MeshSpec, sponge: Sponge) -> FluidOperators:
    """``fluid`` with the sponge term ``σ (u - θ u_θ)`` (``u_θ`` only with ``sponge.rotation_target``)
    added to the momentum residual: ``∫ σ u·v`` to ``J_ff`` and ``-∫ σ u_θ·v`` to the θ column of
    ``J_fs`` (free dofs only; the pressure rows unchanged)."""
    from ngsolve import BilinearForm, InnerProduct, LinearForm, dx

    space = fluid.steady.space
    sigma = sponge_coefficient(spec.domain, sponge)
    (u, _), (v, _) = space.TnT()
    form = BilinearForm(space)
    form += sigma * InnerProduct(u, v) * dx
    form.Assemble()
    index = fluid.free_dofs
    block = _to_scipy(form.mat, space.ndof)[index][:, index]
    jfs = fluid.jfs
    if sponge.rotation_target:
        target = LinearForm(space)
        target += -sigma * InnerProduct(rotation_target(fluid.steady), v) * dx
        target.Assemble()
        jfs = jfs.copy()
        jfs[:, 1] += target.vec.FV().NumPy()[index]  # columns (h, θ, ḣ, θ')
    return replace(fluid, jff=(fluid.jff + block).tocsr(), jfs=jfs, analyses={})


def with_slip_far_field(steady):
    """``steady`` on a space where the perturbation has ``U·N = 0`` only on the inlet and the lateral
    sides (free slip; the tangential component is free, with zero tangential stress), instead of
    ``U = 0``: a no-slip far boundary turns the potential perturbation's tangential velocity into a
    vortex sheet that the free stream carries past the plate. The steady state (``U⁰ ≈ 0`` there) is
    kept as it is; the dof numbering of both spaces is the same."""
    from ngsolve import H1, GridFunction, VectorH1

    mesh = steady.mesh
    velocity = VectorH1(mesh, order=2, dirichletx="inlet|wall", dirichlety="lateral|wall")
    space = velocity * H1(mesh, order=1)
    state = GridFunction(space)
    state.vec.data = steady.state.vec
    return replace(steady, space=space, state=state)


def velocity_range(mass_ratio: float) -> tuple[float, float]:
    """The U* range swept: the flutter onset and divergence at large m, the low-m windows below."""
    return (2.0, 10.0) if mass_ratio >= 100 else (1.5, 6.0)


def sweep_record(
    label: str, operators: FluidOperators, mass_ratio: float, velocities: tuple[float, float] | None = None
) -> dict:
    """Thresholds of one sweep over ``velocities`` (default :func:`velocity_range`) with its cost, as a
    JSON-ready record."""
    low, high = velocities or velocity_range(mass_ratio)
    counter, t0 = FactorCounter(), time.perf_counter()
    messages = []
    try:
        result = sweep_thresholds(
            operators,
            Solid(mass_ratio=mass_ratio, reduced_velocity=low),
            (low, high),
            counter=counter,
            progress=messages.append,
        )
    except ConvergenceError as exc:  # a Newton that fails from the sweep's start: record it, go on
        return {
            "variant": label,
            "mass_ratio": mass_ratio,
            "velocity_range": [low, high],
            "error": str(exc),
            "last_progress": messages[-1] if messages else "",
            "factorisations": counter.count,
            "seconds": round(time.perf_counter() - t0, 1),
        }
    return {
        "variant": label,
        "mass_ratio": mass_ratio,
        "velocity_range": [low, high],
        "samples": len(result.frequencies),
        "factorisations": counter.count,
        "unresolved": [list(i) for i in result.unresolved],
        "seconds": round(time.perf_counter() - t0, 1),
        "thresholds": [
            {
                "kind": t.kind,
                "boundary": t.boundary,
                "reduced_velocity": t.reduced_velocity,
                "frequency": t.frequency,
            }
            for t in result.thresholds
        ],
    }


def print_record(record: dict) -> None:
    if "error" in record:
        print(
            f"{record['variant']}, m = {record['mass_ratio']:g}: "
            f"FAILED ({record['last_progress']}): {record['error']}",
            flush=True,
        )
        return
    print(
        f"{record['variant']}, m = {record['mass_ratio']:g}: {record['samples']} samples, "
        f"{record['factorisations']} factorisations, {record['seconds']:.0f} s"
        + (f", unresolved {record['unresolved']}" if record["unresolved"] else ""),
        flush=True,
    )
    for t in record["thresholds"]:
        print(
            f"    {t['kind']:10s} {t['boundary']:16s} "
            f"U* = {t['reduced_velocity']:.6f}  ω = {t['frequency']:.6f}"
        )


# the scalar sizes --size may set (the boxes and band have their own options)
SCALAR_SIZES = tuple(f.name for f in fields(MeshSizes) if f.type in (float, "float"))


def size_item(item: str) -> tuple[str, float]:
    """``NAME=VALUE`` of ``--size``: a scalar size of :class:`fsistab.mesh.MeshSizes` and a positive
    number, else a one-line error."""
    name, _, text = item.partition("=")
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if name not in SCALAR_SIZES or not value > 0:
        raise SystemExit(
            f"--size {item}: expected NAME=VALUE with VALUE > 0, NAME one of {', '.join(SCALAR_SIZES)}"
        )
    return name, value


def add_size_option(parser: argparse.ArgumentParser) -> None:
    """``--size NAME=VALUE`` (repeatable), checked by :func:`size_item`, and ``--far-wake H END
    HALF`` (:func:`size_overrides`)."""
    parser.add_argument(
        "--size",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="another of the preset's sizes (fsistab.mesh.MeshSizes: wall, corner, near, wake, ...)",
    )
    parser.add_argument(
        "--far-wake",
        type=float,
        nargs=3,
        metavar=("H", "END", "HALF"),
        help="elements of size H from the wake box's end to END chords, half-width HALF (far_wake)",
    )


def size_overrides(args) -> dict:
    """The sizes of ``--size`` (checked by :func:`size_item`) and ``--far-wake`` (checked by
    :class:`fsistab.mesh.MeshSizes` when the spec is made, before any mesh)."""
    sizes = dict(size_item(item) for item in args.size)
    if args.far_wake is not None:
        sizes["far_wake"] = tuple(args.far_wake)
    return sizes


def build_spec(args) -> MeshSpec:
    sizes = {}
    if args.far is not None:
        sizes["far"] = args.far
    if args.middle is not None:
        sizes["middle"], sizes["middle_box"] = args.middle[0], tuple(args.middle[1:])
    if args.band is not None:
        sizes["middle_band"] = tuple(args.band)
    sizes.update(size_overrides(args))
    domain = Domain(*args.domain) if args.domain else None
    # its own sponges only, unless the library's is asked for (then it is the baseline's)
    sponge = parse_sponge(args.library_sponge) if args.library_sponge else None
    return mesh_spec(Plate(), args.preset, REYNOLDS, domain, sponge=sponge, **sizes)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("preset", nargs="?", default="coarse")
    parser.add_argument("--regions", nargs="+", default=["all"], choices=("all", *REGIONS))
    parser.add_argument("--sigma", type=float, nargs="+", default=[1.0], help="σ_max values")
    parser.add_argument("--zone", type=float, nargs="+", default=[0.25], help="downstream zone fractions")
    parser.add_argument("--upstream-zone", type=float, default=None, help="default: the --zone value")
    parser.add_argument("--lateral-zone", type=float, default=0.3)
    parser.add_argument("--mass-ratios", type=float, nargs="+", default=[1000.0, 10.0, 30.0])
    parser.add_argument("--velocity-range", type=float, nargs=2, metavar=("LOW", "HIGH"))
    parser.add_argument("--domain", type=float, nargs=3, metavar=("UP", "DOWN", "LAT"))
    parser.add_argument("--far", type=float, help="far-field element size (chords)")
    parser.add_argument("--middle", type=float, nargs=4, metavar=("SIZE", "UP", "DOWN", "LAT"))
    add_size_option(parser)
    parser.add_argument(
        "--band", type=float, nargs=2, metavar=("END", "HALF"), help="middle-sized band behind the body"
    )
    parser.add_argument(
        "--rotation-target",
        action="store_true",
        help="relax towards the steady field turned with the pitch (σ (u - θ u_θ)), not towards 0",
    )
    parser.add_argument(
        "--slip", action="store_true", help="U·N = 0 only on the inlet and lateral sides (free slip)"
    )
    parser.add_argument(
        "--library-sponge",
        metavar="SPEC",
        help="the library's sponge (fsistab.params.Sponge, as fsistab's --sponge: preset, none, "
        "SIGMA_MAX,ZONE[,FAR_SIGMA,FAR_RAMP]) in the baseline's operators; implies --no-sponge",
    )
    parser.add_argument("--no-baseline", action="store_true", help="skip the sweeps without sponge")
    parser.add_argument("--no-sponge", action="store_true", help="only the sweeps without sponge")
    parser.add_argument("--out", help="append one JSON record per sweep to this file")
    args = parser.parse_args()
    try:  # bad input: one line, before any mesh or steady state is built
        regions = REGIONS if "all" in args.regions else tuple(r for r in REGIONS if r in args.regions)
        sponges = [
            Sponge(sigma, regions, zone, args.upstream_zone or zone, args.lateral_zone, args.rotation_target)
            for sigma in args.sigma
            for zone in args.zone
        ]
        spec = build_spec(args)
        if args.library_sponge:
            args.no_sponge = True
        if args.no_baseline and args.no_sponge:
            raise InputError("--no-baseline and --no-sponge leave nothing to compute")
        for mass in args.mass_ratios:
            Solid(mass_ratio=mass)  # validates the mass ratio
        if args.velocity_range and not 0 < args.velocity_range[0] < args.velocity_range[1]:
            raise InputError(f"the velocity range must satisfy 0 < low < high, got {args.velocity_range}")
    except InputError as exc:
        parser.error(str(exc))
    steady = solve_steady(spec, Flow(REYNOLDS), cache_dir=default_cache_dir())
    fluid = fluid_operators(with_slip_far_field(steady) if args.slip else steady)
    domain = spec.domain
    up, down, lat = domain.upstream, domain.downstream, domain.lateral
    mesh = f"{args.preset} [-{up:g}, {down:g}] x [-{lat:g}, {lat:g}]" + (
        ", slip far field" if args.slip else ""
    )
    print(f"{mesh}: {fluid.jff.shape[0]} fluid unknowns", flush=True)
    baseline = f"library sponge {args.library_sponge}" if args.library_sponge else "no sponge"
    variants = [] if args.no_baseline else [(baseline, None)]
    variants += [] if args.no_sponge else [(s.label(), s) for s in sponges]
    for label, sponge in variants:
        operators = fluid if sponge is None else with_sponge(fluid, spec, sponge)
        for mass in args.mass_ratios:
            record = sweep_record(label, operators, mass, args.velocity_range)
            record.update(mesh=spec.describe(), unknowns=int(fluid.jff.shape[0]), slip=args.slip)
            print_record(record)
            if args.out:
                with open(args.out, "a") as stream:
                    stream.write(json.dumps(record) + "\n")


if __name__ == "__main__":
    main()
