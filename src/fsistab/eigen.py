"""Eigenpairs of ``σ M q + J q = 0`` nearest given shifts (docs/model.md §7), by shift-invert Arnoldi.

``σ = λ + iω``: growth rate ``λ``, frequency ``ω`` in the body's time unit (``L/U∞``). ``J`` and
``M`` are real, so eigenvalues come in conjugate pairs: only ``ω ≥ 0`` is reported. Modes are
normalised so that their largest solid displacement (or, for a fixed body, their fluid
``qᴴ M q``) is one and real, and labelled by their kinetic-energy content.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spla

from fsistab.coupled import CoupledSystem, solid_energies
from fsistab.errors import ConvergenceError
from fsistab.linalg import FactorCounter, FluidFactor, ShiftedSolver, residual_norm, shift_invert_operator
from fsistab.params import Solid


@dataclass(frozen=True)
class Eigenpair:
    """One eigenvalue with its mode (coupled vector, solid states first) and diagnostics.

    ``solid`` holds the complex amplitudes of ``(h, θ, ḣ, θ')`` (zero for inactive states);
    ``solid_energy_fraction`` the share of the solid in the kinetic energy near the body,
    ``E_s / (E_s + E_f)`` with ``E_s = (m/4)(|ḣ|² + r_θ²|θ'|²)`` (units ``ρL²U∞²``) and ``E_f`` the
    fluid's ``½∫|û|²`` within one body length of G.
    """

    value: complex
    vector: np.ndarray
    residual: float
    label: str
    solid: np.ndarray
    solid_energy_fraction: float
    shift: complex

    @property
    def growth_rate(self) -> float:
        return float(self.value.real)

    @property
    def frequency(self) -> float:
        return float(self.value.imag)


def label_mode(
    solid: np.ndarray, params: Solid, fluid_energy: float, theta0: float = 0.0
) -> tuple[str, float]:
    """``fluid`` when the solid holds less than half the kinetic energy, else ``heave``, ``pitch``
    or ``coupled`` (both above a quarter of the solid energy); the solid's energies as
    :func:`fsistab.coupled.solid_energies` (with a static unbalance, the heave of the centre of mass)."""
    # m̃ = m ρL²/2, so the kinetic energy ½m̃|ḣ|² is (m/4)|ḣ|² in units of ρL²U∞²; the fluid's is ½∫|û|²
    heave, pitch = solid_energies(params, solid[2:4], theta0)
    solid_energy = heave + pitch
    fraction = solid_energy / (solid_energy + fluid_energy) if solid_energy + fluid_energy > 0 else 0.0
    if fraction < 0.5:
        return "fluid", fraction
    if min(heave, pitch) > 0.25 * solid_energy:
        return "coupled", fraction
    return ("heave" if heave > pitch else "pitch"), fraction


def _normalise(system: CoupledSystem, vector: np.ndarray) -> np.ndarray:
    solid, _ = system.split(vector)
    displacement = solid[:2]
    if system.n_solid and np.abs(displacement).max() > 0:
        scale = displacement[np.argmax(np.abs(displacement))]
    else:
        n = system.fluid.n_fluid
        fluid = vector[-n:]
        scale = np.sqrt(np.vdot(fluid, system.fluid.mff @ fluid).real) or 1.0
        scale *= np.exp(1j * np.angle(fluid[np.argmax(np.abs(fluid))]))
    return vector / scale


def eigenpairs_near(
    system: CoupledSystem,
    shifts: Sequence[complex],
    n_eigenvalues: int = 6,
    *,
    tol: float = 1e-10,
    max_residual: float = 1e-6,
    counter: FactorCounter | None = None,
    fluid_factors: dict[complex, FluidFactor] | None = None,
) -> list[Eigenpair]:
    """The ``n_eigenvalues`` eigenpairs nearest each shift, merged, conjugates collapsed to ``ω ≥ 0``.

    One factorisation per shift (reused from ``fluid_factors`` when given, e.g. across solid
    parameters). Eigenpairs whose residual exceeds ``max_residual`` are dropped; if none remain
    near a shift a ConvergenceError suggests another shift.
    """
    counter = counter if counter is not None else FactorCounter()
    found: list[Eigenpair] = []
    for shift in shifts:
        shift = complex(shift)
        factor = (fluid_factors or {}).get(shift)
        solver = ShiftedSolver(system, shift, fluid_factor=factor, counter=counter)
        if fluid_factors is not None and solver.fluid_factor is not None:
            fluid_factors[shift] = solver.fluid_factor
        operator = shift_invert_operator(solver)
        k = min(n_eigenvalues, system.size - 2)
        try:
            # a wide Krylov space: the solid modes sit among many weakly damped fluid modes, and
            # restarts cost more than the memory (ncv vectors) here
            ncv = min(max(3 * k, 40), system.size - 1)
            start = _start_vector(system.size, operator.dtype)
            mu, vectors = spla.eigs(operator, k=k, which="LM", ncv=ncv, tol=tol, maxiter=2000, v0=start)
        except spla.ArpackNoConvergence as exc:
            mu, vectors = exc.eigenvalues, exc.eigenvectors
            if len(mu) == 0:
                raise ConvergenceError(
                    f"no eigenvalue converged near the shift {shift:.4g}; try a shift closer to the "
                    f"expected eigenvalue or ask for fewer eigenvalues"
                ) from None
        kept = 0
        for m_i, v_i in zip(mu, vectors.T, strict=True):
            if abs(m_i) < 1e-12:
                continue  # infinite eigenvalue (pressure constraint)
            sigma = shift - 1.0 / m_i
            vector = np.asarray(v_i, dtype=complex)
            if sigma.imag < 0:
                sigma, vector = np.conj(sigma), np.conj(vector)
            residual = residual_norm(system, sigma, vector)
            if residual > max_residual:
                continue
            found.append(_labelled(system, complex(sigma), vector, residual, shift))
            kept += 1
        if kept == 0:
            raise ConvergenceError(
                f"no eigenvalue near the shift {shift:.4g} reached a residual below {max_residual:g}; "
                f"try another shift"
            )
    return _unique(found)


def _labelled(system: CoupledSystem, sigma: complex, vector: np.ndarray, residual: float, shift: complex):
    """The normalised, labelled :class:`Eigenpair` of ``(σ, q)``."""
    vector = _normalise(system, vector)
    solid, fluid = system.split(vector)
    label, fraction = label_mode(solid, system.solid, system.fluid.near_energy(fluid), system.fluid.theta0)
    return Eigenpair(sigma, vector, residual, label, solid, fraction, shift)


def neutral_eigenpair(system: CoupledSystem, frequency: float, vector: np.ndarray) -> Eigenpair:
    """The :class:`Eigenpair` of a neutral mode ``σ = iω`` found without Arnoldi: a threshold's
    critical mode, e.g. the null vector of the transfer function's characteristic matrix
    (:meth:`fsistab.transfer.TransferSample.mode`, docs/model.md §7) at a converged neutral point of
    ``system``'s solid. Normalised and labelled as :func:`eigenpairs_near`'s; its residual
    ``‖J q + iω M q‖/‖q‖`` is computed, not assumed (it is as small as the point is converged)."""
    sigma = complex(0.0, frequency)
    vector = np.asarray(vector, dtype=complex)
    return _labelled(system, sigma, vector, residual_norm(system, sigma, vector), sigma)


def _start_vector(size: int, dtype) -> np.ndarray:
    """Arnoldi's start vector: a fixed pseudo-random one (ARPACK's own is drawn anew each call),
    so that a rerun gives the same eigenvalues to the last bit and meets its cached results."""
    rng = np.random.default_rng(20261129)
    vector = rng.standard_normal(size)
    return vector + 1j * rng.standard_normal(size) if np.issubdtype(dtype, np.complexfloating) else vector


def _unique(pairs: list[Eigenpair], rtol: float = 1e-7) -> list[Eigenpair]:
    """Drop duplicates found from several shifts (or a conjugate pair); sort by growth rate."""
    unique: list[Eigenpair] = []
    for pair in sorted(pairs, key=lambda p: p.residual):
        if all(abs(pair.value - q.value) > rtol * max(1.0, abs(q.value)) for q in unique):
            unique.append(pair)
    return sorted(unique, key=lambda p: -p.growth_rate)


def spectrum_dataset(pairs: list[Eigenpair], system: CoupledSystem, attrs: dict | None = None):
    """Eigenvalues, residuals, labels and solid amplitudes as an xarray Dataset (NetCDF-ready).

    Complex values (``shift``, ``solid``) carry the store's trailing ``part`` dimension
    (:func:`fsistab.store.complex_variable`); ``h, θ`` amplitudes are those of the normalised modes.
    Attributes carry the solid parameters and conventions.
    """
    import xarray as xr

    from fsistab.params import as_dict
    from fsistab.store import complex_variable

    n = len(pairs)
    solid = np.array([p.solid for p in pairs]).reshape(n, 4)
    data = {
        "growth_rate": ("mode", np.array([p.growth_rate for p in pairs])),
        "frequency": ("mode", np.array([p.frequency for p in pairs])),
        "residual": ("mode", np.array([p.residual for p in pairs])),
        "label": ("mode", np.array([p.label for p in pairs], dtype=str)),
        "solid_energy_fraction": ("mode", np.array([p.solid_energy_fraction for p in pairs])),
        "shift": complex_variable("mode", np.array([p.shift for p in pairs], dtype=complex)),
        "solid": complex_variable(("mode", "solid_state"), solid),
    }
    solid_attrs = {
        f"solid_{k}": (",".join(v) if isinstance(v, tuple) else v) for k, v in as_dict(system.solid).items()
    }
    ds = xr.Dataset(
        data,
        coords={"mode": np.arange(n), "solid_state": ["h", "theta", "hdot", "thetadot"]},
        attrs={
            "convention": "sigma = growth_rate + i frequency of sigma M q + J q = 0; time unit L/U",
            "reynolds": system.fluid.reynolds,
            "alpha0_deg": system.fluid.steady.flow.alpha0_deg,
            "body": system.fluid.steady.mesh_spec.body.kind,
            "ndof": system.size,
            **solid_attrs,
            **(attrs or {}),
        },
    )
    return ds
