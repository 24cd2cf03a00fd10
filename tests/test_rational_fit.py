"""Rational fits of the transfer function (fsistab.rational_fit) against rational functions known
in closed form: poles, values between samples, derivatives, and the certification's refusals."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fsistab.errors import InputError
from fsistab.rational_fit import aaa, certified_transfer
from fsistab.reduced_model import relative_error

# the plate's fluid poles near the wake mode at Re 2900 (docs/transfer.md, default mesh), rounded
WAKE_POLES = (-0.032 + 11.098j, -0.160 + 10.900j, -0.150 + 11.210j, -0.183 + 10.650j, -0.19 + 11.47j)


def _transfer(seed: int, poles=WAKE_POLES):
    """A 3 × 4 G(s) = A₀ + A₁ s + Σ R_k/(s − p_k) with random matrices (the first row 1e-12 times
    smaller, like the drag row at α0 = 0), its derivative, both in closed form."""
    rng = np.random.default_rng(seed)
    shape = (3, 4)
    a0, a1 = (rng.normal(size=shape) + 1j * rng.normal(size=shape) for _ in range(2))
    residues = [rng.normal(size=shape) + 1j * rng.normal(size=shape) for _ in poles]
    row = np.array([1e-12, 1.0, 0.3])[:, None]

    def value(s):
        return row * (a0 + a1 * s + sum(r / (s - p) for r, p in zip(residues, poles, strict=True)))

    def rate(s):
        return row * (a1 - sum(r / (s - p) ** 2 for r, p in zip(residues, poles, strict=True)))

    return value, rate


def _samples(value, rate, frequencies):
    return (
        np.asarray(frequencies),
        np.array([value(1j * w) for w in frequencies]),
        np.array([rate(1j * w) for w in frequencies]),
    )


@pytest.mark.parametrize("seed", range(4))
def test_aaa_recovers_the_poles_values_and_derivatives_of_a_rational_function(seed):
    """40 samples 0.03 apart over ω ∈ [10.4, 11.6]: between them (the midpoints, not fitted) the
    values and derivatives equal the closed form to 1e-8, and the poles inside the band are found
    to 1e-6, also at a support point (where the derivative is a limit)."""
    value, rate = _transfer(seed)
    w = np.linspace(10.4, 11.6, 41)
    model = aaa(1j * w, np.array([value(1j * x) for x in w]))
    middle = 0.5 * (w[1:] + w[:-1])[5:-5]
    got = [model(1j * x, derivative=True) for x in middle]
    assert relative_error(np.array([g for g, _ in got]), np.array([value(1j * x) for x in middle])) < 1e-8
    assert relative_error(np.array([d for _, d in got]), np.array([rate(1j * x) for x in middle])) < 1e-6
    for support in model.support[:3]:
        assert relative_error(model(support, derivative=True)[1], rate(support)) < 1e-6
    poles = model.poles()
    for pole in WAKE_POLES[:3]:
        assert np.abs(poles - pole).min() < 1e-6


def test_a_fit_is_certified_on_its_interval_and_accurate_there():
    value, rate = _transfer(7)
    w = np.linspace(10.6, 11.4, 60)
    fit = certified_transfer(*_samples(value, rate, w), (10.9, 11.2))
    assert fit is not None and fit.covers(11.0) and not fit.covers(11.3)
    assert fit.error < 1e-6
    for omega in (10.9137, 11.05, 11.0983, 11.1999):
        g, dg = fit.transfer(omega)
        assert relative_error(g, value(1j * omega)) < 1e-8
        assert relative_error(dg, rate(1j * omega)) < 1e-6


def test_a_pole_closer_to_the_axis_than_the_sample_spacing_is_refused():
    """A mode damped by 1e-4 at ω = 11.05 between samples 0.014 apart: G between them is not
    known from them, whatever the fit says at the samples."""
    value, rate = _transfer(3, poles=(*WAKE_POLES, -1e-4 + 11.05j))
    w = np.linspace(10.6, 11.4, 58)
    assert certified_transfer(*_samples(value, rate, w), (10.9, 11.2)) is None


def test_too_few_or_too_distant_samples_are_refused():
    value, rate = _transfer(5)
    assert certified_transfer(*_samples(value, rate, np.linspace(10.9, 11.2, 8)), (10.95, 11.1)) is None
    # samples 0.2 apart: the wake pole (damping 0.032) is not resolved; the halves disagree
    assert certified_transfer(*_samples(value, rate, np.linspace(8.0, 14.0, 31)), (10.8, 11.4)) is None
    # the interval must lie inside the samples
    assert certified_transfer(*_samples(value, rate, np.linspace(10.6, 11.4, 40)), (10.5, 11.0)) is None


def test_bad_points_are_refused():
    with pytest.raises(InputError):
        aaa(np.array([1j]), np.ones((1, 2)))
    with pytest.raises(InputError):
        aaa(np.array([1j, 1j, 2j]), np.ones((3, 2)))


@settings(max_examples=25, deadline=None)
@given(
    damping=st.floats(0.02, 0.5),
    frequency=st.floats(10.8, 11.2),
    seed=st.integers(0, 10_000),
)
def test_a_resolved_pole_anywhere_in_the_band_is_fitted_between_the_samples(damping, frequency, seed):
    """Any pole damped by at least about the sample spacing (0.0136): the certified fit, where it
    is given, is right between the samples; and it is given for damping above twice the spacing."""
    value, rate = _transfer(seed, poles=(-damping + 1j * frequency, -0.4 + 10.7j))
    w = np.linspace(10.4, 11.6, 89)
    fit = certified_transfer(*_samples(value, rate, w), (10.7, 11.3))
    if damping > 2 * (w[1] - w[0]):
        assert fit is not None
    if fit is not None:
        middle = 0.5 * (w[1:] + w[:-1])
        middle = middle[(middle > 10.7) & (middle < 11.3)]
        got = np.array([fit.transfer(x)[0] for x in middle])
        assert relative_error(got, np.array([value(1j * x) for x in middle])) < 1e-6


def test_a_support_point_of_zero_weight_is_dropped(monkeypatch):
    """Where the SVD gives a support point a weight of exactly zero (as the exactly affine drag row
    of a symmetric section's G did), that point is no part of the interpolant: the model keeps only
    weighted points, is finite with its derivative at every sample, and has no pole there."""
    svd = np.linalg.svd

    def first_weight_zero(matrix, *args, **kwargs):
        u, s, vh = svd(matrix, *args, **kwargs)
        if vh.shape[1] >= 3:
            vh = vh.copy()
            vh[-1, 0] = 0.0
        return u, s, vh

    monkeypatch.setattr(np.linalg, "svd", first_weight_zero)
    points = 1j * np.linspace(0.5, 1.5, 12)
    cauchy = 1.0 / (points[:, None] - np.array([0.05 + 0.8j, 0.04 + 1.3j])[None, :])
    values = cauchy @ np.array([[1.0, 2.0], [0.5, -1.0]])  # two entries, two poles
    model = aaa(points, values, tolerance=1e-10)
    assert len(model.support) >= 2 and np.all(model.weights != 0)
    for s in points:
        value, rate = model(s, derivative=True)
        assert np.all(np.isfinite(value)) and np.all(np.isfinite(rate))
    assert np.all(np.abs(model.poles()[:, None] - points[None, :]) > 1e-12)
