"""The plan's trunk leaned into an upward reach: how far the IK's base target pitches forward.

A person striking a high five leans 11–13° into it; the retargeting plan's trunk stays upright (its base
orientation is the home one turned to face the partner, the spine held at home), so in the standing mode the
balance controller's torso rows hold the trunk upright while the striking arm's reaction tips it back (traced on
Stubby's high fives, docs/design.md §5). With ``StanceConfig.strike_lean`` k_l the plan leans its base forward,
about the heading's lateral axis, by

    θ = min(θ_max, k_l · max_i max(0, (w_i − s_i) · x))   over the arms i whose wrist target stands at least h_l
    above that arm's shoulder ((w_i − s_i) · z ≥ h_l),

w_i the wrist target and s_i the shoulder at its home offset from the base target, both in the robot's frame (x its
heading toward the partner, z up): the farther the raised wrist reaches ahead of its shoulder, the more the trunk
leans, at most θ_max (the issue's rule: the torso within 10° of upright unless the motion calls for a lean). A reach
at or below the shoulder (a handshake, a hand over, a pull-up's grasp) or behind it leans nothing.

With ``StanceConfig.strike_lean_out`` N the lean is ramped out once every contact sub-goal of the task has been met
(the hands have met): n frames after the meeting the plan leans θ · max(0, 1 − n/N) (:func:`lean_out`), so that the
leaned plan stops pressing the person after the meeting instead of holding the lean to the episode's end.
"""

from __future__ import annotations

import numpy as np

__all__ = ["strike_lean", "lean_out"]


def strike_lean(targets: np.ndarray, shoulders: np.ndarray, gain: float, most: float, raised: float) -> float:
    """The plan's forward lean θ (radians, ≥ 0) for robot-frame key-frame ``targets`` (5, 3) (base, left wrist,
    right wrist, left ankle, right ankle; metres) and the shoulders' home offsets from the base ``shoulders`` (2, 3)
    (left, right; metres, robot frame): ``gain`` k_l (degrees per metre of the raised wrist's reach ahead of its
    shoulder), ``most`` θ_max (degrees), ``raised`` h_l (metres, the wrist's least height above its shoulder).
    A wrist target that is not finite leans nothing."""
    t = np.asarray(targets, dtype=np.float64)
    s = t[0] + np.asarray(shoulders, dtype=np.float64)  # (2, 3) the shoulders, robot frame
    d = t[1:3] - s  # (2, 3) each wrist target from its shoulder
    ok = np.isfinite(d).all(axis=1) & (d[:, 2] >= raised)
    if not ok.any():
        return 0.0
    ahead = float(np.max(np.where(ok, d[:, 0], 0.0)))
    return float(np.radians(min(most, gain * max(0.0, ahead))))


def lean_out(lean: float, since: int | None, frames: int | None) -> float:
    """The lean ``lean`` (radians) ramped out ``since`` frames (≥ 0) after the task's sub-goals were all met, over
    ``frames`` N frames: θ · max(0, 1 − since/N); ``since`` ``None`` (not met yet) or ``frames`` ``None`` (the option
    off): the lean as given; N ≤ 0 drops it at the meeting."""
    if since is None or frames is None:
        return float(lean)
    if frames <= 0:
        return 0.0
    return float(lean) * max(0.0, 1.0 - max(0, since) / frames)
