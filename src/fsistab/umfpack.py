"""UMFPACK on SciPy matrices: LU factorisations with a reusable symbolic analysis and cheap solves.

NGSolve's wheel links SuiteSparse's UMFPACK into ``libngla`` and exports its ``umfpack_dl_*`` and
``umfpack_zl_*`` entry points (64-bit indices, real and complex); this module calls them through
ctypes, on a SciPy CSC matrix. Against ``BaseMatrix.Inverse(inverse="umfpack")`` it gains
(docs/performance.md, "Where a solve went"):

* **cheaper solves**: NGSolve's solve runs UMFPACK's iterative refinement
  (``UMFPACK_IRSTEP = 2``), which estimates backward errors at the cost of extra products and
  solves. Here the plain solve is the default and one refinement step is done in NumPy on request
  (:meth:`LU.solve` ``refine``), for one extra solve;
* **the symbolic analysis reused** (:class:`Analysis`) for every matrix of the same sparsity
  pattern — ``J + sM`` at every shift ``s`` — instead of redone in each factorisation;
* no reassembly of ``J + sM`` by NGSolve: the matrix is formed from SciPy blocks.

The ngsolve version is pinned in ``pyproject.toml``; if the symbols were missing, :func:`available`
says so and :mod:`fsistab.linalg` falls back to NGSolve's own UMFPACK.
"""

from __future__ import annotations

import ctypes
import functools
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from fsistab.errors import ConvergenceError, InputError

# How a sparse matrix is factorised: this module, or NGSolve's Inverse(inverse="umfpack") (which
# refines every solve and redoes the analysis each time; kept as the fallback and for comparison)
BACKENDS = ("umfpack", "ngsolve")


def check_backend(backend: str, what: str = "factorisation") -> str:
    """``backend`` if it is one of :data:`BACKENDS`, else a one-line InputError."""
    if backend not in BACKENDS:
        raise InputError(f"unknown {what} {backend!r}: choose {', '.join(BACKENDS)}")
    return backend


_CONTROL, _INFO = 20, 90  # UMFPACK_CONTROL, UMFPACK_INFO
_IRSTEP = 7  # Control index: steps of iterative refinement
_SYSTEM_A = 0  # UMFPACK_A: solve A x = b
_SYSTEM_AT = 1  # UMFPACK_At: solve Aᴴ x = b (conjugate transpose; the transpose if A is real)
_STATUS_WARNING_SINGULAR = 1

_void_p = ctypes.c_void_p
_doubles = np.ctypeslib.ndpointer(np.float64, flags="C_CONTIGUOUS")
_indices = np.ctypeslib.ndpointer(np.int64, flags="C_CONTIGUOUS")


@functools.cache
def _library():
    """``libngla`` with UMFPACK's prototypes declared, or None if it does not export them."""
    import ngsolve

    candidates = sorted((Path(ngsolve.__file__).parent.parent / "netgen_mesher.libs").glob("libngla*.so*"))
    if not candidates:
        return None
    try:
        lib = ctypes.CDLL(str(candidates[0]))
        lib.umfpack_dl_defaults.argtypes = [_doubles]
        for kind in "dz":
            z = [_void_p] if kind == "z" else []  # split imaginary parts: NULL = packed complex
            symbolic = getattr(lib, f"umfpack_{kind}l_symbolic")
            symbolic.argtypes = [ctypes.c_int64, ctypes.c_int64, _indices, _indices, _doubles, *z]
            symbolic.argtypes += [ctypes.POINTER(_void_p), _doubles, _doubles]
            qsymbolic = getattr(lib, f"umfpack_{kind}l_qsymbolic")  # with a given ordering Qinit
            qsymbolic.argtypes = [ctypes.c_int64, ctypes.c_int64, _indices, _indices, _doubles, *z, _indices]
            qsymbolic.argtypes += [ctypes.POINTER(_void_p), _doubles, _doubles]
            numeric = getattr(lib, f"umfpack_{kind}l_numeric")
            numeric.argtypes = [_indices, _indices, _doubles, *z, _void_p, ctypes.POINTER(_void_p)]
            numeric.argtypes += [_doubles, _doubles]
            solve = getattr(lib, f"umfpack_{kind}l_solve")
            solve.argtypes = [ctypes.c_int, _indices, _indices, _doubles, *z, _doubles, *z, _doubles, *z]
            solve.argtypes += [_void_p, _doubles, _doubles]
            for name in ("symbolic", "qsymbolic", "numeric", "solve"):
                getattr(lib, f"umfpack_{kind}l_{name}").restype = ctypes.c_int
            for name in ("free_symbolic", "free_numeric"):
                getattr(lib, f"umfpack_{kind}l_{name}").argtypes = [ctypes.POINTER(_void_p)]
    except (OSError, AttributeError):
        return None
    return lib


def available() -> bool:
    """Whether NGSolve's library exports UMFPACK's entry points."""
    return _library() is not None


def _control() -> np.ndarray:
    control = np.zeros(_CONTROL)
    _library().umfpack_dl_defaults(control)
    control[_IRSTEP] = 0  # refinement, when wanted, is LU.solve's (one step, in NumPy)
    return control


def _check(status: int, what: str) -> None:
    if status == _STATUS_WARNING_SINGULAR:
        raise ConvergenceError(f"UMFPACK {what}: the matrix is singular")
    if status != 0:
        raise ConvergenceError(f"UMFPACK {what} failed with status {status}")


class PackedMatrix:
    """A CSC matrix's pattern and values as UMFPACK reads them (64-bit indices, packed complex);
    ``indices``: the 64-bit ``(pointers, rows)`` of the matrix if the caller has them
    (:class:`Pencil`), else copied from it."""

    def __init__(self, matrix: sp.spmatrix, indices: tuple[np.ndarray, np.ndarray] | None = None):
        csc = sp.csc_matrix(matrix)
        csc.sort_indices()
        if csc.shape[0] != csc.shape[1]:
            raise ValueError(f"UMFPACK factorises square matrices, got shape {csc.shape}")
        self.matrix = csc
        self.complex = np.iscomplexobj(csc.data)
        self.kind = "z" if self.complex else "d"
        self.size = csc.shape[0]
        if indices is None:
            indices = csc.indptr.astype(np.int64), csc.indices.astype(np.int64)
        self.pointers, self.rows = indices
        data = np.asarray(csc.data, dtype=complex if self.complex else float)
        self.values = np.ascontiguousarray(data).view(np.float64)
        self.split = [None] if self.complex else []  # the NULL imaginary-part arguments


class Pencil:
    """The matrices ``A + sB`` of two square SciPy matrices, for many shifts ``s``, in UMFPACK's
    form: the union of their patterns (sorted CSC, with its 64-bit indices) and the values of
    ``A`` and ``B`` on it are made once, so a shift costs one vectorised ``a + s b`` instead of a
    sparse sum, a conversion to CSC and copies of the indices (docs/performance.md, "The sparse
    LU"). Every shift has the same pattern (nonzeros of ``|A| + |B|``), so one :class:`Analysis`
    serves them all; the values are those of SciPy's ``A + s B`` to the bit (at ``s = 0`` with
    ``B``'s entries kept, as zeros)."""

    def __init__(self, a: sp.spmatrix, b: sp.spmatrix):
        if a.shape != b.shape or a.shape[0] != a.shape[1]:
            raise ValueError(f"a pencil of square matrices of one shape, got {a.shape} and {b.shape}")
        # canonical copies: SciPy canonicalises a matrix in place (abs, sums), which would write to
        # the caller's arrays while other threads may read them
        a, b = _sorted_csc(a), _sorted_csc(b)
        union = _sorted_csc(abs(a) + abs(b))  # the pattern: absolute values, so nothing cancels
        self.shape = union.shape
        self._indptr, self._indices = union.indptr, union.indices
        self._indices64 = union.indptr.astype(np.int64), union.indices.astype(np.int64)
        self._a, self._b = _on_pattern(a, union), _on_pattern(b, union)

    def at(self, shift: complex) -> PackedMatrix:
        """``A + shift·B`` (real for a real ``shift``), ready for :class:`Analysis` and :class:`LU`."""
        shift = complex(shift)
        values = self._a + (shift if shift.imag != 0 else shift.real) * self._b
        matrix = sp.csc_matrix((values, self._indices, self._indptr), shape=self.shape)
        matrix.has_sorted_indices = True
        return PackedMatrix(matrix, self._indices64)


def _sorted_csc(matrix: sp.spmatrix) -> sp.csc_matrix:
    """A canonical copy of ``matrix`` (sorted rows, no repeated entry), CSC."""
    csc = sp.csc_matrix(matrix, copy=True)
    csc.sum_duplicates()
    return csc


def _on_pattern(csc: sp.csc_matrix, union: sp.csc_matrix) -> np.ndarray:
    """The values of the canonical ``csc`` at the entries of ``union`` (a pattern holding its), zero
    where it has none: entry ``(i, j)`` of a sorted CSC matrix is the ``j·n + i``-th key in order."""
    n = union.shape[0]
    union_keys = np.repeat(np.arange(n, dtype=np.int64), np.diff(union.indptr)) * n + union.indices
    keys = np.repeat(np.arange(n, dtype=np.int64), np.diff(csc.indptr)) * n + csc.indices
    nonzero = csc.data != 0  # the union leaves out explicit zeros
    values = np.zeros(union.nnz, dtype=csc.data.dtype)
    values[np.searchsorted(union_keys, keys[nonzero])] = csc.data[nonzero]
    return values


class Analysis:
    """UMFPACK's symbolic analysis (column ordering, memory estimates) of one sparsity pattern in
    one arithmetic, reused by every :class:`LU` of a matrix with that pattern (e.g. ``J + sM`` at
    every shift ``s``). ``control``: UMFPACK's Control array (default :func:`_control`)."""

    def __init__(
        self, pattern: PackedMatrix, control: np.ndarray | None = None, ordering: np.ndarray | None = None
    ):
        lib = _library()
        self.kind = pattern.kind
        self._pointers, self._rows = pattern.pointers, pattern.rows  # shared with the first LU
        self._handle = _void_p()
        self.ordering = ordering
        info = np.zeros(_INFO)
        control = _control() if control is None else control
        common = (pattern.size, pattern.size, pattern.pointers, pattern.rows, pattern.values, *pattern.split)
        if ordering is None:
            status = getattr(lib, f"umfpack_{pattern.kind}l_symbolic")(
                *common, ctypes.byref(self._handle), control, info
            )
        else:  # a given column pre-ordering (UMFPACK_ORDERING_GIVEN)
            ordering = np.ascontiguousarray(ordering, dtype=np.int64)
            if ordering.shape != (pattern.size,):
                raise ValueError(f"an ordering of {ordering.shape} for a matrix of size {pattern.size}")
            status = getattr(lib, f"umfpack_{pattern.kind}l_qsymbolic")(
                *common, ordering, ctypes.byref(self._handle), control, info
            )
        _check(status, "symbolic analysis")

    def matches(self, pattern: PackedMatrix) -> bool:
        if self.kind != pattern.kind:
            return False
        if self._pointers is pattern.pointers and self._rows is pattern.rows:
            return True  # the same pencil's pattern: no comparison of millions of indices
        return np.array_equal(self._pointers, pattern.pointers) and np.array_equal(self._rows, pattern.rows)

    def __del__(self):
        lib = _library()
        if lib is not None and getattr(self, "_handle", None):
            getattr(lib, f"umfpack_{self.kind}l_free_symbolic")(ctypes.byref(self._handle))


_STRATEGY, _STRATEGY_SYMMETRIC = 5, 3  # Control index and value: UMFPACK_STRATEGY_SYMMETRIC
_ORDERING, _ORDERING_GIVEN = 10, 2  # Control index and value: UMFPACK_ORDERING_GIVEN (Qinit)


def nested_dissection(matrix: sp.spmatrix) -> np.ndarray:
    """A fill-reducing ordering of a square matrix with a (nearly) symmetric pattern: METIS's
    multilevel nested dissection (pymetis) of the graph of ``A + Aᵀ``, as a permutation ``q`` (the
    ``k``-th pivot is row and column ``q[k]``). On the plate's Taylor–Hood Jacobians it halves the
    flops of the LU against UMFPACK's own AMD ordering (nested dissection is the asymptotically
    optimal ordering of 2-D meshes; docs/performance.md)."""
    import pymetis

    pattern = sp.csr_matrix(matrix, copy=True)
    pattern.data = np.ones_like(pattern.data, dtype=np.int8)
    graph = (pattern + pattern.T).tocsr()
    graph.setdiag(0)
    graph.eliminate_zeros()
    # METIS's result depends on the order of each vertex's neighbours: sorted, it depends on the
    # matrix alone, not on how SciPy happened to store it (a sum's output is not always sorted)
    graph.sort_indices()
    order, _ = pymetis.nested_dissection(pymetis.CSRAdjacency(graph.indptr, graph.indices))
    return np.asarray(order, dtype=np.int64)


def symmetric_analysis(matrix: sp.spmatrix | PackedMatrix, ordering: np.ndarray | None = None) -> Analysis:
    """:class:`Analysis` with UMFPACK's symmetric strategy (diagonal pivots preferred) on the nested-
    dissection ordering of :func:`nested_dissection`, for a pattern-symmetric matrix such as a
    Taylor–Hood Jacobian: its numeric factorisations take less time and memory than with AMD or
    the default strategy (docs/performance.md, "The sparse LU: a nested-dissection ordering"). The
    strategy and ordering are kept in the analysis, so every :class:`LU` made with it follows them.
    ``ordering``: that of another analysis of the same pattern (e.g. in the other arithmetic)
    instead of a new one, since METIS takes most of an analysis's time."""
    control = _control()
    control[_STRATEGY] = _STRATEGY_SYMMETRIC
    control[_ORDERING] = _ORDERING_GIVEN
    packed = _packed(matrix)
    return Analysis(packed, control, nested_dissection(packed.matrix) if ordering is None else ordering)


def _packed(matrix: sp.spmatrix | PackedMatrix) -> PackedMatrix:
    return matrix if isinstance(matrix, PackedMatrix) else PackedMatrix(matrix)


class LU:
    """``A = LU`` (with UMFPACK's row and column permutations and scaling) of a square SciPy matrix,
    real or complex, or of one already packed (:meth:`Pencil.at`); ``analysis`` reuses a symbolic
    analysis of the same pattern (a mismatched one is ignored and a new one made).
    :attr:`analysis` is the one used, to pass to the next LU."""

    def __init__(self, matrix: sp.spmatrix | PackedMatrix, analysis: Analysis | None = None):
        pattern = _packed(matrix)
        self._pattern = pattern
        self.analysis = analysis if analysis is not None and analysis.matches(pattern) else Analysis(pattern)
        self._control = _control()
        self._handle = _void_p()
        info = np.zeros(_INFO)
        status = getattr(_library(), f"umfpack_{pattern.kind}l_numeric")(
            pattern.pointers, pattern.rows, pattern.values, *pattern.split, self.analysis._handle,
            ctypes.byref(self._handle), self._control, info,
        )  # fmt: skip
        _check(status, "factorisation")

    @property
    def dtype(self):
        return complex if self._pattern.complex else float

    def _solve(self, b: np.ndarray, system: int = _SYSTEM_A) -> np.ndarray:
        p = self._pattern
        b = np.ascontiguousarray(b, dtype=self.dtype)
        x = np.empty_like(b)
        info = np.zeros(_INFO)
        status = getattr(_library(), f"umfpack_{p.kind}l_solve")(
            system, p.pointers, p.rows, p.values, *p.split, x.view(np.float64), *p.split,
            b.view(np.float64), *p.split, self._handle, self._control, info,
        )  # fmt: skip
        _check(status, "solve")
        return x

    def solve(self, b: np.ndarray, refine: bool = True, transpose: bool = False) -> np.ndarray:
        """``A⁻¹ b`` for one vector in the matrix's arithmetic (a complex ``b`` with a real matrix
        is solved as two real systems). ``refine``: one step of iterative refinement,
        ``x ← x + A⁻¹(b − A x)`` (one product and one more solve; the relative residual falls from
        about 1e-12 to round-off on the plate Jacobians with :func:`symmetric_analysis`, from 1e-7
        with UMFPACK's default strategy). ``transpose``: solve ``Aᴴ x = b`` instead (the conjugate
        transpose, UMFPACK_At) with the same factors, e.g. for adjoint modes."""
        b = np.asarray(b)
        if b.ndim != 1 or b.shape[0] != self._pattern.size:
            raise ValueError(f"right-hand side of shape {b.shape} for a matrix of size {self._pattern.size}")
        if not self._pattern.complex and np.iscomplexobj(b):
            return self.solve(b.real, refine, transpose) + 1j * self.solve(b.imag, refine, transpose)
        if transpose:
            x = self._solve(b, _SYSTEM_AT)
            if refine:  # Aᴴ x = conj(Aᵀ conj(x)): a CSR view of the CSC matrix, no copy
                x += self._solve(b - np.conj(self._pattern.matrix.T @ np.conj(x)), _SYSTEM_AT)
            return x
        x = self._solve(b)
        if refine:
            x += self._solve(b - self._pattern.matrix @ x)
        return x

    def __del__(self):
        lib = _library()
        if lib is not None and getattr(self, "_handle", None):
            getattr(lib, f"umfpack_{self._pattern.kind}l_free_numeric")(ctypes.byref(self._handle))
