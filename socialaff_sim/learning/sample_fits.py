"""Exact-input memo of the deterministic fits of a sub-event type's sample set, one per run of Algorithm 1.

The initial parse fits every type again at every hard-EM round (:mod:`.initial`) and at every score of a
restructuring candidate (:class:`~.scorer.AffordanceTarget`), though a type's sample set (the intervals the
parses label it) often stays the same from one to the next. What follows from the sample set alone does not
draw from the random stream, so it can be kept; the Gibbs inner loop, which draws, always runs again.

:class:`SampleFits` keeps, for one sample set (identified by its interval keys (instance, start frame, stop
frame), in the order the table stacks them):

* the two motion fits of :class:`~.likelihood.TypeLikelihood` (every available joint in one batch, always the
  same batch);
* the spatial fits of every batch of memo keys a :class:`~.likelihood.TypeLikelihood` asked for, keyed by the
  whole batch: the von Mises fit steps every row of a batch until all rows have converged, so a row's
  value can depend on the other rows fitted with it, and only the same batch gives bitwise the same values;
* the potentials of :func:`~socialaff_sim.model.potentials.fit_type_potentials` by grouping;
* whatever a caller keeps under its own key (:meth:`SampleFits.keep`): the duration fit, the path noise, ...

A value read back is the object computed the first time (callers never write into it), so a run with the
memo is bitwise the run without it (``tests/test_sample_fits.py``).
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import TypeVar

import numpy as np

__all__ = ["SampleFits", "SampleFitsStore"]

T = TypeVar("T")


class SampleFits:
    """What was fitted on one sample set (see the module doc)."""

    def __init__(self) -> None:
        self.motion: tuple[np.ndarray, np.ndarray] | None = None
        """(null log-likelihoods (11,), affordable motion log-likelihoods (11,)) once fitted."""
        self.batches: dict[tuple[int, ...], list[float]] = {}
        """Spatial log-likelihoods of a batch of memo keys, by the batch (in its order)."""
        self._kept: dict[Hashable, object] = {}
        self.hits = 0
        """Look-ups answered from the memo (for the benchmarks)."""
        self.misses = 0
        """Look-ups computed."""

    def batch(self, keys: tuple[int, ...], compute: Callable[[], list[float]]) -> list[float]:
        """The spatial terms of the batch ``keys``: the stored ones, else ``compute()`` (stored)."""
        hit = self.batches.get(keys)
        if hit is not None:
            self.hits += 1
            return hit
        self.misses += 1
        value = self.batches[keys] = compute()
        return value

    def keep(self, key: Hashable, compute: Callable[[], T]) -> T:
        """The value kept under ``key``, else ``compute()`` (kept): a pure function of the sample set and ``key``."""
        if key in self._kept:
            self.hits += 1
            return self._kept[key]  # type: ignore[return-value]
        self.misses += 1
        value = self._kept[key] = compute()
        return value


class SampleFitsStore:
    """The :class:`SampleFits` of every sample set seen in one run (the tracks, atoms and settings fixed)."""

    def __init__(self) -> None:
        self._sets: dict[tuple[tuple[int, int, int], ...], SampleFits] = {}

    def __len__(self) -> int:
        return len(self._sets)

    def of(self, keys: tuple[tuple[int, int, int], ...]) -> SampleFits:
        """The fits of the sample set of interval ``keys`` (instance, start frame, stop frame), in stacking order."""
        fits = self._sets.get(keys)
        if fits is None:
            fits = self._sets[keys] = SampleFits()
        return fits

    @property
    def hits(self) -> int:
        """Look-ups answered from the memo over all sample sets."""
        return sum(f.hits for f in self._sets.values())

    @property
    def misses(self) -> int:
        """Look-ups computed over all sample sets."""
        return sum(f.misses for f in self._sets.values())
