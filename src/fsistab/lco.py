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
  ``P`` period amplitudes, the angular frequency ``2πP`` over their span;
* it is **modulated** (beating, quasi-periodic), whatever ``r``, when over the whole periods of the
  record's second half (at least ``2P`` of them) the envelope both rises and falls by more than
  the tolerance from one period to the next: four periods at the top of a slow modulation look
  saturated. Its amplitude and frequency are then those of the second half's periods. For every
  state the smallest and largest period amplitudes of that window and the largest excursion from
  the mid-level over the second half (the measure of published VIV amplitude curves) are kept;
* a march from the perturbed steady state is ``transient``, not saturated, when the envelope test
  cannot tell a cycle from the linear transient (:func:`left_linear_transient`): the linear growth
  per period ``|e^{σ₀T₀} − 1|`` of the start mode is below the tolerance (near a threshold σ₀ → 0 and
  the linear transient passes the envelope test), or the amplitude is within a factor
  ``START_FACTOR`` of the first whole period's (the march has not left its start).

The bifurcation diagram is these amplitudes against U* with the linear thresholds of the same mesh
(:func:`fsistab.workflows.critical_points`, docs/model.md §8). Near a supercritical (Hopf) onset
``A² ∝ U* − U*_c``: a straight line through the first saturated points past the threshold meets
zero at ``U*_0 ≈ U*_c`` (:func:`onset_fit`). A subcritical onset shows as hysteresis: the sweep by
decreasing U*, each march started from the last state of the one above (a start that was not
saturated is flagged, variable ``decreasing_start_state``), stays on a large cycle where the
increasing sweep decays to the steady state (:func:`classify_onset`).

Only the march's records up to the duration asked are read (the march cache is shared by every
duration, docs/simulation.md); a march found run beyond it is not chained from, since its
checkpoint holds the state at its own end.

Execution: each U* of the increasing sweep is one task, in this process or on a
``dask.distributed`` client (:func:`fsistab.study.study_client`); each finished point is saved
as ``out/lco_points/<tag>_<preset>_u<U*>_<key>.nc`` (checksummed, with its identity), so that a
rerun reads it back, and each march is checkpointed in the cache by
:func:`fsistab.workflows.simulate` itself, so that an interrupted point resumes where it stopped.
The decreasing sweep is sequential by nature.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import xarray as xr
from scipy.optimize import least_squares

from fsistab.params import Case, LcoSettings, Solid, body_velocity_scale
from fsistab.progress import Progress

STATES = ("saturated", "modulated", "growing", "decaying", "too short", "transient")

# A march from the perturbed steady state whose amplitude stays within this factor of its first
# whole period's has not left its start: it is no cycle, whatever its envelope (module docstring).
START_FACTOR = 2.0


@dataclass(frozen=True)
class Saturation:
    """The last whole periods of an oscillating signal (module docstring): ``amplitude`` (mean
    half peak-to-peak of the last ``periods`` periods, else half the range of the signal's second
    half), angular ``frequency`` (NaN without a whole period), ``mean`` level, ``change`` (relative
    envelope change per period, NaN when too short), ``found`` whole periods in all, ``state``,
    ``first`` the first whole period's amplitude (NaN without one); ``low`` and ``high`` the
    smallest and largest period amplitudes of the second half's whole periods (of the last
    ``periods`` if it has fewer), ``largest`` the largest ``|value - mean|`` over the second half."""

    amplitude: float
    frequency: float
    mean: float
    change: float
    periods: int
    found: int
    state: str
    first: float = math.nan
    low: float = math.nan
    high: float = math.nan
    largest: float = math.nan

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
    saturated when the envelope changes by less than ``tolerance`` (relative) per period, modulated
    when it rises and falls by more over the second half (module docstring)."""
    times, values = np.asarray(times, dtype=float), np.asarray(values, dtype=float)
    crossings, amplitudes, level = period_amplitudes(times, values)
    found = len(amplitudes)
    first = float(amplitudes[0]) if found else math.nan
    late = values[len(values) // 2 :]
    largest = float(np.max(np.abs(late - level))) if len(late) else 0.0
    if found < periods or not np.all(amplitudes[-periods:] > 0):
        frequency = 2 * math.pi * found / (crossings[-1] - crossings[0]) if found else math.nan
        amplitude = 0.5 * float(np.ptp(late)) if len(late) else 0.0
        return Saturation(
            amplitude, frequency, level, math.nan, periods, found, "too short", first, largest=largest
        )
    last = amplitudes[-periods:]
    slope = np.polyfit(np.arange(periods), np.log(last), 1)[0]
    change = float(math.expm1(slope))
    state = "saturated" if abs(change) < tolerance else ("growing" if change > 0 else "decaying")
    span = crossings[-1] - crossings[-1 - periods]
    frequency, amplitude = 2 * math.pi * periods / span, float(last.mean())
    second = crossings[:-1] >= 0.5 * (times[0] + times[-1])  # the second half's whole periods
    window = amplitudes[second] if second.sum() >= periods else last
    if len(window) >= 2 * periods and np.all(window > 0):
        steps = np.diff(np.log(window))
        if steps.max() > math.log1p(tolerance) and steps.min() < -math.log1p(tolerance):
            state, amplitude = "modulated", float(window.mean())
            frequency = 2 * math.pi * len(window) / (crossings[-1] - crossings[-1 - len(window)])
    low, high = float(window.min()), float(window.max())
    return Saturation(amplitude, frequency, level, change, periods, found, state, first, low, high, largest)


def left_linear_transient(s: Saturation, growth_rate: float, frequency: float, tolerance: float) -> bool:
    """Whether a march from the steady state plus a perturbation of the mode ``growth_rate +
    i frequency`` can be called saturated (module docstring): the mode's linear growth per period
    ``|e^{σ₀·2π/ω₀} − 1|`` must reach ``tolerance`` (below it the linear transient itself passes the
    envelope test, as it does near a threshold), and the amplitude must have left the start, beyond
    a factor :data:`START_FACTOR` of the first whole period's either way (a cycle reached from a small
    perturbation has grown or decayed to it). docs/simulation.md, "Limit-cycle amplitudes"."""
    if not (math.isfinite(growth_rate) and math.isfinite(frequency) and frequency > 0):
        return True  # no start mode recorded: a given start state, judged by its envelope alone
    linear = abs(math.expm1(growth_rate * 2 * math.pi / frequency))
    ratio = s.amplitude / s.first if s.first > 0 else math.inf
    return linear >= tolerance and not (1 / START_FACTOR < ratio < START_FACTOR)


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


def half_period_peaks(times, values, level: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """``(times, peaks)``: the largest ``|v − level|`` between each pair of successive crossings of
    ``level``, placed by the parabola through the largest sample and its two neighbours (the peak
    between samples: the sampled maximum of a sinusoid misses it by about ``(ωΔt)²/8`` relative,
    which would differ between two time steps being compared). Only half periods closed by a
    crossing on both sides are counted. Twice as many amplitude samples as whole periods give: the
    measure of docs/simulation.md's time-step and mesh checks of a slowly changing envelope."""
    times, centred = np.asarray(times, dtype=float), np.asarray(values, dtype=float) - level
    crossings = np.nonzero(np.diff(np.sign(centred)) != 0)[0]
    at, peaks = [], []
    for start, end in zip(crossings[:-1], crossings[1:], strict=True):
        k = start + 1 + int(np.argmax(np.abs(centred[start + 1 : end + 1])))  # 1 <= k <= end <= len - 2
        y0, y1, y2 = centred[k - 1 : k + 2] * np.sign(centred[k])
        curvature = y0 - 2 * y1 + y2
        shift = 0.5 * (y0 - y2) / curvature if curvature < 0 else 0.0
        at.append(times[k] + shift * (times[k + 1] - times[k - 1]) / 2)
        peaks.append(y1 - 0.25 * (y0 - y2) * shift)
    return np.array(at), np.array(peaks)


@dataclass(frozen=True)
class Envelope:
    """A settling envelope fitted to a march's half-period peaks (:func:`envelope_limit`):
    ``A(t) = limit + e^{rate·τ}(c cos(frequency·τ) + s sin(frequency·τ))``, ``τ = t − end``, over
    the ``count`` peaks of ``start``–``end``; ``limit_error`` is the limit's standard error from the
    fit's residual ``rms``, ``swing = √(c² + s²)`` the modulation's size at ``end``."""

    limit: float
    limit_error: float
    rate: float
    frequency: float
    coefficients: tuple[float, float]
    rms: float
    count: int
    start: float
    end: float

    @property
    def swing(self) -> float:
        return math.hypot(*self.coefficients)

    def __call__(self, times) -> np.ndarray:
        """The fitted envelope at ``times`` (beyond ``end``: its extrapolation)."""
        tau = np.asarray(times, dtype=float) - self.end
        return self.limit + _modulation(tau, self.rate, self.frequency) @ np.asarray(self.coefficients)


def _modulation(tau: np.ndarray, rate: float, frequency: float) -> np.ndarray:
    decay = np.exp(rate * tau)
    return np.column_stack([decay * np.cos(frequency * tau), decay * np.sin(frequency * tau)])


def envelope_limit(times, peaks) -> Envelope:
    """The level a slowly settling oscillation tends to, from its half-period peaks
    (:func:`half_period_peaks`): near a stable limit cycle the amplitude's departure from it decays
    as the cycle's slowest Floquet pair, ``A(t) → limit + Re(b e^{(rate + i·frequency)t})``, a
    modulation of the envelope much slower than the oscillation itself. The model is linear in
    ``(limit, c, s)`` and these are solved for at each ``(rate, frequency)`` (variable projection),
    the two searched by least squares from several starts (modulation periods from twice the
    peaks' span down to six peak spacings). Meaningful when ``rate < 0`` and the peaks span at
    least about one modulation; the peaks given should start after the release's own transient,
    and a fit is tested by predicting later peaks (docs/how-to/limit-cycles.md; docs/simulation.md,
    check d). ValueError with fewer than eight peaks."""
    times, peaks = np.asarray(times, dtype=float), np.asarray(peaks, dtype=float)
    if len(peaks) < 8:
        raise ValueError(f"an envelope fit needs at least eight half-period peaks, got {len(peaks)}")
    tau, span = times - times[-1], times[-1] - times[0]

    def solve(params):
        columns = np.column_stack([np.ones_like(tau), _modulation(tau, *params)])
        coefficients, *_ = np.linalg.lstsq(columns, peaks, rcond=None)
        return columns, coefficients

    def residual(params):
        columns, coefficients = solve(params)
        return columns @ coefficients - peaks

    spacing = span / (len(peaks) - 1)
    starts = [
        (rate, frequency)
        for frequency in np.geomspace(math.pi / span, math.pi / (3 * spacing), 6)
        for rate in (-4 / span, -1 / span, 0.0)
    ]
    best = min((least_squares(residual, start) for start in starts), key=lambda fit: fit.cost)
    columns, (limit, c, s) = solve(best.x)
    rate, frequency = best.x
    # the full model's Jacobian in (limit, c, s, rate, frequency), for the limit's standard error
    full = np.column_stack(
        [columns, tau * (columns[:, 1:] @ [c, s]), tau * (s * columns[:, 1] - c * columns[:, 2])]
    )
    variance = 2 * best.cost / max(len(peaks) - 5, 1)
    covariance = np.linalg.pinv(full.T @ full) * variance
    return Envelope(
        float(limit),
        float(math.sqrt(max(covariance[0, 0], 0.0))),
        float(rate),
        float(abs(frequency)),
        (float(c), float(s) * (1 if frequency >= 0 else -1)),
        float(math.sqrt(2 * best.cost / len(peaks))),
        len(peaks),
        float(times[0]),
        float(times[-1]),
    )


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
    """``supercritical``, ``subcritical`` or ``undetermined`` (a stated rule, docs/simulation.md,
    "Limit-cycle amplitudes"): subcritical when, at a U* below the linear threshold where the
    increasing sweep settled (``decaying``, or ``saturated``), the decreasing sweep holds a saturated
    cycle at least five times the increasing sweep's amplitude (hysteresis: just above a
    supercritical onset the increasing march is still ``growing``, which is no evidence of it);
    supercritical when the onset fit (:func:`onset_fit`) has a positive slope and ``U*_0`` within
    the sweep's spacing of the threshold (at least 5 % of it)."""
    name = _leading(ds)
    prefix = name.removesuffix("_amplitude")
    u = ds.reduced_velocity.values
    if f"decreasing_{name}" in ds:
        up, down = ds[name].values, ds[f"decreasing_{name}"].values
        held = ds[f"decreasing_{prefix}_saturated"].values == 1
        state = ds[f"{prefix}_state"].values.astype(str)
        settled = (state == "decaying") | (state == "saturated")
        if np.any(held & settled & (u < threshold) & (down > 5 * np.abs(up)) & (down > 0)):
            return "subcritical"
    slope, start = ds.attrs.get("onset_slope", math.nan), ds.attrs.get("onset_velocity", math.nan)
    spacing = max(float(np.max(np.diff(u))) if len(u) > 1 else 0.0, 0.05 * abs(threshold))
    if math.isfinite(slope) and slope > 0 and abs(start - threshold) <= spacing:
        return "supercritical"
    return "undetermined"


def start_mode_warning(ds: xr.Dataset) -> str:
    """Why a sweep may not show the cycle past its first linear threshold: the marches there that
    started from a decaying mode ('' if none). With coupled-mode flutter the two solid modes form a
    pair of nearly equal frequency, one growing and one decaying past the threshold; a shift
    between them picks either, and a release of the decaying one settles back before the growing
    one takes over, if it does within the march (docs/how-to/limit-cycles.md)."""
    if "start_growth_rate" not in ds or not ds.threshold_velocity.size:
        return ""
    u, rate = ds.reduced_velocity.values, ds.start_growth_rate.values
    past = (u > float(ds.threshold_velocity.values[0])) & (rate < 0)  # NaN (a given start): never
    if not past.any():
        return ""
    listed = ", ".join(
        f"{v:g} (λ = {r:+.3g}, ω = {w:.4g})"
        for v, r, w in zip(u[past], rate[past], ds.start_frequency.values[past], strict=True)
    )
    return (
        f"past the linear threshold U*_c = {float(ds.threshold_velocity.values[0]):.5g} the marches "
        f"at U* = {listed} started from a decaying mode: the shift may have picked the damped "
        "partner of the flutter mode; move --shift to the growing one's side"
    )


def signals(ds: xr.Dataset) -> list[str]:
    """The signals of a diagram, the leading one first: the pitch when it moves, the heave when it
    moves, else (a fixed body) the lift coefficient (the diagram, the report and the onset read
    the first)."""
    dofs = ds.attrs.get("dofs", "")
    return [n for n in ("pitch", "heave") if n in dofs] or ["lift"]


def _leading(ds: xr.Dataset) -> str:
    """The amplitude variable of the leading signal (:func:`signals`)."""
    return f"{signals(ds)[0]}_amplitude"


# --- one march -------------------------------------------------------------------------------------


def _moving(case: Case, solid: Solid, velocity: float) -> Solid:
    """The solid at U* = ``velocity`` (body convention, docs/model.md §10)."""
    return replace(solid, reduced_velocity=velocity / body_velocity_scale(case.kind))


def point_identity(
    case: Case, solid: Solid, velocity: float, settings: LcoSettings, start: str | None
) -> str:
    """The JSON text identifying one point's result (checked when it is read back): the march's own
    identity (:func:`fsistab.workflows._simulation_identity`: flow, mesh and sponge, every solid
    parameter, step, start), the duration read and the saturation test."""
    from fsistab import __version__, workflows

    simulation = replace(settings.simulation, start=start)
    return json.dumps(
        {
            "case": case.tag,
            "preset": case.preset,
            "march": workflows._simulation_identity(case, _moving(case, solid, velocity), simulation),
            "reduced_velocity": velocity,
            "duration": simulation.duration,
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
    """The march at U* = ``velocity`` (body convention) from ``start`` (None: the settings' own
    start, ``--start`` or the perturbed steady state) and its saturated amplitudes, saved to
    :func:`point_path` (a task of :func:`limit_cycles`, in-process or on a dask worker).
    Idempotent: a finished point's file is read back (attribute ``from_file``)."""
    import time

    from fsistab import workflows
    from fsistab.mesh import NGSOLVE_LOCK
    from fsistab.store import read_cached, write_dataset

    start = settings.simulation.start if start is None else start
    identity = point_identity(case, solid, velocity, settings, start)
    path = point_path(out, identity, case, velocity)
    finished = read_cached(path, expect={"point_identity": identity})
    if finished is not None:
        return finished.assign_attrs(from_file=1)
    t0 = time.perf_counter()
    simulation = replace(settings.simulation, start=start)
    runs = Path(out) / "lco_runs" / path.stem
    moving = _moving(case, solid, velocity)
    with NGSOLVE_LOCK:  # one march at a time on a dask worker with several threads
        result = workflows.simulate(case, moving, simulation, cache_dir, runs, progress=lambda message: None)
    ds = point_dataset(result.dataset, velocity, settings)
    ds.attrs.update(point_identity=identity, point_seconds=time.perf_counter() - t0)
    write_dataset(ds, path)
    return ds.assign_attrs(point_file=str(path))


def point_dataset(series: xr.Dataset, velocity: float, settings: LcoSettings) -> xr.Dataset:
    """The saturated oscillation of one march's time series up to the duration asked (the march
    cache is shared by every duration, so its records may go further), by :func:`saturation` of
    the heave, the pitch and the lift coefficient and, from a perturbed start, the test
    :func:`left_linear_transient` (not for a body released at a finite amplitude,
    ``--perturbation-of heave|pitch``: no linear transient, judged by its envelope alone, as a given
    start), as scalars. ``march_end`` is where the records end."""
    simulation = settings.simulation
    t_all = series.time.values
    kept = series.isel(time=t_all <= simulation.duration + 0.5 * simulation.time_step)
    t = kept.time.values
    start = (series.attrs.get("start_growth_rate", math.nan), series.attrs.get("start_frequency", math.nan))
    mode = start
    if series.attrs.get("perturbation_of", "largest") != "largest":
        mode = (math.nan, math.nan)  # a body released at a finite amplitude: judged by its envelope
    # the mode the march started from, kept whatever the start (NaN from a given state): a sweep
    # shows which branch its shift picked at each U* (start_mode_warning)
    data = {"reduced_velocity": velocity, "start_growth_rate": start[0], "start_frequency": start[1]}
    for name, signal in (("heave", "heave"), ("pitch", "pitch"), ("lift", "lift_coefficient")):
        s = saturation(t, kept[signal].values, settings.periods, settings.saturation_tolerance)
        if s.saturated and not left_linear_transient(s, *mode, settings.saturation_tolerance):
            s = replace(s, state="transient")
        data |= {
            f"{name}_amplitude": s.amplitude,
            f"{name}_frequency": s.frequency,
            f"{name}_mean": s.mean,
            f"{name}_change": s.change,
            f"{name}_saturated": int(s.saturated),
            f"{name}_state": s.state,
            f"{name}_periods": s.found,
            f"{name}_low": s.low,
            f"{name}_high": s.high,
            f"{name}_largest": s.largest,
        }
    keep = ("ndof", "steps", "factorisations", "seconds_per_step", "checkpoint", "netcdf", "dofs")
    attrs = {k: series.attrs[k] for k in keep if k in series.attrs}
    attrs |= {k: float(v) for k, v in zip(("start_growth_rate", "start_frequency"), mode, strict=True)}
    attrs |= {"duration": float(t[-1]), "march_end": float(t_all[-1])}
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


def _state(result: xr.Dataset) -> str:
    """The state of the leading signal of one point (:func:`_leading`)."""
    return str(result[_leading(result).replace("_amplitude", "_state")].item())


def _outcome(result) -> str:
    if isinstance(result, str):
        return f"FAILED: {result}"
    name = _leading(result).removesuffix("_amplitude")
    return (
        f"{name} amplitude {float(result[f'{name}_amplitude']):.4g}, "
        f"{result[f'{name}_state'].item()} (envelope {float(result[f'{name}_change']):+.2g} per period)"
    )


def _chain_start(previous, settings: LcoSettings) -> tuple[str | None, str]:
    """``(checkpoint, state)`` to start the next march of the decreasing sweep from, or ``(None,
    reason)``: no point above, or a march above whose records go beyond the duration (an earlier,
    longer run of the same march): its checkpoint holds the state at its own end, not at the
    duration its amplitudes were read to (module docstring)."""
    if isinstance(previous, str):
        return None, "no state above to start from"
    simulation = settings.simulation
    end = float(previous.attrs.get("march_end", previous.attrs.get("duration", 0.0)))
    if end > simulation.duration + 0.5 * simulation.time_step:
        return None, (
            f"the march above was run to t = {end:g} before, beyond --duration {simulation.duration:g}: "
            f"its checkpoint holds the state at t = {end:g}; give --duration {end:g} to chain from it"
        )
    return str(previous.attrs["checkpoint"]), _state(previous)


def _run_decreasing(case, solid, settings, cache_dir, out, top, client, say) -> list[xr.Dataset | str]:
    """The decreasing sweep from the march at the highest U* (``top``): each march starts from the
    last state of the one above (its checkpoint, :func:`_chain_start`), that march's state kept as
    ``start_state`` (a start that was not saturated is so flagged)."""
    from fsistab.study import _one_line

    velocities = settings.velocities()
    results: list[xr.Dataset | str] = [top if isinstance(top, str) else top.assign(start_state="not chained")]
    for u in reversed(velocities[:-1]):
        start, state = _chain_start(results[-1], settings)
        if start is None:
            results.append(state)
            continue
        try:
            if client is None:
                point = compute_point(case, solid, u, settings, cache_dir, out, start)
            else:
                point = client.submit(compute_point, case, solid, u, settings, cache_dir, out, start).result()
            results.append(point.assign(start_state=state))
        except Exception as exc:
            results.append(_one_line(exc))
        say(f"decreasing U* = {u:g} (from a {state} state): {_outcome(results[-1])}")
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
        column = [_scalar(r, name, "failed" if text else np.nan) for r in results]
        data[f"{prefix}{name}"] = ("reduced_velocity", np.array(column, dtype=str if text else float))
    data[f"{prefix}error"] = (
        "reduced_velocity",
        np.array([r if isinstance(r, str) else "" for r in results]),
    )
    return data


def _scalar(result, name: str, missing):
    """One point's scalar ``name``: ``missing`` for a failed point, or for a point file written
    before that field was."""
    return missing if isinstance(result, str) or name not in result else result[name].item()


def threshold_sweep(settings: LcoSettings, mass_ratio: float):
    """The :class:`fsistab.params.SweepSettings` of the linear thresholds beside the diagram: the
    sweep's range widened by 20 % each way, at ``mass_ratio`` (built before any march, so that
    bad input is refused before the work)."""
    from fsistab.params import LCO_THRESHOLD_MARGIN, SweepSettings

    low, high = settings.velocity_range
    margin = LCO_THRESHOLD_MARGIN
    return SweepSettings(((1 - margin) * low, (1 + margin) * high), 24, None, mass_ratio)


def _thresholds(case, solid, sweep, cache_dir, say) -> tuple[np.ndarray, str]:
    """``(onsets, problem)``: the linear onsets (``boundary`` onset, not divergence) along U* of
    :func:`fsistab.workflows.critical_points` at the same mesh, or none and the one-line reason the
    search failed (the marches' diagram is kept, not lost to it)."""
    from fsistab import workflows
    from fsistab.study import _one_line

    try:
        ds = workflows.critical_points(case, solid, sweep, cache_dir, None, progress=say)
    except Exception as exc:  # reported in the diagram's onset, which stays undetermined
        problem = f"threshold search failed: {_one_line(exc)}"
        say(problem)
        return np.zeros(0), problem
    if not ds.sizes.get("threshold"):
        return np.zeros(0), ""
    keep = (ds.kind.values != "divergence") & (ds.boundary.values == "onset")
    return np.sort(ds.reduced_velocity.values[keep]), ""


def _attributes(case, solid, settings, mass_ratio, points, client) -> dict:
    """The diagram's provenance: flow, mesh and sponge, every solid parameter
    (:func:`fsistab.workflows._solid_attrs`), the march and saturation settings, and the counts of
    both sweeps' marches (``points``, a failed one its error text)."""
    from fsistab.workflows import _solid_attrs

    simulation = settings.simulation
    done = [r for r in points if not isinstance(r, str)]
    shift = "default" if simulation.shift is None else f"{simulation.shift.real!r}{simulation.shift.imag:+}j"
    return {
        "body": case.kind,
        "preset": case.preset,
        **_solid_attrs(case, solid),
        "mass_ratio": mass_ratio,
        "dofs": ",".join(solid.dofs) or "none",
        "time_step": simulation.time_step,
        "duration": simulation.duration,
        "perturbation": simulation.perturbation,
        "perturbation_of": simulation.perturbation_of,
        "shift": shift,
        "start": "none" if simulation.start is None else str(simulation.start),
        "step_tolerance": simulation.tolerance,
        "max_step_iterations": simulation.max_iterations,
        "periods": settings.periods,
        "saturation_tolerance": settings.saturation_tolerance,
        "hysteresis": int(settings.hysteresis),
        "ndof": int(done[0].attrs.get("ndof", 0)) if done else 0,
        "failed": len(points) - len(done),
        "computed": sum(not r.attrs.get("from_file") for r in done),
        "execution": "in-process" if client is None else "dask.distributed",
        "saturation_rule": "saturated: |envelope change per period| < tolerance over the last periods and, "
        f"from a perturbed start, the start mode's linear change per period >= tolerance and the "
        f"amplitude beyond a factor {START_FACTOR:g} of the first period's (else transient)",
        "conventions": "U* and m in the body's conventions (docs/model.md §2, §10); amplitudes: heave in L, "
        "pitch in rad, half peak-to-peak; frequencies in U/L",
    }


def _onset(ds: xr.Dataset, critical: np.ndarray, problem: str) -> dict:
    """The onset fit and class at the first linear threshold (:func:`onset_fit`,
    :func:`classify_onset`), or why there is none."""
    name = _leading(ds)
    if problem or not len(critical) or name not in ds:
        reason = problem or ("no threshold in the range" if not len(critical) else "no march finished")
        onset = reason if reason == "no threshold in the range" else f"undetermined ({reason})"
        return {"onset_slope": math.nan, "onset_velocity": math.nan, "onset": onset}
    saturated = ds[name.replace("amplitude", "saturated")]
    slope, start = onset_fit(ds.reduced_velocity, ds[name], saturated, critical[0])
    onset = classify_onset(ds.assign_attrs(onset_slope=slope, onset_velocity=start), critical[0])
    return {"onset_slope": slope, "onset_velocity": start, "onset": onset}


def diagram_path(out: Path, case: Case, solid: Solid, settings: LcoSettings, thresholds: bool) -> Path:
    """``out/lco_{tag}_{preset}_{key}.nc``: the key covers every march's identity, the U*, the
    hysteresis sweep and the thresholds (runs that differ in any never overwrite each other)."""
    from fsistab.store import cache_key

    velocities = settings.velocities()
    inputs = {
        "tag": case.tag,
        "velocities": list(velocities),
        "settings": point_identity(case, solid, velocities[0], settings, settings.simulation.start),
        "hysteresis": settings.hysteresis,
        "thresholds": thresholds,
    }
    return Path(out) / f"lco_{case.tag}_{case.preset}_{cache_key('lco', inputs)[:10]}.nc"


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
    :func:`diagram_path` (path in attribute ``data``)."""
    import time

    from fsistab.store import write_dataset

    say = progress if progress is not None else (lambda message: None)
    t0 = time.perf_counter()
    sweep = threshold_sweep(settings, mass_ratio) if thresholds else None  # refused before any march
    velocities = settings.velocities()
    duration, first, last = settings.simulation.duration, velocities[0], velocities[-1]
    if len(velocities) == 1:
        say(f"1 march of {duration:g} time units, U* = {first:g}")
    else:
        say(f"{len(velocities)} marches of {duration:g} time units, U* from {first:g} to {last:g}")
    increasing = _run_increasing(case, solid, settings, cache_dir, out, client, say)
    data, decreasing = _stack(velocities, increasing), []
    if settings.hysteresis and len(velocities) > 1:
        decreasing = _run_decreasing(case, solid, settings, cache_dir, out, increasing[-1], client, say)
        data |= _stack(velocities, decreasing, "decreasing_")
    critical, problem = np.zeros(0), "" if thresholds else "thresholds not computed: --no-thresholds"
    if sweep is not None:
        critical, problem = _thresholds(case, solid, sweep, cache_dir, say)
    ds = xr.Dataset(data, coords={"reduced_velocity": np.array(velocities)})
    ds = ds.assign(threshold_velocity=("threshold", critical))
    # the decreasing sweep's top is the increasing sweep's last march: counted once
    ds.attrs.update(_attributes(case, solid, settings, mass_ratio, increasing + decreasing[:-1], client))
    ds.attrs.update(thresholds=int(thresholds), seconds=time.perf_counter() - t0)
    ds.attrs.update(_onset(ds, critical, problem), start_mode_warning=start_mode_warning(ds))
    path = write_dataset(ds, diagram_path(out, case, solid, settings, thresholds))
    return ds.assign_attrs(data=str(path))
