"""Neutral curves in the flow-parameter planes ``(Re, U*)`` and ``(α0, U*)`` by pseudo-arclength
continuation (docs/model.md §8), at fixed solid parameters, through turning points.

A dynamic neutral point at flow parameter ``p`` (``log Re`` or ``α0`` in degrees) solves the two
real equations of the exact transfer (:mod:`fsistab.transfer`, docs/model.md §8)::

    det T(iω; U*, p) / d0 = 0,        T = P(U*) + iω M_s(θ₀) - C G(iω; p),

in the unknowns ``y = (ω, log U*, p)``; ``d0`` is ``|det T|`` of the in-vacuo part at the start
(a fixed scale). ``∂/∂ω`` and ``∂/∂ log U*`` are analytic (Jacobi's formula with ``dG/ds`` and the
solid stiffness derivative, as in :func:`fsistab.transfer.transfer_flutter_point`); ``∂/∂p`` is a
one-sided finite difference through a second steady state at ``p + δp`` (Newton from the state at
``p``). It only steers Newton and the tangent: the points themselves solve the equations to the
tolerance. The generic continuation (:class:`fsistab.continuation.ContinuationIterator`) measures
arclength in the plane ``(log U*, p)`` and reports turning points in ``p`` (where the threshold
folds back, e.g. in α0 near 3° for the plate at Re = 2900, m = 1000).

All steady states lie on one mesh (``spec``, fixed along the curve) and are cached on disk when a
cache directory is given, so a rerun recomputes no steady state.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import replace
from pathlib import Path

import numpy as np

from fsistab.continuation import ContinuationIterator, ContinuationSettings, TestFunction
from fsistab.errors import ConvergenceError, InputError
from fsistab.linalg import FactorCounter
from fsistab.neutral_map import NeutralCurve
from fsistab.neutral_point import DeterminantProblem, NeutralPoint, TurningPoint
from fsistab.operators import fluid_operators
from fsistab.params import Flow, Solid
from fsistab.steady import solve_steady
from fsistab.symmetry import antisymmetric_operators
from fsistab.transfer import characteristic_matrix, determinant_gradient, exact_transfer

PARAMETERS = ("reynolds", "alpha0")
_FD_STEP = {"reynolds": 1e-4, "alpha0": 1e-3}  # in log Re and in degrees (steady states to 1e-10)


class _FlowDeterminant:
    """The exact-transfer formulation of the neutral point in a flow plane (module doc): ``det T(iω;
    U*, p)`` with its derivatives (:func:`fsistab.transfer.determinant_gradient`), memoised on the
    steady states and transfers, for :class:`fsistab.neutral_point.DeterminantProblem`."""

    def __init__(
        self, spec, flow: Flow, solid: Solid, parameter: str, cache_dir, counter, initial, fluid=None
    ):
        self.spec, self.flow0, self.solid, self.parameter = spec, flow, solid, parameter
        self.cache_dir, self.counter = cache_dir, counter
        self._states: OrderedDict = OrderedDict()
        self._transfers: OrderedDict = OrderedDict()
        self.scale = 1.0
        if fluid is not None:
            self._states[self.value_of(flow)] = (fluid.steady, antisymmetric_operators(fluid))
        elif initial is not None:
            self._states[self.value_of(flow)] = (initial, None)

    def value_of(self, flow: Flow) -> float:
        return math.log(flow.reynolds) if self.parameter == "reynolds" else flow.alpha0_deg

    def flow_at(self, p: float) -> Flow:
        if self.parameter == "reynolds":
            return replace(self.flow0, reynolds=math.exp(p))
        return replace(self.flow0, alpha0_deg=p)

    def fluid_at(self, p: float):
        if p in self._states and self._states[p][1] is not None:
            self._states.move_to_end(p)
            return self._states[p][1]
        nearest = min(self._states, key=lambda q: abs(q - p)) if self._states else None
        if p in self._states:
            steady = self._states[p][0]
        else:
            initial = self._states[nearest][0] if nearest is not None else None
            steady = solve_steady(self.spec, self.flow_at(p), cache_dir=self.cache_dir, initial=initial)
        # G from the antisymmetric fields where the flow is symmetric (fsistab.symmetry)
        fluid = antisymmetric_operators(fluid_operators(steady))
        self._states[p] = (steady, fluid)
        while len(self._states) > 4:
            self._states.popitem(last=False)
        return fluid

    def transfer(self, p: float, omega: float):
        key = (p, omega)
        if key not in self._transfers:
            fluid = self.fluid_at(p)
            self._transfers[key] = (fluid, *exact_transfer(fluid, 1j * omega, self.counter, derivative=True))
            while len(self._transfers) > 8:
                self._transfers.popitem(last=False)
        return self._transfers[key]

    def determinant(self, y: np.ndarray, derivatives: bool = False):
        omega, log_u, p = (float(v) for v in y)
        fluid, value, rate = self.transfer(p, omega)
        solid = replace(self.solid, reduced_velocity=math.exp(log_u))
        _, det, gradient = determinant_gradient(value, rate, solid, omega, fluid.theta0, fluid.loads0)
        det, d_omega, d_logu = det / self.scale, gradient[0] / self.scale, gradient[1] / self.scale
        return (det, d_omega, d_logu) if derivatives else det

    def characteristic(self, y: np.ndarray, gradient: bool):
        """``f = det T / scale`` and, with ``gradient``, ``∂f/∂(ω, log U*, p)``: analytic in ω and
        U*, a one-sided finite difference through a second steady state in ``p``."""
        if not gradient:
            return self.determinant(y)
        det, d_omega, d_logu = self.determinant(y, derivatives=True)
        step = _FD_STEP[self.parameter]
        shifted = np.array(y, dtype=float)
        shifted[2] += step
        d_p = (self.determinant(shifted) - det) / step
        return det, np.array([d_omega, d_logu, d_p])

    def problem(self) -> DeterminantProblem:
        # chord Newton: keep the finite-difference Jacobian while the residual falls tenfold
        return DeterminantProblem(self.characteristic, chord=True)


def _checked_range(parameter: str, parameter_range: tuple[float, float], frequency: float):
    """The range of the continuation variable (``log Re`` or ``α0``) from that of Re or α0."""
    if parameter not in PARAMETERS:
        raise InputError(f"parameter must be one of {PARAMETERS}, got {parameter!r}")
    low, high = (float(v) for v in parameter_range)
    if not low < high or (parameter == "reynolds" and low <= 0):
        raise InputError(
            f"the {parameter} range must be increasing (and positive for Re), got {low:g} {high:g}"
        )
    if frequency <= 0:
        raise InputError("a dynamic neutral curve needs a positive starting frequency")
    return (math.log(low), math.log(high)) if parameter == "reynolds" else (low, high)


def _set_scale(problem: _FlowDeterminant, p0: float, solid: Solid, omega: float) -> None:
    """The fixed scale of the determinant: ``|det|`` of the in-vacuo part at the start (so that
    the tolerances are relative)."""
    start_fluid = problem.fluid_at(p0)
    in_vacuo = characteristic_matrix(
        np.zeros((3, 4)), solid, 1j * omega, start_fluid.theta0, start_fluid.loads0
    )
    problem.scale = abs(np.linalg.det(in_vacuo))


def _flow_point(problem: _FlowDeterminant, y: np.ndarray) -> NeutralPoint:
    f = problem.flow_at(float(y[2]))
    return NeutralPoint(
        problem.solid.mass_ratio,
        math.exp(float(y[1])),
        float(y[0]),
        reynolds=f.reynolds,
        alpha0_deg=f.alpha0_deg,
    )


def _flow_turning_point(problem: _FlowDeterminant, event) -> TurningPoint:
    point = _flow_point(problem, event.point)
    return TurningPoint(**vars(point), index=event.index, localised=event.localised)


def _flow_stop(iterator: ContinuationIterator, parameter: str) -> str:
    """Why a curve ended: ``<parameter>_bound``, ``velocity_bound``, ``zero_frequency``,
    ``max_points`` or ``step_too_small``."""
    if iterator.stop == "bound":
        return f"{parameter}_bound" if iterator.stop_event.component == 2 else "velocity_bound"
    return "zero_frequency" if iterator.stop == "event:zero_frequency" else iterator.stop


def _positive_frequency(y: np.ndarray) -> float:
    """The test function that ends a curve where its frequency reaches zero (divergence)."""
    return float(y[0]) - 1e-4


def continue_flow_neutral_curve(
    spec,
    flow: Flow,
    solid: Solid,
    frequency: float,
    parameter: str,
    parameter_range: tuple[float, float],
    *,
    direction: float = 1.0,
    velocity_range: tuple[float, float] = (1e-2, 100.0),
    step: float = 0.1,
    max_step: float = 0.4,
    min_step: float = 1e-3,
    max_points: int = 40,
    cache_dir: Path | None = None,
    initial=None,
    fluid=None,
    counter: FactorCounter | None = None,
    on_point=None,
) -> NeutralCurve:
    """Follow the dynamic neutral curve through ``(flow, solid.reduced_velocity, frequency)`` (e.g.
    a flutter threshold of :func:`fsistab.critical.find_thresholds`, refined here) in the plane of
    ``parameter`` (``reynolds``: ``log Re`` is the continuation variable; ``alpha0``: degrees)
    and U*, within ``parameter_range`` (Re or α0 in degrees) and ``velocity_range``.

    ``direction`` ±1 starts towards increasing or decreasing parameter. Steps ``Δs`` are in the
    plane ``(log U*, p)``. The curve stops at a bound, when the frequency reaches zero (a
    codimension-two point with divergence) or after ``max_points`` (the corrected start included).
    ``initial`` (the steady state at ``flow``) or ``fluid`` (its operators) are reused when given.
    ``on_point(point)`` is called for every accepted neutral point after the start.
    """
    p_range = _checked_range(parameter, parameter_range, frequency)
    counter = counter if counter is not None else FactorCounter()
    first = counter.count
    problem = _FlowDeterminant(spec, flow, solid, parameter, cache_dir, counter, initial, fluid)
    p0 = problem.value_of(flow)
    if not p_range[0] <= p0 <= p_range[1]:
        raise InputError(f"the starting flow lies outside the {parameter} range")
    omega, log_u = float(frequency), math.log(solid.reduced_velocity)
    _set_scale(problem, p0, solid, omega)
    iterator = ContinuationIterator(
        problem.problem().curve(np.array([0.0, 1.0, 1.0])),
        np.array([omega, log_u, p0]),
        np.array([0.0, 0.0, float(np.sign(direction) or 1.0)]),
        ContinuationSettings.neutral_curve(
            step=step, min_step=min_step, max_step=max_step, max_points=max_points, tol=1e-9, locate_tol=1e-5
        ),
        bounds={2: p_range, 1: (math.log(velocity_range[0]), math.log(velocity_range[1]))},
        events={"zero_frequency": TestFunction(_positive_frequency, terminal=True, localise=False)},
    )
    points, turning = [], []
    try:
        for accepted in iterator:
            turning += [_flow_turning_point(problem, e) for e in accepted.events if e.kind == "fold"]
            points.append(_flow_point(problem, accepted.point))
            if on_point and accepted.index > 0:
                on_point(points[-1])
    except ConvergenceError as exc:
        raise ConvergenceError(
            f"the neutral point at {parameter} = {p0:.5g} did not converge from U* = "
            f"{solid.reduced_velocity:.5g}, ω = {frequency:.5g} ({exc}); start from a threshold of "
            "an eigenvalue sweep (fsistab critical)"
        ) from None
    stop = _flow_stop(iterator, parameter)
    return NeutralCurve(
        tuple(points),
        parameter=parameter,
        turning_points=tuple(turning),
        folds=tuple(t.index for t in turning),
        stops=(stop,),
        factorisations=counter.count - first,
    )


FLOW_CURVE_FIELDS = {
    "point": ("reynolds", "alpha0_deg", "reduced_velocity", "frequency"),
    "fold": ("fold_reynolds", "fold_alpha0_deg", "fold_reduced_velocity", "fold_frequency"),
}


def flow_curve_table(path, attrs: dict):
    """The resumable table (:class:`fsistab.store.ResumableTable`) of one half-curve of identity
    ``attrs``: its points along ``point``, its turning points along ``fold`` (fields
    ``FLOW_CURVE_FIELDS``); complete once :func:`record_flow_curve` has finished it."""
    from fsistab.store import ResumableTable

    return ResumableTable(path, attrs, FLOW_CURVE_FIELDS)


def record_flow_curve(table, curve: NeutralCurve):
    """Record ``curve`` in ``table`` (:func:`flow_curve_table`, emptied first) and finish it with
    attributes ``parameter``, ``stop`` and ``factorisations``; returns the table's dataset, the
    input of :func:`stack_flow_curves`."""

    def columns(point, prefix=""):
        return {
            f"{prefix}reynolds": point.reynolds,
            f"{prefix}alpha0_deg": point.alpha0_deg,
            f"{prefix}reduced_velocity": point.reduced_velocity,
            f"{prefix}frequency": point.frequency,
        }

    table.clear()
    for point in curve.points:
        table.append(columns(point), kind="point", save=False)
    for point in curve.turning_points:
        table.append(columns(point, "fold_"), kind="fold", save=False)
    table.finish(
        {"parameter": curve.parameter, "stop": curve.stops[-1], "factorisations": curve.factorisations}
    )
    return table.dataset()


def stack_flow_curves(halves, parameter: str, attrs: dict):
    """The half-curves of :func:`record_flow_curve` (each continued from one threshold in one
    direction) stacked in one Dataset: points along ``point`` with a ``curve`` index, turning points
    along ``fold``, each half's kind, direction and stop along ``curve_index``."""
    import xarray as xr

    column = "reynolds" if parameter == "reynolds" else "alpha0_deg"

    def stacked(name: str, dim: str) -> np.ndarray:
        return np.concatenate([h[name].values for h in halves] or [np.zeros(0)]).astype(float)

    def index(dim: str) -> np.ndarray:
        return np.concatenate(
            [np.full(h.sizes.get(dim, 0), i) for i, h in enumerate(halves)] or [np.zeros(0)]
        )

    return xr.Dataset(
        {
            "curve": ("point", index("point").astype(int)),
            "parameter_value": ("point", stacked(column, "point")),
            "reduced_velocity": ("point", stacked("reduced_velocity", "point")),
            "frequency": ("point", stacked("frequency", "point")),
            "fold_curve": ("fold", index("fold").astype(int)),
            "fold_parameter_value": ("fold", stacked(f"fold_{column}", "fold")),
            "fold_reduced_velocity": ("fold", stacked("fold_reduced_velocity", "fold")),
            "kind": ("curve_index", np.array([h.attrs["kind"] for h in halves], dtype=str)),
            "direction": ("curve_index", np.array([int(h.attrs["direction"]) for h in halves], dtype=int)),
            "stop": ("curve_index", np.array([str(h.attrs["stop"]) for h in halves], dtype=str)),
        },
        attrs={**attrs, "parameter": parameter},
    )


def flow_curves(ds):
    """``(kind, direction, values, U*, ω, fold values, fold U*, stop)`` of each half-curve of a
    Dataset of :func:`stack_flow_curves`."""
    result = []
    for i in range(ds.sizes.get("curve_index", 0)):
        on, fold = ds.curve.values == i, ds.fold_curve.values == i
        result.append(
            (
                str(ds.kind.values[i]),
                int(ds.direction.values[i]),
                ds.parameter_value.values[on],
                ds.reduced_velocity.values[on],
                ds.frequency.values[on],
                ds.fold_parameter_value.values[fold],
                ds.fold_reduced_velocity.values[fold],
                str(ds.stop.values[i]),
            )
        )
    return result
