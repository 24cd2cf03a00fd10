"""A finite-difference check shared by the tests of operator terms (the sponge, an added term)."""

import numpy as np


def difference_matches_finite_differences(plain, other, residuals, seed):
    """``other.jacobian − plain.jacobian`` against central differences of ``residuals[1]`` minus
    ``residuals[0]`` (the nonlinear residuals of ``other`` and ``plain``) along random solid, fluid
    and mixed directions from the steady state, which both must keep an equilibrium; the difference
    is returned."""
    q0 = residuals[1].point()
    assert np.abs(residuals[1](q0)).max() < 1e-10  # the steady state stays an equilibrium
    difference = (other.jacobian - plain.jacobian).tocsr()
    rng = np.random.default_rng(seed)
    ns = plain.n_solid
    eps = 1e-5
    for part in (slice(0, ns), slice(ns, None), slice(None)):  # solid, fluid, both
        direction = np.zeros(plain.size)
        direction[part] = rng.standard_normal(direction[part].shape)
        direction /= np.linalg.norm(direction)
        plus, minus = q0 + eps * direction, q0 - eps * direction
        fd = (residuals[1](plus) - residuals[0](plus) - residuals[1](minus) + residuals[0](minus)) / (2 * eps)
        exact = difference @ direction
        assert np.linalg.norm(exact) > 1e-3 * np.linalg.norm(plain.jacobian @ direction)
        assert np.linalg.norm(fd - exact) < 1e-6 * np.linalg.norm(exact)
    return difference
