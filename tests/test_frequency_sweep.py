"""Thresholds from the exact transfer function swept in frequency (fsistab.frequency_sweep) against
independent references: the branch tracking's thresholds, finite differences of the roots, the
coupled eigenvalue problem."""

import math
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
from fsistab.neutral_map import VIV_FOLLOWING
from fsistab.params import Solid
from fsistab.transfer import transfer_flutter_point, transfer_sample
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


def _following_by_differences(fluid, solid: Solid, threshold, step: float = 0.01) -> float:
    """The local frequency following ``|Δ log ω / Δ log U*|`` of the neutral curve through
    ``threshold`` from two more of its points, at ``m e^(±step)`` (Newton on ``det T`` from the
    threshold, about six factorisations): a centred difference along the curve, independent of the
    exact tangent that labelled the threshold."""
    points = [
        transfer_flutter_point(
            fluid,
            replace(
                solid, mass_ratio=solid.mass_ratio * math.exp(s), reduced_velocity=threshold.reduced_velocity
            ),
            threshold.frequency,
            refine=False,
        )[0]
        for s in (-step, step)
    ]
    d_log_frequency = math.log(points[1].frequency / points[0].frequency)
    d_log_velocity = math.log(points[1].reduced_velocity / points[0].reduced_velocity)
    return abs(d_log_frequency / d_log_velocity)


def test_sweep_reproduces_the_branch_tracking(plate_operators):
    """Coarse plate, Re 2900, m = 1000: the flutter onset and the divergence of the branch
    tracking (Newton on the augmented sparse system) to 1e-8, with the same kinds and sides, in
    fewer factorisations; each critical mode is an eigenvector of the coupled problem. The onset is
    flutter by its frequency following: its frequency follows the solid's (``ω_c U*_c`` = 0.82
    near the heave frequency Ω = 0.8 in vacuo), the following from the tangent matches a centred
    difference along the neutral curve, near 1."""
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
        q = t.mode
        residual = system.jacobian @ q + 1j * t.frequency * (system.mass @ q)
        scale = spla.norm(system.jacobian, 1) * np.linalg.norm(q)  # ‖J‖₁‖q‖: ‖Jq‖ vanishes at ω = 0
        assert np.linalg.norm(residual) < 1e-10 * scale
    assert swept[0].branch == "heave"  # Moulin & Marquet 2021: the heave branch goes unstable
    onset = swept[0]
    assert onset.frequency * onset.reduced_velocity == pytest.approx(solid.freq_ratio, rel=0.1)
    following = _following_by_differences(plate_operators, solid, onset)
    assert onset.frequency_following == pytest.approx(following, rel=1e-2)
    assert VIV_FOLLOWING < following < 1.2
    assert math.isnan(swept[1].frequency_following)  # divergence: no frequency to follow


def test_viv_thresholds_are_labelled_without_a_wake_shift(plate_operators):
    """Coarse plate, Re 2900, m = 10, U* from 0.04 to 0.12, where the solid's frequencies meet the
    fixed plate's wake mode: with no wake hint, both thresholds (a lock-in onset and its
    restabilisation) are VIV. Their frequencies lie within 5 % of the wake mode's (an eigenvalue of
    the fixed plate, solved here) and nearer it than both in-vacuo frequencies Ω/U*, 1/U*; the
    frequency following that labelled them is far below 1/2 and matches, on the restabilisation,
    a centred difference along its neutral curve."""
    from fsistab.critical import wake_mode_near

    solid = Solid(mass_ratio=10.0, reduced_velocity=0.04)
    found, details = find_thresholds(plate_operators, solid, np.array([0.04, 0.12]))
    assert details["wake_frequency"] is None and details["unresolved"] == ()
    assert [(t.kind, t.boundary) for t in found] == [("viv", "onset"), ("viv", "restabilisation")]
    wake = wake_mode_near(plate_operators, 11.0).frequency
    assert wake == pytest.approx(10.807, rel=1e-3)  # docs/how-to/sensitivity.md, coarse
    for t in found:
        in_vacuo = (solid.freq_ratio / t.reduced_velocity, 1.0 / t.reduced_velocity)
        assert abs(t.frequency / wake - 1) < 0.05
        assert abs(t.frequency - wake) < min(abs(t.frequency - w) for w in in_vacuo)
        assert t.frequency_following < 0.1 * VIV_FOLLOWING
    restabilisation = found[1]
    following = _following_by_differences(plate_operators, solid, restabilisation)
    assert restabilisation.frequency_following == pytest.approx(following, rel=1e-2)


def test_sweep_finds_a_narrow_window_and_the_eigenvalues_confirm_it(plate_operators):
    """Coarse plate, m = 10: a window of instability 3.38 < U* < 3.57 (a heave mode mixed with the
    coarse far field's weakly damped modes, docs/discretisation.md) that the branch tracking
    misses. The coupled eigenvalues inside and outside it confirm the sides."""
    solid = Solid(mass_ratio=10.0, reduced_velocity=2.0)
    result = sweep_thresholds(plate_operators, solid, (2.0, 10.0))
    window = [t for t in result.thresholds if 3.0 < t.reduced_velocity < 4.0]
    assert [t.boundary for t in window] == ["onset", "restabilisation"]
    assert [t.kind for t in window] == ["flutter", "flutter"]  # its frequency follows 1/U*
    inside = 0.5 * (window[0].reduced_velocity + window[1].reduced_velocity)
    below = window[0].reduced_velocity - 0.1
    for velocity, unstable in ((inside, True), (below, False)):
        system = CoupledSystem(plate_operators, replace(solid, reduced_velocity=velocity))
        pairs = eigenpairs_near(system, [1j * window[0].frequency], 8)
        assert any(p.growth_rate > 0 for p in pairs) == unstable


def test_crossings_the_cubics_miss_near_the_wake_resonance_are_found(plate_operators):
    """Coarse plate, m = 1000, U* from 0.03 to 0.12, across the fixed plate's wake resonance
    (ω ≈ 10.8, damping 0.07). Two crossings there are missed by the cubics: Newton from one's
    estimate does not converge (it is found from the exact samples that cut its interval), and a
    narrow stable gap inside the lock-in window is not bracketed at all (the exact signs of
    ``Im u`` at the samples around it disagree with the parity of the crossings converged between
    them, and the audit finds both of its edges). The four VIV crossings, none unresolved; the
    coupled eigenvalues in the gap and on each side of it confirm the sides."""
    solid = Solid(mass_ratio=1000.0, reduced_velocity=0.03)
    result = sweep_thresholds(plate_operators, solid, (0.03, 0.12))
    assert result.unresolved == ()
    onset, restabilisation = ("viv", "onset"), ("viv", "restabilisation")
    assert [(t.kind, t.boundary) for t in result.thresholds] == [onset, restabilisation] * 2
    v = [t.reduced_velocity for t in result.thresholds]
    for velocity, unstable in (
        (0.5 * (v[0] + v[1]), True),
        (0.5 * (v[1] + v[2]), False),
        (0.5 * (v[2] + v[3]), True),
    ):
        system = CoupledSystem(plate_operators, replace(solid, reduced_velocity=velocity))
        pairs = eigenpairs_near(system, [1j * result.thresholds[2].frequency], 8)
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


def test_samples_are_yielded_as_they_finish_and_an_interruption_drops_the_rest(monkeypatch):
    """``iter_transfer_samples`` gives every shift once, counted as it is yielded; closed after
    the first sample (an interrupted map), the shifts not yet started are not computed."""
    import threading
    import time

    from fsistab import transfer

    started, lock = [], threading.Lock()

    def fake(fluid, s, refine=True):
        with lock:
            started.append(s)
        time.sleep(0.05 if s != 0.1j else 0.2)  # the first shift finishes last
        return transfer.TransferSample(s, np.zeros((3, 4)), np.zeros((3, 4)), np.zeros((1, 4)))

    monkeypatch.setattr(transfer, "transfer_sample", fake)
    monkeypatch.setattr(transfer.umfpack, "available", lambda: False)  # no symbolic analysis
    shifts = [0.1j * k for k in range(1, 9)]
    counter = FactorCounter()
    order = [x.s for x in transfer.iter_transfer_samples(None, shifts, counter, threads=2)]
    assert sorted(order, key=abs) == shifts and order[0] != shifts[0] and counter.count == 8
    assert [x.s for x in transfer.transfer_samples(None, shifts, threads=2)] == shifts

    started.clear()
    counter = FactorCounter()
    samples = transfer.iter_transfer_samples(None, shifts, counter, threads=2)
    next(samples)
    samples.close()
    assert counter.count == 1 and len(started) <= 3


def _synthetic_sample(frequency: float, loads: np.ndarray, slope: np.ndarray):
    from fsistab.frequency_sweep import SweepSample

    return SweepSample(frequency, np.array([]), np.array([]), loads, slope)


@pytest.mark.parametrize("points", [2, 3])
def test_loads_interpolant_reproduces_polynomials_of_its_degree(points):
    """The Hermite interpolant through values and ω-derivatives at 2 (3) samples is a cubic
    (quintic): it reproduces any complex matrix polynomial of that degree exactly, also away from
    the samples (checked against the polynomial evaluated directly)."""
    from fsistab.frequency_sweep import _loads_interpolant

    rng = np.random.default_rng(points)
    degree = 2 * points - 1
    coefficients = rng.normal(size=(degree + 1, 2, 2)) + 1j * rng.normal(size=(degree + 1, 2, 2))
    value = lambda w: sum(c * w**k for k, c in enumerate(coefficients))  # noqa: E731
    slope = lambda w: sum(k * c * w ** (k - 1) for k, c in enumerate(coefficients) if k)  # noqa: E731
    frequencies = [0.3, 0.45, 0.7][:points]
    samples = [_synthetic_sample(w, value(w), slope(w)) for w in frequencies]
    h = 0.15
    coef = _loads_interpolant(samples, 0.3, h)
    for w in (0.31, 0.4, 0.6, 0.8):
        interpolated = np.polynomial.polynomial.polyval((w - 0.3) / h, coef).reshape(2, 2)
        assert np.allclose(interpolated, value(w), rtol=1e-10, atol=1e-10 * np.abs(value(w)).max())


@pytest.mark.parametrize(
    ("values", "margin", "certain"),
    [
        ([0.3, 0.1, -0.1, -0.3], [0.0, 0.05, 0.05, 0.0], True),  # clear of the margin: one crossing
        ([0.3, 0.01, -0.02, -0.3], [0.0, 0.05, 0.05, 0.0], True),  # enters and leaves on opposite sides
        ([0.3, 0.01, 0.02, 0.3], [0.0, 0.05, 0.05, 0.0], False),  # a tangency within the error
        ([0.3, 0.2, 0.1, 0.3], [0.0, 0.05, 0.05, 0.0], True),  # a dip that stays clear of zero
        ([0.0, 0.2, 0.3], [0.0, 0.0, 0.0], False),  # exactly zero at an end: undecided
    ],
)
def test_crossings_certain_only_for_transversal_crossings(values, margin, certain):
    from fsistab.frequency_sweep import _crossings_certain

    assert _crossings_certain(np.array(values), np.array(margin)) == certain


def test_interpolated_roots_within_their_error_estimate(plate_operators):
    """Coarse plate, m = 1000: the roots followed on the cubic between exact samples at ω = 0.30
    and 0.35 differ at the midpoint from those of an exact sample there (one more factorisation)
    by less than ERROR_SAFETY times the cubic-against-quintics estimate, which is not zero."""
    from fsistab.frequency_sweep import ERROR_SAFETY, _loads_interpolant, _path_error, _paths

    solid = Solid(mass_ratio=1000.0, reduced_velocity=3.0)
    theta0, loads0 = plate_operators.theta0, plate_operators.loads0
    samples = [
        velocity_roots(transfer_sample(plate_operators, 1j * w, refine=False), solid, theta0, loads0)
        for w in (0.25, 0.30, 0.35, 0.40, 0.325)
    ]
    outer, left, right, outer_right, middle = samples
    h = right.frequency - left.frequency
    taus, roots = _paths(_loads_interpolant([left, right], left.frequency, h), left.frequency, h, solid)
    error = _path_error(taus, roots, left, right, [outer, outer_right], solid)
    k = int(np.argmin(np.abs(taus - 0.5)))
    assert taus[k] == pytest.approx(0.5)
    exact = middle.roots
    for u, e in zip(roots[k], error[k], strict=True):
        if u.real > 0:
            actual = np.min(np.abs(exact - u))
            assert 0 < e and actual <= ERROR_SAFETY * e
    assert np.allclose(np.sort_complex(roots[0][roots[0].real > 0]), np.sort_complex(left.roots), rtol=1e-9)
    assert np.allclose(
        np.sort_complex(roots[-1][roots[-1].real > 0]), np.sort_complex(right.roots), rtol=1e-9
    )


def test_real_and_complex_factorisations_share_one_ordering(plate_operators):
    """J_ff (real) and J_ff + iω M_f (complex) have one pattern: the second symbolic analysis
    reuses the first's nested-dissection ordering, and solves with it are exact to round-off."""
    from fsistab.linalg import FluidFactor

    fluid = replace(plate_operators, analyses={})
    rng = np.random.default_rng(0)
    b = rng.normal(size=fluid.n_fluid)
    for shift in (0.4j, 0.0):
        factor = FluidFactor(fluid, shift)
        x = factor.solve(b)
        matrix = fluid.jff + shift * fluid.mff
        assert np.linalg.norm(matrix @ x - b) <= 1e-10 * np.linalg.norm(b)
    assert fluid.analyses[float].ordering is fluid.analyses[complex].ordering


def test_a_crossing_newton_cannot_converge_is_reported_not_fatal(plate_operators, monkeypatch):
    """Coarse plate, m = 1000, with Newton on det T made to fail: the sweep still returns the
    divergence, and reports the flutter crossing's interval as unresolved instead of raising."""
    import fsistab.frequency_sweep as sweep
    from fsistab.errors import ConvergenceError

    def fails(*args, **kwargs):
        raise ConvergenceError("Newton on det T(iω; U*) did not converge (test)")

    monkeypatch.setattr(sweep, "transfer_flutter_point", fails)
    messages = []
    result = sweep_thresholds(
        plate_operators, Solid(mass_ratio=1000.0, reduced_velocity=2.0), (2.0, 10.0), progress=messages.append
    )
    assert [t.kind for t in result.thresholds] == ["divergence"]
    assert len(result.unresolved) == 1
    low, high = result.unresolved[0]
    assert low < 0.1876 < high  # the flutter frequency (the branch tracking's, REFERENCE §E's coarse value)
    assert any("unresolved" in m and "did not converge" in m for m in messages)


@pytest.mark.parametrize(
    ("zeros", "points_found", "mismatch"),
    [
        ((1.5,), 0, True),  # Im u changes sign once: a crossing is missing
        ((1.5,), 1, False),
        ((1.5,), 2, True),  # two points on the root where the signs say one (or three)
        ((1.2, 1.8), 0, False),  # the same sign at both ends: none, or two
        ((1.2, 1.8), 1, True),
        ((1.2, 1.8), 2, False),
    ],
)
def test_parity_audit_compares_the_crossings_found_with_the_exact_signs(zeros, points_found, mismatch):
    """Heave alone, no damping: ``u = (ω/Ω) √(1 + A_hh/(m ω²))``, so ``Im u`` has the sign of
    ``Im A_hh``, here ``i Π(ω − ω_k)`` with zeros between the samples at ω = 1 and 2. The audit
    flags the interval when the number of neutral points found on that root does not have the
    parity of the change of sign of ``Im u`` at the two samples (the root ``−u``, outside the range,
    is not checked)."""
    from fsistab.frequency_sweep import _parity_mismatch
    from fsistab.neutral_point import NeutralPoint

    solid = Solid(mass_ratio=10.0, reduced_velocity=1.0, dofs=("heave",), freq_ratio=1.0)
    polynomial = np.polynomial.Polynomial.fromroots(zeros) * 1j

    def sample(w: float):
        loads, slope = np.zeros((2, 2), complex), np.zeros((2, 2), complex)
        loads[0, 0], slope[0, 0] = polynomial(w), polynomial.deriv()(w)
        return _synthetic_sample(w, loads, slope)

    def velocity(w: float) -> float:  # U* where Im u = 0: A_hh = 0 there
        return 1.0 / (w / solid.freq_ratio)

    found = [NeutralPoint(10.0, velocity(w), w) for w in (1.5, 1.25)[:points_found]]
    band = (1.0 / 1.2, 1.0 / 0.4)  # U* from 0.4 to 1.2
    assert _parity_mismatch(sample(1.0), sample(2.0), found, solid, band) == mismatch
