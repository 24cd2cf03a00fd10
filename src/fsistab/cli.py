"""Command line: thin typer commands over :mod:`fsistab.workflows`.

Every command parses its options, builds validated parameters (:mod:`fsistab.params`) before any
work, checks that the mesh fits the machine (:func:`fsistab.resources.check_fits`) and that
``--out`` and ``--cache`` are writable directories, then calls one workflow, draws its figures and
prints a table, or with ``--json`` exactly one JSON object on stdout. Progress goes to stderr (a
spinner on a terminal, timed lines otherwise); an interrupted run says what was saved. Bad input
prints one line and exits with status 2. The options shared by several commands are declared once
(the ``*_OPTIONS`` groups below) and added to each command's signature by :func:`command`.

Imports of the numerical modules are lazy, so that ``--help`` and bad input answer at once.
"""

import contextlib
import inspect
import json
import logging
import math
import os
import sys
from collections.abc import MutableMapping
from pathlib import Path
from types import SimpleNamespace
from typing import Annotated

import typer
import typer.core

from fsistab import params
from fsistab.errors import FsistabError, InputError
from fsistab.progress import one_line


def _fail(message: str) -> None:
    from rich.console import Console
    from rich.text import Text

    console = Console(stderr=True, soft_wrap=True, highlight=False)
    console.print(Text.assemble(("error:", "bold red"), " ", one_line(message)))
    raise typer.Exit(code=2)


class _PlainWarnings(logging.Handler):
    """fsistab's warnings (e.g. a damaged cache entry recomputed) as single plain lines on the
    stderr of the moment (stdout stays clean for ``--json``)."""

    def emit(self, record: logging.LogRecord) -> None:
        try:
            sys.stderr.write(f"warning: {one_line(record.getMessage())}\n")
            sys.stderr.flush()
        except Exception:  # a warning must never end the run
            self.handleError(record)


def _install_warning_handler() -> None:
    logger = logging.getLogger("fsistab")
    if not any(isinstance(h, _PlainWarnings) for h in logger.handlers):
        handler = _PlainWarnings(level=logging.WARNING)
        logger.addHandler(handler)
    if logger.level == logging.NOTSET:
        logger.setLevel(logging.WARNING)


# click's UsageError as typer raises it (typer vendors its own copy of click)
_UsageError = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "UsageError")


class _Commands(typer.core.TyperGroup):
    """Usage errors of a command (a value of the wrong type, an unknown option) in one line too."""

    def invoke(self, ctx):
        _install_warning_handler()
        try:
            return super().invoke(ctx)
        except _UsageError as exc:
            _fail(exc.format_message())


app = typer.Typer(
    cls=_Commands,
    add_completion=False,
    no_args_is_help=True,
    help="Global linear stability of spring-mounted bodies in viscous flow (fsistab).",
)


# --- the shared options, declared once ------------------------------------------------------------

CASE_OPTIONS = {
    "body": (
        Annotated[str, typer.Option("--body", help="plate (chord-based units) or cylinder (diameter-based)")],
        "plate",
    ),
    "reynolds": (Annotated[float, typer.Option("--Re", help="Reynolds number on the body length")], 2900.0),
    "alpha0": (
        Annotated[float, typer.Option("--alpha0", help="steady angle of attack, degrees, nose-up +")],
        0.0,
    ),
    "preset": (
        Annotated[str, typer.Option("--mesh", help="mesh preset: coarse, quick (plate), medium or fine")],
        "medium",
    ),
    "aspect_ratio": (Annotated[float, typer.Option("--aspect-ratio", help="plate chord/thickness")], 20.0),
    "corner_radius": (
        Annotated[float, typer.Option("--corner-radius", help="plate corner radius / thickness")],
        0.1,
    ),
    "domain": (
        Annotated[
            tuple[float, float, float] | None,
            typer.Option("--domain", help="upstream, downstream and lateral extents in body lengths"),
        ],
        None,
    ),
    "sponge": (
        Annotated[
            str,
            typer.Option(
                "--sponge",
                help="outlet sponge of the linear operators: preset (the mesh preset's, on its own "
                "domain), none, SIGMA_MAX,ZONE (e.g. 0.2,0.25), or SIGMA_MAX,ZONE,FAR_SIGMA,FAR_RAMP "
                "with a far-field layer outside the middle box and band (e.g. 0.2,0.25,0.2,10)",
            ),
        ],
        "preset",
    ),
}
OUTPUT_OPTIONS = {
    "out": (
        Annotated[Path, typer.Option("--out", help="directory for figures and data")],
        Path("fsistab-out"),
    ),
    "as_json": (
        Annotated[bool, typer.Option("--json", help="print one JSON object on stdout and nothing else")],
        False,
    ),
    "cache": (
        Annotated[
            Path | None,
            typer.Option("--cache", help="cache directory (default $FSISTAB_CACHE or ~/.cache/fsistab)"),
        ],
        None,
    ),
}
FIGURE_OPTIONS = {
    "figure_format": (
        Annotated[str, typer.Option("--format", help="figure format: png, pdf or svg (vector)")],
        "png",
    ),
}
SOLID_OPTIONS = {
    "freq_ratio": (Annotated[float, typer.Option("--freq-ratio", help="Ω = ω_h/ω_θ")], 0.8),
    "zeta_h": (Annotated[float, typer.Option("--zeta-h", help="heave damping ratio")], 0.0),
    "zeta_theta": (Annotated[float, typer.Option("--zeta-theta", help="pitch damping ratio")], 0.05),
    "r_theta": (Annotated[float, typer.Option("--r-theta", help="radius of gyration about G")], 0.289),
}
MASS_OPTION = {
    "mass_ratio": (
        Annotated[
            float | None,
            typer.Option("--mass-ratio", help="m (plate default 1000; cylinder, MODEL.md §10: 20)"),
        ],
        None,
    )
}
VELOCITY_OPTION = {
    "reduced_velocity": (
        Annotated[
            float | None, typer.Option("--reduced-velocity", help="U* (plate default 4.7; cylinder: 8)")
        ],
        None,
    )
}
DOFS_OPTION = {
    "dofs": (Annotated[str | None, typer.Option("--dofs", help="heave,pitch | heave | pitch | none")], None)
}

VelocityRange = Annotated[
    tuple[float, float], typer.Option("--reduced-velocity-range", help="U* range of the (initial) sweep")
]
Points = Annotated[int, typer.Option("--points", help="U* values of each sweep (log-spaced)")]


class Options(SimpleNamespace):
    """The raw values of a command's shared options, and the parameters they make."""

    def case(self, body: str | None = None, reynolds: float | None = None) -> params.Case:
        return params.Case.create(
            self.body if body is None else body,
            self.reynolds if reynolds is None else reynolds,
            self.alpha0,
            self.preset,
            self.aspect_ratio,
            self.corner_radius,
            self.domain,
            self.sponge,
        )

    def solid(self, kind: str, mass_ratio=None, reduced_velocity=None, dofs=None) -> params.Solid:
        mass = getattr(self, "mass_ratio", None) if mass_ratio is None else mass_ratio
        velocity = getattr(self, "reduced_velocity", None) if reduced_velocity is None else reduced_velocity
        text = getattr(self, "dofs", None)
        return params.solid_for(
            kind,
            mass,
            velocity,
            self.freq_ratio,
            self.zeta_h,
            self.zeta_theta,
            self.r_theta,
            params.parse_dofs(text, kind) if dofs is None else dofs,
        )


def command(*groups: dict, name: str | None = None, **settings):
    """Register ``func(opts, **own_options)`` as a command whose options are its own plus those of
    ``groups``; their values reach it as ``opts`` (:class:`Options`). Errors of fsistab (and
    failed writes) become one line and exit status 2. ``settings`` go to ``app.command``."""

    def decorate(func):
        own = [p for p in inspect.signature(func).parameters.values() if p.name != "opts"]
        shared = [
            inspect.Parameter(key, inspect.Parameter.KEYWORD_ONLY, default=default, annotation=annotation)
            for group in groups
            for key, (annotation, default) in group.items()
        ]
        names = [p.name for p in shared]

        def wrapper(**values):
            opts = Options(**{key: values.pop(key) for key in names})
            try:
                with _figure_format(getattr(opts, "figure_format", None)):
                    return func(opts, **values)
            except FsistabError as exc:
                _fail(str(exc).splitlines()[0] if str(exc) else type(exc).__name__)
            except OSError as exc:  # e.g. the disk filled up during the run
                _fail(f"cannot write {exc.filename or ''}: {exc.strerror or type(exc).__name__}")

        parameters = [p.replace(kind=inspect.Parameter.KEYWORD_ONLY) for p in own] + shared
        wrapper.__signature__ = inspect.Signature(parameters)
        wrapper.__annotations__ = {p.name: p.annotation for p in parameters}
        wrapper.__name__, wrapper.__doc__ = func.__name__, func.__doc__
        app.command(name, **settings)(wrapper)
        return func

    return decorate


# --- what every command does around its workflow -----------------------------------------------------


def _figure_format(fmt: str | None):
    """The figures of a command with ``--format`` are written in that format (fsistab.plots)."""
    if fmt is None:
        return contextlib.nullcontext()
    from fsistab import plots

    return plots.figure_format(fmt)


def _missing(path: Path) -> list[Path]:
    """``path`` and its ancestors that do not exist yet, deepest first."""
    path = Path(path).expanduser().absolute()
    return [p for p in (path, *path.parents) if not p.exists()]


def _writable_dirs(out: Path, cache: Path | None) -> tuple[Path, Path]:
    """Create and write-test ``--out`` and ``--cache``; on a refusal remove what was created."""
    from fsistab.store import default_cache_dir, ensure_writable_dir

    cache = default_cache_dir() if cache is None else cache
    created: list[Path] = []
    try:
        for path, what in ((out, "--out"), (cache, "--cache")):
            created += _missing(path)
            ensure_writable_dir(path, what)
    except InputError:
        for path in created:
            with contextlib.suppress(OSError):
                path.rmdir()
        raise
    return Path(out), Path(cache)


def _prepare(opts: Options, cases=()) -> tuple[Path, Path]:
    """After validation, before any work: the meshes fit the machine, the directories are writable."""
    from fsistab.mesh import spec_for
    from fsistab.resources import check_fits

    for case in cases:
        check_fits(spec_for(case))
    return _writable_dirs(opts.out, opts.cache)


@contextlib.contextmanager
def _running(resume_hint: str = "rerun the same command to resume"):
    """Progress reporter (stderr) and clean interruption naming the files saved so far."""
    from fsistab.progress import Reporter, interruptible
    from fsistab.store import recording

    with recording() as saved, interruptible(lambda: list(saved), resume_hint), Reporter() as reporter:
        yield reporter


def _emit(payload: dict) -> None:
    sys.stdout.write(json.dumps(payload, allow_nan=True) + "\n")


def _print(*renderables) -> None:
    from rich.console import Console

    console = Console()
    for item in renderables:
        console.print(item)


def _table(title: str, columns, rows):
    from rich.table import Table

    table = Table(title=title)
    for column in columns:
        table.add_column(column, justify="right")
    for row in rows:
        table.add_row(*row)
    return table


def _threshold_sweep(opts, velocity_range, points, wake_shift, what: str, method: str = "transfer"):
    """``(case, sweep, solid)`` of a command that finds every threshold along U* at one mass ratio
    (the body's default when ``--mass-ratio`` is not given); ``what`` names it in the error."""
    case = opts.case()
    mass = case.body.default_mass_ratio if opts.mass_ratio is None else opts.mass_ratio
    wake = None if wake_shift is None else params.parse_complex("wake shift", wake_shift)
    sweep = params.SweepSettings(velocity_range, points, wake, mass, method)
    solid = opts.solid(case.kind, reduced_velocity=sweep.velocity_range[0])
    if not solid.dofs:
        raise InputError(f"{what} need at least one solid degree of freedom (--dofs)")
    return case, sweep, solid


# --- commands -----------------------------------------------------------------------------------------


@command(CASE_OPTIONS, OUTPUT_OPTIONS, FIGURE_OPTIONS)
def mesh(opts):
    """Build (or reuse) a mesh; print its size and save a picture."""
    from fsistab import workflows

    case = opts.case()
    out, cache = _prepare(opts, [case])
    with _running() as progress:
        ds = workflows.mesh_summary(case, cache, out, progress)
    payload = workflows.payload("mesh", ds)
    if opts.as_json:
        return _emit(payload)
    rows = [
        (name, f"{payload[name]:.4g}" if isinstance(payload[name], float) else str(payload[name]))
        for name in ("triangles", "vertices", "ndof", "h_min", "h_max")
    ]
    title = f"mesh: {case.kind}, preset {case.preset}, fitted to Re = {case.flow.reynolds:g}"
    _print(_table(title, ("quantity", "value"), rows), f"figure: {payload['figure']}")


@command(CASE_OPTIONS, OUTPUT_OPTIONS, FIGURE_OPTIONS)
def steady(opts):
    """Steady flow around the fixed body: coefficients, recirculation length, Newton history."""
    from fsistab import workflows

    case = opts.case()
    out, cache = _prepare(opts, [case])
    with _running() as progress:
        ds = workflows.steady_flow(case, cache, out, progress)
    p = workflows.payload("steady", ds)
    if opts.as_json:
        return _emit(p)
    rows = [
        (label, f"{p[key]:.6g}")
        for label, key in [
            ("lift coefficient C_L", "lift_coefficient"),
            ("drag coefficient C_D", "drag_coefficient"),
            ("moment coefficient C_M (about G, ccw +)", "moment_coefficient"),
            ("recirculation length (from the rear)", "recirculation_length"),
        ]
    ]
    rows += [("unknowns", str(p["ndof"])), ("Newton iterations at target", str(p["newton_iterations"]))]
    title = f"steady flow: {case.kind}, Re = {p['reynolds']:g}, alpha0 = {p['alpha0_deg']:g} deg"
    lines = [_table(title, ("quantity", "value"), rows)]
    lines.append("Newton residuals: " + ", ".join(f"{r:.2e}" for r in p["newton_residuals"]))
    if p["continuation"]:
        lines.append("continuation in Re: " + ", ".join(f"{s['reynolds']:.4g}" for s in p["continuation"]))
    work = f"{p['seconds']:.1f} s, {p['factorisations']} factorisations"
    _print(*lines, f"({'cache' if p['from_cache'] else work}) figure: {p['figure']}")


@command(
    CASE_OPTIONS, OUTPUT_OPTIONS, FIGURE_OPTIONS, MASS_OPTION, VELOCITY_OPTION, SOLID_OPTIONS, DOFS_OPTION
)
def spectrum(
    opts,
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
    case = opts.case()
    solid = opts.solid(case.kind)
    default = ["0.75j"] if case.kind == "cylinder" else ["0.05+0.2j"]
    shifts = tuple(params.parse_complex("shift", z) for z in (default if shift is None else shift))
    settings = params.SpectrumSettings(shifts, n_eigenvalues, vtk, mode_figures, phase)
    out, cache = _prepare(opts, [case])
    from fsistab import plots, workflows

    with _running() as progress:
        ds = workflows.spectrum(case, solid, settings, cache, out, progress)
    title = f"{case.kind}, Re = {case.flow.reynolds:g}"
    ds.attrs["figure"] = str(plots.plot_spectrum(ds, out / f"spectrum_{case.tag}.png", title=title))
    p = workflows.payload("spectrum", ds)
    if opts.as_json:
        return _emit(p)
    rows = [
        (f"{g:+.6f}", f"{w:.6f}", str(label), f"{e:.2f}", f"{r:.1e}")
        for g, w, label, e, r in zip(
            ds.growth_rate.values,
            ds.frequency.values,
            ds.label.values,
            ds.solid_energy_fraction.values,
            ds.residual.values,
            strict=True,
        )
    ]
    title = f"spectrum: {title}, alpha0 = {case.flow.alpha0_deg:g} deg, dofs {ds.attrs['dofs']}"
    columns = ("growth rate λ", "frequency ω", "label", "solid energy", "residual")
    modes = f"; modes {p['vtk']}" if p["vtk"] else ""
    _print(
        _table(title, columns, rows), f"{p['ndof']} unknowns; data {p['netcdf']}; figure {p['figure']}{modes}"
    )


_SLOPES_CASE = {k: v for k, v in CASE_OPTIONS.items() if k not in ("body", "reynolds")}


@command(_SLOPES_CASE, OUTPUT_OPTIONS, FIGURE_OPTIONS)
def slopes(
    opts,
    reynolds: Annotated[list[float], typer.Option("--Re", help="Reynolds numbers: --Re 10 100 1000")],
    more_reynolds: Annotated[
        list[float] | None, typer.Argument(help="further Reynolds numbers", show_default=False)
    ] = None,
):
    """Static slopes dC_L/dα and d(-C_M)/dα of the plate against Re (MODEL.md §9)."""
    opts.body = "plate"
    values = sorted({*reynolds, *(more_reynolds or [])})
    if len(values) > params.MAX_SWEEP_POINTS:
        raise InputError(f"at most {params.MAX_SWEEP_POINTS} Reynolds numbers, got {len(values)}")
    cases = [opts.case(reynolds=re) for re in values]  # every value validated before any work
    out, cache = _prepare(opts, cases)
    from fsistab import plots, workflows
    from fsistab.slopes import THIN_AIRFOIL_LIFT_SLOPE, THIN_AIRFOIL_MOMENT_SLOPE

    with _running() as progress:
        ds = workflows.static_slopes_study(cases, cache, out, progress)
    stem = f"slopes_plate_a{cases[0].flow.alpha0_deg:g}_{opts.preset}"
    ds.attrs["figure"] = str(plots.plot_slopes(ds, out / f"{stem}.png"))
    p = workflows.payload("slopes", ds)
    if opts.as_json:
        return _emit(p)
    rows = [
        (f"{s['reynolds']:g}", f"{s['lift_slope_alpha']:.4f}", f"{s['moment_slope_alpha']:.4f}")
        for s in p["slopes"]
    ]
    rows.append(("thin airfoil", f"{THIN_AIRFOIL_LIFT_SLOPE:.4f}", f"{THIN_AIRFOIL_MOMENT_SLOPE:.4f}"))
    title = f"static slopes, plate, alpha0 = {opts.alpha0:g} deg, mesh {opts.preset} (per radian)"
    _print(_table(title, ("Re", "dC_L/dα", "d(-C_M)/dα"), rows), f"data {p['netcdf']}; figure {p['figure']}")


@command(CASE_OPTIONS, OUTPUT_OPTIONS, MASS_OPTION, SOLID_OPTIONS, DOFS_OPTION)
def critical(
    opts,
    velocity_range: VelocityRange = (2.0, 10.0),
    points: Points = 24,
    wake_shift: Annotated[
        str | None,
        typer.Option(
            "--wake-shift",
            help="shift near the wake mode: samples near its frequency (VIV is labelled without it); "
            "with --method tracking, the wake mode is followed and labels VIV",
        ),
    ] = None,
    method: Annotated[
        str,
        typer.Option(
            "--method",
            help="transfer (G(iω) swept in frequency; --points unused) or tracking (eigenvalue branches)",
        ),
    ] = "transfer",
):
    """Every instability threshold along U* at one mass ratio (MODEL.md §8): by default the exact
    transfer function swept in frequency, each crossing converged by Newton on det T(iω; U*), and
    divergence from G(0); --method tracking follows eigenvalue branches over --points values."""
    case, sweep, solid = _threshold_sweep(opts, velocity_range, points, wake_shift, "critical points", method)
    out, cache = _prepare(opts, [case])
    from fsistab import workflows

    with _running() as progress:
        ds = workflows.critical_points(case, solid, sweep, cache, progress)
    p = workflows.payload("critical", ds)
    if opts.as_json:
        return _emit(p)
    scale = params.body_velocity_scale(case.kind)
    rows = [
        (t["kind"], t["boundary"], f"{t['reduced_velocity']:.6g}", f"{t['frequency']:.6g}")
        + (f"{t['frequency'] * t['reduced_velocity'] / scale:.4g}",)
        for t in p["critical_points"]
    ]
    lo, hi = sweep.velocity_range
    mass = sweep.mass_ratio
    title = f"thresholds: {case.kind}, Re = {case.flow.reynolds:g}, m = {mass:g}, U* in [{lo:g}, {hi:g}]"
    columns = ("kind", "boundary", "U*_c", "ω_c", "ω_c U*_c")
    _print(
        _table(title, columns, rows), f"{p['factorisations']} factorisations; {points} values of U* tracked"
    )


MAP_OPTIONS = {
    "mass_range": (
        Annotated[tuple[float, float], typer.Option("--mass-ratio-range", help="m range")],
        (1.0, 1e4),
    ),
    "start_mass": (
        Annotated[float, typer.Option("--start-mass-ratio", help="m of the initial sweep")],
        1000.0,
    ),
    "velocity_range": (VelocityRange, (2.0, 10.0)),
    "seed_masses": (
        Annotated[
            list[float] | None,
            typer.Option(
                "--seed-mass-ratio",
                help="further sweeps (repeatable; default m/10 and m/100 of the start), "
                "U* range scaled by √m",
            ),
        ],
        None,
    ),
    "wake_frequency": (
        Annotated[
            float | None,
            typer.Option(
                "--wake-frequency",
                help="guess of the fixed body's wake-mode ω (refined by Arnoldi): extra frequencies "
                "(transfer) or the VIV sweep at the lowest m (continuation); VIV is labelled without it",
            ),
        ],
        None,
    ),
    "points": (Points, 24),
    "max_points": (Annotated[int, typer.Option("--max-points", help="points per curve and direction")], 60),
    "method": (
        Annotated[
            str,
            typer.Option(
                "--method", help="transfer (G(iω) sweep, default) or continuation (sweeps + arclength)"
            ),
        ],
        "transfer",
    ),
    "frequency_range": (
        Annotated[
            tuple[float, float] | None,
            typer.Option(
                "--frequency-range",
                help="transfer: ω range sampled (default 0.01 to max(20, 1.5 ω_wake), "
                "extended down while a curve leaves it)",
            ),
        ],
        None,
    ),
    "min_step": (
        Annotated[
            float | None,
            typer.Option(
                "--min-step",
                help="transfer: smallest relative step of the exact refinement in ω (default 1e-3; "
                "reduced models: 1e-7); below it a certified rational fit of the samples refines on "
                "to 1e-7 where it can",
            ),
        ],
        None,
    ),
    "tolerance": (
        Annotated[
            float | None,
            typer.Option(
                "--tolerance",
                help="transfer: largest error of the tangent predictions between two samples, in "
                "(log m, log U*) (default 3e-3; exact samples only: 3e-2)",
            ),
        ],
        None,
    ),
    "max_frequencies": (
        Annotated[
            int | None,
            typer.Option(
                "--max-frequencies",
                help="transfer: at most this many sampled ω (default 4000; exact: 400, not counting "
                "those from rational fits)",
            ),
        ],
        None,
    ),
    "reduced_blocks": (
        Annotated[
            int | None,
            typer.Option(
                "--reduced-blocks",
                help="transfer: Krylov blocks of the reduced fluid models (0: exact samples, one "
                "model at a sharp resonance such as the wake mode and one at ω = 0; default 60 below "
                "100 000 fluid unknowns, 0 from there)",
            ),
        ],
        None,
    ),
    "reduced_tolerance": (
        Annotated[
            float,
            typer.Option("--reduced-tolerance", help="transfer: certified error of the reduced models' G"),
        ],
        1e-7,
    ),
}


@command(CASE_OPTIONS, OUTPUT_OPTIONS, FIGURE_OPTIONS, SOLID_OPTIONS, MAP_OPTIONS)
def neutral(opts):
    """Stability map in the (m, U*) plane (MODEL.md §8): flutter and VIV neutral curves, the
    divergence curve, turning points and codimension-two crossings.

    --method transfer (default): the exact transfer function G(iω) sampled over --frequency-range,
    refined until every neutral curve is resolved to --tolerance; at each ω all neutral (m, U*)
    follow from a polynomial (fsistab.transfer_map). Where the sampling is refined, G comes from
    reduced (rational Krylov) models of the fluid with a certified error, one factorisation each
    (fsistab.reduced_model; on meshes from 100 000 fluid unknowns, quick and medium among them, and
    with --reduced-blocks 0, G is sampled exactly instead: faster there, docs/performance.md).
    Samples and models are saved and reused for other solid parameters. A weakly damped fluid mode
    between two samples (the wake mode, whose VIV curves are narrow in ω) is located from them and
    sampled at its frequency: the VIV curves need no --wake-frequency.

    --method continuation: sweeps at --start-mass-ratio over --reduced-velocity-range, at each
    --seed-mass-ratio over that range scaled by √(m/start), and (with --wake-frequency) at the lowest
    m around the coincidence of the solid frequencies with the wake mode's; every threshold found is
    continued by pseudo-arclength. Each curve is saved (NetCDF) after every point.

    Rerunning the same command resumes."""
    case = opts.case()
    case.require_plate("neutral maps")
    names = [name for name in MAP_OPTIONS if name != "seed_masses"]
    seeds = None if opts.seed_masses is None else tuple(opts.seed_masses)
    settings = params.MapSettings(seed_masses=seeds, **{name: getattr(opts, name) for name in names})
    template = opts.solid("plate", settings.template_mass, settings.velocity_range[0], ("heave", "pitch"))
    out, cache = _prepare(opts, [case])
    from fsistab import plots, workflows

    with _running() as progress:
        ds = workflows.stability_map(case, template, settings, cache, out, progress)
    title = f"plate, Re = {case.flow.reynolds:g}, alpha0 = {case.flow.alpha0_deg:g} deg"
    ds.attrs["figure"] = str(plots.plot_map(ds, out / f"neutral_{case.tag}.png", title=title))
    p = workflows.payload("neutral", ds)
    if opts.as_json:
        return _emit(p)
    _print(*_neutral_report(ds, p, settings, out))


def _neutral_report(ds, p: dict, settings, out: Path) -> list:
    from fsistab.neutral_map import map_curve_names
    from fsistab.workflows import divergence_coefficient

    rows = []
    for name, c in zip(map_curve_names(ds), p["curves"], strict=True):
        m, u = c["mass_ratio"], c["reduced_velocity"]
        turning = ", ".join(
            f"({t['mass_ratio']:.4g}, {t['reduced_velocity']:.4g})" for t in c["turning_points"]
        )
        seed = "—" if c["seed_mass_ratio"] is None else f"{c['seed_mass_ratio']:g}"
        rows.append((name, seed, str(len(m)), f"{min(m):.4g}–{max(m):.4g}", f"{min(u):.4g}–{max(u):.4g}"))
        rows[-1] += (turning or "—", " / ".join(c["stops"]))
    lo_m, hi_m = settings.mass_range
    coefficient = divergence_coefficient(ds)
    law = f"U*_D = {coefficient:.4g} √m" if math.isfinite(coefficient) else "none (dC_M/dθ <= 0)"
    rows.append(("divergence", "—", "analytic", f"{lo_m:g}–{hi_m:g}", law, "—", "—"))
    columns = ("curve", "seed m", "points", "m range", "U* range", "turning points (m, U*)", "stops")
    title = f"neutral curves: plate, Re = {ds.attrs['reynolds']:g}, m in [{lo_m:g}, {hi_m:g}]"
    lines = [_table(title, columns, rows)]
    for c in p["codimension_two"]:
        first, second = c["curves"]
        lines.append(
            f"codimension-two point: {first} × {second} at "
            f"m = {c['mass_ratio']:.5g}, U* = {c['reduced_velocity']:.5g}"
        )
    if p["wake_frequency"] is not None:
        lines.append(f"wake-mode frequency (from --wake-frequency): {p['wake_frequency']:.5g}")
    elif p["method"] == "continuation":
        lines.append("no VIV sweep: give --wake-frequency (a guess of the fixed body's wake-mode frequency)")
    if p["method"] == "transfer":
        fitted = p["interpolated_frequencies"]  # with exact samples: from fits or resonance models
        lines.append(
            f"transfer method: {ds.attrs.get('frequencies', 0)} frequencies sampled "
            f"({p['reduced_models']} reduced fluid model{'' if p['reduced_models'] == 1 else 's'}"
            + (f"; {fitted} interpolated by them and {p['rational_fits']} rational fits" if fitted else "")
            + ")"
        )
    for interval in p["unresolved"]:
        low, high = interval["frequency_range"]
        lines.append(f"unresolved: ω in [{low:.5g}, {high:.5g}] ({interval['reason']})")
    for gap in p["unshaded"]:
        low, high = gap["mass_ratio_range"]
        lines.append(
            f"{gap['kind']}: a curve is missing at m in [{low:.4g}, {high:.4g}] (its crossings do not "
            "add up); its unstable region is not shaded there"
        )
    # a rerun reuses the saved samples: the map's frequencies are its cost, this count the run's
    lines.append(
        f"{p['factorisations']} factorisations in this run; curves and map saved in {out}; "
        f"figure {p['figure']}"
    )
    return lines


@command(CASE_OPTIONS, OUTPUT_OPTIONS, FIGURE_OPTIONS, MASS_OPTION, SOLID_OPTIONS, name="flow-neutral")
def flow_neutral(
    opts,
    parameter: Annotated[str, typer.Option("--parameter", help="reynolds or alpha0")] = "alpha0",
    parameter_range: Annotated[
        tuple[float, float], typer.Option("--range", help="range of Re, or of alpha0 in degrees")
    ] = (0.0, 5.0),
    velocity_range: VelocityRange = (2.0, 10.0),
    points: Points = 24,
    max_points: Annotated[int, typer.Option("--max-points", help="points per curve and direction")] = 40,
):
    """Neutral curves in the (Re, U*) or (alpha0, U*) plane at one mass ratio, by pseudo-arclength
    continuation through turning points (MODEL.md §8), from the flutter thresholds of a sweep in U*
    at --Re/--alpha0. One mesh (fitted to --Re) for the whole curve; steady states are cached."""
    case = opts.case()
    case.require_plate("flow-parameter neutral curves")
    start = opts.reynolds if parameter == "reynolds" else opts.alpha0
    settings = params.FlowNeutralSettings(
        parameter, parameter_range, start, velocity_range, points, max_points
    )
    solid = opts.solid("plate", reduced_velocity=settings.velocity_range[0], dofs=("heave", "pitch"))
    out, cache = _prepare(opts, [case])
    from fsistab import plots, workflows
    from fsistab.flow_neutral import flow_curves

    with _running() as progress:
        ds = workflows.flow_neutral_curves(case, solid, settings, cache, out, progress)
    mass = solid.mass_ratio
    path = out / f"flow_neutral_{case.tag}_{parameter}_m{mass:g}.png"
    title = f"plate, m = {mass:g}, from Re = {case.flow.reynolds:g}, alpha0 = {case.flow.alpha0_deg:g} deg"
    ds.attrs["figure"] = str(plots.plot_flow_neutral_curves(ds, path, title=title))
    p = workflows.payload("flow-neutral", ds)
    if opts.as_json:
        return _emit(p)
    rows = []
    for kind, direction, values, u, _, fp, fu, stop in flow_curves(ds):
        turning = ", ".join(f"({a:.4g}, {b:.4g})" for a, b in zip(fp, fu, strict=True)) or "—"
        side = "down" if direction < 0 else "up"
        rows.append((f"{kind} ({side})", str(len(values)), f"{values.min():.4g}–{values.max():.4g}"))
        rows[-1] += (f"{u.min():.4g}–{u.max():.4g}", turning, stop)
    columns = ("curve", "points", f"{parameter} range", "U* range", "turning points", "stop")
    table = _table(f"neutral curves in ({parameter}, U*): plate, m = {mass:g}", columns, rows)
    _print(table, f"{p['factorisations']} factorisations; curves saved in {out}; figure {p['figure']}")


_THEODORSEN_SOLID = {
    **SOLID_OPTIONS,
    "r_theta": (
        Annotated[float, typer.Option("--r-theta", help="radius of gyration about the elastic axis")],
        0.289,
    ),
}
_THEODORSEN_CASE = {k: v for k, v in CASE_OPTIONS.items() if k != "body"}


@command(_THEODORSEN_SOLID, _THEODORSEN_CASE, OUTPUT_OPTIONS, FIGURE_OPTIONS)
def theodorsen(
    opts,
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
):
    """Analytic typical section with Theodorsen aerodynamics (MODEL.md §9): every flutter boundary
    (real roots of the 2×2 determinant) and the divergence along U* at one mass ratio, or the
    neutral curves U*(m) with --mass-ratio-range (compared with the map `fsistab neutral` wrote in
    --out for the same Re and alpha0, by either method). --Re, --alpha0 and --mesh matter for
    --slopes calibrated only (and --Re, --alpha0 for finding the viscous map)."""
    opts.body = "plate"
    case = opts.case()
    settings = params.TheodorsenSettings(
        mass_ratio, mass_range, points, velocity_range, slopes, lift_slope_alpha, moment_slope_alpha,
        elastic_axis, static_unbalance,
    )  # fmt: skip
    from fsistab import workflows

    section = workflows.typical_section(opts.solid("plate", mass_ratio, dofs=("heave", "pitch")), settings)
    out, cache = _prepare(opts, [case] if slopes == "calibrated" else [])
    with _running() as progress:
        section = workflows.section_slopes(section, settings, case, cache, progress)
        if settings.mass_range is None:
            ds = workflows.theodorsen_points(section, settings)
        else:
            ds = workflows.theodorsen_comparison(section, settings, case, out, progress)
    if settings.mass_range is None:
        return _theodorsen_points_report(ds, settings, opts.as_json)
    from fsistab import plots

    source = section.slopes.source
    title = f"Theodorsen typical section, slopes {source}"
    if "viscous_divergence_mass_ratio" in ds:
        title = f"Theodorsen ({source}) vs viscous, plate, Re = {case.flow.reynolds:g}"
    path = Path(ds.attrs["netcdf"]).with_suffix(".png")
    ds.attrs["figure"] = str(plots.plot_theodorsen_comparison(ds, path, title=title))
    p = workflows.payload("theodorsen-map", ds)
    if opts.as_json:
        return _emit(p)
    _print(*_theodorsen_map_report(ds, p, settings))


def _theodorsen_points_report(ds, settings, as_json: bool) -> None:
    from fsistab.workflows import payload

    p = payload("theodorsen-points", ds)
    if as_json:
        return _emit(p)
    s = p["slopes"]
    lo, hi = settings.velocity_range
    title = (
        f"Theodorsen typical section: m = {p['mass_ratio']:g}, slopes {s['source']}, "
        f"a = {settings.elastic_axis:g}, x_θ = {settings.static_unbalance:g}, U* in [{lo:g}, {hi:g}]"
    )
    rows = [
        (t["kind"], t["boundary"], f"{t['reduced_velocity']:.6g}", f"{t['frequency']:.6g}", f"{r:.4g}")
        for t, r in zip(p["critical_points"], ds.frequency_ratio.values, strict=True)
    ]
    lines = [_table(title, ("kind", "boundary", "U*_c", "ω_c", "ω_c/ω_θ = ω_c U*_c"), rows)]
    if not rows:
        lines.append("no flutter or divergence boundary in this U* range")
    lines.append(
        f"dC_L/dα = {s['lift_slope_alpha']:.4f}, d(-C_M)/dα = {s['moment_slope_alpha']:.4f} "
        f"(mid-chord), dC_M/dθ about the elastic axis = {s['moment_slope_elastic_axis']:.4f}"
    )
    _print(*lines)


def _theodorsen_map_report(ds, p: dict, settings) -> list:
    import numpy as np

    masses, velocities = ds.mass_ratio.values, ds.reduced_velocity.values
    rows = []
    for i in np.unique(np.linspace(0, len(masses) - 1, min(len(masses), 12)).round().astype(int)):
        row = velocities[i]
        ok = np.isfinite(row)
        flutter = ", ".join(f"{v:.4g}" for v in row[ok]) or "none"
        ratio = ", ".join(f"{v:.3g}" for v in (row * ds.frequency.values[i])[ok]) or "-"
        rows.append((f"{masses[i]:.4g}", flutter, ratio, f"{ds.divergence_velocity.values[i]:.4g}"))
    lo_m, hi_m = settings.mass_range
    title = f"Theodorsen neutral curves, slopes {p['slopes']['source']}, m in [{lo_m:g}, {hi_m:g}]"
    lines = [_table(title, ("m", "flutter U*_F", "ω_F/ω_θ", "divergence U*_D"), rows)]
    errors = np.array([c["relative_error"] for c in p["comparison"] or [] if c["relative_error"] is not None])
    if errors.size:
        lines.append(
            f"lowest flutter boundary vs viscous ({errors.size} points): relative error "
            f"{100 * errors.min():+.1f} % to {100 * errors.max():+.1f} %"
        )
    else:
        lines.append(ds.attrs["viscous_comparison"])
    lines.append(f"data {p['netcdf']}; figure {p['figure']}")
    return lines


@command(CASE_OPTIONS, OUTPUT_OPTIONS, FIGURE_OPTIONS)
def transfer(
    opts,
    k_range: Annotated[
        tuple[float, float],
        typer.Option("--reduced-frequency-range", help="k = ω L/(2U∞) range, log-spaced"),
    ] = (0.01, 2.0),
    points: Annotated[int, typer.Option("--points", help="number of reduced frequencies")] = 24,
):
    """Viscous Theodorsen function: the body's load transfer G(ik) against Theodorsen's model."""
    case = opts.case()
    settings = params.TransferSettings(k_range, points)
    out, cache = _prepare(opts, [case])
    from fsistab import plots, workflows
    from fsistab.store import complex_values

    with _running() as progress:
        ds = workflows.transfer_function(case, settings, cache, out, progress)
    stem = f"transfer_{case.tag}_{case.preset}"
    ds.attrs["figure"] = str(plots.plot_viscous_theodorsen(ds, out / f"{stem}.png"))
    p = workflows.payload("transfer", ds)
    if opts.as_json:
        return _emit(p)
    loads = [
        complex_values(ds[name])
        for name in ("viscous_loads", "theodorsen_thin_airfoil", "theodorsen_calibrated")
    ]

    def fmt(z) -> str:
        return f"{z.real:+.2f}{z.imag:+.2f}i"

    rows = [
        (f"{w / 2:.3g}", *(fmt(a[i, 0, 1]) for a in loads), *(fmt(a[i, 1, 1]) for a in loads))
        for i, w in enumerate(ds.frequency.values)
    ]
    columns = ("k", "C_L/θ̂ (NS)", "thin airfoil", "calibrated", "C_M/θ̂ (NS)", "thin airfoil", "calibrated")
    flow = f"Re = {case.flow.reynolds:g}, α0 = {case.flow.alpha0_deg:g}°"
    title = f"C_L/θ̂ and C_M/θ̂, {case.kind}, {flow}, mesh {case.preset}"
    _print(
        _table(title, columns, rows),
        f"{p['factorisations']} factorisations; data {p['netcdf']}; figure {p['figure']}",
    )


@command(CASE_OPTIONS, OUTPUT_OPTIONS)
def onset(
    opts,
    guess: Annotated[
        float, typer.Option("--guess", help="first guess of the critical value (Re, or alpha0 in degrees)")
    ],
    parameter: Annotated[str, typer.Option("--parameter", help="reynolds or alpha0")] = "reynolds",
    shift: Annotated[
        str | None,
        typer.Option("--shift", help="guess of the leading eigenvalue, e.g. 0.75j (cylinder default)"),
    ] = None,
):
    """Critical Reynolds number (at --alpha0) or critical alpha0 (at --Re) of the FIXED body: the
    value where its leading global mode's growth rate vanishes, by the secant method on the growth
    rate, the steady state continued and the eigenvalue followed from iterate to iterate
    (fsistab.onset). One mesh for every iterate: fitted to --guess for the critical Re (--Re is then
    unused), to --Re for the critical alpha0. Steady states are cached: a rerun reuses them."""
    from fsistab.onset import check_onset, fitted_case

    case = opts.case()
    value = None if shift is None else params.parse_complex("shift", shift)
    guess, value = check_onset(case.kind, parameter, guess, value)
    out, cache = _prepare(opts, [fitted_case(case, parameter, guess)])
    from fsistab import plots, workflows

    with _running() as progress:
        ds = workflows.fixed_body_onset(case, parameter, guess, value, cache, out, progress)
    flow = case.flow
    at = f"alpha0 = {flow.alpha0_deg:g} deg" if parameter == "reynolds" else f"Re = {flow.reynolds:g}"
    title = f"onset: fixed {case.kind}, {at}, mesh {case.preset} ({ds.attrs['ndof']} unknowns)"
    ds.attrs["figure"] = str(plots.plot_onset(ds, Path(ds.attrs["data"]).with_suffix(".png"), title=title))
    p = workflows.payload("onset", ds)
    if opts.as_json:
        return _emit(p)
    name = "Re" if parameter == "reynolds" else "alpha0"
    rows = [
        (str(int(i)), f"{v:.8g}", f"{g:+.4e}", f"{w:.6f}", f"{r:.1e}", f"{ts:.1f}", f"{te:.1f}")
        for i, v, g, w, r, ts, te in zip(
            ds.iterate.values,
            ds.value.values,
            ds.growth_rate.values,
            ds.frequency.values,
            ds.residual.values,
            ds.steady_seconds.values,
            ds.eigen_seconds.values,
            strict=True,
        )
    ]
    columns = ("iterate", name, "growth rate λ", "frequency ω", "residual", "steady [s]", "eigen [s]")
    _print(
        _table(title, columns, rows),
        f"critical {name} = {p['critical_value']:.6f}, ω_c = {p['frequency']:.5f} "
        f"(Strouhal {ds.attrs['strouhal']:.5f}); {p['iterations']} iterates, "
        f"{p['factorisations']} factorisations; data {p['data']}; figure {p['figure']}",
    )


_STUDY_CASE = {k: v for k, v in CASE_OPTIONS.items() if k not in ("reynolds", "alpha0")}
_STUDY_LISTS = {"--Re": "reynolds", "--alpha0": "alpha0", "--thresholds": "thresholds"}


def _study_lists(args: list[str]) -> dict[str, list[float]]:
    """The space-separated values of ``--Re``, ``--alpha0`` and ``--thresholds`` (``--Re 100 500
    --alpha0 -4 0 4``), which click's options (one value each) cannot take; anything else left
    over is refused in one line."""
    lists: dict[str, list[float]] = {}
    current = None
    for token in args:
        name, _, inline = token.partition("=") if token.startswith("--") else (token, "", "")
        if token.startswith("--"):
            if name not in _STUDY_LISTS:
                raise InputError(f"no such option: {name}")
            current = _STUDY_LISTS[name]
            if current in lists:
                raise InputError(f"{name} given twice: give all its values after one {name}")
            lists[current] = []
            if not inline:
                continue
            token = inline
        if current is None:
            raise InputError(f"unexpected argument {token!r}: values go after --Re, --alpha0 or --thresholds")
        try:
            lists[current].append(float(token))
        except ValueError:
            option = next(k for k, v in _STUDY_LISTS.items() if v == current)
            raise InputError(f"{token!r} is not a number (after {option})") from None
    return lists


@command(
    _STUDY_CASE,
    OUTPUT_OPTIONS,
    FIGURE_OPTIONS,
    SOLID_OPTIONS,
    DOFS_OPTION,
    context_settings={"ignore_unknown_options": True, "allow_extra_args": True},
)
def study(
    opts,
    ctx: typer.Context,
    slopes: Annotated[
        bool, typer.Option("--slopes", help="steady C_L, C_M, C_D, recirculation length, static slopes")
    ] = False,
    modes: Annotated[bool, typer.Option("--modes", help="the fixed body's least stable eigenvalues")] = False,
    shift: Annotated[
        list[str] | None,
        typer.Option("--shift", help="eigenvalue guess of --modes, repeatable (cylinder default 0.75j)"),
    ] = None,
    n_modes: Annotated[int, typer.Option("--n-modes", help="eigenvalues kept per point")] = 4,
    velocity_range: VelocityRange = (2.0, 10.0),
    points: Points = 24,
    wake_shift: Annotated[
        str | None,
        typer.Option(
            "--wake-shift",
            help="shift near the wake mode: samples near its frequency, which the classification "
            "also tests (rule 2); VIV is recognised without it",
        ),
    ] = None,
    with_map: Annotated[
        bool, typer.Option("--map", help="the whole (m, U*) map at each point (plate)")
    ] = False,
    workers: Annotated[
        int | None, typer.Option("--workers", help="run on a new dask LocalCluster of N worker processes")
    ] = None,
    scheduler: Annotated[
        str | None, typer.Option("--scheduler", help="run on the dask scheduler at ADDRESS (tcp://host:8786)")
    ] = None,
):
    """A parameter study over flow points: --Re R1 R2 ... and --alpha0 A1 A2 ... (degrees; default
    0), and at each point --slopes, --modes, --thresholds M1 M2 ... (every threshold along U* at
    each mass ratio, classified: coupled-mode, pitch or heave single-mode flutter, divergence, VIV)
    and/or --map. Each point is one task: in this process by default, on a dask LocalCluster with
    --workers N, or on a running dask scheduler with --scheduler ADDRESS. Finished points are saved
    in OUT/points as they come: a rerun computes only what is missing. Exit status 1 when a point
    failed (the others are kept)."""
    from fsistab.study import StudySettings, check_execution, study_client

    lists = _study_lists(list(ctx.args))
    if "reynolds" not in lists:
        raise InputError("give the Reynolds numbers of the study: --Re R1 R2 ...")
    opts.alpha0 = 0.0
    opts.reynolds = lists["reynolds"][0] if lists["reynolds"] else 1.0
    wake = None if wake_shift is None else params.parse_complex("wake shift", wake_shift)
    settings = StudySettings(
        reynolds=tuple(lists["reynolds"]),
        alpha0=tuple(lists.get("alpha0", [0.0])),
        slopes=slopes,
        modes=modes,
        shifts=tuple(params.parse_complex("shift", z) for z in shift or ()),
        n_modes=n_modes,
        thresholds=tuple(lists.get("thresholds", ())),
        velocity_range=velocity_range,
        points=points,
        wake_shift=wake,
        map=with_map,
        freq_ratio=opts.freq_ratio,
        zeta_h=opts.zeta_h,
        zeta_theta=opts.zeta_theta,
        r_theta=opts.r_theta,
        dofs=None if opts.dofs is None else params.parse_dofs(opts.dofs, opts.body),
    )
    cases = [opts.case(reynolds=re) for re in settings.reynolds]  # one mesh per Re
    settings.check_body(cases[0].kind)
    check_execution(workers, scheduler)
    out, cache = _prepare(opts, cases)
    from fsistab import plots, workflows
    from fsistab.study import run_study

    with _running() as progress, study_client(workers, scheduler) as client:
        ds = run_study(cases[0], settings, cache, out, client=client, progress=progress)
    stem = Path(ds.attrs["data"]).with_suffix("")
    figures = []
    if (ds.status.values == "done").any():
        if slopes:
            figures.append(plots.plot_study_coefficients(ds, Path(f"{stem}_coefficients.png")))
        if modes or settings.thresholds:
            figures.append(plots.plot_study_thresholds(ds, Path(f"{stem}_thresholds.png")))
        if with_map:
            figures.append(plots.plot_study_maps(ds, Path(f"{stem}_maps.png")))
    ds.attrs["figures"] = json.dumps([str(f) for f in figures])
    p = workflows.payload("study", ds)
    if opts.as_json:
        _emit(p)
    else:
        _print(*_study_report(ds, p))
    if p["failed"]:
        raise typer.Exit(code=1)


def _study_report(ds, p: dict) -> list:
    import numpy as np

    rows = []
    for i, re in enumerate(ds.reynolds.values):
        for j, a in enumerate(ds.alpha0.values):
            row = [f"{re:g}", f"{a:g}", str(ds.status.values[i, j])]
            if "lift_coefficient" in ds:
                row += [f"{ds[name].values[i, j]:.4g}" for name in ("lift_coefficient", "moment_coefficient")]
            if "mode_growth_rate" in ds:
                rates, frequencies = ds.mode_growth_rate.values[i, j], ds.mode_frequency.values[i, j]
                lead = int(np.nanargmax(rates)) if np.isfinite(rates).any() else 0
                row.append(f"{rates[lead]:+.4g} {frequencies[lead]:+.4g}i")
            if "threshold_class" in ds:
                found = [
                    f"{c} U*={u:.4g}"
                    for c, u in zip(
                        ds.threshold_class.values[i, j].ravel(),
                        ds.threshold_reduced_velocity.values[i, j].ravel(),
                        strict=True,
                    )
                    if c
                ]
                row.append("; ".join(found) or "—")
            rows.append(tuple(row))
    columns = ["Re", "alpha0", "status"]
    if "lift_coefficient" in ds:
        columns += ["C_L", "C_M"]
    if "mode_growth_rate" in ds:
        columns.append("leading mode σ")
    if "threshold_class" in ds:
        columns.append("thresholds (all mass ratios)")
    lines = [_table(f"study: {ds.attrs['body']}, mesh {ds.attrs['preset']}", columns, rows)]
    for failure in p["failed"]:
        lines.append(f"FAILED Re {failure['reynolds']:g}, alpha0 {failure['alpha0']:g}: {failure['error']}")
    lines.append(
        f"{p['points']} points ({p['computed']} computed now, {len(p['failed'])} failed), "
        f"{p['factorisations']} factorisations, {p['seconds']:.1f} s ({ds.attrs['execution']}); "
        f"data {p['data']}"
    )
    return lines


@command(CASE_OPTIONS, OUTPUT_OPTIONS, FIGURE_OPTIONS, MASS_OPTION, SOLID_OPTIONS, DOFS_OPTION)
def sensitivity(
    opts,
    velocity_range: VelocityRange = (2.0, 10.0),
    points: Points = 24,
    wake_shift: Annotated[
        str | None,
        typer.Option(
            "--wake-shift",
            help="shift near the wake mode: samples near its frequency, and map the fixed body's",
        ),
    ] = None,
):
    """Every threshold along U* with its derivatives dU*_c/dp for p in Re, α0 (per degree), m, Ω,
    ζ_h, ζ_θ, r_θ (adjoint, implicit function theorem), and where a steady force or a small control
    cylinder moves each threshold most (maps: NetCDF, VTK, figure; docs/how-to/sensitivity.md)."""
    case, sweep, solid = _threshold_sweep(opts, velocity_range, points, wake_shift, "threshold sensitivities")
    from fsistab import umfpack, workflows

    if not umfpack.available():
        raise InputError("adjoint solves need UMFPACK's transposed solve, which this NGSolve wheel lacks")
    out, cache = _prepare(opts, [case])
    with _running() as progress:
        ds = workflows.sensitivity(case, solid, sweep, cache, out, progress)
    p = workflows.payload("sensitivity", ds)
    if opts.as_json:
        return _emit(p)
    names = [str(n) for n in ds.parameter.values]
    rows = [
        (t["kind"], f"{t['reduced_velocity']:.6g}", *(f"{t['derivatives'][n]:+.4g}" for n in names))
        for t in p["thresholds"]
    ]
    flow = case.flow
    mass = sweep.mass_ratio
    title = f"dU*_c/dp: {case.kind}, Re = {flow.reynolds:g}, α0 = {flow.alpha0_deg:g}°, m = {mass:g}"
    lines = [_table(title, ("kind", "U*_c", *names), rows)]
    for target, best in p["best_control"].items():
        gain = ", ".join(f"{k} {v:+.4g}" for k, v in best.items() if k not in ("x", "y"))
        where = f"X = {best['x']:.3g}, Y = {best['y']:.3g}"
        lines.append(f"{target}: a control cylinder helps most at {where} ({gain})")
    lines.append(f"{p['factorisations']} factorisations; data {p['data']}; maps {p['maps']}")
    _print(*lines)


BLAS_THREADS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def single_threaded_blas(environ: MutableMapping[str, str]) -> MutableMapping[str, str]:
    """``environ`` with BLAS set to one thread unless the user set any of :data:`BLAS_THREADS`
    (then all are left as they are: OpenBLAS reads its own variable before ``OMP_NUM_THREADS``,
    so setting one would override the user's choice). fsistab runs its own
    threads (two sparse factorisations at once, :func:`fsistab.linalg.sample_threads`); OpenBLAS's
    threads beside them made eight transfer samples on the default mesh 2.5 times slower (100 s
    against 40 s wall, docs/performance.md). Must run before NumPy and NGSolve load, which the
    commands import lazily."""
    if not any(variable in environ for variable in BLAS_THREADS):
        environ.update(dict.fromkeys(BLAS_THREADS, "1"))
    return environ


def main() -> None:  # pragma: no cover - console entry point (tested in a subprocess)
    single_threaded_blas(os.environ)
    app()


if __name__ == "__main__":  # pragma: no cover
    main()
