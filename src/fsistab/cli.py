"""Command line: thin typer commands over :mod:`fsistab.workflows`.

Every command parses its options, builds validated parameters (:mod:`fsistab.params`) before any
work, checks that the mesh fits the machine (:func:`fsistab.resources.check_fits`) and that
``--out`` and ``--cache`` are writable directories, then calls one workflow, has the outputs layer
write its figures (:mod:`fsistab.figures`) and prints its report (:mod:`fsistab.reports`), or with
``--json`` exactly one JSON object (:mod:`fsistab.payloads`) on stdout. Progress goes to stderr;
an interrupted run says what was saved. Bad input prints one line and exits with status 2. The
options are declared once in groups (``*_OPTIONS``) and added to each command by :func:`command`.
Imports of the numerical modules are lazy, so that ``--help`` and bad input answer at once.
"""

import contextlib
import inspect
import json
import logging
import os
import sys
from collections.abc import MutableMapping
from pathlib import Path
from types import SimpleNamespace
from typing import Annotated

import typer
import typer.core

from fsistab import params
from fsistab.cli_options import (
    CASE_OPTIONS,
    CRITICAL_OPTIONS,
    EXECUTION_OPTIONS,
    EXTRA_ARGS,
    FILES,
    FLOW_NEUTRAL_OPTIONS,
    LCO_OPTIONS,
    MAP_OPTIONS,
    MASS_OPTION,
    ONSET_OPTIONS,
    OUTPUT_OPTIONS,
    SENSITIVITY_OPTIONS,
    SIMULATE_OPTIONS,
    SLOPES_CASE,
    SOLID_OPTIONS,
    SPECTRUM_OPTIONS,
    SPRINGS,
    STUDY_CASE,
    STUDY_OPTIONS,
    THEODORSEN_CASE,
    THEODORSEN_OPTIONS,
    TRANSFER_OPTIONS,
    VELOCITY_OPTION,
)
from fsistab.errors import FsistabError, InputError
from fsistab.progress import BLAS_THREADS, one_line


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
        logger.addHandler(_PlainWarnings(level=logging.WARNING))
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


def _version(value: bool) -> None:
    if value:
        from fsistab import __version__

        sys.stdout.write(f"fsistab {__version__}\n")
        raise typer.Exit()


@app.callback()
def _main(
    version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True)] = False,
) -> None:
    """Global linear stability of spring-mounted bodies in viscous flow (fsistab)."""


# --- the shared options, declared once ------------------------------------------------------------


class Options(SimpleNamespace):
    """The raw values of a command's options, and the parameters they make."""

    def case(
        self, body: str | None = None, reynolds: float | None = None, elastic_axis: float | None = None
    ) -> params.Case:
        """The case; the section in the frame of ``--elastic-axis`` (docs/model.md §3.1) unless
        ``elastic_axis`` says otherwise."""
        body, reynolds = self.body if body is None else body, self.reynolds if reynolds is None else reynolds
        shape = (self.aspect_ratio, self.corner_radius, self.domain, self.sponge)
        outline = {name: getattr(self, name, None) for name in ("body_file", "reference_length")}
        outline["trailing_edge"] = getattr(self, "trailing_edge", "closed")
        mesh_reynolds = getattr(self, "mesh_reynolds", None)
        axis = getattr(self, "elastic_axis", 0.0) if elastic_axis is None else elastic_axis
        if axis and "pitch" not in params.body_type(body).allowed_dofs:
            raise InputError(f"the {body} does not pitch: it has no elastic axis")
        return params.Case.create(
            body,
            reynolds,
            self.alpha0,
            self.preset,
            *shape,
            **outline,
            mesh_reynolds=mesh_reynolds,
            elastic_axis=axis,
            mesh_sizes=getattr(self, "mesh_sizes", None),
            outlet=getattr(self, "outlet", "stress"),
        )

    def solid(self, kind: str, mass_ratio=None, reduced_velocity=None, dofs=None) -> params.Solid:
        mass = getattr(self, "mass_ratio", None) if mass_ratio is None else mass_ratio
        velocity = getattr(self, "reduced_velocity", None) if reduced_velocity is None else reduced_velocity
        dofs = params.parse_dofs(getattr(self, "dofs", None), kind) if dofs is None else dofs
        spring = (self.freq_ratio, self.zeta_h, self.zeta_theta, self.r_theta)
        typical = (getattr(self, "elastic_axis", 0.0), getattr(self, "static_unbalance", 0.0))
        return params.solid_for(kind, mass, velocity, *spring, dofs, *typical)


def command(*groups: dict, name: str | None = None, **settings):
    """Register ``func(opts)`` (or ``func(opts, ctx)``) as a command whose options are those of
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


def _figure_format(fmt: str | None):  # the figures of a command with --format: in that format
    if fmt is None:
        return contextlib.nullcontext()
    from fsistab import plots

    return plots.figure_format(fmt)


def _missing(path: Path) -> list[Path]:
    """``path`` and its ancestors that do not exist yet, deepest first."""
    path = Path(path).expanduser().absolute()
    return [p for p in (path, *path.parents) if not p.exists()]


def _writable_dirs(out: str, cache: str | None) -> tuple[Path, Path]:
    """Create and write-test ``--out`` and ``--cache`` (an empty path, the current folder, is
    refused); on a refusal remove what was created."""
    from fsistab.store import default_cache_dir, ensure_writable_dir

    for text, what in ((out, "--out"), (cache, "--cache")):
        if text is not None and not str(text).strip():
            raise InputError(f"{what} must name a directory, got an empty path")
    out, cache = Path(out), default_cache_dir() if cache is None else Path(cache)
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
    return out, cache


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


def _finish(name: str, ds, as_json: bool, report, *args) -> dict:
    """Print the command's JSON payload (``--json``) or its report (:mod:`fsistab.reports`)."""
    from rich.console import Console

    from fsistab.payloads import payload

    p = payload(name, ds)
    if as_json:
        sys.stdout.write(json.dumps(p, allow_nan=True) + "\n")
        return p
    console = Console()
    for item in report(ds, p, *args):
        console.print(item)
    return p


def _threshold_sweep(opts, what: str, method: str = "transfer"):
    """``(case, sweep, solid)`` of a command that finds every threshold along U* at one mass ratio
    (the body's default when ``--mass-ratio`` is not given); ``what`` names it in the error."""
    case = opts.case()
    mass = case.body.default_mass_ratio if opts.mass_ratio is None else opts.mass_ratio
    wake = None if opts.wake_shift is None else params.parse_complex("wake shift", opts.wake_shift)
    sweep = params.SweepSettings(opts.velocity_range, opts.points, wake, mass, method)
    solid = opts.solid(case.kind, reduced_velocity=sweep.velocity_range[0])
    if not solid.dofs:
        raise InputError(f"{what} need at least one solid degree of freedom (--dofs)")
    return case, sweep, solid


# --- commands -----------------------------------------------------------------------------------------


@command(CASE_OPTIONS, *FILES)
def mesh(opts):
    """Build (or reuse) a mesh; print its size and save a picture."""
    from fsistab import figures, reports, workflows

    case = opts.case()
    out, cache = _prepare(opts, [case])
    with _running() as progress:
        result = workflows.mesh_summary(case, cache, progress)
    _finish("mesh", figures.mesh(result, out), opts.as_json, reports.mesh)


@command(CASE_OPTIONS, *FILES)
def steady(opts):
    """Steady flow around the fixed body: coefficients, recirculation length, Newton history."""
    from fsistab import figures, reports, workflows

    case = opts.case()
    out, cache = _prepare(opts, [case])
    with _running() as progress:
        result = workflows.steady_flow(case, cache, progress)
    _finish("steady", figures.steady(result, case.tag, out), opts.as_json, reports.steady)


@command(CASE_OPTIONS, *FILES, MASS_OPTION, VELOCITY_OPTION, *SPRINGS, SPECTRUM_OPTIONS)
def spectrum(opts):
    """Eigenvalues of the coupled fluid–solid system nearest the given shifts (docs/model.md §7),
    and how many are unstable."""
    case = opts.case()
    solid = opts.solid(case.kind)
    shifts = case.body.spectrum_shifts
    if opts.shift is not None:
        shifts = tuple(params.parse_complex("shift", z) for z in opts.shift)
    settings = params.SpectrumSettings(shifts, opts.n_eigenvalues, opts.vtk, opts.mode_figures, opts.phase)
    out, cache = _prepare(opts, [case])
    from fsistab import figures, reports, workflows

    with _running() as progress:
        result = workflows.spectrum(case, solid, settings, cache, out, progress)
        ds = figures.spectrum(result, case.tag, settings, out, progress)
    _finish("spectrum", ds, opts.as_json, reports.spectrum)


@command(SLOPES_CASE, *FILES)
def slopes(
    opts,
    reynolds: Annotated[list[float], typer.Option("--Re", help="Reynolds numbers: --Re 10 100 1000")],
    more_reynolds: Annotated[
        list[float] | None, typer.Argument(help="further Reynolds numbers", show_default=False)
    ] = None,
):
    """Static slopes dC_L/dα and d(-C_M)/dα of the plate against Re (docs/model.md §9)."""
    opts.body = "plate"
    values = sorted({*reynolds, *(more_reynolds or [])})
    if len(values) > params.MAX_SWEEP_POINTS:
        raise InputError(f"at most {params.MAX_SWEEP_POINTS} Reynolds numbers, got {len(values)}")
    cases = [opts.case(reynolds=re) for re in values]  # every value validated before any work
    out, cache = _prepare(opts, cases)
    from fsistab import figures, reports, workflows

    with _running() as progress:
        ds = workflows.static_slopes_study(cases, cache, out, progress)
    _finish("slopes", figures.slopes(ds, out), opts.as_json, reports.slopes)


def _check_sample_execution(opts, method: str) -> None:
    """``--workers``/``--scheduler`` of a command whose transfer method spreads its samples on dask
    (``critical``, ``neutral``): well formed, and only with ``--method transfer``."""
    from fsistab.study import check_execution

    check_execution(opts.workers, opts.scheduler)
    if method != "transfer" and (opts.workers is not None or opts.scheduler is not None):
        raise InputError("--workers and --scheduler spread the samples of --method transfer only")


@command(CASE_OPTIONS, *FILES, MASS_OPTION, *SPRINGS, CRITICAL_OPTIONS, EXECUTION_OPTIONS)
def critical(opts):
    """Every instability threshold along U* at one mass ratio (docs/model.md §8): by default the
    exact transfer function swept in frequency, each crossing converged by Newton on det T(iω; U*),
    and divergence from G(0); --method tracking follows eigenvalue branches over --points values.
    --workers N or --scheduler ADDRESS: the sweep's samples are factorised on dask workers, the
    same thresholds (--method transfer; docs/how-to/cluster.md).
    Writes the thresholds (NetCDF) and their figure in --out."""
    from fsistab.study import study_client

    case, sweep, solid = _threshold_sweep(opts, "critical points", opts.method)
    _check_sample_execution(opts, opts.method)
    out, cache = _prepare(opts, [case])
    from fsistab import figures, reports, workflows

    with _running() as progress, study_client(opts.workers, opts.scheduler) as client:
        ds = workflows.critical_points(case, solid, sweep, cache, out, progress, client=client)
    _finish("critical", figures.critical(ds), opts.as_json, reports.critical)


@command(CASE_OPTIONS, *FILES, SOLID_OPTIONS, MAP_OPTIONS, EXECUTION_OPTIONS)
def neutral(opts):
    """Stability map in the (m, U*) plane (docs/model.md §8): flutter and VIV neutral curves, the
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

    --workers N (a dask LocalCluster) or --scheduler ADDRESS (a running dask scheduler): the exact
    samples of each refinement round are factorised on the workers, the same samples and the same
    map as in this process (--method transfer; docs/how-to/cluster.md).

    Rerunning the same command resumes."""
    from fsistab.study import study_client

    case = opts.case()
    case.require_plate("neutral maps")
    names = [name for name in MAP_OPTIONS if name != "seed_masses"]
    seeds = None if opts.seed_masses is None else tuple(opts.seed_masses)
    settings = params.MapSettings(seed_masses=seeds, **{name: getattr(opts, name) for name in names})
    template = opts.solid("plate", settings.template_mass, settings.velocity_range[0], ("heave", "pitch"))
    _check_sample_execution(opts, settings.method)
    out, cache = _prepare(opts, [case])
    from fsistab import figures, reports, workflows

    with _running() as progress, study_client(opts.workers, opts.scheduler) as client:
        ds = workflows.stability_map(case, template, settings, cache, out, progress, client=client)
    ds = figures.stability_map(ds, case, out)
    _finish("neutral", ds, opts.as_json, reports.stability_map, settings.mass_range, out)


@command(CASE_OPTIONS, *FILES, MASS_OPTION, SOLID_OPTIONS, FLOW_NEUTRAL_OPTIONS, name="flow-neutral")
def flow_neutral(opts):
    """Neutral curves in the (Re, U*) or (alpha0, U*) plane at one mass ratio, by pseudo-arclength
    continuation through turning points (docs/model.md §8), from the flutter thresholds of a sweep
    in U* at --Re/--alpha0. One mesh (fitted to --Re, or to --mesh-reynolds) for the whole curve;
    steady states are cached."""
    case = opts.case()
    case.require_plate("flow-parameter neutral curves")
    start = opts.reynolds if opts.parameter == "reynolds" else opts.alpha0
    settings = params.FlowNeutralSettings(
        opts.parameter, opts.parameter_range, start, opts.velocity_range, opts.points, opts.max_points
    )
    solid = opts.solid("plate", reduced_velocity=settings.velocity_range[0], dofs=("heave", "pitch"))
    out, cache = _prepare(opts, [case])
    from fsistab import figures, reports, workflows

    with _running() as progress:
        ds = workflows.flow_neutral_curves(case, solid, settings, cache, out, progress)
    _finish("flow-neutral", figures.flow_neutral(ds, case, out), opts.as_json, reports.flow_neutral, out)


@command(THEODORSEN_OPTIONS, THEODORSEN_CASE, *FILES)
def theodorsen(opts):
    """Analytic typical section with Theodorsen aerodynamics (docs/model.md §9): every flutter
    boundary (real roots of the 2×2 determinant) and the divergence along U* at one mass ratio, or
    the neutral curves U*(m) with --mass-ratio-range (compared with the last map of `fsistab
    neutral` for the same section, Re and alpha0 with the same --cache, by either method). The
    section (--body, --body-file), --Re, --alpha0 and --mesh matter for --slopes calibrated only
    (and for finding the viscous map)."""
    case = opts.case(elastic_axis=0.0)  # calibrated slopes about mid-chord, moved to the axis by the model
    if "pitch" not in case.body.allowed_dofs:
        raise InputError(f"the {case.kind} does not pitch: the typical section needs a pitching section")
    names = ("mass_ratio", "mass_range", "points", "velocity_range", "slopes", "lift_slope_alpha")
    names += ("moment_slope_alpha", "elastic_axis", "static_unbalance")
    settings = params.TheodorsenSettings(*(getattr(opts, name) for name in names))
    from fsistab import figures, reports, workflows

    solid = opts.solid("plate", opts.mass_ratio, dofs=("heave", "pitch"))
    section = workflows.typical_section(solid, settings)
    out, cache = _prepare(opts, [case] if settings.slopes == "calibrated" else [])
    with _running() as progress:
        ds = workflows.theodorsen(section, settings, case, cache, out, progress)
    if settings.mass_range is None:
        _finish("theodorsen-points", ds, opts.as_json, reports.theodorsen_points)
    else:
        _finish(
            "theodorsen-map",
            figures.theodorsen(ds),
            opts.as_json,
            reports.theodorsen_map,
            settings.mass_range,
        )


@command(CASE_OPTIONS, *FILES, TRANSFER_OPTIONS)
def transfer(opts):
    """Viscous Theodorsen function: the body's load transfer G(ik) against Theodorsen's model."""
    case = opts.case()
    settings = params.TransferSettings(opts.k_range, opts.points)
    out, cache = _prepare(opts, [case])
    from fsistab import figures, reports, workflows

    with _running() as progress:
        ds = workflows.transfer_function(case, settings, cache, out, progress)
    _finish("transfer", figures.transfer(ds, case.tag, case.preset, out), opts.as_json, reports.transfer)


@command(CASE_OPTIONS, OUTPUT_OPTIONS, ONSET_OPTIONS)
def onset(opts):
    """Critical Reynolds number (at --alpha0) or critical alpha0 (at --Re) of the FIXED body: the
    value where its leading global mode's growth rate vanishes, by the secant method on the growth
    rate, the steady state continued and the eigenvalue followed from iterate to iterate
    (fsistab.onset). One mesh for every iterate: fitted to --mesh-reynolds if given, else to --guess
    for the critical Re (--Re is then unused) and to --Re for the critical alpha0. Steady states are
    cached: a rerun reuses them."""
    from fsistab.onset import check_onset, fitted_case

    case, parameter = opts.case(), opts.parameter
    value = None if opts.shift is None else params.parse_complex("shift", opts.shift)
    guess, value = check_onset(case.kind, parameter, opts.guess, value)
    out, cache = _prepare(opts, [fitted_case(case, parameter, guess)])
    from fsistab import figures, reports, workflows

    with _running() as progress:
        ds = workflows.fixed_body_onset(case, parameter, guess, value, cache, out, progress)
    _finish("onset", figures.onset(ds), opts.as_json, reports.onset, figures.onset_title(ds))


@command(STUDY_CASE, *FILES, *SPRINGS, STUDY_OPTIONS, context_settings=EXTRA_ARGS)
def study(opts, ctx: typer.Context):
    """A parameter study over flow points: --Re R1 R2 ... and --alpha0 A1 A2 ... (degrees; default
    0), and at each point --slopes, --modes, --thresholds M1 M2 ... (every threshold along U* at
    each mass ratio, classified: coupled-mode, pitch or heave single-mode flutter, divergence, VIV)
    and/or --map. Each point is one task: in this process by default, on a dask LocalCluster with
    --workers N, or on a running dask scheduler with --scheduler ADDRESS. Each Re gets a mesh fitted
    to it, unless --mesh-reynolds RE holds one mesh (fitted to RE) for every point: then the results
    vary smoothly with Re (no change of mesh between points). Finished points are saved in OUT/points
    as they come: a rerun computes only what is missing. Exit status 1 when a point failed (the
    others are kept)."""
    from fsistab.study import StudySettings, check_execution, study_client, study_lists

    lists = study_lists(list(ctx.args))
    if "reynolds" not in lists:
        raise InputError("give the Reynolds numbers of the study: --Re R1 R2 ...")
    opts.alpha0 = 0.0
    opts.reynolds = lists["reynolds"][0] if lists["reynolds"] else 1.0
    settings = StudySettings.from_options(lists, vars(opts))
    cases = [opts.case(reynolds=re) for re in settings.reynolds]  # one mesh per Re, or --mesh-reynolds
    settings.check_body(cases[0].kind)
    check_execution(opts.workers, opts.scheduler)
    out, cache = _prepare(opts, cases)
    from fsistab import figures, reports
    from fsistab.study import run_study

    with _running() as progress, study_client(opts.workers, opts.scheduler) as client:
        ds = run_study(cases[0], settings, cache, out, client=client, progress=progress)
    p = _finish("study", figures.study(ds, settings), opts.as_json, reports.study)
    if p["failed"]:
        raise typer.Exit(code=1)


@command(CASE_OPTIONS, *FILES, MASS_OPTION, *SPRINGS, SENSITIVITY_OPTIONS)
def sensitivity(opts):
    """Every threshold along U* with its derivatives dU*_c/dp for p in Re, α0 (per degree), m, Ω,
    ζ_h, ζ_θ, r_θ (adjoint, implicit function theorem), and where a steady force or a small control
    cylinder moves each threshold most (maps: NetCDF, VTK, figure; docs/how-to/sensitivity.md)."""
    case, sweep, solid = _threshold_sweep(opts, "threshold sensitivities")
    from fsistab import figures, reports, umfpack, workflows

    if not umfpack.available():
        raise InputError("adjoint solves need UMFPACK's transposed solve, which this NGSolve wheel lacks")
    out, cache = _prepare(opts, [case])
    with _running() as progress:
        result = workflows.sensitivity(case, solid, sweep, cache, out, progress)
        ds = figures.sensitivity(result, progress)
    _finish("sensitivity", ds, opts.as_json, reports.sensitivity)


@command(CASE_OPTIONS, OUTPUT_OPTIONS, MASS_OPTION, VELOCITY_OPTION, *SPRINGS, SIMULATE_OPTIONS)
def simulate(opts):
    """March the nonlinear Navier–Stokes equations in the body frame coupled with heave and pitch
    (docs/model.md §12): BDF2, monolithic, from the steady state plus --perturbation times the
    eigenmode nearest --shift (or from --start). Writes the time series of h, θ, their rates and the
    load coefficients (NetCDF); checkpoints so that rerunning the same command resumes (also with a
    longer --duration). With --animation, an animation of the vorticity near the body, one frame
    per snapshot of the steps marched in this run."""
    case = opts.case()
    solid = opts.solid(case.kind)
    shift = None if opts.shift is None else params.parse_complex("shift", opts.shift)
    names = ("duration", "time_step", "perturbation", "perturbation_of", "start", "checkpoint_every")
    names += ("snapshot_interval", "tolerance", "max_iterations")
    settings = params.SimulationSettings(shift=shift, **{name: getattr(opts, name) for name in names})
    settings.check_dofs(solid)
    if settings.start is not None and not Path(settings.start).is_file():
        raise InputError(f"--start: no such file {settings.start}")
    if opts.animation is not None:
        from fsistab import animation

        animation.check_animation(opts.animation, settings.snapshot_interval)
    out, cache = _prepare(opts, [case])
    from fsistab import reports, vtk, workflows

    write, paths = vtk.snapshot_writer(out / f"simulate_{case.tag}_vtk", f"simulate_{case.tag}")
    frames = None if opts.animation is None else animation.VorticityRecorder()
    snapshot = write if frames is None else animation.chain(write, frames)
    with _running() as progress:
        result = workflows.simulate(case, solid, settings, cache, out, progress, snapshot=snapshot)
    ds = result.dataset.assign_attrs(snapshots=json.dumps(paths))
    if frames is not None:
        target = animation.animation_path(out, case.tag, opts.animation)
        written = animation.write_vorticity_animation(frames, result.dataset, target)
        count = len(frames.frames)
        ds = ds.assign_attrs(animation="" if written is None else str(written), animation_frames=count)
    _finish("simulate", ds, opts.as_json, reports.simulate)


@command(CASE_OPTIONS, *FILES, MASS_OPTION, *SPRINGS, LCO_OPTIONS)
def lco(opts):
    """Limit-cycle amplitudes past the threshold: one nonlinear march (as `fsistab simulate`) at each
    of --points U* over --reduced-velocity-range, the saturated amplitude and frequency of h and θ
    from their last --periods periods (saturated when the envelope changes by less than
    --saturation-tolerance per period; from the perturbed steady state also only once it has left
    the start mode's linear transient; modulated when over the march's second half the envelope
    rises and falls by more, with the range of its period amplitudes), the bifurcation diagram
    with the linear onsets of the same mesh, and whether the onset is supercritical (A² linear in
    U* − U*_c) or subcritical (--hysteresis: a sweep by decreasing U*, each march from the last
    state of the one above). Each march is one task: in this process by default, on a dask
    LocalCluster with --workers N or a scheduler with --scheduler; finished marches are kept in
    OUT/lco_points and rerunning resumes. Exit status 1 when a march of either sweep failed."""
    from fsistab.study import check_execution, study_client

    case = opts.case()
    mass = case.body.default_mass_ratio if opts.mass_ratio is None else opts.mass_ratio
    solid = opts.solid(case.kind, mass_ratio=mass, reduced_velocity=opts.velocity_range[0])
    shift = None if opts.shift is None else params.parse_complex("shift", opts.shift)
    names = (
        "duration",
        "time_step",
        "perturbation",
        "perturbation_of",
        "start",
        "checkpoint_every",
        "tolerance",
        "max_iterations",
    )
    simulation = params.SimulationSettings(shift=shift, **{name: getattr(opts, name) for name in names})
    simulation.check_dofs(solid)
    settings = params.LcoSettings(
        opts.velocity_range, opts.points, simulation, opts.periods, opts.saturation_tolerance, opts.hysteresis
    )
    if simulation.start is not None and not Path(simulation.start).is_file():
        raise InputError(f"--start: no such file {simulation.start}")
    check_execution(opts.workers, opts.scheduler)
    from fsistab.lco import limit_cycles, threshold_sweep

    if opts.thresholds:
        threshold_sweep(settings, mass)  # the thresholds' search refuses bad input now, not after the marches
    out, cache = _prepare(opts, [case])
    from fsistab import figures, reports

    with _running() as progress, study_client(opts.workers, opts.scheduler) as client:
        ds = limit_cycles(
            case,
            solid,
            settings,
            mass,
            cache,
            out,
            client=client,
            progress=progress,
            thresholds=opts.thresholds,
        )
    p = _finish("lco", figures.lco(ds), opts.as_json, reports.lco)
    if p["failed"]:
        raise typer.Exit(code=1)


def single_threaded_blas(environ: MutableMapping[str, str]) -> MutableMapping[str, str]:
    """``environ`` with BLAS on one thread unless the user set one of the BLAS_THREADS variables
    (then all are left as they are: OpenBLAS reads its own variable before ``OMP_NUM_THREADS``).
    fsistab runs its own threads (two sparse factorisations at once,
    :func:`fsistab.linalg.sample_threads`), which BLAS threads beside them would slow down
    (docs/performance.md). Must run before NumPy and NGSolve load (the commands import lazily)."""
    if not any(variable in environ for variable in BLAS_THREADS):
        environ.update(dict.fromkeys(BLAS_THREADS, "1"))
    return environ


def main() -> None:  # pragma: no cover - console entry point (tested in a subprocess)
    single_threaded_blas(os.environ)
    os.environ.setdefault("MPLBACKEND", "Agg")  # the commands write figures to files, never to a window
    app()


if __name__ == "__main__":  # pragma: no cover
    main()
