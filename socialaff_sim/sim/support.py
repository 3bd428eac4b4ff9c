"""How physical a robot's motion is: the support it gets from anything but its feet, and its effort.

:class:`SupportMeter` reads the physics state after every step and keeps, per
data frame:

* **outside support**: the force of the harness (the weld that holds the
  robot's root to its mocap anchor, or to the spring-mounted carriage of a
  compliant harness, as the generalised force ``Jᵀλ`` of the weld's constraint
  rows on the root's translational coordinates) plus the weight carried by
  gravity compensation (``Σ gravcomp·m·g`` over the robot's bodies), as a
  fraction of the robot's weight ``m·g``: the mean over the frame's physics steps
  and its peak;
* **foot sliding**: the horizontal distance a foot (the subtree of an ankle key
  frame's body) moves while it touches the floor on two consecutive steps, m;
* **penetration**: the deepest robot–floor contact, m;
* **effort**: the largest ratio of an actuator's force to its force limit, and
  whether any servo is saturated (≥ :data:`SATURATED` of its limit) or any robot
  joint is at the end of its range (within :data:`AT_LIMIT` rad).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from .robot_mjcf import subtree_mask
from .scene import Scene

__all__ = ["SupportMeter", "FrameSupport", "SATURATED", "AT_LIMIT"]

SATURATED = 0.99
"""An actuator force at this fraction of its limit or more counts as saturated."""
AT_LIMIT = 1e-3
"""A joint this close (rad or m) to an end of its range counts as at its limit."""


@dataclass(frozen=True)
class FrameSupport:
    """Support and effort figures of one data frame (see the module docstring)."""

    outside_mean: float
    """Mean outside support over the frame's physics steps, fraction of the robot's weight."""
    outside_peak: float
    """Its largest value in the frame."""
    slide: float
    """Horizontal foot sliding in the frame (largest of the feet), m."""
    penetration: float
    """Deepest robot–floor penetration in the frame, m."""
    torque_ratio: float
    """Largest |actuator force| / force limit in the frame (0 without limited actuators)."""
    saturated: float
    """Fraction of the frame's physics steps with a saturated servo."""
    at_limit: float
    """Fraction of the frame's physics steps with a robot joint at the end of its range."""
    tilt_deg: float = 0.0
    """Largest angle in the frame between the torso's up axis and the vertical, degrees (the torso: the
    body both shoulders hang from)."""


def _ancestry(model: mujoco.MjModel, body: int) -> list[int]:
    """``body`` and its ancestors up to (not including) the world."""
    out = [body]
    while int(model.body_parentid[out[-1]]) > 0:
        out.append(int(model.body_parentid[out[-1]]))
    return out


class SupportMeter:
    """Accumulates :class:`FrameSupport` figures; :meth:`reset` before an episode, :meth:`update` after every
    physics step, :meth:`end_frame` after the last step of a data frame."""

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        m = scene.model
        robot_bodies = subtree_mask(m, scene.root_body)
        mass = m.body_mass[robot_bodies]
        self.mass = float(mass.sum())
        """Robot mass, kg."""
        self.weight = self.mass * float(np.linalg.norm(m.opt.gravity))
        """Robot weight, N."""
        self.gravcomp_fraction = float((m.body_gravcomp[robot_bodies] * mass).sum() / self.mass) if self.mass else 0.0
        """Share of the robot's weight carried by gravity compensation (0: real weight)."""
        self._weld = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, "robot_anchor")
        self._root_lin = scene.robot_vadr[:3]
        self._feet = []
        for k in (3, 4):
            fid = int(scene.frame_ids[k])
            body = int(m.site_bodyid[fid]) if scene.frame_kinds[k] == "site" else fid
            inside = subtree_mask(m, body)
            self._feet.append((body, inside[m.geom_bodyid] & scene.robot_geom))
        self._robot_geom = scene.robot_geom
        left = _ancestry(m, int(scene.limb_body_ids[0]))
        right = set(_ancestry(m, int(scene.limb_body_ids[1])))
        self._torso = next((b for b in left[1:] if b in right), scene.root_body)
        d0 = mujoco.MjData(m)
        d0.qpos[scene.robot_qadr] = scene.home_qpos
        mujoco.mj_kinematics(m, d0)
        # The torso's own axis that points up at home (models differ in how their bodies' frames sit).
        self._torso_up = d0.xmat[self._torso].reshape(3, 3).T @ np.array([0.0, 0.0, 1.0])
        lim = np.where(m.actuator_forcelimited[scene.act_ids].astype(bool),
                       np.abs(m.actuator_forcerange[scene.act_ids]).max(axis=1), np.inf)
        self._act_limit = lim
        joints = scene.robot_joint_ids[1:]
        limited = m.jnt_limited[joints].astype(bool)
        self._lim_qadr = m.jnt_qposadr[joints[limited]]
        self._lim_range = m.jnt_range[joints[limited]]
        self._vec = np.zeros(0)
        self._res = np.zeros(m.nv)
        self.frames: list[FrameSupport] = []
        self.reset()

    def reset(self) -> None:
        """Forget everything (a new episode)."""
        self.frames = []
        self._foot_prev: list[np.ndarray | None] = [None, None]
        self.feet_down = (True, True)
        """Whether each foot (left, right) touched the floor at the last physics step."""
        self._clear_frame()

    def _clear_frame(self) -> None:
        self._n = 0
        self._out_sum = self._out_peak = self._slide_max = self._pen = self._ratio = 0.0
        self._slide = [0.0, 0.0]
        self._sat = self._lim = 0
        self._tilt = 0.0

    def harness_force(self, data: mujoco.MjData) -> np.ndarray:
        """(3,) force (N, world frame) the harness weld exerts on the robot's root at the current state."""
        m = self.scene.model
        if self._weld < 0 or data.nefc == 0:
            return np.zeros(3)
        rows = (data.efc_type[: data.nefc] == int(mujoco.mjtConstraint.mjCNSTR_EQUALITY)) & (data.efc_id[: data.nefc] == self._weld)
        if not rows.any():
            return np.zeros(3)
        if self._vec.shape[0] != data.nefc:
            self._vec = np.zeros(data.nefc)
        self._vec[:] = 0.0
        self._vec[rows] = data.efc_force[: data.nefc][rows]
        mujoco.mj_mulJacTVec(m, data, self._res, self._vec)
        return np.array(self._res[self._root_lin])

    def update(self, data: mujoco.MjData) -> None:
        """Account for the physics step just taken."""
        outside = float(np.linalg.norm(self.harness_force(data))) / self.weight + self.gravcomp_fraction
        self._out_sum += outside
        self._out_peak = max(self._out_peak, outside)
        n = data.ncon
        floor = self.scene.floor_geom
        if n and floor >= 0:
            g1, g2 = data.contact.geom[:n, 0], data.contact.geom[:n, 1]
            dist = data.contact.dist[:n]
            other = np.where(g1 == floor, g2, np.where(g2 == floor, g1, -1))
            on_floor = other >= 0
            robot = on_floor & self._robot_geom[np.maximum(other, 0)]
            if robot.any():
                self._pen = max(self._pen, float(-dist[robot].min()))
            for s, (body, geoms) in enumerate(self._feet):
                touching = bool((robot & geoms[np.maximum(other, 0)] & (dist <= 0)).any())
                pos = np.array(data.xpos[body, :2])
                prev = self._foot_prev[s]
                if touching and prev is not None:
                    self._slide[s] += float(np.linalg.norm(pos - prev))
                self._foot_prev[s] = pos if touching else None
            self.feet_down = (self._foot_prev[0] is not None, self._foot_prev[1] is not None)
        else:
            self._foot_prev = [None, None]
            self.feet_down = (False, False)
        if len(self._act_limit):
            ratio = np.abs(data.actuator_force[self.scene.act_ids]) / self._act_limit
            top = float(ratio.max())
            self._ratio = max(self._ratio, top)
            self._sat += top >= SATURATED
        if len(self._lim_qadr):
            q = data.qpos[self._lim_qadr]
            self._lim += bool(((q - self._lim_range[:, 0] <= AT_LIMIT) | (self._lim_range[:, 1] - q <= AT_LIMIT)).any())
        up = data.xmat[self._torso].reshape(3, 3) @ self._torso_up
        self._tilt = max(self._tilt, float(np.degrees(np.arccos(np.clip(up[2], -1.0, 1.0)))))
        self._n += 1

    def end_frame(self) -> FrameSupport:
        """Close the data frame: its figures (also appended to :attr:`frames`)."""
        n = max(self._n, 1)
        fs = FrameSupport(outside_mean=self._out_sum / n, outside_peak=self._out_peak, slide=max(self._slide),
                          penetration=self._pen, torque_ratio=self._ratio, saturated=self._sat / n, at_limit=self._lim / n,
                          tilt_deg=self._tilt)
        self.frames.append(fs)
        self._clear_frame()
        return fs
