"""The parts of the transfer map's engine on small synthetic transfer functions with known neutral
curves (sample sources, refinement policy, root tracker, the loop), and on the coarse plate the
rebuild of a damaged models file and the factorisation counts over a resume.

The synthetic fluid: pitch only, ``θ0 = 0`` and no steady load, so that ``A_θθ(s) = 2 (G_Mθ + s
G_Mθ̇)`` (:func:`fsistab.transfer.aerodynamic_loads`). With ``A_θθ(iω) = a + i β(ω)`` the neutral
condition ``m r² (u² − ω² + 2iζuω) = a + iβ`` gives, with ``k = m r²``,

    ``k(u² − ω²) = a``,  ``2kζuω = β``  ⇒  ``k = K/ω²``, ``K = (−a + √(a² + β²/ζ²))/2``,
    ``U* = 1/u = 2Kζ/(βω)``:

one neutral curve, a power law ``m ∝ ω⁻²``, ``U* ∝ ω⁻¹`` for a constant ``β``.
"""

import math
from types import SimpleNamespace

import numpy as np
import pytest
from damage import damage
from scipy.optimize import brentq

from fsistab.linalg import FactorCounter
from fsistab.map_engine import MapEngine, MapSources
from fsistab.map_refinement import FIT_MIN_STEP, RefinementPolicy, initial_frequencies, resonance, runs
from fsistab.map_roots import AxisSample, NeutralRoot, neutral_roots
from fsistab.map_samples import SAMPLE_FIELDS, SAVE_EVERY, SampleStore
from fsistab.map_sources import Certified, RationalFitSource, ResonanceSource
from fsistab.map_tracker import RootTracker, _born_outside, _match, _neutral_fold
from fsistab.params import MAX_FREQUENCY, Solid
from fsistab.reduced_model import ReducedModels, models_table, read_models
from fsistab.store import ResumableTable
from fsistab.transfer_map import _assemble, transfer_neutral_map

PITCH = Solid(dofs=("pitch",), zeta_theta=0.05)
A, B = 1.0, 0.5  # A_θθ(iω) = A + iB (power law) or A + iB(1 + ω) (not)


def _pitch_sample(omega: float, slope: bool = False) -> AxisSample:
    """``G`` with ``A_θθ(iω) = A + iB`` (or ``A + iB(1 + ω)`` with ``slope``: ``G_Mθ̇ = B/2``);
    ``G`` constant: ``dG/ds = 0``."""
    g = np.zeros((3, 4), dtype=complex)
    g[2, 1] = (A + 1j * B) / 2
    if slope:
        g[2, 3] = B / 2
    return AxisSample(omega, g, np.zeros((3, 4), dtype=complex))


def _curve(omega: float, beta: float) -> tuple[float, float]:
    """``(m, U*)`` of the neutral point at ``omega`` (module docstring)."""
    k = (-A + math.sqrt(A * A + beta * beta / PITCH.zeta_theta**2)) / 2
    return k / (PITCH.r_theta**2 * omega**2), 2 * k * PITCH.zeta_theta / (beta * omega)


class _Synthetic:
    """An exact source of the synthetic ``G``: each sample counted as one factorisation."""

    def __init__(self, counter: FactorCounter, slope: bool = False):
        self.counter, self.slope = counter, slope

    def sample(self, omega: float) -> AxisSample:
        self.counter.count += 1
        return _pitch_sample(omega, self.slope)

    def samples(self, frequencies, later=None):
        for omega in [*frequencies, *(later.items() if later else ())]:
            yield self.sample(omega)


def _policy(**kwargs) -> RefinementPolicy:
    settings = dict(
        inner=(1.0, 1e4),
        wide=(0.25, 4e4),
        omega_range=(0.05, 10.0),
        tolerance=3e-2,
        min_step=1e-3,
        max_samples=400,
        exact=True,
    )
    return RefinementPolicy(**{**settings, **kwargs})


def _plate_sample(omega: float, loads, rates) -> AxisSample:
    """A sample from the lift and moment rows of ``G`` and ``dG/ds`` in the columns ``θ, ḣ, θ̇`` (the
    drag row and the heave column vanish for the plate at α0 = 0)."""
    g, dg = np.zeros((3, 4), complex), np.zeros((3, 4), complex)
    g[1:, 1:], dg[1:, 1:] = loads, rates
    return AxisSample(omega, g, dg)


# `quick` (the plate at Re 2900) at ω = 8.9096 and 9.6915, eight digits: a pair of tracks is born
# between them at m ≈ −2.3 (near ω = 9.18)
PLATE_BIRTH = {
    8.909566872610508: (
        [
            [-0.79181306 - 6.4384933j, -0.79180541 - 6.4384939j, 0.036024678 + 0.30112755j],
            [0.56407377 + 0.26410447j, 0.56407346 + 0.26410508j, -0.070765526 - 0.19561854j],
        ],
        [
            [-0.77108098 - 0.52243016j, -0.77108032 - 0.5224302j, 0.038013793 - 0.011980077j],
            [0.055602555 - 0.06083999j, 0.055602553 - 0.060839964j, -0.016858583 + 0.0084182335j],
        ],
    ),
    9.69152663054872: (
        [
            [-0.49939952 - 7.0854973j, -0.4993918 - 7.0854976j, 0.039613516 + 0.36340065j],
            [0.62307741 + 0.28918837j, 0.6230771 + 0.289189j, -0.073338443 - 0.20226639j],
        ],
        [
            [-0.98199014 - 0.22829473j, -0.98198987 - 0.22829498j, 0.087887187 - 0.024778417j],
            [0.031063885 - 0.08480936j, 0.031063907 - 0.08480936j, 0.0042708188 - 0.004384172j],
        ],
    ),
}


def test_a_pair_born_outside_the_mass_range_is_settled_without_bisecting():
    """The refinement policy on the plate's two samples (the steady drag's rotation left out,
    ``loads0 = 0``; no neutral root in the range at either,
    a pair of tracks born in between, 19 % apart in v at the upper one): the interval is a possible
    sweep, and the pair's rates place its fold inside it with the branch at m < 0, so nothing is
    sampled, fitted or left unresolved. Before, it was bisected until the pair was young."""
    policy = _policy()
    tracker = RootTracker(Solid(), policy.wide, 0.0, np.zeros(3))
    samples = {w: _plate_sample(w, *data) for w, data in PLATE_BIRTH.items()}
    for sample in samples.values():
        tracker.add(sample)
    w0, w1 = tracker.grid
    assert not tracker.roots[w0] and not tracker.roots[w1]
    assert (len(tracker.tracks[w0]), len(tracker.tracks[w1])) == (1, 3) and tracker.swept(w0, w1)
    nothing = Certified(ResonanceSource(None), RationalFitSource(SampleStore()))
    survey = policy.survey(tracker, samples.get, nothing, {}, sharp=False)
    assert not (survey.todo or survey.pending or survey.stuck or survey.unresolved)
    assert not _born_outside(tracker.tracks[w0], tracker.tracks[w1], policy.wide)  # bisected before


# `quick` at ω near the nose of the flutter curve (m ≈ 14.4, U* ≈ 0.855), eight digits: a pair
# of neutral roots at 1.02242, none at 1.02305, where the curve folds back in ω
PLATE_NOSE = {
    0.9868629702114634: (
        [
            [-1.8521919 - 0.15032928j, -1.8521818 - 0.15043294j, -0.21058896 + 0.091338473j],
            [0.51089065 - 0.07566618j, 0.51088887 - 0.075635105j, -0.088455304 - 0.046218356j],
        ],
        [
            [-0.16555691 - 0.16868349j, -0.16869648 - 0.16023859j, 0.26025421 + 0.13966596j],
            [-0.13477306 - 0.020813759j, -0.13396614 - 0.023346511j, -0.098509268 - 0.018734736j],
        ],
    ),
    1.0071790018994755: (
        [
            [-1.8339916 - 0.16056087j, -1.8341119 - 0.16057314j, -0.20707789 + 0.094582233j],
            [0.5072845 - 0.076118234j, 0.50731994 - 0.076114441j, -0.089869079 - 0.047472529j],
        ],
        [
            [-1.1888798 - 0.85329493j, -1.1793552 - 0.85242038j, -0.13927797 - 0.25613915j],
            [0.1703939 + 0.14856943j, 0.16769285 + 0.14835917j, 0.02625455 + 0.086371683j],
        ],
    ),
    1.0173370177434815: (
        [
            [-1.8277827 - 0.17143737j, -1.8278688 - 0.17136062j, -0.20560816 + 0.09264968j],
            [0.50644781 - 0.074797519j, 0.50647339 - 0.074818719j, -0.090409875 - 0.047091512j],
        ],
        [
            [-0.87520823 - 0.58240381j, -0.86874018 - 0.58952136j, -0.19312209 - 0.060893317j],
            [0.072507914 + 0.078849509j, 0.070710442 + 0.080854335j, 0.035422716 + 0.029558207j],
        ],
    ),
    1.0224160256654846: (
        [
            [-1.8242255 - 0.17587139j, -1.8242707 - 0.17577202j, -0.20537128 + 0.09167317j],
            [0.50587483 - 0.074421685j, 0.50588895 - 0.074449143j, -0.090542279 - 0.046916986j],
        ],
        [
            [-0.93698154 - 0.81891j, -0.93464051 - 0.82747991j, -0.19998371 - 0.035518298j],
            [0.094382361 + 0.14554246j, 0.093739791 + 0.14792848j, 0.035889288 + 0.023412077j],
        ],
    ),
    1.023050901655735: (
        [
            [-1.8236983 - 0.17647711j, -1.823738 - 0.17637641j, -0.20534974 + 0.091544751j],
            [0.50578055 - 0.074358544j, 0.50579316 - 0.074386364j, -0.090556888 - 0.046893834j],
        ],
        [
            [-0.97202318 - 0.84121286j, -0.97021077 - 0.84977595j, -0.20470501 - 0.032246603j],
            [0.10476044 + 0.15124059j, 0.10426429 + 0.15362174j, 0.037083982 + 0.022580609j],
        ],
    ),
    1.0274950335874875: (
        [
            [-1.8198639 - 0.18151127j, -1.8198674 - 0.18141009j, -0.20529539 + 0.090534345j],
            [0.50509471 - 0.073688334j, 0.50509728 - 0.073716278j, -0.090633219 - 0.046703007j],
        ],
        [
            [-1.3093852 - 0.82909677j, -1.3108013 - 0.83657496j, -0.25250393 + 0.01699481j],
            [0.200286 + 0.14135183j, 0.20067433 + 0.14341414j, 0.049407152 + 0.0091462283j],
        ],
    ),
}
NOSE_DRAG = np.array([0.0340665, 0.0, 0.0])  # `quick`'s steady loads: C_D / 2


def _nose_tracker(frequencies, policy) -> tuple[RootTracker, dict]:
    tracker = RootTracker(Solid(), policy.wide, 0.0, NOSE_DRAG)
    samples = {w: _plate_sample(w, *PLATE_NOSE[w]) for w in frequencies}
    for sample in samples.values():
        tracker.add(sample)
    return tracker, samples


def test_the_flutter_curve_fold_in_frequency_is_left_once_its_pair_places_it():
    """The plate's flutter nose on `quick`. With samples at 0.98686, 1.00718 and 1.0275 the pair at
    1.00718 is not matched to 0.98686 (its tangents go as 1/√(ω − ω_b)): both intervals are
    bisected. Once 1.01734 is sampled, its pair is matched to 1.00718 and its tangents place the
    fold at 1.02267, between the last sample with the pair (1.02242) and the first without it
    (1.02305): the interval is left as a fold, the curve joined through it, with nothing sampled in
    it (the map bisected it four more rounds before). Were samples free there (a certified model),
    the next would go three quarters of the way to the fold, the pair's chord being longer than
    the tolerance; and a fold not yet placed would be bisected below ``min_step``."""
    policy = _policy()
    nothing = Certified(ResonanceSource(None), RationalFitSource(SampleStore()))
    w = sorted(PLATE_NOSE)
    tracker, samples = _nose_tracker([w[0], w[1], w[5]], policy)
    assert [len(tracker.roots[x]) for x in tracker.grid] == [2, 2, 0]
    assert tracker.placed_fold(w[1], w[5], policy.tolerance, policy.inner) is None
    survey = policy.survey(tracker, samples.get, nothing, {}, sharp=False)
    assert sorted(x[-1] for x in survey.todo) == pytest.approx([0.99702, 1.01734], abs=1e-5)

    tracker, samples = _nose_tracker([w[0], w[1], w[2], w[5]], policy)
    survey = policy.survey(tracker, samples.get, nothing, {}, sharp=False)
    assert survey.unresolved == {(w[2], w[5]): "fold"}
    assert [x[1:3] for x in survey.todo] == [(w[0], w[1])]  # the pair at 1.00718 still unmatched below
    fold = w[2] + _neutral_fold(*tracker.roots[w[2]])
    assert fold == pytest.approx(1.02267, abs=1e-5)
    closest, _ = _nose_tracker([w[3], w[4]], policy)
    assert len(closest.roots[w[3]]) == 2 and not closest.roots[w[4]]
    assert w[3] < fold < w[4]

    covered = SimpleNamespace(spanned=lambda a, b: True, fitted=lambda omega: None)
    survey = policy.survey(tracker, samples.get, covered, {}, sharp=False)
    (at, offset, chord) = tracker.placed_fold(w[2], w[5], policy.tolerance, policy.inner)
    assert (at, chord) == (w[2], pytest.approx(math.log(16.3415 / 12.7378), rel=1e-3))
    assert (w[2], w[5]) not in survey.unresolved  # free samples: on towards the fold
    assert (w[5] - w[2], w[2], w[5], pytest.approx(w[2] + 0.75 * offset)) in survey.todo

    tracker, samples = _nose_tracker([w[0], w[1], w[5]], policy)  # not placed yet
    coarse = _policy(min_step=0.1)  # the interval is below min_step
    left = coarse.survey(tracker, samples.get, nothing, {}, sharp=False)
    assert left.unresolved[(w[1], w[5])] == "min_step"  # exact samples: no step resolves a fold
    onwards = coarse.survey(tracker, samples.get, covered, {}, sharp=False)
    assert (w[5] - w[1], w[1], w[5], 0.5 * (w[1] + w[5])) in onwards.todo  # free: bisected on


def _engine(policy, slope=False, store=None):
    counter, store = FactorCounter(), store if store is not None else SampleStore()
    sources = MapSources(_Synthetic(counter, slope), ResonanceSource(None), RationalFitSource(store))
    tracker = RootTracker(PITCH, policy.wide, 0.0, np.zeros(3))
    return MapEngine(policy, sources, store, tracker, counter, lambda message: None), counter


def test_roots_of_a_synthetic_transfer_function_are_the_analytic_neutral_points():
    """One root per frequency, at the (m, U*) of the module docstring (to 1e-12), with the tangent
    of the power law: d log m/dω = −2/ω, d log U*/dω = −1/ω."""
    for omega in (0.3, 1.0, 4.0):
        (root,) = neutral_roots(_pitch_sample(omega), PITCH, 0.0, np.zeros(3), (1.0, 1e4))
        m, u = _curve(omega, B)
        assert root.mass_ratio == pytest.approx(m, rel=1e-12)
        assert root.reduced_velocity == pytest.approx(u, rel=1e-12)
        assert root.dlog_mass == pytest.approx(-2 / omega, rel=1e-9)
        assert root.dlog_velocity == pytest.approx(-1 / omega, rel=1e-9)


def _power_root(omega: float, scale: float = 1.0) -> NeutralRoot:
    m, u = _curve(omega, B)
    return NeutralRoot(omega, scale * m, u, -2 / omega, -1 / omega, 1.0)


def test_the_tracker_matches_roots_along_their_tangents_and_not_across_curves():
    """Two power-law curves 10 × apart in m at ω = 1 and 1.1: each root is matched to its own
    (prediction error 0: the curves are straight in log ω), never to the other (error log 10)."""
    left = [_power_root(1.0), _power_root(1.0, 10.0)]
    right = [_power_root(1.1, 10.0), _power_root(1.1)]
    matches = _match(left, right, math.log(1.1), 0.25)
    assert sorted((i, j) for i, j, _ in matches) == [(0, 1), (1, 0)]
    assert max(d for *_, d in matches) < 1e-12
    assert _match(left[:1], right[:1], math.log(1.1), 0.25) == []  # log 10 > 0.25 apart


def test_the_policy_bisects_unmatched_intervals_and_leaves_a_fold_at_min_step():
    """Roots that do not match: the midpoint is sampled; an interval narrower than min_step with
    exact samples is left to a rational fit (stuck); a fold (two roots born) is not, and at min_step
    it is unresolved; a matched interval needs nothing."""
    policy = _policy()
    tracker = RootTracker(PITCH, policy.wide, 0.0, np.zeros(3))
    empty = np.zeros((0, 2))
    tracker.roots = {1.0: [_power_root(1.0)], 1.1: [_power_root(1.1)], 2.0: [_power_root(2.0, 3.0)]}
    tracker.tracks = {w: empty for w in tracker.roots}
    nothing = Certified(ResonanceSource(None), RationalFitSource(SampleStore()))
    survey = policy.survey(tracker, _pitch_sample, nothing, {}, sharp=False)
    assert survey.todo == [(2.0 - 1.1, 1.1, 2.0, (1.1 + 2.0) / 2)]  # 1.0-1.1 matched; not 1.1-2.0 (m × 3)
    assert survey.pending == [(1.1, 2.0)] and not survey.stuck and not survey.unresolved
    w1 = 1.1 * (1 + 1e-4)  # narrower than min_step
    tracker.roots = {1.1: [_power_root(1.1)], w1: [_power_root(w1, 3.0)]}
    tracker.tracks = {w: empty for w in tracker.roots}
    survey = policy.survey(tracker, _pitch_sample, nothing, {}, sharp=False)
    assert survey.stuck == [(1.1, w1)] and not survey.todo
    tracker.roots[w1] = tracker.roots[w1] + [_power_root(w1, 5.0), _power_root(w1, 7.0)]  # a pair born
    tracker.tracks = {1.1: np.array([[1.0, 45.0]]), w1: np.array([[1.0, 135.0], [2.0, 225.0], [2.1, 315.0]])}
    survey = policy.survey(tracker, _pitch_sample, nothing, {}, sharp=False)
    assert survey.unresolved == {(1.1, w1): "min_step"} and not survey.stuck and not survey.todo


def test_the_budget_keeps_the_widest_intervals_and_marks_the_rest():
    """With room for two costly frequencies the two widest intervals are sampled, the third is over
    the budget; a frequency a certified model covers is free."""
    policy = _policy(max_samples=12)
    todo = [(0.1, 1.0, 1.1, 1.05), (0.5, 2.0, 2.5, 2.25), (0.3, 3.0, 3.3, 3.15), (0.2, 5.0, 5.2, 5.1)]
    covered = lambda omega: object() if omega == 5.1 else None  # noqa: E731
    batch, over = policy.budget(todo, spent=10, interpolated=0, fitted=covered)
    assert batch == [2.25, 3.15, 5.1] and over == [(0.1, 1.0, 1.1, 1.05)]
    assert runs([(2.0, 3.0), (1.0, 2.0), (5.0, 6.0)]) == [[(1.0, 2.0), (2.0, 3.0)], [(5.0, 6.0)]]


def test_a_source_that_cannot_answer_says_so_and_the_next_one_samples():
    """No resonance model and no fit: the certified sources answer None; a rational fit from too
    few exact samples is not certified; the engine then takes the exact sample (one factorisation)."""
    store = SampleStore()
    fits = RationalFitSource(store)
    certified = Certified(ResonanceSource(None), fits)
    assert certified.sample(1.0) is None and fits.sample(1.0) is None
    assert not ResonanceSource(None).enabled
    for omega in (0.9, 1.1):
        store.keep(_pitch_sample(omega))
    assert not fits.certify(0.95, 1.05, lambda message: None)  # two samples certify nothing
    engine, counter = _engine(_policy())
    sample = engine.sample(2.0)
    assert counter.count == 1 and not sample.reduced and sample.frequency == 2.0
    assert engine.sample(2.0) is sample and counter.count == 1  # kept: not sampled again


def test_the_pole_two_samples_point_to_is_that_of_a_one_pole_transfer_function():
    """``G(s) = R/(s − λ)`` in every entry, samples at ω = 0.8 and 1.2 around λ = −0.01 + 1.0i:
    the fit p(t)/(t − μ) holds it exactly, so the pole is λ (to 1e-9) and its share of G is large."""
    pole = -0.01 + 1.0j
    residue = np.arange(1, 13, dtype=complex).reshape(3, 4)

    def one_pole(omega):
        s = 1j * omega
        return AxisSample(omega, residue / (s - pole), -residue / (s - pole) ** 2)

    found, share = resonance(one_pole(0.8), one_pole(1.2))
    assert abs(found - pole) < 1e-9
    assert share > 0.1


def test_the_loop_on_a_power_law_curve_needs_no_refinement_and_finds_the_exact_crossing():
    """A power law is straight in (log ω, log m, log U*): the tangents predict every root exactly,
    so no interval is refined (8 initial frequencies and ω = 0: 9 samples) and the curve crosses
    m = 100 at the U* and ω of the module docstring (to 1e-8: the Hermite cubic is exact, its root
    is taken from a companion matrix whose higher coefficients vanish only to round-off)."""
    policy = _policy()
    engine, counter = _engine(policy)
    run = engine.run(initial_frequencies(policy.omega_range, 8, None))
    assert counter.count == 9 and len(run.tracker.roots) == 8
    (curve,) = _assemble(run.tracker.roots, run.tracker.tracks, policy.inner)
    omega = math.sqrt((-A + math.sqrt(A * A + B * B / PITCH.zeta_theta**2)) / 2 / (PITCH.r_theta**2 * 100.0))
    ((u, w, _),) = curve.crossings_at(100.0)
    assert u == pytest.approx(_curve(omega, B)[1], rel=1e-8)
    assert w == pytest.approx(omega, rel=1e-8)
    assert run.unresolved == {}  # the curve leaves the mass range inside the frequency range


def test_the_loop_refines_a_curve_that_is_not_a_power_law_until_it_is_resolved():
    """``A_θθ = A + iB(1 + ω)``: the curve bends in log ω, the initial 8 frequencies do not
    resolve it and the loop refines (exact bisections, and rational fits of the samples); at
    tolerance 1e-2 the Hermite curve's crossings of m = 10, 100, 1000 are the analytic ones (m(ω)
    solved by bracketing) to 1e-3 (the error is about the square of the tolerance)."""
    policy = _policy(tolerance=1e-2)
    engine, counter = _engine(policy, slope=True)
    run = engine.run(initial_frequencies(policy.omega_range, 8, None))
    # each frequency (and ω = 0) one exact sample, except those a certified rational fit gave
    assert len(run.tracker.roots) > 8 and counter.count == len(run.tracker.roots) + 1 - run.interpolated
    # m(ω = 10) ≈ 6.5 is inside the mass range: the curve leaves the frequency range at its top
    assert list(run.unresolved.items()) == [((10.0, max(MAX_FREQUENCY, 20.0)), "range")]
    (curve,) = _assemble(run.tracker.roots, run.tracker.tracks, policy.inner)
    for mass in (10.0, 100.0, 1000.0):
        omega = brentq(lambda w, m=mass: math.log(_curve(w, B * (1 + w))[0] / m), 0.01, 20.0, xtol=1e-14)
        ((u, _, _),) = curve.crossings_at(mass)
        assert u == pytest.approx(_curve(omega, B * (1 + omega))[1], rel=1e-3)
    assert FIT_MIN_STEP < policy.min_step


class _Clock:
    """A clock that advances only when told to: ``step`` seconds at each reading."""

    def __init__(self, step: float = 0.0):
        self.now, self.step = 0.0, step

    def __call__(self) -> float:
        self.now += self.step
        return self.now


def _saved(path) -> list[float]:
    return SampleStore(ResumableTable(path, {"flow": "synthetic"}, SAMPLE_FIELDS)).frequencies()


def test_the_store_saves_exact_samples_at_once_and_counts_them_when_read_back(tmp_path):
    """Three exact samples and two from a certified model, with each save far shorter than the
    time between samples: the exact ones are saved as they come, the reduced ones with the next
    save; read back, the samples are sorted by frequency and the three exact ones are the
    factorisations a resumed map reuses."""
    path = tmp_path / "samples.nc"
    clock = _Clock(step=1.0)  # every reading 1 s later: each save "takes" 1 s, 1 s passes between
    store = SampleStore(ResumableTable(path, {"flow": "synthetic"}, SAMPLE_FIELDS), clock=clock)
    for omega in (2.0, 0.5, 1.0):
        clock.now += 100.0  # a sample takes 100 s: at least SAVE_EVERY saves' time
        store.keep(_pitch_sample(omega))
        assert not store.unsaved
    store.keep(AxisSample(1.5, _pitch_sample(1.5).transfer, np.zeros((3, 4)), reduced=True))
    assert store.unsaved and _saved(path) == [0.5, 1.0, 2.0]
    store.keep(AxisSample(0.7, _pitch_sample(0.7).transfer, np.zeros((3, 4)), reduced=True))
    store.save()
    again = SampleStore(ResumableTable(path, {"flow": "synthetic"}, SAMPLE_FIELDS))
    assert again.frequencies() == [0.5, 0.7, 1.0, 1.5, 2.0] and again.reused_factorisations == 3
    assert again[1.5].reduced and not again[2.0].reduced
    assert again.snap(1.0 * (1 + 1e-12)) == 1.0 and again.snap(1.01) == 1.01
    assert again.exact_frequencies().tolist() == [0.5, 1.0, 2.0]


def test_exact_samples_faster_than_the_saves_are_saved_together(tmp_path):
    """Samples that come quicker than SAVE_EVERY saves' time wait for the next save: the first is
    saved at once (no save timed yet), the next ones once SAVE_EVERY times the last save's
    duration has passed since it ended, and :meth:`SampleStore.save` writes the rest."""
    path = tmp_path / "samples.nc"
    clock = _Clock(step=0.5)  # a save "takes" 0.5 s (two readings), each keep reads once more
    store = SampleStore(ResumableTable(path, {"flow": "synthetic"}, SAMPLE_FIELDS), clock=clock)
    store.keep(_pitch_sample(1.0))
    assert _saved(path) == [1.0] and not store.unsaved
    for omega in (1.1, 1.2):  # 1 s and 1.5 s after the save ended: less than SAVE_EVERY × 0.5 s
        store.keep(_pitch_sample(omega))
        assert store.unsaved and _saved(path) == [1.0]
    clock.now += SAVE_EVERY * 0.5
    store.keep(_pitch_sample(1.3))
    assert _saved(path) == [1.0, 1.1, 1.2, 1.3] and not store.unsaved
    store.keep(_pitch_sample(1.4))
    assert store.unsaved
    store.save()
    assert _saved(path) == [1.0, 1.1, 1.2, 1.3, 1.4] and not store.unsaved
    saves = clock.now
    store.save()  # nothing new: no write, the clock not read
    assert clock.now == saves


def test_the_engine_saves_what_it_holds_when_interrupted(tmp_path):
    """A map interrupted at its third exact sample: the first is saved at once, the second kept
    but not yet saved (it came sooner after that save than SAVE_EVERY saves' time), and both are
    in the file all the same: the engine saves however its loop ends."""
    path = tmp_path / "samples.nc"
    clock = _Clock(step=1.0)  # a save "takes" 1 s; the next sample comes 1 s after it
    store = SampleStore(ResumableTable(path, {"flow": "synthetic"}, SAMPLE_FIELDS), clock=clock)
    engine, counter = _engine(_policy(), store=store)

    class Interrupted(Exception):
        pass

    synthetic = engine.sources.exact

    def interrupted(frequencies, later=None):
        for omega in frequencies:
            if counter.count == 2:
                raise Interrupted
            yield synthetic.sample(omega)

    engine.sources.exact = SimpleNamespace(samples=interrupted, sample=synthetic.sample)
    with pytest.raises(Interrupted):
        engine.run(np.array([0.3, 0.6, 1.2]))
    assert not store.unsaved and len(_saved(path)) == 2
    assert SampleStore(ResumableTable(path, {"flow": "synthetic"}, SAMPLE_FIELDS)).reused_factorisations == 2


# --- on the coarse plate --------------------------------------------------------------------------

SETTINGS = dict(mass_range=(3000.0, 8000.0), omega_range=(0.01, 0.2), initial=8)


def test_a_damaged_models_file_is_rebuilt_and_the_counts_add_up_over_a_resume(plate_operators, tmp_path):
    """The map of test_transfer_map's s = 0 model (exact samples and one real model at s = 0):
    a rerun factorises nothing and counts the first run's factorisations in total. The models file
    damaged: the rerun reports it, rebuilds the model at s = 0 (one factorisation this run; in
    total the same as the first run's), the file is valid again with the same model to the bit,
    and the map is the same."""
    path = tmp_path / "s.nc"
    first = transfer_neutral_map(plate_operators, Solid(), samples_path=path, **SETTINGS)
    assert first.resonance_models == 1 and first.factorisations_total == first.factorisations > 1
    again = transfer_neutral_map(plate_operators, Solid(), samples_path=path, **SETTINGS)
    assert again.factorisations == 0 and again.factorisations_total == first.factorisations
    models_path = tmp_path / "s_resonance_models.nc"
    identity = ReducedModels(plate_operators, tolerance=1e-7, blocks=40).identity
    (model,) = read_models(models_table(models_path, identity))
    damage(models_path, "flipped")
    messages = []
    rerun = transfer_neutral_map(
        plate_operators, Solid(), samples_path=path, progress=messages.append, **SETTINGS
    )
    assert any("rebuilding 1 reduced models" in m for m in messages)
    # the total: this run's model and the first run's exact samples (its model's file was lost)
    assert rerun.factorisations == 1 and rerun.factorisations_total == first.factorisations
    (rebuilt,) = read_models(models_table(models_path, identity))  # valid again
    assert rebuilt.shift == model.shift and rebuilt.interval == model.interval
    for name in ("jr", "mr", "br0", "br1", "lf", "lm"):
        assert np.array_equal(getattr(rebuilt, name), getattr(model, name)), name
    assert np.array_equal(rerun.frequencies, first.frequencies)
    for m in (3000.0, 6000.0, 8000.0):
        assert rerun.crossings_at(m) == first.crossings_at(m)
