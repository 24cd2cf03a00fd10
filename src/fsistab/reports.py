"""What each command prints without ``--json``: a table and a few plain sentences, made from the
Dataset its workflow returned and the JSON payload made from it (:mod:`fsistab.payloads`).

Each function returns the lines to print, in order (rich tables and strings); nothing here
prints or computes a result: the numbers are the Dataset's, formatted.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import xarray as xr
from rich.table import Table


def table(title: str, columns, rows) -> Table:
    """A table with right-justified columns."""
    result = Table(title=title)
    for column in columns:
        result.add_column(column, justify="right")
    for row in rows:
        result.add_row(*row)
    return result


def _plural(count: int, noun: str, plural: str | None = None) -> str:
    return f"{count} {noun if count == 1 else plural or noun + 's'}"


def _held_mesh(attrs) -> str:
    """``, mesh fitted to Re = 2900`` when the mesh is fitted to another Re than the flow's
    (``--mesh-reynolds``; a study's points each have their own Re), else nothing."""
    held = attrs.get("mesh_reynolds")
    if held is None or held == attrs.get("reynolds"):
        return ""
    return f", mesh fitted to Re = {held:g}"


def mesh(ds: xr.Dataset, p: dict) -> list:
    rows = [
        (name, f"{p[name]:.4g}" if isinstance(p[name], float) else str(p[name]))
        for name in ("triangles", "vertices", "ndof", "h_min", "h_max")
    ]
    a = ds.attrs
    fitted = a.get("mesh_reynolds", a["reynolds"])
    title = f"mesh: {a['body']}, preset {a['preset']}, fitted to Re = {fitted:g}"
    return [table(title, ("quantity", "value"), rows), f"figure: {p['figure']}"]


def steady(ds: xr.Dataset, p: dict) -> list:
    rows = [
        (label, f"{p[key]:.6g}")
        for label, key in [
            ("lift coefficient C_L", "lift_coefficient"),
            ("drag coefficient C_D", "drag_coefficient"),
            ("moment coefficient C_M (about the pitch axis, ccw +)", "moment_coefficient"),
            ("recirculation length (from the rear)", "recirculation_length"),
        ]
    ]
    rows += [("unknowns", str(p["ndof"])), ("Newton iterations at target", str(p["newton_iterations"]))]
    title = f"steady flow: {p['body']}, Re = {p['reynolds']:g}, alpha0 = {p['alpha0_deg']:g} deg"
    lines = [table(title, ("quantity", "value"), rows)]
    lines.append("Newton residuals: " + ", ".join(f"{r:.2e}" for r in p["newton_residuals"]))
    if p["continuation"]:
        lines.append("continuation in Re: " + ", ".join(f"{s['reynolds']:.4g}" for s in p["continuation"]))
    work = f"{p['seconds']:.1f} s, {p['factorisations']} factorisations"
    return [*lines, f"({'cache' if p['from_cache'] else work}) figure: {p['figure']}"]


def unstable_verdict(ds: xr.Dataset) -> str:
    """How many of the eigenvalues found are unstable (growth rate > 0), and which."""
    unstable = ds.growth_rate.values > 0
    found = f"among the {_plural(ds.sizes['mode'], 'eigenvalue')} found"
    if not unstable.any():
        return f"no unstable eigenvalue {found}"
    values = ", ".join(
        f"λ = {g:+.6f}, ω = {w:.6f} ({label})"
        for g, w, label in zip(
            ds.growth_rate.values[unstable],
            ds.frequency.values[unstable],
            ds.label.values[unstable],
            strict=True,
        )
    )
    return f"{_plural(int(unstable.sum()), 'unstable eigenvalue')} {found}: {values}"


def spectrum(ds: xr.Dataset, p: dict) -> list:
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
    a = ds.attrs
    title = (
        f"spectrum: {a['body']}, Re = {a['reynolds']:g}, alpha0 = {a['alpha0_deg']:g} deg, dofs {a['dofs']}"
    )
    columns = ("growth rate λ", "frequency ω", "label", "solid energy", "residual")
    modes = f"; modes {p['vtk']}" if p["vtk"] else ""
    return [
        table(title, columns, rows),
        unstable_verdict(ds),
        f"{p['ndof']} unknowns; data {p['netcdf']}; figure {p['figure']}{modes}",
    ]


def slopes(ds: xr.Dataset, p: dict) -> list:
    rows = [
        (f"{s['reynolds']:g}", f"{s['lift_slope_alpha']:.4f}", f"{s['moment_slope_alpha']:.4f}")
        for s in p["slopes"]
    ]
    a = ds.attrs
    rows.append(
        ("thin airfoil", f"{a['thin_airfoil_lift_slope']:.4f}", f"{a['thin_airfoil_moment_slope']:.4f}")
    )
    title = f"static slopes, plate, alpha0 = {a['alpha0_deg']:g} deg, mesh {a['mesh']} (per radian)"
    return [table(title, ("Re", "dC_L/dα", "d(-C_M)/dα"), rows), f"data {p['netcdf']}; figure {p['figure']}"]


def search_summary(ds: xr.Dataset) -> str:
    """What the threshold search of ``fsistab critical`` did, as it did it."""
    a = ds.attrs
    if a["method"] == "tracking":
        branches = _plural(int(a["branches_tracked"]), "eigenvalue branch", "eigenvalue branches")
        return f"{branches} tracked over {a['points']} values of U*"
    sampled = _plural(int(a["frequencies_sampled"]), "frequency", "frequencies")
    return f"G(iω) sampled at {sampled} (no sweep in U*)"


def critical(ds: xr.Dataset, p: dict) -> list:
    rows = [
        (t["kind"], t["boundary"], f"{t['reduced_velocity']:.6g}", f"{t['frequency']:.6g}", f"{ratio:.4g}")
        for t, ratio in zip(p["critical_points"], ds.frequency_ratio.values, strict=True)
    ]
    a = ds.attrs
    lo, hi = a["velocity_range"]
    title = (
        f"thresholds: {a['body']}, Re = {a['reynolds']:g}, m = {a['mass_ratio']:g}, U* in [{lo:g}, {hi:g}]"
        + _held_mesh(a)
    )
    columns = ("kind", "boundary", "U*_c", "ω_c", "ω_c U*_c")
    lines = [table(title, columns, rows)]
    if not rows:
        lines.append(f"no threshold for U* in [{lo:g}, {hi:g}]")
    lines.append(f"{p['factorisations']} factorisations; {search_summary(ds)}")
    if "netcdf" in a:
        lines.append(f"data {a['netcdf']}; figure {a['figure']}")
    return lines


def _map_rows(ds: xr.Dataset, p: dict, mass_range) -> list[tuple]:
    from fsistab.neutral_map import map_curve_names

    rows = []
    for name, c in zip(map_curve_names(ds), p["curves"], strict=True):
        m, u = c["mass_ratio"], c["reduced_velocity"]
        turning = ", ".join(
            f"({t['mass_ratio']:.4g}, {t['reduced_velocity']:.4g})" for t in c["turning_points"]
        )
        seed = "—" if c["seed_mass_ratio"] is None else f"{c['seed_mass_ratio']:g}"
        rows.append((name, seed, str(len(m)), f"{min(m):.4g}–{max(m):.4g}", f"{min(u):.4g}–{max(u):.4g}"))
        rows[-1] += (turning or "—", " / ".join(c["stops"]))
    lo_m, hi_m = mass_range
    coefficient = float(ds.attrs["divergence_coefficient"])
    law = f"U*_D = {coefficient:.4g} √m" if math.isfinite(coefficient) else "none (dC_M/dθ <= 0)"
    rows.append(("divergence", "—", "analytic", f"{lo_m:g}–{hi_m:g}", law, "—", "—"))
    return rows


def _map_notes(ds: xr.Dataset, p: dict) -> list[str]:
    lines = []
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
    return lines


def stability_map(ds: xr.Dataset, p: dict, mass_range, out: Path) -> list:
    columns = ("curve", "seed m", "points", "m range", "U* range", "turning points (m, U*)", "stops")
    lo_m, hi_m = mass_range
    title = f"neutral curves: plate, Re = {ds.attrs['reynolds']:g}, m in [{lo_m:g}, {hi_m:g}]"
    lines = [table(title, columns, _map_rows(ds, p, mass_range)), *_map_notes(ds, p)]
    # a rerun reuses the saved samples: the map's frequencies are its cost, this count the run's
    lines.append(
        f"{p['factorisations']} factorisations in this run, {p['factorisations_total']} in total; "
        f"curves and map saved in {out}; "
        f"figure {p['figure']}"
    )
    return lines


def flow_neutral(ds: xr.Dataset, p: dict, out: Path) -> list:
    from fsistab.flow_neutral import flow_curves

    parameter, mass = ds.attrs["parameter"], ds.attrs["mass_ratio"]
    rows = []
    for kind, direction, values, u, _, fp, fu, stop in flow_curves(ds):
        turning = ", ".join(f"({a:.4g}, {b:.4g})" for a, b in zip(fp, fu, strict=True)) or "—"
        side = "down" if direction < 0 else "up"
        rows.append((f"{kind} ({side})", str(len(values)), f"{values.min():.4g}–{values.max():.4g}"))
        rows[-1] += (f"{u.min():.4g}–{u.max():.4g}", turning, stop)
    columns = ("curve", "points", f"{parameter} range", "U* range", "turning points", "stop")
    title = f"neutral curves in ({parameter}, U*): plate, m = {mass:g}" + _held_mesh(ds.attrs)
    lines = [table(title, columns, rows)]
    lines.append(f"{p['factorisations']} factorisations; curves saved in {out}; figure {p['figure']}")
    return lines


def theodorsen_points(ds: xr.Dataset, p: dict) -> list:
    s, a = p["slopes"], ds.attrs
    lo, hi = a["velocity_range"]
    title = (
        f"Theodorsen typical section: m = {p['mass_ratio']:g}, slopes {s['source']}, "
        f"a = {a['elastic_axis']:g}, x_θ = {a['static_unbalance']:g}, U* in [{lo:g}, {hi:g}]"
    )
    rows = [
        (t["kind"], t["boundary"], f"{t['reduced_velocity']:.6g}", f"{t['frequency']:.6g}", f"{r:.4g}")
        for t, r in zip(p["critical_points"], ds.frequency_ratio.values, strict=True)
    ]
    lines = [table(title, ("kind", "boundary", "U*_c", "ω_c", "ω_c/ω_θ = ω_c U*_c"), rows)]
    if not rows:
        lines.append("no flutter or divergence boundary in this U* range")
    lines.append(
        f"dC_L/dα = {s['lift_slope_alpha']:.4f}, d(-C_M)/dα = {s['moment_slope_alpha']:.4f} "
        f"(mid-chord), dC_M/dθ about the elastic axis = {s['moment_slope_elastic_axis']:.4f}"
    )
    return lines


def theodorsen_map(ds: xr.Dataset, p: dict, mass_range) -> list:
    masses, velocities = ds.mass_ratio.values, ds.reduced_velocity.values
    rows = []
    for i in np.unique(np.linspace(0, len(masses) - 1, min(len(masses), 12)).round().astype(int)):
        ok = np.isfinite(velocities[i])
        flutter = ", ".join(f"{v:.4g}" for v in velocities[i][ok]) or "none"
        ratio = ", ".join(f"{v:.3g}" for v in ds.flutter_frequency_ratio.values[i][ok]) or "-"
        rows.append((f"{masses[i]:.4g}", flutter, ratio, f"{ds.divergence_velocity.values[i]:.4g}"))
    lo_m, hi_m = mass_range
    title = f"Theodorsen neutral curves, slopes {p['slopes']['source']}, m in [{lo_m:g}, {hi_m:g}]"
    lines = [table(title, ("m", "flutter U*_F", "ω_F/ω_θ", "divergence U*_D"), rows)]
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


def transfer(ds: xr.Dataset, p: dict) -> list:
    from fsistab.store import complex_values

    loads = [
        complex_values(ds[name])
        for name in ("viscous_loads", "theodorsen_thin_airfoil", "theodorsen_calibrated")
    ]

    def fmt(z) -> str:
        return f"{z.real:+.2f}{z.imag:+.2f}i"

    rows = [
        (f"{k:.3g}", *(fmt(a[i, 0, 1]) for a in loads), *(fmt(a[i, 1, 1]) for a in loads))
        for i, k in enumerate(ds.reduced_frequency.values)
    ]
    columns = ("k", "C_L/θ̂ (NS)", "thin airfoil", "calibrated", "C_M/θ̂ (NS)", "thin airfoil", "calibrated")
    a = ds.attrs
    flow = f"Re = {a['reynolds']:g}, α0 = {a['alpha0_deg']:g}°"
    title = f"C_L/θ̂ and C_M/θ̂, {a['body']}, {flow}, mesh {a['preset']}"
    return [
        table(title, columns, rows),
        f"{p['factorisations']} factorisations; data {p['netcdf']}; figure {p['figure']}",
    ]


def onset(ds: xr.Dataset, p: dict, title: str) -> list:
    name = "Re" if ds.attrs["parameter"] == "reynolds" else "alpha0"
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
    return [
        table(title, columns, rows),
        f"critical {name} = {p['critical_value']:.6f}, ω_c = {p['frequency']:.5f} "
        f"(Strouhal {ds.attrs['strouhal']:.5f}); {p['iterations']} iterates, "
        f"{p['factorisations']} factorisations; data {p['data']}; figure {p['figure']}",
    ]


def _study_row(ds: xr.Dataset, i: int, j: int) -> tuple:
    row = [f"{ds.reynolds.values[i]:g}", f"{ds.alpha0.values[j]:g}", str(ds.status.values[i, j])]
    if "lift_coefficient" in ds:
        row += [f"{ds[name].values[i, j]:.4g}" for name in ("lift_coefficient", "moment_coefficient")]
    if "leading_growth_rate" in ds:
        row.append(f"{ds.leading_growth_rate.values[i, j]:+.4g} {ds.leading_frequency.values[i, j]:+.4g}i")
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
    return tuple(row)


def study(ds: xr.Dataset, p: dict) -> list:
    rows = [_study_row(ds, i, j) for i in range(ds.sizes["reynolds"]) for j in range(ds.sizes["alpha0"])]
    columns = ["Re", "alpha0", "status"]
    if "lift_coefficient" in ds:
        columns += ["C_L", "C_M"]
    if "leading_growth_rate" in ds:
        columns.append("leading mode σ")
    if "threshold_class" in ds:
        columns.append("thresholds (all mass ratios)")
    title = f"study: {ds.attrs['body']}, mesh {ds.attrs['preset']}" + _held_mesh(ds.attrs)
    lines = [table(title, columns, rows)]
    for failure in p["failed"]:
        lines.append(f"FAILED Re {failure['reynolds']:g}, alpha0 {failure['alpha0']:g}: {failure['error']}")
    lines.append(
        f"{p['points']} points ({p['computed']} computed now, {len(p['failed'])} failed), "
        f"{p['factorisations']} factorisations, {p['seconds']:.1f} s ({ds.attrs['execution']}); "
        f"data {p['data']}"
    )
    return lines


def sensitivity(ds: xr.Dataset, p: dict) -> list:
    names = [str(n) for n in ds.parameter.values]
    rows = [
        (t["kind"], f"{t['reduced_velocity']:.6g}", *(f"{t['derivatives'][n]:+.4g}" for n in names))
        for t in p["thresholds"]
    ]
    a = ds.attrs
    title = (
        f"dU*_c/dp: {a['body']}, Re = {a['reynolds']:g}, α0 = {a['alpha0_deg']:g}°, m = {a['mass_ratio']:g}"
        + _held_mesh(a)
    )
    lines = [table(title, ("kind", "U*_c", *names), rows)]
    for target, best in p["best_control"].items():
        gain = ", ".join(f"{k} {v:+.4g}" for k, v in best.items() if k not in ("x", "y"))
        where = f"X = {best['x']:.3g}, Y = {best['y']:.3g}"
        lines.append(f"{target}: a control cylinder helps most at {where} ({gain})")
    lines.append(f"{p['factorisations']} factorisations; data {p['data']}; maps {p['maps']}")
    return lines


def simulate(ds: xr.Dataset, p: dict) -> list:
    a = ds.attrs
    last = p["last"]
    rows = [
        (label, f"{last[key]:.6g}")
        for label, key in (
            ("heave h", "heave"),
            ("pitch θ (rad)", "pitch"),
            ("lift coefficient C_L", "lift_coefficient"),
            ("drag coefficient C_D", "drag_coefficient"),
            ("moment coefficient C_M", "moment_coefficient"),
        )
    ]
    title = (
        f"simulation: {a['body']}, Re = {a['reynolds']:g}, dofs {a['dofs']}, "
        f"t = {p['time']:.6g} (dt = {p['time_step']:g}, {p['steps']} steps)"
    )
    lines = [table(title, ("at the last step", "value"), rows)]
    if p["start_eigenvalue"] is not None:
        e = p["start_eigenvalue"]
        lines.append(f"started from the eigenmode λ = {e['growth_rate']:+.6f}, ω = {e['frequency']:.6f}")
    cost = p["seconds_per_step"]
    speed = "" if cost is None else f", {cost:.3g} s per step this run"
    lines.append(f"{p['ndof']} unknowns, {p['factorisations']} factorisations{speed}; data {p['data']}")
    if p["vtk"]:
        lines.append(f"{_plural(len(p['vtk']), 'snapshot')}: {p['vtk'][0]} ...")
    if p["animation"]:
        lines.append(f"vorticity animation ({_plural(p['animation_frames'], 'frame')}): {p['animation']}")
    elif "animation" in a:
        lines.append("no vorticity animation: no snapshot time among the steps marched in this run")
    return lines


def lco(ds: xr.Dataset, p: dict) -> list:
    from fsistab.lco import signals

    a = ds.attrs
    names = signals(ds)
    rows = []
    for point in p["points"]:
        if point["error"]:
            rows.append((f"{point['reduced_velocity']:g}", *(["FAILED"] * len(names)), point["error"]))
            continue
        cells = []
        for name in names:
            s = point[name]
            amplitude = "—" if s["amplitude"] is None else f"{s['amplitude']:.4g}"
            frequency = "—" if s["frequency"] is None else f"{s['frequency']:.4g}"
            cells.append(f"{amplitude} (ω {frequency})")
        state = point[names[0]]
        change = "" if state["change_per_period"] is None else f" {state['change_per_period']:+.2g}/period"
        if state["state"] == "modulated" and state.get("low") is not None:
            change = f" {state['low']:.4g}–{state['high']:.4g}"  # the range of its period amplitudes
        rows.append((f"{point['reduced_velocity']:g}", *cells, f"{state['state']}{change}"))
    title = (
        f"limit cycles: {a['body']}, Re = {a['reynolds']:g}, m = {a['mass_ratio']:g}, dofs {a['dofs']}, "
        f"dt = {a['time_step']:g}, duration {a['duration']:g}"
    )
    lines = [table(title, ("U*", *(f"{n} amplitude" for n in names), "envelope"), rows)]
    thresholds = ", ".join(f"{u:.5g}" for u in p["thresholds"]) or "none in the range"
    lines.append(f"linear thresholds U*_c: {thresholds}; onset: {p['onset']}")
    if p["start_mode_warning"]:
        lines.append(f"warning: {p['start_mode_warning']}")
    fit = p["onset_fit"]
    if fit["velocity"] is not None:
        lines.append(
            f"A² = {fit['slope']:.4g} (U* − {fit['velocity']:.5g}) through the first saturated points"
        )
    lines.append(
        f"{p['computed']} march{'' if p['computed'] == 1 else 'es'} computed ({p['execution']}), "
        f"{p['failed']} failed, {p['seconds']:.4g} s; "
        f"{p['ndof']} unknowns; data {p['data']}; figure {p['figure']}"
    )
    return lines
