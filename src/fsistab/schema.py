"""The data dictionary of fsistab's NetCDF files: what every variable means and its unit, and the
global attributes that say where a file comes from.

Every file fsistab writes goes through :func:`fsistab.store.write_dataset`, which calls
:func:`describe`: each variable and coordinate gets the CF attributes ``long_name`` and ``units``
from this dictionary (unless it carries its own), and the file gets ``Conventions``,
``fsistab_version``, ``software_versions``, ``source`` and a ``history`` line (UTC time and command
line, :func:`provenance`). Attributes already present are kept, never renamed; values, dtypes and
names are not touched.

Units follow CF and UDUNITS: everything is non-dimensional (docs/model.md §1-§2, §10: lengths in
the body's reference length ``L`` — chord of the plate, diameter of the cylinder —, time in
``L/U∞``, loads in ``ρU∞²L``, masses as the mass ratio ``m``), so most units are ``"1"``; angles
are ``"degree"`` where the code uses degrees (``alpha0_deg``, ``alpha0``), slopes per radian
``"rad-1"``, wall-clock times ``"s"``. Text variables (labels, kinds, messages) have a
``long_name`` and no ``units``. Frequencies ``ω`` and growth rates ``λ`` are those of
``σ = λ + iω`` of ``σ M q + J q = 0`` (docs/model.md §7) in the body's time unit.

A variable name missing here is written without units, with an
:class:`UndescribedVariableWarning`, which the test suite turns into an error: add a new variable
here with its meaning and unit (:func:`undescribed` lists the names a dataset lacks).
"""

from __future__ import annotations

import datetime
import json
import re
import shlex
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from types import MappingProxyType

import xarray as xr

CONVENTIONS = "CF-1.10"
PROVENANCE_ATTRS = ("Conventions", "fsistab_version", "software_versions", "source", "history")
# distributions whose versions a file records (besides fsistab's own)
SOFTWARE = ("ngsolve", "netgen-mesher", "numpy", "scipy", "xarray", "h5netcdf", "h5py")


class UndescribedVariableWarning(UserWarning):
    """A variable written without ``units`` or ``long_name``: its name is missing from
    :data:`VARIABLES` (the test suite turns this warning into an error)."""


@dataclass(frozen=True)
class Field:
    """The CF description of one variable: ``long_name`` and ``units`` (None for text, which has
    no unit)."""

    long_name: str
    units: str | None = "1"

    def attrs(self) -> dict[str, str]:
        return {"long_name": self.long_name} | ({} if self.units is None else {"units": self.units})


def _text(long_name: str) -> Field:
    return Field(long_name, None)


_U = "reduced velocity U* (body's convention, docs/model.md §2, §10)"
_M = "mass ratio m (body's convention, docs/model.md §2, §10)"
_W = "angular frequency omega (time unit L/U)"
_SIGMA = "of sigma = lambda + i omega (time unit L/U)"


def _limit_cycle_fields() -> dict[str, Field]:
    """The saturated oscillation of each signal of ``fsistab lco`` (fsistab.lco), on the sweep by
    increasing U* and (prefix ``decreasing_``) by decreasing U*."""
    signals = {"heave": ("heave h", "1"), "pitch": ("pitch theta", "rad"), "lift": ("lift coefficient", "1")}
    fields = {"error": _text("error message of a failed point")}
    for name, (what, unit) in signals.items():
        fields |= {
            f"{name}_amplitude": Field(
                f"amplitude of the {what}: mean half peak-to-peak of its last periods (modulated: of the "
                "second half's)",
                unit,
            ),
            f"{name}_frequency": Field(f"angular frequency of the {what} over its last periods (U/L)"),
            f"{name}_mean": Field(f"mid-level of the {what} oscillation", unit),
            f"{name}_change": Field(f"relative change per period of the {what} envelope"),
            f"{name}_saturated": Field(f"1 when the {what} oscillation is a limit cycle (saturated)"),
            f"{name}_state": _text(
                f"the {what} march: saturated, modulated (the envelope rises and falls over the second "
                "half), growing, decaying, too short or transient (the envelope test cannot tell it from "
                "the start mode's linear transient)"
            ),
            f"{name}_periods": Field(f"whole periods of the {what} in the march"),
            f"{name}_low": Field(f"smallest period amplitude of the {what} over the second half", unit),
            f"{name}_high": Field(f"largest period amplitude of the {what} over the second half", unit),
            f"{name}_largest": Field(
                f"largest excursion of the {what} from its mid-level over the second half", unit
            ),
        }
    fields |= {
        "start_growth_rate": Field("growth rate lambda of the eigenmode the march started from (U/L)"),
        "start_frequency": Field("angular frequency omega of the eigenmode the march started from (U/L)"),
    }
    fields["start_state"] = _text(
        "state of the leading signal of the march this one started from (the one above; 'not chained' "
        "for the sweep's top)"
    )
    fields |= {
        f"decreasing_{k}": Field(f"{v.long_name} (sweep by decreasing U*)", v.units)
        for k, v in fields.items()
    }
    fields["threshold_velocity"] = Field(f"linear threshold: {_U}")
    return fields


# every variable and coordinate name, in the meaning it has in every file that holds it
VARIABLES: Mapping[str, Field] = MappingProxyType(
    {
        # --- flow, mesh, steady state
        "state": Field("steady flow state: velocity and pressure degrees of freedom"),
        "reynolds": Field("Reynolds number on the body length, Re = U L / nu"),
        "alpha0_deg": Field("steady angle of attack alpha0, nose-up positive", "degree"),
        "alpha0": Field("steady angle of attack alpha0, nose-up positive", "degree"),
        "newton_residual": Field("Newton residual norm of the steady equations at each iteration"),
        "path_reynolds": Field("Reynolds number of each continuation step of the steady state"),
        "path_alpha0_deg": Field("angle of attack of each continuation step of the steady state", "degree"),
        "path_iterations": Field("Newton iterations of each continuation step of the steady state"),
        # --- steady coefficients and slopes (docs/model.md §4, §9)
        "lift_coefficient": Field("lift coefficient C_L = L / (0.5 rho U^2 L s)"),
        "moment_coefficient": Field(
            "moment coefficient C_M about the pitch axis (G, or the elastic axis), counter-clockwise positive"
        ),
        "drag_coefficient": Field("drag coefficient C_D = D / (0.5 rho U^2 L s)"),
        "recirculation_length": Field("length of the recirculation region behind the body (in L)"),
        "lift_slope_alpha": Field("static lift slope dC_L/dalpha, alpha = -theta", "rad-1"),
        "moment_slope_alpha": Field(
            "static moment slope d(-C_M)/dalpha about the pitch axis (mid-chord, or the elastic axis)",
            "rad-1",
        ),
        "drag_slope_theta": Field("static drag slope dC_D/dtheta", "rad-1"),
        # --- eigenvalues (docs/model.md §7)
        "mode": Field("index of the eigenmode, least stable first"),
        "growth_rate": Field(f"growth rate lambda {_SIGMA}"),
        "frequency": Field(_W),
        "residual": Field("relative residual of the eigenpair"),
        "label": _text("part of the system the mode lives in (fluid or solid)"),
        "solid_energy_fraction": Field("share of the mode's energy in the solid"),
        "shift": Field("complex shift of the shift-invert or of the reduced model (time unit L/U)"),
        "solid": Field("solid part (h, theta, hdot, thetadot) of the eigenmode"),
        "solid_state": _text("solid state: h heave, theta pitch (rad), hdot, thetadot"),
        "part": _text("part of a complex number: real or imag"),
        "shift_real": Field("real part of the eigenvalue guess (time unit L/U)"),
        "shift_imag": Field("imaginary part of the eigenvalue guess (time unit L/U)"),
        "mode_growth_rate": Field(f"growth rate lambda of the fixed body's mode {_SIGMA}"),
        "mode_frequency": Field(f"angular frequency omega of the fixed body's mode {_SIGMA}"),
        "mode_residual": Field("relative residual of the fixed body's eigenpair"),
        # --- onset of the fixed body's instability (secant iterates)
        "iterate": Field("index of the secant iterate"),
        "steady_seconds": Field("wall-clock time of the iterate's steady state", "s"),
        "eigen_seconds": Field("wall-clock time of the iterate's eigenvalue", "s"),
        "factorisations": Field("number of sparse LU factorisations"),
        "steady_from_cache": Field("1 when the iterate's steady state was read from the cache"),
        # --- thresholds along U* (docs/model.md §8)
        "threshold": Field("index of the threshold along U*"),
        "kind": _text("kind of threshold or curve: flutter, divergence or viv"),
        "boundary": _text("onset (unstable above U*_c) or restabilisation"),
        "reduced_velocity": Field(_U),
        "mass_ratio": Field(_M),
        "frequency_ratio": Field("critical frequency over the pitch natural frequency, omega_c U*_c"),
        "flutter_frequency_ratio": Field("flutter frequency over the pitch natural frequency, omega_F U*_F"),
        "leading_growth_rate": Field(f"growth rate lambda of the study point's leading mode {_SIGMA}"),
        "leading_frequency": Field("angular frequency of the study point's leading mode (time unit L/U)"),
        "wake_frequency": Field("angular frequency of the fixed body's wake mode (time unit L/U)"),
        "threshold_reduced_velocity": Field(f"critical {_U}"),
        "threshold_frequency": Field("critical angular frequency omega_c (time unit L/U)"),
        "threshold_heave_share": Field("heave share of the critical mode's solid energy"),
        "threshold_pitch_share": Field("pitch share of the critical mode's solid energy"),
        "threshold_fluid_share": Field("fluid share of the critical mode's energy near the body"),
        "threshold_frequency_over_heave": Field("critical frequency over the heave natural frequency"),
        "threshold_frequency_over_pitch": Field("critical frequency over the pitch natural frequency"),
        "threshold_frequency_over_wake": Field("critical frequency over the wake mode's frequency"),
        "threshold_heave_alone_growth": Field("growth rate with heave alone at the threshold (in U/L)"),
        "threshold_pitch_alone_growth": Field("growth rate with pitch alone at the threshold (in U/L)"),
        "threshold_kind": _text("kind of threshold: flutter, divergence or viv"),
        "threshold_boundary": _text("onset (unstable above U*_c) or restabilisation"),
        "threshold_branch": _text("eigenvalue branch the threshold lies on"),
        "threshold_class": _text("class of threshold: coupled-mode, heave or pitch flutter, divergence, viv"),
        "threshold_unresolved_intervals": Field("number of frequency intervals left unresolved"),
        # --- neutral curves and maps in (m, U*) (docs/model.md §8)
        "point": Field("index of the point along the curve"),
        "curve": Field("index of the curve the point belongs to"),
        "curve_index": Field("index of the curve"),
        "curve_mass_ratio": Field(f"{_M} along the neutral curves"),
        "curve_reduced_velocity": Field(f"{_U} along the neutral curves"),
        "curve_frequency": Field(f"critical {_W} along the neutral curves"),
        "curve_unstable_side": Field("side of instability: +1 larger U* at fixed m, -1 smaller, 0 unknown"),
        "curve_kind": _text("kind of neutral curve: flutter or viv"),
        "curve_frequency_following": Field("range of log(frequency) over range of log(U*) along the curve"),
        "curve_seed_mass_ratio": Field(f"{_M} where the curve was seeded"),
        "curve_stop_low": _text("why the curve stopped at its low end"),
        "curve_stop_high": _text("why the curve stopped at its high end"),
        "fold": Field("index of the turning point"),
        "fold_curve": Field("index of the curve of the turning point"),
        "fold_mass_ratio": Field(f"{_M} at the turning point"),
        "fold_reduced_velocity": Field(f"{_U} at the turning point"),
        "fold_frequency": Field(f"critical {_W} at the turning point"),
        "fold_index": Field("index of the curve point before the turning point"),
        "fold_localised": Field("1 when the turning point was located on the curve, 0 when bracketed"),
        "last_mode": Field("critical mode at the curve's last point (state to resume from)"),
        "crossing": Field("index of the crossing of two curves"),
        "crossing_first": Field("index of the first curve of the crossing (-1: divergence)"),
        "crossing_second": Field("index of the second curve of the crossing (-1: divergence)"),
        "crossing_mass_ratio": Field(f"{_M} at the crossing"),
        "crossing_reduced_velocity": Field(f"{_U} at the crossing"),
        "crossing_first_kind": _text("kind of the first curve of the crossing"),
        "crossing_second_kind": _text("kind of the second curve of the crossing"),
        "crossing_first_frequency": Field(f"{_W} of the first curve at the crossing"),
        "crossing_second_frequency": Field(f"{_W} of the second curve at the crossing"),
        "unresolved": Field("index of the unresolved frequency interval"),
        "unresolved_low": Field("low end of the unresolved frequency interval (time unit L/U)"),
        "unresolved_high": Field("high end of the unresolved frequency interval (time unit L/U)"),
        "unresolved_reason": _text("why the frequency interval is unresolved"),
        "divergence_reduced_velocity": Field(f"divergence {_U}, U*_D = sqrt(m r_theta^2 / (dC_M/dtheta))"),
        "grid_mass_ratio": Field(f"{_M} of the shading grid"),
        "grid_reduced_velocity": Field(f"{_U} of the shading grid"),
        "unstable_count": Field("number of unstable eigenvalues at the grid point"),
        "shading_family": _text("family of curves: divergence, flutter or viv"),
        "unshaded": Field("1 where the family's crossings do not add up (a curve missing)"),
        "map_point": Field("index of the map's curve point"),
        "map_mass_ratio": Field(f"{_M} along the map's dynamic curves"),
        "map_reduced_velocity": Field(f"{_U} along the map's dynamic curves"),
        "map_frequency": Field(f"critical {_W} along the map's dynamic curves"),
        "map_curve": Field("index of the map's curve of the point (-1: padding)"),
        "map_kind": _text("kind of the map's curve: flutter or viv"),
        "map_divergence_coefficient": Field("divergence law U*_D / sqrt(m)"),
        "map_data": _text("path of the map's own NetCDF file"),
        # --- neutral curves in the flow plane
        "parameter_value": Field("value of the flow parameter along the curve"),
        "fold_parameter_value": Field("value of the flow parameter at the turning point"),
        "fold_reynolds": Field("Reynolds number at the turning point"),
        "fold_alpha0_deg": Field("angle of attack at the turning point", "degree"),
        "direction": Field("direction of continuation in the flow parameter: -1 down, +1 up"),
        "stop": _text("why the curve stopped"),
        # --- transfer functions (docs/model.md §7, §9)
        "transfer": Field("aerodynamic transfer matrix G: loads (F_x, F_y, M) [rho U^2 L] per unit state"),
        "transfer_rate": Field("derivative dG/ds of the aerodynamic transfer matrix"),
        "reduced": Field("1 where G comes from a certified reduced model or fit, 0 from a factorisation"),
        "sample": Field("index of the frequency sample"),
        "record": Field("index of the record"),
        "load": _text("body-axis load: force_x, force_y, moment (about the pitch axis, counter-clockwise +)"),
        "reduced_frequency": Field("reduced frequency k = omega b / U, b = L/2"),
        "coefficient": _text("load coefficient: lift or moment"),
        "motion": _text("motion: heave or pitch"),
        "viscous_loads": Field("viscous lift and moment coefficients per unit heave and pitch"),
        "theodorsen_thin_airfoil": Field("Theodorsen loads per unit heave and pitch, thin-airfoil slopes"),
        "theodorsen_calibrated": Field("Theodorsen loads per unit heave and pitch, viscous static slopes"),
        # --- reduced models of G (fsistab.reduced_model)
        "model": Field("index of the reduced model"),
        "jr": Field("reduced stiffness J_r of K_r(s) = J_r + s M_r"),
        "mr": Field("reduced mass M_r of K_r(s) = J_r + s M_r"),
        "br0": Field("reduced input B_0 of B(s) = B_0 + s B_1"),
        "br1": Field("reduced input B_1 of B(s) = B_0 + s B_1"),
        "lf": Field("reduced output L_f of L(s) = L_f + s L_m"),
        "lm": Field("reduced output L_m of L(s) = L_f + s L_m"),
        "load_s": Field("direct load term of G(s) = load_s + s load_mass_s - L K_r^-1 B"),
        "load_mass_s": Field("direct inertial load term of G(s)"),
        "ends": Field("sizes of the nested Krylov bases of the model"),
        "interval": Field("frequency interval where the model is certified (time unit L/U)"),
        "built_shift": Field("shift of a reduced model as it was built (time unit L/U; the models' index)"),
        "built_interval": Field(
            "frequency interval a reduced model was certified on when built (time unit L/U)"
        ),
        # --- Theodorsen typical section (docs/model.md §9)
        "branch": _text("p-k branch of the typical section"),
        "onset": Field("1 onset, 0 restabilisation, -1 no boundary"),
        "divergence_velocity": Field(f"divergence {_U} of the typical section"),
        "comparison": Field("index of the compared mass ratio"),
        "comparison_mass_ratio": Field(f"{_M} of the comparison"),
        "comparison_viscous": Field(f"lowest flutter {_U} of the viscous map"),
        "comparison_theodorsen": Field(f"lowest flutter {_U} of the Theodorsen model"),
        "comparison_relative_error": Field("relative error of the Theodorsen flutter U* on the viscous one"),
        "viscous_divergence_mass_ratio": Field(f"{_M} of the viscous divergence curve"),
        "viscous_divergence_reduced_velocity": Field(f"{_U} of the viscous divergence curve"),
        # --- adjoint sensitivities (docs/reference/sensitivity.md)
        "parameter": _text("parameter of the derivative"),
        "unit": _text("unit of the parameter"),
        "d_reduced_velocity": Field("derivative dU*_c/dp of the critical U*, per unit of p (see unit)"),
        "d_frequency": Field("derivative domega_c/dp of the critical frequency, per unit of p (see unit)"),
        "d_growth_rate": Field(
            "derivative dlambda/dp of the growth rate at fixed U*, per unit of p (see unit)"
        ),
        "d_eigenfrequency": Field(
            "derivative domega/dp of the frequency at fixed U*, per unit of p (see unit)"
        ),
        "adjoint_residual": Field("relative residual of the adjoint mode"),
        "adjoint_iterations": Field("iterative refinements of the adjoint solve"),
        "target": _text("eigenvalue of the map: a threshold (kind and index) or the wake mode"),
        "vertex": Field("index of the mesh vertex"),
        "x": Field("streamwise coordinate of the mesh vertex in the body frame (in L)"),
        "y": Field("cross-stream coordinate of the mesh vertex in the body frame (in L)"),
        "force_x": Field("eigenvalue sensitivity dsigma per unit streamwise steady force density"),
        "force_y": Field("eigenvalue sensitivity dsigma per unit cross-stream steady force density"),
        "control": Field("eigenvalue change dsigma of a small control cylinder at the vertex"),
        "structural": Field("structural sensitivity |u_adjoint| |u| of the mode"),
        "d_reduced_velocity_force_x": Field("dU*_c per unit streamwise steady force density"),
        "d_reduced_velocity_force_y": Field("dU*_c per unit cross-stream steady force density"),
        "d_reduced_velocity_control": Field("dU*_c of a small control cylinder at the vertex"),
        "eigenvalue": Field("eigenvalue sigma = lambda + i omega (time unit L/U) of the target"),
        "slope": Field("derivative dsigma/dU* of the target's eigenvalue"),
        "wall_distance": Field("distance of the vertex to the body's wall (in L)"),
        # --- nonlinear time march (fsistab simulate, docs/model.md §11)
        "time": Field("simulated time (in L/U)"),
        "heave": Field("heave displacement h, upwards positive (in L)"),
        "pitch": Field("pitch angle theta, counter-clockwise positive (alpha = -theta)", "rad"),
        "heave_rate": Field("heave velocity dh/dt (in U)"),
        "pitch_rate": Field("pitch rate dtheta/dt (in U/L)", "rad"),
        "chord_iterations": Field("chord (simplified Newton) iterations of the time step"),
        "current_state": Field("coupled state of the last step: active solid states, then fluid dofs"),
        "previous_state": Field("coupled state of the step before the last (the BDF2 history)"),
        "start_eigenvalue": Field("growth rate and frequency of the eigenmode the march started from"),
        # --- parameter studies (fsistab.study)
        "point_factorisations": Field("factorisations of the study point (-1: not computed)"),
        "point_seconds": Field("wall-clock time of the study point", "s"),
        "point_steady_start": _text("where the point's steady state started from"),
        "status": _text("state of the study point: done or failed"),
        "error": _text("error message of a failed study point"),
    }
    | {k: v for k, v in _limit_cycle_fields().items() if k != "error"}
)

# a dimension coordinate whose name means something else as a data variable
DIMENSION_COORDINATES: Mapping[str, Field] = MappingProxyType(
    {
        "state": _text("solid state: h heave, theta pitch (rad), hdot, thetadot"),
        "boundary": Field("index of the flutter boundary at each mass ratio, by increasing U*"),
    }
)

# variables whose unit is that of the dataset's flow parameter (attribute ``parameter``)
_PARAMETER_UNITS = {"reynolds": ("Reynolds number", "1"), "alpha0": ("angle of attack alpha0", "degree")}
BY_PARAMETER: Mapping[str, str] = MappingProxyType(
    {
        "value": "{} of the secant iterate",
        "parameter_value": "{} along the curve",
        "fold_parameter_value": "{} at the turning point",
    }
)

# families of names made from a template: (pattern, long name from the match)
PATTERNS: Sequence[tuple[re.Pattern, str]] = (
    (re.compile(r"viscous_flutter(\d+)_mass_ratio"), "mass ratio m of the viscous flutter curve {0}"),
    (
        re.compile(r"viscous_flutter(\d+)_reduced_velocity"),
        "reduced velocity U* of viscous flutter curve {0}",
    ),
    (re.compile(r"(\w+)_shape"), "shape of each record's {0} (a resumable table's ragged field)"),
)


def field_for(name: str, variable: xr.Variable, attrs: Mapping) -> Field | None:
    """The dictionary's description of variable ``name`` (its ``variable`` and the dataset's
    ``attrs`` settle the names whose meaning depends on them), or None if it is not described."""
    if variable.dims == (name,) and name in DIMENSION_COORDINATES:
        return DIMENSION_COORDINATES[name]
    if name in BY_PARAMETER:
        known = _PARAMETER_UNITS.get(str(attrs.get("parameter")))
        return None if known is None else Field(BY_PARAMETER[name].format(known[0]), known[1])
    if name in VARIABLES:
        return VARIABLES[name]
    for pattern, long_name in PATTERNS:
        match = pattern.fullmatch(name)
        if match:
            return Field(long_name.format(*match.groups()))
    return None


def _is_text(variable: xr.Variable) -> bool:
    return variable.dtype.kind in "OUS"


def annotate(ds: xr.Dataset) -> xr.Dataset:
    """A shallow copy of ``ds`` whose variables and coordinates carry ``long_name`` and ``units``
    from the dictionary where they have none of their own (text variables get no ``units``)."""
    out = ds.copy(deep=False)
    for name, variable in ds.variables.items():
        field = field_for(str(name), variable, ds.attrs)
        if field is None:
            continue
        extra = field.attrs()
        if _is_text(variable):
            extra.pop("units", None)
        target = out.variables[name]
        target.attrs = {**extra, **target.attrs}  # its own attributes win
    return out


def undescribed(ds: xr.Dataset) -> list[str]:
    """Names of the variables and coordinates of ``ds`` without ``long_name``, or without ``units``
    when they hold numbers."""
    return sorted(
        str(name)
        for name, variable in ds.variables.items()
        if "long_name" not in variable.attrs or ("units" not in variable.attrs and not _is_text(variable))
    )


def command_line(argv: Sequence[str]) -> str:
    """The command that runs: ``fsistab steady --Re 40`` for the command line (the ``fsistab``
    script or ``python -m fsistab.cli``), else ``python script.py args`` (``python`` alone when
    interactive)."""
    argv = list(argv)
    if not argv or not argv[0]:
        return "python"
    program = Path(argv[0])
    if program.name == "fsistab" or program.parts[-2:] in (("fsistab", "cli.py"), ("fsistab", "__main__.py")):
        return shlex.join(["fsistab", *argv[1:]])
    return shlex.join(["python", *argv])


def software_versions() -> dict[str, str]:
    """Installed versions of fsistab and of the libraries that compute and write its results (read
    from the package metadata: nothing is imported)."""
    from fsistab import __version__

    versions = {"fsistab": __version__, "python": sys.version.split()[0]}
    for name in SOFTWARE:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions


def provenance(argv: Sequence[str] | None = None, now: datetime.datetime | None = None) -> dict[str, str]:
    """The global attributes that say where a file comes from: ``Conventions``, ``fsistab_version``,
    ``software_versions`` (JSON), ``source`` and ``history`` (``YYYY-MM-DDThh:mm:ssZ fsistab
    neutral --mesh coarse``). ``argv`` defaults to ``sys.argv`` and ``now`` to the present, read
    at each call."""
    from fsistab import __version__

    argv = sys.argv if argv is None else argv
    now = datetime.datetime.now(datetime.UTC) if now is None else now
    stamp = now.astimezone(datetime.UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
    return {
        "Conventions": CONVENTIONS,
        "fsistab_version": __version__,
        "software_versions": json.dumps(software_versions(), sort_keys=True),
        "source": f"fsistab {__version__}",
        "history": f"{stamp} {command_line(argv)}",
    }


def describe(ds: xr.Dataset, argv: Sequence[str] | None = None) -> xr.Dataset:
    """``ds`` as it is written: :func:`annotate`-d, with :func:`provenance`'s global attributes.
    A ``history`` already there (a file read back and written again) is kept below the new line,
    as CF asks; the other provenance attributes describe this write."""
    out = annotate(ds)
    attrs = provenance(argv)
    previous = str(ds.attrs.get("history", "")).strip()
    if previous:
        attrs["history"] += "\n" + previous
    out.attrs = {**ds.attrs, **attrs}
    return out
