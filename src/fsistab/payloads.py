"""JSON payloads: the one JSON object each command prints with ``--json`` (keys documented in
docs/cli.md), made from the Dataset its workflow returned (:mod:`fsistab.workflows`) and the
paths of the files the outputs layer wrote beside it (attributes ``figure``, ``figures``).
Plain Python values only: floats, ints, strings, lists, dicts, None for a missing number."""

from __future__ import annotations

import json
import math

import numpy as np
import xarray as xr


def _finite_or_none(values) -> list:
    return [float(v) if math.isfinite(v) else None for v in np.asarray(values, dtype=float).ravel()]


def _pair(z) -> list[float]:
    return [float(z.real), float(z.imag)]


def payload(command: str, ds: xr.Dataset) -> dict:
    """The JSON object a command prints, from the Dataset its workflow returned (and the figure
    path the command added as the ``figure`` attribute), with ``mesh_reynolds`` (the Re the mesh
    is fitted to) and the ``outlet`` condition when the dataset records them."""
    result = _PAYLOADS[command](ds)
    if "mesh_reynolds" in ds.attrs:
        result["mesh_reynolds"] = float(ds.attrs["mesh_reynolds"])
    if "outlet" in ds.attrs:
        result["outlet"] = str(ds.attrs["outlet"])
    return result


def _mesh_payload(ds):
    keys = ("triangles", "vertices", "ndof", "h_min", "h_max", "preset", "mesh_key", "figure")
    return {k: _plain(ds.attrs[k]) for k in keys}


def _plain(value):
    return value.item() if isinstance(value, np.generic) else value


def _steady_payload(ds):
    a = ds.attrs
    keys = ("body", "reynolds", "alpha0_deg", "lift_coefficient", "moment_coefficient", "drag_coefficient")
    keys += ("recirculation_length", "ndof", "newton_iterations")
    result = {k: _plain(a[k]) for k in keys}
    result["newton_residuals"] = ds.newton_residual.values.tolist()
    result["continuation"] = [
        {"reynolds": float(r), "alpha0_deg": float(al), "iterations": int(n)}
        for r, al, n in zip(
            ds.path_reynolds.values, ds.path_alpha0_deg.values, ds.path_iterations.values, strict=True
        )
    ]
    result.update(
        factorisations=_plain(a["factorisations"]),
        from_cache=bool(a["from_cache"]),
        seconds=_plain(a["seconds"]),
        figure=a["figure"],
    )
    return result


def _spectrum_payload(ds):
    return {
        "eigenvalues": [
            {
                "growth_rate": float(g),
                "frequency": float(w),
                "label": str(label),
                "residual": float(r),
            }
            for g, w, label, r in zip(
                ds.growth_rate.values, ds.frequency.values, ds.label.values, ds.residual.values, strict=True
            )
        ],
        "ndof": int(ds.attrs["ndof"]),
        "netcdf": ds.attrs["netcdf"],
        "figure": ds.attrs["figure"],
        "vtk": ds.attrs["vtk"] or None,
        "mode_figures": json.loads(ds.attrs["mode_figures"]),
        "unstable": int(ds.attrs["unstable"]),
    }


def _slopes_payload(ds):
    return {
        "alpha0_deg": float(ds.attrs["alpha0_deg"]),
        "slopes": [
            {"reynolds": float(r), "lift_slope_alpha": float(lift), "moment_slope_alpha": float(moment)}
            for r, lift, moment in zip(
                ds.reynolds.values, ds.lift_slope_alpha.values, ds.moment_slope_alpha.values, strict=True
            )
        ],
        "netcdf": ds.attrs["netcdf"],
        "figure": ds.attrs["figure"],
    }


def _thresholds(ds) -> list[dict]:
    return [
        {"kind": str(k), "reduced_velocity": float(u), "frequency": float(w), "boundary": str(b)}
        for k, u, w, b in zip(
            ds.kind.values, ds.reduced_velocity.values, ds.frequency.values, ds.boundary.values, strict=True
        )
    ]


def _critical_payload(ds):
    return {
        "mass_ratio": float(ds.attrs["mass_ratio"]),
        "critical_points": _thresholds(ds),
        "factorisations": int(ds.attrs["factorisations"]),
        "method": str(ds.attrs.get("method", "transfer")),
        "unresolved_intervals": int(ds.attrs.get("unresolved_intervals", 0)),
        "netcdf": ds.attrs.get("netcdf"),
        "figure": ds.attrs.get("figure"),
    }


def _map_curve(ds, i: int, kind: str, m, u, w) -> dict:
    """Curve ``i`` of a map dataset: its points, unstable sides, turning points and stops."""
    fold = ds.fold_curve.values == i
    seed = float(ds.curve_seed_mass_ratio.values[i])
    return {
        "kind": kind,
        "seed_mass_ratio": seed if math.isfinite(seed) else None,
        "mass_ratio": m.tolist(),
        "reduced_velocity": u.tolist(),
        "frequency": w.tolist(),
        "unstable_side": ds.curve_unstable_side.values[ds.curve.values == i].tolist(),
        "frequency_following": _finite_or_none([ds.curve_frequency_following.values[i]])[0],
        "turning_points": [
            {"mass_ratio": float(a), "reduced_velocity": float(b), "frequency": float(c)}
            for a, b, c in zip(
                ds.fold_mass_ratio.values[fold],
                ds.fold_reduced_velocity.values[fold],
                ds.fold_frequency.values[fold],
                strict=True,
            )
        ],
        "stops": [str(ds.curve_stop_low.values[i]), str(ds.curve_stop_high.values[i])],
    }


def _codimension_two(ds, names: list[str]) -> list[dict]:
    """The crossings of two curves of a map dataset (index -1: the divergence curve)."""

    def name_of(index: int) -> str:
        return "divergence" if index < 0 else names[index]

    return [
        {
            "curves": [name_of(int(a)), name_of(int(b))],
            "kinds": [str(ka), str(kb)],
            "mass_ratio": float(m),
            "reduced_velocity": float(u),
            "frequencies": _finite_or_none([wa, wb]),
        }
        for a, b, ka, kb, m, u, wa, wb in zip(
            ds.crossing_first.values,
            ds.crossing_second.values,
            ds.crossing_first_kind.values,
            ds.crossing_second_kind.values,
            ds.crossing_mass_ratio.values,
            ds.crossing_reduced_velocity.values,
            ds.crossing_first_frequency.values,
            ds.crossing_second_frequency.values,
            strict=True,
        )
    ]


def _neutral_payload(ds):
    from fsistab.neutral_map import map_curve_names, map_curves, unshaded_families

    wake = float(ds.attrs["wake_frequency"])
    return {
        "curves": [_map_curve(ds, i, *curve) for i, curve in enumerate(map_curves(ds))],
        "divergence": {
            "mass_ratio": ds.mass_ratio.values.tolist(),
            "reduced_velocity": ds.divergence_reduced_velocity.values.tolist(),
            "moment_slope": float(ds.attrs["moment_slope"]),
        },
        "codimension_two": _codimension_two(ds, map_curve_names(ds)),
        "unresolved": [
            {"frequency_range": [float(lo), float(hi)], "reason": str(why)}
            for lo, hi, why in zip(
                ds.unresolved_low.values, ds.unresolved_high.values, ds.unresolved_reason.values, strict=True
            )
        ],
        "unresolved_count": int(ds.sizes.get("unresolved", 0)),
        "unshaded": [
            {"kind": kind, "mass_ratio_range": [low, high]} for kind, low, high in unshaded_families(ds)
        ],
        "wake_frequency": wake if math.isfinite(wake) else None,
        "method": ds.attrs["method"],
        "factorisations": int(ds.attrs["factorisations_this_run"]),
        "factorisations_total": int(
            ds.attrs.get("factorisations_total", ds.attrs["factorisations_this_run"])
        ),
        "reduced_models": int(ds.attrs["reduced_models"]),
        "rational_fits": int(ds.attrs.get("rational_fits", 0)),
        "interpolated_frequencies": int(ds.attrs.get("interpolated_frequencies", 0)),
        "data": ds.attrs["data"],
        "figure": ds.attrs["figure"],
    }


def _flow_neutral_payload(ds):
    from fsistab.flow_neutral import flow_curves

    parameter = ds.attrs["parameter"]
    return {
        "parameter": parameter,
        "mass_ratio": float(ds.attrs["mass_ratio"]),
        "curves": [
            {
                "kind": kind,
                "direction": "decreasing" if direction < 0 else "increasing",
                parameter: values.tolist(),
                "reduced_velocity": u.tolist(),
                "frequency": w.tolist(),
                "turning_points": [
                    {parameter: float(p), "reduced_velocity": float(v)} for p, v in zip(fp, fu, strict=True)
                ],
                "stop": stop,
            }
            for kind, direction, values, u, w, fp, fu, stop in flow_curves(ds)
        ],
        "factorisations": int(ds.attrs["factorisations"]),
        "figure": ds.attrs["figure"],
    }


def _slopes_info(ds) -> dict:
    a = ds.attrs
    return {
        "source": a["slopes_source"],
        "lift_slope_alpha": float(a["lift_slope_alpha"]),
        "moment_slope_alpha": float(a["moment_slope_alpha"]),
        "moment_slope_elastic_axis": float(a["moment_slope_elastic_axis"]),
    }


def _theodorsen_points_payload(ds):
    return {
        "mass_ratio": float(ds.attrs["mass_ratio"]),
        "critical_points": _thresholds(ds),
        "slopes": _slopes_info(ds),
    }


def _theodorsen_map_payload(ds):
    comparison = None
    if "comparison_mass_ratio" in ds and ds.sizes.get("comparison", 0):
        comparison = [
            {
                "mass_ratio": float(m),
                "viscous": float(u),
                "theodorsen": t,
                "relative_error": e,
            }
            for m, u, t, e in zip(
                ds.comparison_mass_ratio.values,
                ds.comparison_viscous.values,
                _finite_or_none(ds.comparison_theodorsen.values),
                _finite_or_none(ds.comparison_relative_error.values),
                strict=True,
            )
        ]
    return {
        "mass_ratio": ds.mass_ratio.values.tolist(),
        "flutter": {
            "reduced_velocity": [_finite_or_none(row) for row in ds.reduced_velocity.values],
            "frequency": [_finite_or_none(row) for row in ds.frequency.values],
        },
        "divergence": _finite_or_none(ds.divergence_velocity.values),
        "slopes": _slopes_info(ds),
        "comparison": comparison,
        "netcdf": ds.attrs["netcdf"],
        "figure": ds.attrs["figure"],
    }


def _transfer_payload(ds):
    from fsistab.store import complex_values

    loads = complex_values(ds.viscous_loads)
    return {
        "reynolds": float(ds.attrs["reynolds"]),
        "alpha0_deg": float(ds.attrs["alpha0_deg"]),
        "ndof": int(ds.attrs["ndof_fluid"]),
        "factorisations": int(ds.attrs["factorisations"]),
        "lift_slope_alpha": float(ds.attrs["lift_slope_alpha"]),
        "moment_slope_alpha": float(ds.attrs["moment_slope_alpha"]),
        "samples": [
            {
                "frequency": float(w),
                "reduced_frequency": float(k),
                "lift_per_pitch": _pair(loads[i, 0, 1]),
                "moment_per_pitch": _pair(loads[i, 1, 1]),
                "lift_per_heave": _pair(loads[i, 0, 0]),
                "moment_per_heave": _pair(loads[i, 1, 0]),
            }
            for i, (w, k) in enumerate(zip(ds.frequency.values, ds.reduced_frequency.values, strict=True))
        ],
        "netcdf": ds.attrs["netcdf"],
        "figure": ds.attrs["figure"],
    }


def _onset_payload(ds):
    keys = ("parameter", "critical_value", "frequency", "iterations", "factorisations", "data", "figure")
    return {k: _plain(ds.attrs[k]) for k in keys}


def _study_payload(ds):
    """``fsistab study --json``: the data file, the counts, each failed point with its error and
    every classified threshold (docs/cli.md)."""
    failed = [
        {"reynolds": float(re), "alpha0": float(a), "error": str(ds.error.sel(reynolds=re, alpha0=a).values)}
        for re in ds.reynolds.values
        for a in ds.alpha0.values
        if str(ds.status.sel(reynolds=re, alpha0=a).values) == "failed"
    ]
    thresholds = []
    if "threshold_class" in ds:
        for re in ds.reynolds.values:
            for a in ds.alpha0.values:
                for m in ds.mass_ratio.values:
                    sub = ds.sel(reynolds=re, alpha0=a, mass_ratio=m)
                    for k in range(sub.sizes["threshold"]):
                        label = str(sub.threshold_class.values[k])
                        if not label:
                            continue
                        thresholds.append(
                            {
                                "reynolds": float(re),
                                "alpha0": float(a),
                                "mass_ratio": float(m),
                                "class": label,
                                "boundary": str(sub.threshold_boundary.values[k]),
                                "reduced_velocity": float(sub.threshold_reduced_velocity.values[k]),
                                "frequency": float(sub.threshold_frequency.values[k]),
                            }
                        )
    a = ds.attrs
    return {
        "data": a["data"],
        "points": int(a["points"]),
        "computed": int(a["computed"]),
        "failed": failed,
        "factorisations": int(a["factorisations"]),
        "seconds": float(a["seconds"]),
        "execution": a["execution"],
        "thresholds": thresholds,
        "figures": json.loads(a.get("figures", "[]")),
    }


def _sensitivity_payload(ds):
    """``fsistab sensitivity --json`` (docs/cli.md)."""
    thresholds = []
    for k in range(ds.sizes["threshold"]):
        row = ds.isel(threshold=k)
        parameters = [str(p) for p in ds.parameter.values]
        thresholds.append(
            {
                "kind": str(row.kind.values),
                "boundary": str(row.boundary.values),
                "reduced_velocity": float(row.reduced_velocity),
                "frequency": float(row.frequency),
                "derivatives": dict(zip(parameters, map(float, row.d_reduced_velocity.values), strict=True)),
                "frequency_derivatives": dict(
                    zip(parameters, map(float, row.d_frequency.values), strict=True)
                ),
                "adjoint_residual": float(row.adjoint_residual),
            }
        )
    a = ds.attrs
    return {
        "mass_ratio": float(a["mass_ratio"]),
        "thresholds": thresholds,
        "maps": a["maps"] or None,
        "vtk": a["vtk"] or None,
        "figure": a["figure"] or None,
        "best_control": json.loads(a.get("best_control", "{}")),
        "data": a["netcdf"],
        "factorisations": int(a["factorisations"]),
    }


def _simulate_payload(ds):
    a = ds.attrs
    last = {name: float(ds[name].values[-1]) for name in ("heave", "pitch", "heave_rate", "pitch_rate")}
    for name in ("lift_coefficient", "drag_coefficient", "moment_coefficient"):
        last[name] = float(ds[name].values[-1])
    start = None
    if "start_growth_rate" in a:
        start = {"growth_rate": float(a["start_growth_rate"]), "frequency": float(a["start_frequency"])}
    return {
        "data": a["netcdf"],
        "time": float(ds.time.values[-1]),
        "time_step": float(a["time_step"]),
        "steps": int(a["steps"]),
        "steps_this_run": int(a["steps_this_run"]),
        "seconds_per_step": _finite_or_none([a["seconds_per_step"]])[0],
        "ndof": int(a["ndof"]),
        "factorisations": int(a["factorisations"]),
        "start_eigenvalue": start,
        "last": last,
        "checkpoint": a["checkpoint"],
        "vtk": json.loads(a.get("snapshots", "[]")),
        "animation": a.get("animation") or None,
        "animation_frames": int(a.get("animation_frames", 0)),
    }


def _lco_payload(ds):
    a = ds.attrs
    points = []
    for i, u in enumerate(ds.reduced_velocity.values):
        point = {"reduced_velocity": float(u), "error": str(ds["error"].values[i]) or None}
        if "start_growth_rate" in ds:  # diagrams written before this field have none
            rate, omega = _finite_or_none([ds.start_growth_rate.values[i], ds.start_frequency.values[i]])
            point["start_eigenvalue"] = None if rate is None else {"growth_rate": rate, "frequency": omega}
        for name in ("heave", "pitch", "lift"):
            if f"{name}_amplitude" in ds:
                point[name] = {
                    "amplitude": _finite_or_none([ds[f"{name}_amplitude"].values[i]])[0],
                    "frequency": _finite_or_none([ds[f"{name}_frequency"].values[i]])[0],
                    "change_per_period": _finite_or_none([ds[f"{name}_change"].values[i]])[0],
                    "state": str(ds[f"{name}_state"].values[i]),
                    **{
                        key: _finite_or_none([ds[f"{name}_{key}"].values[i]])[0]
                        for key in ("low", "high", "largest")
                        if f"{name}_{key}" in ds  # diagrams written before these fields
                    },
                }
            if f"decreasing_{name}_amplitude" in ds:
                point[f"decreasing_{name}"] = {
                    "amplitude": _finite_or_none([ds[f"decreasing_{name}_amplitude"].values[i]])[0],
                    "state": str(ds[f"decreasing_{name}_state"].values[i]),
                    "start_state": str(ds["decreasing_start_state"].values[i])
                    if "decreasing_start_state" in ds
                    else None,
                }
        points.append(point)
    return {
        "data": a["data"],
        "figure": a.get("figure"),
        "points": points,
        "thresholds": [float(u) for u in ds.threshold_velocity.values],
        "onset": a["onset"],
        "start_mode_warning": a.get("start_mode_warning") or None,
        "onset_fit": {
            "slope": _finite_or_none([a["onset_slope"]])[0],
            "velocity": _finite_or_none([a["onset_velocity"]])[0],
        },
        "saturation_rule": a["saturation_rule"],
        "saturation_tolerance": float(a["saturation_tolerance"]),
        "periods": int(a["periods"]),
        "ndof": int(a["ndof"]),
        "computed": int(a["computed"]),
        "failed": int(a["failed"]),
        "seconds": float(a["seconds"]),
        "execution": a["execution"],
    }


_PAYLOADS = {
    "mesh": _mesh_payload,
    "steady": _steady_payload,
    "spectrum": _spectrum_payload,
    "slopes": _slopes_payload,
    "critical": _critical_payload,
    "neutral": _neutral_payload,
    "flow-neutral": _flow_neutral_payload,
    "theodorsen-points": _theodorsen_points_payload,
    "theodorsen-map": _theodorsen_map_payload,
    "transfer": _transfer_payload,
    "onset": _onset_payload,
    "study": _study_payload,
    "sensitivity": _sensitivity_payload,
    "simulate": _simulate_payload,
    "lco": _lco_payload,
}
