"""The samples of a transfer map, ``G(iω)`` and ``dG/ds`` by frequency, kept and saved through the
store (:class:`fsistab.store.ResumableTable`): the fluid's whole contribution to the map, reusable
for any solid parameters (docs/model.md §7).

A sample that cost a factorisation is saved as soon as it is computed, unless the last save
ended less than :data:`SAVE_EVERY` times that save's own duration ago: then with the next one.
Each save rewrites the whole file (checksummed), which on a coarse mesh takes longer than a
sample (docs/performance.md, "Writing the samples"), so saving every sample would spend more time
writing than sampling; this way writing stays below about a tenth of the run, and a run killed
outright loses at most that many save-durations of samples (the map saves what it holds at the
end of each round and when it stops, interrupted or not). A sample from a certified model (a
reduced fluid model or a rational fit) is saved with the next save. A rerun reads them back: the
map then samples the same frequencies for free.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from fsistab.map_roots import AxisSample
from fsistab.operators import FluidOperators
from fsistab.store import ResumableTable
from fsistab.transfer import flow_identity

SAMPLE_FIELDS = {"sample": ("frequency", "transfer", "transfer_rate", "reduced")}
SAME_FREQUENCY = 1e-9  # a frequency this close (relative) to a stored one is that one
# an exact sample is saved at once when the last save ended at least this many times that save's
# duration ago (module docstring): writing stays below about 1/SAVE_EVERY of the run
SAVE_EVERY = 10.0


def samples_table(path: Path, fluid: FluidOperators) -> ResumableTable:
    """The resumable table of ``G(iω)`` and ``dG/ds`` at the sampled frequencies of one mesh and
    flow (:func:`fsistab.transfer.flow_identity`): the fluid's whole contribution to the map,
    reusable for any solid parameters. Fields of each ``sample``: ``frequency``, ``transfer`` (G:
    body-axis loads (F_x, F_y, M) [ρ U² L] per unit (h, θ, ḣ, θ̇) ~ e^{st}, s = i·frequency, time
    unit L/U), ``transfer_rate`` (dG/ds), ``reduced`` (1 where G comes from a certified model, not
    a factorisation: :mod:`fsistab.reduced_model` or :mod:`fsistab.rational_fit`)."""
    return ResumableTable(path, flow_identity(fluid), SAMPLE_FIELDS)


def sample_record(sample: AxisSample) -> dict:
    return {
        "frequency": sample.frequency,
        "transfer": sample.transfer,
        "transfer_rate": sample.rate,
        "reduced": int(sample.reduced),
    }


def read_samples(table: ResumableTable) -> dict[float, AxisSample]:
    """The samples of a :func:`samples_table`, by frequency in increasing order."""
    samples = [
        AxisSample(float(r["frequency"]), r["transfer"], r["transfer_rate"], bool(r["reduced"]))
        for r in table.records
    ]
    return {s.frequency: s for s in sorted(samples, key=lambda s: s.frequency)}


class SampleStore:
    """The samples of one map by frequency: those saved in ``table`` by earlier runs (checksummed;
    a damaged file is reported and moved aside by the table), then those added. Without a table
    nothing is saved. ``clock`` (seconds) times the saves (module docstring)."""

    def __init__(self, table: ResumableTable | None = None, clock: Callable[[], float] = time.monotonic):
        self.table = table
        self._samples: dict[float, AxisSample] = read_samples(table) if table is not None else {}
        # the factorisations behind the samples read back (one per exact sample): a resumed map's
        # cost in total is this run's plus theirs
        self.reused_factorisations = sum(not s.reduced for s in self._samples.values())
        self._clock = clock
        self._unsaved = False
        self._last_save_end, self._last_save_seconds = clock(), 0.0

    @classmethod
    def at(cls, path: Path | None, fluid: FluidOperators) -> SampleStore:
        """The store of the samples saved at ``path`` (None: nothing saved)."""
        return cls(samples_table(Path(path), fluid) if path is not None else None)

    def __contains__(self, omega: float) -> bool:
        return omega in self._samples

    def __getitem__(self, omega: float) -> AxisSample:
        return self._samples[omega]

    def frequencies(self) -> list[float]:
        """Every stored frequency, in the order stored."""
        return list(self._samples)

    def keep(self, sample: AxisSample) -> AxisSample:
        """Store a new sample; an exact one is saved at once unless the last save was too recent
        (:data:`SAVE_EVERY`), a reduced one with the next save."""
        self._samples[sample.frequency] = sample
        if self.table is not None:
            self.table.append(sample_record(sample), save=False)
            self._unsaved = True
            since = self._clock() - self._last_save_end
            if not sample.reduced and since >= SAVE_EVERY * self._last_save_seconds:
                self.save()
        return sample

    @property
    def unsaved(self) -> bool:
        """Whether samples were kept since the last save."""
        return self._unsaved

    def save(self) -> None:
        """Write the samples kept since the last save (nothing when there are none)."""
        if self.table is None or not self._unsaved:
            return
        start = self._clock()
        self.table.save()
        self._last_save_end = self._clock()
        self._last_save_seconds = self._last_save_end - start
        self._unsaved = False

    def snap(self, omega: float) -> float:
        """The stored frequency equal to ``omega`` up to rounding, else ``omega``."""
        near = [w for w in self._samples if abs(omega - w) <= SAME_FREQUENCY * omega]
        return near[0] if near else omega

    def exact_frequencies(self) -> np.ndarray:
        """The frequencies ω > 0 of the exact samples (one factorisation each), increasing."""
        return np.array(sorted(w for w, x in self._samples.items() if w > 0 and not x.reduced))

    def near_exact(self, omega: float, radius: float) -> bool:
        """Whether an exact sample at ω > 0 lies within ``radius`` of ``omega``."""
        return any(0 < w and abs(w - omega) <= radius for w, x in self._samples.items() if not x.reduced)

    def any_reduced(self) -> bool:
        return any(x.reduced for x in self._samples.values())

    def reduced_among(self, frequencies) -> int:
        """How many of ``frequencies`` (stored) have a sample from a certified model."""
        return sum(self._samples[w].reduced for w in frequencies)
