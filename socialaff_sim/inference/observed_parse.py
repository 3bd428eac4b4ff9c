"""Parse a whole instance from the observed agent's joints alone (DP over sub-event and end time).

Offline evaluation gives every method agent 0's (and the object's) whole recorded track, but
agent 1's only for the first T0 frames. The sub-events can then be parsed once, over the whole
instance, from what is observed: each candidate interval is scored by the motion (and path-noise)
terms of agent 0's joints and the object plus its log-normal duration, with the learned
transitions (:meth:`~socialaff_sim.model.affordance.AffordanceParameters.observed_log_score`).
Spatial potentials are left out: each needs every member of its group, and the groups mix both
agents. Cut points are every ``step`` frames rather than the learned atoms, whose K-means
descriptions include agent 1's motion.
"""

from __future__ import annotations

import numpy as np

from ..data.skeletons import N_KEY
from ..errors import ModelError
from ..model.affordance import AffordanceParameters
from ..model.joints import OBJECT

__all__ = ["observed_joints", "parse_observed"]


def observed_joints(model: AffordanceParameters) -> np.ndarray:
    """(11,) bool: agent 0's key joints and the object, where the model uses them."""
    mask = np.zeros(model.available_.shape, bool)
    mask[:N_KEY] = True
    mask[OBJECT] = True
    return mask & model.available_


def parse_observed(model: AffordanceParameters, track: np.ndarray, fps: float, *, step: int = 2) -> np.ndarray:
    """Best parse of a canonical ``track`` (T, 11, 3) from the observed joints alone.

    Returns (K, 3) int64 rows (start frame, stop frame exclusive, label) covering [0, T).
    Agent 1's joints are never read (they may be NaN).
    """
    if step < 1:
        raise ModelError(f"parse_observed: step: expected at least 1 frame, found {step}")
    track = np.asarray(track, float)
    T = track.shape[0]
    joints = observed_joints(model)
    if not np.isfinite(track[:, joints]).all():
        raise ModelError("parse_observed: the observed joints (agent 0 and the object) must be finite in every frame")
    bounds = np.unique(np.r_[np.arange(0, T, step), T])
    # Agent 1's joints are unused: fill them so the feature code sees finite numbers.
    x = np.where(joints[None, :, None], track, 0.0)
    _, rows = model.parse_over(x, fps, bounds, lambda feats, s: model.observed_log_score(feats, s, joints))
    if not len(rows):
        return np.array([[0, T, int(np.argmax(model.log_start_probs_))]], dtype=np.int64)
    return rows
