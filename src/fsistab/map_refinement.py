"""The refinement policy of the transfer map: which frequencies to sample next (docs/model.md §8).

The map starts from log-spaced frequencies (:func:`initial_frequencies`, with saved samples) and,
round after round, looks at every interval between neighbouring samples (:meth:`RefinementPolicy.survey`):

- roots not matched by their tangents (:class:`fsistab.map_tracker.RootTracker`): bisect, down to
  ``min_step``; with exact samples an interval already at ``min_step`` goes on with a certified
  rational fit of the samples around it (``stuck``), and with ``fit_first`` such a fit is tried
  before the exact bisections too (``pending``); a fold in ω (a pair born or dying) is no step's,
  and is left as soon as the pair's tangents place it inside the interval with the pair matched
  beyond it (:meth:`fsistab.map_tracker.RootTracker.placed_fold`), or, where a certified model
  makes samples free, once the pair is within the tolerance (:meth:`RefinementPolicy.settle_fold`);
- a curve that may cross the whole mass range inside the interval (:func:`fsistab.map_tracker._swept`):
  bisect down to ``SWEEP_STEP``, unless the change is a pole of the neutral mass or a pair born
  outside the range (its fold placed inside the interval by the tracks' rates, or a young pair at
  ``min_step``);
- a weakly damped fluid pole between the samples (:func:`unresolved_resonance`): sample at its
  frequency, with exact samples through a reduced model there if the resonance is sharp
  (:func:`sharp_resonance`, first round only);
- a curve leaving the lowest frequency inside the mass range: halve it (``follow``).

Each round's frequencies are bounded by the budget (:meth:`RefinementPolicy.budget`): ``max_samples``
frequencies that cost a factorisation (or a reduced model), ``FITTED_SAMPLES`` from rational fits.
An interval that nothing refines further is left unresolved with its reason
(:data:`fsistab.transfer_map.UNRESOLVED_REASONS`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from fsistab.map_roots import AxisSample
from fsistab.map_tracker import SWEEP_STEP, RootTracker
from fsistab.params import MAX_FREQUENCY

# an interval whose samples point to a fluid pole between them, closer to the axis than this many
# half-widths, is sampled at the pole's frequency (:func:`unresolved_resonance`)
RESONANCE_DAMPING = 0.5
RESONANCE_SHARE = 1e-3  # and whose residue makes at least this share of G at the samples
RESONANCE_STEP = 1e-3  # relative width below which no resonance is looked for
RESONANCE_MARGIN = 0.05  # a resonance sample stays this fraction of its interval from either end
# only for a resonance between two initial frequencies, this many times narrower than their
# half-width, whose residue makes at least SHARP_SHARE of G there: an isolated weakly damped mode
# the initial grid steps over (the wake mode), sampled by a reduced model at its pole
SHARP_RESONANCE = 0.1
SHARP_SHARE = 0.02
# with exact samples and a frequency range that starts below this, G(0) and the lowest frequencies
# come from one real reduced model at s = 0, built beside the initial exact samples above this reach
# (those below wait for it)
LOW_MODEL_REACH = 0.1
# the default frequency range is extended down, by halving, while a curve leaves it inside the mass
# range (the flutter curve's restabilisation branch: ω ∝ 1/U* falls as m grows), down to this
LOWEST_FREQUENCY = 1e-4
FIT_MIN_STEP = 1e-7  # rational fits refine down to this relative step (no factorisation)
FIT_FIRST_SPAN = 2  # a fit before exact bisection is certified this many exact samples beyond its run
FITTED_SAMPLES = 4000  # and at most this many interpolated frequencies in one map

# a frequency to sample for an interval: (width, low end, high end, frequency); rounds sort them
Bisection = tuple[float, float, float, float]
Interval = tuple[float, float]


@dataclass
class Survey:
    """What one round found, interval by interval: frequencies to sample (``todo``), intervals at
    ``min_step`` that only a rational fit can refine (``stuck``), intervals where a fit is to be
    tried before bisecting exactly (``pending``), sharp resonances ``(w0, w1, pole)`` for a reduced
    model (``sharp``) and intervals left unresolved with their reasons."""

    todo: list[Bisection] = field(default_factory=list)
    stuck: list[Interval] = field(default_factory=list)
    pending: list[Interval] = field(default_factory=list)
    sharp: list[tuple[float, float, float]] = field(default_factory=list)
    unresolved: dict[Interval, str] = field(default_factory=dict)


class Certificates(Protocol):
    """What the policy asks of the certified local models of ``G`` (resonance models and fits)."""

    def fitted(self, omega: float): ...

    def spanned(self, w0: float, w1: float) -> bool: ...


@dataclass(frozen=True)
class RefinementPolicy:
    """The rules of the module docstring for one map: roots followed on ``wide``, matched within
    ``tolerance`` in ``(log m, log U*)`` on ``inner`` (the mass range), bisections down to the
    relative step ``min_step``; ``exact``: samples are exact where no certified model answers (no
    reduced models), so rational fits refine; ``follow``: a curve leaving the lowest frequency is
    followed below it (down to ``LOWEST_FREQUENCY``)."""

    inner: tuple[float, float]
    wide: tuple[float, float]
    omega_range: tuple[float, float]
    tolerance: float
    min_step: float
    max_samples: int
    exact: bool
    follow: bool = False
    fit_first: bool = True

    def first_frequencies(self, initial: np.ndarray, stored: Sequence[float]) -> list[float]:
        """The ``initial`` frequencies and every stored one in the range (free: use them all)."""
        lowest = LOWEST_FREQUENCY if self.follow else self.omega_range[0]
        saved = [w for w in stored if lowest <= w <= self.omega_range[1]]
        return sorted({*initial.tolist(), *saved})

    def wants_low_model(self) -> bool:
        """Whether ``G(0)`` and the lowest frequencies should come from one model at ``s = 0``."""
        return self.omega_range[0] < LOW_MODEL_REACH

    def survey(
        self,
        tracker: RootTracker,
        samples: Callable[[float], AxisSample],
        certified: Certificates,
        unresolved: dict[Interval, str],
        sharp: bool,
    ) -> Survey:
        """Every interval of ``tracker``'s grid not already ``unresolved``, decided
        (:meth:`decide`); ``samples`` gives the sample at a frequency; ``sharp``: look for sharp
        resonances (with exact samples and resonance models, in the first round)."""
        found = Survey()
        grid = tracker.grid
        for w0, w1 in zip(grid[:-1], grid[1:], strict=True):
            if (w0, w1) not in unresolved:
                self.decide(w0, w1, tracker, samples, certified, sharp, found)
        return found

    def decide(self, w0, w1, tracker, samples, certified, sharp, found: Survey) -> None:
        """Add to ``found`` what the interval ``[w0, w1]`` needs (module docstring)."""
        if not tracker.resolved(w0, w1, self.tolerance, self.inner):
            # a fold in ω is no step's to resolve: it is left once its pair places it, and where
            # samples are free bisected towards it until then; curves too fast for the step are
            # refined on with a rational fit
            fold = tracker.fold(w0, w1)
            if fold and (placed := tracker.placed_fold(w0, w1, self.tolerance, self.inner)):
                self.settle_fold(w0, w1, placed, certified, found)
                return
            covered = certified.spanned(w0, w1)
            if not covered and not fold and self.exact and w1 - w0 < self.min_step * w1:
                found.stuck.append((w0, w1))  # a rational fit of the samples around may go on
                return
            if self.fit_first and not covered and not fold and self.exact:
                found.pending.append((w0, w1))
            smallest, reason = (FIT_MIN_STEP if covered else self.min_step), "min_step"
        elif tracker.swept(w0, w1):
            # a curve may cross the whole range in between: find it
            smallest, reason = SWEEP_STEP, "sweep"
            if w1 - w0 < smallest * w1 and not tracker.swept(w0, w1, settled=True):
                return  # at the finest step: a pole of m, or roots born outside the range
            if tracker.born_outside(w0, w1, young=w1 - w0 < self.min_step * w1):
                return  # a pair born outside the range on one side, at a fold found: never in it
            if self.fit_first and self.exact and not certified.spanned(w0, w1):
                found.pending.append((w0, w1))
        elif (pole := unresolved_resonance(samples(w0), samples(w1))) is not None:
            # a weakly damped fluid mode between the samples (its VIV curves may leave no root at
            # either): sample at its pole, from a reduced model there if the resonance is sharp
            if sharp and certified.fitted(pole) is None and sharp_resonance(samples(w0), samples(w1)):
                found.sharp.append((w0, w1, pole))
            found.todo.append((w1 - w0, w0, w1, pole))
            return
        else:
            return
        if w1 - w0 < smallest * w1:
            found.unresolved[(w0, w1)] = reason
        else:
            found.todo.append((w1 - w0, w0, w1, 0.5 * (w0 + w1)))

    def settle_fold(self, w0, w1, placed: tuple[float, float, float], certified, found: Survey) -> None:
        """A fold in ω placed by its pair (:meth:`fsistab.map_tracker.RootTracker.placed_fold`:
        the pair's frequency, the fold's offset, the pair's chord): left as a ``fold``, the curve
        joined through it between the pair, unless a certified model covers the interval and the
        chord is longer than the tolerance. Then a free sample three quarters of the way to the
        fold brings a pair closer to it (the chord goes as the square root of the distance): a
        midpoint past the fold would hold no pair."""
        at, offset, chord = placed
        closer = at + 0.75 * offset
        free = certified.spanned(w0, w1) and abs(closer - at) >= FIT_MIN_STEP * at
        if free and chord > self.tolerance:
            found.todo.append((w1 - w0, w0, w1, closer))
        else:
            found.unresolved[(w0, w1)] = "fold"

    def below(self, tracker: RootTracker) -> Bisection | None:
        """Half the lowest frequency if a curve leaves the grid there inside the mass range."""
        lowest = tracker.grid[0]
        if self.follow and lowest / 2 >= LOWEST_FREQUENCY and tracker.leaves(lowest, self.inner):
            return (lowest / 2, 0.0, lowest, lowest / 2)
        return None

    def budget(
        self, todo: list[Bisection], spent: int, interpolated: int, fitted: Callable[[float], object]
    ) -> tuple[list[float], list[Bisection]]:
        """The round's frequencies to sample and the bisections over the budget: at most
        ``max_samples`` frequencies that cost a factorisation (``spent`` so far; widest intervals
        first), and those a certified model covers while fewer than ``FITTED_SAMPLES`` came from
        rational fits (``interpolated``)."""
        room = max(self.max_samples - spent, 0)
        free = [item for item in todo if fitted(item[-1]) is not None]
        costly = [item for item in sorted(todo, reverse=True) if fitted(item[-1]) is None]
        over = costly[room:] + (free if interpolated >= FITTED_SAMPLES else [])
        batch = [omega for *_, omega in costly[:room] + (free if interpolated < FITTED_SAMPLES else [])]
        return batch, over

    def range_ends(self, tracker: RootTracker) -> dict[Interval, str]:
        """The intervals beyond the grid's ends where a curve leaves it inside the mass range."""
        grid, ends = tracker.grid, {}
        if tracker.leaves(grid[0], self.inner):
            ends[(0.0, grid[0])] = "range"
        if tracker.leaves(grid[-1], self.inner):
            ends[(grid[-1], max(MAX_FREQUENCY, 2 * grid[-1]))] = "range"
        return ends


def runs(intervals: list[Interval]) -> list[list[Interval]]:
    """Adjacent intervals (each starting where the last ends) grouped into runs, in order."""
    found: list[list[Interval]] = []
    for interval in sorted(intervals):
        if found and found[-1][-1][1] == interval[0]:
            found[-1].append(interval)
        else:
            found.append([interval])
    return found


def resonance(left: AxisSample, right: AxisSample) -> tuple[complex, float]:
    """The pole ``λ`` of the fluid's transfer function that two samples point to, and the share of
    ``G`` its residue makes at the samples: from one rational fit ``p_e(s)/(s − λ)`` (``p_e``
    quadratic, one per entry of ``G``) to the values and ``dG/ds`` of both samples, in least
    squares (48 equations, 37 unknowns); the share is ``‖p(λ)‖/‖G‖`` in the fit's variable
    ``t = (s − s_mid)/h`` (``h`` the half-width), the pole's part of ``G`` at the ends.

    A weakly damped fluid mode (the wake mode) between two frequencies far apart compared with its
    damping leaves no neutral root at either, but the tails of its pole ``R/(s − λ)`` in ``G`` and
    ``dG/ds`` show: on the plate at Re 2900 (default mesh), samples at ω = 10.47 and 12.31 give
    0.005 + 10.915i with share 0.047 for the wake mode −0.032 + 11.098i. A smooth ``G`` gives a
    pole anywhere with a small share (4e-4 for an exact quadratic in ``s``)."""
    a, b = 1j * left.frequency, 1j * right.frequency
    middle, half = 0.5 * (a + b), 0.5 * (b - a)
    entries = left.transfer.size
    rows, rhs = [], []
    for s, value, rate in ((a, left.transfer, left.rate), (b, right.transfer, right.rate)):
        t = (s - middle) / half  # unknowns: μ = (λ − middle)/half, then p_e's coefficients in t
        for e, (f, df) in enumerate(zip(value.ravel(), half * rate.ravel(), strict=True)):
            # (t − μ) f = p(t) and its t-derivative f + (t − μ) f' = p'(t), at both samples
            equations = ((-f, -t * f, (1, t, t * t)), (-df, -(f + t * df), (0, 1, 2 * t)))
            for coefficient, known, powers in equations:
                row = np.zeros(1 + 3 * entries, dtype=complex)
                row[0], row[1 + 3 * e : 4 + 3 * e] = coefficient, np.negative(powers)
                rows.append(row)
                rhs.append(known)
    matrix = np.array(rows)
    scale = np.linalg.norm(matrix, axis=0)
    scale[scale == 0] = 1.0
    solution = np.linalg.lstsq(matrix / scale, np.array(rhs), rcond=None)[0] / scale
    mu, numerators = solution[0], solution[1:].reshape(entries, 3)
    residue = numerators @ np.array([1.0, mu, mu * mu])
    size = max(np.linalg.norm(left.transfer), np.linalg.norm(right.transfer))
    return complex(middle + half * mu), float(np.linalg.norm(residue) / size) if size > 0 else 0.0


def sharp_resonance(left: AxisSample, right: AxisSample) -> bool:
    """Whether the :func:`resonance` pole between two samples lies closer to the axis than
    ``SHARP_RESONANCE`` half-widths of their interval with a residue of at least ``SHARP_SHARE``
    of ``G``: an isolated resonance that exact bisections would resolve only after many halvings."""
    pole, share = resonance(left, right)
    narrow = abs(pole.real) < SHARP_RESONANCE * 0.5 * (right.frequency - left.frequency)
    return narrow and share >= SHARP_SHARE


def unresolved_resonance(left: AxisSample, right: AxisSample) -> float | None:
    """The frequency at which to sample next if the two samples straddle a resonance they do not
    resolve: the :func:`resonance` pole lies between them, closer to the axis than
    ``RESONANCE_DAMPING`` half-widths, with a residue share above ``RESONANCE_SHARE``; its
    frequency, kept ``RESONANCE_MARGIN`` of the interval from either end. None otherwise, and for
    intervals narrower than ``RESONANCE_STEP`` (relative), where the fit is ill-conditioned."""
    low, high = left.frequency, right.frequency
    if not 0 < low < high or high - low < RESONANCE_STEP * high:
        return None
    pole, share = resonance(left, right)
    if not low < pole.imag < high or abs(pole.real) >= RESONANCE_DAMPING * 0.5 * (high - low):
        return None
    if share < RESONANCE_SHARE:
        return None
    margin = RESONANCE_MARGIN * (high - low)
    return float(min(max(pole.imag, low + margin), high - margin))


def default_frequency_range(wake_frequency: float | None) -> tuple[float, float]:
    """``ω`` from 0.01 to ``max(20, 1.5 ω_wake)``: flutter below ω ≈ 2 and VIV around the wake."""
    return (0.01, 20.0 if wake_frequency is None else max(20.0, 1.5 * wake_frequency))


def initial_frequencies(
    omega_range: tuple[float, float], count: int, wake_frequency: float | None
) -> np.ndarray:
    """Log-spaced frequencies over ``omega_range``, and 24 more within ±10 % of the wake frequency
    (VIV windows are narrow in ω)."""
    grid = np.geomspace(*omega_range, count)
    if wake_frequency is not None:
        grid = np.concatenate([grid, np.linspace(0.9, 1.1, 24) * wake_frequency])
    return np.unique(grid[(grid >= omega_range[0]) & (grid <= omega_range[1])])
