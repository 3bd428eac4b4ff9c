"""Standing balance of the retargeting IK while both feet are planted.

:class:`StandingBalance` holds what the IK adds when the robot stands on both
feet: the support rectangle the centre of mass may not leave
(:class:`~.support_limit.SupportPolygonLimit`, ``IKConfig.support_margin``) and,
optionally, a :class:`mink.ComTask` drawing the centre of mass toward the
rectangle's centre (``IKConfig.com_cost``). Both read the centre of mass of body
1's subtree (mink's convention), which must be the robot's root.
"""

from __future__ import annotations

from collections.abc import Sequence

import mink
import mujoco
import numpy as np

from ..errors import SimulationError
from .ik_config import IKConfig
from .support_limit import SupportPolygonLimit, support_box

__all__ = ["StandingBalance"]


class StandingBalance:
    """The balance terms of one IK model; :meth:`update` once per solved frame."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, ankles: np.ndarray, frame_kinds: Sequence[str],
                 frame_ids: Sequence[int], robot_geoms: np.ndarray, config: IKConfig) -> None:
        """``data``: the model at the robot's home posture (kinematics done, facing +x); ``ankles`` (2, 3): the
        ankle key frames there, m; ``frame_kinds`` / ``frame_ids``: the five key frames; ``robot_geoms``: the
        robot's collidable geoms (the feet among them make the support rectangle)."""
        if model.body_parentid[1] != 0 or model.body_jntnum[1] < 1 \
                or int(model.jnt_type[model.body_jntadr[1]]) != int(mujoco.mjtJoint.mjJNT_FREE):
            raise SimulationError("IK model: body 1 must be the robot's root on a free joint (the balance terms "
                                  "read its subtree's centre of mass)")
        self.config = config
        mid = np.asarray(ankles)[:, :2].mean(axis=0)
        self.com_offset = np.array(data.subtree_com[1, :2] - mid)
        """(2,) the centre of mass's horizontal offset from the ankles' middle at home, robot frame, m."""
        self.com_task = mink.ComTask(cost=[config.com_cost, config.com_cost, 0.0])
        feet = [int(model.site_bodyid[f]) if k == "site" else int(f)
                for k, f in zip(frame_kinds[3:5], frame_ids[3:5], strict=True)]
        self.box: np.ndarray | None = None
        """(2, 2) the feet's horizontal extent around the ankles' middle at home, robot frame, m
        (:func:`~.support_limit.support_box`); ``None`` for feet without collidable geoms when no support
        limit asks for it."""
        try:
            self.box = support_box(model, data, (feet[0], feet[1]), robot_geoms, ankles)
        except SimulationError:
            if config.support_margin is not None:
                raise
        self.limit: SupportPolygonLimit | None = None
        if config.support_margin is not None and self.box is not None:
            self.limit = SupportPolygonLimit(model, self.box, config.support_margin)

    def support_centre(self, ankles: np.ndarray, yaw: float) -> np.ndarray:
        """(2,) the centre of the support polygon (world, m) of feet whose ankles are at ``ankles`` (2, 3)
        (world, m) with the robot turned by ``yaw`` (rad): the ankles' middle plus the home offset of the
        centre of mass, turned."""
        c, s = np.cos(yaw), np.sin(yaw)
        o = self.com_offset
        return np.asarray(ankles, dtype=np.float64)[:, :2].mean(axis=0) + np.array([c * o[0] - s * o[1], s * o[0] + c * o[1]])

    def box_centre(self, ankles: np.ndarray, yaw: float) -> np.ndarray:
        """(2,) the middle of the feet's support rectangle (world, m) with the ankles at ``ankles`` (2, 3)
        (world, m) and the robot turned by ``yaw`` (rad): the ankles' middle plus the rectangle's centre, turned.
        Unlike :meth:`support_centre` (where the robot's home posture puts the centre of mass) it is as far
        from the toes as from the heels (feet without geoms: :meth:`support_centre`)."""
        if self.box is None:
            return self.support_centre(ankles, yaw)
        c, s = np.cos(yaw), np.sin(yaw)
        o = self.box.mean(axis=1)
        return np.asarray(ankles, dtype=np.float64)[:, :2].mean(axis=0) + np.array([c * o[0] - s * o[1], s * o[0] + c * o[1]])

    def update(self, ankles: np.ndarray, yaw: float, standing: bool,
               com_target: np.ndarray | None = None, com_cost: float | None = None) -> list[mink.Task]:
        """Place (``standing``: both feet planted, ankle targets ``ankles`` (2, 3), world) or lift the balance
        terms for the next frame; returns the tasks to add (the ComTask when standing and ``com_cost`` > 0,
        drawn to ``com_target`` (2,) world m, or to the support centre when ``None``; ``com_cost`` replaces
        ``IKConfig.com_cost`` when given)."""
        if self.limit is not None:
            if standing:
                self.limit.set_support(ankles, yaw)
            else:
                self.limit.clear()
        cost = self.config.com_cost if com_cost is None else com_cost
        if standing and cost > 0:
            self.com_task.set_cost(np.array([cost, cost, 0.0]))
            centre = self.support_centre(ankles, yaw) if com_target is None else np.asarray(com_target)[:2]
            self.com_task.set_target(np.append(centre, 0.0))
            return [self.com_task]
        return []

    def limits(self) -> list[mink.Limit]:
        """The limits to add to the QP (the support rectangle while standing)."""
        return [self.limit] if self.limit is not None and self.limit.active else []
