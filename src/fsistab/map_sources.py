"""Where a transfer map's samples ``G(iω)``, ``dG/ds`` come from (docs/model.md §7): each source
answers "``G`` and ``dG/ds`` at this frequency" or says it cannot (None).

- :class:`ExactSource`: one sparse factorisation per frequency (:func:`fsistab.transfer.exact_transfer`),
  always answers; many frequencies are factorised ``threads`` at a time.
- :class:`ReducedSource`: reduced Krylov models of the fluid (:class:`fsistab.reduced_model.ReducedModels`)
  certified on intervals; a frequency close to an exact sample (a region being refined) gets a new
  model built there.
- :class:`ResonanceSource`: with exact samples elsewhere, one reduced model at a sharp resonance (the
  wake mode) or at ``s = 0``, whose certified interval then costs no factorisation.
- :class:`RationalFitSource`: certified rational fits of the exact samples around a run of
  intervals (:func:`fsistab.rational_fit.certified_transfer`), no factorisation.

The map engine (:mod:`fsistab.map_engine`) asks them in that order of cost: the certified models
(:class:`Certified`: resonance models, then fits), the reduced models, the exact sample.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Sequence
from typing import Protocol

import numpy as np

from fsistab.errors import ConvergenceError
from fsistab.linalg import FactorCounter
from fsistab.map_roots import AxisSample
from fsistab.map_samples import SampleStore
from fsistab.operators import FluidOperators
from fsistab.rational_fit import TransferFit, certified_transfer
from fsistab.reduced_model import ReducedModels
from fsistab.transfer import Deferred, exact_transfer, iter_transfer_samples

# the exact samples' solves are not refined: with the symmetric nested-dissection analysis the plain
# solve's G differs from the refined one by at most 3e-13 (dG/ds 3e-12, relative), far below the
# certification of the fits (1e-6); it halves the solves' cost
SAMPLE_REFINE = False
REFINEMENT_RADIUS = 0.05  # before any reduced model: distance to an exact sample that calls for one
# with exact samples, a sharp resonance (or s = 0) is sampled by a reduced fluid model of this many
# Krylov blocks, certified to RESONANCE_TOLERANCE (one factorisation, fsistab.reduced_model)
RESONANCE_BLOCKS = 40
RESONANCE_TOLERANCE = 1e-7
# a run of unresolved intervals is refined on with a certified rational fit of the exact samples
# around it, this many on each side (more on a retry)
FIT_MARGINS = (10, 16)

Say = Callable[[str], None]


class SampleSource(Protocol):
    def sample(self, omega: float) -> AxisSample | None:
        """``G`` and ``dG/ds`` at ``s = iω`` (``s = 0`` for ``omega = 0``), or None if this source
        cannot give them there."""
        ...


class ExactSource:
    """Exact samples of ``fluid``: one factorisation each, counted by ``counter``; batches
    factorised ``threads`` at a time (:class:`fsistab.map_distributed.DistributedExactSource`: on
    dask workers). ``seconds``: the wall time of the batches so far (the phase workers share)."""

    def __init__(self, fluid: FluidOperators, counter: FactorCounter, threads: int | None = None):
        self.fluid, self.counter, self.threads = fluid, counter, threads
        self.seconds = 0.0

    def sample(self, omega: float) -> AxisSample:
        s = 1j * omega if omega > 0 else 0.0
        g, dg = exact_transfer(self.fluid, s, self.counter, derivative=True, refine=SAMPLE_REFINE)
        return AxisSample(omega, g, dg)

    def samples(self, frequencies: Sequence[float], later: Deferred | None = None) -> Iterator[AxisSample]:
        """Exact samples at ``frequencies`` (> 0), and at those ``later`` gives when its futures
        are done, yielded as they finish (:func:`fsistab.transfer.iter_transfer_samples`): an
        interruption loses those under way only."""
        frequency = {complex(1j * w): w for w in frequencies}
        shifts = list(frequency)

        def later_shifts() -> list[complex]:
            extra = {complex(1j * w): w for w in later.items()}
            frequency.update(extra)
            return list(extra)

        start = time.perf_counter()
        found = iter_transfer_samples(
            self.fluid,
            shifts,
            self.counter,
            refine=SAMPLE_REFINE,
            threads=self.threads,
            later=Deferred(later.awaited, later_shifts) if later else None,
        )
        try:
            for sample in found:
                yield AxisSample(frequency[sample.s], sample.value, sample.rate)
        finally:
            self.seconds += time.perf_counter() - start

    def release(self) -> None:
        """Free what the batches hold beyond the map (nothing in this process)."""


class ReducedSource:
    """Samples from reduced fluid models (``models``): from the model whose certified interval
    holds the frequency, or from a new one built there if an exact sample of ``store`` lies within
    two model half-widths (a region being refined); None for an isolated frequency."""

    def __init__(self, models: ReducedModels, store: SampleStore, say: Say):
        self.models, self.store, self.say = models, store, say

    def refined(self, omega: float) -> bool:
        """Whether ``omega`` is close to an exact sample: a model there will serve the refinement."""
        return self.store.near_exact(omega, 2 * (self.models.half_width() or REFINEMENT_RADIUS))

    def will_cover(self, omega: float) -> bool:
        """Whether :meth:`sample` answers at ``omega`` without an exact sample (or tries a model)."""
        return self.models.covering(omega) is not None or self.refined(omega)

    def sample(self, omega: float) -> AxisSample | None:
        model = self.models.covering(omega)
        if model is None and omega > 0 and self.refined(omega):
            try:
                model = self.models.build(omega)
            except ConvergenceError as error:  # no certified interval here: sample exactly
                self.say(str(error))
        if model is None:
            return None
        g, dg = model.transfer(1j * omega if omega > 0 else 0.0, derivative=True)
        return AxisSample(omega, g, dg, reduced=True)


class _AxisModel:
    """A reduced fluid model (:class:`fsistab.reduced_model.KrylovModel`) called as the model of a
    :class:`fsistab.rational_fit.TransferFit` is: ``G(s)`` and, with ``derivative``, ``dG/ds``."""

    def __init__(self, model):
        self.model = model

    def __call__(self, s: complex, derivative: bool = False):
        return self.model.transfer(s, derivative=derivative)


def _model_cover(model, tolerance: float) -> TransferFit:
    """A reduced model as a certified local model of ``G`` on its certified interval."""
    return TransferFit(model.interval[0], model.interval[1], _AxisModel(model), tolerance)


def _cover_of(fits: Sequence[TransferFit], omega: float) -> TransferFit | None:
    return next((f for f in fits if f.covers(omega)), None)


def _fitted_sample(fit: TransferFit | None, omega: float) -> AxisSample | None:
    if fit is None:
        return None
    g, dg = fit.transfer(omega)
    return AxisSample(omega, g, dg, reduced=True)


class ResonanceSource:
    """With exact samples, reduced models at sharp resonances and at ``s = 0`` (``models``, saved
    and reused; None: no such models), each a certified local model of ``G`` on its interval. Their
    factorisations are counted apart by the models' own counter (they are built beside exact
    samples, in another thread) and charged to the map's counter by :meth:`charge`."""

    def __init__(self, models: ReducedModels | None):
        self.models = models
        self.built = models.counter if models is not None else FactorCounter()
        existing = models.models if models is not None else []
        self.covers: list[TransferFit] = [_model_cover(m, RESONANCE_TOLERANCE) for m in existing]

    @property
    def enabled(self) -> bool:
        return self.models is not None

    def cover(self, omega: float) -> TransferFit | None:
        return _cover_of(self.covers, omega)

    def sample(self, omega: float) -> AxisSample | None:
        return _fitted_sample(self.cover(omega), omega)

    def build(self, omega: float, say: Say) -> TransferFit | None:
        """A reduced model at the resonance ``omega`` (at s = 0, real, for ``omega`` = 0) as a
        certified local model of ``G``, not yet added (:meth:`add`); None if it certifies nothing."""
        try:
            model = self.models.build(omega)
        except ConvergenceError as error:  # no certified interval: exact samples there
            say(str(error))
            return None
        return _model_cover(model, RESONANCE_TOLERANCE)

    def add(self, covers) -> None:
        self.covers.extend(c for c in covers if c is not None)

    def charge(self, counter: FactorCounter) -> None:
        """Add the factorisations of the models built so far to ``counter``."""
        counter.count += self.built.count
        self.built.count = 0


class RationalFitSource:
    """Certified rational fits of the exact samples of ``store`` (:meth:`certify`), each a local
    model of ``G`` on its interval; ``margins``: exact samples taken on each side of the interval
    (the next on a retry)."""

    def __init__(self, store: SampleStore, margins: Sequence[int] = FIT_MARGINS):
        self.store, self.margins = store, tuple(margins)
        self.fits: list[TransferFit] = []

    def cover(self, omega: float) -> TransferFit | None:
        return _cover_of(self.fits, omega)

    def sample(self, omega: float) -> AxisSample | None:
        return _fitted_sample(self.cover(omega), omega)

    def fit_around(self, low_end: float, high_end: float, beyond: int = 0) -> TransferFit | None:
        """A rational fit of the exact samples around ``[low_end, high_end]``, certified there,
        the interval first widened to the ``beyond``-th exact sample outside it on each side."""
        exact = self.store.exact_frequencies()
        first, last = np.searchsorted(exact, low_end, "right") - 1, np.searchsorted(exact, high_end, "left")
        if beyond:
            first, last = max(first - beyond, 0), min(last + beyond, len(exact) - 1)
            low_end, high_end = float(exact[first]), float(exact[last])
        for margin in self.margins:
            window = exact[max(first - margin, 0) : last + margin + 1]
            data = [self.store[w] for w in window]
            fit = certified_transfer(
                window, [x.transfer for x in data], [x.rate for x in data], (low_end, high_end)
            )
            if fit is not None:
                return fit
        return None

    def certify(self, low_end: float, high_end: float, say: Say, beyond: int = 0) -> bool:
        """Whether a fit is certified around ``[low_end, high_end]`` (:meth:`fit_around`; kept)."""
        fit = self.fit_around(low_end, high_end, beyond)
        if fit is not None:
            self.fits.append(fit)
            say(f"a rational fit certified on ω ∈ [{fit.low:.5g}, {fit.high:.5g}] (error {fit.error:.1e})")
        return fit is not None


class Certified:
    """The certified local models of ``G`` of a map: the resonance models, then the rational fits
    (the first covering a frequency answers)."""

    def __init__(self, resonances: ResonanceSource, fits: RationalFitSource):
        self.resonances, self.fits = resonances, fits

    def fitted(self, omega: float) -> TransferFit | None:
        """The certified model covering ``omega`` (a resonance model first), or None."""
        return self.resonances.cover(omega) or self.fits.cover(omega)

    def spanned(self, w0: float, w1: float) -> bool:
        """Whether one certified model covers both ends of ``[w0, w1]``."""
        return any(f.covers(w0) and f.covers(w1) for f in (*self.resonances.covers, *self.fits.fits))

    def sample(self, omega: float) -> AxisSample | None:
        return _fitted_sample(self.fitted(omega), omega)
