"""Sparse factorisations of ``K(s) = J + s M`` and the shift-invert operator (the solvers layer).

The fluid block ``K_ff(s) = J_ff + s M_f``, assembled by :func:`fsistab.operators.shifted_fluid_matrix`
(in complex arithmetic for a complex shift; NGSolve's solvers take no SciPy matrix), is factorised
once with UMFPACK (faster than SciPy's SuperLU on these matrices: docs/performance.md, "Sparse
direct solvers compared"); this module writes no finite-element form. The few solid unknowns are
attached by exact block elimination (a bordered solve)::

    X = K_ff⁻¹ K_fs,   S = K_ss - K_sf X        (n_s fluid solves per factorisation)
    x_s = S⁻¹ (b_s - K_sf K_ff⁻¹ b_f),   x_f = K_ff⁻¹ b_f - X x_s

``X`` depends on the shift only, not on the solid parameters, so one factorisation serves every
``(m, U*, ...)`` at that shift. ``backend="superlu"`` factorises the whole coupled matrix with SciPy
instead (slower, kept so that solvers stay swappable and to cross-check).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse.linalg as spla

from fsistab import umfpack
from fsistab.coupled import CoupledSystem
from fsistab.errors import InputError
from fsistab.operators import FluidOperators, shifted_fluid_matrix

BACKENDS = ("umfpack", "superlu")


def sample_threads(threads: int | None = None) -> int:
    """Factorisations (or solves) run at once: ``threads``, or the CPU count but at most 2 (each
    factorisation held at once costs memory, of the order of a gigabyte on the default meshes). A
    one-line InputError below 1."""
    threads = min(2, os.cpu_count() or 1) if threads is None else int(threads)
    if threads < 1:
        raise InputError(f"threads must be at least 1, got {threads}")
    return threads


@dataclass
class FactorCounter:
    """Counts sparse factorisations (a benchmark figure)."""

    count: int = 0


def _shifted(fluid: FluidOperators, shift: complex) -> umfpack.PackedMatrix:
    """``J_ff + s M_f`` as UMFPACK reads it, real if ``s`` is (the operators' pencil)."""
    return fluid.pencil.at(shift)


def shared_analysis(
    fluid: FluidOperators, shift: complex, matrix=None, ordering: np.ndarray | None = None
) -> umfpack.Analysis:
    """The UMFPACK symbolic analysis of ``J_ff + s M_f`` in ``s``'s arithmetic, made once per
    operators and arithmetic (kept in ``fluid.analyses``) and shared by every shift: the symmetric
    strategy (the Taylor–Hood pattern is symmetric; its factors are cheaper and its unrefined solves
    more accurate, docs/performance.md, "The steady Newton") on a nested-dissection
    ordering, one for both arithmetics (``J_ff`` and ``J_ff + s M_f`` share their pattern).
    ``ordering``: the one to use when ``fluid`` has no analysis yet (:func:`analysis_ordering` of
    the same operators in another process, e.g. on a dask worker: factorised as there, bit for bit,
    without a new METIS run)."""
    shift = complex(shift)
    dtype = complex if shift.imag != 0 else float
    if dtype not in fluid.analyses:
        known = [a.ordering for a in fluid.analyses.values() if a.ordering is not None]
        matrix = _shifted(fluid, shift) if matrix is None else matrix
        fluid.analyses[dtype] = umfpack.symmetric_analysis(matrix, known[0] if known else ordering)
    return fluid.analyses[dtype]


def analysis_ordering(fluid: FluidOperators) -> np.ndarray | None:
    """The fill-reducing ordering of ``fluid``'s symbolic analyses (:func:`shared_analysis`), made
    now in complex arithmetic if there is none yet; None without UMFPACK's symbols."""
    if not umfpack.available():
        return None
    known = [a.ordering for a in fluid.analyses.values() if a.ordering is not None]
    return known[0] if known else shared_analysis(fluid, 1j).ordering


class FluidFactor:
    """``K_ff(s) = J_ff + s M_f`` factorised by UMFPACK (real arithmetic if ``s`` is real).

    By default through :mod:`fsistab.umfpack` on the SciPy blocks, the symbolic analysis shared by
    every shift of the same operators (``fluid.analyses``); ``backend="ngsolve"`` (or a wheel
    without UMFPACK's symbols) uses NGSolve's ``Inverse(inverse="umfpack")`` on a reassembled form,
    whose solves include UMFPACK's own iterative refinement.
    """

    def __init__(
        self,
        fluid: FluidOperators,
        shift: complex,
        counter: FactorCounter | None = None,
        backend: str = "umfpack",
    ):
        umfpack.check_backend(backend, "fluid factorisation")
        shift = complex(shift)
        self.shift = shift
        self.dtype = complex if shift.imag != 0 else float
        self.index = fluid.free_dofs
        if backend == "umfpack" and umfpack.available():
            matrix = _shifted(fluid, shift)
            self._lu = umfpack.LU(matrix, shared_analysis(fluid, shift, matrix))
        else:
            form, free = shifted_fluid_matrix(fluid, shift)
            self._lu = None
            self._inverse = form.mat.Inverse(free, inverse="umfpack")
            self._rhs = form.mat.CreateColVector()
            self._sol = form.mat.CreateColVector()
            self._form = form  # keeps the matrix alive with its factorisation
        if counter is not None:
            counter.count += 1

    def solve(
        self, b: np.ndarray, refine: bool = True, transpose: bool = False, threads: int | None = None
    ) -> np.ndarray:
        """``K_ff⁻¹ b`` for one vector or the columns of a matrix (fluid unknowns). ``refine=False``
        skips the refinement step (a third of the cost; relative residual about 1e-12 instead of
        round-off with the symmetric nested-dissection analysis): for Krylov bases whose results
        are checked against the exact residual afterwards, and for samples that only bracket a
        root that is then converged with refined solves.
        ``transpose``: ``K_ffᴴ x = b`` with the same factors (adjoint modes; umfpack backend only).
        The columns of a matrix are solved ``threads`` at a time (:func:`sample_threads`) with the
        umfpack backend: UMFPACK's solve only reads the factors and releases the GIL, and one
        right-hand side at a time is all it does (the Krylov blocks of the reduced models)."""
        if b.ndim == 2:
            # a zero column has the zero solution: not solved (the heave column of J_fs + s M_fs,
            # docs/model.md §7: the body-frame equations do not see the heave displacement)
            nonzero = [k for k in range(b.shape[1]) if np.any(b[:, k])]
            result = np.zeros(b.shape, dtype=np.result_type(b.dtype, self.dtype))
            columns = [b[:, k] for k in nonzero]
            threads = min(sample_threads(threads), max(len(columns), 1)) if self._lu is not None else 1
            if threads == 1:
                solved = [self.solve(col, refine, transpose) for col in columns]
            else:
                with ThreadPoolExecutor(threads) as pool:
                    solved = list(pool.map(lambda col: self.solve(col, refine, transpose), columns))
            for k, x in zip(nonzero, solved, strict=True):
                result[:, k] = x
            return result
        if self._lu is not None:
            return self._lu.solve(b, refine, transpose=transpose)
        if transpose:
            raise InputError("adjoint (transposed) solves need the backend 'umfpack' (fsistab.umfpack)")
        if self.dtype is float and np.iscomplexobj(b):
            return self.solve(b.real) + 1j * self.solve(b.imag)
        rhs = self._rhs.FV().NumPy()
        rhs[:] = 0
        rhs[self.index] = b
        self._sol.data = self._inverse * self._rhs
        return self._sol.FV().NumPy()[self.index].copy()


@dataclass
class ShiftedSolver:
    """Solves ``(J + s M) x = b`` for a coupled system; ``solve`` is the only public method."""

    system: CoupledSystem
    shift: complex
    fluid_factor: FluidFactor | None = None
    backend: str = "umfpack"
    counter: FactorCounter = field(default_factory=FactorCounter)

    def __post_init__(self):
        if self.backend not in BACKENDS:
            raise InputError(f"unknown linear solver backend {self.backend!r}: choose {', '.join(BACKENDS)}")
        s, sys_ = complex(self.shift), self.system
        s = s.real if s.imag == 0 else s  # real arithmetic for a real shift (divergence, slopes)
        if self.backend == "superlu":
            matrix = (sys_.jacobian + s * sys_.mass).tocsc()
            self._lu = spla.splu(matrix)
            self.counter.count += 1
            return
        if self.fluid_factor is None:
            self.fluid_factor = FluidFactor(sys_.fluid, s, self.counter)
        elif self.fluid_factor.shift != complex(s):
            raise InputError("the fluid factorisation was made for another shift")
        if sys_.n_solid:
            kfs = sys_.jfs + s * sys_.mfs
            self._ksf = (sys_.jsf + s * sys_.msf).tocsr()
            self._x = self.fluid_factor.solve(kfs)
            schur = (sys_.jss + s * sys_.mss) - self._ksf @ self._x
            self._schur = np.linalg.inv(schur)

    def solve(self, b: np.ndarray, refine: bool = True) -> np.ndarray:
        """``(J + sM)⁻¹ b``; ``refine`` as in :meth:`FluidFactor.solve`."""
        if self.backend == "superlu":
            return self._lu.solve(b)
        ns = self.system.n_solid
        y = self.fluid_factor.solve(b[ns:], refine)
        if not ns:
            return y
        x_s = self._schur @ (b[:ns] - self._ksf @ y)
        return np.concatenate([x_s, y - self._x @ x_s])


def shift_invert_operator(solver: ShiftedSolver) -> spla.LinearOperator:
    """``x ↦ (J + sM)⁻¹ M x``; its eigenvalues ``μ = 1/(s - σ)`` for ``σ M q + J q = 0``."""
    mass = solver.system.mass
    n = solver.system.size
    dtype = complex if complex(solver.shift).imag else float

    def matvec(x):
        # no refinement: Arnoldi's Ritz pairs are checked against the exact residual afterwards
        return solver.solve(mass @ np.asarray(x).ravel(), refine=False)

    return spla.LinearOperator((n, n), matvec=matvec, dtype=dtype)


def residual_norm(system: CoupledSystem, sigma: complex, vector: np.ndarray) -> float:
    """``‖J q + σ M q‖ / ‖q‖`` (2-norms)."""
    r = system.jacobian @ vector + sigma * (system.mass @ vector)
    return float(np.linalg.norm(r) / np.linalg.norm(vector))
