"""Active-hand relabelling: per instance and agent, the wrist that travels farther is called "right".

An actor may do a one-handed action with either hand (a left-handed high five, a left-hand grip).
One joint grouping per sub-event type cannot cover both (docs/design.md), so with
:attr:`~socialaff_sim.model.config.AffordanceConfig.active_hand` the model swaps an agent's left
and right key joints (wrists and ankles together; a relabelling, not a reflection: positions are
unchanged) in every instance where its left wrist's path is the longer. This goes beyond the paper,
whose actors keep one hand.

At synthesis agent 1's flag is unknown: it is the most frequent partner flag seen in training for
agent 0's flag (:func:`fit_hand_coupling`, :func:`partner_flag`), and the synthesized joints are
relabelled back with it.
"""

from __future__ import annotations

import numpy as np

from ..data.skeletons import N_KEY

__all__ = ["KEY_SWAP", "left_active", "wrist_paths", "hand_flags", "relabel", "fit_hand_coupling", "partner_flag"]

KEY_SWAP = np.array([0, 2, 1, 4, 3])
"""Permutation of one agent's key joints (base, left wrist, right wrist, left ankle, right ankle) that swaps sides."""


def left_active(track: np.ndarray, agent: int, stop: int | None = None, margin: float = 0.0) -> bool:
    """Whether agent ``agent``'s left wrist travels farther than its right, by more than ``margin``
    metres, over frames ``[0, stop)``.

    ``track``: (T, 11, 3) model joints, metres (any frame: path lengths are rigid-invariant).
    Frames where a wrist is missing add nothing to its path; a tie (including no motion) is right-handed.
    """
    x = track[:stop, agent * N_KEY + 1 : agent * N_KEY + 3]  # (T', 2, 3): left, right wrist
    steps = np.linalg.norm(np.diff(x, axis=0), axis=-1)  # (T'-1, 2)
    path = np.nansum(steps, axis=0) if steps.size else np.zeros(2)
    return bool(path[0] - path[1] > margin)


def wrist_paths(track: np.ndarray, agent: int) -> np.ndarray:
    """(T, 2) float64 metres: row k holds the path lengths of agent ``agent``'s left and right wrists over
    frames ``[0, k]`` of ``track`` (T, 11, 3), missing frames adding nothing, so that
    ``left_active(track, agent, stop, margin)`` is ``paths[stop − 1, 0] − paths[stop − 1, 1] > margin``
    (up to rounding) in O(1) per query: the causal flag of a long stream at every frame."""
    x = track[:, agent * N_KEY + 1 : agent * N_KEY + 3]
    steps = np.nan_to_num(np.linalg.norm(np.diff(x, axis=0), axis=-1), nan=0.0)
    return np.concatenate([np.zeros((1, 2)), np.cumsum(steps, axis=0)])


def hand_flags(track: np.ndarray) -> np.ndarray:
    """(2,) bool: :func:`left_active` of both agents over the whole ``track`` (T, 11, 3)."""
    return np.array([left_active(track, 0), left_active(track, 1)])


def relabel(track: np.ndarray, flags: np.ndarray) -> np.ndarray:
    """A copy of ``track`` (..., 11, 3) with the key joints of each agent ``a`` where ``flags[a]`` swapped.

    Relabelling is its own inverse: applying it twice with the same flags gives the track back.
    """
    order = np.arange(track.shape[-2])
    for a in range(2):
        if flags[a]:
            order[a * N_KEY : (a + 1) * N_KEY] = a * N_KEY + KEY_SWAP
    return track[..., order, :].copy()


def fit_hand_coupling(flags: np.ndarray, alpha: float = 1.0) -> np.ndarray:
    """(2, 2) float64: p(agent 1 left-active | agent 0's flag) from training ``flags`` (N, 2) bool,
    add-``alpha`` smoothed; row = agent 0's flag (0 right, 1 left), column = agent 1's."""
    f = np.asarray(flags, bool).reshape(-1, 2)
    counts = np.zeros((2, 2))
    np.add.at(counts, (f[:, 0].astype(int), f[:, 1].astype(int)), 1.0)
    counts += alpha
    return counts / counts.sum(axis=1, keepdims=True)


def partner_flag(coupling: np.ndarray, flag0: bool) -> bool:
    """Agent 1's most probable flag given agent 0's (right-handed on a tie)."""
    row = coupling[int(bool(flag0))]
    return bool(row[1] > row[0])
