"""Frame regression: agent 1's key joints at every frame of a sub-event given agent 0's at that frame.

The paper synthesizes the frames inside a sub-event by interpolating between its ends, so a contact
in the middle of a sub-event (a high five's strike meets the other hand and rebounds) is never
reached. This per-type ridge regression (:func:`~socialaff_sim.model.ridge.fit_ridge`, λ by
leave-one-instance-out error) predicts agent 1's five key joints at each frame from what is
observed at that frame.

Context (relative to the anchor, agent 0's base at the frame, canonical metres): agent 0's other four
key joints, the object (when the model uses one), agent 1's five key joints on the instance's
reference frame (T0 − 1, the last observed before synthesis), the anchor itself, the phase
u ∈ (0, 1] of the frame in its interval and u², and agent 1's reference pose scaled by u. The last
part lets agent 1's way from where it was last observed grow with the phase: its distance to agent 0
shrinks over an approach in proportion to how far the approach has got, a product the ridge cannot
form from u and the pose alone.
Target: agent 1's five key joints relative to the anchor (15 values); as for the end regression,
the ridge may shrink toward agent 1's pose at the reference frame (:func:`offset_columns`).
"""

from __future__ import annotations

import numpy as np

from ..data.skeletons import N_KEY
from .joints import OBJECT
from .nan_fill import nan_to_zero
from .ridge import RidgeRegression, fit_ridge

__all__ = ["fit_frame_regression", "frame_context", "frame_samples", "frame_offset_columns", "n_frame_context"]


def n_frame_context(available: np.ndarray) -> int:
    """Length of the frame context for a model using the joints ``available`` (11,)."""
    return 3 * ((N_KEY - 1) + 2 * N_KEY + 1 + int(bool(available[OBJECT]))) + 2


def frame_offset_columns(available: np.ndarray) -> np.ndarray:
    """(15,) int64: the frame context's columns of agent 1's key joints at the reference frame, in target order."""
    start = 3 * ((N_KEY - 1) + int(bool(available[OBJECT])))
    return np.arange(start, start + 3 * N_KEY)


def frame_context(frames: np.ndarray, reference: np.ndarray, phase: np.ndarray, available: np.ndarray) -> np.ndarray:
    """(M, C) context of M frames (M, 11, 3) of instances whose reference frame was ``reference``
    (M, 11, 3), at phases ``phase`` (M,); absent joints read as 0."""
    frames = np.asarray(frames, float)
    anchor = frames[:, 0:1]
    parts = [frames[:, 1:N_KEY] - anchor]
    if available[OBJECT]:
        parts.append(frames[:, OBJECT : OBJECT + 1] - anchor)
    parts += [np.asarray(reference, float)[:, N_KEY : 2 * N_KEY] - anchor, anchor]
    x = nan_to_zero(np.concatenate([p.reshape(frames.shape[0], -1) for p in parts], axis=1))
    u = np.asarray(phase, float)[:, None]
    return np.concatenate([x, u, u**2, u * x[:, frame_offset_columns(available)]], axis=1)


def frame_samples(
    tracks: list[np.ndarray], spans: list[list[tuple[int, int, int]]], s: int, reference: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every frame of every interval labelled ``s``: frames (M, 11, 3), their instance's reference
    frame (M, 11, 3) (frame ``reference``, or the last if the instance is shorter), their phase (M,)
    = (f − start + 1) / (stop − start), and their instance index (M,)."""
    frames, refs, phases, groups = [], [], [], []
    for i, (x, sp) in enumerate(zip(tracks, spans, strict=True)):
        for a, b, lab in sp:
            if lab != s:
                continue
            f = np.arange(a, b)
            frames.append(x[f])
            refs.append(np.repeat(x[min(reference, len(x) - 1)][None], f.size, axis=0))
            phases.append((f - a + 1) / (b - a))
            groups.append(np.full(f.size, i))
    if not frames:
        J = tracks[0].shape[1] if tracks else 11
        return np.zeros((0, J, 3)), np.zeros((0, J, 3)), np.zeros(0), np.zeros(0, np.int64)
    return np.concatenate(frames), np.concatenate(refs), np.concatenate(phases), np.concatenate(groups)


def fit_frame_regression(
    frames: np.ndarray, reference: np.ndarray, phase: np.ndarray, groups: np.ndarray, available: np.ndarray, *, sigma_min: float
) -> RidgeRegression | None:
    """Fit one type's frame regression; ``None`` unless the frames come from at least 3 instances."""
    if np.unique(groups).size < 3:
        return None
    frames = np.asarray(frames, float)
    X = frame_context(frames, reference, phase, available)
    Y = np.nan_to_num((frames[:, N_KEY : 2 * N_KEY] - frames[:, 0:1]).reshape(frames.shape[0], -1))
    return fit_ridge(X, Y, groups, sigma_min=sigma_min, offset_columns=frame_offset_columns(available))
