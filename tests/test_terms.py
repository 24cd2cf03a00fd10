"""The terms of the linearised fluid equations (fsistab.operators.TERMS): a term added to the list
reaches every operator from its one definition — ``J_ff``, the solid columns, the shifted matrix —
consistently with the nonlinear residual that contains it (docs/model.md §5, §7)."""

import numpy as np
import pytest
import scipy.sparse as sp
from jacobian_checks import difference_matches_finite_differences

from fsistab.coupled import CoupledResidual, CoupledSystem
from fsistab.operators import (
    TERMS,
    FluidResidual,
    Term,
    fluid_operators,
    shifted_fluid_matrix,
)
from fsistab.params import Solid


class Relaxation(Term):
    """``c (U − (1 + θ − θ0) U⁰)``: a uniform relaxation towards the steady field scaled with the pitch
    (a test term only, zero at the steady state), so that it has a part in ``J_ff``, ``c u``, one on
    the ``θ`` column, ``-c U⁰``, and sources in the residual."""

    strength = 0.3

    def residual(self, fields, motion, trial, test):
        from ngsolve import InnerProduct

        return self.strength * InnerProduct(trial[0], test[0])

    def sources(self, fields, v):
        from ngsolve import InnerProduct

        target = self.strength * InnerProduct(fields.velocity, v)
        return [(lambda q_solid: 1.0, target), (lambda q_solid: q_solid[1] - fields.theta0, target)]

    def stiffness(self, fields, trial, test):
        return self.residual(fields, None, trial, test)

    def solid_column(self, fields, state, v):
        from ngsolve import InnerProduct

        return -self.strength * InnerProduct(fields.velocity, v) if state == "theta" else None


EXTENDED = (*TERMS, Relaxation())


@pytest.fixture(scope="module")
def damped(plate_2900_alpha5):
    """Plate at Re 2900, α0 = 5 (coarse): the systems with the standard terms and with the damping."""
    solid = Solid(mass_ratio=3.0, reduced_velocity=2.0)
    plain = CoupledSystem(fluid_operators(plate_2900_alpha5), solid)
    return plain, CoupledSystem(fluid_operators(plate_2900_alpha5, EXTENDED), solid)


def test_an_added_term_matches_finite_differences_of_its_residual(damped):
    """``J`` with the added term minus ``J`` without it against central differences of the residuals
    with and without ``c (U − (1 + θ − θ0) U⁰)``, along solid, fluid and mixed directions."""
    plain, extended = damped
    steady = plain.fluid.steady
    residuals = CoupledResidual(plain), CoupledResidual(extended, FluidResidual(steady, EXTENDED))
    difference = difference_matches_finite_differences(plain, extended, residuals, seed=5)
    theta = np.zeros(plain.size)
    theta[1] = 1.0
    assert np.linalg.norm(difference @ theta) > 0  # the θ column holds the term's solid part


def test_the_shifted_matrix_holds_an_added_term(damped):
    """``shifted_fluid_matrix`` with the extended terms is ``J_ff + s M_f`` of the extended operators
    on the fluid unknowns, and differs from the standard one by the term's ``J_ff`` part."""
    plain, extended = damped
    shift = 0.2 + 0.7j
    index = extended.fluid.free_dofs

    def block(terms):
        form, _ = shifted_fluid_matrix(extended.fluid, shift, terms)
        values, columns, starts = form.mat.CSR()
        n = len(starts) - 1
        matrix = sp.csr_matrix((np.array(values), np.array(columns), np.array(starts)), shape=(n, n))
        return matrix[index][:, index]

    expected = extended.fluid.jff + shift * extended.fluid.mff
    assert abs(block(EXTENDED) - expected).max() < 1e-12 * abs(expected).max()
    added = extended.fluid.jff - plain.fluid.jff
    assert abs(added).max() > 0.1 * Relaxation.strength * abs(extended.fluid.mff).max()
    assert abs(block(TERMS) - block(EXTENDED) + added).max() < 1e-12 * abs(expected).max()
