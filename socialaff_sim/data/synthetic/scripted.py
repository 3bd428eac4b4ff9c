"""The output of one interaction script, before placement in the room and corruption."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from .body import N_JOINTS, hand_joint_indices
from .motion import Timeline

__all__ = ["Scripted", "contact_mask"]


@dataclass(frozen=True)
class Scripted:
    """Clean joints, object track and ground truth of one scripted instance (stage frame)."""

    timeline: Timeline
    """Frame rate and sub-event boundaries; its names are the ground-truth sub-events."""
    joints: np.ndarray
    """(T, 2, 25, 3) float64, metres, z up, floor at z = 0: agent 0 then agent 1, Kinect v2 order."""
    object: np.ndarray | None
    """(T, 3) float64, metres: the object's centre, or ``None``."""
    occluded: np.ndarray
    """(T, 2, 25) bool: joints hidden in a contact (tracked with more noise and dropouts)."""


def contact_mask(timeline: Timeline, phases: Iterable[int], hands: Iterable[tuple[int, int]]) -> np.ndarray:
    """(T, 2, 25) bool marking the hand joints of (agent, side) ``hands`` during sub-events ``phases``."""
    mask = np.zeros((timeline.n_frames, 2, N_JOINTS), dtype=bool)
    frames = np.zeros(timeline.n_frames, dtype=bool)
    for k in phases:
        frames[timeline.bounds[k] : timeline.bounds[k + 1]] = True
    for agent, side in hands:
        idx = list(hand_joint_indices(side))
        mask[np.ix_(frames, [agent], idx)] = True
    return mask
