"""UMFPACK through ctypes (fsistab.umfpack) against SciPy's SuperLU on random sparse systems."""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from fsistab import umfpack
from fsistab.errors import ConvergenceError

pytestmark = pytest.mark.skipif(not umfpack.available(), reason="NGSolve's wheel exports no UMFPACK")


def _matrix(n: int, seed: int, complex_values: bool) -> sp.csc_matrix:
    """A random sparse, diagonally dominated (hence regular) non-symmetric matrix."""
    rng = np.random.default_rng(seed)
    a = sp.random(n, n, density=0.02, random_state=rng, format="csc")
    if complex_values:
        a = a + 1j * sp.random(n, n, density=0.02, random_state=rng, format="csc")
    return (a + sp.diags(np.full(n, 3.0 + (0.5j if complex_values else 0.0)))).tocsc()


@pytest.mark.parametrize("complex_values", [False, True])
@pytest.mark.parametrize("refine", [False, True])
def test_solution_equals_superlu(complex_values, refine):
    a = _matrix(400, 1, complex_values)
    b = np.random.default_rng(2).standard_normal(400) * (1 + 1j if complex_values else 1)
    x = umfpack.LU(a).solve(b, refine)
    reference = spla.splu(a).solve(b)
    assert np.linalg.norm(x - reference) < 1e-11 * np.linalg.norm(reference)


def test_complex_right_hand_side_with_real_matrix():
    a = _matrix(300, 3, False)
    b = np.random.default_rng(4).standard_normal(300) + 1j * np.random.default_rng(5).standard_normal(300)
    x = umfpack.LU(a).solve(b)
    assert np.linalg.norm(a @ x - b) < 1e-12 * np.linalg.norm(b)


def test_analysis_reused_for_the_same_pattern_only():
    a = _matrix(300, 6, True)
    first = umfpack.LU(a)
    shifted = a + 2.5j * sp.diags(np.ones(300))  # same pattern: the diagonal is already there
    second = umfpack.LU(shifted.tocsc(), first.analysis)
    assert second.analysis is first.analysis
    b = np.ones(300, dtype=complex)
    assert np.linalg.norm(shifted @ second.solve(b) - b) < 1e-12 * np.linalg.norm(b)
    other = _matrix(300, 7, True)  # another pattern: a new analysis, still a correct solution
    third = umfpack.LU(other, first.analysis)
    assert third.analysis is not first.analysis
    assert np.linalg.norm(other @ third.solve(b) - b) < 1e-12 * np.linalg.norm(b)


def test_singular_matrix_is_reported():
    a = sp.csc_matrix(np.array([[1.0, 2.0], [2.0, 4.0]]))
    with pytest.raises(ConvergenceError, match="singular"):
        umfpack.LU(a).solve(np.ones(2))


def test_wrong_right_hand_side_refused():
    with pytest.raises(ValueError, match="right-hand side"):
        umfpack.LU(_matrix(50, 8, False)).solve(np.ones(49))


def _grid_laplacian(n: int) -> sp.csc_matrix:
    """The 5-point Laplacian of an n × n grid plus a non-symmetric convection part (the pattern of
    a 2-D finite-element Jacobian: symmetric pattern, non-symmetric values)."""
    one = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(n, n))
    upwind = sp.diags([-0.3, 0.3], [-1, 1], shape=(n, n))
    eye = sp.identity(n)
    return (sp.kron(one, eye) + sp.kron(eye, one) + sp.kron(upwind, eye)).tocsc()


def test_nested_dissection_is_a_permutation():
    a = _grid_laplacian(30)
    order = umfpack.nested_dissection(a)
    assert order.dtype == np.int64
    assert np.array_equal(np.sort(order), np.arange(a.shape[0]))


@pytest.mark.parametrize("complex_values", [False, True])
def test_symmetric_analysis_with_nested_dissection_solves(complex_values):
    a = _grid_laplacian(40)
    if complex_values:
        a = (a + 0.7j * sp.identity(a.shape[0])).tocsc()
    b = np.random.default_rng(9).standard_normal(a.shape[0]) * (1 - 2j if complex_values else 1)
    analysis = umfpack.symmetric_analysis(a)
    x = umfpack.LU(a, analysis).solve(b, refine=False)
    reference = spla.splu(a).solve(b)
    assert np.linalg.norm(x - reference) < 1e-11 * np.linalg.norm(reference)


def test_given_ordering_of_the_wrong_size_refused():
    a = _grid_laplacian(10)
    with pytest.raises(ValueError, match="ordering"):
        umfpack.Analysis(umfpack.PackedMatrix(a), ordering=np.arange(5))


@pytest.mark.parametrize("shift", [0.0, 0.4, 1.3j, 0.2 - 0.9j])
def test_pencil_packs_scipys_shifted_matrix_to_the_bit(shift):
    # B has entries outside A's pattern and A an explicit zero: the pencil's pattern is their union
    # without it, SciPy's sum's for a nonzero shift, the same at every shift (at 0, SciPy's sum
    # drops B's entries: the pencil keeps them as zeros), so one analysis serves every shift
    a = _matrix(200, 11, False)
    a.data[5] = 0.0  # an explicit zero, stored
    b = sp.random(200, 200, density=0.01, random_state=np.random.default_rng(12), format="csr")
    pencil = umfpack.Pencil(a, b)
    packed, other = pencil.at(shift), pencil.at(2.0j)
    value = shift if complex(shift).imag else complex(shift).real
    assert np.array_equal(packed.matrix.toarray(), (a + value * b).toarray())
    union = umfpack.PackedMatrix(a + 1.0 * b)
    for pattern in (packed, other):
        assert np.array_equal(pattern.pointers, union.pointers) and np.array_equal(pattern.rows, union.rows)
    if shift:
        assert np.array_equal(packed.values, umfpack.PackedMatrix(a + value * b).values)
    assert packed.complex == bool(complex(shift).imag)
    first = umfpack.LU(pencil.at(2.0j if packed.complex else 2.0))
    lu = umfpack.LU(packed, first.analysis)
    assert lu.analysis is first.analysis
    rhs = np.random.default_rng(13).standard_normal(200)
    assert np.linalg.norm((a + value * b) @ lu.solve(rhs) - rhs) < 1e-12 * np.linalg.norm(rhs)


def test_pencil_of_matrices_of_different_shapes_refused():
    with pytest.raises(ValueError, match="pencil"):
        umfpack.Pencil(_matrix(20, 1, False), _matrix(21, 1, False))


def test_pencil_leaves_its_matrices_as_they_are():
    # a product's rows may come unsorted: SciPy would sort them in place (abs, sums), writing to
    # arrays that other threads read (a map's first factorisations start in several threads)
    a = _matrix(120, 14, False).tocsr()
    for row in range(a.shape[0]):
        start, end = a.indptr[row], a.indptr[row + 1]
        a.indices[start:end] = a.indices[start:end][::-1].copy()
        a.data[start:end] = a.data[start:end][::-1].copy()
    a.has_sorted_indices = False
    b = sp.identity(120, format="csr")
    indices, data = a.indices.copy(), a.data.copy()
    pencil = umfpack.Pencil(a, b)
    assert np.array_equal(a.indices, indices) and np.array_equal(a.data, data)
    assert np.array_equal(pencil.at(0.5j).matrix.toarray(), (a + 0.5j * b).toarray())
