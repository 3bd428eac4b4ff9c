"""Atomic time intervals (Algorithm 1, line 1): K-means over skeleton frames, then runs of a cluster.

Every training frame is described by the skeletons of both agents (:func:`frame_vectors`): each
agent's wrists and ankles relative to its own base, both bases in the canonical frame, the object
relative to the midpoint of the bases, and the velocities of all these joints (m/s) times
``tau`` seconds, so that frames where the motion changes fall in different clusters. All
training frames are clustered by K-means (Lloyd iterations from a k-means++ start, seeded by the
caller's Generator). In each instance a maximal run of frames in one cluster is an atomic
interval; a run shorter than ``min_frames`` is merged into the neighbouring run whose mean
feature is closer (repeatedly, shortest first), and a run longer than ``max_seconds`` is cut
into equal parts no longer than that, so that sub-event boundaries can be placed to within a
few frames. New instances are cut the same way with the stored centroids. The normalized motion
change d_b at the start of atom b is the distance between the mean joint velocities (m/s) of
atoms b − 1 and b, divided by the largest such distance in the instance (so d_b ∈ [0, 1]).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "kmeans",
    "assign",
    "frame_vectors",
    "split_long",
    "runs_to_atoms",
    "cut_atoms",
    "motion_change",
    "AtomicIntervals",
    "atomic_intervals",
]


def kmeans(x: np.ndarray, k: int, *, rng: np.random.Generator, max_iter: int = 50) -> np.ndarray:
    """Centroids ``(k', D)`` of K-means on ``x`` (N, D); k' = min(k, number of distinct rows)."""
    uniq = np.unique(x, axis=0)
    k = int(min(k, uniq.shape[0]))
    # k-means++ seeding over the distinct rows
    first = int(rng.integers(uniq.shape[0]))
    centres = [uniq[first]]
    d2 = ((uniq - centres[0]) ** 2).sum(axis=1)
    for _ in range(1, k):
        total = d2.sum()
        if total <= 0:
            break
        c = int(rng.choice(uniq.shape[0], p=d2 / total))
        centres.append(uniq[c])
        d2 = np.minimum(d2, ((uniq - uniq[c]) ** 2).sum(axis=1))
    C = np.array(centres)
    prev: np.ndarray | None = None
    for _ in range(max_iter):
        labels = assign(x, C)
        if prev is not None and np.array_equal(labels, prev):
            break
        sums = np.zeros_like(C)
        np.add.at(sums, labels, x)
        counts = np.bincount(labels, minlength=C.shape[0])
        keep = counts > 0
        C = sums[keep] / counts[keep, None]  # drop a cluster that lost all its frames
        prev = labels if keep.all() else None
    return C


def assign(x: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """(N,) int64: index of the nearest centre of each row of ``x``."""
    d2 = (x * x).sum(1)[:, None] - 2.0 * x @ centres.T + (centres * centres).sum(1)[None, :]
    return np.argmin(d2, axis=1)


def frame_vectors(track: np.ndarray, available: np.ndarray, fps: float, tau: float) -> np.ndarray:
    """(T, D) float64: the K-means description of every frame of a canonical track (T, 11, 3)."""
    x = track.copy()
    base0, base1 = track[:, 0], track[:, 5]
    x[:, 1:5] -= base0[:, None]
    x[:, 6:10] -= base1[:, None]
    x[:, 10] -= 0.5 * (base0 + base1)
    vel = np.gradient(track, axis=0) * fps if track.shape[0] > 1 else np.zeros_like(track)
    T = track.shape[0]
    return np.concatenate([x[:, available].reshape(T, -1), tau * vel[:, available].reshape(T, -1)], axis=1)


def split_long(bounds: np.ndarray, max_frames: int) -> np.ndarray:
    """Cut every atom longer than ``max_frames`` into equal parts no longer than that."""
    out = [0]
    for a0, a1 in zip(bounds[:-1].tolist(), bounds[1:].tolist()):
        n = -(-(a1 - a0) // max_frames)
        out.extend(a0 + round(k * (a1 - a0) / n) for k in range(1, n))
        out.append(a1)
    return np.asarray(out, dtype=np.int64)


def runs_to_atoms(labels: np.ndarray, vectors: np.ndarray, min_frames: int) -> np.ndarray:
    """Atom bounds ``(A + 1,)`` from per-frame cluster labels, merging runs shorter than ``min_frames``."""
    T = labels.shape[0]
    cuts = np.flatnonzero(labels[1:] != labels[:-1]) + 1
    bounds = [0, *cuts.tolist(), T]
    while len(bounds) > 2:
        lengths = np.diff(bounds)
        short = int(np.argmin(lengths))
        if lengths[short] >= min_frames:
            break
        n = len(lengths)
        mean = vectors[bounds[short] : bounds[short + 1]].mean(axis=0)

        def dist(a: int) -> float:
            return float(np.linalg.norm(vectors[bounds[a] : bounds[a + 1]].mean(axis=0) - mean))

        if short == 0:
            side = 1
        elif short == n - 1:
            side = -1
        else:
            side = -1 if dist(short - 1) <= dist(short + 1) else 1
        # Remove the boundary between the short run and the chosen neighbour.
        del bounds[short + (1 if side == 1 else 0)]
    return np.asarray(bounds, dtype=np.int64)


def motion_change(track: np.ndarray, available: np.ndarray, bounds: np.ndarray, fps: float) -> np.ndarray:
    """(A + 1,) float64: d_b ∈ [0, 1] at each atom start (entries 0 and A are 0)."""
    A = bounds.shape[0] - 1
    T = track.shape[0]
    vel = (np.gradient(track[:, available], axis=0) * fps).reshape(T, -1) if T > 1 else np.zeros((T, 1))
    means = np.array([vel[bounds[a] : bounds[a + 1]].mean(axis=0) for a in range(A)])
    d = np.zeros(A + 1)
    if A > 1:
        d[1:A] = np.linalg.norm(means[1:] - means[:-1], axis=1)
        top = d.max()
        if top > 0:
            d /= top
    return d


def cut_atoms(
    track: np.ndarray, fps: float, available: np.ndarray, centroids: np.ndarray, *, min_frames: int, max_seconds: float, tau: float
) -> np.ndarray:
    """(A + 1,) int64 atom bounds of one canonical track (T, 11, 3) given K-means centroids."""
    v = frame_vectors(track, available, fps, tau)
    b = runs_to_atoms(assign(v, centroids), v, min_frames)
    return split_long(b, max(min_frames, int(round(max_seconds * fps))))


@dataclass(frozen=True)
class AtomicIntervals:
    """The atoms of every training instance and the centroids that produced them."""

    centroids: np.ndarray
    """(K, D) float64: K-means centroids of the frame descriptions (:func:`frame_vectors`)."""
    bounds: tuple[np.ndarray, ...]
    """Per instance, (A_i + 1,) int64 atom start frames then T_i."""
    change: tuple[np.ndarray, ...]
    """Per instance, (A_i + 1,) float64 normalized motion change d_b."""


def atomic_intervals(
    tracks: Sequence[np.ndarray],
    fps: Sequence[float],
    available: np.ndarray,
    *,
    n_clusters: int,
    min_frames: int,
    max_seconds: float,
    tau: float,
    rng: np.random.Generator,
    max_iter: int = 50,
) -> AtomicIntervals:
    """Cluster all frames of ``tracks`` (each (T_i, 11, 3) canonical) and cut every instance into atoms."""
    vecs = [frame_vectors(t, available, f, tau) for t, f in zip(tracks, fps, strict=True)]
    C = kmeans(np.concatenate(vecs), n_clusters, rng=rng, max_iter=max_iter)
    bounds, change = [], []
    for t, f in zip(tracks, fps, strict=True):
        b = cut_atoms(t, f, available, C, min_frames=min_frames, max_seconds=max_seconds, tau=tau)
        bounds.append(b)
        change.append(motion_change(t, available, b, f))
    return AtomicIntervals(C, tuple(bounds), tuple(change))
