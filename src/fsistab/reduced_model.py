"""Reduced models of the fixed-body fluid: ``G(iω)`` on the whole imaginary axis from a few
factorisations, with a controlled error (docs/model.md §7, issue 6).

The aerodynamic transfer matrix (:func:`fsistab.transfer.exact_transfer`)::

    G(s) = load_s + s load_mass_s - (load_f + s load_mass_f) K(s)⁻¹ (J_fs + s M_fs),   K(s) = J_ff + s M_f

is a rational function of ``s`` whose poles are the fixed-body fluid's eigenvalues. At Re = 2900
dozens of them lie within 0.01–0.04 of the axis, so a single global fit of samples fails
(docs/transfer.md). Instead, around a shift ``s₀`` one factorisation of ``K(s₀)`` spans the block
Krylov space (shift-invert, shift-invariant)::

    V = span{ K(s₀)⁻¹B, A K(s₀)⁻¹B, …, A^d K(s₀)⁻¹B },   A = K(s₀)⁻¹ M_f,   B = [J_fs, M_fs]

and the Galerkin projection ``K_r(s) = Vᴴ J_ff V + s Vᴴ M_f V`` gives a rational model
``G_r(s)`` that matches the first ``d + 1`` moments of ``G`` at ``s₀`` (Grimme 1997; Antoulas 2005,
§11) and converges geometrically in ``d`` inside a disc around ``s₀`` limited by the nearest
poles it has not captured. Its error is estimated a posteriori by the model built on two blocks
fewer of the same (nested) basis: ``|G_r^{(d)} - G_r^{(d-2)}|``, which was above the true error
(by 2–5×) wherever that error was above round-off (tests/test_reduced_model.py, docs/transfer.md).

:class:`ReducedModels` builds models on demand (the neutral map asks for one where it refines
its sampling, :func:`fsistab.transfer_map.transfer_neutral_map`); :func:`reduced_cover` marches
along the axis from ``ω = 0`` and places shifts until every frequency up to ``omega_max`` lies in
the certified interval of one model. ``G`` and ``dG/ds`` then cost one dense solve of size
``≈ 4 (d + 1)`` per frequency, for any number of frequencies and any solid parameters: one
factorisation and ``d + 1`` block back-substitutions per model. The coupled eigenvalues of a model
(:func:`coupled_eigenvalues`) are those of the full problem where the model is accurate, which
gives certified unstable modes (:meth:`ReducedModels.unstable_eigenvalues`).

Units: ``s = λ + iω`` in the body's time unit ``L/U∞`` (chord for the plate, diameter for the
cylinder, docs/model.md §2, §10); loads as in :func:`fsistab.transfer.exact_transfer`.
"""

from __future__ import annotations

import functools
import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import scipy.linalg as sla

from fsistab.coupled import active_states, solid_blocks
from fsistab.errors import ConvergenceError, InputError
from fsistab.linalg import FactorCounter, FluidFactor, sample_threads
from fsistab.operators import FluidOperators
from fsistab.params import Solid
from fsistab.progress import Progress
from fsistab.store import ResumableTable
from fsistab.transfer import flow_identity

DEFLATION = 1e-10  # a new Krylov direction smaller than this (relative) is dropped as dependent
ESTIMATE_LAG = 2  # the error estimate compares the model with the one built on two blocks fewer
SCAN_POINTS = 32  # grid points per certified interval on which the estimate is checked
ROW_FLOOR = 1e-3  # relative size below which a load row is measured against the others
MIN_WIDTH = 1e-6  # a certified interval narrower than this (relative) means the model failed
PROJECTION_COLUMNS = 32  # columns of A V formed at a time for the projection Vᴴ A V


def relative_error(value: np.ndarray, reference: np.ndarray) -> float:
    """Largest entry of ``|value - reference|`` relative to the largest entry of the same load row
    of ``reference`` (forces and moment have different scales), rows smaller than ``ROW_FLOOR``
    times the largest entry measured against that floor (the drag row vanishes at α0 = 0)."""
    size = np.abs(reference)
    scale = np.maximum(size.max(axis=-1, keepdims=True), ROW_FLOOR * size.max())
    return float((np.abs(value - reference) / np.where(scale > 0, scale, 1.0)).max())


@dataclass(frozen=True)
class KrylovModel:
    """The Galerkin-projected fluid around one shift (module docstring): ``K_r(s) = jr + s mr``,
    inputs ``br0 + s br1`` (k × 4), output rows ``lf + s lm`` (3 × k); ``ends`` are the basis sizes
    after each Krylov block (nested models for the error estimate); ``interval`` the certified
    frequencies ``[ω_lo, ω_hi]`` (set by :meth:`ReducedModels.build`)."""

    shift: complex
    jr: np.ndarray
    mr: np.ndarray
    br0: np.ndarray
    br1: np.ndarray
    lf: np.ndarray
    lm: np.ndarray
    load_s: np.ndarray
    load_mass_s: np.ndarray
    ends: tuple[int, ...]
    interval: tuple[float, float] = (math.nan, math.nan)

    @property
    def size(self) -> int:
        return self.ends[-1]

    def transfer(self, s: complex, size: int | None = None, derivative: bool = False):
        """``G_r(s)`` (3 × 4) of the model on the first ``size`` basis vectors; with
        ``derivative``, also ``dG_r/ds`` (same formula as :func:`fsistab.transfer.exact_transfer`)."""
        k = size or self.size
        lu = sla.lu_factor(self.jr[:k, :k] + s * self.mr[:k, :k], check_finite=False)
        response = sla.lu_solve(lu, self.br0[:k] + s * self.br1[:k], check_finite=False)
        rows = self.lf[:, :k] + s * self.lm[:, :k]
        value = self.load_s + s * self.load_mass_s - rows @ response
        if not derivative:
            return value
        rate = sla.lu_solve(lu, self.br1[:k] - self.mr[:k, :k] @ response, check_finite=False)
        return value, self.load_mass_s - self.lm[:, :k] @ response - rows @ rate

    def error_estimate(self, s: complex) -> float:
        """``|G_r - G_r'|`` (:func:`relative_error`) with ``G_r'`` the model on ``ESTIMATE_LAG``
        blocks fewer: an upper estimate of the error of ``G_r(s)`` where the models converge."""
        if len(self.ends) <= ESTIMATE_LAG:
            return math.inf
        full = self.transfer(s)
        return relative_error(self.transfer(s, self.ends[-1 - ESTIMATE_LAG]), full)

    def covers(self, omega: float) -> bool:
        return self.interval[0] <= omega <= self.interval[1]


def _orthonormal_block(block: np.ndarray, basis: np.ndarray, scale: float) -> np.ndarray:
    """Columns of ``block`` orthogonalised against ``basis`` (classical Gram–Schmidt, twice) and
    among themselves (pivoted QR); directions below ``DEFLATION · scale`` are dropped."""
    for _ in range(2):
        if basis.shape[1]:
            # Vᴴb as (bᴴV)ᴴ: conjugates the thin block, not a copy of the whole basis
            block = block - basis @ (block.conj().T @ basis).conj().T
    q, r, _ = sla.qr(block, mode="economic", pivoting=True)
    rank = int(np.sum(np.abs(np.diag(r)) > DEFLATION * scale))
    return q[:, :rank]


def krylov_model(
    fluid: FluidOperators,
    shift: complex,
    blocks: int = 60,
    counter: FactorCounter | None = None,
    refine: bool = True,
) -> KrylovModel:
    """The reduced model at ``shift`` (module docstring) from one factorisation of ``K(shift)`` and
    ``blocks + 1`` block back-substitutions (block size ≤ 8, the independent columns of
    ``[J_fs, M_fs]``), refined unless ``refine`` is False. A real ``shift`` gives a real basis (real
    factorisation)."""
    if blocks < ESTIMATE_LAG + 1:
        raise InputError(f"a reduced model needs at least {ESTIMATE_LAG + 1} Krylov blocks, got {blocks}")
    factor = FluidFactor(fluid, shift, counter)
    inputs = np.column_stack([fluid.jfs, fluid.mfs])
    inputs = inputs[:, np.linalg.norm(inputs, axis=0) > 0]
    # the whole basis allocated once (columns filled block by block, no copy per block)
    store = np.empty((fluid.n_fluid, (blocks + 1) * inputs.shape[1]), dtype=factor.dtype, order="F")
    size, ends = 0, []
    # refined solves by default: the certificate must bound the true error, and an unrefined solve
    # with a large residual leaves a model error the nested-model estimate does not see. With the
    # symmetric nested-dissection analysis of FluidFactor the plain residual (~5e-13) is far below
    # the models' tolerance, and plain solves (refine=False) make the same model to within its
    # estimate, faster
    block = factor.solve(inputs, refine)
    for j in range(blocks + 1):
        scale = float(np.linalg.norm(block, axis=0).max())
        new = _orthonormal_block(block, store[:, :size], scale)
        if not new.shape[1]:
            break  # the Krylov space is invariant: the model is exact
        store[:, size : size + new.shape[1]] = new
        size += new.shape[1]
        ends.append(size)
        if j < blocks:
            block = factor.solve(fluid.mff @ new, refine)
    del factor, block  # the factors are not needed for the projections: their memory goes first
    basis = store[:, :size]
    # the two projections at once: SciPy's sparse and NumPy's dense products release the GIL, and
    # a model built while no exact sample runs (the end of a map's round) has both cores to itself
    with ThreadPoolExecutor(sample_threads()) as pool:
        jr, mr = pool.map(functools.partial(_projected, basis), (fluid.jff, fluid.mff))
    return KrylovModel(
        shift=complex(shift),
        jr=jr,
        mr=mr,
        br0=_adjoint_product(basis, fluid.jfs),
        br1=_adjoint_product(basis, fluid.mfs),
        lf=np.asarray(fluid.load_f @ basis),
        lm=np.asarray(fluid.load_mass_f @ basis),
        load_s=fluid.load_s,
        load_mass_s=fluid.load_mass_s,
        ends=tuple(ends),
    )


def _adjoint_product(basis: np.ndarray, other: np.ndarray) -> np.ndarray:
    """``Vᴴ X`` as ``conj(Vᵀ conj(X))``: ``Vᵀ`` is a view, so only the thin ``X`` is conjugated,
    not the basis (the basis is the largest array of a model). NumPy's product releases the
    GIL, which SciPy's BLAS wrappers do not: the map builds its models beside the exact samples."""
    if not np.iscomplexobj(basis):
        return basis.T @ other
    return (basis.T @ np.conj(other)).conj()


def _projected(basis: np.ndarray, operator) -> np.ndarray:
    """``Vᴴ A V`` for a sparse ``A``, ``PROJECTION_COLUMNS`` columns of ``A V`` at a time: the
    product is never held whole (another copy of the basis's size). A real ``A`` multiplies the
    real and imaginary parts of a complex basis separately: SciPy would otherwise convert ``A`` to
    complex, twice as slow."""
    size = basis.shape[1]
    result = np.empty((size, size), dtype=basis.dtype)
    for start in range(0, size, PROJECTION_COLUMNS):
        columns = basis[:, start : start + PROJECTION_COLUMNS]
        if np.iscomplexobj(columns) and not np.iscomplexobj(operator.data):
            product = operator @ columns.real + 1j * (operator @ columns.imag)
        else:
            product = operator @ columns
        result[:, start : start + PROJECTION_COLUMNS] = _adjoint_product(basis, product)
    return result


def certified_edge(model: KrylovModel, direction: int, tolerance: float, limit: float, first: float) -> float:
    """The frequency, going from the shift in ``direction`` (±1) but not past ``limit``, up to which
    the model's error estimate stays below ``tolerance``: steps doubling from ``first``, then
    bisection to 2 %, then a check on a grid of ``SCAN_POINTS`` (a narrow spike between the steps
    moves the edge back to the last good grid point)."""
    center = model.shift.imag
    span = abs(limit - center)
    if span == 0:
        return center

    def good(distance: float) -> bool:
        return model.error_estimate(1j * (center + direction * distance)) <= tolerance

    inside, outside = 0.0, min(first, span)
    while good(outside):
        inside = outside
        if outside >= span:
            return limit
        outside = min(2 * outside, span)
    for _ in range(40):
        if outside - inside <= 0.02 * outside:
            break
        middle = 0.5 * (inside + outside)
        inside, outside = (middle, outside) if good(middle) else (inside, middle)
    checked = 0.0
    for distance in np.linspace(0.0, inside, SCAN_POINTS + 1)[1:]:
        if not good(distance):
            break
        checked = distance
    return center + direction * checked


class ReducedModels:
    """Reduced models of one fluid, built on demand along the imaginary axis (module docstring).

    ``models`` holds the models built so far, each certified on its interval (estimated error of
    ``G`` below ``tolerance``, :func:`relative_error`); :meth:`transfer` evaluates ``G(iω)`` and
    ``dG/ds`` from the model covering ``ω`` (closest shift if several), :meth:`build` adds a
    model. With ``path`` every model is saved as it is built (NetCDF, atomically) and a new
    instance reuses the saved models of the same mesh, flow, ``blocks`` and ``tolerance``.
    """

    def __init__(
        self,
        fluid: FluidOperators,
        *,
        tolerance: float = 1e-7,
        blocks: int = 60,
        path: Path | None = None,
        counter: FactorCounter | None = None,
        progress: Progress = None,
        refine: bool = True,
    ):
        if not 0 < tolerance < 1e-2:
            raise InputError(f"the reduced-model tolerance must be in (0, 1e-2), got {tolerance}")
        if blocks < ESTIMATE_LAG + 1:
            raise InputError(f"a reduced model needs at least {ESTIMATE_LAG + 1} Krylov blocks, got {blocks}")
        self.fluid = fluid
        self.tolerance = float(tolerance)
        self.blocks = int(blocks)
        self.refine = bool(refine)
        self.path = Path(path) if path is not None else None
        self.counter = counter if counter is not None else FactorCounter()
        self._say = progress or (lambda message: None)
        self.identity = {**flow_identity(fluid), "blocks": self.blocks, "tolerance": self.tolerance}
        # models saved before (checksummed; a damaged file is reported and moved aside, another
        # run's refused); the index of where they were built survives it (:meth:`restore`)
        self._table = models_table(self.path, self.identity) if self.path is not None else None
        self.models: list[KrylovModel] = read_models(self._table) if self._table is not None else []
        self._index = index_table(self.path, self.identity) if self.path is not None else None
        if self.models:
            self._say(f"{len(self.models)} reduced models reused from {self.path}")
            self._index_missing()

    def _index_missing(self) -> None:
        """List in the index the models read back that it lacks (a file saved without one)."""
        listed = set(_indexed(self._index))
        missing = [m for m in self.models if _built_key(m.shift, m.interval) not in listed]
        for model in missing:
            self._index.append(index_record(model), save=False)
        if missing:
            self._index.save()

    def restore(self) -> int:
        """Rebuild the models of the index that the models file lost (damaged, reported and moved
        aside when it was read): each at its shift, one factorisation, with its certified interval;
        the rebuilt models are the lost ones (the same operators, shift and Krylov blocks) and are
        saved again. Returns how many were rebuilt."""
        if self._index is None:
            return 0
        have = {_built_key(m.shift, m.interval) for m in self.models}
        lost = [key for key in _indexed(self._index) if key not in have]
        if lost:
            self._say(f"rebuilding {len(lost)} reduced models lost from {self.path}")
        for shift, interval in lost:
            shift = 1j * shift.imag if shift.imag > 0 else 0.0
            model = krylov_model(self.fluid, shift, self.blocks, self.counter, refine=self.refine)
            model = replace(model, interval=interval)
            self.models.append(model)
            self._table.append(model_record(model))
        return len(lost)

    def covering(self, omega: float) -> KrylovModel | None:
        """The model whose certified interval contains ``omega`` (closest shift), or None."""
        inside = [m for m in self.models if m.covers(omega)]
        return min(inside, key=lambda m: abs(m.shift.imag - omega)) if inside else None

    def transfer(self, omega: float, derivative: bool = True):
        """``G(iω)`` and, with ``derivative``, ``dG/ds`` at ``s = iω`` (3 × 4 each); None if no
        model covers ``omega``."""
        model = self.covering(omega)
        if model is None:
            return None
        return model.transfer(1j * omega if omega > 0 else 0.0, derivative=derivative)

    def half_width(self) -> float | None:
        """Median half-width of the certified intervals built so far (None before the first)."""
        widths = [0.5 * (m.interval[1] - m.interval[0]) for m in self.models if m.shift.imag > 0]
        return float(np.median(widths)) if widths else None

    def build(self, omega: float, low: float = 0.0, high: float = math.inf) -> KrylovModel:
        """A model at ``s = iω`` (``s = 0``, real, for ``omega = 0``), certified inside
        ``[low, high]``: one factorisation, ``blocks + 1`` block back-substitutions (refined unless
        the models were made with ``refine=False``)."""
        shift = 1j * omega if omega > 0 else 0.0
        model = krylov_model(self.fluid, shift, self.blocks, self.counter, refine=self.refine)
        first = max(1e-3, 0.01 * omega)
        lo = certified_edge(model, -1, self.tolerance, max(low, 0.0), first) if omega > 0 else 0.0
        hi = certified_edge(model, +1, self.tolerance, min(high, 1e3 * max(omega, 1.0)), first)
        if hi - lo < MIN_WIDTH * max(1.0, omega):
            raise ConvergenceError(
                f"the reduced model at ω = {omega:.5g} certifies no interval at tolerance "
                f"{self.tolerance:g}: use more Krylov blocks or a larger tolerance"
            )
        model = replace(model, interval=(float(lo), float(hi)))
        self.models.append(model)
        if self._table is not None:
            self._table.append(model_record(model))
            self._index.append(index_record(model))
        interval = f"[{lo:.5g}, {hi:.5g}]"
        self._say(
            f"reduced model {len(self.models)} at ω = {omega:.5g}: size {model.size}, certified {interval}"
        )
        return model

    def unstable_eigenvalues(self, solid: Solid, tolerance: float | None = None) -> np.ndarray:
        """Eigenvalues with ``Re σ > 0``, ``Im σ ≥ 0`` of the coupled problem for ``solid``
        (:func:`coupled_eigenvalues`) that the models certify: ``Im σ`` in the interval of the model
        that computed it (the model of :meth:`covering`) and the error estimate at ``σ`` itself below
        ``tolerance`` (default: the models' tolerance; a larger one gives approximate eigenvalues,
        e.g. shifts for the full eigen-solver). Unstable modes at frequencies no model covers are
        not seen."""
        tolerance = self.tolerance if tolerance is None else tolerance
        found = []
        for model in self.models:
            for value in coupled_eigenvalues(model, solid, self.fluid.theta0, self.fluid.loads0):
                if value.real > 0 and value.imag >= 0 and self.covering(value.imag) is model:
                    if model.error_estimate(value) <= tolerance:
                        found.append(value)
        return np.array(sorted(found, key=lambda v: v.imag))

    def covered_to(self, omega: float) -> float:
        """Upper end of the covered part of the axis that starts at ``omega`` (``omega`` if none)."""
        reach = omega
        for model in sorted(self.models, key=lambda m: m.interval[0]):
            if model.interval[0] <= reach <= model.interval[1]:
                reach = max(reach, model.interval[1])
        return reach


def coupled_eigenvalues(model: KrylovModel, solid: Solid, theta0: float, loads0: np.ndarray) -> np.ndarray:
    """Eigenvalues ``σ`` of the coupled problem ``σ M q + J q = 0`` (docs/model.md §7) with the fluid
    replaced by ``model``'s Galerkin projection: the solid rows of :func:`fsistab.coupled.solid_blocks`,
    fluid rows ``Vᴴ(J_fs + σ M_fs) q_s + K_r(σ) y``. Dense, size ``n_s + k``; finite eigenvalues
    only. Valid where the model is accurate: see :meth:`ReducedModels.unstable_eigenvalues`."""
    jss, mss, coefficient_rows = solid_blocks(solid, theta0, loads0, model.load_s, model.load_mass_s)
    active = active_states(solid)
    k = model.size
    jsf = np.vstack([np.zeros((2, k)), -coefficient_rows @ model.lf])[active]
    msf = np.vstack([np.zeros((2, k)), -coefficient_rows @ model.lm])[active]
    jacobian = np.block([[jss[np.ix_(active, active)], jsf], [model.br0[:, active], model.jr]])
    mass = np.block([[mss[np.ix_(active, active)], msf], [model.br1[:, active], model.mr]])
    values = sla.eigvals(-jacobian, mass)
    return values[np.isfinite(values)]


def reduced_cover(
    fluid: FluidOperators,
    omega_max: float,
    *,
    tolerance: float = 1e-7,
    blocks: int = 60,
    path: Path | None = None,
    counter: FactorCounter | None = None,
    progress: Progress = None,
) -> ReducedModels:
    """Reduced models whose certified intervals cover ``[0, omega_max]``: ``G(iω)`` on that whole
    segment with an estimated error below ``tolerance`` (module docstring).

    The first shift is ``s = 0`` (real factorisation; ``G(0)`` for divergence); each next shift is
    placed 0.9 certified radius of the previous model beyond the covered part, and a gap left
    between two intervals is filled by a model at its middle. With ``path`` the models are saved
    as they are built, and an interrupted cover resumes where it stopped.
    """
    if not (math.isfinite(omega_max) and omega_max > 0):
        raise InputError(f"the largest frequency must be positive and finite, got {omega_max}")
    models = ReducedModels(
        fluid, tolerance=tolerance, blocks=blocks, path=path, counter=counter, progress=progress
    )

    def fill(low: float, high: float) -> None:
        lo, hi = models.build(0.5 * (low + high), low, high).interval
        if lo > low:
            fill(low, lo)
        if hi < high:
            fill(hi, high)

    if models.covering(0.0) is None:
        models.build(0.0, 0.0, omega_max)
    while (reach := models.covered_to(0.0)) < omega_max:
        last = max((m for m in models.models if m.covers(reach)), key=lambda m: m.interval[1])
        radius = last.interval[1] - max(last.shift.imag, last.interval[0])
        lo = models.build(min(reach + 0.9 * max(radius, 1e-3), omega_max), reach, omega_max).interval[0]
        if lo > reach:
            fill(reach, lo)
    return models


MODEL_FIELDS = {
    "model": ("shift", "jr", "mr", "br0", "br1", "lf", "lm", "load_s", "load_mass_s", "ends", "interval")
}


def models_table(path: Path, identity: dict) -> ResumableTable:
    """The resumable table of reduced models of identity ``identity`` (mesh, flow, blocks,
    tolerance): one record per :class:`KrylovModel`, its fields by name (the matrices' sizes differ
    from model to model: ragged fields). Conventions: ``K_r(s) = jr + s mr`` around ``shift``;
    ``G(s) = load_s + s load_mass_s - (lf + s lm) K_r⁻¹ (br0 + s br1)``; certified on ``interval``
    (frequency, time unit L/U)."""
    return ResumableTable(path, identity, MODEL_FIELDS)


def model_record(model: KrylovModel) -> dict:
    return {name: getattr(model, name) for name in MODEL_FIELDS["model"]}


def read_models(table: ResumableTable) -> list[KrylovModel]:
    """The models of a :func:`models_table`, in the order they were built."""
    return [
        KrylovModel(
            **{name: r[name] for name in ("jr", "mr", "br0", "br1", "lf", "lm", "load_s", "load_mass_s")},
            shift=complex(r["shift"]),
            ends=tuple(int(e) for e in r["ends"]),
            interval=tuple(float(x) for x in r["interval"]),
        )
        for r in table.records
    ]


INDEX_FIELDS = {"built": ("built_shift", "built_interval")}


def index_table(path: Path, identity: dict) -> ResumableTable:
    """The index of the reduced models saved at ``path``: the shift and certified interval of each,
    in the order built (``<stem>_index.nc`` beside it, same identity). Small and written apart, it
    tells which models to rebuild when the models file is found damaged (:meth:`ReducedModels.restore`)."""
    return ResumableTable(path.with_name(path.stem + "_index.nc"), identity, INDEX_FIELDS)


def index_record(model: KrylovModel) -> dict:
    return {"built_shift": model.shift, "built_interval": np.array(model.interval, dtype=float)}


def _built_key(shift: complex, interval) -> tuple[complex, tuple[float, float]]:
    return complex(shift), (float(interval[0]), float(interval[1]))


def _indexed(table: ResumableTable) -> list[tuple[complex, tuple[float, float]]]:
    """The ``(shift, interval)`` of every model in an :func:`index_table`, in the order built."""
    return [_built_key(r["built_shift"], r["built_interval"]) for r in table.records]
