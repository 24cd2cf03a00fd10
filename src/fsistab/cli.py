"""Command line: thin typer commands over the Python API.

Conventions shared by every command: ``--body {plate,cylinder}``, ``--Re``, ``--alpha0`` (degrees),
``--mesh {coarse,medium,fine}``, ``--out DIR`` for figures and data, ``--json`` to print exactly one
JSON object on stdout (progress and tables then go to stderr). Errors print one line and exit 2.
"""

from __future__ import annotations

import functools
import json
import math
import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

from fsistab.errors import FsistabError, InputError

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    help="Global linear stability of spring-mounted bodies in viscous flow (fsistab).",
)

BodyOpt = Annotated[
    str, typer.Option("--body", help="plate (chord-based units) or cylinder (diameter-based)")
]
ReOpt = Annotated[float, typer.Option("--Re", help="Reynolds number on the body length")]
AlphaOpt = Annotated[float, typer.Option("--alpha0", help="steady angle of attack, degrees, nose-up +")]
MeshOpt = Annotated[str, typer.Option("--mesh", help="mesh preset: coarse, medium or fine")]
OutOpt = Annotated[Path, typer.Option("--out", help="directory for figures and data")]
JsonOpt = Annotated[bool, typer.Option("--json", help="print one JSON object on stdout and nothing else")]
CacheOpt = Annotated[
    Path | None, typer.Option("--cache", help="cache directory (default $FSISTAB_CACHE or ~/.cache/fsistab)")
]
AspectOpt = Annotated[float, typer.Option("--aspect-ratio", help="plate chord/thickness")]
CornerOpt = Annotated[float, typer.Option("--corner-radius", help="plate corner radius / thickness")]
DomainOpt = Annotated[
    tuple[float, float, float] | None,
    typer.Option("--domain", help="upstream, downstream and lateral extents in body lengths"),
]


def _console(as_json: bool) -> Console:
    return Console(stderr=as_json)


def _fail(message: str) -> None:
    Console(stderr=True).print(f"[bold red]error:[/] {message}", highlight=False, soft_wrap=True)
    raise typer.Exit(code=2)


def user_errors(command):
    """Turn fsistab's own errors into a one-line message and exit status 2."""

    @functools.wraps(command)
    def wrapper(*args, **kwargs):
        try:
            return command(*args, **kwargs)
        except FsistabError as exc:
            _fail(str(exc).splitlines()[0] if str(exc) else type(exc).__name__)

    return wrapper


def _spec(body: str, reynolds: float, preset: str, aspect: float, corner: float, domain):
    from fsistab.mesh import mesh_spec
    from fsistab.params import Domain, Flow, make_body

    Flow(reynolds)  # validate before any work
    shape = {"aspect_ratio": aspect, "corner_radius": corner} if body == "plate" else {}
    if body not in ("plate", "cylinder"):
        raise InputError(f"unknown body {body!r}: choose 'plate' or 'cylinder'")
    body_obj = make_body(body, **shape)
    dom = Domain(*domain) if domain else None
    return mesh_spec(body_obj, preset, reynolds, dom)


def _cache(cache: Path | None) -> Path:
    from fsistab.store import default_cache_dir

    return cache if cache is not None else default_cache_dir()


def _emit_json(payload: dict) -> None:
    sys.stdout.write(json.dumps(payload, allow_nan=True) + "\n")


def _tag(body: str, reynolds: float, alpha0: float) -> str:
    return f"{body}_Re{reynolds:g}_a{alpha0:g}"


@app.command()
@user_errors
def mesh(
    body: BodyOpt = "plate",
    reynolds: ReOpt = 2900.0,
    preset: MeshOpt = "medium",
    out: OutOpt = Path("fsistab-out"),
    as_json: JsonOpt = False,
    cache: CacheOpt = None,
    aspect_ratio: AspectOpt = 20.0,
    corner_radius: CornerOpt = 0.1,
    domain: DomainOpt = None,
):
    """Build (or reuse) a mesh; print its size and save a picture."""
    from fsistab.mesh import build_mesh, mesh_statistics
    from fsistab.plots import plot_mesh

    spec = _spec(body, reynolds, preset, aspect_ratio, corner_radius, domain)
    the_mesh = build_mesh(spec, _cache(cache))
    stats = mesh_statistics(the_mesh)
    figure = plot_mesh(the_mesh, out / f"mesh_{body}_{preset}_Re{reynolds:g}.png", title=f"{body}, {preset}")
    payload = {**stats, "preset": preset, "mesh_key": spec.key(), "figure": str(figure)}
    if as_json:
        _emit_json(payload)
        return
    table = Table(title=f"mesh: {body}, preset {preset}, fitted to Re = {reynolds:g}")
    for name in ("triangles", "vertices", "ndof", "h_min", "h_max"):
        table.add_row(name, f"{stats[name]:.4g}" if isinstance(stats[name], float) else str(stats[name]))
    console = _console(False)
    console.print(table)
    console.print(f"figure: {figure}")


@app.command()
@user_errors
def steady(
    body: BodyOpt = "plate",
    reynolds: ReOpt = 2900.0,
    alpha0: AlphaOpt = 0.0,
    preset: MeshOpt = "medium",
    out: OutOpt = Path("fsistab-out"),
    as_json: JsonOpt = False,
    cache: CacheOpt = None,
    aspect_ratio: AspectOpt = 20.0,
    corner_radius: CornerOpt = 0.1,
    domain: DomainOpt = None,
):
    """Steady flow around the fixed body: coefficients, recirculation length, Newton history."""
    from fsistab.forces import aerodynamic_coefficients, recirculation_length
    from fsistab.params import Flow
    from fsistab.plots import plot_streamwise_velocity
    from fsistab.steady import solve_steady

    flow = Flow(reynolds, alpha0)
    spec = _spec(body, reynolds, preset, aspect_ratio, corner_radius, domain)
    console = _console(as_json)
    with console.status("steady Navier–Stokes (Newton, continuation in Re)") as status:

        def progress(step_flow, iterations):
            status.update(
                f"continuation: Re = {step_flow.reynolds:.4g}, alpha0 = {step_flow.alpha0_deg:.3g} deg "
                f"converged in {iterations} Newton iterations"
            )

        result = solve_steady(spec, flow, cache_dir=_cache(cache), progress=progress)
    coefficients = aerodynamic_coefficients(result)
    length = recirculation_length(result)
    figure = plot_streamwise_velocity(result, out / f"steady_{_tag(body, reynolds, alpha0)}.png")
    payload = {
        "body": body,
        "reynolds": flow.reynolds,
        "alpha0_deg": flow.alpha0_deg,
        "lift_coefficient": coefficients.lift,
        "moment_coefficient": coefficients.moment,
        "drag_coefficient": coefficients.drag,
        "recirculation_length": length,
        "ndof": result.ndof,
        "newton_iterations": result.newton_iterations,
        "newton_residuals": list(result.history),
        "continuation": [{"reynolds": r, "alpha0_deg": a, "iterations": n} for r, a, n in result.path],
        "factorisations": result.factorisations,
        "from_cache": result.from_cache,
        "seconds": result.seconds,
        "figure": str(figure),
    }
    if as_json:
        _emit_json(payload)
        return
    table = Table(title=f"steady flow: {body}, Re = {flow.reynolds:g}, alpha0 = {flow.alpha0_deg:g} deg")
    table.add_column("quantity")
    table.add_column("value", justify="right")
    for label, key in [
        ("lift coefficient C_L", "lift_coefficient"),
        ("drag coefficient C_D", "drag_coefficient"),
        ("moment coefficient C_M (about G, ccw +)", "moment_coefficient"),
        ("recirculation length (from the rear)", "recirculation_length"),
    ]:
        table.add_row(label, f"{payload[key]:.6g}")
    table.add_row("unknowns", str(result.ndof))
    table.add_row("Newton iterations at target", str(result.newton_iterations))
    console.print(table)
    history = ", ".join(f"{r:.2e}" for r in result.history)
    console.print(f"Newton residuals: {history}")
    if result.path:
        steps = ", ".join(f"{r:.4g}" for r, _, _ in result.path)
        console.print(f"continuation in Re: {steps}")
    source = (
        "cache" if result.from_cache else f"{result.seconds:.1f} s, {result.factorisations} factorisations"
    )
    console.print(f"({source}) figure: {figure}")


def _solid(body: str, mass_ratio, reduced_velocity, freq_ratio, zeta_h, zeta_theta, r_theta, dofs: str):
    """Solid parameters in the body's conventions (plate MODEL.md §2, cylinder §10)."""
    from fsistab.params import Solid

    names = () if dofs == "none" else tuple(d.strip() for d in dofs.split(",") if d.strip())
    if body == "cylinder":
        if "pitch" in names:
            raise InputError("the cylinder has no pitch degree of freedom: use --dofs heave or none")
        solid = Solid.cylinder(mass_ratio or 20.0, reduced_velocity or 8.0, zeta=zeta_h)
        return Solid(**{**solid.__dict__, "dofs": names})
    return Solid(
        mass_ratio=mass_ratio or 1000.0,
        reduced_velocity=reduced_velocity or 4.7,
        freq_ratio=freq_ratio,
        zeta_h=zeta_h,
        zeta_theta=zeta_theta,
        r_theta=r_theta,
        dofs=names,
    )


def _shifts(values: list[str]) -> list[complex]:
    shifts = []
    for value in values:
        try:
            shift = complex(value.replace(" ", "").replace("i", "j"))
        except ValueError:
            raise InputError(f"cannot read the shift {value!r}: write it like 0.05+0.2j") from None
        if not (math.isfinite(shift.real) and math.isfinite(shift.imag)):
            raise InputError(f"the shift must be finite, got {value!r}")
        shifts.append(shift)
    return shifts


MassOpt = Annotated[
    float | None, typer.Option("--mass-ratio", help="m (plate default 1000; cylinder, MODEL.md §10: 20)")
]
VelocityOpt = Annotated[
    float | None, typer.Option("--reduced-velocity", help="U* (plate default 4.7; cylinder: 8)")
]
FreqRatioOpt = Annotated[float, typer.Option("--freq-ratio", help="Ω = ω_h/ω_θ")]
ZetaHOpt = Annotated[float, typer.Option("--zeta-h", help="heave damping ratio")]
ZetaThetaOpt = Annotated[float, typer.Option("--zeta-theta", help="pitch damping ratio")]
RThetaOpt = Annotated[float, typer.Option("--r-theta", help="radius of gyration about G")]
DofsOpt = Annotated[str | None, typer.Option("--dofs", help="heave,pitch | heave | pitch | none")]


@app.command()
@user_errors
def spectrum(
    body: BodyOpt = "plate",
    reynolds: ReOpt = 2900.0,
    alpha0: AlphaOpt = 0.0,
    preset: MeshOpt = "medium",
    out: OutOpt = Path("fsistab-out"),
    as_json: JsonOpt = False,
    cache: CacheOpt = None,
    aspect_ratio: AspectOpt = 20.0,
    corner_radius: CornerOpt = 0.1,
    domain: DomainOpt = None,
    mass_ratio: MassOpt = None,
    reduced_velocity: VelocityOpt = None,
    freq_ratio: FreqRatioOpt = 0.8,
    zeta_h: ZetaHOpt = 0.0,
    zeta_theta: ZetaThetaOpt = 0.05,
    r_theta: RThetaOpt = 0.289,
    dofs: DofsOpt = None,
    shift: Annotated[list[str] | None, typer.Option("--shift", help="complex shift, repeatable")] = None,
    n_eigenvalues: Annotated[int, typer.Option("--n-eigenvalues", help="eigenvalues per shift")] = 6,
    vtk: Annotated[bool, typer.Option("--vtk/--no-vtk", help="write the modes as VTK")] = True,
    mode_figures: Annotated[
        int,
        typer.Option("--mode-figures", help="pressure snapshots and h(t), -θ(t) of the N least stable modes"),
    ] = 2,
    phase: Annotated[float, typer.Option("--phase", help="phase (rad) of the pressure snapshots")] = 0.0,
):
    """Eigenvalues of the coupled fluid–solid system nearest the given shifts (MODEL.md §7)."""
    from fsistab.coupled import CoupledSystem
    from fsistab.eigen import eigenpairs_near, spectrum_dataset
    from fsistab.operators import fluid_operators
    from fsistab.params import Flow
    from fsistab.plots import plot_mode_snapshot, plot_solid_motion, plot_spectrum, write_modes_vtk
    from fsistab.steady import solve_steady
    from fsistab.store import write_dataset

    flow = Flow(reynolds, alpha0)
    default_dofs = "heave" if body == "cylinder" else "heave,pitch"
    solid = _solid(
        body, mass_ratio, reduced_velocity, freq_ratio, zeta_h, zeta_theta, r_theta, dofs or default_dofs
    )
    shifts = _shifts(shift or (["0.75j"] if body == "cylinder" else ["0.05+0.2j"]))
    if not 1 <= n_eigenvalues <= 50:
        raise InputError(f"--n-eigenvalues must be between 1 and 50, got {n_eigenvalues}")
    spec = _spec(body, reynolds, preset, aspect_ratio, corner_radius, domain)
    console = _console(as_json)
    with console.status("steady state") as status:
        steady_state = solve_steady(spec, flow, cache_dir=_cache(cache))
        status.update("fluid operators")
        system = CoupledSystem(fluid_operators(steady_state), solid)
        status.update(f"shift-invert Arnoldi near {len(shifts)} shift(s), {system.size} unknowns")
        pairs = eigenpairs_near(system, shifts, n_eigenvalues)
    tag = _tag(body, reynolds, alpha0)
    ds = spectrum_dataset(pairs, system, {"shifts": json.dumps([[z.real, z.imag] for z in shifts])})
    data_path = write_dataset(ds, out / f"spectrum_{tag}.nc")
    figure = plot_spectrum(ds, out / f"spectrum_{tag}.png", title=f"{body}, Re = {reynolds:g}")
    mode_paths = []
    for i, pair in enumerate(pairs[: max(0, mode_figures)]):
        mode_paths.append(
            str(
                plot_mode_snapshot(
                    steady_state, system.fluid.free_dofs, pair, system, out / f"mode{i}_{tag}.png", phase
                )
            )
        )
        if system.n_solid:
            mode_paths.append(str(plot_solid_motion(pair, out / f"mode{i}_motion_{tag}.png").path))
    vtk_path = None
    if vtk:
        n_solid = system.n_solid
        modes = {f"mode{i}": p.vector[n_solid:] for i, p in enumerate(pairs[:6])}
        vtk_path = write_modes_vtk(steady_state, system.fluid.free_dofs, modes, out / f"modes_{tag}")
    payload = {
        "eigenvalues": [
            {"growth_rate": p.growth_rate, "frequency": p.frequency, "label": p.label, "residual": p.residual}
            for p in pairs
        ],
        "ndof": system.size,
        "netcdf": str(data_path),
        "figure": str(figure),
        "vtk": str(vtk_path) if vtk_path else None,
        "mode_figures": mode_paths,
    }
    if as_json:
        _emit_json(payload)
        return
    table = Table(
        title=f"spectrum: {body}, Re = {reynolds:g}, alpha0 = {alpha0:g} deg, dofs {solid.dofs or 'none'}"
    )
    for column in ("growth rate λ", "frequency ω", "label", "solid energy", "residual"):
        table.add_column(column, justify="right")
    for p in pairs:
        table.add_row(
            f"{p.growth_rate:+.6f}",
            f"{p.frequency:.6f}",
            p.label,
            f"{p.solid_energy_fraction:.2f}",
            f"{p.residual:.1e}",
        )
    console.print(table)
    console.print(
        f"{system.size} unknowns; data {data_path}; figure {figure}"
        + (f"; modes {vtk_path}" if vtk_path else "")
    )


@app.command()
@user_errors
def slopes(
    reynolds: Annotated[list[float], typer.Option("--Re", help="Reynolds numbers: --Re 10 100 1000")],
    more_reynolds: Annotated[
        list[float] | None, typer.Argument(help="further Reynolds numbers", show_default=False)
    ] = None,
    alpha0: AlphaOpt = 0.0,
    preset: MeshOpt = "medium",
    out: OutOpt = Path("fsistab-out"),
    as_json: JsonOpt = False,
    cache: CacheOpt = None,
    aspect_ratio: AspectOpt = 20.0,
    corner_radius: CornerOpt = 0.1,
    domain: DomainOpt = None,
):
    """Static slopes dC_L/dα and d(-C_M)/dα of the plate against Re (MODEL.md §9)."""
    import numpy as np
    import xarray as xr

    from fsistab.operators import fluid_operators
    from fsistab.params import Flow
    from fsistab.plots import plot_slopes
    from fsistab.slopes import THIN_AIRFOIL_LIFT_SLOPE, THIN_AIRFOIL_MOMENT_SLOPE, static_slopes
    from fsistab.steady import solve_steady
    from fsistab.store import write_dataset

    values = sorted({*reynolds, *(more_reynolds or [])})
    flows = [Flow(re, alpha0) for re in values]  # validate every value before any work
    specs = [_spec("plate", re, preset, aspect_ratio, corner_radius, domain) for re in values]
    console = _console(as_json)
    results = []
    with console.status("steady slopes") as status:
        for flow, spec in zip(flows, specs, strict=True):
            status.update(f"Re = {flow.reynolds:g}: steady state and one linear solve")
            steady_state = solve_steady(spec, flow, cache_dir=_cache(cache))
            results.append(static_slopes(fluid_operators(steady_state)))
    ds = xr.Dataset(
        {
            "lift_slope_alpha": ("reynolds", np.array([r.lift_slope_alpha for r in results])),
            "moment_slope_alpha": ("reynolds", np.array([r.moment_slope_alpha for r in results])),
            "drag_slope_theta": ("reynolds", np.array([r.drag for r in results])),
        },
        coords={"reynolds": np.array(values)},
        attrs={
            "alpha0_deg": alpha0,
            "mesh": preset,
            "convention": "dC_L/dalpha and d(-C_M)/dalpha per radian, alpha = -theta, moment about mid-chord",
            "thin_airfoil_lift_slope": THIN_AIRFOIL_LIFT_SLOPE,
            "thin_airfoil_moment_slope": THIN_AIRFOIL_MOMENT_SLOPE,
        },
    )
    data_path = write_dataset(ds, out / f"slopes_plate_a{alpha0:g}_{preset}.nc")
    figure = plot_slopes(ds, out / f"slopes_plate_a{alpha0:g}_{preset}.png")
    payload = {
        "alpha0_deg": alpha0,
        "slopes": [
            {
                "reynolds": r.reynolds,
                "lift_slope_alpha": r.lift_slope_alpha,
                "moment_slope_alpha": r.moment_slope_alpha,
            }
            for r in results
        ],
        "netcdf": str(data_path),
        "figure": str(figure),
    }
    if as_json:
        _emit_json(payload)
        return
    table = Table(title=f"static slopes, plate, alpha0 = {alpha0:g} deg, mesh {preset} (per radian)")
    for column in ("Re", "dC_L/dα", "d(-C_M)/dα"):
        table.add_column(column, justify="right")
    for r in results:
        table.add_row(f"{r.reynolds:g}", f"{r.lift_slope_alpha:.4f}", f"{r.moment_slope_alpha:.4f}")
    table.add_row("thin airfoil", f"{THIN_AIRFOIL_LIFT_SLOPE:.4f}", f"{THIN_AIRFOIL_MOMENT_SLOPE:.4f}")
    console.print(table)
    console.print(f"data {data_path}; figure {figure}")


@app.command()
@user_errors
def critical(
    body: BodyOpt = "plate",
    reynolds: ReOpt = 2900.0,
    alpha0: AlphaOpt = 0.0,
    preset: MeshOpt = "medium",
    out: OutOpt = Path("fsistab-out"),
    as_json: JsonOpt = False,
    cache: CacheOpt = None,
    aspect_ratio: AspectOpt = 20.0,
    corner_radius: CornerOpt = 0.1,
    domain: DomainOpt = None,
    mass_ratio: MassOpt = None,
    freq_ratio: FreqRatioOpt = 0.8,
    zeta_h: ZetaHOpt = 0.0,
    zeta_theta: ZetaThetaOpt = 0.05,
    r_theta: RThetaOpt = 0.289,
    dofs: DofsOpt = None,
    velocity_range: Annotated[
        tuple[float, float], typer.Option("--reduced-velocity-range", help="U* range of the sweep")
    ] = (2.0, 10.0),
    points: Annotated[int, typer.Option("--points", help="U* values of the sweep (log-spaced)")] = 24,
    wake_shift: Annotated[
        str | None, typer.Option("--wake-shift", help="shift near the wake mode, to follow it too (VIV)")
    ] = None,
):
    """Every instability threshold along U* at one mass ratio (MODEL.md §8): branch tracking,
    then Newton on the augmented system at each crossing; divergence from the static system."""
    import numpy as np

    from fsistab.critical import find_thresholds
    from fsistab.linalg import FactorCounter
    from fsistab.operators import fluid_operators
    from fsistab.params import Flow
    from fsistab.steady import solve_steady

    flow = Flow(reynolds, alpha0)
    default_dofs = "heave" if body == "cylinder" else "heave,pitch"
    lo, hi = velocity_range
    if not (0 < lo < hi and math.isfinite(hi)):
        raise InputError(f"--reduced-velocity-range must be 0 < low < high, got {lo:g} {hi:g}")
    if not 2 <= points <= 500:
        raise InputError(f"--points must be between 2 and 500, got {points}")
    solid = _solid(body, mass_ratio, lo, freq_ratio, zeta_h, zeta_theta, r_theta, dofs or default_dofs)
    if not solid.dofs:
        raise InputError("critical points need at least one solid degree of freedom (--dofs)")
    shifts = _shifts([wake_shift]) if wake_shift else [None]
    velocities = np.geomspace(lo, hi, points)
    if body == "cylinder":  # MODEL.md §10 U* = 2π × the generic one
        velocities = velocities / (2 * math.pi)
    spec = _spec(body, reynolds, preset, aspect_ratio, corner_radius, domain)
    console = _console(as_json)
    counter = FactorCounter()
    with console.status("steady state") as status:
        steady_state = solve_steady(spec, flow, cache_dir=_cache(cache))
        fluid = fluid_operators(steady_state)

        def progress(i, velocity):
            status.update(f"tracking branches: point {i + 1}/{points}, {counter.count} factorisations")

        thresholds, _ = find_thresholds(
            fluid, solid, velocities, wake_shift=shifts[0], counter=counter, progress=progress
        )
    scale = 2 * math.pi if body == "cylinder" else 1.0
    user_mass = mass_ratio or (20.0 if body == "cylinder" else 1000.0)
    payload = {
        "mass_ratio": user_mass,
        "critical_points": [
            {
                "kind": t.kind,
                "reduced_velocity": t.reduced_velocity * scale,
                "frequency": t.frequency,
                "boundary": t.boundary,
            }
            for t in thresholds
        ],
        "factorisations": counter.count,
    }
    if as_json:
        _emit_json(payload)
        return
    table = Table(title=f"thresholds: {body}, Re = {reynolds:g}, m = {user_mass:g}, U* in [{lo:g}, {hi:g}]")
    for column in ("kind", "boundary", "U*_c", "ω_c", "ω_c U*_c"):
        table.add_column(column, justify="right")
    for t in thresholds:
        u = t.reduced_velocity * scale
        table.add_row(
            t.kind, t.boundary, f"{u:.6g}", f"{t.frequency:.6g}", f"{t.frequency * t.reduced_velocity:.4g}"
        )
    console.print(table)
    console.print(f"{counter.count} factorisations; {points} values of U* tracked")


def _curve_attrs(reynolds, alpha0, spec, freq_ratio, zeta_h, zeta_theta, r_theta) -> dict:
    """What a saved neutral curve depends on besides its own parameters (checked on resume)."""
    return {
        "reynolds": reynolds,
        "alpha0_deg": alpha0,
        "mesh_key": spec.key(),
        "freq_ratio": freq_ratio,
        "zeta_h": zeta_h,
        "zeta_theta": zeta_theta,
        "r_theta": r_theta,
    }


@app.command()
@user_errors
def neutral(
    body: BodyOpt = "plate",
    reynolds: ReOpt = 2900.0,
    alpha0: AlphaOpt = 0.0,
    preset: MeshOpt = "medium",
    out: OutOpt = Path("fsistab-out"),
    as_json: JsonOpt = False,
    cache: CacheOpt = None,
    aspect_ratio: AspectOpt = 20.0,
    corner_radius: CornerOpt = 0.1,
    domain: DomainOpt = None,
    mass_range: Annotated[tuple[float, float], typer.Option("--mass-ratio-range", help="m range")] = (
        1.0,
        1e4,
    ),
    start_mass: Annotated[float, typer.Option("--start-mass-ratio", help="m of the initial sweep")] = 1000.0,
    velocity_range: Annotated[
        tuple[float, float], typer.Option("--reduced-velocity-range", help="U* range of the initial sweep")
    ] = (2.0, 10.0),
    seed_masses: Annotated[
        list[float] | None,
        typer.Option(
            "--seed-mass-ratio",
            help="further sweeps (repeatable; default m/10 and m/100 of the start), U* range scaled by √m",
        ),
    ] = None,
    wake_frequency: Annotated[
        float | None,
        typer.Option(
            "--wake-frequency",
            help="guess of the fixed body's wake-mode ω (refined by Arnoldi): VIV sweep at the lowest m",
        ),
    ] = None,
    points: Annotated[int, typer.Option("--points", help="U* values of each sweep")] = 24,
    max_points: Annotated[int, typer.Option("--max-points", help="points per curve and direction")] = 60,
    freq_ratio: FreqRatioOpt = 0.8,
    zeta_h: ZetaHOpt = 0.0,
    zeta_theta: ZetaThetaOpt = 0.05,
    r_theta: RThetaOpt = 0.289,
    method: Annotated[
        str,
        typer.Option("--method", help="transfer (G(iω) sweep, default) or continuation (sweeps + arclength)"),
    ] = "transfer",
    frequency_range: Annotated[
        tuple[float, float] | None,
        typer.Option(
            "--frequency-range", help="transfer: ω range sampled (default 0.01 to max(20, 1.5 ω_wake))"
        ),
    ] = None,
    tolerance: Annotated[
        float | None,
        typer.Option(
            "--tolerance",
            help="transfer: largest error of the tangent predictions between two samples, in (log m, log U*) "
            "(default 3e-3; exact samples only: 1e-2)",
        ),
    ] = None,
    max_frequencies: Annotated[
        int | None,
        typer.Option(
            "--max-frequencies", help="transfer: at most this many sampled ω (default 4000; exact: 400)"
        ),
    ] = None,
    reduced_blocks: Annotated[
        int,
        typer.Option(
            "--reduced-blocks",
            help="transfer: Krylov blocks of the reduced fluid models (0: exact samples only)",
        ),
    ] = 60,
    reduced_tolerance: Annotated[
        float, typer.Option("--reduced-tolerance", help="transfer: certified error of the reduced models' G")
    ] = 1e-7,
):
    """Stability map in the (m, U*) plane (MODEL.md §8): flutter and VIV neutral curves, the
    divergence curve, turning points and codimension-two crossings.

    --method transfer (default): the exact transfer function G(iω) sampled over --frequency-range,
    refined until every neutral curve is resolved to --tolerance; at each ω all neutral (m, U*)
    follow from a polynomial (fsistab.transfer_map). Where the sampling is refined, G comes from
    reduced (rational Krylov) models of the fluid with a certified error, one factorisation each
    (fsistab.reduced_model; --reduced-blocks 0 samples G exactly instead). Samples and models are
    saved and reused for other solid parameters.

    --method continuation: sweeps at --start-mass-ratio over --reduced-velocity-range, at each
    --seed-mass-ratio over that range scaled by √(m/start), and (with --wake-frequency) at the lowest
    m around the coincidence of the solid frequencies with the wake mode's; every threshold found is
    continued by pseudo-arclength. Each curve is saved (NetCDF) after every point.

    Rerunning the same command resumes."""

    from fsistab.critical import wake_mode_near
    from fsistab.linalg import FactorCounter
    from fsistab.neutral import map_seeds, neutral_map_dataset, trace_neutral_map
    from fsistab.operators import fluid_operators
    from fsistab.params import Flow
    from fsistab.plots import plot_stability_map
    from fsistab.reduced_model import ReducedModels
    from fsistab.steady import solve_steady
    from fsistab.store import write_dataset
    from fsistab.transfer_map import (
        as_neutral_map,
        default_frequency_range,
        transfer_neutral_map,
        unstable_grid,
    )

    if body != "plate":
        raise InputError("neutral maps are implemented for the plate (heave and pitch)")
    flow = Flow(reynolds, alpha0)
    lo_m, hi_m = mass_range
    if not (0 < lo_m < hi_m and math.isfinite(hi_m)):
        raise InputError(f"--mass-ratio-range must be 0 < low < high, got {lo_m:g} {hi_m:g}")
    if method == "continuation" and not lo_m <= start_mass <= hi_m:
        raise InputError("--mass-ratio-range must contain --start-mass-ratio (the first sweep)")
    start_mass = min(max(start_mass, lo_m), hi_m)  # transfer: only the template's m, any value works
    lo, hi = velocity_range
    if not 0 < lo < hi:
        raise InputError(f"--reduced-velocity-range must be 0 < low < high, got {lo:g} {hi:g}")
    if points < 2:
        raise InputError(f"--points must be at least 2, got {points}")
    if seed_masses is None:
        seed_masses = [m for m in (start_mass / 10, start_mass / 100) if m >= lo_m]
    if method == "continuation" and any(not lo_m <= m <= hi_m for m in seed_masses):
        raise InputError(f"every --seed-mass-ratio must lie in the mass-ratio range [{lo_m:g}, {hi_m:g}]")
    if wake_frequency is not None and not (math.isfinite(wake_frequency) and wake_frequency > 0):
        raise InputError(f"--wake-frequency must be positive, got {wake_frequency}")
    if method not in ("continuation", "transfer"):
        raise InputError(f"--method must be continuation or transfer, got {method!r}")
    if frequency_range is not None and not 0 < frequency_range[0] < frequency_range[1]:
        raise InputError(f"--frequency-range must be 0 < low < high, got {frequency_range}")
    if tolerance is not None and not 0 < tolerance < 0.5:
        raise InputError(f"--tolerance must be in (0, 0.5), got {tolerance}")
    if max_frequencies is not None and max_frequencies < 4:
        raise InputError(f"--max-frequencies must be at least 4, got {max_frequencies}")
    if reduced_blocks < 0 or 0 < reduced_blocks < 3:
        raise InputError(f"--reduced-blocks must be 0 (exact samples) or at least 3, got {reduced_blocks}")
    if not 0 < reduced_tolerance < 1e-2:
        raise InputError(f"--reduced-tolerance must be in (0, 1e-2), got {reduced_tolerance}")
    template = _solid(body, start_mass, lo, freq_ratio, zeta_h, zeta_theta, r_theta, "heave,pitch")
    spec = _spec(body, reynolds, preset, aspect_ratio, corner_radius, domain)
    console = _console(as_json)
    counter = FactorCounter()
    tag = _tag(body, reynolds, alpha0)
    attrs = _curve_attrs(reynolds, alpha0, spec, freq_ratio, zeta_h, zeta_theta, r_theta)
    reduced = None
    with console.status("steady state and operators") as status:
        fluid = fluid_operators(solve_steady(spec, flow, cache_dir=_cache(cache)))
        if wake_frequency is not None:
            status.update("wake mode of the fixed body")
            wake_frequency = wake_mode_near(fluid, wake_frequency, counter=counter).frequency
        if method == "transfer":
            if reduced_blocks:
                reduced = ReducedModels(
                    fluid,
                    tolerance=reduced_tolerance,
                    blocks=reduced_blocks,
                    path=out / f"reduced_{tag}_models.nc",
                    counter=counter,
                    progress=status.update,
                )
            tmap = transfer_neutral_map(
                fluid,
                template,
                mass_range=mass_range,
                omega_range=frequency_range or default_frequency_range(wake_frequency),
                wake_frequency=wake_frequency,
                tolerance=tolerance,
                max_samples=max_frequencies,
                samples_path=out / f"transfer_{tag}_samples.nc",
                reduced=reduced,
                counter=counter,
                progress=status.update,
            )
            result = as_neutral_map(tmap, template)
        else:
            seeds = map_seeds(
                start_mass, velocity_range, points, seed_masses, wake_frequency, lo_m, freq_ratio
            )
            result = trace_neutral_map(
                fluid,
                template,
                seeds,
                out,
                tag,
                attrs,
                mass_range=mass_range,
                max_points=max_points,
                counter=counter,
                progress=status.update,
            )
    map_attrs = {
        **attrs,
        "method": method,
        "wake_frequency": wake_frequency if wake_frequency is not None else float("nan"),
    }
    if method == "transfer":
        map_attrs["frequencies"] = len(tmap.frequencies)
        map_attrs["unresolved_intervals"] = len(tmap.unresolved)
        map_attrs["reduced_models"] = len(reduced.models) if reduced else 0
    data_path = write_dataset(neutral_map_dataset(result, map_attrs), out / f"neutral_{tag}_map.nc")
    import xarray as xr

    divergence = xr.Dataset(
        {"reduced_velocity": ("mass_ratio", result.divergence_velocities)},
        coords={"mass_ratio": result.divergence_mass_ratios},
        attrs={**attrs, "moment_slope": result.moment_slope},
    )
    write_dataset(divergence, out / f"neutral_{tag}_divergence.nc")
    import numpy as np

    unstable = None
    if method == "transfer":  # exact unstable regions from the signed crossings
        grid_m = np.geomspace(lo_m, hi_m, 100)
        all_u = [p.reduced_velocity for c in result.curves for p in c.points] + [1.0]
        grid_u = np.geomspace(min(all_u) / 1.5, max(all_u) * 1.5, 150)
        unstable = (grid_m, grid_u, unstable_grid(tmap, grid_m, grid_u)[0])
    figure = plot_stability_map(
        [
            (c.kind, [p.mass_ratio for p in c.points], [p.reduced_velocity for p in c.points])
            for c in result.curves
        ],
        (result.divergence_mass_ratios, result.divergence_velocities),
        out / f"neutral_{tag}.png",
        title=f"plate, Re = {reynolds:g}, alpha0 = {alpha0:g} deg",
        turning_points=[(t.mass_ratio, t.reduced_velocity) for c in result.curves for t in c.turning_points],
        crossings=[(c.crossing.mass_ratio, c.crossing.reduced_velocity) for c in result.crossings],
        unstable=unstable,
    )
    names = [f"{c.kind} {i}" for i, c in enumerate(result.curves)]

    def name_of(index: int) -> str:
        return "divergence" if index < 0 else names[index]

    payload = {
        "curves": [
            {
                "kind": c.kind,
                "seed_mass_ratio": c.seed_mass_ratio if math.isfinite(c.seed_mass_ratio) else None,
                "mass_ratio": [p.mass_ratio for p in c.points],
                "reduced_velocity": [p.reduced_velocity for p in c.points],
                "frequency": [p.frequency for p in c.points],
                "turning_points": [
                    {
                        "mass_ratio": t.mass_ratio,
                        "reduced_velocity": t.reduced_velocity,
                        "frequency": t.frequency,
                    }
                    for t in c.turning_points
                ],
                "stops": list(c.stops),
            }
            for c in result.curves
        ],
        "divergence": {
            "mass_ratio": result.divergence_mass_ratios.tolist(),
            "reduced_velocity": result.divergence_velocities.tolist(),
            "moment_slope": result.moment_slope,
        },
        "codimension_two": [
            {
                "curves": [name_of(c.first), name_of(c.second)],
                "mass_ratio": c.crossing.mass_ratio,
                "reduced_velocity": c.crossing.reduced_velocity,
            }
            for c in result.crossings
        ],
        "wake_frequency": wake_frequency,
        "method": method,
        "factorisations": counter.count,
        "reduced_models": len(reduced.models) if reduced else 0,
        "data": str(data_path),
        "figure": str(figure),
    }
    if as_json:
        _emit_json(payload)
        return
    table = Table(title=f"neutral curves: plate, Re = {reynolds:g}, m in [{lo_m:g}, {hi_m:g}]")
    for column in ("curve", "seed m", "points", "m range", "U* range", "turning points (m, U*)", "stops"):
        table.add_column(column, justify="right")
    for name, c in zip(names, result.curves, strict=True):
        m = [p.mass_ratio for p in c.points]
        u = [p.reduced_velocity for p in c.points]
        table.add_row(
            name,
            f"{c.seed_mass_ratio:g}" if math.isfinite(c.seed_mass_ratio) else "—",
            str(len(c.points)),
            f"{min(m):.4g}–{max(m):.4g}",
            f"{min(u):.4g}–{max(u):.4g}",
            ", ".join(f"({t.mass_ratio:.4g}, {t.reduced_velocity:.4g})" for t in c.turning_points) or "—",
            " / ".join(c.stops),
        )
    slope = result.moment_slope
    table.add_row(
        "divergence",
        "—",
        "analytic",
        f"{lo_m:g}–{hi_m:g}",
        f"U*_D = {math.sqrt(r_theta**2 / slope):.4g} √m",
        "—",
        "—",
    )
    console.print(table)
    for c in result.crossings:
        console.print(
            f"codimension-two point: {name_of(c.first)} × {name_of(c.second)} at "
            f"m = {c.crossing.mass_ratio:.5g}, U* = {c.crossing.reduced_velocity:.5g}"
        )
    if wake_frequency is not None:
        console.print(f"wake-mode frequency of the VIV sweep: {wake_frequency:.5g}")
    else:
        console.print("no VIV sweep: give --wake-frequency (a guess of the fixed body's wake-mode frequency)")
    if method == "transfer":
        console.print(
            f"transfer method: {len(tmap.frequencies)} frequencies sampled "
            f"({len(reduced.models) if reduced else 0} reduced fluid models), "
            f"{len(tmap.unresolved)} intervals unresolved at the smallest step (ends of curves or the budget)"
        )
    console.print(f"{counter.count} factorisations; curves and map saved in {out}; figure {figure}")


@app.command("flow-neutral")
@user_errors
def flow_neutral(
    parameter: Annotated[str, typer.Option("--parameter", help="reynolds or alpha0")] = "alpha0",
    parameter_range: Annotated[
        tuple[float, float], typer.Option("--range", help="range of Re, or of alpha0 in degrees")
    ] = (0.0, 5.0),
    body: BodyOpt = "plate",
    reynolds: ReOpt = 2900.0,
    alpha0: AlphaOpt = 0.0,
    preset: MeshOpt = "medium",
    out: OutOpt = Path("fsistab-out"),
    as_json: JsonOpt = False,
    cache: CacheOpt = None,
    aspect_ratio: AspectOpt = 20.0,
    corner_radius: CornerOpt = 0.1,
    domain: DomainOpt = None,
    mass_ratio: MassOpt = None,
    velocity_range: Annotated[
        tuple[float, float], typer.Option("--reduced-velocity-range", help="U* range of the initial sweep")
    ] = (2.0, 10.0),
    points: Annotated[int, typer.Option("--points", help="U* values of the initial sweep")] = 24,
    max_points: Annotated[int, typer.Option("--max-points", help="points per curve and direction")] = 40,
    freq_ratio: FreqRatioOpt = 0.8,
    zeta_h: ZetaHOpt = 0.0,
    zeta_theta: ZetaThetaOpt = 0.05,
    r_theta: RThetaOpt = 0.289,
):
    """Neutral curves in the (Re, U*) or (alpha0, U*) plane at one mass ratio, by pseudo-arclength
    continuation through turning points (MODEL.md §8), from the flutter thresholds of a sweep in U*
    at --Re/--alpha0. One mesh (fitted to --Re) for the whole curve; steady states are cached."""
    from dataclasses import replace

    import numpy as np

    from fsistab.critical import find_thresholds
    from fsistab.flow_neutral import PARAMETERS, continue_flow_neutral_curve, flow_curve_dataset
    from fsistab.linalg import FactorCounter
    from fsistab.operators import fluid_operators
    from fsistab.params import Flow
    from fsistab.plots import plot_flow_neutral
    from fsistab.steady import solve_steady
    from fsistab.store import read_dataset, write_dataset

    if body != "plate":
        raise InputError("flow-parameter neutral curves are implemented for the plate (heave and pitch)")
    if parameter not in PARAMETERS:
        raise InputError(f"--parameter must be one of {', '.join(PARAMETERS)}, got {parameter!r}")
    low, high = parameter_range
    start_value = reynolds if parameter == "reynolds" else alpha0
    if not low <= start_value <= high or not low < high:
        raise InputError(f"--range {low:g} {high:g} must be increasing and contain the starting {parameter}")
    lo, hi = velocity_range
    if not 0 < lo < hi:
        raise InputError(f"--reduced-velocity-range must be 0 < low < high, got {lo:g} {hi:g}")
    mass = 1000.0 if mass_ratio is None else mass_ratio
    solid = _solid(body, mass, lo, freq_ratio, zeta_h, zeta_theta, r_theta, "heave,pitch")
    flow = Flow(reynolds, alpha0)
    spec = _spec(body, reynolds, preset, aspect_ratio, corner_radius, domain)
    console = _console(as_json)
    counter = FactorCounter()
    tag = _tag(body, reynolds, alpha0)
    attrs = {
        **_curve_attrs(reynolds, alpha0, spec, freq_ratio, zeta_h, zeta_theta, r_theta),
        "mass_ratio": mass,
        "range_low": low,
        "range_high": high,
    }
    curves = []
    with console.status("steady state and operators") as status:
        fluid = fluid_operators(solve_steady(spec, flow, cache_dir=_cache(cache)))
        status.update(f"sweep in U* at m = {mass:g}")
        thresholds, _ = find_thresholds(fluid, solid, np.geomspace(lo, hi, points), counter=counter)
        dynamic = [t for t in thresholds if t.kind != "divergence"]
        for k, threshold in enumerate(dynamic):
            for direction in (-1, 1):
                side = "down" if direction < 0 else "up"
                path = out / f"flow_neutral_{tag}_{parameter}_m{mass:g}_curve{k}_{side}.nc"
                wanted = {**attrs, "kind": threshold.kind, "direction": direction, "max_points": max_points}
                if path.exists():
                    ds = read_dataset(path, expect=wanted)
                    curves.append((threshold.kind, direction, ds))
                    continue
                status.update(f"curve {k + 1}/{len(dynamic)} towards {side} {parameter}")
                curve = continue_flow_neutral_curve(
                    spec,
                    flow,
                    replace(solid, reduced_velocity=threshold.reduced_velocity),
                    threshold.frequency,
                    parameter,
                    parameter_range,
                    direction=direction,
                    max_points=max_points,
                    cache_dir=_cache(cache),
                    fluid=fluid,
                    counter=counter,
                )
                ds = write_dataset(flow_curve_dataset(curve, wanted), path)
                curves.append((threshold.kind, direction, read_dataset(ds)))
    column = "reynolds" if parameter == "reynolds" else "alpha0_deg"
    figure = plot_flow_neutral(
        [
            (
                kind,
                ds[column].values,
                ds.reduced_velocity.values,
                ds[f"fold_{column}"].values,
                ds.fold_reduced_velocity.values,
            )
            for kind, _, ds in curves
        ],
        parameter,
        out / f"flow_neutral_{tag}_{parameter}_m{mass:g}.png",
        title=f"plate, m = {mass:g}, from Re = {reynolds:g}, alpha0 = {alpha0:g} deg",
    )
    payload = {
        "parameter": parameter,
        "mass_ratio": mass,
        "curves": [
            {
                "kind": kind,
                "direction": "decreasing" if direction < 0 else "increasing",
                parameter: ds[column].values.tolist(),
                "reduced_velocity": ds.reduced_velocity.values.tolist(),
                "frequency": ds.frequency.values.tolist(),
                "turning_points": [
                    {parameter: float(p), "reduced_velocity": float(u)}
                    for p, u in zip(ds[f"fold_{column}"].values, ds.fold_reduced_velocity.values, strict=True)
                ],
                "stop": ds.attrs["stop"],
            }
            for kind, direction, ds in curves
        ],
        "factorisations": counter.count,
        "figure": str(figure),
    }
    if as_json:
        _emit_json(payload)
        return
    table = Table(title=f"neutral curves in ({parameter}, U*): plate, m = {mass:g}")
    for name in ("curve", "points", f"{parameter} range", "U* range", "turning points", "stop"):
        table.add_column(name, justify="right")
    for kind, direction, ds in curves:
        values, u = ds[column].values, ds.reduced_velocity.values
        table.add_row(
            f"{kind} ({'down' if direction < 0 else 'up'})",
            str(len(values)),
            f"{values.min():.4g}–{values.max():.4g}",
            f"{u.min():.4g}–{u.max():.4g}",
            ", ".join(
                f"({p:.4g}, {v:.4g})"
                for p, v in zip(ds[f"fold_{column}"].values, ds.fold_reduced_velocity.values, strict=True)
            )
            or "—",
            ds.attrs["stop"],
        )
    console.print(table)
    console.print(f"{counter.count} factorisations; curves saved in {out}; figure {figure}")


SLOPE_SOURCES = ("thin-airfoil", "calibrated", "given")


def _theodorsen_slopes(
    slopes: str,
    lift_slope_alpha: float | None,
    moment_slope_alpha: float | None,
    reynolds: float,
    alpha0: float,
    preset: str,
    aspect_ratio: float,
    corner_radius: float,
    domain,
    cache: Path | None,
    console: Console,
):
    """Slopes of the Theodorsen model: thin airfoil, given (dC_L/dα, d(-C_M)/dα), or the viscous
    static slopes of MODEL.md §9 (``calibrated``) through the same API path as ``fsistab slopes``:
    cached steady state, fluid operators, one linear solve."""
    from fsistab.theodorsen import AirfoilSlopes

    if slopes not in SLOPE_SOURCES:
        raise InputError(f"unknown --slopes {slopes!r}: choose {', '.join(SLOPE_SOURCES)}")
    given = (lift_slope_alpha, moment_slope_alpha)
    if slopes != "given" and any(v is not None for v in given):
        raise InputError("--lift-slope-alpha and --moment-slope-alpha need --slopes given")
    if slopes == "thin-airfoil":
        return AirfoilSlopes.thin_airfoil()
    if slopes == "given":
        if any(v is None for v in given):
            raise InputError("--slopes given needs both --lift-slope-alpha and --moment-slope-alpha")
        return AirfoilSlopes.from_alpha(lift_slope_alpha, moment_slope_alpha)
    from fsistab.operators import fluid_operators
    from fsistab.params import Flow
    from fsistab.slopes import static_slopes
    from fsistab.steady import solve_steady

    flow = Flow(reynolds, alpha0)
    spec = _spec("plate", reynolds, preset, aspect_ratio, corner_radius, domain)
    with console.status(f"viscous static slopes at Re = {reynolds:g} (steady state, one linear solve)"):
        steady_state = solve_steady(spec, flow, cache_dir=_cache(cache))
        return AirfoilSlopes.from_static(static_slopes(fluid_operators(steady_state)))


def _viscous_neutral_curves(out: Path, tag: str, section):
    """Flutter curves and divergence written by ``fsistab neutral`` in ``out`` for ``tag``, if they
    exist and were computed with the section's solid parameters; ``(curves, note)``."""
    from fsistab.errors import CacheError
    from fsistab.store import read_dataset

    files = sorted(out.glob(f"neutral_{tag}_curve*_*.nc"))
    if not files:
        return None, f"no neutral_{tag}_curve*.nc in {out}: no viscous comparison"
    if section.elastic_axis != 0 or section.static_unbalance != 0:
        return None, "the viscous plate has a = 0 and x_θ = 0: no viscous comparison"
    solid = section.solid
    wanted = {
        "freq_ratio": solid.freq_ratio,
        "zeta_h": solid.zeta_h,
        "zeta_theta": solid.zeta_theta,
        "r_theta": solid.r_theta,
    }
    pieces: dict[str, dict[str, object]] = {}
    for path in files:
        try:
            ds = read_dataset(path)
        except CacheError as exc:
            return None, f"{exc}: no viscous comparison"
        if any(not math.isclose(float(ds.attrs.get(k, math.nan)), v) for k, v in wanted.items()):
            return None, f"{path.name} has other solid parameters: no viscous comparison"
        if ds.attrs.get("kind") != "flutter":
            continue
        curve, direction = path.stem.rsplit("_", 2)[-2:]
        pieces.setdefault(curve, {})[direction] = (ds.mass_ratio.values, ds.reduced_velocity.values)
    flutter = []
    for parts in pieces.values():
        down = parts.get("down", ([], []))
        up = parts.get("up", ([], []))
        masses = [*reversed(list(down[0])), *list(up[0])[1 if len(down[0]) else 0 :]]
        velocities = [*reversed(list(down[1])), *list(up[1])[1 if len(down[1]) else 0 :]]
        if masses:
            flutter.append(([float(m) for m in masses], [float(u) for u in velocities]))
    divergence = None
    divergence_path = out / f"neutral_{tag}_divergence.nc"
    if divergence_path.is_file():
        ds = read_dataset(divergence_path)
        divergence = (ds.mass_ratio.values, ds.reduced_velocity.values)
    return {"flutter": flutter, "divergence": divergence}, f"viscous neutral curves from {out}"


@app.command()
@user_errors
def theodorsen(
    mass_ratio: Annotated[float, typer.Option("--mass-ratio", help="m = m_solid/(½ρc²)")] = 1000.0,
    mass_range: Annotated[
        tuple[float, float] | None,
        typer.Option("--mass-ratio-range", help="draw the neutral curves U*(m) over this m range"),
    ] = None,
    points: Annotated[int, typer.Option("--points", help="mass ratios of the neutral curves (log)")] = 40,
    velocity_range: Annotated[
        tuple[float, float], typer.Option("--reduced-velocity-range", help="U* range searched")
    ] = (0.01, 100.0),
    slopes: Annotated[
        str, typer.Option("--slopes", help="thin-airfoil | calibrated (viscous, at --Re) | given")
    ] = "thin-airfoil",
    lift_slope_alpha: Annotated[
        float | None, typer.Option("--lift-slope-alpha", help="dC_L/dα per radian (--slopes given)")
    ] = None,
    moment_slope_alpha: Annotated[
        float | None,
        typer.Option("--moment-slope-alpha", help="d(-C_M)/dα about mid-chord per radian (--slopes given)"),
    ] = None,
    elastic_axis: Annotated[
        float, typer.Option("--elastic-axis", help="a: mid-chord → elastic axis, chords, downstream +")
    ] = 0.0,
    static_unbalance: Annotated[
        float, typer.Option("--static-unbalance", help="x_θ: elastic axis → centre of mass, chords, aft +")
    ] = 0.0,
    freq_ratio: FreqRatioOpt = 0.8,
    zeta_h: ZetaHOpt = 0.0,
    zeta_theta: ZetaThetaOpt = 0.05,
    r_theta: Annotated[
        float, typer.Option("--r-theta", help="radius of gyration about the elastic axis")
    ] = 0.289,
    reynolds: ReOpt = 2900.0,
    alpha0: AlphaOpt = 0.0,
    preset: MeshOpt = "medium",
    out: OutOpt = Path("fsistab-out"),
    as_json: JsonOpt = False,
    cache: CacheOpt = None,
    aspect_ratio: AspectOpt = 20.0,
    corner_radius: CornerOpt = 0.1,
    domain: DomainOpt = None,
):
    """Analytic typical section with Theodorsen aerodynamics (MODEL.md §9): every flutter boundary
    (real roots of the 2×2 determinant) and the divergence along U* at one mass ratio, or the
    neutral curves U*(m) with --mass-ratio-range (compared with `fsistab neutral` if its files for
    the same Re are in --out). --Re, --alpha0 and --mesh matter for --slopes calibrated only
    (and --Re for finding the viscous curves)."""
    from dataclasses import replace

    import numpy as np

    from fsistab.theodorsen import (
        TypicalSection,
        critical_points,
        lower_envelope,
        lowest_flutter_velocity,
        neutral_curves,
    )

    lo, hi = velocity_range
    if not (0 < lo < hi and math.isfinite(hi)):
        raise InputError(f"--reduced-velocity-range must be 0 < low < high, got {lo:g} {hi:g}")
    if mass_range is not None:
        lo_m, hi_m = mass_range
        if not (0 < lo_m < hi_m and math.isfinite(hi_m)):
            raise InputError(f"--mass-ratio-range must be 0 < low < high, got {lo_m:g} {hi_m:g}")
        if not 2 <= points <= 2000:
            raise InputError(f"--points must be between 2 and 2000, got {points}")
    section = TypicalSection.create(
        mass_ratio=mass_ratio,
        reduced_velocity=lo,
        freq_ratio=freq_ratio,
        zeta_h=zeta_h,
        zeta_theta=zeta_theta,
        r_theta=r_theta,
        elastic_axis=elastic_axis,
        static_unbalance=static_unbalance,
    )
    console = _console(as_json)
    airfoil = _theodorsen_slopes(
        slopes,
        lift_slope_alpha,
        moment_slope_alpha,
        reynolds,
        alpha0,
        preset,
        aspect_ratio,
        corner_radius,
        domain,
        cache,
        console,
    )
    section = replace(section, slopes=airfoil)
    slope_info = {
        "source": airfoil.source,
        "lift_slope_alpha": airfoil.lift_slope_alpha,
        "moment_slope_alpha": airfoil.moment_slope_alpha,
        "moment_slope_elastic_axis": section.moment_slope_elastic_axis,
    }
    if mass_range is None:
        found = critical_points(section, (lo, hi))
        payload = {
            "mass_ratio": section.mass_ratio,
            "critical_points": [
                {
                    "kind": p.kind,
                    "reduced_velocity": p.reduced_velocity,
                    "frequency": p.frequency,
                    "boundary": p.boundary,
                }
                for p in found
            ],
            "slopes": slope_info,
        }
        if as_json:
            _emit_json(payload)
            return
        table = Table(
            title=f"Theodorsen typical section: m = {section.mass_ratio:g}, slopes {airfoil.source}, "
            f"a = {elastic_axis:g}, x_θ = {static_unbalance:g}, U* in [{lo:g}, {hi:g}]"
        )
        for column in ("kind", "boundary", "U*_c", "ω_c", "ω_c/ω_θ = ω_c U*_c"):
            table.add_column(column, justify="right")
        for p in found:
            table.add_row(
                p.kind,
                p.boundary,
                f"{p.reduced_velocity:.6g}",
                f"{p.frequency:.6g}",
                f"{p.frequency_ratio:.4g}",
            )
        console.print(table)
        if not found:
            console.print("no flutter or divergence boundary in this U* range")
        console.print(
            f"dC_L/dα = {airfoil.lift_slope_alpha:.4f}, d(-C_M)/dα = {airfoil.moment_slope_alpha:.4f} "
            f"(mid-chord), dC_M/dθ about the elastic axis = {section.moment_slope_elastic_axis:.4f}"
        )
        return
    masses = np.geomspace(lo_m, hi_m, points)
    with console.status(f"Theodorsen neutral curves at {points} mass ratios"):
        ds = neutral_curves(section, masses, (lo, hi))
    tag = _tag("plate", reynolds, alpha0)
    name = f"theodorsen_{tag}_{slopes}"
    ds.attrs.update({"reynolds": reynolds, "alpha0_deg": alpha0})
    from fsistab.plots import plot_theodorsen_map
    from fsistab.store import write_dataset

    viscous, note = _viscous_neutral_curves(out, tag, section)
    comparison = None
    if viscous and viscous["flutter"]:
        lowest = lower_envelope(viscous["flutter"])
        errors = []
        for m, u in lowest:
            u_theodorsen = lowest_flutter_velocity(section.with_mass_ratio(m), (lo, hi))
            errors.append((m, u, u_theodorsen, (u_theodorsen - u) / u))
        comparison = errors
        ds.attrs["viscous_comparison"] = note
    data_path = write_dataset(ds, out / f"{name}.nc")
    figure = plot_theodorsen_map(
        ds,
        out / f"{name}.png",
        viscous=viscous,
        comparison=([c[0] for c in comparison], [c[3] for c in comparison]) if comparison else None,
        title=f"Theodorsen ({airfoil.source}) vs viscous, plate, Re = {reynolds:g}"
        if viscous
        else f"Theodorsen typical section, slopes {airfoil.source}",
    )
    velocities = ds.reduced_velocity.values
    payload = {
        "mass_ratio": masses.tolist(),
        "flutter": {
            "reduced_velocity": [
                [None if not math.isfinite(v) else float(v) for v in row] for row in velocities
            ],
            "frequency": [
                [None if not math.isfinite(v) else float(v) for v in row] for row in ds.frequency.values
            ],
        },
        "divergence": [None if not math.isfinite(v) else float(v) for v in ds.divergence_velocity.values],
        "slopes": slope_info,
        "comparison": [
            {
                "mass_ratio": m,
                "viscous": u,
                "theodorsen": t if math.isfinite(t) else None,
                "relative_error": e if math.isfinite(e) else None,
            }
            for m, u, t, e in comparison
        ]
        if comparison
        else None,
        "netcdf": str(data_path),
        "figure": str(figure),
    }
    if as_json:
        _emit_json(payload)
        return
    table = Table(title=f"Theodorsen neutral curves, slopes {airfoil.source}, m in [{lo_m:g}, {hi_m:g}]")
    for column in ("m", "flutter U*_F", "ω_F/ω_θ", "divergence U*_D"):
        table.add_column(column, justify="right")
    for i in np.unique(np.linspace(0, points - 1, min(points, 12)).round().astype(int)):
        row = velocities[i]
        ok = np.isfinite(row)
        flutter = ", ".join(f"{v:.4g}" for v in row[ok]) or "none"
        ratio = ", ".join(f"{v:.3g}" for v in (row * ds.frequency.values[i])[ok]) or "-"
        table.add_row(f"{masses[i]:.4g}", flutter, ratio, f"{ds.divergence_velocity.values[i]:.4g}")
    console.print(table)
    errors = np.array([c[3] for c in comparison or [] if math.isfinite(c[3])])
    if errors.size:
        console.print(
            f"lowest flutter boundary vs viscous ({errors.size} points): relative error "
            f"{100 * errors.min():+.1f} % to {100 * errors.max():+.1f} %"
        )
    else:
        console.print(note)
    console.print(f"data {data_path}; figure {figure}")


@app.command()
@user_errors
def transfer(
    body: BodyOpt = "plate",
    reynolds: ReOpt = 2900.0,
    alpha0: AlphaOpt = 0.0,
    preset: MeshOpt = "medium",
    out: OutOpt = Path("fsistab-out"),
    as_json: JsonOpt = False,
    cache: CacheOpt = None,
    aspect_ratio: AspectOpt = 20.0,
    corner_radius: CornerOpt = 0.1,
    domain: DomainOpt = None,
    k_range: Annotated[
        tuple[float, float],
        typer.Option("--reduced-frequency-range", help="k = ω L/(2U∞) range, log-spaced"),
    ] = (0.01, 2.0),
    points: Annotated[int, typer.Option("--points", help="number of reduced frequencies")] = 24,
):
    """Viscous Theodorsen function: the body's load transfer G(ik) against Theodorsen's model."""
    import numpy as np

    from fsistab.operators import fluid_operators
    from fsistab.params import Flow
    from fsistab.plots import plot_viscous_theodorsen
    from fsistab.steady import solve_steady
    from fsistab.store import write_dataset
    from fsistab.transfer import from_parts, viscous_theodorsen_dataset

    k_low, k_high = k_range
    if not (math.isfinite(k_low) and math.isfinite(k_high) and 0 < k_low < k_high):
        raise InputError(f"the reduced-frequency range must be 0 < low < high, got {k_low:g} {k_high:g}")
    if points < 2:
        raise InputError("--points must be at least 2")
    flow = Flow(reynolds, alpha0)
    spec = _spec(body, reynolds, preset, aspect_ratio, corner_radius, domain)
    console = _console(as_json)
    omega = 2 * np.geomspace(k_low, k_high, points)
    with console.status("steady state") as status:
        fluid = fluid_operators(solve_steady(spec, flow, cache_dir=_cache(cache)))

        def progress(done: int, total: int) -> None:
            status.update(f"G(iω): {done}/{total} frequencies ({fluid.n_fluid} fluid unknowns)")

        samples_path = _cache(cache) / "transfer" / f"{spec.key()}_{_tag(body, reynolds, alpha0)}.nc"
        ds = viscous_theodorsen_dataset(fluid, omega, progress=progress, samples_path=samples_path)
    tag = _tag(body, reynolds, alpha0)
    data_path = write_dataset(ds, out / f"transfer_{tag}_{preset}.nc")
    figure = plot_viscous_theodorsen(ds, out / f"transfer_{tag}_{preset}.png")
    loads = from_parts(ds.viscous_loads)
    thin = from_parts(ds.theodorsen_thin_airfoil)
    calibrated = from_parts(ds.theodorsen_calibrated)
    pair = lambda z: [float(z.real), float(z.imag)]  # noqa: E731
    payload = {
        "reynolds": reynolds,
        "alpha0_deg": alpha0,
        "ndof": fluid.n_fluid,
        "factorisations": int(ds.attrs["factorisations"]),
        "lift_slope_alpha": float(ds.attrs["lift_slope_alpha"]),
        "moment_slope_alpha": float(ds.attrs["moment_slope_alpha"]),
        "samples": [
            {
                "frequency": float(w),
                "reduced_frequency": float(w / 2),
                "lift_per_pitch": pair(loads[i, 0, 1]),
                "moment_per_pitch": pair(loads[i, 1, 1]),
                "lift_per_heave": pair(loads[i, 0, 0]),
                "moment_per_heave": pair(loads[i, 1, 0]),
            }
            for i, w in enumerate(omega)
        ],
        "netcdf": str(data_path),
        "figure": str(figure),
    }
    if as_json:
        _emit_json(payload)
        return
    table = Table(title=f"C_L/θ̂ and C_M/θ̂, {body}, Re = {reynolds:g}, α0 = {alpha0:g}°, mesh {preset}")
    for column in (
        "k",
        "C_L/θ̂ (NS)",
        "thin airfoil",
        "calibrated",
        "C_M/θ̂ (NS)",
        "thin airfoil",
        "calibrated",
    ):
        table.add_column(column, justify="right")
    fmt = lambda z: f"{z.real:+.2f}{z.imag:+.2f}i"  # noqa: E731
    for i, w in enumerate(omega):
        table.add_row(
            f"{w / 2:.3g}",
            *(fmt(a[i, 0, 1]) for a in (loads, thin, calibrated)),
            *(fmt(a[i, 1, 1]) for a in (loads, thin, calibrated)),
        )
    console.print(table)
    console.print(f"{ds.attrs['factorisations']} factorisations; data {data_path}; figure {figure}")


def main() -> None:  # pragma: no cover - console entry point
    app()


if __name__ == "__main__":  # pragma: no cover
    main()
