"""The plan's velocities over a data frame: the centre of mass's relative to the feet, and the torso's attitude.

The balance controller's centre-of-mass and torso tasks (:mod:`~.balance_control`) are PD laws toward the IK's plan
at the frame's end. Without a velocity reference their damping brakes toward rest: ``−2ζω_c ċ`` holds the centre of
mass still and ``−2ω_o ω`` the trunk, so a plan that swings its trunk and moves its centre of mass within a few
frames (a high five's strike: the shoulder carried 20 cm forward in three frames) is followed late, and with the
centre of mass's rows weighing 100–10,000 against the joints' 1 the QP takes the swing up by leaning the trunk the
other way (docs/design.md §5, "The standing mode's high fives: the plan's velocities …"). :class:`PlanVelocity` gives
the references the damping then tracks: the plan's change over the frame divided by its duration,

* ``com``: v_c = (o_end − o_start) / T, o the plan's centre of mass's horizontal offset from the middle of its feet
  (the quantity c* carries onto the physical feet, :mod:`~.com_reference`);
* ``torso``: ω_t = log(R_end R_startᵀ) / T, the torso's rotation (world) from the frame's start to its end.
"""

from __future__ import annotations

import mujoco
import numpy as np

__all__ = ["PlanVelocity"]


class PlanVelocity:
    """The plan's velocities of one model (see the module docstring): ``feet`` (F,) the foot bodies, ``root`` the
    robot's root body (its subtree's centre of mass), ``torso`` the torso body, ``qadr`` (nq_r,) the robot's
    coordinates in ``qpos``."""

    def __init__(self, m: mujoco.MjModel, feet: np.ndarray, root: int, torso: int, qadr: np.ndarray) -> None:
        self._m, self._feet, self._root, self._torso, self._qadr = m, np.asarray(feet), int(root), int(torso), qadr
        self._start = mujoco.MjData(m)
        self._quat = np.zeros(4)
        self.com = np.zeros(2)
        """(2,) v_c, m/s (world, horizontal)."""
        self.torso = np.zeros(3)
        """(3,) ω_t, rad/s (world)."""

    def offset(self, d: mujoco.MjData) -> np.ndarray:
        """(2,) the centre of mass's horizontal offset from the middle of the feet in ``d`` (after ``mj_comPos``)."""
        return d.subtree_com[self._root, :2] - d.xpos[self._feet, :2].mean(axis=0)

    def clear(self) -> None:
        """No velocities (a new episode, or a frame without a start to measure from)."""
        self.com[:] = 0.0
        self.torso[:] = 0.0

    def measure(self, q_start: np.ndarray, end: mujoco.MjData, duration: float) -> None:
        """The velocities from the robot coordinates ``q_start`` (nq_r,) to the plan ``end`` (posed, after
        ``mj_kinematics`` and ``mj_comPos``) over ``duration`` (s, > 0)."""
        s = self._start
        s.qpos[self._qadr] = q_start
        mujoco.mj_kinematics(self._m, s)
        mujoco.mj_comPos(self._m, s)
        self.com[:] = (self.offset(end) - self.offset(s)) / duration
        rel = end.xmat[self._torso].reshape(3, 3) @ s.xmat[self._torso].reshape(3, 3).T  # world: start → end
        mujoco.mju_mat2Quat(self._quat, rel.ravel())
        mujoco.mju_quat2Vel(self.torso, self._quat, duration)
