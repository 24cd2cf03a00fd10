"""Workflows: one function per command-line command, the whole computation behind it.

Each takes validated parameter objects (:mod:`fsistab.params`), a cache directory, the output
directory where it writes its data (NetCDF, written atomically by :mod:`fsistab.store`) and a
``progress`` callback taking one message string. Each returns an :class:`xarray.Dataset` holding
the results with their units and conventions in attributes, or, where the figures need the fields
themselves (the mesh, the steady state, the modes, the sensitivity maps), a small result holding
that Dataset and those fields. Nothing here draws, prints or makes JSON: the outputs layer does,
from what is returned (:mod:`fsistab.figures`, :mod:`fsistab.payloads`, :mod:`fsistab.reports`).
No workflow reads a file of ``out`` as its input: a result one workflow needs from another is
passed, or read from the cache (:func:`stored_map_path`).

Lengths, times and coefficients follow the body's conventions (docs/model.md §1, §10): chord-based
for the plate, diameter-based for the cylinder (where U* = 2πU∞/(Dω_n), docs/model.md §10).
"""

from __future__ import annotations

import functools
import inspect
import json
import math
from collections import deque
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import NamedTuple

import numpy as np
import xarray as xr

from fsistab.errors import InputError
from fsistab.params import (
    Case,
    FlowNeutralSettings,
    MapSettings,
    Solid,
    SpectrumSettings,
    SweepSettings,
    TheodorsenSettings,
    TransferSettings,
    body_velocity_scale,
)
from fsistab.progress import Progress, running


def _workflow(function):
    """Run a workflow inside :func:`fsistab.progress.running`, as the command line does: BLAS on one
    thread unless the user chose, and its progress to the caller's callback or, called from Python
    without one, to the logger ``fsistab`` (:func:`fsistab.show_progress`)."""
    signature = inspect.signature(function)

    @functools.wraps(function)
    def run(*args, **kwargs):
        bound = signature.bind(*args, **kwargs)
        bound.apply_defaults()
        with running(bound.arguments["progress"]) as say:
            bound.arguments["progress"] = say
            return function(*bound.args, **bound.kwargs)

    return run


def _mesh_spec(case: Case):
    from fsistab.mesh import spec_for

    return spec_for(case)


def _fluid(case: Case, cache_dir: Path, say: Callable[[str], None]):
    """Steady state (cached) and its linear operators (docs/model.md §6, §7)."""
    from fsistab.operators import fluid_operators
    from fsistab.steady import solve_steady

    say(f"steady state: {case.kind}, Re = {case.flow.reynolds:g}, alpha0 = {case.flow.alpha0_deg:g} deg")
    steady = solve_steady(_mesh_spec(case), case.flow, cache_dir=cache_dir, progress=say)
    say("fluid operators")
    return steady, fluid_operators(steady)


def _divergence_velocity(moment_slope, r_theta, mass_ratio):
    """``U*_D = √(m r_θ²/(dC_M/dθ))`` (docs/model.md §8), inf where there is no divergence."""
    from fsistab.neutral_point import divergence_velocity

    return divergence_velocity(moment_slope, r_theta, mass_ratio)


# --- mesh and steady flow --------------------------------------------------------------------------


class MeshResult(NamedTuple):
    """The mesh's size (attributes of ``dataset``) and the mesh itself, to be drawn."""

    dataset: xr.Dataset
    mesh: object


@_workflow
def mesh_summary(case: Case, cache_dir: Path, progress: Progress = None) -> MeshResult:
    """Build (or read from the cache) the case's mesh; its size in the dataset's attributes."""
    from fsistab.mesh import build_mesh, mesh_statistics

    say = progress
    spec = _mesh_spec(case)
    say(f"mesh: {case.kind}, preset {case.preset}")
    mesh = build_mesh(spec, cache_dir)
    stats = mesh_statistics(mesh)
    attrs = {
        **stats,
        "body": case.kind,
        "reynolds": case.flow.reynolds,
        "preset": case.preset,
        "mesh_reynolds": case.fitted_reynolds,
        "mesh_key": spec.key(),
        "mesh_tag": case.mesh_tag,
    }
    return MeshResult(xr.Dataset(attrs=attrs), mesh)


class SteadyResult(NamedTuple):
    """The steady flow's numbers (``dataset``) and the steady state itself, to be drawn."""

    dataset: xr.Dataset
    steady: object


@_workflow
def steady_flow(case: Case, cache_dir: Path, progress: Progress = None) -> SteadyResult:
    """Steady flow around the fixed body (docs/model.md §6): coefficients (docs/model.md §5 conventions),
    recirculation length, Newton history and continuation path, and the steady state to be drawn."""
    from fsistab.forces import aerodynamic_coefficients, recirculation_length
    from fsistab.steady import solve_steady

    say = progress
    say("steady Navier–Stokes (Newton, continuation in Re)")
    result = solve_steady(_mesh_spec(case), case.flow, cache_dir=cache_dir, progress=say)
    coefficients = aerodynamic_coefficients(result)
    path = np.array(result.path, dtype=float).reshape(-1, 3)
    ds = xr.Dataset(
        {
            "newton_residual": ("iteration", np.array(result.history, dtype=float)),
            "path_reynolds": ("step", path[:, 0]),
            "path_alpha0_deg": ("step", path[:, 1]),
            "path_iterations": ("step", path[:, 2].astype(int)),
        },
        attrs={
            "body": case.kind,
            "reynolds": result.flow.reynolds,
            "alpha0_deg": result.flow.alpha0_deg,
            "mesh_reynolds": case.fitted_reynolds,
            "outlet": case.outlet,
            "lift_coefficient": coefficients.lift,
            "moment_coefficient": coefficients.moment,
            "drag_coefficient": coefficients.drag,
            "recirculation_length": recirculation_length(result),
            "ndof": result.ndof,
            "newton_iterations": result.newton_iterations,
            "factorisations": result.factorisations,
            "from_cache": int(result.from_cache),
            "seconds": result.seconds,
            "conventions": "coefficients F/(0.5 rho U^2 L s); C_M about G, counter-clockwise +",
        },
    )
    return SteadyResult(ds, result)


# --- eigenvalues -----------------------------------------------------------------------------------


class SpectrumResult(NamedTuple):
    """The eigenvalues (``dataset``) and what their figures are drawn from: the steady state, the
    coupled system and its eigenpairs, least stable first."""

    dataset: xr.Dataset
    steady: object
    system: object
    pairs: list


@_workflow
def spectrum(
    case: Case,
    solid: Solid,
    settings: SpectrumSettings,
    cache_dir: Path,
    out: Path,
    progress: Progress = None,
) -> SpectrumResult:
    """Eigenvalues of the coupled system nearest the shifts (docs/model.md §7), saved as
    ``spectrum_{tag}.nc`` in ``out``; the number of unstable eigenvalues in attribute
    ``unstable``."""
    from fsistab.coupled import CoupledSystem
    from fsistab.eigen import eigenpairs_near, spectrum_dataset
    from fsistab.store import write_dataset

    say = progress
    steady, fluid = _fluid(case, cache_dir, say)
    system = CoupledSystem(fluid, solid)
    say(f"shift-invert Arnoldi near {len(settings.shifts)} shift(s), {system.size} unknowns")
    pairs = eigenpairs_near(system, list(settings.shifts), settings.n_eigenvalues)
    shifts = json.dumps([[z.real, z.imag] for z in settings.shifts])
    ds = spectrum_dataset(pairs, system, {"shifts": shifts})
    data_path = write_dataset(ds, Path(out) / f"spectrum_{case.tag}.nc")
    ds = ds.assign_attrs(
        netcdf=str(data_path),
        dofs=",".join(solid.dofs) or "none",
        unstable=int((ds.growth_rate.values > 0).sum()),
        mesh_reynolds=case.fitted_reynolds,
    )
    return SpectrumResult(ds, steady, system, pairs)


@_workflow
def static_slopes_study(
    cases: list[Case], cache_dir: Path, out: Path, progress: Progress = None
) -> xr.Dataset:
    """Static slopes ``dC_L/dα``, ``d(-C_M)/dα`` (per radian, α = -θ, about mid-chord, docs/model.md §9)
    of the plate at each case's Re (same α0, preset and mesh Re), saved as
    ``slopes_plate_a{α0}_{preset}.nc`` (``_meshRe{Re}`` added when the cases share a held mesh)."""
    from fsistab.slopes import THIN_AIRFOIL_LIFT_SLOPE, THIN_AIRFOIL_MOMENT_SLOPE, static_slopes
    from fsistab.store import write_dataset

    say = progress
    results = []
    for case in cases:
        say(f"Re = {case.flow.reynolds:g}: steady state and one linear solve")
        _, fluid = _fluid(case, cache_dir, lambda message: None)
        results.append(static_slopes(fluid))
    first = cases[0]
    ds = xr.Dataset(
        {
            "lift_slope_alpha": ("reynolds", np.array([r.lift_slope_alpha for r in results])),
            "moment_slope_alpha": ("reynolds", np.array([r.moment_slope_alpha for r in results])),
            "drag_slope_theta": ("reynolds", np.array([r.drag for r in results])),
        },
        coords={"reynolds": np.array([c.flow.reynolds for c in cases])},
        attrs={
            "alpha0_deg": first.flow.alpha0_deg,
            "mesh": first.preset,
            "convention": "dC_L/dalpha and d(-C_M)/dalpha per radian, alpha = -theta, moment about mid-chord",
            "thin_airfoil_lift_slope": THIN_AIRFOIL_LIFT_SLOPE,
            "thin_airfoil_moment_slope": THIN_AIRFOIL_MOMENT_SLOPE,
        },
    )
    name = f"slopes_plate_a{first.flow.alpha0_deg:g}_{first.preset}"
    if first.mesh_reynolds is not None:  # one mesh for every Re
        ds.attrs["mesh_reynolds"] = first.mesh_reynolds
        name += f"_meshRe{first.mesh_reynolds:g}"
    name += first.mesh_tag
    return ds.assign_attrs(netcdf=str(write_dataset(ds, Path(out) / f"{name}.nc")))


# --- thresholds along U* ---------------------------------------------------------------------------


def _threshold_sweep(case: Case, solid: Solid, sweep: SweepSettings):
    """``(scale, velocities, solid, counter)`` of a search for every threshold along U*: the sweep
    in the generic U* (the body's divided by ``scale``, docs/model.md §10), the solid at its first
    value and a factorisation counter."""
    from fsistab.linalg import FactorCounter

    scale = body_velocity_scale(case.kind)
    velocities = np.geomspace(*sweep.velocity_range, sweep.points) / scale
    return scale, velocities, replace(solid, reduced_velocity=float(velocities[0])), FactorCounter()


def _sweep_attrs(case: Case, sweep: SweepSettings, counter) -> dict:
    """The attributes a threshold sweep's datasets share: the case, the sweep and its factorisations."""
    return {
        "body": case.kind,
        "reynolds": case.flow.reynolds,
        "alpha0_deg": case.flow.alpha0_deg,
        "preset": case.preset,
        "mesh_reynolds": case.fitted_reynolds,
        "mass_ratio": sweep.mass_ratio,
        "velocity_range": list(sweep.velocity_range),
        "points": sweep.points,
        "factorisations": counter.count,
    }


@_workflow
def critical_points(
    case: Case,
    solid: Solid,
    sweep: SweepSettings,
    cache_dir: Path,
    out: Path | None = None,
    progress: Progress = None,
    client=None,
) -> xr.Dataset:
    """Every threshold along U* at one mass ratio (docs/model.md §8) over the sweep's range: the exact
    transfer function swept in frequency, each crossing converged by Newton on ``det T``,
    divergence from ``G(0)`` (:func:`fsistab.critical.find_thresholds`). U* in the body's
    convention (×2π for the cylinder, docs/model.md §10); ``frequency_ratio`` is ``ω_c/ω_n`` (over the
    solid's natural frequency: ω_θ of the plate, ω_h of the cylinder). What the
    search did in attributes: ``frequencies_sampled`` (transfer) or ``branches_tracked`` over
    ``points`` values of U* (tracking). Saved as ``critical_{tag}_m{m}_{preset}.nc`` in ``out``
    (when given), its path in attribute ``netcdf``. ``client``: a ``dask.distributed`` client whose
    workers factorise the frequency sweep's samples (:mod:`fsistab.map_distributed`), the same
    thresholds."""
    from fsistab.critical import find_thresholds
    from fsistab.store import write_dataset

    say = progress
    scale, velocities, solid, counter = _threshold_sweep(case, solid, sweep)
    _, fluid = _fluid(case, cache_dir, say)
    thresholds, details = find_thresholds(
        fluid,
        solid,
        velocities,
        wake_shift=sweep.wake_shift,
        counter=counter,
        progress=say,
        method=sweep.method,
        client=client,
    )
    velocity = np.array([t.reduced_velocity * scale for t in thresholds])
    frequency = np.array([t.frequency for t in thresholds])
    ds = xr.Dataset(
        {
            "kind": ("threshold", np.array([t.kind for t in thresholds], dtype=str)),
            "boundary": ("threshold", np.array([t.boundary for t in thresholds], dtype=str)),
            "reduced_velocity": ("threshold", velocity),
            "frequency": ("threshold", frequency),
            # ω_c/ω_n = ω_c U*_c in the generic convention (time unit L/U)
            "frequency_ratio": ("threshold", frequency * velocity / scale),
        },
        attrs={
            **_sweep_attrs(case, sweep, counter),
            "method": sweep.method,
            "frequencies_sampled": len(details.get("frequencies", ())),
            "branches_tracked": len(details.get("branches", ())),
            "unresolved_intervals": len(details.get("unresolved", ())),
            "conventions": "U* and m in the body's conventions (docs/model.md §2, §10); frequency in U/L",
        },
    )
    if out is None:
        return ds
    path = write_dataset(ds, Path(out) / f"critical_{case.tag}_m{sweep.mass_ratio:g}_{case.preset}.nc")
    return ds.assign_attrs(netcdf=str(path))


# --- stability map in (m, U*) ----------------------------------------------------------------------


def _solid_attrs(case: Case, solid: Solid) -> dict:
    """What a saved curve or map depends on besides its own parameters (checked on reuse)."""
    return {
        "reynolds": case.flow.reynolds,
        "alpha0_deg": case.flow.alpha0_deg,
        **_mesh_spec(case).linear_identity(),
        "freq_ratio": solid.freq_ratio,
        "zeta_h": solid.zeta_h,
        "zeta_theta": solid.zeta_theta,
        "r_theta": solid.r_theta,
        "elastic_axis": solid.elastic_axis,
        "static_unbalance": solid.static_unbalance,
    }


def _trace_map(case, template, settings, fluid, out, attrs, reduced, counter, say, client=None):
    """The map by the chosen method; ``(NeutralMap, TransferMap or None)``; the transfer map's
    exact samples on the workers of ``client`` if given."""
    from fsistab.neutral import map_seeds, trace_neutral_map
    from fsistab.transfer_map import as_neutral_map, transfer_neutral_map

    wake = attrs["wake_frequency"]
    wake = None if not math.isfinite(wake) else wake
    if settings.method == "continuation":
        seeds = map_seeds(
            settings.template_mass,
            settings.velocity_range,
            settings.points,
            list(settings.seeds),
            wake,
            settings.mass_range[0],
            template.freq_ratio,
        )
        result = trace_neutral_map(
            fluid,
            template,
            seeds,
            out,
            case.tag,
            _solid_attrs(case, template),
            mass_range=settings.mass_range,
            max_points=settings.max_points,
            counter=counter,
            progress=say,
        )
        return result, None
    tmap = transfer_neutral_map(
        fluid,
        template,
        mass_range=settings.mass_range,
        omega_range=settings.frequency_range,  # None: the default range, followed down
        wake_frequency=wake,
        tolerance=settings.tolerance,
        min_step=settings.min_step,
        max_samples=settings.max_frequencies,
        samples_path=out / f"transfer_{case.tag}_samples.nc",
        reduced=reduced,
        counter=counter,
        progress=say,
        client=client,
    )
    return as_neutral_map(tmap, template), tmap


@_workflow
def stability_map(
    case: Case,
    template: Solid,
    settings: MapSettings,
    cache_dir: Path,
    out: Path,
    progress: Progress = None,
    client=None,
) -> xr.Dataset:
    """The stability map of the plate in ``(m, U*)`` (docs/model.md §8): flutter and VIV neutral curves,
    the divergence curve ``U*_D = √(m r_θ²/(dC_M/dθ))``, turning points and codimension-two
    crossings, by the transfer function (default) or by continuation (settings.method).

    Saves ``neutral_{tag}_map.nc`` (also in the cache, where :func:`theodorsen_comparison` finds
    it: :func:`stored_map_path`) and ``neutral_{tag}_divergence.nc``; the samples, reduced models
    and curves saved on the way make a rerun resume. The returned map dataset also has each
    curve's seed mass and stops, the frequency at each turning point, the divergence law's
    coefficient ``U*_D/√m`` and (transfer) the count of unstable eigenvalues on a grid.

    ``client``: a ``dask.distributed`` client (:func:`fsistab.study.study_client`) whose workers
    factorise the transfer map's exact samples (:mod:`fsistab.map_distributed`): the same map.
    """
    from fsistab.linalg import FactorCounter
    from fsistab.neutral_map import neutral_map_dataset
    from fsistab.store import write_dataset

    if client is not None and settings.method != "transfer":
        raise InputError("--workers and --scheduler spread the samples of --method transfer only")
    say = progress
    out = Path(out)
    template = replace(
        template,
        mass_ratio=settings.template_mass,
        reduced_velocity=settings.velocity_range[0],
        dofs=("heave", "pitch"),
    )
    counter = FactorCounter()
    _, fluid = _fluid(case, cache_dir, say)
    wake = _map_wake_frequency(fluid, settings, counter, say)
    reduced = _map_reduced_models(case, fluid, settings, out, counter, say)
    attrs = {**_solid_attrs(case, template), "wake_frequency": math.nan if wake is None else wake}
    result, tmap = _trace_map(case, template, settings, fluid, out, attrs, reduced, counter, say, client)
    # the reduced models of the map, or with exact samples those built at sharp resonances and s = 0
    models = len(reduced.models) if reduced else tmap.resonance_models if tmap is not None else 0
    ds = neutral_map_dataset(result, _map_attrs(attrs, settings, tmap, models))
    ds = _map_counts(_map_details(ds, result, tmap, settings), case, tmap, counter.count, models)
    data_path = write_dataset(ds, out / f"neutral_{case.tag}_map.nc")
    write_dataset(ds, stored_map_path(cache_dir, case.tag))
    _write_divergence(result, case, template, out)
    return ds.assign_attrs(data=str(data_path))


def _map_wake_frequency(fluid, settings: MapSettings, counter, say) -> float | None:
    """The frequency of the fixed body's wake mode nearest ``settings.wake_frequency`` (None if not
    given): the map's guess (transfer: initial frequencies around it and a wider default range;
    continuation: a VIV sweep, :func:`fsistab.neutral.map_seeds`)."""
    from fsistab.critical import wake_mode_near

    wake = settings.wake_frequency
    if wake is not None:
        say("wake mode of the fixed body")
        wake = wake_mode_near(fluid, wake, counter=counter).frequency
    return wake


def _map_reduced_models(case: Case, fluid, settings: MapSettings, out: Path, counter, say):
    """The transfer map's reduced fluid models (``settings.krylov_blocks`` Krylov blocks), saved in
    ``reduced_{tag}_models.nc`` and reused by a rerun; None with exact samples or by continuation."""
    from fsistab.reduced_model import ReducedModels
    from fsistab.symmetry import antisymmetric_operators

    blocks = settings.krylov_blocks(fluid.n_fluid)  # by the whole mesh's unknowns
    if settings.method != "transfer" or not blocks:
        return None
    return ReducedModels(
        antisymmetric_operators(fluid),  # the same models from half the unknowns (fsistab.symmetry)
        tolerance=settings.reduced_tolerance,
        blocks=blocks,
        path=out / f"reduced_{case.tag}_models.nc",
        counter=counter,
        progress=say,
    )


def _map_attrs(attrs: dict, settings: MapSettings, tmap, models: int) -> dict:
    """The map dataset's attributes: what it depends on, its method and (transfer) its sampling."""
    map_attrs = {**attrs, "method": settings.method}
    if tmap is not None:
        map_attrs["frequencies"] = len(tmap.frequencies)
        map_attrs["unresolved_intervals"] = len(tmap.unresolved)
        map_attrs["reduced_models"] = models
        map_attrs["rational_fits"] = tmap.rational_fits  # fsistab.rational_fit: below min_step
        map_attrs["interpolated_frequencies"] = tmap.interpolated
    return map_attrs


def _map_counts(ds: xr.Dataset, case: Case, tmap, this_run: int, models: int) -> xr.Dataset:
    """The map's costs (``this_run`` factorisations, and over every run that built its samples and
    models: a resumed map counts them all), its mesh's Reynolds number and the divergence law's
    coefficient ``U*_D/√m``."""
    ds.attrs["factorisations_this_run"] = this_run
    ds.attrs["mesh_reynolds"] = case.fitted_reynolds
    earlier = tmap.factorisations_total - tmap.factorisations if tmap is not None else 0
    ds.attrs["factorisations_total"] = earlier + this_run
    ds.attrs["reduced_models"] = models
    ds.attrs["divergence_coefficient"] = divergence_coefficient(ds)
    return ds


def _write_divergence(result, case: Case, template: Solid, out: Path) -> None:
    """``neutral_{tag}_divergence.nc``: the divergence curve ``U*_D(m)`` of the map (docs/model.md §8)."""
    from fsistab.store import write_dataset

    divergence = xr.Dataset(
        {"reduced_velocity": ("mass_ratio", result.divergence_velocities)},
        coords={"mass_ratio": result.divergence_mass_ratios},
        attrs={**_solid_attrs(case, template), "moment_slope": result.moment_slope},
    )
    write_dataset(divergence, out / f"neutral_{case.tag}_divergence.nc")


def shading_velocities(curve_velocities, divergence_velocities, points: int = 150) -> np.ndarray:
    """The U* of the map's shading grid: every curve point and the divergence line over the mass
    range (finite values; without the line, a map with no curve below it left the divergence
    region at low m unshaded), and U* = 1, with a margin of 1.5 either side."""
    values = [*curve_velocities, *np.ravel(divergence_velocities), 1.0]
    values = [u for u in values if np.isfinite(u) and u > 0]
    return np.geomspace(min(values) / 1.5, max(values) * 1.5, points)


def _map_details(ds: xr.Dataset, result, tmap, settings: MapSettings) -> xr.Dataset:
    """What the JSON and the figure need beyond :func:`fsistab.neutral_map.neutral_map_dataset`."""
    from fsistab.transfer_map import unstable_grid

    curves = result.curves
    ds = ds.assign(
        curve_seed_mass_ratio=("curve_index", np.array([c.seed_mass_ratio for c in curves], dtype=float)),
        curve_stop_low=("curve_index", np.array([c.stops[0] for c in curves], dtype=str)),
        curve_stop_high=("curve_index", np.array([c.stops[1] for c in curves], dtype=str)),
        fold_frequency=(
            "fold",
            np.array([t.frequency for c in curves for t in c.turning_points], dtype=float),
        ),
    )
    if tmap is not None:  # exact unstable regions from the signed crossings
        grid_m = np.geomspace(*settings.mass_range, 100)
        grid_u = shading_velocities(
            [p.reduced_velocity for c in curves for p in c.points], result.divergence_velocities
        )
        counts, incomplete = unstable_grid(tmap, grid_m, grid_u)
        families = list(incomplete)
        ds = ds.assign(
            unstable_count=(("grid_reduced_velocity", "grid_mass_ratio"), counts),
            # where a family's crossings do not add up (a curve missing): left out of the count
            unshaded=(("shading_family", "grid_mass_ratio"), np.array([incomplete[k] for k in families])),
        ).assign_coords(grid_mass_ratio=grid_m, grid_reduced_velocity=grid_u, shading_family=families)
    return ds


def divergence_coefficient(ds: xr.Dataset) -> float:
    """``U*_D/√m = √(r_θ²/(dC_M/dθ))`` of a map (inf without divergence)."""
    return float(_divergence_velocity(float(ds.attrs["moment_slope"]), float(ds.attrs["r_theta"]), 1.0))


# --- neutral curves in the flow plane --------------------------------------------------------------


@_workflow
def flow_neutral_curves(
    case: Case,
    solid: Solid,
    settings: FlowNeutralSettings,
    cache_dir: Path,
    out: Path,
    progress: Progress = None,
) -> xr.Dataset:
    """Neutral curves in ``(Re, U*)`` or ``(α0, U*)`` at one mass ratio (docs/model.md §8): the flutter
    thresholds of a sweep in U* at the case's flow, each continued both ways by pseudo-arclength.
    Each half is saved as ``flow_neutral_{tag}_{parameter}_m{m}_curve{k}_{down|up}.nc`` and reused
    by a rerun with the same parameters. Returns the halves stacked along ``point`` (index
    ``curve``), turning points along ``fold``, and per half ``kind``, ``direction``, ``stop``."""
    from fsistab.critical import find_thresholds
    from fsistab.flow_neutral import (
        continue_flow_neutral_curve,
        flow_curve_table,
        record_flow_curve,
        stack_flow_curves,
    )
    from fsistab.linalg import FactorCounter

    say = progress
    out = Path(out)
    mass = solid.mass_ratio
    counter = FactorCounter()
    attrs = {
        **_solid_attrs(case, solid),
        "mass_ratio": mass,
        "range_low": settings.parameter_range[0],
        "range_high": settings.parameter_range[1],
    }
    _, fluid = _fluid(case, cache_dir, say)
    say(f"sweep in U* at m = {mass:g}")
    velocities = np.geomspace(*settings.velocity_range, settings.points)
    solid = replace(solid, reduced_velocity=float(velocities[0]), dofs=("heave", "pitch"))

    thresholds, _ = find_thresholds(fluid, solid, velocities, counter=counter, progress=say)
    dynamic = [t for t in thresholds if t.kind != "divergence"]
    halves = []
    for k, threshold in enumerate(dynamic):
        for direction in (-1, 1):
            side = "down" if direction < 0 else "up"
            path = out / f"flow_neutral_{case.tag}_{settings.parameter}_m{mass:g}_curve{k}_{side}.nc"
            wanted = {
                **attrs,
                "kind": threshold.kind,
                "direction": direction,
                "max_points": settings.max_points,
            }
            table = flow_curve_table(path, wanted)  # damaged: reported and traced again
            if table.complete:
                halves.append(table.dataset())
            else:
                say(f"curve {k + 1}/{len(dynamic)} towards {side} {settings.parameter}")
                curve = continue_flow_neutral_curve(
                    _mesh_spec(case),
                    case.flow,
                    replace(solid, reduced_velocity=threshold.reduced_velocity),
                    threshold.frequency,
                    settings.parameter,
                    settings.parameter_range,
                    direction=direction,
                    max_points=settings.max_points,
                    cache_dir=cache_dir,
                    fluid=fluid,
                    counter=counter,
                )
                halves.append(record_flow_curve(table, curve))
    final = {**attrs, "factorisations": counter.count, "mesh_reynolds": case.fitted_reynolds}
    return stack_flow_curves(halves, settings.parameter, final)


# --- Theodorsen typical section --------------------------------------------------------------------


def typical_section(solid: Solid, settings: TheodorsenSettings):
    """The typical section of docs/model.md §9 (thin-airfoil slopes until :func:`section_slopes`): the
    settings' m, elastic axis and static unbalance with ``solid``'s other parameters. Cheap: it
    validates the section before any work."""
    from fsistab.theodorsen import TypicalSection

    solid = replace(
        solid,
        mass_ratio=settings.mass_ratio,
        reduced_velocity=settings.velocity_range[0],
        dofs=("heave", "pitch"),
    )
    return TypicalSection(solid, settings.elastic_axis, settings.static_unbalance)


@_workflow
def section_slopes(
    section, settings: TheodorsenSettings, case: Case, cache_dir: Path, progress: Progress = None
):
    """``section`` with the settings' slopes: thin airfoil, given, or the viscous static slopes at
    the case's Re (``calibrated``, docs/model.md §9: cached steady state, one linear solve)."""
    from fsistab.theodorsen import AirfoilSlopes

    if settings.slopes == "thin-airfoil":
        return replace(section, slopes=AirfoilSlopes.thin_airfoil())
    if settings.slopes == "given":
        airfoil = AirfoilSlopes.from_alpha(settings.lift_slope_alpha, settings.moment_slope_alpha)
        return replace(section, slopes=airfoil)
    from fsistab.slopes import static_slopes

    say = progress
    say(f"viscous static slopes at Re = {case.flow.reynolds:g} (steady state, one linear solve)")
    _, fluid = _fluid(case, cache_dir, say)
    return replace(section, slopes=AirfoilSlopes.from_static(static_slopes(fluid)))


def _slope_attrs(section) -> dict:
    airfoil = section.slopes
    return {
        "slopes_source": airfoil.source,
        "lift_slope_alpha": airfoil.lift_slope_alpha,
        "moment_slope_alpha": airfoil.moment_slope_alpha,
        "moment_slope_elastic_axis": section.moment_slope_elastic_axis,
        "elastic_axis": section.elastic_axis,
        "static_unbalance": section.static_unbalance,
    }


def theodorsen_points(section, settings: TheodorsenSettings) -> xr.Dataset:
    """Every flutter boundary and the divergence of the typical section at its m (docs/model.md §9)."""
    from fsistab.theodorsen import critical_points as section_points

    found = section_points(section, settings.velocity_range)
    return xr.Dataset(
        {
            "kind": ("threshold", np.array([p.kind for p in found], dtype=str)),
            "boundary": ("threshold", np.array([p.boundary for p in found], dtype=str)),
            "reduced_velocity": ("threshold", np.array([p.reduced_velocity for p in found], dtype=float)),
            "frequency": ("threshold", np.array([p.frequency for p in found], dtype=float)),
            "frequency_ratio": (
                "threshold",
                np.array([p.frequency * p.reduced_velocity for p in found], dtype=float),
            ),
        },
        attrs={
            "mass_ratio": section.mass_ratio,
            "velocity_range": list(settings.velocity_range),
            **_slope_attrs(section),
        },
    )


def stored_map_path(cache_dir: Path, tag: str) -> Path:
    """Where the cache keeps the last stability map of ``fsistab neutral`` (either method) for the
    case ``tag``: the viscous map that :func:`theodorsen_comparison` compares with."""
    return Path(cache_dir) / "maps" / f"neutral_{tag}_map.nc"


def viscous_map_curves(cache_dir: Path, tag: str, section):
    """The viscous neutral curves of the last ``fsistab neutral`` for ``tag`` with this cache
    (:func:`stored_map_path`), if they were computed with the section's solid parameters:
    ``({"flutter": [(m, U*), ...], "divergence": (m, U*)}, note)`` or ``(None, why not)``."""
    from fsistab.errors import CacheError
    from fsistab.store import read_dataset

    path = stored_map_path(cache_dir, tag)
    if not path.is_file():
        return None, f"no stability map of {tag} in the cache {cache_dir}: no viscous comparison"
    try:
        ds = read_dataset(path)
    except CacheError as exc:
        return None, f"{exc}: no viscous comparison"
    solid = section.solid
    wanted = {"freq_ratio": solid.freq_ratio, "zeta_h": solid.zeta_h, "zeta_theta": solid.zeta_theta}
    wanted["r_theta"] = solid.r_theta
    stored = {k: float(ds.attrs.get(k, math.nan)) for k in wanted}
    # maps saved before the typical section (docs/model.md §3.1) are about mid-chord, balanced
    typical = {"elastic_axis": section.elastic_axis, "static_unbalance": section.static_unbalance}
    stored.update({k: float(ds.attrs.get(k, 0.0)) for k in typical})
    wanted.update(typical)
    if any(not math.isclose(stored[k], v, abs_tol=1e-15) for k, v in wanted.items()):
        return None, f"the stored map of {tag} has other solid parameters: no viscous comparison"
    from fsistab.neutral_map import map_curves

    flutter = [(m, u) for kind, m, u, _ in map_curves(ds) if kind == "flutter" and len(m)]
    divergence = (ds.mass_ratio.values, ds.divergence_reduced_velocity.values)
    return {"flutter": flutter, "divergence": divergence}, f"viscous neutral curves from {path}"


@_workflow
def theodorsen_comparison(
    section,
    settings: TheodorsenSettings,
    case: Case,
    cache_dir: Path,
    out: Path,
    progress: Progress = None,
) -> xr.Dataset:
    """Neutral curves ``U*(m)`` of the typical section over the settings' mass range (docs/model.md §9)
    with their frequency ratio ``ω_F/ω_θ = ω_F U*_F``, and the viscous map of ``fsistab neutral``
    for the plate at the case's Re and α0 if the cache holds one (:func:`viscous_map_curves`)
    with the relative error of the lowest flutter boundary against it. Saved as
    ``theodorsen_{tag}_{slopes}.nc`` in ``out``."""
    from fsistab.store import write_dataset
    from fsistab.theodorsen import lower_envelope, lowest_flutter_velocity, neutral_curves

    say = progress
    masses = np.geomspace(*settings.mass_range, settings.points)
    say(f"Theodorsen neutral curves at {settings.points} mass ratios")
    ds = neutral_curves(section, masses, settings.velocity_range)
    ds["flutter_frequency_ratio"] = ds.reduced_velocity * ds.frequency  # ω_F/ω_θ
    ds.attrs.update(_slope_attrs(section))
    ds.attrs.update({"reynolds": case.flow.reynolds, "alpha0_deg": case.flow.alpha0_deg})
    # the viscous map of the same section: its mesh is in the frame of the elastic axis
    from fsistab.bodies import Pivoted

    axis = section.elastic_axis
    tag = replace(case, body=Pivoted(case.body, axis)).tag if axis else case.tag
    viscous, note = viscous_map_curves(cache_dir, tag, section)
    ds.attrs["viscous_comparison"] = note
    if viscous:
        say("lowest flutter boundary against the viscous map")
        for i, (m, u) in enumerate(viscous["flutter"]):
            ds[f"viscous_flutter{i}_mass_ratio"] = (f"viscous_point{i}", np.asarray(m, dtype=float))
            ds[f"viscous_flutter{i}_reduced_velocity"] = (f"viscous_point{i}", np.asarray(u, dtype=float))
        ds["viscous_divergence_mass_ratio"] = ("viscous_divergence", viscous["divergence"][0])
        ds["viscous_divergence_reduced_velocity"] = ("viscous_divergence", viscous["divergence"][1])
        lowest = lower_envelope(viscous["flutter"]) if viscous["flutter"] else []
        theodorsen = [
            lowest_flutter_velocity(section.with_mass_ratio(m), settings.velocity_range) for m, _ in lowest
        ]
        ds["comparison_mass_ratio"] = ("comparison", np.array([m for m, _ in lowest], dtype=float))
        ds["comparison_viscous"] = ("comparison", np.array([u for _, u in lowest], dtype=float))
        ds["comparison_theodorsen"] = ("comparison", np.array(theodorsen, dtype=float))
        ds["comparison_relative_error"] = (
            ds.comparison_theodorsen - ds.comparison_viscous
        ) / ds.comparison_viscous
    ds.attrs["viscous_flutter_curves"] = len(viscous["flutter"]) if viscous else 0
    path = write_dataset(ds, Path(out) / f"theodorsen_{tag}_{settings.slopes}.nc")
    return ds.assign_attrs(netcdf=str(path))


def theodorsen(
    section,
    settings: TheodorsenSettings,
    case: Case,
    cache_dir: Path,
    out: Path,
    progress: Progress = None,
) -> xr.Dataset:
    """``fsistab theodorsen``: the typical section (:func:`typical_section`) with the settings'
    slopes (:func:`section_slopes`), then its thresholds at one m (:func:`theodorsen_points`) or,
    with a mass range, its neutral curves against the viscous map (:func:`theodorsen_comparison`)."""
    section = section_slopes(section, settings, case, cache_dir, progress)
    if settings.mass_range is None:
        return theodorsen_points(section, settings)
    return theodorsen_comparison(section, settings, case, cache_dir, out, progress)


# --- viscous Theodorsen function -------------------------------------------------------------------


@_workflow
def transfer_function(
    case: Case, settings: TransferSettings, cache_dir: Path, out: Path, progress: Progress = None
) -> xr.Dataset:
    """The viscous Theodorsen function ``G(ik)`` beside Theodorsen's model (docs/model.md §9), at
    ``k = ω L/(2U∞)`` log-spaced (coordinate ``reduced_frequency``); samples kept in the cache as
    they come (a rerun resumes); saved as ``transfer_{tag}_{preset}.nc``."""
    from fsistab.store import write_dataset
    from fsistab.transfer import viscous_theodorsen_dataset

    say = progress
    omega = 2 * np.geomspace(*settings.k_range, settings.points)
    _, fluid = _fluid(case, cache_dir, say)

    samples_path = Path(cache_dir) / "transfer" / f"{_mesh_spec(case).linear_key()}_{case.tag}.nc"
    ds = viscous_theodorsen_dataset(fluid, omega, progress=say, samples_path=samples_path)
    ds.attrs.update({"reynolds": case.flow.reynolds, "alpha0_deg": case.flow.alpha0_deg})
    ds.attrs.update({"body": case.kind, "preset": case.preset, "mesh_reynolds": case.fitted_reynolds})
    path = write_dataset(ds, Path(out) / f"transfer_{case.tag}_{case.preset}.nc")
    return ds.assign_attrs(netcdf=str(path))


# --- onset of a fixed body's wake instability --------------------------------------------------------


@_workflow
def fixed_body_onset(
    case: Case,
    parameter: str,
    guess: float,
    shift: complex | None = None,
    cache_dir: Path | None = None,
    out: Path = Path("fsistab-out"),
    progress: Progress = None,
) -> xr.Dataset:
    """The fixed body's critical Reynolds number at the case's α0 (``parameter="reynolds"``) or
    critical α0 at the case's Re (``"alpha0"``, degrees): the root of the leading mode's growth
    rate by the secant of :mod:`fsistab.onset`, from ``guess`` and the leading eigenvalue near
    ``shift`` (None: the cylinder's wake mode, 0.75i; required for the plate). One mesh for every
    iterate, fitted to the guess for the critical Re (the case's Re is then unused) and to the
    case's Re for the critical α0 (:func:`fsistab.onset.fitted_case`); steady states continued
    from iterate to iterate and cached, so a rerun reuses them. Iterates along ``iterate`` with the
    parameter's ``value``; critical value, frequency ``ω_c`` (U∞/L), Strouhal number, iterations
    and factorisations in attributes; saved as
    ``onset_{body}_{parameter}_{Re or a}{value}_{preset}.nc``, its path in attribute ``data``."""
    from fsistab.onset import check_onset, critical_onset, fitted_case, onset_dataset
    from fsistab.store import json_attr, write_dataset

    say = progress
    guess, shift = check_onset(case.kind, parameter, guess, shift)
    fitted = fitted_case(case, parameter, guess)
    spec = _mesh_spec(fitted)
    fit = fitted.fitted_reynolds
    say(f"onset in {parameter}: fixed {case.kind}, mesh {case.preset} fitted to Re {fit:g}")
    result = critical_onset(spec, case.flow, parameter, guess, shift, cache_dir=cache_dir, progress=say)
    flow = case.flow
    fixed = {"reynolds": flow.reynolds} if parameter == "alpha0" else {"alpha0_deg": flow.alpha0_deg}
    ds = onset_dataset(
        result,
        {
            "body": case.kind,
            **fixed,
            "guess": guess,
            "shift_real": shift.real,
            "shift_imag": shift.imag,
            "preset": case.preset,
            "mesh_fitted_reynolds": fitted.fitted_reynolds,
            "mesh_reynolds": fitted.fitted_reynolds,
            "mesh": json_attr(spec.describe()),
            "mesh_key": spec.key(),
            "ndof": result.iterates[-1].unknowns,
            "conventions": case.body.conventions,
        },
    )
    where = f"a{case.flow.alpha0_deg:g}" if parameter == "reynolds" else f"Re{case.flow.reynolds:g}"
    if case.mesh_reynolds is not None:  # another mesh than the one fitted to the guess or --Re
        where += f"_meshRe{case.mesh_reynolds:g}"
    where += case.mesh_tag
    path = write_dataset(ds, Path(out) / f"onset_{case.kind}_{parameter}_{where}_{case.preset}.nc")
    return ds.assign_attrs(data=str(path))


# --- adjoint sensitivities (fsistab.sensitivity) ----------------------------------------------------


class SensitivityResult(NamedTuple):
    """The thresholds' derivatives (``dataset``), and what the maps' VTK file and figure are made
    from: the maps (:class:`fsistab.sensitivity.SensitivityMaps`) and the steady state; ``scale``
    the body's U* over the generic one."""

    dataset: xr.Dataset
    maps: list
    steady: object
    scale: float


def _sensitivity_maps(fluid, solid, sweep: SweepSettings, thresholds, results, factor, counter, say):
    """The spatial sensitivity maps of each threshold and, with ``sweep.wake_shift``, of the fixed
    body's wake mode near ``Im(wake_shift)``."""
    from fsistab import sensitivity as adjoint
    from fsistab.coupled import CoupledSystem
    from fsistab.critical import wake_mode_near

    say(f"sensitivity maps of {len(results)} threshold(s)")
    maps = []
    for i, (threshold, result) in enumerate(zip(thresholds, results, strict=True)):
        at_point = replace(solid, reduced_velocity=result.reduced_velocity, mass_ratio=result.mass_ratio)
        slope = result.eigenvalue["reduced_velocity"]
        maps.append(
            adjoint.sensitivity_maps(
                CoupledSystem(fluid, at_point),
                result.adjoint,
                f"{threshold.kind}{i}",
                factor=factor,
                slope=slope,
            )
        )
    if sweep.wake_shift is not None:
        say("fixed body's wake mode and its adjoint")
        pair = wake_mode_near(fluid, sweep.wake_shift.imag, counter=counter)
        fixed = CoupledSystem(fluid, Solid(dofs=()))
        mode = adjoint.adjoint_mode(fixed, pair.value, pair.vector, counter=counter)
        maps.append(adjoint.sensitivity_maps(fixed, mode, "wake", factor=factor))
    return maps


def _body_derivatives(ds: xr.Dataset, case: Case, scale: float) -> xr.Dataset:
    """The derivatives in the body's conventions: U* = scale U*_g, and the cylinder's
    m = 2 m_g / π (docs/model.md §10)."""
    per_mass = xr.where(ds.parameter == "mass_ratio", case.body.mass_scale, 1.0)
    ds["reduced_velocity"] = ds.reduced_velocity * scale
    ds["d_reduced_velocity"] = ds.d_reduced_velocity * scale * per_mass
    for name in ("d_frequency", "d_growth_rate", "d_eigenfrequency"):
        ds[name] = ds[name] * per_mass
    return ds


@_workflow
def sensitivity(
    case: Case, solid: Solid, sweep: SweepSettings, cache_dir: Path, out: Path, progress: Progress = None
) -> SensitivityResult:
    """Every threshold along U* at one mass ratio (as :func:`critical_points`) with its derivatives
    with respect to every parameter (adjoint, implicit function theorem; docs/model.md §8,
    docs/reference/sensitivity.md), and the spatial sensitivity maps of each threshold and, with
    ``sweep.wake_shift``, of the fixed body's wake mode near ``Im(wake_shift)``: a steady force, a
    control cylinder, the structural sensitivity. U* and its derivatives in the body's convention
    (docs/model.md §10). Writes ``sensitivity_{stem}.nc`` (thresholds) and ``sensitivity_{stem}_maps.nc``
    (maps at the mesh vertices); their paths in attributes ``netcdf`` and ``maps`` ("" without
    any map), the file stem in ``stem``."""
    from fsistab import sensitivity as adjoint
    from fsistab.store import write_dataset

    say = progress
    scale, velocities, solid, counter = _threshold_sweep(case, solid, sweep)
    steady, fluid = _fluid(case, cache_dir, say)
    factors: dict = {}
    thresholds, results = adjoint.sensitivity_results(
        fluid, solid, velocities, wake_shift=sweep.wake_shift, counter=counter, progress=say, factors=factors
    )
    if 0j not in factors:
        factors[0j] = adjoint.steady_factor(fluid, counter)
    maps = _sensitivity_maps(fluid, solid, sweep, thresholds, results, factors[0j], counter, say)
    attrs = {
        **_sweep_attrs(case, sweep, counter),
        "conventions": case.body.conventions + "; alpha0 derivatives per degree",
    }
    ds = adjoint.sensitivity_dataset(thresholds, results, adjoint.PARAMETERS, attrs)
    ds = _body_derivatives(ds, case, scale)
    stem = f"sensitivity_{case.tag}_m{sweep.mass_ratio:g}_{case.preset}"
    maps_path = ""
    if maps:
        say("writing the maps (NetCDF)")
        maps_ds = adjoint.maps_dataset(maps, steady.mesh, attrs, scale)
        maps_path = str(write_dataset(maps_ds, Path(out) / f"{stem}_maps.nc"))
        restabilising = {f"{t.kind}{i}" for i, t in enumerate(thresholds) if t.boundary == "restabilisation"}
        ds = ds.assign_attrs(best_control=json.dumps(_best_control(maps_ds, restabilising)))
    netcdf = write_dataset(ds, Path(out) / f"{stem}.nc")
    ds = ds.assign_attrs(netcdf=str(netcdf), maps=maps_path, stem=str(Path(out) / stem))
    return SensitivityResult(ds, maps, steady, scale)


def _best_control(maps_ds: xr.Dataset, restabilising: set[str] = frozenset()) -> dict:
    """Per map target, the mesh vertex where the control cylinder helps most: the largest
    ``δU*_c`` for an onset threshold (the most negative for a restabilisation, in
    ``restabilising``: the unstable interval shrinks), the most negative growth-rate change for the
    wake mode — among the vertices where the cylinder clears the body by its diameter (nearer,
    the model of a small isolated cylinder does not hold)."""
    best = {}
    near = maps_ds.wall_distance.values < maps_ds.attrs["control_diameter"]
    for k, target in enumerate(maps_ds.target.values):
        gain = np.where(near, np.nan, maps_ds.d_reduced_velocity_control.values[k])
        if np.isfinite(gain).any():
            pick = np.nanargmin if str(target) in restabilising else np.nanargmax
            i, value = int(pick(gain)), "d_reduced_velocity"
            amount = float(gain[i])
        else:
            growth = np.where(near, np.nan, maps_ds.control.values[k, :, 0])
            i, value = int(np.nanargmin(growth)), "d_growth_rate"
            amount = float(growth[i])
        best[str(target)] = {"x": float(maps_ds.x.values[i]), "y": float(maps_ds.y.values[i]), value: amount}
    return best


# --- nonlinear time march ---------------------------------------------------------------------------

SIMULATION_FIELDS = (
    "time",
    "heave",
    "pitch",
    "heave_rate",
    "pitch_rate",
    "lift_coefficient",
    "drag_coefficient",
    "moment_coefficient",
    "chord_iterations",
)
PROGRESS_EVERY, PROGRESS_WINDOW = 50, 200  # steps between progress lines; steps of the amplitude
SIMULATION_STATE = ("current_state", "previous_state", "start_eigenvalue")


class SimulationResult(NamedTuple):
    """The time series (``dataset``, its NetCDF path in attribute ``netcdf``) and the steady state
    the march started from (its mesh, for figures)."""

    dataset: xr.Dataset
    steady: object


def _sample_record(sample) -> dict:
    h, theta, hdot, thetadot = sample.solid
    values = (sample.time, h, theta, hdot, thetadot, sample.lift, sample.drag, sample.moment)
    return {**dict(zip(SIMULATION_FIELDS, values, strict=False)), "chord_iterations": sample.iterations}


def _simulation_identity(case: Case, solid: Solid, settings) -> dict:
    """What a march's states depend on: the case, the solid, the step and the start."""
    return {
        "body": case.kind,
        **_solid_attrs(case, solid),
        "mass_ratio": solid.mass_ratio,
        "reduced_velocity": solid.reduced_velocity,
        "dofs": ",".join(solid.dofs) or "none",
        **settings.identity(),
        **({} if settings.start is None else {"start": _start_fingerprint(settings.start)}),
    }


def _start_fingerprint(path: str) -> str:
    """``--start`` as its path and the SHA-256 of the file's bytes: a checkpoint marched further
    later (the same path, another last state) is another start, so the march from it is another
    march, never the cached one from the old state. An unreadable file keeps its path alone (it is
    refused when read, :func:`_saved_start`)."""
    import hashlib

    try:
        digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError:
        return str(path)
    return f"{path} sha256:{digest}"


def _start_mode(system, settings, case: Case, say):
    """The eigenpair nearest the shift (the body's spectrum shift by default, docs/model.md §7).
    A released body (``perturbation_of`` heave or pitch) starts from the mode's solid motion, so
    its mode is the nearest of the six found that is labelled heave, pitch or coupled
    (:func:`fsistab.eigen.label_mode`), the nearest of all when every one is labelled fluid (a
    wake mode carrying a light body, as in VIV): the flutter mode's frequency moves with U* while
    the fluid modes stay, and one shift serves a range of U* (``fsistab lco``)."""
    from fsistab.eigen import eigenpairs_near

    shift = case.body.spectrum_shifts[0] if settings.shift is None else settings.shift
    say(f"eigenmode nearest {shift:.4g} (shift-invert Arnoldi)")
    pairs = eigenpairs_near(system, [shift], 6)
    if settings.perturbation_of != "largest":
        pairs = [p for p in pairs if p.label != "fluid"] or pairs
    return min(pairs, key=lambda p: abs(p.value - shift))


class SavedStart(NamedTuple):
    """The last state of a ``--start`` checkpoint, and the mesh it was marched on when it is not
    this case's (None when it is)."""

    state: np.ndarray
    mesh: object | None


def _saved_start(settings, case: Case, identity: dict) -> SavedStart | None:
    """The ``--start`` checkpoint's last state, read and checked before any work: of this body,
    flow and degrees of freedom, on this mesh, or on another whose specification the checkpoint's
    cache holds (:func:`_source_mesh`)."""
    from fsistab.store import read_dataset

    if settings.start is None:
        return None
    path = Path(settings.start)
    keys = ("body", "reynolds", "alpha0_deg", "dofs")
    ds = read_dataset(path, {k: identity[k] for k in keys})
    if "current_state" not in ds or "mesh_key" not in ds.attrs:
        raise InputError(f"{path} holds no state (not a simulation checkpoint)")
    state = ds["current_state"].values.astype(float)
    if ds.attrs["mesh_key"] == identity["mesh_key"]:
        return SavedStart(state, None)
    return SavedStart(state, _source_mesh(path, str(ds.attrs["mesh_key"]), case))


def _source_mesh(checkpoint: Path, mesh_key: str, case: Case):
    """The specification of the mesh ``mesh_key`` that the checkpoint was marched on: the one saved
    with a steady state of this flow on that mesh in the cache that holds the checkpoint (its body
    this case's, checked by the key). It must cover this case's domain: the start is interpolated
    at this mesh's points."""
    from fsistab.errors import CacheError
    from fsistab.mesh import MeshSizes
    from fsistab.params import Domain
    from fsistab.store import read_attributes, read_dataset

    target, flow = _mesh_spec(case), {"reynolds": case.flow.reynolds, "alpha0_deg": case.flow.alpha0_deg}
    for path in sorted((checkpoint.resolve().parent.parent / "steady").glob("*.nc")):
        if read_attributes(path).get("mesh_key") != mesh_key:
            continue
        try:
            attrs = read_dataset(path, {"mesh_key": mesh_key, **flow}).attrs
        except CacheError:
            continue
        saved = json.loads(attrs["mesh"])
        sizes = MeshSizes(**{k: tuple(v) if isinstance(v, list) else v for k, v in saved["sizes"].items()})
        spec = replace(target, domain=Domain(**saved["domain"]), sizes=sizes, sponge=None)
        spec = replace(spec, preset=saved["preset"], outlet=saved["outlet"])
        if spec.key() != mesh_key:
            continue
        sides = ("upstream", "downstream", "lateral")
        if any(getattr(spec.domain, side) < getattr(target.domain, side) for side in sides):
            own = target.domain
            raise InputError(f"{checkpoint}: its domain {spec.domain} does not cover this mesh's {own}")
        return spec
    raise InputError(
        f"{checkpoint} was marched on another mesh (key {mesh_key}) whose steady state is not in "
        "its cache: a start on another mesh needs it"
    )


def _start_state(saved: SavedStart, stepper, case: Case, start: str, say) -> np.ndarray:
    """The saved start as a state of this mesh: as saved, or interpolated from its own mesh
    (:func:`fsistab.simulation.transferred_state`)."""
    from fsistab.simulation import transferred_state
    from fsistab.steady import solve_steady

    if saved.mesh is None:
        if saved.state.size != stepper.system.size:
            size = stepper.system.size
            raise InputError(f"{start} holds no state of {size} unknowns (a checkpoint of this case)")
        return saved.state
    cache = Path(start).resolve().parent.parent
    source = solve_steady(saved.mesh, case.flow, cache_dir=cache, progress=say)
    say(f"the start's state interpolated from its mesh ({source.space.ndof} dofs) onto this one")
    return transferred_state(source, saved.state, stepper)


def _start(table, stepper, system, settings, case, saved: SavedStart | None, say):
    """The :class:`fsistab.simulation.MarchState` to march from: the checkpoint's last state, else
    the start (a saved state, the steady state plus the perturbation times the mode nearest the
    shift, or without perturbation the steady state itself), recorded as the table's first row."""
    from fsistab.simulation import MarchState, perturbed_state

    records, state = table.records, table.state
    if records and "current_state" in state:
        last = records[-1]
        say(f"resuming at t = {float(last['time']):.6g} (step {len(records) - 1})")
        previous = state.get("previous_state")
        return MarchState(float(last["time"]), len(records) - 1, state["current_state"], previous)
    states = {}
    if saved is not None:
        q0 = _start_state(saved, stepper, case, settings.start, say)
    elif settings.perturbation == 0:
        q0 = stepper.steady_point()  # no mode to add: no eigenvalue solve
    else:
        pair = _start_mode(system, settings, case, say)
        q0 = perturbed_state(stepper, pair.vector, settings.perturbation, settings.perturbation_of)
        states["start_eigenvalue"] = np.array([pair.growth_rate, pair.frequency])
    start = MarchState(0.0, 0, q0)
    table.append(_sample_record(stepper.initial_sample(start)), state={"current_state": q0, **states})
    return start


def _resume_linearisation(table, stepper, state, say) -> None:
    """A march resumed after a step that needed more than ``stepper.refresh_after`` chord
    iterations had its iteration matrix rebuilt about the current flow and motion
    (:meth:`fsistab.simulation.TimeStepper.refresh`); that matrix is not saved, so rebuild it at
    the resumed state: the steady state's would make the next step start over far from its
    solution (a large-amplitude cycle then stalls). The residual, hence every converged step, is
    unchanged."""
    records = table.records
    if state.step == 0 or not records or stepper.refresh_after <= 0:
        return
    if int(records[-1]["chord_iterations"]) > stepper.refresh_after:
        say(f"iteration matrix rebuilt at the resumed state (t = {state.time:.6g})")
        stepper.refresh(state.current)


def _amplitude(samples, reference, active: list[int]) -> float:
    """The largest deviation from the steady ``reference`` sample, over ``samples``, of the pitch
    (else the heave, else the lift coefficient for a fixed body): the progress display's amplitude."""
    if 1 in active:
        deviations = [s.solid[1] - reference.solid[1] for s in samples]
    elif 0 in active:
        deviations = [s.solid[0] - reference.solid[0] for s in samples]
    else:
        deviations = [s.lift - reference.lift for s in samples]
    return float(np.max(np.abs(deviations))) if deviations else 0.0


def _time_series(table, attrs: dict) -> xr.Dataset:
    """The checkpoint's records as the result: variables along the coordinate ``time``."""
    records = table.records
    columns = {name: np.array([float(r[name]) for r in records]) for name in SIMULATION_FIELDS}
    time = columns.pop("time")
    data = {name: ("time", values) for name, values in columns.items()}
    data["chord_iterations"] = ("time", columns["chord_iterations"].astype(int))
    return xr.Dataset(data, coords={"time": time}, attrs=attrs)


@_workflow
def simulate(
    case: Case,
    solid: Solid,
    settings,
    cache_dir: Path,
    out: Path,
    progress: Progress = None,
    snapshot: Callable | None = None,
) -> SimulationResult:
    """March the nonlinear coupled equations in time (docs/model.md §12, :mod:`fsistab.simulation`)
    to ``settings.duration``, saved as ``simulate_{tag}.nc`` in ``out`` (the time series, coordinate
    ``time``). The march is checkpointed in the cache (a rerun resumes it, also with a longer
    duration). ``snapshot(index, time, steady, full_state)`` is called at every multiple of the
    snapshot interval (the VTK files of the outputs layer)."""
    import time as clock

    from fsistab.coupled import CoupledSystem
    from fsistab.simulation import TimeStepper, march
    from fsistab.store import ResumableTable, cache_key, write_dataset

    say = progress
    identity = _simulation_identity(case, solid, settings)
    saved = _saved_start(settings, case, identity)
    steady, fluid = _fluid(case, cache_dir, say)
    system = CoupledSystem(fluid, solid)
    path = Path(cache_dir) / "simulations" / f"simulate_{case.tag}_{cache_key('simulation', identity)}.nc"
    path.parent.mkdir(parents=True, exist_ok=True)
    table = ResumableTable(path, identity, {"sample": SIMULATION_FIELDS}, SIMULATION_STATE)
    stepper = TimeStepper(system, settings.time_step, settings.tolerance, settings.max_iterations)
    state = _start(table, stepper, system, settings, case, saved, say)
    _resume_linearisation(table, stepper, state, say)
    say(f"BDF2 march to t = {settings.duration:g}, dt = {settings.time_step:g}, {system.size} unknowns")
    reference = stepper.sample(0.0, stepper.steady_point(), fluid.loads0)
    started, first_step, recent = clock.perf_counter(), state.step, deque(maxlen=PROGRESS_WINDOW)
    try:
        for reached, sample in march(stepper, state, settings.duration):
            state = reached
            checkpoint = state.step % settings.checkpoint_every == 0
            states = {"current_state": state.current, "previous_state": state.previous}
            table.append(_sample_record(sample), state=states, save=checkpoint)
            recent.append(sample)
            _snapshot(snapshot, settings, state, stepper, steady)
            if checkpoint or (state.step - first_step) % PROGRESS_EVERY == 0:
                rate = (state.step - first_step) / max(clock.perf_counter() - started, 1e-9)
                amplitude = _amplitude(recent, reference, system.active)
                say(
                    f"t = {state.time:.4g} of {settings.duration:g}: {rate:.3g} steps/s, "
                    f"amplitude {amplitude:.3g}"
                )
    except BaseException:
        table.save()  # the last state reached, when interrupted
        raise
    seconds = clock.perf_counter() - started
    steps = state.step - first_step
    eigenvalue = table.state.get("start_eigenvalue")
    attrs = {
        **table.identity,
        **(
            {} if eigenvalue is None else dict(start_growth_rate=eigenvalue[0], start_frequency=eigenvalue[1])
        ),
        "perturbation_of": settings.perturbation_of,
        "ndof": system.size,
        "duration": float(state.time),
        "steps": state.step,
        "steps_this_run": steps,
        "seconds_per_step": seconds / steps if steps else float("nan"),
        "factorisations": stepper.counter.count,
        "scheme": "BDF2 (first step BDF1), chord iteration on J + (c0/dt) M, J_ff rebuilt about the "
        "current flow and motion after a step with many iterations",
        "conventions": "time in L/U; heave in L, pitch in rad (counter-clockwise +); coefficients "
        "F/(0.5 rho U^2 L s), lift and drag in laboratory axes, moment about the pitch axis",
        "checkpoint": str(path),
    }
    table.finish({"stop": "duration"})
    ds = _time_series(table, attrs)
    netcdf = write_dataset(ds, Path(out) / f"simulate_{case.tag}.nc")
    return SimulationResult(ds.assign_attrs(netcdf=str(netcdf)), steady)


def _snapshot(snapshot, settings, state, stepper, steady) -> None:
    """Call ``snapshot`` when the step crossed a multiple of the snapshot interval."""
    interval = settings.snapshot_interval
    if snapshot is None or interval is None:
        return
    index = math.floor(state.time / interval + 1e-6)
    if index > math.floor((state.time - settings.time_step) / interval + 1e-6):
        q = state.current
        full = stepper.fluid.full_state(stepper.solid_state(q), q[stepper.system.n_solid :])
        snapshot(index, state.time, steady, full)
