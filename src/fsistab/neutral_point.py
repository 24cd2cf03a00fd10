"""The neutral point of docs/model.md §8, independent of how the coupled problem is discretised:
:class:`NeutralPoint`, the one point type that every threshold method returns (a
:class:`TurningPoint` is one that also says where its curve turns), and the problem it solves.

The static neutral point (divergence, ``ω = 0``) of the pitching body has a closed form: the
static moment does not depend on the heave, so ``J(U*) q̂ = 0`` reduces to the torsional balance
``m r_θ² / U*² = dC_M/dθ`` (docs/model.md §8, §9), i.e. ``U*_D = √(m r_θ² / (dC_M/dθ))``. Every module
that needs a divergence velocity (the sparse map of :mod:`fsistab.neutral`, the transfer map, the
Theodorsen model, the threshold estimates of :mod:`fsistab.critical`) takes it from
:func:`divergence_velocity`.

A dynamic neutral point (``ω > 0``) is one problem — the problem is separate from the solver
(:func:`fsistab.continuation.newton`) and from the curve driver
(:class:`fsistab.continuation.ContinuationIterator`), as in BifurcationKit.jl. A *formulation* gives the
residual ``F(y)`` and a bordered solve ``[F_y; bᵀ] δ = rhs`` (a
:class:`~fsistab.continuation.CurveProblem`) for real unknowns ``y = (state…, ω, U*-coordinate, p)``
with ``p`` the parameter of the plane (``log m``, ``log Re`` or ``α0``); ``F`` has one equation
fewer than unknowns. One neutral point is ``F(y) = 0`` with ``p`` held
(:meth:`~fsistab.continuation.CurveProblem.pinned`: the same bordered solve with ``b = e_p``),
solved by the one Newton; a neutral curve is the continuation of the same ``F``. This module is
NumPy-only (the analytic Theodorsen model uses it without the finite elements). Formulations:

- :class:`fsistab.critical.AugmentedProblem`, the augmented sparse system of docs/model.md §8 in the
  ``(m, U*)`` plane, ``y = (Re q̂, Im q̂, ω, U*, log m)``::

      (iω M(m) + J(U*, m)) q̂ = 0,   Re(ĥ) = 0 (phase),   q̂ᴴ M q̂ = 1 (amplitude);

- :class:`DeterminantProblem`, any complex characteristic function ``f(ω, v, p)`` of three real
  unknowns with its gradient, ``F = (Re f, Im f)``: the exact transfer determinant ``det T(iω)``
  (:mod:`fsistab.transfer`, in the ``(m, U*)``, ``(Re, U*)`` and ``(α0, U*)`` planes), the
  characteristic polynomial of the transfer map at a sampled frequency
  (:mod:`fsistab.transfer_map`) and Theodorsen's determinant (:mod:`fsistab.theodorsen`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from fsistab.continuation import CurveProblem, SquareProblem
from fsistab.errors import InputError

STATIC_FREQUENCY = 1e-8  # |ω| below which a neutral point is static (divergence; U∞/L units)
KINDS = ("flutter", "viv", "divergence")
BOUNDARIES = ("onset", "restabilisation")


@dataclass(frozen=True)
class NeutralPoint:
    """A neutral point, ``λ = iω`` (docs/model.md §8): the one point type of every threshold method
    (the augmented system, the transfer determinant, the frequency sweep, the transfer map,
    continuation in ``(m, U*)`` and in the flow parameters, the Theodorsen model's thresholds).

    ``frequency`` in the body's time unit ``L/U∞`` (0 for divergence); ``reynolds`` and
    ``alpha0_deg`` the flow, NaN when the caller holds it implicitly. What a method knows beyond the
    point is optional: ``kind`` (flutter, viv or divergence; '' when not classified), ``boundary``
    (onset: unstable above ``reduced_velocity`` at fixed m; restabilisation; '' unknown),
    ``branch`` (the solid dof with most of the critical mode's kinetic energy, ``static`` for
    divergence), ``frequency_following`` (the local rule that labelled flutter or VIV,
    docs/model.md §8), ``mode`` (the coupled critical mode), the Newton ``residuals`` and
    ``iterations``, and the ``factorisations`` it cost.
    """

    mass_ratio: float
    reduced_velocity: float
    frequency: float
    kind: str = ""
    boundary: str = ""
    branch: str = ""
    frequency_following: float = math.nan
    reynolds: float = math.nan
    alpha0_deg: float = math.nan
    mode: np.ndarray | None = None
    residuals: tuple[float, ...] = ()
    iterations: int = 0
    factorisations: int = 0

    def __post_init__(self):
        if self.kind not in ("", *KINDS):
            raise InputError(f"unknown kind of neutral point {self.kind!r}: choose {', '.join(KINDS)}")
        if self.boundary not in ("", *BOUNDARIES):
            raise InputError(f"unknown boundary {self.boundary!r}: choose {', '.join(BOUNDARIES)}")


@dataclass(frozen=True)
class TurningPoint(NeutralPoint):
    """A neutral point where a curve turns in its parameter (a fold of ``U*_c(m)``,
    ``d(log m)/ds = 0``, or of ``U*_c(Re)``), between the curve's points ``index`` and ``index + 1``
    (``-1`` when not known); ``localised`` when it was located on the curve (otherwise it is the
    sampled point of extreme parameter)."""

    index: int = -1
    localised: bool = False


def _checked(name: str, value, positive: bool) -> np.ndarray:
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number or an array of numbers, got {value!r}") from None
    if not np.all(np.isfinite(array)):
        raise InputError(f"{name} must be finite, got {value!r}")
    if positive and np.any(array <= 0):
        raise InputError(f"{name} must be positive, got {value!r}")
    return array


def divergence_velocity(moment_slope, r_theta, mass_ratio):
    """Torsional divergence velocity ``U*_D = √(m r_θ² / (dC_M/dθ))`` (docs/model.md §8, §9).

    ``moment_slope`` is the steady slope ``dC_M/dθ`` about the elastic axis; the arguments
    broadcast like NumPy arrays. Where ``moment_slope <= 0`` the static moment restores the pitch
    at every speed: there is no divergence and the velocity is ``inf``. Non-finite inputs and
    non-positive ``r_theta`` or ``mass_ratio`` raise :class:`~fsistab.errors.InputError`. Returns a
    float for scalar inputs, an array otherwise.
    """
    slope = _checked("moment slope dC_M/dθ", moment_slope, positive=False)
    radius = _checked("radius of gyration r_θ", r_theta, positive=True)
    mass = _checked("mass ratio", mass_ratio, positive=True)
    slope, radius, mass = np.broadcast_arrays(slope, radius, mass)
    velocity = np.full(slope.shape, np.inf)
    restoring = slope > 0
    velocity[restoring] = np.sqrt(mass[restoring] * radius[restoring] ** 2 / slope[restoring])
    return float(velocity) if velocity.ndim == 0 else velocity


def unit_index(border: np.ndarray) -> int | None:
    """``k`` if ``border`` is a multiple of ``e_k`` (a held component), else ``None``."""
    nonzero = np.flatnonzero(border)
    return int(nonzero[0]) if len(nonzero) == 1 else None


Characteristic = Callable[[np.ndarray, bool], "complex | tuple[complex, np.ndarray]"]


class DeterminantProblem:
    """``F(y) = (Re f(y), Im f(y)) = 0`` for a complex characteristic function ``f`` of the three
    real unknowns ``y = (ω, v, p)`` (``v`` a coordinate of ``U*``, ``p`` the plane's parameter).

    ``characteristic(y, gradient)`` returns ``f(y)``, or with ``gradient`` the pair ``(f, ∇f)``
    (three complex numbers, ``∂f/∂(ω, v, p)``). The bordered solve is dense (3×3); a border
    ``e_k`` (a held component) reduces it to the 2×2 system in the other two. With ``chord`` the
    Jacobian of the last fresh solve is reused while the caller allows it (``reuse``), e.g. when
    one of its columns is a finite difference through a new steady state."""

    def __init__(self, characteristic: Characteristic, *, chord: bool = False, parameter: int = 2):
        self.characteristic, self.chord, self.parameter = characteristic, chord, parameter
        self._jacobian: np.ndarray | None = None

    size = 3

    def residual(self, y: np.ndarray) -> np.ndarray:
        value = complex(self.characteristic(y, False))
        return np.array([value.real, value.imag])

    def jacobian(self, y: np.ndarray) -> np.ndarray:
        _, gradient = self.characteristic(y, True)
        gradient = np.asarray(gradient, dtype=complex)
        return np.array([gradient.real, gradient.imag])

    def solve(self, y: np.ndarray, border: np.ndarray, rhs: np.ndarray, reuse: bool) -> np.ndarray:
        if not (self.chord and reuse and self._jacobian is not None):
            self._jacobian = self.jacobian(y)
        jacobian = self._jacobian
        held = unit_index(border)
        if held is None:
            return np.linalg.solve(np.vstack([jacobian, border]), rhs)
        delta = np.zeros(3)
        delta[held] = rhs[-1] / border[held]
        free = [i for i in range(3) if i != held]
        reduced_rhs = rhs[:2] - jacobian[:, held] * delta[held] if delta[held] else rhs[:2]
        delta[free] = np.linalg.solve(jacobian[:, free], reduced_rhs)
        return delta

    def curve(self, weights: np.ndarray | None = None) -> CurveProblem:
        """The neutral curve ``F = 0`` in the plane of ``(v, p)`` (default weights ``(0, 1, 1)``:
        arclength in the plane, not in ``ω``), turning points in ``p``."""
        weights = np.array([0.0, 1.0, 1.0]) if weights is None else weights
        return CurveProblem(self.residual, self.solve, parameter=self.parameter, weights=weights)

    def at(self, index: int, value: float) -> SquareProblem:
        """The neutral point with ``y[index]`` held at ``value`` (e.g. ``p``: a point at fixed m or
        flow; ``ω``: the transfer map at a sampled frequency)."""
        return self.curve().pinned(index, value)
