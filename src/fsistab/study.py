"""Parameter studies over flow points (Re, α0), one task per point, in-process or on dask.distributed.

A study is a grid of flow points ``(Re, α0)`` (:class:`StudySettings`); at each point
:func:`run_point` computes what is asked among

* ``slopes``: the steady coefficients ``C_L``, ``C_M``, ``C_D`` (docs/model.md §5 conventions), the
  recirculation length and the static slopes ``dC_L/dα``, ``d(-C_M)/dα`` (docs/model.md §9);
* ``modes``: the fixed body's least stable eigenvalues ``σ = λ + iω`` near given shifts
  (docs/model.md §7), growth rate and frequency;
* ``thresholds``: at each given mass ratio every threshold along U* (docs/model.md §8, the branch
  frequency sweep of the exact transfer function of :func:`fsistab.critical.find_thresholds`), each
  **classified** (below);
* ``map``: the whole ``(m, U*)`` map of :func:`fsistab.workflows.stability_map` (plate only).

Classification of a threshold (:func:`classify`)
-------------------------------------------------
From the critical mode ``q̂`` at ``(m, U*_c)`` with frequency ``ω_c`` (``U∞/L``), the kinetic
energies near the body (as :func:`fsistab.eigen.label_mode`, units ``ρL²U∞²``)::

    E_h = (m/4)|ḣ|²,   E_θ = (m/4) r_θ²|θ'|²,   E_f = ½ ∫_{|x - G| < L} |û|²,

(with a static unbalance, ``E_h`` is the heave of the centre of mass and ``E_θ`` the rest,
:func:`fsistab.coupled.solid_energies`, docs/model.md §3.1),

the fluid share ``e_f = E_f/(E_h + E_θ + E_f)`` and the heave share of the solid energy
``s_h = E_h/(E_h + E_θ)``; the in-vacuo frequencies ``ω_h = Ω/U*`` and ``ω_θ = 1/U*`` (generic
units, docs/model.md §2; for the cylinder ``ω_h = 2π/U*`` in its own U*, docs/model.md §10) and the wake
frequency ``ω_w`` (the fixed body's wake mode followed from ``wake_shift``, when given). In order:

1. ``divergence``: a static threshold, ``ω_c = 0`` (:func:`fsistab.critical.divergence_point`);
2. ``viv`` by the wake: the threshold is the wake mode's — its own kind is ``viv`` (its frequency
   stays locked while the solid's moves: the local frequency following of its neutral curve,
   :func:`fsistab.frequency_sweep.local_following`, which needs no ``ω_w``) or it lies on the
   tracked wake branch — or ``ω_c`` is within 30 % of ``ω_w`` and nearer to it than to both
   ``ω_h`` and ``ω_θ``;
3. for a body with heave and pitch, by mechanism (:func:`single_dof_growth`): the growth rates
   ``λ_h``, ``λ_θ`` of the structural modes of the body with only heave (pitch clamped) and with
   only pitch, at the same ``m`` and ``U*_c``. The critical mode's own dof is the one holding
   more of its solid energy (heave if ``E_h ≥ E_θ``). ``heave`` (``pitch``) ``single-mode
   flutter`` if that dof alone is unstable there (``λ ≥ 0``) and, when the fluid holds at least
   half the energy, ``ω_c`` lies within 30 % of that dof's in-vacuo frequency: one dof, at its own
   frequency, extracts energy from the flow by itself (near stall the separated flow responds
   strongly to the pitching and holds most of the energy near the body, yet the mechanism is the
   pitch's). A mode led by one dof whose other dof alone is unstable is not that other dof's
   single-mode flutter: it is rule 5's;
4. ``viv`` by energy: the fluid holds at least half the energy (``e_f ≥ 1/2``): a wake mode
   carrying the body;
5. with the one-dof rates of rule 3: ``coupled-mode flutter``, neither dof alone explaining the
   instability of this mode (the textbook definition: the coupling of the two makes it);
   without them (one dof, or the rates not computed), by energy: ``heave single-mode flutter``
   when ``s_h ≥ 3/4``, ``pitch single-mode flutter`` when ``s_h ≤ 1/4``, else ``coupled-mode
   flutter``. Energy alone misleads for the plate: its coupled-mode flutter at Re 2900,
   m = 1000 holds 94 % of the kinetic energy in heave (``r_θ² = 0.084`` weighs pitch down), yet
   heave alone and pitch alone are both stable there (growth rates −0.003 and −0.014 on the
   coarse mesh), as Moulin & Marquet 2021 says.

Without ``ω_w`` (no ``wake_shift``) rule 2 rests on the threshold's kind alone: the sweep
recognises a lock-in on the wake by itself. ``wake_shift`` adds the frequency test, which also
calls VIV a threshold of kind ``flutter`` (its frequency following the solid's) lying within 30 %
of ``ω_w`` and nearer to it than to the solid frequencies.

The shares and the ratios ``ω_c/ω_h``, ``ω_c/ω_θ``, ``ω_c/ω_w`` are kept in the study's data, so
that the class can be checked or redrawn with other thresholds.

Execution
---------
Each point is an independent task (:func:`run_point` then a checksummed NetCDF written
atomically to ``out/points/<tag>_<key>.nc``, with the point's identity: case, mesh key,
settings; :func:`point_path`). :func:`run_study` runs the points not yet finished: in this
process one after the other (no dask needed), or on a ``dask.distributed`` client (a
``LocalCluster`` of worker processes, or an existing scheduler) where every point is one
``client.submit``; the scheduler places them, and a worker that dies loses only its running
point (dask resubmits it elsewhere; after repeated deaths it is reported as failed and a rerun
computes it). A rerun skips the points whose file verifies (checksum and identity); a damaged one
is reported, moved aside and recomputed (:func:`fsistab.store.read_cached`). A point that fails
is reported with its error; the others go on. The assembled :class:`xarray.Dataset` (dimensions
``reynolds``, ``alpha0`` and per quantity ``mode``, ``mass_ratio``, ``threshold``,
``map_point``; ``status`` and ``error`` per point) is written by :func:`fsistab.store.write_dataset`.

Steady states along Re and α0 under parallel execution: every worker shares the cache directory
(meshes and steady states are written atomically under keys of everything they depend on, so two
workers computing the same entry write the same content). A point first looks for its own cached
steady state; otherwise it continues from the nearest point of the study on the same mesh whose
steady state is already in the cache (distance ``|Δ log Re| + |Δα0|/10°``: the mesh is fitted to
Re, so along α0 at fixed Re the neighbours always share it, and with the case's ``mesh_reynolds``
every point shares one mesh); otherwise it starts from rest
(:func:`fsistab.steady.solve_steady`'s own continuation). The points are submitted in order of
increasing Re and ``|α0|``, so that with N workers the first N start from rest and later ones
usually find a finished neighbour. Which neighbour was used depends on timing; the steady state
differs only within the Newton tolerance, so the results agree to that accuracy.
"""

from __future__ import annotations

import contextlib
import json
import math
import time
from collections.abc import Iterator
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np
import xarray as xr

from fsistab.bodies import body_type
from fsistab.errors import CacheError, FsistabError, InputError
from fsistab.neutral_point import STATIC_FREQUENCY
from fsistab.params import (
    MAX_MASS_RATIO,
    MAX_REYNOLDS,
    Case,
    Flow,
    MapSettings,
    Solid,
    SweepSettings,
    body_velocity_scale,
    solid_for,
)
from fsistab.progress import Progress

CLASSES = (
    "coupled-mode flutter",
    "pitch single-mode flutter",
    "heave single-mode flutter",
    "divergence",
    "viv",
)
MAX_GRID_VALUES = 200  # values of Re or α0 in one study
MAX_MASS_RATIOS = 20
MAX_ALPHA0 = 45.0  # degrees, as fsistab.params.Flow
# |ω_c/ω_ref - 1| below which ω_c is at ω_ref: the wake's (VIV, as find_thresholds) or a dof's
FREQUENCY_BAND = 0.3
SINGLE_MODE_SHARE = 0.75  # share of the solid energy in one dof beyond which flutter is single-mode


def _values(name: str, values, low: float, high: float, positive: bool) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in values)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be numbers, got {values!r}") from None
    if not values:
        raise InputError(f"give at least one value of {name}")
    if len(values) > MAX_GRID_VALUES:
        raise InputError(f"at most {MAX_GRID_VALUES} values of {name}, got {len(values)}")
    for v in values:
        bad = not math.isfinite(v) or v > high or (v <= 0 if positive else v < low)
        if bad:
            where = f"(0, {high:g}]" if positive else f"[{low:g}, {high:g}]"
            raise InputError(f"every value of {name} must be in {where}, got {v:g}")
    if len(set(values)) != len(values):
        raise InputError(f"the values of {name} must be distinct, got {', '.join(f'{v:g}' for v in values)}")
    return tuple(sorted(values))


LIST_OPTIONS = {"--Re": "reynolds", "--alpha0": "alpha0", "--thresholds": "thresholds"}


def study_lists(args: list[str]) -> dict[str, list[float]]:
    """The space-separated values of ``--Re``, ``--alpha0`` and ``--thresholds`` on the command
    line (``--Re 100 500 --alpha0 -4 0 4``), which click's options (one value each) cannot take;
    anything else left over is refused in one line."""
    lists: dict[str, list[float]] = {}
    current = None
    for token in args:
        name, _, inline = token.partition("=") if token.startswith("--") else (token, "", "")
        if token.startswith("--"):
            if name not in LIST_OPTIONS:
                raise InputError(f"no such option: {name}")
            current = LIST_OPTIONS[name]
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
            option = next(k for k, v in LIST_OPTIONS.items() if v == current)
            raise InputError(f"{token!r} is not a number (after {option})") from None
    return lists


@dataclass(frozen=True)
class StudySettings:
    """What a study computes: the grid ``reynolds`` × ``alpha0`` (degrees, nose-up +) and, at each
    point, ``slopes``, ``modes`` (the ``n_modes`` least stable fixed-body eigenvalues near
    ``shifts``), ``thresholds`` (every threshold along U* over ``velocity_range``, ``points``
    log-spaced values, at each mass ratio of ``thresholds``, body conventions; the wake mode
    followed from ``wake_shift`` when given) and ``map`` (settings ``map_settings``). The solid
    parameters other than ``m`` and ``U*`` are ``freq_ratio``, ``zeta_h``, ``zeta_theta``,
    ``r_theta``, ``dofs`` (None: the body's default), ``elastic_axis`` and ``static_unbalance``
    (docs/model.md §3.1; the cases' meshes must be in the frame of the same axis). Every value is
    checked on creation; what depends on the body is checked by :meth:`check_body`."""

    reynolds: tuple[float, ...]
    alpha0: tuple[float, ...] = (0.0,)
    slopes: bool = False
    modes: bool = False
    shifts: tuple[complex, ...] = ()
    n_modes: int = 4
    thresholds: tuple[float, ...] = ()
    velocity_range: tuple[float, float] = (2.0, 10.0)
    points: int = 24
    wake_shift: complex | None = None
    map: bool = False
    map_settings: MapSettings = field(default_factory=MapSettings)
    freq_ratio: float = 0.8
    zeta_h: float = 0.0
    zeta_theta: float = 0.05
    r_theta: float = 0.289
    dofs: tuple[str, ...] | None = None
    elastic_axis: float = 0.0
    static_unbalance: float = 0.0

    @classmethod
    def from_options(cls, lists: dict, options: dict) -> StudySettings:
        """The settings of ``fsistab study``: the value lists of :func:`study_lists` and the raw
        values of its other options (complex shifts and dofs as text)."""
        from fsistab.params import parse_complex, parse_dofs

        wake = options["wake_shift"]
        keys = ("slopes", "modes", "n_modes", "velocity_range", "points")
        keys += ("freq_ratio", "zeta_h", "zeta_theta", "r_theta", "elastic_axis", "static_unbalance")
        return cls(
            reynolds=tuple(lists["reynolds"]),
            alpha0=tuple(lists.get("alpha0", [0.0])),
            thresholds=tuple(lists.get("thresholds", ())),
            shifts=tuple(parse_complex("shift", z) for z in options["shift"] or ()),
            wake_shift=None if wake is None else parse_complex("wake shift", wake),
            map=options["with_map"],
            dofs=None if options["dofs"] is None else parse_dofs(options["dofs"], options["body"]),
            **{key: options[key] for key in keys},
        )

    def __post_init__(self):
        object.__setattr__(self, "reynolds", _values("--Re", self.reynolds, 0.0, MAX_REYNOLDS, True))
        object.__setattr__(self, "alpha0", _values("--alpha0", self.alpha0, -MAX_ALPHA0, MAX_ALPHA0, False))
        if not (self.slopes or self.modes or self.thresholds or self.map):
            raise InputError("nothing to compute: give --slopes, --modes, --thresholds M... and/or --map")
        shifts = tuple(complex(z) for z in self.shifts)
        for z in shifts:
            if not (math.isfinite(z.real) and math.isfinite(z.imag)) or z.imag < 0:
                raise InputError(f"every --shift must be finite with a frequency >= 0, got {z}")
        if len(shifts) > 20:
            raise InputError(f"at most 20 shifts, got {len(shifts)}")
        object.__setattr__(self, "shifts", shifts)
        if not (isinstance(self.n_modes, int) and 1 <= self.n_modes <= 50):
            raise InputError(f"--n-modes must be an integer in [1, 50], got {self.n_modes!r}")
        masses = tuple(float(m) for m in self.thresholds)
        if len(masses) > MAX_MASS_RATIOS:
            raise InputError(f"at most {MAX_MASS_RATIOS} mass ratios, got {len(masses)}")
        if masses:
            masses = _values("--thresholds (mass ratios)", masses, 0.0, MAX_MASS_RATIO, True)
        object.__setattr__(self, "thresholds", masses)
        # the sweep's own checks (range, points, wake shift), before any work
        sweep = SweepSettings(self.velocity_range, self.points, self.wake_shift)
        object.__setattr__(self, "velocity_range", sweep.velocity_range)
        object.__setattr__(self, "points", sweep.points)
        if self.wake_shift is not None:
            wake = complex(self.wake_shift)
            if not (math.isfinite(wake.real) and math.isfinite(wake.imag) and wake.imag > 0):
                raise InputError(f"--wake-shift must be finite with a frequency > 0, got {wake}")
            object.__setattr__(self, "wake_shift", wake)
        if not isinstance(self.map_settings, MapSettings):
            raise InputError("map_settings must be a fsistab.params.MapSettings")
        # the solid parameters, checked as every command checks them (the plate's conventions)
        springs = (self.freq_ratio, self.zeta_h, self.zeta_theta, self.r_theta)
        solid_for("plate", None, None, *springs, (), self.elastic_axis, self.static_unbalance)
        if self.dofs is not None:
            object.__setattr__(self, "dofs", Solid(dofs=tuple(self.dofs)).dofs)

    def check_body(self, kind: str) -> None:
        """What depends on the body, before any work: the plate's modes need ``shifts`` (its wake
        frequency varies with Re and α0; the cylinder's default is its wake mode ``0.75i``); the
        map is the plate's; thresholds need a solid dof (and the cylinder has no pitch)."""
        body = body_type(kind)
        if self.modes and not self.shifts and not body.wake_shifts:
            raise InputError(
                f"give --shift for the {kind}'s modes: a guess of the leading eigenvalue, e.g. 0+11j "
                "for the plate's wake at Re 2900 (fsistab spectrum finds it)"
            )
        if self.map and "pitch" not in body.allowed_dofs:
            raise InputError("the (m, U*) map (--map) needs heave and pitch (the plate, an airfoil, a curve)")
        if self.thresholds:
            solid = self.solid(kind, self.thresholds[0], self.velocity_range[0])
            if not solid.dofs:
                raise InputError("thresholds need at least one solid degree of freedom (--dofs)")

    def mode_shifts(self, kind: str) -> tuple[complex, ...]:
        """The shifts of the modes: the given ones, else the body's wake-mode shifts (the
        cylinder's ``0.75i``; none for the plate, whose wake frequency varies with Re and α0)."""
        if self.shifts:
            return self.shifts
        return body_type(kind).wake_shifts

    def solid(self, kind: str, mass_ratio: float, reduced_velocity: float) -> Solid:
        """The solid at ``(m, U*)`` in the body's conventions (docs/model.md §2, §10), as generic
        :class:`~fsistab.params.Solid`."""
        return solid_for(
            kind,
            mass_ratio,
            reduced_velocity,
            self.freq_ratio,
            self.zeta_h,
            self.zeta_theta,
            self.r_theta,
            self.dofs,
            self.elastic_axis,
            self.static_unbalance,
        )

    def flows(self) -> list[Flow]:
        """The grid's flow points in order of execution: increasing Re, then increasing ``|α0|``
        (so that a point's neighbour towards α0 = 0 and lower Re tends to finish first)."""
        return [Flow(re, a) for re in self.reynolds for a in sorted(self.alpha0, key=lambda a: (abs(a), a))]

    def point_identity(self) -> dict:
        """What a point's result depends on besides its case (not the rest of the grid: adding
        values to a study reuses the points already computed)."""
        identity = asdict(self)
        for name in ("reynolds", "alpha0"):
            identity.pop(name)
        identity["shifts"] = [[z.real, z.imag] for z in self.shifts]
        identity["wake_shift"] = (
            None if self.wake_shift is None else [self.wake_shift.real, self.wake_shift.imag]
        )
        identity["map_settings"] = asdict(self.map_settings) if self.map else None
        # what is not computed does not count: e.g. --points does not invalidate points of --modes
        unused = []
        if not self.modes:
            unused += ["shifts", "n_modes"]
        if not self.thresholds:
            unused += ["velocity_range", "points", "wake_shift"]
        if not (self.thresholds or self.map):
            unused += ["freq_ratio", "zeta_h", "zeta_theta", "r_theta", "dofs"]
        for name in unused:
            identity[name] = None
        for name in ("elastic_axis", "static_unbalance"):  # the section about mid-chord: as before
            if not identity[name]:
                identity.pop(name)
        return json.loads(json.dumps(identity, default=list))


# --- classification (pure) ------------------------------------------------------------------------


def classify(
    frequency: float,
    heave_energy: float,
    pitch_energy: float,
    fluid_energy: float,
    heave_frequency: float,
    pitch_frequency: float,
    wake_frequency: float = math.nan,
    wake_branch: bool = False,
    heave_alone_growth: float = math.nan,
    pitch_alone_growth: float = math.nan,
) -> str:
    """The class of a threshold (one of :data:`CLASSES`) by the five rules of the module
    docstring: divergence if ``ω_c = 0``; VIV if ``wake_branch`` (the wake mode's threshold: on the
    tracked wake branch, or of kind ``viv``) or within 30 % of ``ω_w`` (and nearer it than ``ω_h``
    and ``ω_θ``); with both one-dof growth rates (:func:`single_dof_growth`),
    heave (pitch) single-mode flutter if the mode's own dof (the larger of ``E_h``, ``E_θ``) alone
    is unstable, at its own frequency (within 30 %) when the fluid holds half the energy; VIV when
    the fluid holds half the energy; then coupled-mode flutter with the rates, or, without them,
    by the solid energy shares (3/4 in one dof: single-mode). ``*_frequency`` in the same units
    (``U∞/L``)."""
    values = (frequency, heave_energy, pitch_energy, fluid_energy, heave_frequency, pitch_frequency)
    if not all(math.isfinite(v) for v in values):
        raise InputError(f"classification needs finite frequencies and energies, got {values}")
    if min(heave_energy, pitch_energy, fluid_energy) < 0:
        raise InputError("energies must be non-negative")
    omega = abs(frequency)
    if omega <= STATIC_FREQUENCY:
        return "divergence"
    if wake_branch:
        return "viv"
    if math.isfinite(wake_frequency) and wake_frequency > 0:
        to_wake = abs(omega - wake_frequency)
        if to_wake < FREQUENCY_BAND * wake_frequency and to_wake < min(
            abs(omega - heave_frequency), abs(omega - pitch_frequency)
        ):
            return "viv"
    solid_energy = heave_energy + pitch_energy
    fluid_dominated = fluid_energy >= solid_energy
    rates_known = math.isfinite(heave_alone_growth) and math.isfinite(pitch_alone_growth)
    if rates_known:
        own, rate, natural = (
            ("heave", heave_alone_growth, heave_frequency)
            if heave_energy >= pitch_energy
            else ("pitch", pitch_alone_growth, pitch_frequency)
        )
        at_own_frequency = abs(omega - natural) < FREQUENCY_BAND * natural
        if rate >= 0 and (at_own_frequency or not fluid_dominated):
            return f"{own} single-mode flutter"
    if fluid_dominated:
        return "viv"
    if rates_known:
        return "coupled-mode flutter"
    heave_share = heave_energy / solid_energy
    if heave_share >= SINGLE_MODE_SHARE:
        return "heave single-mode flutter"
    if heave_share <= 1 - SINGLE_MODE_SHARE:
        return "pitch single-mode flutter"
    return "coupled-mode flutter"


def classify_thresholds(data: xr.Dataset) -> xr.DataArray:
    """The class of every threshold of a study's Dataset (:func:`run_study`) by :func:`classify`,
    from what the Dataset keeps: the energy shares, the frequency, the one-dof growth rates, the
    wake frequency, the branch and kind, and ``ω_h = Ω/U*``, ``ω_θ = 1/U*`` from ``U*_c`` and the settings'
    ``freq_ratio`` (attribute ``settings``; the body's U* convention from attribute ``body``).
    ``""`` where there is no threshold. The one place a class is decided: :func:`run_point`
    applies it to a new point and :func:`assemble` to every point again, so that a study's classes
    always follow the present rules, points read back from files included."""
    kind = data["threshold_kind"]
    body, given = data.attrs["body"], json.loads(data.attrs["settings"])
    dofs = tuple(given["dofs"]) if given["dofs"] else None
    names = ("freq_ratio", "zeta_h", "zeta_theta", "r_theta")
    # Ω in the generic form of the solid as run_point built it (1 for the cylinder, docs/model.md §10)
    freq_ratio = solid_for(body, None, None, *(given[n] for n in names), dofs).freq_ratio
    scale = body_velocity_scale(body)
    wake = (
        data["wake_frequency"].broadcast_like(kind)
        if "wake_frequency" in data
        else xr.full_like(kind, math.nan, dtype=float)
    )
    columns = [
        kind, data["threshold_frequency"], data["threshold_reduced_velocity"],
        data["threshold_heave_share"], data["threshold_pitch_share"], data["threshold_fluid_share"],
        data["threshold_branch"], wake,
        data["threshold_heave_alone_growth"], data["threshold_pitch_alone_growth"],
    ]  # fmt: skip
    flat = [np.asarray(c.transpose(*kind.dims).values).ravel() for c in columns]
    labels = []
    for k, w, u, e_h, e_t, e_f, branch, w_w, r_h, r_t in zip(*flat, strict=True):
        if k == "":
            labels.append("")
        elif k == "divergence":
            labels.append("divergence")
        else:
            velocity = u / scale
            labels.append(
                classify(
                    abs(w),
                    e_h,
                    e_t,
                    e_f,
                    freq_ratio / velocity,
                    1.0 / velocity,
                    w_w,
                    branch == "wake" or k == "viv",  # rule 2: the threshold's own kind is not overruled
                    r_h,
                    r_t,
                )
            )
    return xr.DataArray(np.array(labels, dtype=str).reshape(kind.shape), dims=kind.dims, coords=kind.coords)


STRUCTURAL_SHARE = 0.05  # solid share of the near-body energy above which a mode is structural


def single_dof_growth(fluid, solid, velocity: float, frequency: float, dof: str, counter=None) -> float:
    """Growth rate of the body with ``dof`` alone (the other clamped) at ``U* = velocity`` (module
    docstring, rule 3): the largest of its structural modes (solid share of the near-body energy at
    least :data:`STRUCTURAL_SHARE`; else the most structural one) among the 4 eigenvalues nearest
    ``iω_c`` and the 4 nearest the dof's in-vacuo frequency. Two factorisations."""
    from dataclasses import replace

    from fsistab.coupled import CoupledSystem
    from fsistab.eigen import eigenpairs_near

    one = replace(solid, dofs=(dof,), reduced_velocity=float(velocity))
    system = CoupledSystem(fluid, one)
    natural = (one.freq_ratio if dof == "heave" else 1.0) / velocity
    pairs = eigenpairs_near(system, [1j * abs(frequency), 1j * natural], 4, counter=counter)
    scored = []
    for pair in pairs:
        e_h, e_t, e_f = mode_energies(system, pair.vector)
        scored.append((pair.value.real, (e_h + e_t) / (e_h + e_t + e_f)))
    structural = [growth for growth, share in scored if share >= STRUCTURAL_SHARE]
    return max(structural) if structural else max(scored, key=lambda t: t[1])[0]


def mode_energies(system, vector: np.ndarray) -> tuple[float, float, float]:
    """``(E_h, E_θ, E_f)`` of a coupled mode (units ``ρL²U∞²``, the fluid's within one body length
    of G), as :func:`fsistab.eigen.label_mode` and the module docstring."""
    from fsistab.coupled import solid_energies

    solid, fluid = system.split(np.asarray(vector, dtype=complex))
    heave, pitch = solid_energies(system.solid, solid[2:4], system.fluid.theta0)
    return heave, pitch, system.fluid.near_energy(fluid)


# --- one flow point --------------------------------------------------------------------------------


def _distance(a: Flow, b: Flow) -> float:
    return abs(math.log(a.reynolds / b.reynolds)) + abs(a.alpha0_deg - b.alpha0_deg) / 10.0


def initial_state(case: Case, settings: StudySettings, cache_dir: Path | None):
    """``(state, description)``: the steady state to continue from (module docstring): None when
    the point's own state is cached or no neighbour on its mesh is; else the nearest cached one."""
    from fsistab.mesh import spec_for
    from fsistab.steady import load_steady, steady_path

    if cache_dir is None:
        return None, "rest"
    spec = spec_for(case)
    if steady_path(spec, case.flow, cache_dir).exists():
        return None, "cache"
    others = [f for f in settings.flows() if f != case.flow]
    for flow in sorted(others, key=lambda f: _distance(f, case.flow)):
        if spec_for(replace(case, flow=flow)).key() != spec.key():
            continue
        path = steady_path(spec, flow, cache_dir)
        if path.exists():
            with contextlib.suppress(CacheError):  # a damaged neighbour is not a starting point
                state = load_steady(path, spec, flow, cache_dir)
                return state, f"Re {flow.reynolds:g}, a {flow.alpha0_deg:g}"
    return None, "rest"


def run_point(
    case: Case, settings: StudySettings, cache_dir: Path | None, progress: Progress = None
) -> xr.Dataset:
    """Everything ``settings`` asks at the flow point of ``case``: a Dataset of scalars (steady
    coefficients, slopes), ``mode`` variables, ``(mass_ratio, threshold)`` variables and
    ``map_point`` variables, padded with NaN / ``""``; cost and identity in attributes. Pure but
    for the cache (meshes, steady states) and, with ``map``, the map's own files under
    ``cache_dir/study_maps``."""
    from fsistab.forces import aerodynamic_coefficients, recirculation_length
    from fsistab.linalg import FactorCounter, FluidFactor
    from fsistab.mesh import spec_for
    from fsistab.operators import fluid_operators
    from fsistab.steady import solve_steady

    say = progress if progress is not None else (lambda message: None)
    settings.check_body(case.kind)
    t0 = time.perf_counter()
    spec = spec_for(case)
    initial, start = initial_state(case, settings, cache_dir)
    say(f"steady state at Re {case.flow.reynolds:g}, alpha0 {case.flow.alpha0_deg:g} (from {start})")
    steady = solve_steady(spec, case.flow, cache_dir=cache_dir, initial=initial)
    counter = FactorCounter(0 if steady.from_cache else steady.factorisations)
    fluid = fluid_operators(steady)
    data: dict = {}
    coords: dict = {}
    # one factorisation of J_ff serves the slopes and every divergence point (pitch active)
    pitch = settings.thresholds and "pitch" in settings.solid(case.kind, 1.0, 1.0).dofs
    static = FluidFactor(fluid, 0.0, counter) if settings.slopes or pitch else None
    if settings.slopes:
        from fsistab.slopes import static_slopes

        coefficients = aerodynamic_coefficients(steady)
        slopes = static_slopes(fluid, factor=static)
        data.update(
            lift_coefficient=((), coefficients.lift),
            moment_coefficient=((), coefficients.moment),
            drag_coefficient=((), coefficients.drag),
            recirculation_length=((), recirculation_length(steady)),
            lift_slope_alpha=((), slopes.lift_slope_alpha),
            moment_slope_alpha=((), slopes.moment_slope_alpha),
            drag_slope_theta=((), slopes.drag),
        )
    if settings.modes:
        data.update(_modes(fluid, settings, case.kind, counter))
        coords["mode"] = np.arange(settings.n_modes)
    if settings.thresholds:
        threshold_data, wake = _thresholds(fluid, settings, case.kind, counter, static, say)
        data.update(threshold_data)
        data["wake_frequency"] = ("mass_ratio", wake)
        coords["mass_ratio"] = np.array(settings.thresholds)
    if settings.map:
        data.update(_map(case, settings, cache_dir, counter, say))
    ds = xr.Dataset({k: xr.Variable(*v) for k, v in data.items()}, coords=coords)
    for name in ("threshold", "map_point"):
        if name in ds.dims:
            ds = ds.assign_coords({name: np.arange(ds.sizes[name])})
    if settings.thresholds:
        identity = {"body": case.kind, "settings": json.dumps(settings.point_identity())}
        ds["threshold_class"] = classify_thresholds(ds.assign_attrs(identity))
    return ds.assign_attrs(
        body=case.kind,
        reynolds=case.flow.reynolds,
        alpha0_deg=case.flow.alpha0_deg,
        preset=case.preset,
        mesh_reynolds=case.fitted_reynolds,
        **spec.linear_identity(),
        steady_start=start,
        ndof=fluid.n_fluid,
        factorisations=counter.count,
        seconds=time.perf_counter() - t0,
    )


def _modes(fluid, settings: StudySettings, kind: str, counter) -> dict:
    from fsistab.coupled import CoupledSystem
    from fsistab.eigen import eigenpairs_near

    system = CoupledSystem(fluid, Solid(dofs=()))
    pairs = eigenpairs_near(system, list(settings.mode_shifts(kind)), settings.n_modes, counter=counter)
    pairs = pairs[: settings.n_modes]  # the least stable first (eigenpairs_near sorts them)
    n = settings.n_modes

    def padded(values) -> np.ndarray:
        out = np.full(n, np.nan)
        out[: len(values)] = values
        return out

    return {
        "mode_growth_rate": ("mode", padded([p.growth_rate for p in pairs])),
        "mode_frequency": ("mode", padded([p.frequency for p in pairs])),
        "mode_residual": ("mode", padded([p.residual for p in pairs])),
    }


THRESHOLD_FLOATS = (
    "reduced_velocity",
    "frequency",
    "heave_share",
    "pitch_share",
    "fluid_share",
    "frequency_over_heave",
    "frequency_over_pitch",
    "frequency_over_wake",
    "heave_alone_growth",
    "pitch_alone_growth",
)
THRESHOLD_STRINGS = ("kind", "boundary", "branch")  # the class is added by classify_thresholds


def _thresholds(fluid, settings: StudySettings, kind: str, counter, static, say) -> tuple[dict, np.ndarray]:
    """Every threshold at each mass ratio with what classifies it (:func:`classify_thresholds`);
    ``(variables, wake frequency per m)``."""
    from fsistab.coupled import CoupledSystem
    from fsistab.critical import find_thresholds

    scale = body_velocity_scale(kind)
    rows: list[list[dict]] = []
    wakes, unresolved = [], []
    for mass in settings.thresholds:
        solid = settings.solid(kind, mass, settings.velocity_range[0])
        velocities = np.geomspace(*settings.velocity_range, settings.points) / scale
        say(f"thresholds at m = {mass:g}: {settings.points} values of U*")
        found, details = find_thresholds(
            fluid, solid, velocities, wake_shift=settings.wake_shift, counter=counter, static_factor=static
        )
        wake = details["wake_frequency"] if details["wake_frequency"] is not None else math.nan
        wakes.append(wake)
        unresolved.append(len(details.get("unresolved", ())))  # frequency intervals the sweep left
        row = []
        for t in found:
            u = t.reduced_velocity
            system = CoupledSystem(fluid, replace(solid, reduced_velocity=u))
            heave_f, pitch_f = solid.freq_ratio / u, 1.0 / u
            w = abs(t.frequency)
            alone = [math.nan, math.nan]  # one-dof growth rates (rule 3), flutter of heave + pitch only
            if t.kind == "divergence":
                shares = (math.nan, math.nan, math.nan)
            else:
                e_h, e_t, e_f = mode_energies(system, t.mode)
                total = e_h + e_t + e_f
                shares = (e_h / total, e_t / total, e_f / total)
                if set(solid.dofs) == {"heave", "pitch"} and t.kind == "flutter":
                    alone = [
                        single_dof_growth(fluid, solid, u, w, dof, counter) for dof in ("heave", "pitch")
                    ]
            row.append(
                {
                    "reduced_velocity": u * scale,
                    "frequency": t.frequency,
                    "heave_share": shares[0],
                    "pitch_share": shares[1],
                    "fluid_share": shares[2],
                    "frequency_over_heave": w / heave_f if "heave" in solid.dofs else math.nan,
                    "frequency_over_pitch": w / pitch_f if "pitch" in solid.dofs else math.nan,
                    "frequency_over_wake": w / wake if math.isfinite(wake) else math.nan,
                    "heave_alone_growth": alone[0],
                    "pitch_alone_growth": alone[1],
                    "kind": t.kind,
                    "boundary": t.boundary,
                    "branch": t.branch,
                }
            )
        rows.append(row)
    size = max(1, max(len(r) for r in rows))  # one column at least: NetCDF and zero-size dims
    variables = {}
    for name in THRESHOLD_FLOATS + THRESHOLD_STRINGS:
        is_text = name in THRESHOLD_STRINGS
        table = np.full((len(rows), size), "" if is_text else np.nan, dtype=object if is_text else float)
        for i, row in enumerate(rows):
            for j, entry in enumerate(row):
                table[i, j] = entry[name]
        variables[f"threshold_{name}"] = (
            ("mass_ratio", "threshold"),
            table.astype(str) if is_text else table,
        )
    variables["threshold_unresolved_intervals"] = ("mass_ratio", np.array(unresolved, dtype=np.int64))
    return variables, np.array(wakes)


def _map(case: Case, settings: StudySettings, cache_dir: Path | None, counter, say) -> dict:
    """The point's ``(m, U*)`` map (:func:`fsistab.workflows.stability_map`), its dynamic curves
    flattened along ``map_point`` and the divergence law ``U*_D/√m``."""
    from fsistab.neutral_map import map_curves
    from fsistab.store import default_cache_dir
    from fsistab.workflows import divergence_coefficient, stability_map

    base = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    key = _short_key({"case": _case_identity(case), "settings": settings.point_identity()})
    out = base / "study_maps" / f"{case.tag}_{key}"
    out.mkdir(parents=True, exist_ok=True)
    template = settings.solid(
        "plate", settings.map_settings.template_mass, settings.map_settings.velocity_range[0]
    )
    ds = stability_map(case, template, settings.map_settings, cache_dir, out, say)
    counter.count += int(ds.attrs["factorisations_this_run"])
    curves = map_curves(ds)
    index = np.concatenate([np.full(len(m), i) for i, (_, m, _, _) in enumerate(curves)] or [np.zeros(0)])
    kinds = [kind for kind, m, _, _ in curves for _ in m]
    n = max(1, len(kinds))

    def padded(values, fill=np.nan, dtype=float):
        out = np.full(n, fill, dtype=dtype)
        out[: len(values)] = values
        return out

    return {
        "map_mass_ratio": ("map_point", padded(np.concatenate([c[1] for c in curves] or [np.zeros(0)]))),
        "map_reduced_velocity": (
            "map_point",
            padded(np.concatenate([c[2] for c in curves] or [np.zeros(0)])),
        ),
        "map_frequency": ("map_point", padded(np.concatenate([c[3] for c in curves] or [np.zeros(0)]))),
        "map_curve": ("map_point", padded(index, -1, int)),
        "map_kind": ("map_point", padded(np.array(kinds, dtype=object), "", object).astype(str)),
        "map_divergence_coefficient": ((), divergence_coefficient(ds)),
        "map_data": ((), str(ds.attrs["data"])),
    }


# --- files of finished points -----------------------------------------------------------------------


def _case_identity(case: Case) -> dict:
    from fsistab.mesh import spec_for

    linear = spec_for(case).linear_identity()
    return {
        "body": asdict(case.body),
        "flow": asdict(case.flow),
        "preset": case.preset,
        "domain": None if case.domain is None else asdict(case.domain),
        **{key: linear[key] for key in ("sponge", "outlet") if key in linear},
    }


def _short_key(inputs: dict) -> str:
    import hashlib

    from fsistab import __version__

    text = json.dumps({**inputs, "fsistab": __version__}, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def point_identity(case: Case, settings: StudySettings) -> str:
    """The JSON text that identifies a point's result: case, mesh key, per-point settings and
    fsistab's version (checked when a finished point is reused)."""
    from fsistab import __version__
    from fsistab.mesh import spec_for

    return json.dumps(
        {
            "case": _case_identity(case),
            "mesh_key": spec_for(case).key(),  # the sponge and outlet are in the case's identity
            "settings": settings.point_identity(),
            "fsistab": __version__,
        },
        sort_keys=True,
    )


def point_path(out: Path, case: Case, settings: StudySettings) -> Path:
    """``out/points/<tag>_<key>.nc``: the file of a finished point (key: hash of its identity)."""
    key = _short_key({"identity": point_identity(case, settings)})
    return Path(out) / "points" / f"{case.tag}_{case.preset}_{key}.nc"


def finished_point(out: Path, case: Case, settings: StudySettings) -> xr.Dataset | None:
    """The saved result of a point when its file verifies (checksum and identity); a damaged or
    mismatched file is reported and moved aside (:func:`fsistab.store.read_cached`): None."""
    from fsistab.store import read_cached

    path = point_path(out, case, settings)
    return read_cached(path, expect={"point_identity": point_identity(case, settings)})


def compute_point(case: Case, settings: StudySettings, cache_dir: Path | None, out: Path) -> xr.Dataset:
    """:func:`run_point`, then its result written atomically to :func:`point_path` with its
    identity: the task that runs on a worker (so that a finished point is kept whatever happens
    to the client). Idempotent: when the file is there and verifies, it is returned (attribute
    ``from_file``) and nothing is computed; dask runs a finished task again when the worker that
    held its result died before the client fetched it."""
    from fsistab.mesh import NGSOLVE_LOCK
    from fsistab.store import write_dataset

    finished = finished_point(out, case, settings)
    if finished is not None:
        return finished.assign_attrs(from_file=1)
    with NGSOLVE_LOCK:  # one point at a time on a dask worker with several threads
        ds = run_point(case, settings, cache_dir)
    ds.attrs["point_identity"] = point_identity(case, settings)
    path = write_dataset(ds, point_path(out, case, settings))
    return ds.assign_attrs(point_file=str(path))


# --- the study ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class PointOutcome:
    """What became of one point: its ``result`` (None if it failed), ``error`` (one line), and
    whether it was ``computed`` in this run (else read back from its file)."""

    flow: Flow
    result: xr.Dataset | None
    error: str = ""
    computed: bool = False


def _one_line(exc: BaseException) -> str:
    from fsistab.progress import one_line

    text = str(exc).splitlines()[0] if str(exc) else ""
    return one_line(f"{type(exc).__name__}: {text}" if not isinstance(exc, FsistabError) else text)


def _run_serial(todo, settings, cache_dir, out) -> Iterator[PointOutcome]:
    for case in todo:
        try:
            yield PointOutcome(case.flow, compute_point(case, settings, cache_dir, out), computed=True)
        except Exception as exc:  # a failed point is reported; the others go on
            yield PointOutcome(case.flow, None, _one_line(exc))


def _run_on_client(client, todo, settings, cache_dir, out) -> Iterator[PointOutcome]:
    from distributed import as_completed

    futures = {}
    for i, case in enumerate(todo):
        # the output directory in the key too: the same point of two studies is two tasks (each
        # writes its own file)
        where = _short_key({"out": str(Path(out).resolve()), "cache": str(cache_dir)})[:8]
        key = f"fsistab-point-{point_path(out, case, settings).stem}-{where}"
        # earlier points first: their steady states serve as neighbours of later ones
        future = client.submit(
            compute_point, case, settings, cache_dir, out, key=key, pure=False, priority=len(todo) - i
        )
        futures[future] = case
    for future in as_completed(list(futures)):
        case = futures[future]
        try:
            yield PointOutcome(case.flow, future.result(), computed=True)
        except Exception as exc:  # any error of a task (or a worker lost repeatedly): report it, go on
            yield PointOutcome(case.flow, None, _one_line(exc))
        finally:
            future.release()


def run_study(
    base_case: Case,
    settings: StudySettings,
    cache_dir: Path | None,
    out: Path,
    client=None,
    progress: Progress = None,
) -> xr.Dataset:
    """Every point of ``settings``' grid at the body, mesh preset and domain of ``base_case``: the
    finished ones read back (:func:`finished_point`), the others computed in this process
    (``client`` None) or as tasks of the ``dask.distributed`` ``client``, each saved as it finishes.
    Returns the assembled Dataset (:func:`assemble`), written to
    ``out/study_<body>_<preset>_<key>.nc`` (path in attribute ``data``); attributes ``points``,
    ``computed``, ``failed``, ``factorisations`` (this run), ``seconds``."""
    from fsistab.store import write_dataset

    say = progress if progress is not None else (lambda message: None)
    settings.check_body(base_case.kind)
    t0 = time.perf_counter()
    out = Path(out)
    (out / "points").mkdir(parents=True, exist_ok=True)
    cases = [replace(base_case, flow=flow) for flow in settings.flows()]
    outcomes: dict[Flow, PointOutcome] = {}
    todo = []
    for case in cases:
        ds = finished_point(out, case, settings)
        if ds is not None:
            outcomes[case.flow] = PointOutcome(case.flow, ds)
        else:
            todo.append(case)
    say(f"{len(cases)} points: {len(outcomes)} finished before, {len(todo)} to compute")
    if client is None:
        running = _run_serial(todo, settings, cache_dir, out)
    else:
        running = _run_on_client(client, todo, settings, cache_dir, out)
    for outcome in running:
        outcomes[outcome.flow] = outcome
        flow = outcome.flow
        where = f"Re {flow.reynolds:g}, alpha0 {flow.alpha0_deg:g}"
        if outcome.result is None:
            say(f"point {where} FAILED: {outcome.error}")
        else:
            say(f"point {where} done ({len(outcomes)}/{len(cases)})")
    ds = assemble(base_case, settings, outcomes)
    computed = [o for o in outcomes.values() if o.computed and not o.result.attrs.get("from_file")]
    ds.attrs.update(
        points=len(cases),
        computed=len(computed),
        failed=int((ds.status.values == "failed").sum()),
        factorisations=int(sum(o.result.attrs["factorisations"] for o in computed)),
        seconds=time.perf_counter() - t0,
        execution="in-process" if client is None else f"dask.distributed ({_workers(client)} workers)",
    )
    grid = {"case": _case_identity(base_case), "grid": [settings.reynolds, settings.alpha0]}
    if base_case.mesh_reynolds is not None:  # one held mesh: another file than the fitted meshes'
        grid["mesh_reynolds"] = base_case.mesh_reynolds
    key = _short_key(grid)
    key += _short_key({"settings": settings.point_identity()})[:4]
    path = write_dataset(ds, out / f"study_{base_case.kind}_{base_case.preset}_{key}.nc")
    return ds.assign_attrs(data=str(path))


def _workers(client) -> int:
    try:
        return len(client.scheduler_info()["workers"])
    except Exception:  # an informative attribute only
        return 0


def _padded_variables(results: dict, shape: tuple[int, int]) -> tuple[dict, dict[str, int]]:
    """Every variable of the points' datasets on ``(reynolds, alpha0, ...)``, padded to the
    largest size of each inner dimension (NaN, ``""``, -1), and those sizes."""
    sizes: dict[str, int] = {}
    names: dict[str, tuple] = {}
    for ds in results.values():
        for name, var in ds.data_vars.items():
            names.setdefault(name, (var.dims, var.dtype.kind))
            for dim in var.dims:
                sizes[dim] = max(sizes.get(dim, 0), ds.sizes[dim])
    data = {}
    for name, (dims, kind) in names.items():
        full = (*shape, *(sizes[d] for d in dims))
        if kind in "OUS":
            table = np.full(full, "", dtype=object)
        elif kind in "iu":
            table = np.full(full, -1, dtype=np.int64)
        else:
            table = np.full(full, np.nan)
        for (i, j), ds in results.items():
            if name in ds:
                values = ds[name].values
                table[(i, j, *(slice(0, n) for n in values.shape))] = values
        data[name] = (("reynolds", "alpha0", *dims), table.astype(str) if kind in "OUS" else table)
    for name, fill in (("factorisations", -1), ("seconds", np.nan), ("steady_start", "")):
        table = np.full(shape, fill, dtype=object if isinstance(fill, str) else type(fill))
        for (i, j), ds in results.items():
            table[i, j] = ds.attrs[name]
        data[f"point_{name}"] = (
            ("reynolds", "alpha0"),
            table.astype(str) if isinstance(fill, str) else table,
        )
    return data, sizes


def leading_modes(growth_rates: np.ndarray, frequencies: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per point (the last axis: its modes), the growth rate and frequency of the least stable
    mode (the first, NaN, at a point without any)."""
    rates = np.asarray(growth_rates, dtype=float)
    finite = np.isfinite(rates).any(axis=-1)
    lead = np.where(finite, np.nanargmax(np.where(np.isfinite(rates), rates, -np.inf), axis=-1), 0)
    pick = lead[..., None]
    return np.take_along_axis(rates, pick, -1)[..., 0], np.take_along_axis(frequencies, pick, -1)[..., 0]


def assemble(base_case: Case, settings: StudySettings, outcomes: dict) -> xr.Dataset:
    """One Dataset of every point's variables on dimensions ``(reynolds, alpha0, ...)``, padded
    to the largest size of each inner dimension (NaN, ``""``, -1); ``status`` ``done`` /
    ``failed`` and ``error`` per point, and per point the cost (``factorisations``, ``seconds``)
    and where its steady state started (``steady_start``); with modes, the least stable one
    (``leading_growth_rate``, ``leading_frequency``); the thresholds classified anew
    (:func:`classify_thresholds`)."""
    reynolds, alpha0 = np.array(settings.reynolds), np.array(settings.alpha0)
    shape = (len(reynolds), len(alpha0))
    results = {
        (reynolds.tolist().index(f.reynolds), alpha0.tolist().index(f.alpha0_deg)): o.result
        for f, o in outcomes.items()
        if o.result is not None
    }
    status = np.full(shape, "failed", dtype=object)
    error = np.full(shape, "", dtype=object)
    for f, o in outcomes.items():
        i, j = reynolds.tolist().index(f.reynolds), alpha0.tolist().index(f.alpha0_deg)
        status[i, j] = "done" if o.result is not None else "failed"
        error[i, j] = o.error
    data, sizes = _padded_variables(results, shape)
    data["status"] = (("reynolds", "alpha0"), status.astype(str))
    data["error"] = (("reynolds", "alpha0"), error.astype(str))
    if "mode_growth_rate" in data:
        rates, frequencies = leading_modes(data["mode_growth_rate"][1], data["mode_frequency"][1])
        data["leading_growth_rate"] = (("reynolds", "alpha0"), rates)
        data["leading_frequency"] = (("reynolds", "alpha0"), frequencies)
    coords = {"reynolds": reynolds, "alpha0": alpha0}
    if settings.thresholds:
        coords["mass_ratio"] = np.array(settings.thresholds)
    for dim, n in sizes.items():
        if dim not in coords:
            coords[dim] = np.arange(n)
    assembled = xr.Dataset(
        data,
        coords=coords,
        attrs={
            "body": base_case.kind,
            "preset": base_case.preset,
            "settings": json.dumps(settings.point_identity(), sort_keys=True),
            # the Re of the one mesh of every point; without it, each point's mesh fits its own Re
            **({} if base_case.mesh_reynolds is None else {"mesh_reynolds": base_case.mesh_reynolds}),
            "classes": json.dumps(CLASSES),
            "conventions": (
                "alpha0 in degrees, nose-up +; U* and m in the body's conventions (docs/model.md §2, §10); "
                "frequencies and growth rates in U/L; coefficients F/(0.5 rho U^2 L s), C_M about G"
            ),
        },
    )
    if "threshold_kind" in assembled:
        # the present rules, also for points computed before a change of them
        assembled["threshold_class"] = classify_thresholds(assembled)
    return assembled


@contextlib.contextmanager
def study_client(workers: int | None = None, scheduler: str | None = None):
    """A ``dask.distributed`` client on a new ``LocalCluster`` of ``workers`` single-threaded
    worker processes, or on the running scheduler at ``scheduler``; None (in-process) when both
    are None. The points of a study (:func:`run_study`) or the exact samples of a map
    (:func:`fsistab.workflows.stability_map`) run on it. A clear error when dask.distributed is
    not installed (``pip install 'fsistab[cluster]'``)."""
    if workers is None and scheduler is None:
        yield None
        return
    check_execution(workers, scheduler)
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise InputError(
            "--workers and --scheduler need dask.distributed: pip install 'fsistab[cluster]'"
        ) from None
    if scheduler is not None:
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise InputError(f"cannot connect to the dask scheduler at {scheduler}: {exc}") from None
        with client:
            yield client
        return
    with (
        _without_malloc_trim(),
        LocalCluster(
            n_workers=workers, processes=True, threads_per_worker=1, dashboard_address=None
        ) as cluster,
        Client(cluster) as client,
    ):
        yield client


def _without_malloc_trim():
    """dask's configuration with the environment of the worker processes a nanny spawns without
    ``MALLOC_TRIM_THRESHOLD_`` (set by dask's defaults): setting it fixes glibc's threshold for
    serving large blocks by ``mmap``, so that the memory of every sparse factorisation is mapped,
    faulted in and unmapped again, at a cost in CPU per factorisation (docs/performance.md, "Maps
    on dask"); the other variables (BLAS on one thread) are kept."""
    import dask

    environ = dict(dask.config.get("distributed.nanny.pre-spawn-environ", default={}) or {})
    environ.pop("MALLOC_TRIM_THRESHOLD_", None)
    return dask.config.set({"distributed.nanny.pre-spawn-environ": environ})


def check_execution(workers: int | None, scheduler: str | None) -> None:
    """``--workers`` and ``--scheduler`` exclude each other; workers in ``[1, 256]``; the scheduler
    an address such as ``tcp://host:8786``."""
    if workers is not None and scheduler is not None:
        raise InputError(
            "give --workers N (a local cluster) or --scheduler ADDRESS (a running one), not both"
        )
    if workers is not None and not (isinstance(workers, int) and 1 <= workers <= 256):
        raise InputError(f"--workers must be an integer in [1, 256], got {workers!r}")
    if scheduler is not None and (not scheduler.strip() or any(c.isspace() for c in scheduler.strip())):
        raise InputError(f"--scheduler must be an address such as tcp://host:8786, got {scheduler!r}")
    if scheduler is not None:
        _check_scheduler_address(scheduler.strip())


def _check_scheduler_address(scheduler: str) -> None:
    """An address that dask.distributed can connect to: a known scheme (tcp, tls, ws, wss, ucx,
    inproc) and, but for inproc, a host and a port. Without dask.distributed nothing is checked
    (:func:`study_client` says that it is missing)."""
    try:
        from distributed.comm.addressing import parse_address, parse_host_port
        from distributed.comm.registry import get_backend
    except ImportError:
        return
    try:
        scheme, location = parse_address(scheduler, strict=False)
        get_backend(scheme)
        if scheme != "inproc":
            parse_host_port(location)
    except ValueError as exc:
        raise InputError(
            f"--scheduler must be an address such as tcp://host:8786, got {scheduler!r} ({exc})"
        ) from None
