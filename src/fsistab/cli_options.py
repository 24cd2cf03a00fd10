"""The options of the command line (:mod:`fsistab.cli`), declared once: each group a dict of
``name: (annotation, default)`` that :func:`fsistab.cli.command` turns into typer options, so that
a command lists the groups it takes and every command spells a shared option the same way."""

from __future__ import annotations

from typing import Annotated

import typer


def option(kind, flag: str, help_text: str, default=None) -> tuple:
    """``(annotation, default)`` of an option ``flag`` of type ``kind`` (a group entry)."""
    return Annotated[kind, typer.Option(flag, help=help_text)], default


Pair = tuple[float, float]

# fmt: off
CASE_OPTIONS = {
    "body": option(str, "--body", "plate, naca0012 (any NACA four-digit section; chord-based units) or "
                    "cylinder (diameter-based)", "plate"),
    "reynolds": option(float, "--Re", "Reynolds number on the body length", 2900.0),
    "alpha0": option(float, "--alpha0", "steady angle of attack, degrees, nose-up +", 0.0),
    "preset": option(str, "--mesh", "mesh preset: coarse, quick or fast (plate), medium or fine", "medium"),
    "mesh_reynolds": option(float | None, "--mesh-reynolds", "fit the mesh preset to this Re instead of "
                             "the flow's (one mesh for a range of Re: study, flow-neutral, onset)"),
    "mesh_sizes": option(str | None, "--mesh-sizes", "NAME=VALUE,... element sizes and refinement extents "
                          "(body lengths) in place of the fitted preset's: wall, corner, near, wake, far, "
                          "middle, band, near_margin, wake_length, wake_half_width "
                          "(e.g. near=0.025,wake=0.1)"),
    "aspect_ratio": option(float, "--aspect-ratio", "plate chord/thickness", 20.0),
    "corner_radius": option(float, "--corner-radius", "plate corner radius / thickness", 0.1),
    "trailing_edge": option(str, "--trailing-edge", "NACA trailing edge: closed or open (blunt)", "closed"),
    "body_file": option(str | None, "--body-file", "a closed curve of points (rows x,y; a header line "
                         "allowed) as the body, splined; scaled to unit chord or --reference-length"),
    "reference_length": option(float | None, "--reference-length",
                                "length unit of --body-file, in the file's units (default: its chord)"),
    "domain": option(tuple[float, float, float] | None, "--domain",
                      "upstream, downstream and lateral extents in body lengths"),
    "sponge": option(str, "--sponge", "outlet sponge of the linear operators: preset (the mesh preset's, "
                      "on its own domain), none, SIGMA_MAX,ZONE (e.g. 0.2,0.25), or SIGMA_MAX,ZONE,FAR_SIGMA,"
                      "FAR_RAMP with a far-field layer outside the middle box and band "
                      "(e.g. 0.2,0.25,0.2,10)", "preset"),
    "outlet": option(str, "--outlet", "outflow condition: stress (symmetric stress-free, σN = 0) or "
                      "gradient (Re⁻¹∂U/∂n = PN)", "stress"),
}

OUTPUT_OPTIONS = {
    "out": option(str, "--out", "directory for figures and data", "fsistab-out"),
    "as_json": option(bool, "--json", "print one JSON object on stdout and nothing else", False),
    "cache": option(str | None, "--cache", "cache directory (default $FSISTAB_CACHE or ~/.cache/fsistab)"),
}

FIGURE_OPTIONS = {"figure_format": option(str, "--format", "figure format: png, pdf or svg (vector)", "png")}

SOLID_OPTIONS = {
    "freq_ratio": option(float, "--freq-ratio", "Ω = ω_h/ω_θ", 0.8),
    "zeta_h": option(float, "--zeta-h", "heave damping ratio", 0.0),
    "zeta_theta": option(float, "--zeta-theta", "pitch damping ratio", 0.05),
    "r_theta": option(float, "--r-theta", "radius of gyration about the elastic axis (G when a = x_θ = 0)",
                       0.289),
    "elastic_axis": option(float, "--elastic-axis",
                            "a: mid-chord → elastic axis (pitch axis), chords, downstream +", 0.0),
    "static_unbalance": option(float, "--static-unbalance",
                                "x_θ: elastic axis → centre of mass, chords, aft +", 0.0),
}

MASS_OPTION = {"mass_ratio": option(float | None, "--mass-ratio",
                                     "m (plate default 1000; cylinder, docs/model.md §10: 20)")}

VELOCITY_OPTION = {"reduced_velocity": option(float | None, "--reduced-velocity",
                                               "U* (plate default 4.7; cylinder: 8)")}

DOFS_OPTION = {"dofs": option(str | None, "--dofs", "heave,pitch | heave | pitch | none")}

VELOCITY_RANGE = option(Pair, "--reduced-velocity-range", "U* range of the (initial) sweep", (2.0, 10.0))

POINTS = option(int, "--points", "U* values of each sweep (log-spaced)", 24)
# fmt: on

# fmt: on
FILES = (OUTPUT_OPTIONS, FIGURE_OPTIONS)  # the options of a command that writes figures

SPRINGS = (SOLID_OPTIONS, DOFS_OPTION)


def sweep_options(wake_help: str) -> dict:
    """The options of a search for every threshold along U* (critical, sensitivity)."""
    return {
        "velocity_range": VELOCITY_RANGE,
        "points": POINTS,
        "wake_shift": option(str | None, "--wake-shift", wake_help),
    }


# fmt: off
SPECTRUM_OPTIONS = {
    "shift": option(list[str] | None, "--shift", "complex shift, repeatable"),
    "n_eigenvalues": option(int, "--n-eigenvalues", "eigenvalues per shift", 6),
    "vtk": (Annotated[bool, typer.Option("--vtk/--no-vtk", help="write the modes as VTK")], True),
    "mode_figures": option(int, "--mode-figures",
                            "pressure snapshots and h(t), -θ(t) of the N least stable modes", 2),
    "phase": option(float, "--phase", "phase (rad) of the pressure snapshots", 0.0),
}
# fmt: on

OUTLINE = (
    "trailing_edge",
    "body_file",
    "reference_length",
)  # shape options of the bodies other than the plate

SLOPES_CASE = {k: v for k, v in CASE_OPTIONS.items() if k not in ("body", "reynolds", *OUTLINE)}

# fmt: off
CRITICAL_OPTIONS = {
    **sweep_options("shift near the wake mode: samples near its frequency (VIV is labelled without it); "
                     "with --method tracking, the wake mode is followed and labels VIV"),
    "method": option(str, "--method", "transfer (G(iω) swept in frequency; --points unused) or tracking "
                      "(eigenvalue branches)", "transfer"),
}
# fmt: on

# fmt: off
# where a command's independent tasks run (fsistab.study.study_client): in this process by default
EXECUTION_OPTIONS = {
    "workers": option(int | None, "--workers", "run on a new dask LocalCluster of N worker processes"),
    "scheduler": option(str | None, "--scheduler", "run on the dask scheduler at ADDRESS (tcp://host:8786)"),
}

MAP_OPTIONS = {
    "mass_range": option(Pair, "--mass-ratio-range", "m range", (1.0, 1e4)),
    "start_mass": option(float, "--start-mass-ratio", "m of the initial sweep", 1000.0),
    "velocity_range": VELOCITY_RANGE,
    "seed_masses": option(list[float] | None, "--seed-mass-ratio", "further sweeps (repeatable; default "
                           "m/10 and m/100 of the start), U* range scaled by √m"),
    "wake_frequency": option(float | None, "--wake-frequency", "guess of the fixed body's wake-mode ω "
                              "(refined by Arnoldi): extra frequencies (transfer) or the VIV sweep at the "
                              "lowest m (continuation); VIV is labelled without it"),
    "points": POINTS,
    "max_points": option(int, "--max-points", "points per curve and direction", 60),
    "method": option(str, "--method", "transfer (G(iω) sweep, default) or continuation (sweeps + arclength)",
                      "transfer"),
    "frequency_range": option(Pair | None, "--frequency-range", "transfer: ω range sampled (default 0.01 to "
                               "max(20, 1.5 ω_wake), extended down while a curve leaves it)"),
    "min_step": option(float | None, "--min-step", "transfer: smallest relative step of the exact "
                        "refinement in ω (default 1e-3; reduced models: 1e-7); below it a certified "
                        "rational fit of the samples refines on to 1e-7 where it can"),
    "tolerance": option(float | None, "--tolerance", "transfer: largest error of the tangent predictions "
                         "between two samples, in (log m, log U*) (default 3e-3; exact samples only: 3e-2)"),
    "max_frequencies": option(int | None, "--max-frequencies", "transfer: at most this many sampled ω "
                               "(default 4000; exact: 400, not counting those from rational fits)"),
    "reduced_blocks": option(int | None, "--reduced-blocks", "transfer: Krylov blocks of the reduced fluid "
                              "models (0: exact samples, one model at a sharp resonance such as the wake "
                              "mode and one at ω = 0; default 60 below 100 000 fluid unknowns, 0 from "
                              "there)"),
    "reduced_tolerance": option(float, "--reduced-tolerance", "transfer: certified error of the reduced "
                                 "models' G", 1e-7),
}
# fmt: on

FLOW_NEUTRAL_OPTIONS = {
    "parameter": option(str, "--parameter", "reynolds or alpha0", "alpha0"),
    "parameter_range": option(Pair, "--range", "range of Re, or of alpha0 in degrees", (0.0, 5.0)),
    "velocity_range": VELOCITY_RANGE,
    "points": POINTS,
    "max_points": option(int, "--max-points", "points per curve and direction", 40),
}

# fmt: off
THEODORSEN_OPTIONS = {
    **SOLID_OPTIONS,
    "mass_ratio": option(float, "--mass-ratio", "m = m_solid/(½ρc²)", 1000.0),
    "mass_range": option(Pair | None, "--mass-ratio-range",
                          "draw the neutral curves U*(m) over this m range"),
    "points": option(int, "--points", "mass ratios of the neutral curves (log)", 40),
    "velocity_range": option(Pair, "--reduced-velocity-range", "U* range searched", (0.01, 100.0)),
    "slopes": option(str, "--slopes", "thin-airfoil | calibrated (viscous, at --Re) | given",
                      "thin-airfoil"),
    "lift_slope_alpha": option(float | None, "--lift-slope-alpha", "dC_L/dα per radian (--slopes given)"),
    "moment_slope_alpha": option(float | None, "--moment-slope-alpha",
                                  "d(-C_M)/dα about mid-chord per radian (--slopes given)"),
}
# fmt: on

# fmt: on
THEODORSEN_CASE = CASE_OPTIONS  # the section whose calibrated slopes and viscous map are used

# fmt: off
TRANSFER_OPTIONS = {
    "k_range": option(Pair, "--reduced-frequency-range", "k = ω L/(2U∞) range, log-spaced", (0.01, 2.0)),
    "points": option(int, "--points", "number of reduced frequencies", 24),
}

ONSET_OPTIONS = {
    "guess": (Annotated[float, typer.Option("--guess", help="first guess of the critical value (Re, or "
                                            "alpha0 in degrees)")], ...),
    "parameter": option(str, "--parameter", "reynolds or alpha0", "reynolds"),
    "shift": option(str | None, "--shift", "guess of the leading eigenvalue, e.g. 0.75j (cylinder default)"),
}
# fmt: on

STUDY_CASE = {k: v for k, v in CASE_OPTIONS.items() if k not in ("reynolds", "alpha0")}

EXTRA_ARGS = {"ignore_unknown_options": True, "allow_extra_args": True}  # the lists of study_lists

# fmt: off
STUDY_OPTIONS = {
    "slopes": option(bool, "--slopes", "steady C_L, C_M, C_D, recirculation length, static slopes", False),
    "modes": option(bool, "--modes", "the fixed body's least stable eigenvalues", False),
    "shift": option(list[str] | None, "--shift",
                     "eigenvalue guess of --modes, repeatable (cylinder default 0.75j)"),
    "n_modes": option(int, "--n-modes", "eigenvalues kept per point", 4),
    "velocity_range": VELOCITY_RANGE,
    "points": POINTS,
    "wake_shift": option(str | None, "--wake-shift", "shift near the wake mode: samples near its frequency, "
                          "which the classification also tests (rule 2); VIV is recognised without it"),
    "with_map": option(bool, "--map", "the whole (m, U*) map at each point (plate)", False),
    **EXECUTION_OPTIONS,
}
# fmt: on

SENSITIVITY_OPTIONS = sweep_options(
    "shift near the wake mode: samples near its frequency, and map the fixed body's"
)

# fmt: off
SIMULATE_OPTIONS = {
    "duration": option(float, "--duration", "simulated time, in the body's time unit L/U", 100.0),
    "time_step": option(float, "--time-step", "time step of the BDF2 march, in L/U", 0.05),
    "perturbation": option(float, "--perturbation", "size of the start: the eigenmode's largest entry, "
                            "or the released body's heave or pitch (--perturbation-of)", 1e-3),
    "perturbation_of": option(str, "--perturbation-of", "largest: the steady state plus the eigenmode "
                               "scaled on its largest entry; heave | pitch: the body released from the "
                               "mode's solid state with that heave (body lengths) or pitch (radians), "
                               "the fluid steady", "largest"),
    "shift": option(str | None, "--shift", "start from the eigenmode nearest this complex shift "
                     "(default: the body's spectrum shift); a released body (--perturbation-of "
                     "heave or pitch) from the nearest of six not labelled fluid, if any"),
    "start": option(str | None, "--start", "start from the last state of this simulation checkpoint "
                     "(same body, flow and dofs; e.g. a saturated state at another U*) instead; "
                     "marched on another mesh (kept in its cache), it is interpolated onto this one"),
    "checkpoint_every": option(int, "--checkpoint-every", "steps between checkpoints (a rerun resumes "
                                "from the last one)", 100),
    "tolerance": option(float, "--step-tolerance", "each step's chord iteration stops when the largest "
                         "entry of its update is below this", 1e-9),
    "max_iterations": option(int, "--max-step-iterations", "chord iterations allowed per step before the "
                              "march fails (a large-amplitude cycle needs more than a small one)", 30),
    "snapshot_interval": option(float | None, "--snapshot-interval", "write the velocity and pressure as "
                                 "VTK every this much simulated time"),
    "animation": option(str | None, "--animation", "also animate the vorticity near the body, one frame per "
                         "snapshot (needs --snapshot-interval) of the steps marched in this run: gif, or mp4 "
                         "(needs ffmpeg); written as simulate_<tag>_vorticity.<format> in --out"),
}
# fmt: on

# fmt: off
LCO_OPTIONS = {
    "velocity_range": (Annotated[Pair, typer.Option("--reduced-velocity-range",
                                                     help="U* of the first and last march (body "
                                                     "convention)")], ...),
    "points": option(int, "--points", "marches, at equally spaced U* (1: the first U* only)", 5),
    **{k: v for k, v in SIMULATE_OPTIONS.items() if k not in ("snapshot_interval", "animation")},
    "periods": option(int, "--periods", "whole periods over which the saturation is judged and the "
                       "amplitude taken", 4),
    "saturation_tolerance": option(float, "--saturation-tolerance", "saturated when the envelope changes "
                                    "by less than this (relative) per period", 0.01),
    "hysteresis": option(bool, "--hysteresis", "also sweep by decreasing U*, each march from the "
                          "saturated state of the one above", False),
    "thresholds": (Annotated[bool, typer.Option("--thresholds/--no-thresholds",
                                                 help="mark the linear thresholds (fsistab critical on the "
                                                 "same mesh)")], True),
    **EXECUTION_OPTIONS,
}
# fmt: on
