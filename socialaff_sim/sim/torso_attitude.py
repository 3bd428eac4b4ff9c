"""The torso's attitude as the balance controller reads it: its tilt from upright, or from the plan's attitude, and
the plan's own lean.

The torso is the body both shoulders hang from (as :class:`~.support.SupportMeter` measures tilt); its up axis is the
world vertical in its own axes at home.
"""

from __future__ import annotations

import mujoco
import numpy as np

from .scene import Scene


class TorsoAttitude:
    """One robot's torso: :attr:`goal` is the plan's attitude (world rotation (3, 3)), set each data frame."""

    def __init__(self, scene: Scene, torso: int, from_plan: bool) -> None:
        self.body = torso
        self.from_plan = from_plan
        """``BalanceConfig.tilt_from_plan``: :meth:`tilt` measures from the plan's attitude, not from upright."""
        self.up = scene.home_data().xmat[torso].reshape(3, 3).T @ np.array([0.0, 0.0, 1.0])
        """(3,) the torso's up axis in its own frame (the world vertical at home)."""
        self.goal = np.eye(3)
        """(3, 3) the plan's torso attitude (world), set by the controller at each data frame's start."""

    def tilt(self, d: mujoco.MjData) -> float:
        """The torso's angle (degrees) from upright, or with :attr:`from_plan` from the plan's attitude."""
        rot = d.xmat[self.body].reshape(3, 3)
        if self.from_plan:  # the angle between the torso's up axis now and in the plan (world)
            up = float((rot @ self.up) @ (self.goal @ self.up))
        else:
            up = float(rot[2] @ self.up)
        return float(np.degrees(np.arccos(min(max(up, -1.0), 1.0))))  # (np.clip's values, without its overhead)

    def plan_lean(self) -> float:
        """The plan's torso angle from upright, degrees (``catch_tilt_lean_roll_free``'s λ)."""
        up = float((self.goal @ self.up)[2])
        return float(np.degrees(np.arccos(min(max(up, -1.0), 1.0))))
