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

With ``raised`` = h_r (``BalanceConfig.plan_velocity_raised``) both are measured only for a frame whose plan at its
end holds a wrist at least h_r above that arm's shoulder (world heights): the strike of a reach above the shoulder (a
high five), not the approach or a reach at the chest's height; in any other frame they are zero, so that the damping
is toward rest there, bit for bit. With ``tilt`` = θ_v (``BalanceConfig.plan_velocity_tilt``) the damping tracks
them only at a physics step whose torso tilts at most θ_v (as the harness's catch measures it), toward rest beyond:
the lean the plan's trunk may bring is bounded below the harness's ``catch_tilt`` (docs/design.md §5, "The standing
mode's high fives: the plan's velocities confined to a raised wrist").
"""

from __future__ import annotations

import mujoco
import numpy as np

from ..errors import ConfigError
from .arm_contacts import wrist_frames, wrist_positions
from .scene import Scene

__all__ = ["PlanVelocity"]


class PlanVelocity:
    """The plan's velocities of one model (see the module docstring): ``feet`` (F,) the foot bodies, ``root`` the
    robot's root body (its subtree's centre of mass), ``torso`` the torso body, ``qadr`` (nq_r,) the robot's
    coordinates in ``qpos``; ``raised`` h_r (m) or ``None`` (no gate), ``wrists`` the two wrist frames as
    (id, is_site) and ``shoulders`` (2,) the two shoulder bodies (left, right; needed with ``raised``);
    ``until_touch`` and ``tilt`` θ_v (degrees or ``None``): :meth:`follows`'s latch and bound."""

    def __init__(self, m: mujoco.MjModel, feet: np.ndarray, root: int, torso: int, qadr: np.ndarray,
                 raised: float | None = None, wrists: tuple[tuple[int, bool], ...] = (),
                 shoulders: np.ndarray | None = None, until_touch: bool = False, tilt: float | None = None) -> None:
        self._m, self._feet, self._root, self._torso, self._qadr = m, np.asarray(feet), int(root), int(torso), qadr
        self._raised, self._wrists = raised, tuple((int(f), bool(site)) for f, site in wrists)
        self._shoulders = None if shoulders is None else np.asarray(shoulders, dtype=np.int64)
        if raised is not None and (len(self._wrists) != 2 or self._shoulders is None or len(self._shoulders) != 2):
            raise ConfigError("PlanVelocity: raised needs the two wrist frames and the two shoulder bodies")
        self.until_touch = until_touch
        """``BalanceConfig.plan_velocity_until_touch``: :meth:`follows` only until an arm's first touch."""
        self.tilt = tilt
        """θ_v (degrees; ``BalanceConfig.plan_velocity_tilt``): :meth:`follows` only while the torso tilts at most
        θ_v, else ``None``."""
        self._start = mujoco.MjData(m)
        self._quat = np.zeros(4)
        self.com = np.zeros(2)
        """(2,) v_c, m/s (world, horizontal)."""
        self.torso = np.zeros(3)
        """(3,) ω_t, rad/s (world)."""

    @classmethod
    def of_scene(cls, scene: Scene, feet: np.ndarray, torso: int, raised: float | None = None,
                 until_touch: bool = False, tilt: float | None = None) -> PlanVelocity:
        """The plan's velocities of ``scene``'s robot: its wrist frames and shoulder bodies for ``raised``."""
        return cls(scene.model, feet, scene.root_body, torso, np.asarray(scene.robot_qadr), raised,
                   tuple(wrist_frames(scene)), scene.limb_body_ids[:2], until_touch, tilt)

    def follows(self, touched: bool, tilt: float) -> bool:
        """Whether the damping tracks the velocities at a physics step (else toward rest): not after an arm's first
        touch (``touched``) with ``until_touch``, nor while the torso tilts (``tilt``, degrees) past ``tilt``."""
        return not (self.until_touch and touched) and (self.tilt is None or tilt <= self.tilt)

    def lift(self, d: mujoco.MjData) -> np.ndarray:
        """(2,) each wrist's height above its shoulder in ``d`` (m, after ``mj_kinematics``; left, right)."""
        return wrist_positions(d, self._wrists)[:, 2] - d.xpos[self._shoulders, 2]  # type: ignore[index]

    def raised(self, end: mujoco.MjData) -> bool:
        """Whether the plan ``end`` holds a wrist at least h_r above its shoulder (always, without ``raised``)."""
        return self._raised is None or bool((self.lift(end) >= self._raised).any())

    def offset(self, d: mujoco.MjData) -> np.ndarray:
        """(2,) the centre of mass's horizontal offset from the middle of the feet in ``d`` (after ``mj_comPos``)."""
        return d.subtree_com[self._root, :2] - d.xpos[self._feet, :2].mean(axis=0)

    def clear(self) -> None:
        """No velocities (a new episode, or a frame without a start to measure from)."""
        self.com[:] = 0.0
        self.torso[:] = 0.0

    def measure(self, q_start: np.ndarray, end: mujoco.MjData, duration: float) -> None:
        """The velocities from the robot coordinates ``q_start`` (nq_r,) to the plan ``end`` (posed, after
        ``mj_kinematics`` and ``mj_comPos``) over ``duration`` (s, > 0); none (:meth:`clear`) unless
        :meth:`raised`."""
        if not self.raised(end):
            self.clear()
            return
        s = self._start
        s.qpos[self._qadr] = q_start
        mujoco.mj_kinematics(self._m, s)
        mujoco.mj_comPos(self._m, s)
        self.com[:] = (self.offset(end) - self.offset(s)) / duration
        rel = end.xmat[self._torso].reshape(3, 3) @ s.xmat[self._torso].reshape(3, 3).T  # world: start → end
        mujoco.mju_mat2Quat(self._quat, rel.ravel())
        mujoco.mju_quat2Vel(self.torso, self._quat, duration)
