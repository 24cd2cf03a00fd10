"""Limit-cycle amplitudes past a threshold: one nonlinear march per U* (``fsistab lco``).

At each U* of a sweep :func:`fsistab.workflows.simulate` marches the coupled nonlinear system
(docs/model.md §12) from the steady state plus a perturbation of the leading mode, or from a given
state, to the duration asked. The saturated oscillation is read from the heave and pitch signals
over their last whole periods (:func:`saturation`):

* the period amplitudes ``a_k`` (half the peak-to-peak range between successive upward crossings
  of the signal's mid-level) and the envelope's relative change per period ``r = e^s - 1``, ``s``
  the least-squares slope of ``ln a_k`` against ``k`` over the last ``P`` periods;
* the march is **saturated** when ``|r|`` is below the tolerance (``growing`` or ``decaying``
  otherwise; ``too short`` with fewer than ``P`` periods); the amplitude is the mean of the last
  ``P`` period amplitudes, the angular frequency ``2πP`` over their span.

The bifurcation diagram is these amplitudes against U* with the linear thresholds of the same mesh
(:func:`fsistab.workflows.critical_points`, docs/model.md §8). Near a supercritical (Hopf) onset
``A² ∝ U* − U*_c``: a straight line through the first saturated points past the threshold meets
zero at ``U*_0 ≈ U*_c`` (:func:`onset_fit`). A subcritical onset shows as hysteresis: the sweep by
decreasing U*, each march started from the saturated state of the one above, stays on a large
cycle where the increasing sweep decays to the steady state.

Execution: each U* of the increasing sweep is one task, in this process or on a
``dask.distributed`` client (:func:`fsistab.study.study_client`); each finished point is saved as
``out/lco_points/<tag>_<key>.nc`` (checksummed, with its identity), so that a rerun reads it back,
and each march is checkpointed in the cache by :func:`fsistab.workflows.simulate` itself, so that
an interrupted point resumes where it stopped. The decreasing sweep is sequential by nature.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import xarray as xr

from fsistab.params import Case, LcoSettings, Solid, body_velocity_scale
from fsistab.progress import Progress

STATES = ("saturated", "growing", "decaying", "too short")


@dataclass(frozen=True)
class Saturation:
    """The last whole periods of an oscillating signal (module docstring): ``amplitude`` (mean
    half peak-to-peak of the last ``periods`` periods, else half the range of the signal's second
    half), angular ``frequency`` (NaN without a whole period), ``mean`` level, ``change`` (relative
    envelope change per period, NaN when too short), ``found`` whole periods in all, ``state``."""

    amplitude: float
    frequency: float
    mean: float
    change: float
    periods: int
    found: int
    state: str

    @property
    def saturated(self) -> bool:
        return self.state == "saturated"


def period_amplitudes(times: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """``(crossings, amplitudes, level)``: the upward crossings of the mid-level ``level`` (the
    middle of the range of the signal's second half), by linear interpolation between samples, and
    half the peak-to-peak range of the samples in each whole period between two crossings."""
    times, values = np.asarray(times, dtype=float), np.asarray(values, dtype=float)
    late = values[len(values) // 2 :]
    level = 0.5 * float(late.max() + late.min()) if len(late) else 0.0
    centred = values - level
    up = np.nonzero((centred[:-1] < 0) & (centred[1:] >= 0))[0]
    weight = -centred[up] / (centred[up + 1] - centred[up])
    crossings = times[up] + weight * (times[up + 1] - times[up])
    amplitudes = np.array(
        [
            0.5 * np.ptp(values[(times >= a) & (times <= b)]) if np.any((times >= a) & (times <= b)) else 0.0
            for a, b in zip(crossings[:-1], crossings[1:], strict=True)
        ]
    )
    return crossings, amplitudes, level


def saturation(times, values, periods: int = 4, tolerance: float = 0.01) -> Saturation:
    """The :class:`Saturation` of a sampled signal over its last ``periods`` whole periods, called
    saturated when the envelope changes by less than ``tolerance`` (relative) per period
    (module docstring)."""
    times, values = np.asarray(times, dtype=float), np.asarray(values, dtype=float)
    crossings, amplitudes, level = period_amplitudes(times, values)
    found = len(amplitudes)
    if found < periods or not np.all(amplitudes[-periods:] > 0):
        late = values[len(values) // 2 :]
        frequency = 2 * math.pi * found / (crossings[-1] - crossings[0]) if found else math.nan
        amplitude = 0.5 * float(np.ptp(late)) if len(late) else 0.0
        return Saturation(amplitude, frequency, level, math.nan, periods, found, "too short")
    last = amplitudes[-periods:]
    slope = np.polyfit(np.arange(periods), np.log(last), 1)[0]
    change = float(math.expm1(slope))
    state = "saturated" if abs(change) < tolerance else ("growing" if change > 0 else "decaying")
    span = crossings[-1] - crossings[-1 - periods]
    return Saturation(float(last.mean()), 2 * math.pi * periods / span, level, change, periods, found, state)


def envelope_growth(times, values) -> tuple[np.ndarray, np.ndarray]:
    """``(amplitudes, rates)``: the envelope's growth rate ``σ_k = ln(a_{k+1}/a_k)/T_k`` between
    successive whole periods (``T_k`` the time between their starts), at the amplitude
    ``√(a_k a_{k+1})``: the amplitude law ``σ(A)`` of a slowly growing or decaying oscillation,
    whose zero is a limit cycle (stable where ``dσ/dA < 0``)."""
    crossings, amplitudes, _ = period_amplitudes(times, values)
    if len(amplitudes) < 2:
        return np.zeros(0), np.zeros(0)
    spans = np.diff(crossings[:-1])
    rates = np.log(amplitudes[1:] / amplitudes[:-1]) / spans
    return np.sqrt(amplitudes[1:] * amplitudes[:-1]), rates


def onset_fit(velocities, amplitudes, saturated, threshold: float, points: int = 3) -> tuple[float, float]:
    """``(slope, U*_0)`` of ``A² = slope·(U* − U*_0)`` through the first ``points`` saturated
    points above ``threshold`` with a nonzero amplitude (least squares; NaN with fewer than two).
    A supercritical onset has ``slope > 0`` and ``U*_0`` near the threshold."""
    u, a, ok = (np.asarray(x) for x in (velocities, amplitudes, saturated))
    keep = ok.astype(bool) & (u > threshold) & (a > 0)
    u, a = u[keep][:points], a[keep][:points]
    if len(u) < 2:
        return math.nan, math.nan
    slope, intercept = np.polyfit(u, a**2, 1)
    return float(slope), float(-intercept / slope) if slope != 0 else math.nan


def classify_onset(ds: xr.Dataset, threshold: float) -> str:
    """``supercritical``, ``subcritical`` or ``undetermined`` (a stated rule): subcritical when the
    decreasing sweep holds a saturated cycle at least five times the increasing sweep's amplitude
    at the same U* (hysteresis); supercritical when the onset fit (:func:`onset_fit`) has a
    positive slope and ``U*_0`` within the sweep's spacing of the threshold (at least 5 % of it)."""
    name = _leading(ds)
    if f"decreasing_{name}" in ds:
        up, down = ds[name].values, ds[f"decreasing_{name}"].values
        held = ds[f"decreasing_{name.replace('amplitude', 'saturated')}"].values.astype(bool)
        if np.any(held & (down > 5 * np.abs(up)) & (down > 0)):
            return "subcritical"
    slope, start = ds.attrs.get("onset_slope", math.nan), ds.attrs.get("onset_velocity", math.nan)
    u = ds.reduced_velocity.values
    spacing = max(float(np.max(np.diff(u))) if len(u) > 1 else 0.0, 0.05 * abs(threshold))
    if math.isfinite(slope) and slope > 0 and abs(start - threshold) <= spacing:
        return "supercritical"
    return "undetermined"


def _leading(ds: xr.Dataset) -> str:
    """The amplitude variable of the diagram: the pitch's when the pitch moves, else the heave's."""
    return "pitch_amplitude" if "pitch" in ds.attrs.get("dofs", "") else "heave_amplitude"


# --- one march -------------------------------------------------------------------------------------


def point_identity(
    case: Case, solid: Solid, velocity: float, settings: LcoSettings, start: str | None
) -> str:
    """The JSON text identifying one point's result (checked when it is read back)."""
    from fsistab import __version__
    from fsistab.mesh import spec_for

    simulation = replace(settings.simulation, start=start)
    return json.dumps(
        {
            "case": case.tag,
            "flow": [case.flow.reynolds, case.flow.alpha0_deg],
            "mesh_key": spec_for(case).key(),
            "solid": [solid.mass_ratio, solid.freq_ratio, solid.zeta_h, solid.zeta_theta, solid.r_theta],
            "dofs": list(solid.dofs),
            "reduced_velocity": velocity,
            "simulation": {**simulation.identity(), "duration": simulation.duration},
            "saturation": [settings.periods, settings.saturation_tolerance],
            "fsistab": __version__,
        },
        sort_keys=True,
    )


def point_path(out: Path, identity: str, case: Case, velocity: float) -> Path:
    from fsistab.store import cache_key

    key = cache_key("lco-point", {"identity": identity})[:12]
    return Path(out) / "lco_points" / f"{case.tag}_{case.preset}_u{velocity:g}_{key}.nc"


def compute_point(
    case: Case,
    solid: Solid,
    velocity: float,
    settings: LcoSettings,
    cache_dir: Path,
    out: Path,
    start: str | None = None,
) -> xr.Dataset:
    """The march at U* = ``velocity`` (body convention) and its saturated amplitudes, saved to
    :func:`point_path` (a task of :func:`limit_cycles`, in-process or on a dask worker).
    Idempotent: a finished point's file is read back (attribute ``from_file``)."""
    import time

    from fsistab import workflows
    from fsistab.store import read_cached, write_dataset

    identity = point_identity(case, solid, velocity, settings, start)
    path = point_path(out, identity, case, velocity)
    finished = read_cached(path, expect={"point_identity": identity})
    if finished is not None:
        return finished.assign_attrs(from_file=1)
    t0 = time.perf_counter()
    moving = replace(solid, reduced_velocity=velocity / body_velocity_scale(case.kind))
    simulation = replace(settings.simulation, start=start)
    runs = Path(out) / "lco_runs" / path.stem
    result = workflows.simulate(case, moving, simulation, cache_dir, runs, progress=lambda message: None)
    ds = point_dataset(result.dataset, velocity, settings)
    ds.attrs.update(point_identity=identity, point_seconds=time.perf_counter() - t0)
    write_dataset(ds, path)
    return ds.assign_attrs(point_file=str(path))


def point_dataset(series: xr.Dataset, velocity: float, settings: LcoSettings) -> xr.Dataset:
    """The saturated oscillation of one march's time series (:func:`saturation` of the heave, the
    pitch and the lift coefficient), as scalars."""
    t = series.time.values
    data = {"reduced_velocity": velocity}
    for name, signal in (("heave", "heave"), ("pitch", "pitch"), ("lift", "lift_coefficient")):
        s = saturation(t, series[signal].values, settings.periods, settings.saturation_tolerance)
        data |= {
            f"{name}_amplitude": s.amplitude,
            f"{name}_frequency": s.frequency,
            f"{name}_mean": s.mean,
            f"{name}_change": s.change,
            f"{name}_saturated": int(s.saturated),
            f"{name}_state": s.state,
            f"{name}_periods": s.found,
        }
    keep = ("ndof", "steps", "factorisations", "seconds_per_step", "checkpoint", "netcdf", "dofs")
    attrs = {k: series.attrs[k] for k in keep if k in series.attrs}
    attrs["duration"] = float(t[-1])
    return xr.Dataset({k: ((), v) for k, v in data.items()}, attrs=attrs)


# --- the sweep -------------------------------------------------------------------------------------


def _run_increasing(case, solid, settings, cache_dir, out, client, say) -> list[xr.Dataset | str]:
    """The increasing sweep: one task per U* (in order, or on ``client``); a failed point is its
    one-line error."""
    from fsistab.study import _one_line

    velocities = settings.velocities()
    results: dict[float, xr.Dataset | str] = {}
    if client is None:
        for u in velocities:
            try:
                results[u] = compute_point(case, solid, u, settings, cache_dir, out)
            except Exception as exc:  # a failed point is reported; the others go on
                results[u] = _one_line(exc)
            say(f"U* = {u:g}: {_outcome(results[u])} ({len(results)}/{len(velocities)})")
        return [results[u] for u in velocities]
    from distributed import as_completed

    futures = {
        client.submit(
            compute_point,
            case,
            solid,
            u,
            settings,
            cache_dir,
            out,
            key=f"fsistab-lco-{case.tag}-{u!r}-{id(out)}",
            pure=False,
        ): u
        for u in velocities
    }
    for future in as_completed(list(futures)):
        u = futures[future]
        try:
            results[u] = future.result()
        except Exception as exc:  # a task's error (or a worker lost repeatedly): report, go on
            results[u] = _one_line(exc)
        finally:
            future.release()
        say(f"U* = {u:g}: {_outcome(results[u])} ({len(results)}/{len(velocities)})")
    return [results[u] for u in velocities]


def _outcome(result) -> str:
    if isinstance(result, str):
        return f"FAILED: {result}"
    name = "pitch" if "pitch" in result.attrs.get("dofs", "") else "heave"
    return (
        f"{name} amplitude {float(result[f'{name}_amplitude']):.4g}, "
        f"{result[f'{name}_state'].item()} (envelope {float(result[f'{name}_change']):+.2g} per period)"
    )


def _run_decreasing(case, solid, settings, cache_dir, out, top, client, say) -> list[xr.Dataset | str]:
    """The decreasing sweep from the saturated march at the highest U* (``top``): each march starts
    from the last state of the one above (its checkpoint)."""
    from fsistab.study import _one_line

    velocities = settings.velocities()
    results: list[xr.Dataset | str] = [top]
    for u in reversed(velocities[:-1]):
        previous = results[-1]
        if isinstance(previous, str):
            results.append("no saturated state above to start from")
            continue
        start = previous.attrs["checkpoint"]
        try:
            if client is None:
                results.append(compute_point(case, solid, u, settings, cache_dir, out, start))
            else:
                results.append(
                    client.submit(compute_point, case, solid, u, settings, cache_dir, out, start).result()
                )
        except Exception as exc:
            results.append(_one_line(exc))
        say(f"decreasing U* = {u:g}: {_outcome(results[-1])}")
    return results[::-1]


def _stack(velocities, results, prefix: str = "") -> dict:
    """The points' scalars as variables along ``reduced_velocity`` (NaN, state ``failed``, for a
    failed point)."""
    template = next((r for r in results if not isinstance(r, str)), None)
    if template is None:
        return {f"{prefix}error": ("reduced_velocity", np.array(results, dtype=str))}
    data = {}
    for name in template.data_vars:
        if name == "reduced_velocity":
            continue
        text = template[name].dtype.kind in "US"
        column = [("failed" if text else np.nan) if isinstance(r, str) else r[name].item() for r in results]
        data[f"{prefix}{name}"] = ("reduced_velocity", np.array(column, dtype=str if text else float))
    data[f"{prefix}error"] = (
        "reduced_velocity",
        np.array([r if isinstance(r, str) else "" for r in results]),
    )
    return data


def _thresholds(case, solid, settings, mass_ratio, cache_dir, say) -> np.ndarray:
    """The linear thresholds along U* over the sweep's range (widened by 20 % each way) at the
    same mesh: :func:`fsistab.workflows.critical_points`."""
    from fsistab import workflows
    from fsistab.params import SweepSettings

    low, high = settings.velocity_range
    sweep = SweepSettings((0.8 * low, 1.2 * high), 24, None, mass_ratio)
    ds = workflows.critical_points(case, solid, sweep, cache_dir, None, progress=say)
    return (
        np.sort(ds.reduced_velocity.values[ds.kind.values != "divergence"])
        if ds.sizes.get("threshold")
        else np.zeros(0)
    )


def limit_cycles(
    case: Case,
    solid: Solid,
    settings: LcoSettings,
    mass_ratio: float,
    cache_dir: Path,
    out: Path,
    client=None,
    progress: Progress = None,
    thresholds: bool = True,
) -> xr.Dataset:
    """The bifurcation diagram of ``fsistab lco`` (module docstring): the saturated amplitudes
    and frequencies of heave, pitch and lift at each U* of ``settings`` (body conventions,
    ``mass_ratio`` the body's for the thresholds), the decreasing sweep's with ``hysteresis``,
    the linear thresholds of the same mesh (``thresholds``), the onset fit and class. Written to
    ``out/lco_{tag}_{preset}_{key}.nc`` (path in attribute ``data``)."""
    import time

    from fsistab.store import cache_key, write_dataset

    say = progress if progress is not None else (lambda message: None)
    t0 = time.perf_counter()
    velocities = settings.velocities()
    say(
        f"{len(velocities)} marches of {settings.simulation.duration:g} time units, "
        f"U* from {velocities[0]:g} to {velocities[-1]:g}"
    )
    increasing = _run_increasing(case, solid, settings, cache_dir, out, client, say)
    data = _stack(velocities, increasing)
    if settings.hysteresis and len(velocities) > 1:
        data |= _stack(
            velocities,
            _run_decreasing(case, solid, settings, cache_dir, out, increasing[-1], client, say),
            "decreasing_",
        )
    critical = _thresholds(case, solid, settings, mass_ratio, cache_dir, say) if thresholds else np.zeros(0)
    done = [r for r in increasing if not isinstance(r, str)]
    first = done[0].attrs if done else {}
    ds = xr.Dataset(data, coords={"reduced_velocity": np.array(velocities)})
    ds = ds.assign(threshold_velocity=("threshold", critical))
    ds.attrs.update(
        body=case.kind,
        reynolds=case.flow.reynolds,
        alpha0_deg=case.flow.alpha0_deg,
        preset=case.preset,
        mass_ratio=mass_ratio,
        dofs=",".join(solid.dofs) or "none",
        time_step=settings.simulation.time_step,
        duration=settings.simulation.duration,
        perturbation=settings.simulation.perturbation,
        periods=settings.periods,
        saturation_tolerance=settings.saturation_tolerance,
        ndof=int(first.get("ndof", 0)),
        failed=sum(isinstance(r, str) for r in increasing),
        computed=sum(not isinstance(r, str) and not r.attrs.get("from_file") for r in increasing),
        seconds=time.perf_counter() - t0,
        execution="in-process" if client is None else "dask.distributed",
        saturation_rule="saturated: |envelope change per period| < tolerance over the last periods",
        conventions="U* and m in the body's conventions (docs/model.md §2, §10); amplitudes: heave in L, "
        "pitch in rad, half peak-to-peak; frequencies in U/L",
    )
    name = _leading(ds)
    if len(critical) and name in ds:
        slope, start = onset_fit(
            ds.reduced_velocity, ds[name], ds[name.replace("amplitude", "saturated")], critical[0]
        )
        ds.attrs.update(
            onset_slope=slope,
            onset_velocity=start,
            onset=classify_onset(ds.assign_attrs(onset_slope=slope, onset_velocity=start), critical[0]),
        )
    else:
        onset = "no threshold in the range" if not len(critical) else "undetermined (no march finished)"
        ds.attrs.update(onset_slope=math.nan, onset_velocity=math.nan, onset=onset)
    key = cache_key(
        "lco",
        {
            "tag": case.tag,
            "velocities": list(velocities),
            "settings": point_identity(case, solid, 0.0, settings, None),
        },
    )[:10]
    path = write_dataset(ds, Path(out) / f"lco_{case.tag}_{case.preset}_{key}.nc")
    return ds.assign_attrs(data=str(path))
