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
        umfpack.Analysis(umfpack._Pattern(a), ordering=np.arange(5))
