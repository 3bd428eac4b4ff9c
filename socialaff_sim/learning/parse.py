"""Parses of an instance over its atomic time intervals, and the constraints on their labels.

A parse of an instance with A atomic intervals is a partition of the atoms into consecutive
intervals, each with a sub-event label in ``0 .. n_labels − 1``. It is stored as the atom index
at which each interval starts (``starts[0] == 0``) and the labels; atom ``a`` covers frames
``bounds[a] : bounds[a + 1]`` of the instance.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from itertools import combinations, product

import numpy as np

from ..errors import ModelError

__all__ = ["Parse", "ParseSpace", "enumerate_parses"]


@dataclass(frozen=True)
class Parse:
    """Intervals of atoms with their sub-event labels (hashable, immutable)."""

    starts: tuple[int, ...]
    """Atom index at which each interval starts; strictly increasing, first 0."""
    labels: tuple[int, ...]
    """Sub-event label of each interval."""

    def __post_init__(self) -> None:
        if len(self.starts) != len(self.labels) or not self.starts or self.starts[0] != 0:
            raise ModelError(f"Parse: expected starts beginning at 0 and one label per interval, found {self}")

    @property
    def n_intervals(self) -> int:
        return len(self.starts)

    def atom_spans(self, n_atoms: int) -> list[tuple[int, int, int]]:
        """``(first atom, stop atom, label)`` of each interval."""
        stops = self.starts[1:] + (n_atoms,)
        return [(a, b, s) for a, b, s in zip(self.starts, stops, self.labels, strict=True)]


@dataclass(frozen=True)
class ParseSpace:
    """What the proposals need to know about one instance."""

    bounds: np.ndarray
    """(A + 1,) int64: frame at which each atom starts, then T."""
    change: np.ndarray
    """(A + 1,) float64: d_b ∈ [0, 1], the normalized motion change at the start of atom b
    (entries 0 and A are unused)."""
    n_labels: int
    """|S|."""
    distinct_neighbours: bool = True
    """Consecutive intervals must have different labels."""
    max_repeats: int | None = None
    """Most intervals with the same label (``None``: unbounded)."""

    @property
    def n_atoms(self) -> int:
        return int(self.bounds.shape[0] - 1)

    def frame_spans(self, parse: Parse) -> list[tuple[int, int, int]]:
        """``(start frame, stop frame, label)`` of each interval (stop exclusive)."""
        return [(int(self.bounds[a]), int(self.bounds[b]), s) for a, b, s in parse.atom_spans(self.n_atoms)]

    def frame_labels(self, parse: Parse) -> np.ndarray:
        """(T,) int64: the label of every frame."""
        out = np.empty(int(self.bounds[-1]), dtype=np.int64)
        for f0, f1, s in self.frame_spans(parse):
            out[f0:f1] = s
        return out

    def is_valid(self, parse: Parse) -> bool:
        """Whether the parse satisfies the structure and the label constraints."""
        st = parse.starts
        if any(b <= a for a, b in zip(st, st[1:])) or st[-1] >= self.n_atoms:
            return False
        lab = np.asarray(parse.labels)
        if lab.min() < 0 or lab.max() >= self.n_labels:
            return False
        if self.distinct_neighbours and np.any(lab[1:] == lab[:-1]):
            return False
        if self.max_repeats is not None and np.bincount(lab, minlength=self.n_labels).max() > self.max_repeats:
            return False
        return True

    # -- label options, vectorized over the candidate labels --------------------------------
    def _rest_counts(self, labels: tuple[int, ...], drop: slice) -> np.ndarray:
        rest = labels[: drop.start] + labels[drop.stop :]
        return np.bincount(np.asarray(rest, dtype=np.int64), minlength=self.n_labels) if rest else np.zeros(self.n_labels, np.int64)

    def single_options(self, labels: tuple[int, ...], k0: int, k1: int) -> np.ndarray:
        """(S,) bool: labels allowed for one interval replacing intervals ``k0:k1``."""
        S = self.n_labels
        ok = np.ones(S, dtype=bool)
        cand = np.arange(S)
        if self.distinct_neighbours:
            if k0 > 0:
                ok &= cand != labels[k0 - 1]
            if k1 < len(labels):
                ok &= cand != labels[k1]
        if self.max_repeats is not None:
            ok &= self._rest_counts(labels, slice(k0, k1)) + 1 <= self.max_repeats
        return ok

    def pair_options(self, labels: tuple[int, ...], k: int) -> np.ndarray:
        """(S, S) bool: label pairs (left, right) allowed when interval ``k`` is split in two."""
        S = self.n_labels
        l1 = np.arange(S)[:, None]
        l2 = np.arange(S)[None, :]
        ok = np.ones((S, S), dtype=bool)
        if self.distinct_neighbours:
            if k > 0:
                ok &= l1 != labels[k - 1]
            if k + 1 < len(labels):
                ok &= l2 != labels[k + 1]
            ok &= l1 != l2
        if self.max_repeats is not None:
            rest = self._rest_counts(labels, slice(k, k + 1))
            ok &= (rest[:, None] + 1 + (l1 == l2) <= self.max_repeats) & (rest[None, :] + 1 <= self.max_repeats)
        return ok

    def initial_parse(self, n_intervals: int) -> Parse:
        """About ``n_intervals`` equal parts at atom boundaries, labelled 0, 1, 2, … in order."""
        n = max(1, min(n_intervals, self.n_atoms, self.n_labels))
        return self._parse_at(np.arange(1, n) / n)

    def fraction_parse(self, fractions: np.ndarray) -> Parse:
        """Consecutive parts with the given positive fractions (n,) of the instance's frames (normalized),
        cut at the nearest atom boundaries and labelled 0, 1, 2, … in order; parts that collapse onto
        one boundary are dropped and at most ``n_labels`` parts are made."""
        fr = np.asarray(fractions, float)[: self.n_labels]
        return self._parse_at(np.cumsum(fr)[:-1] / fr.sum())

    def _parse_at(self, cuts: np.ndarray) -> Parse:
        """Parts cut at the atom boundaries nearest to the given fractions (increasing, in (0, 1)) of T."""
        A = self.n_atoms
        T = float(self.bounds[-1])
        starts = [0]
        for tgt in T * np.asarray(cuts, float):
            if A < 2:
                break
            b = int(np.argmin(np.abs(self.bounds[1:A] - tgt))) + 1
            if b > starts[-1]:
                starts.append(b)
        return Parse(tuple(starts), tuple(range(len(starts))))


def enumerate_parses(space: ParseSpace) -> Iterator[Parse]:
    """Every valid parse of a (small) space, for exact checks."""
    A = space.n_atoms
    for m in range(A):
        for cut in combinations(range(1, A), m):
            starts = (0,) + cut
            for labels in product(range(space.n_labels), repeat=m + 1):
                p = Parse(starts, labels)
                if space.is_valid(p):
                    yield p
