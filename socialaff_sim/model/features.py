"""Features of sub-event intervals: end-frame configuration, displacement and duration."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from .path import path_residuals

__all__ = ["IntervalFeatures", "interval_features", "polar", "type_samples"]


@dataclass(frozen=True)
class IntervalFeatures:
    """What the potentials see of M candidate intervals of one or more instances."""

    end: np.ndarray
    """(M, 11, 3) float64, metres, canonical frame: the joints at each interval's last frame."""
    disp: np.ndarray
    """(M, 11, 3) float64, metres: each joint's displacement over the interval, from the last frame
    before it (its own first frame for an interval starting at frame 0) to its last frame, so
    the displacements of consecutive sub-events add up to the whole motion."""
    seconds: np.ndarray
    """(M,) float64, seconds: interval lengths, frames / fps."""
    path_sq: np.ndarray | None = None
    """(M, 11) float64, m²: per joint, the summed squared distance of the interval's interior frames
    from the straight path between its ends (:func:`~socialaff_sim.model.path.path_residuals`);
    None where the frames in between are not known (e.g. synthesized candidates)."""
    path_n: np.ndarray | None = None
    """(M,) int64: the number of those interior frames (None with ``path_sq``)."""

    def __len__(self) -> int:
        return int(self.seconds.shape[0])

    def take(self, idx: np.ndarray) -> IntervalFeatures:
        """The features of a subset of the intervals."""
        if self.path_sq is None or self.path_n is None:
            return IntervalFeatures(self.end[idx], self.disp[idx], self.seconds[idx])
        return IntervalFeatures(self.end[idx], self.disp[idx], self.seconds[idx], self.path_sq[idx], self.path_n[idx])

    @staticmethod
    def concat(parts: list[IntervalFeatures], n_joints: int = 11) -> IntervalFeatures:
        """Stack several feature sets (an empty list gives M = 0)."""
        if not parts:
            return IntervalFeatures(
                np.zeros((0, n_joints, 3)), np.zeros((0, n_joints, 3)), np.zeros(0),
                np.zeros((0, n_joints)), np.zeros(0, np.int64),
            )
        with_path = all(p.path_sq is not None and p.path_n is not None for p in parts)
        return IntervalFeatures(
            np.concatenate([p.end for p in parts]),
            np.concatenate([p.disp for p in parts]),
            np.concatenate([p.seconds for p in parts]),
            np.concatenate([p.path_sq for p in parts]) if with_path else None,  # type: ignore[misc]
            np.concatenate([p.path_n for p in parts]) if with_path else None,  # type: ignore[misc]
        )


def interval_features(
    x: np.ndarray, starts: np.ndarray, stops: np.ndarray, fps: float, path_profile: str | None = None
) -> IntervalFeatures:
    """Features of intervals ``[starts[m], stops[m])`` (frames, stop exclusive) of one track.

    ``x``: (T, 11, 3) canonical joints of the instance. Vectorized over the M intervals,
    so a dynamic programme can score every (start, end) candidate at once. ``path_profile``:
    also the path residuals with that time profile (``AffordanceConfig.path_profile``); None: not.
    """
    starts = np.asarray(starts, dtype=np.int64).reshape(-1)
    stops = np.asarray(stops, dtype=np.int64).reshape(-1)
    T = x.shape[0]
    if starts.shape != stops.shape or (starts.size and (starts.min() < 0 or stops.max() > T or np.any(stops <= starts))):
        raise ModelError(
            f"interval_features: expected 0 <= start < stop <= T = {T} for every interval, "
            f"found starts {starts[:5]}... stops {stops[:5]}..."
        )
    end = x[stops - 1]
    before = x[np.maximum(starts - 1, 0)]
    seconds = (stops - starts) / float(fps)
    if path_profile is None:
        return IntervalFeatures(end=end, disp=end - before, seconds=seconds)
    sq, n = path_residuals(x, starts, stops, path_profile)
    return IntervalFeatures(end=end, disp=end - before, seconds=seconds, path_sq=sq, path_n=n)


def polar(v: np.ndarray, eps: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Split vectors ``(..., 3)`` into horizontal distance, vertical distance |dz| (both floored
    at ``eps`` metres) and the horizontal angle atan2(dy, dx) in radians."""
    h = np.maximum(np.hypot(v[..., 0], v[..., 1]), eps)
    vz = np.maximum(np.abs(v[..., 2]), eps)
    return h, vz, np.arctan2(v[..., 1], v[..., 0])


def type_samples(
    tracks: list[np.ndarray],
    fps: list[float],
    spans: list[list[tuple[int, int, int]]],
    s: int,
    path_profile: str | None = None,
) -> IntervalFeatures:
    """Features of every interval labelled ``s`` in the parses ``spans`` (per instance, rows
    ``(start frame, stop frame, label)``) of canonical ``tracks`` (each (T_i, 11, 3))."""
    parts = []
    for x, f, sp in zip(tracks, fps, spans, strict=True):
        rows = [(f0, f1) for f0, f1, lab in sp if lab == s]
        if rows:
            f0s, f1s = np.array(rows, dtype=np.int64).T
            parts.append(interval_features(x, f0s, f1s, f, path_profile))
    return IntervalFeatures.concat(parts, tracks[0].shape[1] if tracks else 11)
