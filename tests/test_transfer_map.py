"""Neutral curves from the exact transfer function, one frequency at a time (fsistab.transfer_map).

Plate, Re = 2900, α0 = 0, coarse mesh. Every neutral point the polynomial gives is checked by the
full eigen-solver, the tangents by finite differences, completeness against a brute-force scan,
and a small map against the Newton thresholds of the continuation method.
"""

import logging
import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import numpy.polynomial.polynomial as npoly
import pytest
from damage import damage

from fsistab.coupled import CoupledSystem
from fsistab.critical import divergence_point, flutter_point
from fsistab.eigen import eigenpairs_near
from fsistab.errors import CacheError, InputError
from fsistab.linalg import FactorCounter
from fsistab.map_roots import track_rates
from fsistab.map_tracker import _fold_outside, _pair_fold
from fsistab.params import Solid
from fsistab.reduced_model import relative_error
from fsistab.store import ResumableTable
from fsistab.transfer import characteristic_matrix, exact_transfer
from fsistab.transfer_map import (
    RESONANCE_TOLERANCE,
    SAMPLE_FIELDS,
    AxisSample,
    _born_outside,
    _real_resultant,
    _swept,
    characteristic_function,
    neutral_roots,
    read_samples,
    resultant_tracks,
    roots_from_loads,
    sample_record,
    samples_table,
    scaled_polynomials,
    second_order_loads,
    sharp_resonance,
    transfer_neutral_map,
    undamped_resonances,
    unresolved_resonance,
    unstable_counts,
)


@pytest.fixture(scope="module")
def fluid(plate_operators):
    return plate_operators  # the session's operators (conftest), under a short name


def _sample(fluid, omega):
    g, dg = exact_transfer(fluid, 1j * omega if omega else 0.0, derivative=True)
    return AxisSample(omega, g, dg)


@pytest.fixture(scope="module")
def sample_03(fluid):
    return _sample(fluid, 0.3)


@pytest.mark.parametrize("dofs", [("heave", "pitch"), ("heave",), ("pitch",)])
def test_characteristic_function_is_det_t_and_its_derivatives_match_differences(fluid, sample_03, dofs):
    """F = det(m W − A) is det T(s) times m^n r_θ^(2·pitch) (T of fsistab.transfer, docs/model.md §7);
    ∂F/∂m, ∂F/∂u and ∂F/∂s (with dA/ds from dG/ds) against centred differences."""
    solid = Solid(mass_ratio=37.0, reduced_velocity=2.3, zeta_h=0.02, dofs=dofs)
    s, m, u = 0.3j, solid.mass_ratio, 1 / solid.reduced_velocity
    loads, rate = second_order_loads(sample_03, fluid.theta0, fluid.loads0)
    f, f_m, f_u, f_s = characteristic_function(loads, rate, solid, s, m, u)
    scale = m ** len(dofs) * (solid.r_theta**2 if "pitch" in dofs else 1.0)
    det_t = np.linalg.det(characteristic_matrix(sample_03.transfer, solid, s, fluid.theta0, fluid.loads0))
    assert abs(f / scale - det_t) < 1e-12 * abs(det_t)
    h = 1e-6
    value = lambda **k: characteristic_function(loads, rate, solid, s, k.get("m", m), k.get("u", u))[0]  # noqa: E731
    assert abs((value(m=m + h * m) - value(m=m - h * m)) / (2 * h * m) - f_m) < 1e-7 * abs(f_m)
    assert abs((value(u=u + h) - value(u=u - h)) / (2 * h) - f_u) < 1e-7 * abs(f_u)
    d = 1e-5  # through the fluid: A(s) at s ± i d
    plus, minus = (
        second_order_loads(_sample(fluid, 0.3 + e), fluid.theta0, fluid.loads0)[0] for e in (d, -d)
    )
    f_plus = characteristic_function(plus, rate, solid, s + 1j * d, m, u)[0]
    f_minus = characteristic_function(minus, rate, solid, s - 1j * d, m, u)[0]
    assert abs((f_plus - f_minus) / (2j * d) - f_s) < 1e-6 * abs(f_s)


def test_static_unbalance_in_the_characteristic_function(fluid, sample_03):
    """With a static unbalance (docs/model.md §3.1) ``W`` has the off-diagonal ``x_θ s²``: F is still
    det T times ``m² r_θ²`` (T from the first-order solid mass), its ``s`` derivative still matches
    differences, the scaled polynomials sum to F, and with both dofs undamped the coupled in-vacuo
    resonances are the roots ``undamped_resonances`` divides out (where ``P₂`` vanishes)."""
    solid = Solid(mass_ratio=37.0, reduced_velocity=2.3, zeta_h=0.02, static_unbalance=0.1)
    s, m, u = 0.3j, solid.mass_ratio, 1 / solid.reduced_velocity
    loads, rate = second_order_loads(sample_03, fluid.theta0, fluid.loads0)
    f, _, _, f_s = characteristic_function(loads, rate, solid, s, m, u)
    det_t = np.linalg.det(characteristic_matrix(sample_03.transfer, solid, s, fluid.theta0, fluid.loads0))
    assert abs(f / (m * m * solid.r_theta**2) - det_t) < 1e-12 * abs(det_t)
    balanced = characteristic_function(loads, rate, replace(solid, static_unbalance=0.0), s, m, u)[0]
    assert abs(f - balanced) > 1e-3 * abs(f)
    scaled = sum(
        npoly.polyval(u / 0.3, p) * (m * 0.09) ** k for k, p in enumerate(scaled_polynomials(loads, solid))
    )
    assert abs(scaled - f) < 1e-12 * abs(f)
    d = 1e-5
    plus, minus = (
        second_order_loads(_sample(fluid, 0.3 + e), fluid.theta0, fluid.loads0)[0] for e in (d, -d)
    )
    difference = (
        characteristic_function(plus, rate, solid, s + 1j * d, m, u)[0]
        - characteristic_function(minus, rate, solid, s - 1j * d, m, u)[0]
    ) / (2j * d)
    assert abs(difference - f_s) < 1e-6 * abs(f_s)
    undamped = replace(solid, zeta_h=0.0, zeta_theta=0.0)
    resonances = undamped_resonances(undamped)
    # the in-vacuo frequencies w (units u = 1/U*) of the mass–spring system: det(K − w² M) = 0 with
    # the symmetric mass [[1, x_θ], [x_θ, r_θ²]] and K = diag(Ω², r_θ²); v = 1/w
    x, r2 = undamped.static_unbalance, undamped.r_theta**2
    squares = np.linalg.eigvals(np.linalg.solve([[1.0, x], [x, r2]], np.diag([undamped.freq_ratio**2, r2])))
    assert resonances == pytest.approx(sorted(1 / np.sqrt(squares.real)), rel=1e-10)
    assert min(abs(v - w) for v in resonances for w in (1.0, 1 / undamped.freq_ratio)) > 1e-2
    assert undamped_resonances(solid) == []


def test_every_root_is_a_neutral_eigenvalue_of_the_full_problem(fluid, sample_03):
    """At ω = 0.3 all neutral (m, U*) with 1 ≤ m ≤ 1e4 come from the resultant; the eigen-solver of
    the whole coupled problem finds λ = 0, ω = 0.3 at each, and the crossing rate has the sign of
    the growth-rate change of that eigenvalue between U*(1 ∓ 1e-3)."""
    roots = neutral_roots(sample_03, Solid(), fluid.theta0, fluid.loads0, (1.0, 1e4))
    assert len(roots) >= 1
    for root in roots:
        solid = Solid(mass_ratio=root.mass_ratio, reduced_velocity=root.reduced_velocity)
        pair = min(eigenpairs_near(CoupledSystem(fluid, solid), [0.3j], 3), key=lambda p: abs(p.value - 0.3j))
        assert abs(pair.value - 0.3j) < 1e-8
        rates = []
        for factor in (1 - 1e-3, 1 + 1e-3):
            moved = replace(solid, reduced_velocity=root.reduced_velocity * factor)
            near = eigenpairs_near(CoupledSystem(fluid, moved), [0.3j], 3)
            rates.append(min(near, key=lambda p: abs(p.value - 0.3j)).growth_rate)
        assert np.sign(rates[1] - rates[0]) == np.sign(root.crossing_rate)
        assert (rates[1] - rates[0]) / 2e-3 == pytest.approx(root.crossing_rate, rel=1e-2)


def test_root_tangents_match_roots_at_neighbouring_frequencies(fluid, sample_03):
    d = 1e-5
    roots = neutral_roots(sample_03, Solid(), fluid.theta0, fluid.loads0, (1.0, 1e4))
    sides = [
        neutral_roots(_sample(fluid, 0.3 + e), Solid(), fluid.theta0, fluid.loads0, (0.5, 2e4))
        for e in (d, -d)
    ]
    for root in roots:
        ends = [min(side, key=lambda r: np.abs(r.plane - root.plane).max()) for side in sides]
        difference = (ends[0].plane - ends[1].plane) / (2 * d)
        assert np.allclose(difference, root.tangent, rtol=1e-4, atol=1e-4 * np.abs(root.tangent).max())


def test_track_rates_match_tracks_at_neighbouring_frequencies(fluid):
    """The rates ``(dv/dω, d(1/m)/dω)`` of every resultant track, against central differences of
    the tracks of exact samples at ω ± 1e-5 (tracks of any sign of m)."""
    d, omega = 1e-5, 0.6

    def tracks(w):
        loads, rate = second_order_loads(_sample(fluid, w), fluid.theta0, fluid.loads0)
        return resultant_tracks(loads, w, Solid()), loads, rate

    centre, loads, rate = tracks(omega)
    rates = track_rates(centre, loads, rate, omega, Solid())
    (up, *_), (down, *_) = tracks(omega + d), tracks(omega - d)
    assert len(centre) >= 2 and len(up) == len(down) == len(centre)
    for (v, _), expected in zip(centre, rates, strict=True):
        ends = [side[np.argmin(np.abs(side[:, 0] - v))] for side in (up, down)]
        difference = np.array([ends[0][0] - ends[1][0], 1 / ends[0][1] - 1 / ends[1][1]]) / (2 * d)
        np.testing.assert_allclose(difference, expected, rtol=1e-4, atol=1e-6)


def _cubic_fold(omega_b, a, b, eps_b, c, omega):
    """The pair at ``omega`` of the branch ``ω = ω_b + a (v − 1)² + b (v − 1)³``,
    ``ε = 1/m = ε_b + c (v − 1)``, and their rates ``(dv/dω, dε/dω)``."""
    roots = np.roots([b, a, 0.0, omega_b - omega])
    v = np.sort(1.0 + roots[np.abs(roots.imag) < 1e-12].real)
    v = v[np.argsort(np.abs(v - 1.0))[:2]]  # the two sides of the fold
    slope = 2 * a * (v - 1) + 3 * b * (v - 1) ** 2
    eps = eps_b + c * (v - 1)
    return np.column_stack([v, 1 / eps]), np.column_stack([1 / slope, c / slope])


def test_a_fold_is_placed_by_the_rates_of_its_pair():
    """A branch that is a cubic in v through its fold: the Hermite interpolation of the pair's ends
    reproduces it, so the fold's offset and the range of 1/m between the pair are exact (to the
    201-point evaluation); a pair born (a > 0) or dying (a < 0) both."""
    for a, b in ((2.0, 0.3), (-2.0, 0.3), (5.0, -1.0)):
        pair, rates = _cubic_fold(9.2, a, b, -0.45, 0.8, 9.2 + 0.1 * np.sign(a))
        offset, low, high = _pair_fold(pair, rates)
        assert offset == pytest.approx(-0.1 * np.sign(a), rel=1e-4)
        assert (low, high) == pytest.approx(sorted(1 / pair[:, 1]), abs=1e-12)  # ε linear in v: its ends
    pair, rates = _cubic_fold(9.2, 2.0, 0.0, -0.45, 0.8, 9.3)
    assert _pair_fold(pair, np.abs(rates)) is None  # both slopes of one sign: no fold between
    pair, rates = _cubic_fold(9.2, 2.0, 4.0, -0.45, 0.8, 9.2 + 0.01)
    assert _pair_fold(pair, rates)[0] == pytest.approx(-0.01, rel=1e-4)  # cubic term 14 % of the quadratic
    pair, rates = _cubic_fold(9.2, 2.0, 4.0, -0.45, 0.8, 9.2 + 0.05)
    assert _pair_fold(pair, rates) is None  # 32 %: refused, though the cubic is exact here


def test_a_pair_born_at_a_fold_inside_the_interval_outside_the_band_settles_at_any_step():
    """The plate at Re 2900 (``quick``): between ω = 8.9096 and 9.6915 a pair of tracks is born at
    m < 0 (at ω ≈ 9.18, where samples 0.012 apart show its birth; its two roots at 9.6915 are 19 %
    apart in v, not young). Its rates place the fold inside the interval, so it is settled without
    bisecting; with the interval to 10.4735 the pair's two sides are no longer one resolved fold. A
    fold outside the interval, a branch through m = ∞ or into the band is not settled."""
    band = (0.25, 4e4)
    before, before_rates = np.array([[0.8221, -3.5603]]), np.array([[-0.0457, -0.04338]])
    after = np.array([[0.80657, -3.37409], [0.87697, -1.32049], [1.04472, -4.04942]])
    after_rates = np.array([[-0.00242, -0.00474], [-0.12412, -0.51901], [0.07878, 0.13966]])
    fold = (8.90957, 9.69153, before_rates, after_rates)
    assert _born_outside(before, after, band, fold)
    assert not _born_outside(before, after, band)  # not young: the proximity test alone bisects
    dying = (8.90957, 9.69153, after_rates, before_rates)
    assert not _born_outside(after, before, band, dying)  # the shape of a birth is no death
    later = np.array([[0.62516, -0.52843], [0.8164, -3.32882], [1.13749, -7.97347]])
    later_rates = np.array([[-0.90561, -4.23871], [0.00689, -0.02068], [0.14876, 0.16255]])
    assert not _born_outside(before, later, band, (8.90957, 10.47349, before_rates, later_rates))
    pair, rates = after[1:], after_rates[1:]
    assert _fold_outside(pair, rates, 0.78, True, band)
    assert not _fold_outside(pair, rates, 0.5, True, band)  # the fold 0.44 below: outside 0.8 × 0.5
    assert not _fold_outside(pair, rates, 0.78, False, band)  # a birth is no death
    for eps in ((-0.02, 0.01), (0.5, 2.0), (1e-5, 0.1)):  # through ∞; into the band; across its top
        through = np.column_stack([pair[:, 0], 1 / np.array(eps)])
        assert not _fold_outside(through, np.column_stack([rates[:, 0], [0.0, 0.0]]), 0.78, True, band)


@pytest.mark.parametrize("seed", range(30))
def test_roots_are_complete_against_a_brute_force_scan(seed):
    """Random loads A, frequency and pitch damping (generic: integer-like loads can make the real
    and imaginary parts share whole lines or double roots): following the two complex roots m(u)
    of the quadratic det(m W − A) = 0 along a fine grid of u, their imaginary part changes sign
    (with m in range) as many times as there are roots from the resultant, and each of those
    satisfies F = 0."""
    rng = np.random.default_rng(seed)
    entries, omega, zeta = rng.uniform(-30, 30, 8), rng.uniform(0.05, 5.0), rng.uniform(0, 0.2)
    loads = (np.array(entries[:4]) + 1j * np.array(entries[4:])).reshape(2, 2)
    solid = Solid(zeta_theta=zeta)
    s, mass_range, u_range = 1j * omega, (1e-2, 1e2), (1e-2 * omega, 1e2 * omega)
    roots = [
        r
        for r in roots_from_loads(loads, np.zeros((2, 2)), omega, solid, mass_range)
        if u_range[0] < 1 / r.reduced_velocity < u_range[1]
    ]
    for r in roots:
        f = characteristic_function(loads, np.zeros((2, 2)), solid, s, r.mass_ratio, 1 / r.reduced_velocity)[
            0
        ]
        scale = (
            (r.mass_ratio * omega**2) ** 2
            + r.mass_ratio * omega**2 * np.abs(loads).max()
            + np.abs(loads).max() ** 2
        )
        assert abs(f) < 1e-8 * scale
    u = np.geomspace(*u_range, 20001)
    w_h = s**2 + (0.8 * u) ** 2
    w_t = solid.r_theta**2 * (s**2 + 2 * zeta * u * s + u**2)
    a, b, c = w_h * w_t, -(w_h * loads[1, 1] + w_t * loads[0, 0]), np.linalg.det(loads)
    root = np.sqrt(b * b - 4 * a * c)
    branches = np.stack([(-b + root) / (2 * a), (-b - root) / (2 * a)], axis=1)
    for k in range(1, len(u)):  # follow each root continuously through the branch cut of sqrt
        now, before = branches[k], branches[k - 1]
        if abs(now[0] - before[0]) + abs(now[1] - before[1]) > abs(now[0] - before[1]) + abs(
            now[1] - before[0]
        ):
            branches[k] = now[::-1]
    crossed = np.sign(branches[1:].imag) != np.sign(branches[:-1].imag)
    inside = (branches[1:].real > mass_range[0]) & (branches[1:].real < mass_range[1])
    inside &= np.abs(branches[1:] - branches[:-1]) < 0.1 * np.abs(branches[1:])  # not through ∞ (S_h = 0)
    count = int(np.sum(crossed & inside))
    assert len(roots) == count


def test_map_thresholds_agree_with_newton_and_counts_with_the_eigen_solver(fluid, tmp_path, caplog):
    """A map over m ∈ [300, 3000], ω ∈ [0.05, 0.5]: U*_F(1000) equal to the augmented Newton's
    (continuation method) to 1e-6, U*_D to the static Newton's, the number of unstable modes between
    and beyond them equal to the eigen-solver's; a second run from the saved samples factorises
    nothing, and a damaged samples file is reported and not used. Exact samples only
    (``resonance_blocks=0``: no model at s = 0), one factorisation per frequency."""
    path = tmp_path / "samples.nc"
    counter = FactorCounter()
    settings_ = dict(
        mass_range=(300.0, 3000.0), omega_range=(0.05, 0.5), initial=16, samples_path=path, resonance_blocks=0
    )
    tmap = transfer_neutral_map(fluid, Solid(), counter=counter, **settings_)
    assert counter.count == tmap.factorisations == len(tmap.frequencies)  # ω = 0 included
    start = Solid(mass_ratio=1000, reduced_velocity=4.7)
    pairs = eigenpairs_near(CoupledSystem(fluid, start), [0.003 + 0.17j], 4)
    guess = max((p for p in pairs if p.label != "fluid"), key=lambda p: p.growth_rate)
    flutter = flutter_point(fluid, replace(start, reduced_velocity=4.56), guess.frequency, guess.vector)
    divergence = divergence_point(fluid, Solid(mass_ratio=1000, reduced_velocity=7.2))
    onsets = [(u, kind) for u, rate, kind in tmap.crossings_at(1000.0) if rate > 0]
    assert onsets[0][1] == "flutter"
    assert onsets[0][0] == pytest.approx(flutter.reduced_velocity, rel=1e-6)
    assert onsets[1][1] == "divergence"
    assert onsets[1][0] == pytest.approx(divergence.reduced_velocity, rel=1e-8)
    velocities = [4.0, 5.5, 8.0]
    counts = unstable_counts(tmap, 1000.0, velocities)
    for u, expected in zip(velocities, counts, strict=True):
        pairs = eigenpairs_near(
            CoupledSystem(fluid, Solid(mass_ratio=1000, reduced_velocity=u)),
            [0.02, 0.01 + 0.8j / u, 0.01 + 1j / u],  # near the static and the solid modes
            8,
        )
        unstable = {round(p.value.real, 6) for p in pairs if p.growth_rate > 1e-7 and p.frequency >= 0}
        assert len(unstable) == expected
    again = FactorCounter()
    repeat = transfer_neutral_map(fluid, Solid(), counter=again, **settings_)
    assert again.count == 0 and len(repeat.curves) == len(tmap.curves)
    saved = read_samples(samples_table(path, fluid))  # every sampled frequency, ω = 0 included
    assert list(saved) == tmap.frequencies.tolist() and not any(x.reduced for x in saved.values())
    damage(path, "edited", variable="transfer")
    with caplog.at_level(logging.WARNING, logger="fsistab"):
        assert read_samples(samples_table(path, fluid)) == {}  # reported, moved aside: recomputed
    assert str(path) in caplog.text and "recomputing" in caplog.text


def test_bad_input_is_refused_before_any_factorisation(fluid, tmp_path):
    counter = FactorCounter()
    for kwargs in (
        {"mass_range": (10.0, 1.0)},
        {"mass_range": (0.0, 1.0)},
        {"omega_range": (0.0, 1.0)},
        {"tolerance": 0.0},
        {"min_step": 1.0},
    ):
        with pytest.raises(InputError):
            transfer_neutral_map(fluid, Solid(), counter=counter, **kwargs)
    bad = tmp_path / "samples.nc"  # samples of another flow (a damaged file: test_map_thresholds...)
    other_flow = {"reynolds": 100.0, "alpha0_deg": 0.0, "mesh_key": "x"}
    ResumableTable(bad, other_flow, SAMPLE_FIELDS).append(
        sample_record(AxisSample(0.5, np.ones((3, 4)), np.ones((3, 4))))
    )
    with pytest.raises(CacheError, match="another computation"):
        transfer_neutral_map(fluid, Solid(), samples_path=bad, counter=counter)
    assert counter.count == 0
    with pytest.raises(InputError):
        neutral_roots(AxisSample(0.0, np.zeros((3, 4)), np.zeros((3, 4))), Solid(), 0.0, np.zeros(3), (1, 2))


def test_a_curve_crossing_the_whole_mass_range_between_two_frequencies_is_flagged():
    """Resultant tracks (v, m): a root going from m < 0 to m > 4e4 (through ∞), or from below to
    above the band, or a pair born in between, flags the interval, whether or not the root keeps
    its v (a curve near-vertical in ω moves fast in v as well); staying on one side or being in
    the band at one end (the tangent matching's business) does not."""
    band = (0.25, 4e4)
    assert _swept(np.array([[1.5, -3.0]]), np.array([[1.52, 1e6]]), band)
    assert _swept(np.array([[1.5, 0.01]]), np.array([[1.49, 1e6]]), band)
    assert _swept(np.array([[1.5, -3.0]]), np.array([[0.4, -1.0], [1.5, -2.0], [2.0, 5.0]]), band)
    assert not _swept(np.array([[1.5, -3.0]]), np.array([[1.51, -1e3]]), band)
    assert not _swept(np.array([[1.5, 10.0]]), np.array([[1.51, 1e6]]), band)
    # the one real root at each end changed side, its v doubled: bisected, whichever way it went
    assert _swept(np.array([[1.5, 0.01]]), np.array([[3.0, 1e6]]), band)
    assert not _swept(np.array([[1.5, 0.01]]), np.array([[3.0, 0.02]]), band)


def test_a_root_that_changes_side_with_a_jump_in_v_is_a_sweep():
    """The plate at Re 2900 with a resolved far wake (``medium``, ``far_wake=(0.25, 160, 1.5)``),
    resultant tracks at ω = 11.25139 and 11.26877: a VIV curve crosses the whole mass range within
    ω 11.25–11.26, its root going from v = 1.214, m = −36.8 to v = 2.30, m = 0.913 (through
    m = ∞), while another root moves from v = 1.100 to 1.034, nearer the first's v at both ends
    than the first's own. Matching each root by nearest v pairs both with 1.034 and missed the
    curve; the sides flag it: three roots below 0, then two below 0 and one in the band, which a
    root cannot reach from m < 0 across an edge of the band."""
    band = (0.25, 4e4)
    left = np.array([[0.6215, -1.334], [1.100, -8.89], [1.214, -36.77]])
    right = np.array([[0.6264, -1.311], [1.034, -5.957], [2.300, 0.9132]])
    assert _swept(left, right, band) and _swept(right, left, band)
    # the same tracks with the third root staying negative: nothing crossed the band
    assert not _swept(left, np.array([[0.6264, -1.311], [1.034, -5.957], [2.300, -0.9132]]), band)
    # the default mesh at ω = 0.028614 and 0.028704: a root entering the band across its upper
    # edge (m = 4.002e4 → 3.977e4) is the band's matching's business, not a sweep
    left = np.array([[0.503, -3.014e4], [1.239, 4.002e4], [1.248, 455.4]])
    right = np.array([[0.5038, -2.998e4], [1.239, 3.977e4], [1.248, 452.6]])
    assert not _swept(left, right, band) and not _swept(right, left, band)


def test_at_the_finest_step_a_pole_or_a_birth_outside_the_band_is_not_a_sweep():
    """Two frequencies SWEEP_STEP apart (``settled``): a root that changes sign with |m| beyond the
    band at both (through m = ∞: e.g. the heave curve's m ≈ -2e9 → +4e8 of the coarse plate at
    Re 500, α0 = 10°), or below it at both (through 0), or a pair born on one side outside the band,
    is no sweep; anything that could have crossed the band still is."""
    band = (0.25, 4e4)
    through_infinity = (np.array([[1.25, -2.35e9]]), np.array([[1.25, 3.59e8]]))
    through_zero = (np.array([[1.5, 0.01]]), np.array([[1.5, -0.02]]))
    born_negative = (np.array([[1.5, -3.0]]), np.array([[1.5, -3.1], [1.24, -56.0], [1.241, -62.7]]))
    for left, right in (through_infinity, through_zero, born_negative):
        assert _swept(left, right, band)  # before the finest step: bisected
        assert not _swept(left, right, band, settled=True)
        assert not _swept(right, left, band, settled=True)  # dying, or the other way round
    ambiguous = [
        (np.array([[1.5, -3.0]]), np.array([[1.52, 1e6]])),  # from small |m| to beyond the band
        (np.array([[1.5, -3.0]]), np.array([[1.5, -3.1], [1.24, -56.0], [1.241, 1e6]])),  # straddling
        (np.array([[1.5, -3.0]]), np.array([[0.4, -1.0], [1.5, -2.0], [2.0, 5.0]])),  # one born in band
    ]
    for left, right in ambiguous:
        assert _swept(left, right, band, settled=True)


def test_a_young_pair_born_outside_the_band_on_one_side_settles_at_min_step():
    """A pair of resultant roots born between two frequencies (the plate at Re 2900 near ω = 9.2:
    v 0.9597 and 0.9737, m −2.20 and −2.43, 0.003 after the birth at m ≈ −2.31) is settled at
    ``min_step`` when both its roots lie on one side outside the band and close together in v; a
    pair straddling the band, one with a root in it, one far apart in v (not just born), two pairs,
    or another root that sweeps, is not."""
    band = (0.25, 4e4)
    before = np.array([[0.8148, -3.47]])
    young = np.array([[0.8148, -3.4654], [0.9597, -2.2009], [0.9737, -2.4294]])
    assert _swept(before, young, band)  # a birth: looked for
    assert _born_outside(before, young, band) and _born_outside(young, before, band)  # born, or dying
    beyond = np.array([[0.8148, -3.4654], [0.9597, 5e5], [0.9737, 7e5]])
    assert _born_outside(before, beyond, band)  # beyond the band on one side
    not_settled = [
        np.array([[0.8148, -3.4654], [0.9597, -2.2], [0.9737, 5e5]]),  # straddling (through ∞)
        np.array([[0.8148, -3.4654], [0.9597, -2.2], [0.9737, 3.0]]),  # one in the band
        np.array([[0.8148, -3.4654], [0.9, -2.2], [1.1, -2.4]]),  # 20 % apart in v: not young
        np.array([[0.8148, 5e5], [0.9597, -2.2], [0.9737, -2.4]]),  # the old root crosses through ∞
    ]
    for after in not_settled:
        assert not _born_outside(before, after, band)
    two_pairs = np.array([[0.5, -1.0], [0.51, -1.1], [0.8148, -3.4654], [0.9597, -2.2], [0.9737, -2.4]])
    assert not _born_outside(before, two_pairs, band)


@pytest.mark.parametrize("seed", range(10))
def test_the_undamped_resonance_is_divided_out_of_the_tracks(seed):
    """With ζ_h = 0 the resultant vanishes at v = 1/Ω at every frequency (S_h = 0 there: m = ∞); its
    root carries no curve and, found numerically ~1e-9 off with m of either sign, looked like a
    sweep at every sample. The tracks keep every other real root of the resultant (compared with
    the roots of the undivided resultant) and none at 1/Ω."""
    rng = np.random.default_rng(seed)
    loads = (rng.uniform(-30, 30, 4) + 1j * rng.uniform(-30, 30, 4)).reshape(2, 2)
    omega, solid = rng.uniform(0.05, 5.0), Solid()
    assert undamped_resonances(solid) == [1 / solid.freq_ratio]
    assert undamped_resonances(replace(solid, zeta_h=0.01)) == []
    assert undamped_resonances(replace(solid, zeta_theta=0.0)) == [1 / solid.freq_ratio, 1.0]
    assert undamped_resonances(replace(solid, dofs=("pitch",))) == []
    resultant = _real_resultant(scaled_polynomials(loads, solid))
    v0 = 1 / solid.freq_ratio
    assert abs(np.polynomial.polynomial.polyval(v0, resultant)) < 1e-12 * np.abs(resultant).max()
    roots = np.polynomial.polynomial.polyroots(resultant)
    real = sorted(v.real for v in roots if abs(v.imag) < 1e-6 * abs(v) and v.real > 0 and abs(v - v0) > 1e-6)
    tracks = resultant_tracks(loads, omega, solid)
    assert np.all(np.abs(tracks[:, 0] - v0) > 1e-6)
    np.testing.assert_allclose(sorted(tracks[:, 0]), real, rtol=1e-7)


def test_the_two_branches_of_a_fold_in_frequency_are_joined():
    """A curve log U* = 0.1 log m with ω = 1 + (log m)²: a pair of roots born between the samples
    ω = 0.99 and 1.01 (the resultant gains two real roots). The two branches become one curve
    through the fold, and at m = 1 — between the branches' first roots — its crossing is U* = 1."""
    from fsistab.transfer_map import NeutralRoot, _assemble

    def root(p):
        omega = 1 + p * p
        return NeutralRoot(omega, math.exp(p), math.exp(0.1 * p), 1 / (2 * p), 0.1 / (2 * p), 1.0)

    grid = [0.99, 1.01, 1.02, 1.04]
    roots = {w: [root(s * math.sqrt(w - 1)) for s in (-1, 1)] if w > 1 else [] for w in grid}
    tracks = {w: np.ones((len(roots[w]), 2)) for w in grid}
    (curve,) = _assemble(roots, tracks, (0.5, 2.0))
    assert len(curve.roots) == 6 and len(curve.folds) == 1
    (crossing,) = curve.crossings_at(1.0)
    assert crossing[0] == pytest.approx(1.0, abs=1e-12) and crossing[2] > 0
    separate = _assemble(roots, {w: np.ones((2, 2)) for w in grid}, (0.5, 2.0))
    assert len(separate) == 2 and not separate[0].crossings_at(1.0)  # no birth seen: no join


def test_a_fold_in_frequency_is_placed_by_its_pair_and_drawn_through_it():
    """The curve of the test above, ω = 1 + p² along p = log m (log U* = 0.1 p): from the pair at
    ω = 1.01 or 1.04 and their exact tangents the fold is placed at ω = 1 (the branch is a parabola
    in the chord's parameter, which the Hermite reproduces); tangents of one sign are no fold. The
    curve joined through it carries the parabola's points between the pair, ω included, and the
    map drawn from it has them all, each with the unstable side of its crossing rate. With
    log U* = (log m)² instead, the drawn curve reaches down to the nose's U* = 1 at the fold."""
    from fsistab.map_tracker import _neutral_fold
    from fsistab.transfer_map import FOLD_POINTS, NeutralRoot, _assemble, as_neutral_map

    def root(p):
        omega = 1 + p * p
        return NeutralRoot(omega, math.exp(p), math.exp(0.1 * p), 1 / (2 * p), 0.1 / (2 * p), 1.0)

    for omega in (1.01, 1.04):
        p = math.sqrt(omega - 1)
        assert _neutral_fold(root(-p), root(p)) == pytest.approx(1 - omega, rel=1e-4)
    same_sign = replace(root(0.1), dlog_mass=-5.0, dlog_velocity=-0.5)
    assert _neutral_fold(root(-0.1), same_sign) is None

    grid = [0.99, 1.01, 1.02, 1.04]
    roots = {w: [root(s * math.sqrt(w - 1)) for s in (-1, 1)] if w > 1 else [] for w in grid}
    (curve,) = _assemble(roots, {w: np.ones((len(roots[w]), 2)) for w in grid}, (0.5, 2.0))
    points = np.array(curve.points())
    assert len(points) == len(curve.roots) + FOLD_POINTS
    p = np.log(points[:, 0])
    np.testing.assert_allclose(points[:, 2], 1 + p * p, rtol=1e-12)  # ω along the parabola, fold too
    np.testing.assert_allclose(np.log(points[:, 1]), 0.1 * p, atol=1e-12)
    assert np.all(points[:, 3] > 0)  # the crossing rate keeps its sign through the fold
    nose = min(abs(p))
    assert nose < 0.1 / (FOLD_POINTS + 1) + 1e-12  # a point next to the fold, not only the pair at ±0.1
    tmap = SimpleNamespace(curves=[curve], mass_range=(0.5, 2.0), divergence_lambdas=np.array([]))
    tmap.factorisations, tmap.unresolved = 4, ()
    (drawn,) = as_neutral_map(tmap, Solid()).curves
    assert len(drawn.points) == len(points) and drawn.unstable_sides == (1,) * len(points)

    def nosed(p):  # log U* = p²: the lowest U* (1) at the fold, 0.01 above it at the pair of 1.01
        return replace(root(p), reduced_velocity=math.exp(p * p), dlog_velocity=1.0)

    roots = {w: [nosed(s * math.sqrt(w - 1)) for s in (-1, 1)] if w > 1 else [] for w in grid}
    (curve,) = _assemble(roots, {w: np.ones((len(roots[w]), 2)) for w in grid}, (0.5, 2.0))
    lowest = min(u for _, u, _, _ in curve.points())
    assert math.log(lowest) < 3e-4  # the chord between the pair would draw it at log U* = 0.01


def test_crossings_at_any_mass_are_those_of_a_dense_scan_of_the_curve():
    """A curve that turns in m several times (log m = ω + 2 sin 3ω, log U* = 0.3 ω): the crossings
    found at a mass ratio, solving only the cubics whose range of log m reaches it, are the sign
    changes of ``log m(τ) − log m`` on a dense grid of every segment, at the same U*."""
    from fsistab.transfer_map import NeutralRoot, TransferCurve

    def root(w):
        return NeutralRoot(
            w, math.exp(w + 2 * math.sin(3 * w)), math.exp(0.3 * w), 1 + 6 * math.cos(3 * w), 0.3, 1.0
        )

    curve = TransferCurve("flutter", tuple(root(w) for w in np.geomspace(0.5, 3.0, 14)))
    tau = np.linspace(0.0, 1.0, 200001)
    for log_m in np.random.default_rng(3).uniform(-1.0, 4.0, 40):
        found = sorted(u for u, _, _ in curve.crossings_at(math.exp(log_m)))
        scanned = []
        for _, _, coef, _, _ in curve._segments():
            x = npoly.polyval(tau, coef[:, 0]) - log_m
            for k in np.flatnonzero(np.sign(x[1:]) != np.sign(x[:-1])):
                t = tau[k] - x[k] * (tau[k + 1] - tau[k]) / (x[k + 1] - x[k])
                scanned.append(math.exp(npoly.polyval(t, coef[:, 1])))
        assert len(found) == len(scanned) and found == pytest.approx(sorted(scanned), rel=1e-9)
    assert len(curve.crossings_at(math.exp(2.5))) == 3  # it turns twice in m


def test_a_power_law_branch_is_matched_and_interpolated_exactly_in_log_frequency():
    """At large m the restabilisation branch is close to a power law, m ∝ ω⁻² and U* ∝ ω⁻¹: on
    m = 10 ω⁻², U* = 0.8 ω⁻¹ the roots at the initial frequencies 0.01 and 0.0118 (their ratio)
    predict each other along ``log ω`` to rounding, where along ``ω`` they miss by 0.029 (three
    times the tolerance 1e-2 used here, so the interval would be bisected), and the curve between them
    crosses m = 8 10⁴ at the power law's U* and ω."""
    from fsistab.transfer_map import NeutralRoot, _assemble, _match, log_step

    def root(omega):
        return NeutralRoot(omega, 10 / omega**2, 0.8 / omega, -2 / omega, -1 / omega, -1.0)

    w0, w1 = 0.01, 0.0118
    ((i, j, miss),) = _match([root(w0)], [root(w1)], log_step(w0, w1), 1e-2)
    assert miss < 1e-12
    linear = max(abs(root(w0).plane + (w1 - w0) * root(w0).tangent - root(w1).plane))
    assert linear > 0.028
    (curve,) = _assemble({w: [root(w)] for w in (w0, w1)}, {w: np.ones((1, 2)) for w in (w0, w1)}, (1e4, 1e6))
    ((velocity, omega, rate),) = curve.crossings_at(8e4)
    assert omega == pytest.approx(math.sqrt(10 / 8e4), rel=1e-12)
    assert velocity == pytest.approx(0.8 / math.sqrt(10 / 8e4), rel=1e-12) and rate < 0


# --- map outputs (issue 14, item 4) ----------------------------------------------------------------

# quasi-steady loads A(s) = A0 + A1 s + A2 s² (rows C_L, C_M; columns h, θ): stiffness, damping and
# added mass of the right signs and sizes for a plate; the coupled problem is then a quartic in s
QS_LOADS = (
    np.array([[0.0, -6.0], [0.0, 1.5]]),
    np.array([[-6.0, -3.0], [1.5, -0.4]]),
    np.array([[-1.6, 0.0], [0.0, -0.02]]),
)


def _quasi_steady_unstable(solid, mass_ratio, reduced_velocity):
    """Unstable eigenvalues (Re σ > 0, Im σ ≥ 0) of det(m W(σ, 1/U*) − A(σ)) = 0 with the
    quasi-steady loads: the roots of its quartic, independent of the map's resultant."""
    from numpy.polynomial import polynomial as poly

    u, r2 = 1 / reduced_velocity, solid.r_theta**2
    w_h = np.array([(solid.freq_ratio * u) ** 2, 2 * solid.zeta_h * solid.freq_ratio * u, 1.0])
    w_t = r2 * np.array([u * u, 2 * solid.zeta_theta * u, 1.0])
    a = [[np.array([QS_LOADS[k][i, j] for k in range(3)]) for j in range(2)] for i in range(2)]
    det = poly.polysub(
        poly.polymul(mass_ratio * w_h - a[0][0], mass_ratio * w_t - a[1][1]), poly.polymul(a[0][1], a[1][0])
    )
    roots = poly.polyroots(det)
    return int(np.sum((roots.real > 0) & (roots.imag >= 0)))


def _quasi_steady_map(solid, frequencies, mass_range):
    from fsistab.transfer_map import NeutralRoot, TransferMap, _assemble, resultant_tracks  # noqa: F401

    roots, tracks = {}, {}
    for omega in frequencies:
        s = 1j * omega
        loads = QS_LOADS[0] + QS_LOADS[1] * s + QS_LOADS[2] * s * s
        rate = QS_LOADS[1] + 2 * QS_LOADS[2] * s
        roots[omega] = roots_from_loads(loads, rate, omega, solid, (mass_range[0] / 4, mass_range[1] * 4))
        tracks[omega] = resultant_tracks(loads, omega, solid)
    curves = _assemble(roots, tracks, mass_range)
    return TransferMap(tuple(curves), np.zeros(0), np.zeros(0), np.array(frequencies), mass_range, 0, ())


def test_unstable_sides_agree_with_the_eigenvalue_count():
    """Quasi-steady loads: at every point of the map's curves (as_neutral_map, the transfer method)
    and of the same curve read as a continued one (sides from its role at a seed and its turning
    points, the continuation method), the unstable side is the change of the number of unstable
    eigenvalues of the quartic between U*(1 − 1e-6) and U*(1 + 1e-6) at that m; the curves, whose
    frequency follows the solid's (ω U* ≈ const), are flutter."""
    from fsistab.neutral_map import NeutralCurve, characterised
    from fsistab.transfer_map import as_neutral_map

    solid = Solid()
    tmap = _quasi_steady_map(solid, np.geomspace(0.05, 0.7, 60).tolist(), (10.0, 2000.0))
    result = as_neutral_map(tmap, solid)
    assert result.curves and all(c.kind == "flutter" for c in result.curves)
    checked = 0
    for curve in result.curves:
        assert curve.frequency_following == pytest.approx(1.0, abs=0.25)
        for point, side in zip(curve.points, curve.unstable_sides, strict=True):
            m, u = point.mass_ratio, point.reduced_velocity
            change = _quasi_steady_unstable(solid, m, u * (1 + 1e-6)) - _quasi_steady_unstable(
                solid, m, u * (1 - 1e-6)
            )
            assert side == change != 0
            checked += 1
        # the continuation's rule: a seed where log m grows along the order, its role from the count
        points, sides = curve.points, curve.unstable_sides
        if points[-1].mass_ratio < points[0].mass_ratio:  # ordered like a continued curve: m grows
            points, sides = points[::-1], sides[::-1]
        seed = len(points) // 2
        m, u = points[seed].mass_ratio, points[seed].reduced_velocity
        above = _quasi_steady_unstable(solid, m, u * (1 + 1e-6))
        role = "onset" if above > _quasi_steady_unstable(solid, m, u * (1 - 1e-6)) else "restabilisation"
        continued = NeutralCurve(points, kind="flutter", seed_mass_ratio=m, boundary=role, stops=("", ""))
        relabelled = characterised(continued, seed, (10.0, 2000.0))
        assert relabelled.unstable_sides == sides and relabelled.kind == curve.kind
    assert checked > 20


def test_a_family_whose_crossings_do_not_add_up_is_left_unshaded_and_reported(tmp_path):
    """Quasi-steady loads: the whole map's signed crossings add up everywhere (nothing reported).
    Its second flutter curve (an onset) read as a restabilisation, with no onset below it (a curve
    missing, as in an unresolved interval), would make the flutter count fall below zero: over that
    curve's masses the family is left out of the shading grid and reported as unshaded, in the
    dataset, the JSON and the figure's note."""
    from dataclasses import replace as replaced

    from fsistab import payloads, workflows
    from fsistab.neutral_map import neutral_map_dataset, unshaded_families
    from fsistab.params import MapSettings
    from fsistab.transfer_map import TransferCurve, as_neutral_map

    solid = Solid()
    settings = MapSettings(mass_range=(10.0, 2000.0))
    whole = _quasi_steady_map(solid, np.geomspace(0.05, 0.7, 60).tolist(), (10.0, 2000.0))

    def dataset(tmap):
        result = as_neutral_map(tmap, solid)
        attrs = {"wake_frequency": math.nan, "method": "transfer"}
        ds = workflows._map_details(neutral_map_dataset(result, attrs), result, tmap, settings)
        return ds.assign_attrs(factorisations_this_run=0, reduced_models=0, data="m.nc", figure="m.png")

    complete = dataset(whole)
    assert unshaded_families(complete) == [] and payloads.payload("neutral", complete)["unshaded"] == []
    assert len(whole.curves) == 2 and all(r.crossing_rate > 0 for c in whole.curves for r in c.roots)
    kept = [replaced(r, crossing_rate=-r.crossing_rate) for r in whole.curves[1].roots]
    broken = dataset(replaced(whole, curves=(whole.curves[0], TransferCurve("flutter", tuple(kept)))))
    masses = [r.mass_ratio for r in kept if 10.0 <= r.mass_ratio <= 2000.0]
    [(kind, low, high)] = unshaded_families(broken)
    assert kind == "flutter" and min(masses) * 0.9 <= low < high <= max(masses) * 1.1
    assert (broken.unstable_count.values >= 0).all()
    assert payloads.payload("neutral", broken)["unshaded"] == [
        {"kind": "flutter", "mass_ratio_range": [low, high]}
    ]
    from fsistab.plots import plot_map

    figure = plot_map(broken, tmp_path / "map.svg")
    assert "flutter not shaded at m" in figure.read_text()


def test_a_map_around_the_wake_frequency_is_viv_without_a_hint(fluid, tmp_path):
    """Plate, Re = 2900, coarse mesh: a map whose frequencies (6.3-15.9) hold only the wake mode
    of the fixed plate (-0.07 + 10.81i) and the solid frequencies passing it, with no
    wake_frequency, from initial frequencies 6.3, 10.0 and 15.9 (none within the resonance: without
    the resonance's sample, :func:`unresolved_resonance`, the map has no curve): every curve is
    VIV (frequency locked near the wake mode's while U* varies) in the map, the NetCDF dataset and
    the JSON; every unresolved interval has a reason, serialised."""
    from fsistab import payloads, workflows
    from fsistab.neutral_map import neutral_map_dataset
    from fsistab.params import MapSettings
    from fsistab.reduced_model import ReducedModels
    from fsistab.transfer_map import UNRESOLVED_REASONS, as_neutral_map

    counter = FactorCounter()
    tmap = transfer_neutral_map(
        fluid,
        Solid(),
        mass_range=(1.0, 10.0),
        omega_range=(6.3, 15.9),
        initial=3,
        reduced=ReducedModels(fluid, counter=counter),
        counter=counter,
    )
    assert len(tmap.curves) >= 2 and {c.kind for c in tmap.curves} == {"viv"}
    assert all(abs(r.frequency - 10.81) < 0.1 * 10.81 for c in tmap.curves for r in c.roots)
    assert {kind for _, _, kind in tmap.crossings_at(3.0)} - {"divergence"} == {"viv"}
    assert all(u.reason in UNRESOLVED_REASONS and u.low < u.high for u in tmap.unresolved)
    result = as_neutral_map(tmap, Solid())
    attrs = {"wake_frequency": math.nan, "method": "transfer"}
    ds = workflows._map_details(neutral_map_dataset(result, attrs), result, None, MapSettings())
    ds = ds.assign_attrs(factorisations_this_run=counter.count, reduced_models=0, data="m.nc", figure="m.png")
    assert set(ds.curve_kind.values) == {"viv"}
    assert ds.unresolved_reason.values.tolist() == [u.reason for u in tmap.unresolved]
    payload = payloads.payload("neutral", ds)
    assert {c["kind"] for c in payload["curves"]} == {"viv"} and payload["wake_frequency"] is None
    assert payload["unresolved_count"] == len(tmap.unresolved)
    assert [u["reason"] for u in payload["unresolved"]] == [u.reason for u in tmap.unresolved]
    assert all(set(c["unstable_side"]) <= {-1, 1} for c in payload["curves"])


def _pole_samples(seed: int, pole: complex, residue: float = 1.0) -> tuple[AxisSample, AxisSample]:
    """Samples at ω = 10.47 and 12.31 (the default map's initial frequencies around the plate's wake
    mode) of G(s) = A₀ + A₁s + A₂s²/20 + r R/(s − λ), random 3 × 4 matrices, and of dG/ds."""
    rng = np.random.default_rng(seed)
    a0, a1, a2, r = (rng.normal(size=(3, 4)) + 1j * rng.normal(size=(3, 4)) for _ in range(4))

    def sample(omega):
        s = 1j * omega
        value = a0 + a1 * s + a2 * s * s / 20 + residue * r / (s - pole)
        return AxisSample(omega, value, a1 + a2 * s / 10 - residue * r / (s - pole) ** 2)

    return sample(10.47), sample(12.31)


@pytest.mark.parametrize("seed", range(20))
def test_a_weakly_damped_pole_between_two_samples_is_sampled_next(seed):
    """A pole 0.03 from the axis between two samples 1.84 apart (no neutral root need show at
    either): the next sample lands within 0.1 of its frequency, 6× closer than the nearest sample
    can be. A pole damped more than half the half-width (resolved by the samples), one outside the
    interval, and no pole at all (a quadratic G) call for no sample."""
    frequency = np.random.default_rng(seed + 100).uniform(10.8, 12.0)
    omega = unresolved_resonance(*_pole_samples(seed, -0.03 + 1j * frequency))
    assert omega is not None and abs(omega - frequency) < 0.1
    assert unresolved_resonance(*_pole_samples(seed, -1.0 + 1j * frequency)) is None
    assert unresolved_resonance(*_pole_samples(seed, -0.03 + 14j)) is None
    assert unresolved_resonance(*_pole_samples(seed, -0.03 + 1j * frequency, residue=0.0)) is None


@pytest.mark.parametrize("seed", range(20))
def test_only_a_resonance_much_narrower_than_its_interval_is_sharp(seed):
    """:func:`sharp_resonance`, between samples 1.84 apart: a pole 0.03 from the axis (0.03 of
    the half-width, as the plate's wake mode between the default map's initial frequencies) is sharp
    and gets a reduced model; poles 0.15 and 0.3 from it are sampled (:func:`unresolved_resonance`)
    but not sharp: exact samples resolve them in a few bisections."""
    frequency = np.random.default_rng(seed + 100).uniform(10.8, 12.0)
    assert sharp_resonance(*_pole_samples(seed, -0.03 + 1j * frequency))
    for damping in (0.15, 0.3):
        samples = _pole_samples(seed, -damping + 1j * frequency)
        assert unresolved_resonance(*samples) is not None and not sharp_resonance(*samples)


def test_a_sharp_resonance_is_sampled_by_a_reduced_model(fluid, tmp_path):
    """The wake mode of this mesh (−0.07 + 10.81i) between the initial frequencies 10.3 and 11.9
    (the exact-sample map over that range, m ∈ [1, 10]): the resonance is sharp (its fitted pole
    0.04 half-widths from the axis), and a reduced model there (one factorisation) certifies an
    interval around it whose frequencies cost none. The map has the same VIV curves and crossings at
    m = 2, 5 and 10 as with exact samples alone (``resonance_blocks=0``; to 1e-8 in U*, measured
    1e-12) for less than half the factorisations (measured 4, the model certified on
    ω ∈ [9.90, 12.07], against 49); ``G`` from the model at a crossing's frequency equals an exact
    sample there to 1e-6, and a rerun reads the saved model back (no factorisation)."""
    settings_ = dict(mass_range=(1.0, 10.0), omega_range=(10.3, 11.9), initial=2)
    counter, alone = FactorCounter(), FactorCounter()
    tmap = transfer_neutral_map(fluid, Solid(), counter=counter, samples_path=tmp_path / "s.nc", **settings_)
    exact = transfer_neutral_map(fluid, Solid(), counter=alone, resonance_blocks=0, **settings_)
    assert tmap.resonance_models >= 1 and exact.resonance_models == 0
    assert counter.count == tmap.factorisations < 0.5 * exact.factorisations
    assert exact.factorisations == alone.count
    assert {c.kind for c in tmap.curves} == {c.kind for c in exact.curves} == {"viv"}
    _assert_same_crossings(tmap, exact, (2.0, 5.0, 10.0), 1, rel=1e-8)
    saved = read_samples(samples_table(tmp_path / "s.nc", fluid))
    roots = [r for c in tmap.curves for r in c.roots if 2 < r.mass_ratio < 10]
    root = next(r for r in roots if saved[r.frequency].reduced)
    sample = _sample(fluid, root.frequency)
    assert relative_error(saved[root.frequency].transfer, sample.transfer) < 1e-6
    _assert_root_of_exact_sample(fluid, root, sample)
    again = FactorCounter()
    rerun = transfer_neutral_map(fluid, Solid(), counter=again, samples_path=tmp_path / "s.nc", **settings_)
    assert again.count == 0 and rerun.resonance_models == tmap.resonance_models


def test_unresolved_intervals_are_reported_with_their_reasons():
    """An interval next to a fold in ω (on the fold's side) is a fold, whatever stopped it; the
    others keep the reason the sampling gave; an unknown reason is refused."""
    from fsistab.transfer_map import NeutralRoot, TransferCurve, UnresolvedInterval, unresolved_intervals

    roots = tuple(NeutralRoot(1.0, m, 1.0, 1.0, 0.1, 1.0) for m in (1.0, 2.0))
    curve = TransferCurve("flutter", roots, ((0, -1),))  # two branches born below ω = 1, joined
    found = unresolved_intervals(
        {(0.999, 1.0): "min_step", (1.0, 1.001): "budget", (2.0, 2.1): "sweep"}, [curve]
    )
    assert found == (
        UnresolvedInterval(0.999, 1.0, "fold"),
        UnresolvedInterval(1.0, 1.001, "budget"),
        UnresolvedInterval(2.0, 2.1, "sweep"),
    )
    assert unresolved_intervals({}, [curve]) == ()
    with pytest.raises(InputError, match="reason"):
        UnresolvedInterval(0.0, 1.0, "tired")


def test_a_curve_leaving_the_lowest_frequency_is_followed_below_it(fluid, tmp_path):
    """The flutter curve's restabilisation branch falls in frequency as m grows (ω ≈ 0.0078 at
    m = 6000 on this mesh): followed below ω = 0.01, it bounds the flutter region at m = 6000, and
    the unstable counts on either side of it are the eigen-solver's (2 below: flutter and
    divergence; 1 above). The same map without following leaves the region open above (2 unstable
    modes counted where there is 1) and reports the interval below ω = 0.01 as ``range``."""
    settings_ = dict(mass_range=(3000.0, 8000.0), omega_range=(0.01, 0.2), initial=8)
    settings_["samples_path"] = tmp_path / "samples.nc"
    tmap = transfer_neutral_map(fluid, Solid(), follow_low=True, **settings_)
    assert tmap.frequencies[1] < 0.01  # ω = 0 first
    assert not any(u.reason == "range" and u.low == 0.0 for u in tmap.unresolved)
    flutter = [(u, rate) for u, rate, kind in tmap.crossings_at(6000.0) if kind == "flutter"]
    assert len(flutter) == 2 and flutter[0][1] > 0 > flutter[1][1]  # onset, then restabilisation
    restabilisation = flutter[1][0]
    velocities = [0.9 * restabilisation, 1.1 * restabilisation]
    assert unstable_counts(tmap, 6000.0, velocities).tolist() == [2, 1]
    for u, expected in zip(velocities, (2, 1), strict=True):
        system = CoupledSystem(fluid, Solid(mass_ratio=6000, reduced_velocity=u))
        pairs = eigenpairs_near(system, [0.02, 0.001 + 0.8j / u, 0.001 + 1j / u], 6)
        unstable = {round(p.value.real, 6) for p in pairs if p.growth_rate > 1e-7 and p.frequency >= 0}
        assert len(unstable) == expected
    fixed = transfer_neutral_map(fluid, Solid(), follow_low=False, **settings_)
    assert [u for u, _, kind in fixed.crossings_at(6000.0) if kind == "flutter"] == [flutter[0][0]]
    assert unstable_counts(fixed, 6000.0, velocities[1:]).tolist() == [2]
    assert [(u.low, u.high) for u in fixed.unresolved if u.reason == "range"] == [(0.0, 0.01)]


def test_the_lowest_frequencies_come_from_one_real_model_at_zero(fluid, tmp_path):
    """With exact samples and a range starting below ``LOW_MODEL_REACH``, ``G(0)`` and the lowest
    frequencies come from one real reduced model at s = 0 (one factorisation): its ``G(0)`` and
    ``dG/ds`` equal an exact sample's within the models' tolerance (1e-7; measured 2e-10 and
    4e-9), the divergence lines to 1e-8; every frequency in its certified interval is free (not an
    exact sample: measured ω ≤ 0.055 of 0.01-0.2), and the map has the crossings of the map with
    exact samples only (``resonance_blocks=0``) to 1e-7 in U* (measured 1e-11) for fewer
    factorisations (7 against 12). A rerun reads the model back: no factorisation."""
    settings_ = dict(mass_range=(3000.0, 8000.0), omega_range=(0.01, 0.2), initial=8)
    counter, alone = FactorCounter(), FactorCounter()
    tmap = transfer_neutral_map(fluid, Solid(), counter=counter, samples_path=tmp_path / "s.nc", **settings_)
    exact = transfer_neutral_map(
        fluid, Solid(), counter=alone, resonance_blocks=0, samples_path=tmp_path / "exact.nc", **settings_
    )
    assert tmap.resonance_models == 1 and exact.resonance_models == 0
    saved = read_samples(samples_table(tmp_path / "s.nc", fluid))
    static = read_samples(samples_table(tmp_path / "exact.nc", fluid))[0.0]  # the exact map's G(0)
    assert saved[0.0].reduced and not static.reduced
    assert relative_error(saved[0.0].transfer, static.transfer) < RESONANCE_TOLERANCE
    assert relative_error(saved[0.0].rate, static.rate) < RESONANCE_TOLERANCE
    assert tmap.divergence_lambdas == pytest.approx(exact.divergence_lambdas, rel=1e-8)
    free = [w for w in tmap.frequencies if w > 0 and saved[w].reduced]
    assert free and min(tmap.frequencies[1:]) in free  # the lowest frequencies cost nothing
    assert counter.count == tmap.factorisations < exact.factorisations == alone.count
    assert tmap.factorisations == 1 + sum(not saved[w].reduced for w in tmap.frequencies if w > 0)
    _assert_same_crossings(tmap, exact, (3000.0, 6000.0, 8000.0), 1, rel=1e-7)
    again = FactorCounter()
    rerun = transfer_neutral_map(fluid, Solid(), counter=again, samples_path=tmp_path / "s.nc", **settings_)
    assert again.count == 0 and rerun.resonance_models == 1


def _assert_same_crossings(tmap, reference, masses, least: int, rel: float):
    """At each mass ratio of ``masses`` the two maps cross U* as often (at least ``least`` times),
    in the same order, with the same kinds and crossing signs, at the same U* (to ``rel``)."""
    for m in masses:
        got, expected = tmap.crossings_at(m), reference.crossings_at(m)
        assert len(got) == len(expected) >= least
        for (u, rate, kind), (u0, rate0, kind0) in zip(got, expected, strict=True):
            assert kind == kind0 and np.sign(rate) == np.sign(rate0)
            assert u == pytest.approx(u0, rel=rel)


def _assert_root_of_exact_sample(fluid, root, exact):
    """A map root from an interpolated frequency: the neutral point nearest it from the exact
    sample ``exact`` at that frequency is the same (1e-5 in m, 1e-6 in U*)."""
    again = neutral_roots(exact, Solid(), fluid.theta0, fluid.loads0, (0.25, 400.0))
    twin = min(again, key=lambda r: abs(math.log(r.mass_ratio / root.mass_ratio)))
    assert twin.mass_ratio == pytest.approx(root.mass_ratio, rel=1e-5)
    assert twin.reduced_velocity == pytest.approx(root.reduced_velocity, rel=1e-6)


def test_a_viv_curve_unresolved_at_the_smallest_exact_step_is_found_by_a_rational_fit(
    fluid, tmp_path, monkeypatch
):
    """ω ∈ [11.18, 11.3] on this mesh (wake mode −0.07 + 10.81i): a VIV curve crosses m from 1 to
    100 within Δω ≈ 0.01. Exact samples alone stop at ``min_step`` and draw no curve; a certified
    rational fit of the same samples (:mod:`fsistab.rational_fit`) refines on with no factorisation
    and finds it. At its crossing of m = 10 the fit's G equals an exact sample's to 1e-6, the
    neutral point from that exact sample equals the map's, and the eigen-solver counts no unstable
    wake-frequency mode 1.5 % below it and one 1.5 % above (the curve is a VIV onset). Fits only
    below ``min_step`` here (``fit_first=False``); with fits tried before each exact bisection
    (the default) the same settings cost 13 factorisations instead of 27."""
    settings_ = dict(mass_range=(1.0, 100.0), omega_range=(11.18, 11.3), initial=5, fit_first=False)
    counter = FactorCounter()
    tmap = transfer_neutral_map(fluid, Solid(), counter=counter, samples_path=tmp_path / "s.nc", **settings_)
    assert tmap.rational_fits >= 1 and tmap.interpolated > 0
    assert counter.count == tmap.factorisations == len(tmap.frequencies) - tmap.interpolated
    assert not [u for u in tmap.unresolved if u.reason == "min_step"]
    crossings = [(u, rate) for u, rate, kind in tmap.crossings_at(10.0) if kind != "divergence"]
    assert len(crossings) == 1 and crossings[0][1] > 0
    u_viv = crossings[0][0]
    root = min((r for c in tmap.curves for r in c.roots), key=lambda r: abs(math.log(r.mass_ratio / 10.0)))
    assert {c.kind for c in tmap.curves} == {"viv"} and abs(root.mass_ratio - 10.0) < 1.0
    saved = read_samples(samples_table(tmp_path / "s.nc", fluid))
    assert saved[root.frequency].reduced  # the root came from the fit
    exact = _sample(fluid, root.frequency)
    assert relative_error(saved[root.frequency].transfer, exact.transfer) < 1e-6
    _assert_root_of_exact_sample(fluid, root, exact)
    for factor, expected in ((0.985, 0), (1.015, 1)):
        system = CoupledSystem(fluid, Solid(mass_ratio=10.0, reduced_velocity=factor * u_viv))
        pairs = eigenpairs_near(system, [0.01 + 11.2j], 6)
        unstable = {round(p.value.real, 6) for p in pairs if p.growth_rate > 1e-7 and 10 < p.frequency < 12}
        assert len(unstable) == expected
    monkeypatch.setattr("fsistab.transfer_map.FIT_MARGINS", ())  # exact samples alone
    plain = transfer_neutral_map(fluid, Solid(), samples_path=tmp_path / "plain.nc", **settings_)
    assert plain.factorisations == tmap.factorisations and not plain.curves
    assert {u.reason for u in plain.unresolved} == {"min_step"}


def test_fits_tried_before_exact_bisection_draw_the_same_map_with_fewer_factorisations(fluid, tmp_path):
    """The wake band of this mesh (ω ∈ [10.2, 11.6], m ∈ [1, 100], eight initial frequencies):
    with a certified fit tried before each exact bisection (the default) the map has the same VIV
    curves and crossings at m = 2, 5, 10, 30 (to 1e-6) as with fits only below ``min_step``, for
    less than half the factorisations (measured 57 against 126); a neutral point taken from an
    interpolated frequency equals the one from an exact sample there (1e-5 in m, 1e-6 in U*)."""
    settings_ = dict(mass_range=(1.0, 100.0), omega_range=(10.2, 11.6), initial=8)
    late, first = FactorCounter(), FactorCounter()
    plain = transfer_neutral_map(fluid, Solid(), counter=late, fit_first=False, **settings_)
    tmap = transfer_neutral_map(fluid, Solid(), counter=first, samples_path=tmp_path / "s.nc", **settings_)
    assert first.count == tmap.factorisations < 0.6 * late.count
    assert tmap.rational_fits > plain.rational_fits and tmap.interpolated > plain.interpolated
    assert [(c.kind, len(c.roots)) for c in tmap.curves] == [(c.kind, len(c.roots)) for c in plain.curves]
    assert {c.kind for c in tmap.curves} == {"viv"}
    _assert_same_crossings(tmap, plain, (2.0, 5.0, 10.0, 30.0), 2, rel=1e-6)
    saved = read_samples(samples_table(tmp_path / "s.nc", fluid))
    fitted = [r for c in tmap.curves for r in c.roots if saved[r.frequency].reduced]
    root = next(r for r in fitted if 2 < r.mass_ratio < 50)
    _assert_root_of_exact_sample(fluid, root, _sample(fluid, root.frequency))
