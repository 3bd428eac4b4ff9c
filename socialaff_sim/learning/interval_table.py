"""Interval features of the training tracks, each computed once per run of Algorithm 1.

The tracks and their atomic intervals stay fixed while Algorithm 1 runs, yet the hard-EM rounds
(:mod:`.initial`) re-scored every (start atom, end atom) interval of every instance at every round, and
every :class:`~.scorer.AffordanceTarget` the type-level moves build for a score recomputed the features of
its intervals. :class:`IntervalTable` computes them once (per instance, every interval between two atom
bounds in one batch) and hands out the same rows afterwards.

The features of one interval do not depend on the other intervals computed with it
(:func:`~socialaff_sim.model.features.interval_features` gathers frames and sums each interval's own
path residuals in frame order), so a row read from the table is bitwise the row a fresh call would give
(``tests/test_learning_caches.py`` checks it against fresh calls).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import ModelError
from ..model.features import IntervalFeatures, interval_features

__all__ = ["IntervalTable"]


class IntervalTable:
    """Features of intervals of fixed canonical ``tracks`` (each (T_i, 11, 3) metres) at ``fps``, with the path
    residuals of ``path_profile`` (None: without), memoized by (instance, start frame, stop frame)."""

    def __init__(self, tracks: Sequence[np.ndarray], fps: Sequence[float], path_profile: str | None) -> None:
        self.tracks = list(tracks)
        self.fps = [float(f) for f in fps]
        self.path_profile = path_profile
        self._rows: dict[tuple[int, int, int], IntervalFeatures] = {}
        self._pairs: dict[int, tuple[np.ndarray, IntervalFeatures]] = {}

    def all_pairs(self, i: int, bounds: np.ndarray) -> IntervalFeatures:
        """Features of every interval [bounds[a], bounds[b]), a < b, of instance ``i``, in the order of
        ``np.triu_indices(len(bounds), k=1)`` (frames; ``bounds`` the same at every call for one ``i``)."""
        hit = self._pairs.get(i)
        if hit is not None:
            if not np.array_equal(hit[0], bounds):
                raise ModelError(f"IntervalTable.all_pairs: instance {i} was asked with other atom bounds")
            return hit[1]
        b = np.asarray(bounds, dtype=np.int64)
        ia, ib = np.triu_indices(b.shape[0], k=1)
        feats = interval_features(self.tracks[i], b[ia], b[ib], self.fps[i], self.path_profile)
        self._pairs[i] = (b.copy(), feats)
        return feats

    def rows(self, keys: Sequence[tuple[int, int, int]], n_joints: int = 11) -> IntervalFeatures:
        """Features of the intervals ``keys`` (instance, start frame, stop frame), stacked in that order; the
        ones not seen yet are computed in one batch per instance."""
        missing: dict[int, list[tuple[int, int]]] = {}
        for i, f0, f1 in keys:
            if (i, f0, f1) not in self._rows:
                missing.setdefault(i, []).append((f0, f1))
        for i, spans in missing.items():
            spans = list(dict.fromkeys(spans))
            f0s, f1s = np.array(spans, dtype=np.int64).T
            feats = interval_features(self.tracks[i], f0s, f1s, self.fps[i], self.path_profile)
            for m, (f0, f1) in enumerate(spans):
                self._rows[(i, f0, f1)] = feats.take(np.array([m]))
        return IntervalFeatures.concat([self._rows[k] for k in keys], n_joints)

    def type_samples(self, spans: Sequence[Sequence[tuple[int, int, int]]], s: int, n_joints: int = 11) -> IntervalFeatures:
        """Features of every interval labelled ``s`` in the parses ``spans`` (per instance, rows (start frame,
        stop frame, label)), instance by instance: :func:`~socialaff_sim.model.features.type_samples`'s rows."""
        return self.rows(self.type_keys(spans, s), n_joints)

    @staticmethod
    def type_keys(spans: Sequence[Sequence[tuple[int, int, int]]], s: int) -> list[tuple[int, int, int]]:
        """The keys (instance, start frame, stop frame) of :meth:`type_samples`'s rows, in its order."""
        return [(i, f0, f1) for i, sp in enumerate(spans) for f0, f1, lab in sp if lab == s]
