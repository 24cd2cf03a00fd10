"""The loop of the transfer map (docs/model.md §8): ask the refinement policy which frequencies to
sample, the sample sources for ``G(iω)`` there, the root tracker for the neutral roots; until the
policy has nothing left to refine.

Each round: survey the intervals (:meth:`fsistab.map_refinement.RefinementPolicy.survey`), certify
rational fits where exact samples cannot go on (``stuck``) or before exact bisections (``pending``),
keep the round within the budget, then sample the round's frequencies — exact ones ``threads`` at a
time, each kept as it finishes (and saved: :class:`fsistab.map_samples.SampleStore`); with sharp
resonances, their reduced models built meanwhile in another thread, the frequencies they may cover
waiting for them — and add their roots.
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

from fsistab.linalg import FactorCounter
from fsistab.map_refinement import FIT_FIRST_SPAN, FITTED_SAMPLES, LOW_MODEL_REACH, RefinementPolicy, runs
from fsistab.map_roots import AxisSample
from fsistab.map_samples import SampleStore
from fsistab.map_sources import (
    Certified,
    ExactSource,
    RationalFitSource,
    ReducedSource,
    ResonanceSource,
)
from fsistab.map_tracker import RootTracker
from fsistab.transfer import Deferred


@dataclass
class MapSources:
    """The sample sources of one map, asked in this order: the certified local models
    (``certified``: resonance models, then rational fits), the reduced models (``reduced``, None
    with exact samples), the exact sample (``exact``)."""

    exact: ExactSource
    resonances: ResonanceSource
    fits: RationalFitSource
    reduced: ReducedSource | None = None
    certified: Certified = field(init=False)

    def __post_init__(self):
        self.certified = Certified(self.resonances, self.fits)


@dataclass
class MapRun:
    """What the loop leaves: the roots (``tracker``), the sample at ω = 0, the intervals left
    unresolved with their reasons, and the count of frequencies sampled from rational fits."""

    tracker: RootTracker
    static: AxisSample
    unresolved: dict[tuple[float, float], str]
    interpolated: int


class MapEngine:
    """One map's loop (module docstring): ``policy`` decides, ``sources`` sample into ``store``,
    ``tracker`` holds the roots; ``counter`` counts the factorisations, ``say`` reports."""

    def __init__(
        self,
        policy: RefinementPolicy,
        sources: MapSources,
        store: SampleStore,
        tracker: RootTracker,
        counter: FactorCounter,
        say: Callable[[str], None],
    ):
        self.policy, self.sources, self.store, self.tracker = policy, sources, store, tracker
        self.counter, self.say = counter, say
        self.unresolved: dict[tuple[float, float], str] = {}

    def run(self, initial) -> MapRun:
        """The map from the ``initial`` frequencies (and every saved one) until nothing is left to
        refine or the budget is spent; the samples not yet saved are saved however it stops."""
        try:
            return self._run(initial)
        finally:
            self.store.save()

    def _run(self, initial) -> MapRun:
        first = self.policy.first_frequencies(initial, self.store.frequencies())
        resonances, certified = self.sources.resonances, self.sources.certified
        if (
            resonances.enabled
            and self.policy.wants_low_model()
            and 0.0 not in self.store
            and certified.fitted(0.0) is None
        ):
            # G is smooth near ω = 0 out to the nearest weakly damped fluid poles: one real model at
            # s = 0 gives G(0) and every frequency up to its certified edge; the initial
            # frequencies below LOW_MODEL_REACH wait for it, the others are sampled meanwhile
            self.prefetch_beside_models(first, [(0.0, LOW_MODEL_REACH, 0.0)])
        else:
            self.prefetch(first)
        static = self.sample(0.0)
        for omega in first:
            self.add(float(omega))
        interpolated = self.interpolated()
        first_round = True  # the intervals of the initial frequencies (and of saved samples)
        while refined := self.round(first_round, interpolated):
            interpolated = self.interpolated()
            first_round = False
            self.store.save()  # the round's samples not yet saved: a rerun samples the same frequencies
            self.say(f"{len(self.tracker.roots)} frequencies, {refined} intervals refined")
        self.unresolved.update(self.policy.range_ends(self.tracker))
        return MapRun(self.tracker, static, self.unresolved, interpolated)

    def round(self, first_round: bool, interpolated: int) -> int:
        """One round of refinement: the number of intervals refined, 0 when there is nothing (or
        no budget) left to sample."""
        policy, certified = self.policy, self.sources.certified
        sharp_wanted = self.sources.resonances.enabled and first_round
        survey = policy.survey(self.tracker, self.store.__getitem__, certified, self.unresolved, sharp_wanted)
        self.unresolved.update(survey.unresolved)
        todo = survey.todo
        for run in runs(survey.stuck):
            # exact samples min_step apart that do not resolve a curve while G is smooth there:
            # refine on with a certified rational fit of the samples around, no factorisation
            if interpolated < FITTED_SAMPLES and self.sources.fits.certify(run[0][0], run[-1][1], self.say):
                todo += [(w1 - w0, w0, w1, 0.5 * (w0 + w1)) for w0, w1 in run]
            else:
                self.unresolved.update({interval: "min_step" for interval in run})
        for run in runs(survey.pending):
            # before bisecting exactly: a fit certified over the run and FIT_FIRST_SPAN exact samples
            # on each side makes these midpoints and the refinement around them free
            if interpolated < FITTED_SAMPLES and certified.fitted(0.5 * (run[0][0] + run[0][1])) is None:
                self.sources.fits.certify(run[0][0], run[-1][1], self.say, FIT_FIRST_SPAN)
        if (below := policy.below(self.tracker)) is not None:
            todo.append(below)  # the curve goes on below: follow it
        if not todo:
            return 0
        # max_samples counts the frequencies whose sample costs a factorisation (or a reduced
        # model); those from a rational fit cost none and have their own cap
        roots = len(self.tracker.roots)
        spent = roots if self.sources.reduced is not None else roots - interpolated
        batch, over = policy.budget(todo, spent, interpolated, certified.fitted)
        if over:
            self.unresolved.update({(w0, w1): "budget" for _, w0, w1, _ in over})
            self.say(f"stopped at {spent} sampled frequencies with {len(over)} intervals unresolved")
        if not batch:
            return 0
        if survey.sharp:
            self.prefetch_beside_models(batch, survey.sharp)
        else:
            self.prefetch(batch)
        for omega in batch:
            self.add(omega)
        return len(todo)

    def interpolated(self) -> int:
        """Frequencies of the grid sampled from certified models, with exact samples elsewhere."""
        return self.store.reduced_among(self.tracker.roots) if self.sources.reduced is None else 0

    def add(self, omega: float) -> None:
        """The roots at ``omega`` (sampled if needed), unless that frequency is known already."""
        if self.tracker.knows(omega):
            return  # the same frequency up to rounding (saved grids, bisections)
        self.tracker.add(self.sample(self.store.snap(omega)))

    def sample(self, omega: float) -> AxisSample:
        """The sample at ``omega`` from the first source that answers (kept in the store)."""
        sources = self.sources
        for source in (sources.certified, sources.reduced, sources.exact):
            if omega in self.store:
                break
            if source is not None and (found := source.sample(omega)) is not None:
                self.store.keep(found)
        return self.store[omega]

    def prefetch(self, frequencies, later: Deferred | None = None) -> None:
        """The exact samples among ``frequencies`` (those no certified or reduced model covers or
        will cover), and among those ``later`` gives, factorised ``threads`` at a time, each kept
        as it finishes."""
        for found in self.sources.exact.samples(self._exact_among(frequencies), later):
            self.store.keep(found)

    def _exact_among(self, frequencies) -> list[float]:
        certified, reduced = self.sources.certified, self.sources.reduced
        return [
            float(w)
            for w in dict.fromkeys(frequencies)
            if w > 0
            and w not in self.store
            and certified.fitted(w) is None
            and (reduced is None or not reduced.will_cover(w))
        ]

    def prefetch_beside_models(self, batch: list[float], sharp: list[tuple[float, float, float]]) -> None:
        """:meth:`prefetch` of ``batch`` while the reduced models at the ``sharp`` resonances
        ``(w0, w1, pole)`` are built in another thread: the frequencies inside their intervals wait
        for them (a model may cover them), the others are factorised meanwhile; those the models do
        not cover join the batch as soon as the models are done."""
        resonances = self.sources.resonances
        waiting = [w for w in batch if any(w0 <= w <= w1 for w0, w1, _ in sharp)]

        def uncovered() -> list[float]:  # called by the exact source once the models are done
            resonances.add([future.result() for future in futures])
            return self._exact_among(waiting)

        others = [w for w in batch if w not in waiting]
        with ThreadPoolExecutor(1) as builder:
            futures = [builder.submit(resonances.build, pole, self.say) for *_, pole in sharp]
            if self.sources.reduced is None:
                self.prefetch(others, Deferred(tuple(futures), uncovered))
            else:  # where reduced models serve depends on the exact samples near: the batch's first
                self.prefetch(others)
                self.prefetch(uncovered())
        resonances.charge(self.counter)
