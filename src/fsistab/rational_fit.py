"""Local rational models of the fluid's transfer function from its exact samples (docs/model.md §7):
the neutral map's refinement wherever they certify one (before an exact bisection, and below
the smallest exact step), at no factorisation.

``G(s)`` (:func:`fsistab.transfer.exact_transfer`) is rational in ``s``; its poles are the fixed
body's fluid eigenvalues. Near the wake mode (the plate at Re 2900: ``−0.032 + 11.098i``) the VIV
curves of the map move so fast in ``ω`` that exact samples a relative step ``1e-3`` apart do not
resolve them (:func:`fsistab.transfer_map.transfer_neutral_map`, reason ``min_step``), although
``G`` itself is smooth on that scale: its poles there lie 0.03–0.2 from the axis, several sample
spacings. A rational interpolant of the samples then gives ``G`` between them to ~1e-8, so the
refinement can go on with interpolated samples.

The interpolant is set-valued AAA (Nakatsukasa, Sète & Trefethen, SIAM J. Sci. Comput. 40, 2018;
Lietaert, Meerbergen, Pérez & Vandereycken, IMA J. Numer. Anal. 42, 2022): one barycentric form

    ``r(s) = Σ_j w_j G(s_j) / (s − s_j)  /  Σ_j w_j / (s − s_j)``

for every entry, with support points ``s_j`` chosen greedily among the samples where the error is
largest and weights from the smallest singular vector of the stacked Loewner matrices, until the
error at every sample is below ``FIT_TOLERANCE`` (each load row relative to its size,
:func:`fsistab.reduced_model.relative_error`).

A model is trusted on an interval only when it is **certified** there (:func:`certified_transfer`):

1. *out of sample:* the interpolants of the even- and of the odd-numbered samples each predict the
   other half's values within ``tolerance``;
2. *derivative:* the interpolant of all samples reproduces the exact ``dG/ds`` of every sample
   (data not used in the fit) within ``tolerance`` relative to the size of ``dG/ds``;
3. *resolved poles:* no pole of it lies closer to the axis, inside the interval, than the largest
   sample spacing there (a pole the samples do not resolve, as the wake mode between the map's
   initial frequencies, would make the interpolant wrong between them).

Units: ``s = iω`` in the body's time unit ``L/U∞`` (docs/model.md §2, §10); loads as in
:func:`fsistab.transfer.exact_transfer`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from fsistab.errors import InputError
from fsistab.reduced_model import ROW_FLOOR, relative_error

FIT_TOLERANCE = 1e-9  # AAA stops when every sample is matched this closely (relative, per row)
MAX_DEGREE = 40  # at most this many support points
CERTIFY_TOLERANCE = 1e-6  # out-of-sample and derivative error a certified model stays below
MIN_SAMPLES = 12  # fewer exact samples cannot certify a model (each half must fit on its own)


@dataclass(frozen=True)
class BarycentricModel:
    """``r(s) = N(s)/D(s)``, ``N = Σ w_j f_j/(s − s_j)``, ``D = Σ w_j/(s − s_j)``: support points
    ``support`` (complex), values ``values`` (one row per support point, the entries of ``G``
    flattened) and weights ``weights``; ``shape`` the shape of one value of ``G``."""

    support: np.ndarray
    values: np.ndarray
    weights: np.ndarray
    shape: tuple[int, ...]

    def __call__(self, s: complex, derivative: bool = False):
        """``r(s)`` (shape ``shape``) and, with ``derivative``, ``r'(s) = Σ w_j (r − f_j)/(s − s_j)² / D``
        (the quotient rule rearranged so that it stays accurate near a support point); at a
        support point ``s_k`` the limit ``r'(s_k) = Σ_{j≠k} w_j (f_j − f_k)/(s_k − s_j) / w_k``."""
        d = s - self.support
        at = np.flatnonzero(d == 0)
        if at.size:
            k = at[0]
            value = self.values[k]
            if not derivative:
                return value.reshape(self.shape)
            others = np.arange(len(d)) != k
            c = self.weights[others] / d[others]  # d = s_k − s_j here
            rate = (c @ (self.values[others] - value[None, :])) / self.weights[k]
            return value.reshape(self.shape), rate.reshape(self.shape)
        c = self.weights / d
        denominator = c.sum()
        value = (c @ self.values) / denominator
        if not derivative:
            return value.reshape(self.shape)
        rate = ((c / d) @ (value[None, :] - self.values)) / denominator
        return value.reshape(self.shape), rate.reshape(self.shape)

    def poles(self) -> np.ndarray:
        """The finite poles: eigenvalues of the arrowhead pencil ``(E, B)`` of the barycentric
        form (Nakatsukasa et al. 2018, §2), two of them infinite."""
        n = len(self.support)
        e = np.zeros((n + 1, n + 1), dtype=complex)
        e[0, 1:], e[1:, 0], e[1:, 1:] = self.weights, 1.0, np.diag(self.support)
        b = np.eye(n + 1)
        b[0, 0] = 0.0
        poles = sla.eigvals(e, b)
        return poles[np.isfinite(poles)]


def _row_scales(values: np.ndarray) -> np.ndarray:
    """Per entry, the size of its load row over all samples (as :func:`relative_error` measures),
    so that the small moment row weighs as much as the lift row and a vanishing row (drag at
    α0 = 0: round-off) does not steer the fit."""
    size = np.abs(values).max(axis=0)  # shape of one G
    rows = np.maximum(size.max(axis=-1, keepdims=True), ROW_FLOOR * size.max())
    return np.broadcast_to(np.where(rows > 0, rows, 1.0), size.shape).ravel()


def aaa(points: np.ndarray, values: np.ndarray, tolerance: float = FIT_TOLERANCE) -> BarycentricModel:
    """Set-valued AAA: the barycentric interpolant of ``values[k]`` (arrays of one shape) at the
    complex ``points[k]`` (module docstring), at most ``MAX_DEGREE`` support points."""
    points = np.asarray(points, dtype=complex)
    values = np.asarray(values, dtype=complex)
    if points.ndim != 1 or len(points) < 2 or values.shape[0] != len(points):
        raise InputError("aaa needs at least two points and one value array per point")
    if len(np.unique(points)) != len(points):
        raise InputError("aaa needs distinct points")
    shape = values.shape[1:]
    scale = _row_scales(values)
    f = values.reshape(len(points), -1) / scale
    support: list[int] = []
    fitted = np.tile(f.mean(axis=0), (len(points), 1))
    weights = np.ones(1, dtype=complex)
    for _ in range(min(MAX_DEGREE, len(points) - 1)):
        error = np.abs(f - fitted).max(axis=1)
        error[support] = 0.0
        if error.max() <= tolerance:
            break
        support.append(int(error.argmax()))
        rest = np.setdiff1d(np.arange(len(points)), support)
        cauchy = 1.0 / (points[rest, None] - points[None, support])
        loewner = np.vstack([(f[rest, k, None] - f[None, support, k]) * cauchy for k in range(f.shape[1])])
        weights = np.linalg.svd(loewner, full_matrices=False)[2][-1].conj()
        fitted = f.copy()
        fitted[rest] = (cauchy @ (weights[:, None] * f[support])) / (cauchy @ weights)[:, None]
    if not support:  # constant data
        support = [0]
    # a support point of zero weight is no part of the interpolant: its 0/0 at its own point and
    # the spurious pole it adds to the arrowhead pencil are dropped with it
    used = np.flatnonzero(weights != 0)
    support = np.asarray(support)[used]
    return BarycentricModel(points[support], f[support] * scale, weights[used], shape)


@dataclass(frozen=True)
class TransferFit:
    """A certified local model of ``G`` on the frequencies ``[low, high]``: ``model`` evaluates
    ``G(iω)`` and ``dG/ds`` there; ``error`` is the largest certification error measured."""

    low: float
    high: float
    model: BarycentricModel
    error: float

    def covers(self, omega: float) -> bool:
        return self.low <= omega <= self.high

    def transfer(self, omega: float) -> tuple[np.ndarray, np.ndarray]:
        """``G(iω)`` and ``dG/ds`` at ``s = iω``."""
        return self.model(1j * omega, derivative=True)


def certified_transfer(
    frequencies: np.ndarray,
    values: np.ndarray,
    rates: np.ndarray,
    interval: tuple[float, float],
    tolerance: float = CERTIFY_TOLERANCE,
) -> TransferFit | None:
    """A model of ``G`` from exact samples (``values`` ``G(iω_k)``, ``rates`` ``dG/ds``, at the
    increasing ``frequencies``) certified on ``interval`` by the three checks of the module
    docstring, or None where a check fails or fewer than ``MIN_SAMPLES`` samples are given. The
    samples should reach beyond ``interval`` on both sides (the interpolant is least accurate at
    the ends of its data)."""
    w = np.asarray(frequencies, dtype=float)
    low, high = interval
    if len(w) < MIN_SAMPLES or np.any(np.diff(w) <= 0) or not w[0] <= low < high <= w[-1]:
        return None
    s = 1j * w
    values, rates = np.asarray(values), np.asarray(rates)
    inside = (w >= low) & (w <= high)
    around = np.flatnonzero(inside)
    if around.size < 2:
        return None
    worst = 0.0
    for parity in (0, 1):  # each half predicts the other inside the interval (not beyond its data)
        fit, test = np.arange(len(w)) % 2 == parity, (np.arange(len(w)) % 2 != parity) & inside
        half = aaa(s[fit], values[fit])
        predicted = np.array([half(z) for z in s[test]])
        worst = max(worst, relative_error(predicted, values[test]))
    model = aaa(s, values)
    derivative = np.array([model(z, derivative=True)[1] for z in s[inside]])
    worst = max(worst, relative_error(derivative, rates[inside]))
    if not worst <= tolerance:
        return None
    spacing = np.diff(w[max(around[0] - 1, 0) : around[-1] + 2]).max() if around.size else high - low
    poles = model.poles()
    unresolved = (poles.imag >= low) & (poles.imag <= high) & (np.abs(poles.real) < spacing)
    if unresolved.any():
        return None
    return TransferFit(float(low), float(high), model, float(worst))
