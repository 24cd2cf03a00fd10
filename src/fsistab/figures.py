"""The figures (and VTK files) of each command, drawn from what its workflow returned.

One function per command: it takes the workflow's Dataset (or result, when the figure needs the
fields themselves: the mesh, the steady state, the modes, the sensitivity maps), draws with
:mod:`fsistab.plots`, writes the VTK files with :mod:`fsistab.vtk`, and returns the Dataset with
the paths written in its attributes (``figure``, and ``figures``, ``mode_figures``, ``vtk`` where
a command writes several files), which the JSON payloads (:mod:`fsistab.payloads`) and the
printed reports (:mod:`fsistab.reports`) read. The file names are those of the command's data.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import xarray as xr

from fsistab import plots


def _quiet(message: str) -> None:
    pass


def mesh(result, out: Path) -> xr.Dataset:
    """The mesh and a close-up of the body (``fsistab mesh``)."""
    a = result.dataset.attrs
    path = Path(out) / f"mesh_{a['body']}_{a['preset']}_Re{a['reynolds']:g}{a.get('mesh_tag', '')}.png"
    figure = plots.plot_mesh(result.mesh, path, title=f"{a['body']}, {a['preset']}")
    return result.dataset.assign_attrs(figure=str(figure))


def steady(result, tag: str, out: Path) -> xr.Dataset:
    """The streamwise velocity of the steady flow (``fsistab steady``)."""
    figure = plots.plot_streamwise_velocity(result.steady, Path(out) / f"steady_{tag}.png")
    return result.dataset.assign_attrs(figure=str(figure))


def spectrum(result, tag: str, settings, out: Path, progress: Callable[[str], None] = _quiet) -> xr.Dataset:
    """The eigenvalues; pressure snapshots (at ``settings.phase``) and solid motions of the
    ``settings.mode_figures`` least stable modes; the six least stable modes as VTK
    (``settings.vtk``). ``fsistab spectrum``."""
    out = Path(out)
    ds, system = result.dataset, result.system
    title = f"{ds.attrs['body']}, Re = {ds.attrs['reynolds']:g}"
    figure = plots.plot_spectrum(ds, out / f"spectrum_{tag}.png", title=title)
    mode_paths = []
    for i, pair in enumerate(result.pairs[: settings.mode_figures]):
        progress(f"figures of mode {i}")
        snapshot = out / f"mode{i}_{tag}.png"
        index = system.fluid.free_dofs
        mode_paths.append(
            str(plots.plot_mode_snapshot(result.steady, index, pair, system, snapshot, settings.phase))
        )
        if system.n_solid:
            mode_paths.append(str(plots.plot_solid_motion(pair, out / f"mode{i}_motion_{tag}.png").path))
    vtk_path = None
    if settings.vtk:
        from fsistab.vtk import write_modes_vtk

        progress("modes as VTK")
        modes = {f"mode{i}": p.vector[system.n_solid :] for i, p in enumerate(result.pairs[:6])}
        vtk_path = write_modes_vtk(result.steady, system.fluid.free_dofs, modes, out / f"modes_{tag}")
    return ds.assign_attrs(
        figure=str(figure), vtk=str(vtk_path) if vtk_path else "", mode_figures=json.dumps(mode_paths)
    )


def slopes(ds: xr.Dataset, out: Path) -> xr.Dataset:
    """The static slopes against Re beside thin-airfoil theory (``fsistab slopes``)."""
    path = Path(out) / f"slopes_plate_a{ds.attrs['alpha0_deg']:g}_{ds.attrs['mesh']}.png"
    return ds.assign_attrs(figure=str(plots.plot_slopes(ds, path)))


def critical(ds: xr.Dataset) -> xr.Dataset:
    """The thresholds over the U* range searched, beside the data file (``fsistab critical``)."""
    a = ds.attrs
    lo, hi = a["velocity_range"]
    title = (
        f"{a['body']}, Re = {a['reynolds']:g}, m = {a['mass_ratio']:g}: thresholds in U* ∈ [{lo:g}, {hi:g}]"
    )
    figure = plots.plot_thresholds(ds, Path(a["netcdf"]).with_suffix(".png"), title=title)
    return ds.assign_attrs(figure=str(figure))


def stability_map(ds: xr.Dataset, case, out: Path) -> xr.Dataset:
    """The stability map in (m, U*) (``fsistab neutral``)."""
    title = f"plate, Re = {case.flow.reynolds:g}, alpha0 = {case.flow.alpha0_deg:g} deg"
    path = Path(out) / f"neutral_{case.tag}.png"
    return ds.assign_attrs(figure=str(plots.plot_map(ds, path, title=title)))


def flow_neutral(ds: xr.Dataset, case, out: Path) -> xr.Dataset:
    """The neutral curves in (Re, U*) or (α0, U*) (``fsistab flow-neutral``)."""
    mass, parameter, flow = ds.attrs["mass_ratio"], ds.attrs["parameter"], case.flow
    path = Path(out) / f"flow_neutral_{case.tag}_{parameter}_m{mass:g}.png"
    title = f"plate, m = {mass:g}, from Re = {flow.reynolds:g}, alpha0 = {flow.alpha0_deg:g} deg"
    return ds.assign_attrs(figure=str(plots.plot_flow_neutral_curves(ds, path, title=title)))


def theodorsen(ds: xr.Dataset) -> xr.Dataset:
    """Theodorsen's neutral curves, with the viscous map when there is one (``fsistab theodorsen
    --mass-ratio-range``), beside the data file."""
    a = ds.attrs
    source = a["slopes_source"]
    title = f"Theodorsen typical section, slopes {source}"
    if "viscous_divergence_mass_ratio" in ds:
        title = f"Theodorsen ({source}) vs viscous, plate, Re = {a['reynolds']:g}"
    path = Path(a["netcdf"]).with_suffix(".png")
    return ds.assign_attrs(figure=str(plots.plot_theodorsen_comparison(ds, path, title=title)))


def transfer(ds: xr.Dataset, tag: str, preset: str, out: Path) -> xr.Dataset:
    """The viscous Theodorsen function against Theodorsen's model (``fsistab transfer``)."""
    path = Path(out) / f"transfer_{tag}_{preset}.png"
    return ds.assign_attrs(figure=str(plots.plot_viscous_theodorsen(ds, path)))


def onset_title(ds: xr.Dataset) -> str:
    """The title of the onset's figure and table."""
    a = ds.attrs
    at = f"alpha0 = {a['alpha0_deg']:g} deg" if a["parameter"] == "reynolds" else f"Re = {a['reynolds']:g}"
    return f"onset: fixed {a['body']}, {at}, mesh {a['preset']} ({a['ndof']} unknowns)"


def onset(ds: xr.Dataset) -> xr.Dataset:
    """The secant iterates of the onset search, beside the data file (``fsistab onset``)."""
    path = Path(ds.attrs["data"]).with_suffix(".png")
    return ds.assign_attrs(figure=str(plots.plot_onset(ds, path, title=onset_title(ds))))


def study(ds: xr.Dataset, settings) -> xr.Dataset:
    """The coefficients (``settings.slopes``), the leading modes and thresholds (modes or
    thresholds) and the maps (``settings.map``) of a study's finished points (``fsistab study``);
    their paths as a JSON list in attribute ``figures``."""
    stem = Path(ds.attrs["data"]).with_suffix("")
    figures = []
    if (ds.status.values == "done").any():
        if settings.slopes:
            figures.append(plots.plot_study_coefficients(ds, Path(f"{stem}_coefficients.png")))
        if settings.modes or settings.thresholds:
            figures.append(plots.plot_study_thresholds(ds, Path(f"{stem}_thresholds.png")))
        if settings.map:
            figures.append(plots.plot_study_maps(ds, Path(f"{stem}_maps.png")))
    return ds.assign_attrs(figures=json.dumps([str(f) for f in figures]))


def sensitivity(result, progress: Callable[[str], None] = _quiet) -> xr.Dataset:
    """The sensitivity maps as VTK and as a figure, beside their NetCDF (``fsistab
    sensitivity``); paths in attributes ``vtk`` and ``figure`` ("" without any map)."""
    ds = result.dataset
    if not result.maps:
        return ds.assign_attrs(vtk="", figure="")
    from fsistab.vtk import write_maps_vtk

    progress("writing the maps (VTK, figure)")
    stem = ds.attrs["stem"]
    vtk = write_maps_vtk(result.maps, result.steady.mesh, Path(f"{stem}_maps"))
    figure = plots.plot_sensitivity_maps(result.maps, result.steady, Path(f"{stem}_maps.png"), result.scale)
    return ds.assign_attrs(vtk=str(vtk), figure=str(figure))


def lco(ds: xr.Dataset) -> xr.Dataset:
    """The bifurcation diagram beside the data file (``fsistab lco``), its path in ``figure``."""
    a = ds.attrs
    title = f"limit cycles: {a['body']}, Re = {a['reynolds']:g}, m = {a['mass_ratio']:g}, dofs {a['dofs']}"
    path = Path(a["data"]).with_suffix(".png")
    return ds.assign_attrs(figure=str(plots.plot_lco(ds, path, title=title)))
