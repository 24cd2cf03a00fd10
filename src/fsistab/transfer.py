"""Aerodynamic transfer functions: the fluid eliminated exactly from the coupled problem (MODEL.md §7).

With ``K(s) = J + sM``, eliminating the fluid unknowns from (E) leaves the solid's characteristic
matrix (``n_s ≤ 4`` active solid states)::

    T(s) = K_ss(s) - K_sf(s) K_ff(s)⁻¹ K_fs(s),      σ eigenvalue of (E)  ⇔  det T(σ) = 0

(for ``σ`` not an eigenvalue of the fixed-body fluid). All of the fluid enters ``T`` through the
aerodynamic transfer matrix, 3 × 4::

    G(s) = load_s + s load_mass_s - (load_f + s load_mass_f) K_ff(s)⁻¹ (J_fs + s M_fs)

the body-axis loads ``(F_x, F_y, M)`` (units ``ρU∞²L`` per unit span, ``M`` about G,
counter-clockwise +) for a unit amplitude of each solid state ``(h, θ, ḣ, θ')`` varying like
``e^{st}``, with the inertia of the wall lifting. ``G`` depends on the body, the mesh, ``Re`` and
``α0`` only, and ``T(s) = P(s; m, U*, Ω, ζ, r_θ) - E G(s)`` (:func:`fsistab.coupled.solid_blocks`)
is assembled from it for any solid parameters. It is the viscous counterpart of Theodorsen's loads
(MODEL.md §9) and of the flutter derivatives of wind engineering.

``G`` is sampled exactly on the imaginary axis — one sparse factorisation of ``K_ff(iω)`` and three
back-substitutions per frequency — and approximated by a set-valued AAA rational function (one
barycentric denominator for all entries; Nakatsukasa, Sète & Trefethen 2018; Lietaert et al. 2022),
with samples at ``-iω`` taken as conjugates so that ``G(s̄) = conj G(s)``. Frequencies are added
where two successive approximants differ most; before each new sample is added, the current
approximant's prediction there is compared with the exact value: this *prediction error* is the
reported, measured accuracy, and sampling stops when it is below the tolerance twice in a row.
The fit converges where ``G`` is smooth (the plate at Re = 100: errors ~1e-7 with 80 samples). At
Re = 2900, weakly damped wake modes close to the axis make ``G(iω)`` vary on the scale of their
damping (~0.015), and neither this fit nor rational Krylov projections of the fluid (tried first)
reach useful accuracy with tens of factorisations (docs/transfer.md); neutral points are then
converged exactly by :func:`transfer_flutter_point`.

The eigenvalues of the approximated problem ``T(σ) x = 0`` follow from a linearisation of the
barycentric form (size ``(N + 1) n_s`` for ``N`` support points). Frequencies and growth rates are
in the body's time unit ``L/U∞`` (chord for the plate, diameter for the cylinder, MODEL.md §2, §10).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path

import numpy as np
import scipy.linalg as sla
import xarray as xr

from fsistab.coupled import active_states, lift_and_moment_rows, solid_blocks
from fsistab.critical import stiffness_derivative
from fsistab.errors import ConvergenceError, InputError
from fsistab.linalg import FactorCounter, FluidFactor
from fsistab.operators import FluidOperators
from fsistab.params import Solid
from fsistab.store import read_dataset, write_dataset

LOADS = ("force_x", "force_y", "moment")
RANK_TOLERANCE = 1e-10  # relative size below which a new Krylov direction is dropped as dependent


def default_frequencies(omega_max: float, n: int = 160) -> np.ndarray:
    """Error-estimate grid on the imaginary axis: 0, then log-spaced from 10⁻³ to ``omega_max``
    densified linearly above 1 (where wake poles sit)."""
    if not np.isfinite(omega_max) or omega_max <= 1e-3:
        raise InputError(f"the largest frequency must be above 1e-3, got {omega_max}")
    low = np.geomspace(1e-3, min(1.0, omega_max), n // 4)
    high = np.linspace(1.0, omega_max, n - n // 4) if omega_max > 1 else np.array([])
    return np.unique(np.concatenate([[0.0], low, high]))


def exact_transfer(
    fluid: FluidOperators,
    s: complex,
    counter: FactorCounter | None = None,
    factor: FluidFactor | None = None,
    derivative: bool = False,
):
    """``G(s)`` (3 × 4) from one sparse factorisation of ``K_ff(s)`` (or ``factor`` if given); with
    ``derivative``, also ``dG/ds`` from one more back-substitution with the same factorisation::

        X = K⁻¹(J_fs + s M_fs),   X' = K⁻¹(M_fs - M_f X),
        dG/ds = load_mass_s - load_mass_f X - (load_f + s load_mass_f) X'
    """
    factor = factor if factor is not None else FluidFactor(fluid, s, counter)
    response = factor.solve(fluid.jfs + s * fluid.mfs)
    load_rows = lambda x: fluid.load_f @ x + s * (fluid.load_mass_f @ x)  # noqa: E731
    value = fluid.load_s + s * fluid.load_mass_s - load_rows(response)
    if not derivative:
        return value
    rate = factor.solve(fluid.mfs - fluid.mff @ response)
    return value, fluid.load_mass_s - fluid.load_mass_f @ response - load_rows(rate)


def aerodynamic_loads(transfer: np.ndarray, theta0: float, loads0: np.ndarray, s: complex) -> np.ndarray:
    """``(C_L, C_M)`` per unit ``(ĥ, θ̂)`` for ``(h, θ) ∝ e^{st}`` (2 × 2): the viscous counterpart of
    Theodorsen's ``s² L₂ + s L₁ + L₀`` (:func:`fsistab.theodorsen.load_matrices`, ``a = 0``).

    ``C_L`` lab-frame lift, ``C_M`` about G counter-clockwise + (MODEL.md §4); the lift includes the
    steady force rotated with the body (``∂C_L/∂θ`` at fixed loads)."""
    rows, dcl_dtheta = lift_and_moment_rows(theta0, loads0)
    heave = rows @ (transfer[:, 0] + s * transfer[:, 2])
    pitch = rows @ (transfer[:, 1] + s * transfer[:, 3]) + np.array([dcl_dtheta, 0.0])
    return np.column_stack([heave, pitch])


@dataclass(frozen=True)
class Barycentric:
    """A matrix-valued rational function in barycentric form (set-valued AAA)::

    r(s) = Σ_j w_j F_j / (s - z_j)  /  Σ_j w_j / (s - z_j)

    ``support`` ``z_j`` (N), ``weights`` ``w_j`` (N), ``values`` ``F_j`` (N × 3 × 4)."""

    support: np.ndarray
    weights: np.ndarray
    values: np.ndarray

    def __call__(self, s) -> np.ndarray:
        """``r(s)`` (3 × 4) for a scalar ``s``, (len(s) × 3 × 4) for an array."""
        points = np.atleast_1d(np.asarray(s, dtype=complex))
        with np.errstate(divide="ignore", invalid="ignore"):
            cauchy = 1.0 / (points[:, None] - self.support[None, :])
            out = (
                np.einsum("pj,jab->pab", cauchy * self.weights, self.values)
                / (cauchy @ self.weights)[:, None, None]
            )
        hit_p, hit_j = np.nonzero(points[:, None] == self.support[None, :])
        out[hit_p] = self.values[hit_j]
        return out[0] if np.ndim(s) == 0 else out

    def poles(self) -> np.ndarray:
        """Zeros of the denominator: eigenvalues of the arrowhead pencil of AAA."""
        n = len(self.support)
        a = np.zeros((n + 1, n + 1), dtype=complex)
        a[0, 1:] = self.weights
        a[1:, 0] = 1.0
        a[1:, 1:] = np.diag(self.support)
        b = np.eye(n + 1)
        b[0, 0] = 0.0
        poles = sla.eig(a, b, right=False)
        return poles[np.isfinite(poles)]


def aaa(
    points: np.ndarray, values: np.ndarray, tolerance: float = 1e-12, max_terms: int = 100
) -> Barycentric:
    """Set-valued AAA fit of ``values`` (M × 3 × 4) at distinct ``points`` (M): one support set and one
    denominator for every entry; entries are scaled by their largest modulus (with a floor) so that
    each is fitted to ``tolerance`` relative to its own size."""
    points = np.asarray(points, dtype=complex)
    flat = np.asarray(values, dtype=complex).reshape(len(points), -1)
    scale = np.abs(flat).max(axis=0)
    scale = np.maximum(scale, 1e-8 * scale.max())
    data = flat / scale
    chosen: list[int] = []
    approx = np.tile(data.mean(axis=0), (len(points), 1))
    weights = np.ones(0, dtype=complex)
    for _ in range(min(max_terms, len(points) - 1)):
        error = np.abs(data - approx).max(axis=1)
        error[chosen] = 0.0
        if error.max() <= tolerance:
            break
        chosen.append(int(np.argmax(error)))
        rest = np.setdiff1d(np.arange(len(points)), chosen)
        cauchy = 1.0 / (points[rest, None] - points[None, chosen])
        loewner = np.vstack(
            [(data[rest, k, None] - data[None, chosen, k]) * cauchy for k in range(data.shape[1])]
        )
        weights = np.linalg.svd(loewner, full_matrices=False)[2][-1].conj()
        approx = data.copy()
        approx[rest] = (cauchy * weights) @ data[chosen] / (cauchy @ weights)[:, None]
    if not chosen:  # constant data
        chosen, weights = [0], np.ones(1, dtype=complex)
    fitted = (data[chosen] * scale).reshape((len(chosen),) + np.shape(values)[1:])
    return Barycentric(points[chosen], weights, fitted)


def _symmetric_samples(frequencies: np.ndarray, samples: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Samples at ``iω`` completed with ``-iω ↦ conj`` (``G`` is real on the real axis)."""
    positive = frequencies > 0
    points = np.concatenate([1j * frequencies, -1j * frequencies[positive]])
    values = np.concatenate([samples, samples[positive].conj()])
    return points, values


@dataclass(frozen=True)
class TransferFunction:
    """Exact samples of ``G(iω)`` (``frequencies`` ≥ 0, ``samples`` n × 3 × 4) and their rational
    approximant; ``loads0``/``theta0`` the steady loads and pitch that ``T(s)`` also needs.
    ``attrs`` records the flow, mesh and construction (factorisations, prediction errors)."""

    frequencies: np.ndarray
    samples: np.ndarray
    loads0: np.ndarray
    theta0: float
    attrs: dict = field(default_factory=dict)

    @cached_property
    def fit(self) -> Barycentric:
        tolerance = 1e-2 * self.attrs.get("tolerance", 1e-6)
        return aaa(*_symmetric_samples(self.frequencies, self.samples), tolerance=tolerance)

    @property
    def omega_max(self) -> float:
        return float(self.frequencies.max())

    def __call__(self, s) -> np.ndarray:
        """``G(s)`` from the rational approximant (3 × 4, or n × 3 × 4 for an array of ``s``)."""
        return self.fit(s)


def _scaled_difference(a: np.ndarray, b: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Largest entry-wise difference, each entry relative to its own size (``scale``, 3 × 4)."""
    return (np.abs(a - b) / scale).reshape(len(a), -1).max(axis=1)


def sample_transfer(
    fluid: FluidOperators,
    *,
    omega_max: float = 40.0,
    tolerance: float = 1e-6,
    initial_frequencies: Sequence[float] | None = None,
    max_samples: int = 80,
    counter: FactorCounter | None = None,
    progress: Callable[[str], None] | None = None,
) -> TransferFunction:
    """Adaptive sampling of ``G(iω)`` on ``[0, omega_max]`` (module docstring): one factorisation per
    sample; stops when two successive prediction errors are below ``tolerance`` (relative to each
    entry's largest modulus), or after ``max_samples`` (``attrs["converged"]`` says which)."""
    if not 0 < tolerance < 1:
        raise InputError(f"the tolerance must be in (0, 1), got {tolerance}")
    candidates = default_frequencies(omega_max, 600)
    if initial_frequencies is None:
        initial_frequencies = [0.0, *np.geomspace(0.01, omega_max, 9)]
    counter = counter if counter is not None else FactorCounter()
    frequencies, samples, errors = [], [], []

    def add(omega: float) -> np.ndarray:
        value = exact_transfer(fluid, 1j * omega if omega > 0 else 0.0, counter)
        frequencies.append(float(omega))
        samples.append(value)
        return value

    for omega in initial_frequencies:
        add(float(omega))
    previous = None
    converged = False
    while len(frequencies) < max_samples:
        tf = TransferFunction(
            np.array(frequencies), np.array(samples), fluid.loads0, fluid.theta0, {"tolerance": tolerance}
        )
        current = tf(1j * candidates)
        scale = np.maximum(np.abs(np.array(samples)).max(axis=0), 1e-8 * np.abs(np.array(samples)).max())
        if previous is None:  # a fit on every other sample stands in for the previous approximant
            order = np.argsort(frequencies)[::2]
            previous = TransferFunction(
                np.array(frequencies)[order], np.array(samples)[order], fluid.loads0, fluid.theta0, tf.attrs
            )(1j * candidates)
        change = _scaled_difference(current, previous, scale)
        change[np.isin(candidates, frequencies)] = -1.0
        omega = float(candidates[int(np.argmax(change))])
        predicted = current[int(np.argmax(change))]
        exact = add(omega)
        errors.append(float(_scaled_difference(exact[None], predicted[None], scale)[0]))
        previous = current
        if progress:
            progress(f"{len(frequencies)} samples, prediction error {errors[-1]:.1e} at ω = {omega:.4g}")
        if len(errors) >= 2 and max(errors[-2:]) < tolerance:
            converged = True
            break
    attrs = {
        **flow_identity(fluid),
        "ndof_fluid": fluid.n_fluid,
        "tolerance": tolerance,
        "omega_max": float(omega_max),
        "converged": converged,
        "factorisations": len(frequencies),
        "prediction_errors": errors,
    }
    order = np.argsort(frequencies)
    return TransferFunction(
        np.array(frequencies)[order], np.array(samples)[order], fluid.loads0, fluid.theta0, attrs
    )


def _solid_parts(solid: Solid, theta0: float, loads0: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """``P0`` and ``E`` of ``T(s) = P0 + s I - E G(s)[:, a]`` on the active states ``a``."""
    zero = np.zeros((3, 4))
    jss, _, rows = solid_blocks(solid, theta0, loads0, zero, zero)
    a = active_states(solid)
    coupling = np.vstack([np.zeros((2, 3)), rows])[a]
    return jss[np.ix_(a, a)], coupling, a


def characteristic_matrix(
    transfer: np.ndarray, solid: Solid, s: complex, theta0: float, loads0: np.ndarray
) -> np.ndarray:
    """``T(s)`` on the active solid states (n_s × n_s) from ``G(s)`` (``transfer``, 3 × 4): ``σ`` is a
    coupled eigenvalue iff ``det T(σ) = 0``. Rows those of ``R_s`` (MODEL.md §5), columns the active
    ``(h, θ, ḣ, θ')``."""
    p0, coupling, a = _solid_parts(solid, theta0, loads0)
    return p0 + s * np.eye(len(a)) - coupling @ transfer[:, a]


def determinant_on_axis(
    transfer: np.ndarray, rate: np.ndarray, solid: Solid, omega: float, theta0: float, loads0: np.ndarray
) -> tuple[np.ndarray, complex, complex, complex]:
    """``T(iω)``, ``det T`` and its derivatives ``∂/∂ω`` and ``∂/∂ log U*`` (MODEL.md §8) from
    ``G(iω)`` and ``dG/ds`` (``transfer``, ``rate``), by Jacobi's formula
    ``d det T = det T · tr(T⁻¹ dT)``; ``U*`` enters the in-vacuo rows only."""
    p0, coupling, a = _solid_parts(solid, theta0, loads0)
    identity = np.eye(len(a))
    t = p0 + 1j * omega * identity - coupling @ transfer[:, a]
    dt_ds = identity - coupling @ rate[:, a]
    dt_dlogu = solid.reduced_velocity * stiffness_derivative(solid)[np.ix_(a, a)]
    det = np.linalg.det(t)
    inverse = np.linalg.inv(t)
    return t, det, det * np.trace(inverse @ (1j * dt_ds)), det * np.trace(inverse @ dt_dlogu)


@dataclass(frozen=True)
class TransferCriticalPoint:
    """A neutral point ``det T(iω_c; U*_c) = 0`` at fixed ``mass_ratio`` (time unit ``L/U∞``)."""

    mass_ratio: float
    reduced_velocity: float
    frequency: float
    iterations: int
    residuals: tuple[float, ...]
    factorisations: int


def transfer_flutter_point(
    fluid: FluidOperators,
    solid: Solid,
    frequency: float,
    *,
    tolerance: float = 1e-10,
    max_iterations: int = 12,
    counter: FactorCounter | None = None,
) -> TransferCriticalPoint:
    """Dynamic neutral point from the exact transfer function: Newton on the two real equations
    ``det T(iω; U*) = 0`` in ``(ω, log U*)``, starting from ``(frequency, solid.reduced_velocity)``.

    Each iteration costs one factorisation of ``K_ff(iω)`` and two back-substitutions (``G`` and
    ``dG/ds``); ``∂T/∂U*`` touches the solid part only. The counterpart, with a 4 × 4 determinant in
    place of the augmented sparse system, of :func:`fsistab.critical.flutter_point` (MODEL.md §8).
    """
    counter = counter if counter is not None else FactorCounter()
    start = counter.count
    omega, log_u = float(frequency), float(np.log(solid.reduced_velocity))
    residuals = []
    for iteration in range(1, max_iterations + 1):
        u = float(np.exp(log_u))
        current = replace(solid, reduced_velocity=u)
        value, rate = exact_transfer(fluid, 1j * omega, counter, derivative=True)
        t, det, d_omega, d_logu = determinant_on_axis(value, rate, current, omega, fluid.theta0, fluid.loads0)
        residuals.append(float(np.linalg.svd(t, compute_uv=False)[-1] / np.linalg.norm(t, 2)))
        jacobian = np.array([[d_omega.real, d_logu.real], [d_omega.imag, d_logu.imag]])
        step = np.linalg.solve(jacobian, -np.array([det.real, det.imag]))
        omega, log_u = omega + step[0], log_u + step[1]
        if abs(step[0]) < tolerance * max(1.0, abs(omega)) and abs(step[1]) < tolerance:
            if abs(omega) < 1e-6:
                raise ConvergenceError(
                    f"Newton on det T(iω; U*) from ω = {frequency:.4g} converged to the static root "
                    f"ω = 0 at U* = {np.exp(log_u):.5g} (a divergence, not a flutter point); "
                    "start closer to the dynamic crossing"
                )
            return TransferCriticalPoint(
                solid.mass_ratio,
                float(np.exp(log_u)),
                omega,
                iteration,
                tuple(residuals),
                counter.count - start,
            )
    raise ConvergenceError(
        f"Newton on det T(iω; U*) did not converge from ω = {frequency:.4g}, "
        f"U* = {solid.reduced_velocity:.4g} "
        f"(last residuals {', '.join(f'{r:.1e}' for r in residuals[-3:])}); start closer to the crossing "
        "found by an eigenvalue sweep"
    )


def coupled_eigenvalues(tf: TransferFunction, solid: Solid, radius: float | None = None) -> np.ndarray:
    """Eigenvalues ``σ`` (``ω ≥ 0``, ``|σ| ≤ radius``, default ``omega_max``) of ``T(σ)x = 0`` with the
    rational ``G``, sorted by decreasing growth rate, from the linearisation (``y_j = β_j(σ) x``)::

        (σ - z_j) y_j - w_j t = 0,      (P0 + σ I) Σ_j y_j - Σ_j E F_j y_j = 0

    The linearisation also has eigenvalues at the poles of the rational ``G`` (where ``E N(σ)`` is
    rank-deficient, ``N`` the barycentric numerator); they are removed.
    """
    p0, coupling, a = _solid_parts(solid, tf.theta0, tf.loads0)
    fit, n = tf.fit, len(a)
    count = len(fit.support)
    size = (count + 1) * n
    k0 = np.zeros((size, size), dtype=complex)
    k1 = np.zeros((size, size))
    eye = np.eye(n)
    for j in range(count):
        block = slice(j * n, (j + 1) * n)
        k0[block, block] = -fit.support[j] * eye
        k0[block, count * n :] = -fit.weights[j] * eye
        k1[block, block] = eye
        k0[count * n :, block] = p0 - coupling @ fit.values[j][:, a]
        k1[count * n :, block] = eye
    values = sla.eig(-k0, k1, right=False)
    radius = tf.omega_max if radius is None else radius
    values = values[np.isfinite(values) & (np.abs(values) <= radius) & (values.imag >= -1e-9)]

    poles = fit.poles()
    if len(poles):
        distance = np.abs(values[:, None] - poles[None, :]).min(axis=1)
        values = values[distance > 1e-7 * (1 + np.abs(values))]
    return values[np.argsort(-values.real)]


MOTIONS = ("heave", "pitch")
COEFFICIENTS = ("lift", "moment")


def _complex_variable(dims: tuple[str, ...], values: np.ndarray) -> xr.DataArray:
    """A complex array stored as a trailing ``part`` dimension (real, imag): NetCDF has no complex."""
    values = np.asarray(values)
    return xr.DataArray(np.stack([values.real, values.imag], axis=-1), dims=(*dims, "part"))


def from_parts(array: xr.DataArray) -> np.ndarray:
    """Inverse of the ``part`` split of :func:`viscous_theodorsen_dataset`."""
    return array.sel(part="real").values + 1j * array.sel(part="imag").values


def flow_identity(fluid: FluidOperators) -> dict:
    """What saved samples of ``G`` depend on (Re, α0, mesh key): checked when they are reused."""
    steady = fluid.steady
    return {
        "reynolds": steady.flow.reynolds,
        "alpha0_deg": steady.flow.alpha0_deg,
        "mesh_key": steady.mesh_spec.key(),
    }


def viscous_theodorsen_dataset(
    fluid: FluidOperators,
    frequencies: Sequence[float],
    *,
    counter: FactorCounter | None = None,
    progress: Callable[[int, int], None] | None = None,
    samples_path: Path | None = None,
) -> xr.Dataset:
    """``G(iω)`` at ``frequencies`` (> 0, time unit ``L/U∞``) and the loads ``(C_L, C_M)`` per unit
    ``(ĥ, θ̂)`` it gives (:func:`aerodynamic_loads`), beside Theodorsen's loads (MODEL.md §9, ``a = 0``,
    ``k = ω/2``) with thin-airfoil slopes and with the viscous static slopes of the same steady state
    (calibrated): the viscous Theodorsen function. One factorisation per frequency, one more for the
    slopes. Complex values carry a ``part`` dimension (real, imag). With ``samples_path``, every
    sample is added to that NetCDF as soon as it is computed (atomically) and samples already there
    for the same mesh and flow are reused: an interrupted run resumes, a repeated one factorises
    nothing but the slopes."""
    from fsistab.slopes import static_slopes
    from fsistab.theodorsen import AirfoilSlopes, TypicalSection, load_matrices, theodorsen_function

    omega = np.asarray(frequencies, dtype=float)
    if omega.ndim != 1 or len(omega) == 0 or np.any(~np.isfinite(omega)) or np.any(omega <= 0):
        raise InputError("the frequencies must be positive finite numbers")
    counter = counter if counter is not None else FactorCounter()
    identity = flow_identity(fluid)
    stored: dict[float, np.ndarray] = {}
    if samples_path is not None and Path(samples_path).is_file():
        done = read_dataset(samples_path, expect=identity)
        stored = dict(zip(done.frequency.values.tolist(), from_parts(done.transfer), strict=True))
    samples = []
    for i, w in enumerate(omega):
        if float(w) not in stored:
            stored[float(w)] = exact_transfer(fluid, 1j * w, counter)
            if samples_path is not None:
                keys = sorted(stored)
                write_dataset(
                    xr.Dataset(
                        {
                            "transfer": _complex_variable(
                                ("frequency", "load", "state"), [stored[k] for k in keys]
                            )
                        },
                        coords={"frequency": keys, "part": ["real", "imag"]},
                        attrs=identity,
                    ),
                    samples_path,
                )
        samples.append(stored[float(w)])
        if progress:
            progress(i + 1, len(omega))
    samples = np.array(samples)
    viscous = np.array(
        [
            aerodynamic_loads(g, fluid.theta0, fluid.loads0, 1j * w)
            for g, w in zip(samples, omega, strict=True)
        ]
    )
    static = static_slopes(fluid, counter)
    models = {}
    for name, slopes in (
        ("thin_airfoil", AirfoilSlopes.thin_airfoil()),
        ("calibrated", AirfoilSlopes.from_static(static)),
    ):
        l2, l1, l0 = load_matrices(TypicalSection.create(slopes=slopes), theodorsen_function(omega / 2))
        s = (1j * omega)[:, None, None]
        models[name] = s * s * l2 + s * l1 + l0
    loads_dims = ("frequency", "coefficient", "motion")
    return xr.Dataset(
        {
            "transfer": _complex_variable(("frequency", "load", "state"), samples),
            "viscous_loads": _complex_variable(loads_dims, viscous),
            "theodorsen_thin_airfoil": _complex_variable(loads_dims, models["thin_airfoil"]),
            "theodorsen_calibrated": _complex_variable(loads_dims, models["calibrated"]),
        },
        coords={
            "frequency": omega,
            "reduced_frequency": ("frequency", omega / 2),
            "load": list(LOADS),
            "state": ["h", "theta", "hdot", "thetadot"],
            "coefficient": list(COEFFICIENTS),
            "motion": list(MOTIONS),
            "part": ["real", "imag"],
        },
        attrs={
            **identity,
            "ndof_fluid": fluid.n_fluid,
            "factorisations": counter.count,
            "lift_slope_alpha": static.lift_slope_alpha,
            "moment_slope_alpha": static.moment_slope_alpha,
            "conventions": (
                "transfer: body-axis loads (F_x, F_y, M) [rho U^2 L] per unit (h, theta, hdot, thetadot) "
                "~ e^{st}, "
                "s = i*frequency, time unit L/U; loads: (C_L, C_M about G, counter-clockwise +) per unit "
                "(h, theta); reduced_frequency k = omega b/U with b = L/2 (MODEL.md §9)"
            ),
        },
    )
