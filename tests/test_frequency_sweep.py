"""Thresholds from the exact transfer function swept in frequency (fsistab.frequency_sweep) against
independent references: the branch tracking's thresholds, finite differences of the roots, the
coupled eigenvalue problem."""

from dataclasses import replace

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from fsistab.coupled import CoupledSystem
from fsistab.critical import find_thresholds
from fsistab.eigen import eigenpairs_near
from fsistab.errors import InputError
from fsistab.frequency_sweep import sweep_thresholds, velocity_roots
from fsistab.linalg import FactorCounter
from fsistab.params import Solid
from fsistab.transfer import transfer_sample
from fsistab.transfer_map import AxisSample, characteristic_function, second_order_loads


def test_roots_zero_the_characteristic_determinant(plate_operators):
    """Each root u of the sweep's polynomial (built from the scaled coefficients P_k(v)) zeroes the
    determinant det(m W(iω, u) − A(iω)) evaluated directly from the solid weights and the loads
    (fsistab.transfer_map.characteristic_function), to round-off relative to its terms."""
    solid = Solid(mass_ratio=50.0, reduced_velocity=3.0)
    omega = 0.3
    theta0, loads0 = plate_operators.theta0, plate_operators.loads0
    sample = transfer_sample(plate_operators, 1j * omega)
    roots = velocity_roots(sample, solid, theta0, loads0)
    assert len(roots.roots) == 2 and np.all(roots.roots.real > 0)
    loads, rate = second_order_loads(AxisSample(omega, sample.value, sample.rate), theta0, loads0)
    for u in roots.roots:
        value, d_mass, _, _ = characteristic_function(loads, rate, solid, 1j * omega, solid.mass_ratio, u)
        assert abs(value) < 1e-10 * abs(d_mass) * solid.mass_ratio  # |F| against the size of m²·det W


def test_root_slopes_match_finite_differences(plate_operators):
    """du/dω of each root (implicit differentiation with dG/ds) against a centred difference of
    the roots at ω ± h (two more factorisations)."""
    solid = Solid(mass_ratio=50.0, reduced_velocity=3.0)
    theta0, loads0 = plate_operators.theta0, plate_operators.loads0
    omega, h = 0.3, 1e-5
    at = velocity_roots(transfer_sample(plate_operators, 1j * omega), solid, theta0, loads0)
    plus = velocity_roots(transfer_sample(plate_operators, 1j * (omega + h)), solid, theta0, loads0)
    minus = velocity_roots(transfer_sample(plate_operators, 1j * (omega - h)), solid, theta0, loads0)
    centred = (plus.roots - minus.roots) / (2 * h)
    assert np.allclose(at.slopes, centred, rtol=1e-6, atol=1e-9 * np.abs(at.roots).max())


def test_sweep_reproduces_the_branch_tracking(plate_operators):
    """Coarse plate, Re 2900, m = 1000: the flutter onset and the divergence of the branch
    tracking (Newton on the augmented sparse system) to 1e-8, with the same kinds and sides, in
    fewer factorisations; each critical mode is an eigenvector of the coupled problem."""
    solid = Solid(mass_ratio=1000.0, reduced_velocity=2.0)
    velocities = np.geomspace(2.0, 10.0, 24)
    tracked, _ = find_thresholds(plate_operators, solid, velocities, method="tracking")
    counter = FactorCounter()
    swept, details = find_thresholds(plate_operators, solid, velocities, counter=counter)
    assert [(t.kind, t.boundary) for t in swept] == [(t.kind, t.boundary) for t in tracked]
    assert [(t.kind, t.boundary) for t in swept] == [("flutter", "onset"), ("divergence", "onset")]
    for a, b in zip(swept, tracked, strict=True):
        assert a.reduced_velocity == pytest.approx(b.reduced_velocity, rel=1e-8)
        assert a.frequency == pytest.approx(b.frequency, rel=1e-8, abs=1e-12)
    assert details["unresolved"] == ()
    # one factorisation per sample, at most three Newton iterates for the flutter point, G(0)
    assert len(details["frequencies"]) + 2 <= counter.count <= len(details["frequencies"]) + 4
    for t in swept:
        system = CoupledSystem(plate_operators, replace(solid, reduced_velocity=t.reduced_velocity))
        q = t.point.mode
        residual = system.jacobian @ q + 1j * t.frequency * (system.mass @ q)
        scale = spla.norm(system.jacobian, 1) * np.linalg.norm(q)  # ‖J‖₁‖q‖: ‖Jq‖ vanishes at ω = 0
        assert np.linalg.norm(residual) < 1e-10 * scale
    assert swept[0].branch == "heave"  # REFERENCE.md §E: the heave branch goes unstable


def test_sweep_finds_a_narrow_window_and_the_eigenvalues_confirm_it(plate_operators):
    """Coarse plate, m = 10: a window of instability 3.38 < U* < 3.57 (a heave mode mixed with the
    coarse far field's weakly damped modes, docs/discretisation.md) that the branch tracking
    misses. The coupled eigenvalues inside and outside it confirm the sides."""
    solid = Solid(mass_ratio=10.0, reduced_velocity=2.0)
    result = sweep_thresholds(plate_operators, solid, (2.0, 10.0))
    window = [t for t in result.thresholds if 3.0 < t.reduced_velocity < 4.0]
    assert [t.boundary for t in window] == ["onset", "restabilisation"]
    inside = 0.5 * (window[0].reduced_velocity + window[1].reduced_velocity)
    below = window[0].reduced_velocity - 0.1
    for velocity, unstable in ((inside, True), (below, False)):
        system = CoupledSystem(plate_operators, replace(solid, reduced_velocity=velocity))
        pairs = eigenpairs_near(system, [1j * window[0].frequency], 8)
        assert any(p.growth_rate > 0 for p in pairs) == unstable


def test_bad_range_refused_before_any_factorisation(plate_operators):
    counter = FactorCounter()
    with pytest.raises(InputError, match="velocity range"):
        sweep_thresholds(plate_operators, Solid(), (5.0, 2.0), counter=counter)
    with pytest.raises(InputError, match="method"):
        find_thresholds(plate_operators, Solid(), np.array([2.0, 3.0]), method="guess", counter=counter)
    assert counter.count == 0


def test_samples_in_threads_equal_the_sequential_ones(plate_operators):
    """Two factorisations at once in threads (UMFPACK without the GIL) give the same G, dG/ds and
    response as one at a time, and each is counted once."""
    from fsistab.transfer import transfer_samples

    shifts = [0.3j, 0.5j, 0.7j]
    counter = FactorCounter()
    threaded = transfer_samples(plate_operators, shifts, counter, threads=2)
    assert counter.count == 3
    for s, sample in zip(shifts, threaded, strict=True):
        alone = transfer_sample(plate_operators, s)
        assert sample.s == s
        for a, b in (
            (sample.value, alone.value),
            (sample.rate, alone.rate),
            (sample.response, alone.response),
        ):
            assert np.linalg.norm(a - b) <= 1e-12 * np.linalg.norm(b)
    with pytest.raises(InputError, match="threads"):
        transfer_samples(plate_operators, shifts, threads=0)
