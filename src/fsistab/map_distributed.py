"""A transfer map's exact samples on the workers of a ``dask.distributed`` client (docs/model.md §7):
:class:`DistributedExactSource`, the :class:`fsistab.map_sources.ExactSource` whose batches are
factorised on the workers instead of this process's threads. The map engine, its rounds and its
samples are those of the serial map (:mod:`fsistab.map_engine`); only where the factorisations run
changes.

What is sent, once per map and worker: the sparse blocks of the fluid operators
(:class:`fsistab.operators.FluidOperators` without the steady state, the near-body mass and the
symbolic analyses) and the fill-reducing ordering of this process's analysis
(:func:`fsistab.linalg.analysis_ordering`), scattered to every worker at the first batch. A worker
keeps them in its memory under the scatter's key for every sample of the map, and makes its symbolic
analysis once, on that ordering (:func:`working_operators`): it factorises
``K_ff(iω)`` exactly as this process does, so its ``G(iω)``, ``dG/ds`` are those of the serial map,
bit for bit. Per sample, a frequency goes out and ``G``, ``dG/ds`` (two 3 × 4 complex arrays) come
back. The samples of a batch are submitted together (the scheduler spreads them over the workers)
and returned as they finish: counted there (one factorisation each, the map's counter) and kept by
the engine as they come (:class:`fsistab.map_samples.SampleStore`), so an interruption cancels the
samples not finished and loses only those. A worker that dies loses its sample under way, which
dask computes again on another worker.
"""

from __future__ import annotations

import contextlib
import itertools
import time
import uuid
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import wait
from dataclasses import replace

import numpy as np

from fsistab import umfpack
from fsistab.errors import InputError
from fsistab.linalg import FactorCounter, analysis_ordering, shared_analysis
from fsistab.map_roots import AxisSample
from fsistab.map_sources import SAMPLE_REFINE, ExactSource
from fsistab.operators import FluidOperators
from fsistab.transfer import Deferred, transfer_sample

# the operators a worker process factorises, by map (the scatter's token): the scattered blocks
# with the worker's own symbolic analyses, which stay out of dask's data (they cannot be pickled,
# and dask may copy or spill that data); only the newest map's are kept
_WORKING: dict[str, FluidOperators] = {}


def working_operators(token: str, fluid: FluidOperators, ordering: np.ndarray | None) -> FluidOperators:
    """The operators of map ``token`` in this worker process: ``fluid`` (the scattered blocks, not
    copied) with an analysis dict of its own, analysed once on the client's ``ordering``."""
    if token not in _WORKING:
        _WORKING.clear()
        _WORKING[token] = replace(fluid, analyses={})
        if ordering is not None:
            shared_analysis(_WORKING[token], 1j, ordering=ordering)
    return _WORKING[token]


def forget_operators(token: str) -> None:
    """Drop the operators of map ``token`` from this worker process (the map is done)."""
    _WORKING.pop(token, None)


def remote_sample(token: str, fluid: FluidOperators, ordering: np.ndarray | None, omega: float):
    """``G(iω)`` and ``dG/ds`` on a worker (the task of one exact sample), as
    :meth:`ExactSource.samples` makes them in process (:func:`working_operators`)."""
    sample = transfer_sample(
        working_operators(token, fluid, ordering), complex(1j * omega), refine=SAMPLE_REFINE
    )
    return sample.value, sample.rate


def worker_count(client) -> int:
    """The workers of ``client``'s scheduler now (0 if it cannot say)."""
    try:
        return len(client.scheduler_info()["workers"])
    except Exception:  # an informative figure only
        return 0


class DistributedExactSource(ExactSource):
    """Exact samples of ``fluid`` (one factorisation each, counted by ``counter`` as they arrive)
    computed on the workers of the ``dask.distributed`` ``client`` (module docstring); ``say``
    reports when the operators are sent. A single :meth:`sample` (ω = 0, a frequency outside the
    batches) is made in this process, as in the serial map."""

    def __init__(
        self,
        fluid: FluidOperators,
        counter: FactorCounter,
        client,
        say: Callable[[str], None] | None = None,
    ):
        if not umfpack.available():  # the NGSolve backend needs the steady state, not sent
            raise InputError("maps on dask workers need UMFPACK's symbols in NGSolve's wheel")
        super().__init__(fluid, counter)
        self.client, self.say = client, say or (lambda message: None)
        self._shipped = None  # futures of the operators and ordering on the workers
        self._token = uuid.uuid4().hex[:8]  # the map's tasks are named after it
        self._tasks = itertools.count()

    def _operators(self):
        """The futures of the operators and of the ordering, scattered to every worker at first need."""
        if self._shipped is None:
            ordering = analysis_ordering(self.fluid)
            # the blocks a sample needs: UMFPACK's analyses stay in this process, and neither the
            # steady state (NGSolve's mesh and fields), the near-body mass (mode labels) nor the
            # basis of restricted operators (whole-space fields) is sent
            bare = replace(self.fluid, steady=None, mff_near=None, basis=None, analyses={})
            self._shipped = self.client.scatter([bare, ordering], broadcast=True, hash=False)
            self.say(f"fluid operators sent to {worker_count(self.client)} dask workers")
        return self._shipped

    def samples(self, frequencies: Sequence[float], later: Deferred | None = None) -> Iterator[AxisSample]:
        """Exact samples at ``frequencies`` (> 0) made on the workers, yielded as they finish; then
        those of ``later`` (waited for: on a cluster the workers are many, and the batch short)."""
        yield from self._batch(frequencies)
        if later is not None:
            wait(later.awaited)
            yield from self._batch([float(w) for w in later.items()])

    def _batch(self, frequencies: Sequence[float]) -> Iterator[AxisSample]:
        if not frequencies:
            return
        from distributed import as_completed

        start = time.perf_counter()
        fluid, ordering = self._operators()
        futures = {
            self.client.submit(
                remote_sample,
                self._token,
                fluid,
                ordering,
                float(w),
                key=f"fsistab-sample-{self._token}-{next(self._tasks)}",
                pure=False,
            ): float(w)
            for w in frequencies
        }
        try:
            for future in as_completed(list(futures)):
                value, rate = future.result()
                self.counter.count += 1
                yield AxisSample(futures[future], value, rate)
        finally:  # interrupted: the samples not finished are cancelled
            self.client.cancel([f for f in futures if not f.done()])
            self.seconds += time.perf_counter() - start

    def release(self) -> None:
        """Free the operators on the workers (the map is done)."""
        if self._shipped is not None:
            shipped, self._shipped = self._shipped, None
            # a cleanup that fails (a worker lost, the scheduler gone) must not hide the map's end
            with contextlib.suppress(Exception):
                self.client.cancel(shipped)
                self.client.run(forget_operators, self._token)
