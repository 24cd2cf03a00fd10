"""The fluid operators restricted to the antisymmetric fields of a symmetric section at zero
incidence (fsistab.symmetry), against the whole space: the reflection against NGSolve's
interpolation of fields of known parity, and the transfer function, the thresholds and their modes
against those of the unrestricted operators."""

import numpy as np
import pytest
from ngsolve import CF, GridFunction, x, y
from scipy.sparse import identity

from fsistab import frequency_sweep, symmetry
from fsistab.frequency_sweep import sweep_thresholds
from fsistab.linalg import FactorCounter
from fsistab.operators import fluid_operators
from fsistab.params import Solid
from fsistab.transfer import transfer_sample


@pytest.fixture(scope="module")
def restricted(plate_operators):
    return symmetry.antisymmetric_operators(plate_operators)


def _interpolated(space, velocity, pressure) -> np.ndarray:
    """The dof vector of the quadratic velocity and linear-in-x pressure given, interpolated by
    NGSolve (exact: both lie in the Taylor–Hood space)."""
    field = GridFunction(space)
    field.components[0].Set(CF(velocity))
    field.components[1].Set(pressure)
    return field.vec.FV().NumPy().copy()


@pytest.mark.parametrize("parity", [1.0, -1.0])
def test_the_reflection_maps_fields_of_known_parity_onto_plus_or_minus_themselves(plate_2900, parity):
    """R(U, V, P)(X, Y) = (U, −V, P)(X, −Y): a field with U, P even and V odd in Y is its own
    image, one with U, P odd and V even is minus its image."""
    image, sign = symmetry.reflection(plate_2900)
    if parity > 0:  # U, P even in Y; V odd
        values = _interpolated(plate_2900.space, (1 + x + x * x + y * y, y + x * y), 2 + x + y * y)
    else:  # U, P odd in Y; V even
        values = _interpolated(plate_2900.space, (y + x * y, 1 + x + x * x + y * y), y - x * y)
    reflected = np.empty_like(values)
    reflected[image] = sign * values
    assert np.abs(values).max() > 1
    assert np.abs(reflected - parity * values).max() < 1e-12 * np.abs(values).max()


def test_the_restricted_operators_have_half_the_unknowns_and_an_orthonormal_basis(
    plate_operators, restricted
):
    basis = restricted.basis
    assert restricted is not plate_operators and plate_operators.basis is None
    assert basis.shape == (plate_operators.n_fluid, restricted.n_fluid)
    assert 0.45 < restricted.n_fluid / plate_operators.n_fluid < 0.5
    product = basis.T @ basis
    assert abs(product - identity(restricted.n_fluid)).max() < 1e-15


@pytest.mark.parametrize("s", [0.0, 0.2j, 1.1j, 11.2j, 0.05 + 3j])
def test_the_restricted_transfer_function_is_the_whole_one(plate_operators, restricted, s):
    """G(s), dG/ds and the fluid response from half the unknowns equal the whole space's to
    round-off; the drag row of an antisymmetric response vanishes."""
    whole, half = transfer_sample(plate_operators, s), transfer_sample(restricted, s)
    assert np.abs(half.value - whole.value).max() < 1e-12 * np.abs(whole.value).max()
    assert np.abs(half.rate - whole.rate).max() < 1e-12 * np.abs(whole.rate).max()
    response = restricted.basis @ half.response
    assert np.abs(response - whole.response).max() < 1e-11 * np.abs(whole.response).max()
    assert np.abs(whole.value[0]).max() < 1e-12 * np.abs(whole.value).max()


def test_the_heaving_cylinder_is_restricted_too(cylinder_coarse_40):
    fluid = fluid_operators(cylinder_coarse_40)
    half = symmetry.antisymmetric_operators(fluid)
    assert half.basis is not None
    for s in (0.05j, 0.74j):
        a, b = transfer_sample(fluid, s), transfer_sample(half, s)
        assert np.abs(a.value - b.value).max() < 1e-12 * np.abs(a.value).max()


def test_incidence_and_a_broken_symmetry_keep_the_whole_space(plate_2900_alpha5, plate_operators):
    """At α0 = 5° the flow is not symmetric; a steady state with an antisymmetric part above the
    tolerance (here added by hand) is not restricted either."""
    at_incidence = fluid_operators(plate_2900_alpha5)
    assert symmetry.antisymmetric_operators(at_incidence) is at_incidence
    state = plate_operators.steady.state.vec.FV().NumPy()
    saved = state.copy()
    try:
        state += 1e-6 * np.abs(state).max() * np.sin(np.arange(len(state)))
        assert symmetry.antisymmetric_operators(plate_operators) is plate_operators
    finally:
        state[:] = saved
    assert symmetry.antisymmetric_operators(plate_operators).basis is not None


def test_thresholds_and_modes_from_the_restricted_operators_are_the_whole_ones(plate_operators, monkeypatch):
    """The same sweep with and without the restriction: the same thresholds (to Newton's tolerance),
    factorisation count and critical modes on the whole space's unknowns: flutter and divergence
    (its mode from G(0)) at m = 1000."""
    solid = Solid(mass_ratio=1000.0, reduced_velocity=2.0)

    def sweep():
        counter = FactorCounter()
        result = sweep_thresholds(plate_operators, solid, (2.0, 10.0), counter=counter)
        return result.thresholds, counter.count

    half, half_count = sweep()
    monkeypatch.setattr(frequency_sweep, "antisymmetric_operators", lambda fluid: fluid)
    whole, whole_count = sweep()
    assert [t.kind for t in half] == [t.kind for t in whole] == ["flutter", "divergence"]
    assert half_count == whole_count
    for a, b in zip(half, whole, strict=True):
        assert (a.kind, a.boundary) == (b.kind, b.boundary)
        assert abs(a.reduced_velocity / b.reduced_velocity - 1) < 1e-9
        assert abs(a.frequency - b.frequency) < 1e-9 * max(b.frequency, 1)
        assert len(a.mode) == len(b.mode) == 4 + plate_operators.n_fluid
        phase = np.vdot(a.mode, b.mode)
        phase /= abs(phase)
        assert np.abs(a.mode * phase - b.mode).max() < 1e-6 * np.abs(b.mode).max()
