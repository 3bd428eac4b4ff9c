"""The centre of mass kept over the support polygon of the planted feet, as a limit of the IK's QP.

:class:`SupportPolygonLimit` is a :class:`mink.Limit`: while the robot stands on
both feet, each QP step may not carry the centre of mass (of the subtree of body
1, the robot's root) out of the support rectangle, the box around both feet at
home (their geoms' horizontal extent, :func:`support_box`) shrunk by ``margin``
on every side and placed at the planted ankles, turned with the robot. The rows
are ``n·J_com Δq ≤ gain·(b − n·c)`` for the rectangle's four outward normals n and
offsets b (c the centre of mass), floored at 0 so a centre of mass already
outside (a stance that began there) is not forced in by the limit, only kept from
leaving further; the IK's :class:`mink.ComTask` pulls it back toward the centre.
"""

from __future__ import annotations

import mink
import mujoco
import numpy as np

from ..errors import SimulationError
from .kinematic_tree import subtree_mask

__all__ = ["SupportPolygonLimit", "support_box"]


def support_box(model: mujoco.MjModel, data: mujoco.MjData, feet: tuple[int, int], geoms: np.ndarray,
                ankles: np.ndarray) -> np.ndarray:
    """(2, 2) [[x_lo, x_hi], [y_lo, y_hi]], m: the horizontal extent of both feet's geoms at ``data``'s posture
    (kinematics done; the robot facing +x), relative to the ankles' middle ``ankles`` (2, 3).

    ``feet``: the bodies of the two ankle frames (their subtrees are the feet); ``geoms``: the robot's
    collidable geoms. Each geom contributes the corners of its bounding box (MuJoCo's ``geom_aabb``)."""
    inside = subtree_mask(model, feet[0]) | subtree_mask(model, feet[1])
    foot = np.asarray(geoms, dtype=np.int64)
    foot = foot[inside[model.geom_bodyid[foot]]]
    if not len(foot):
        raise SimulationError("IK model: the ankle frames' subtrees hold no collidable geom")
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=np.float64)
    pts = []
    for g in foot:
        centre, half = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
        local = centre + signs * half  # (8, 3) in the geom's frame
        pts.append(data.geom_xpos[g] + local @ data.geom_xmat[g].reshape(3, 3).T)
    xy = np.concatenate(pts)[:, :2] - np.asarray(ankles)[:, :2].mean(axis=0)
    return np.array([[xy[:, 0].min(), xy[:, 0].max()], [xy[:, 1].min(), xy[:, 1].max()]])


class SupportPolygonLimit(mink.Limit):
    """Keeps the centre of mass inside the support rectangle (see the module docstring); inactive until
    :meth:`set_support` and after :meth:`clear`."""

    def __init__(self, model: mujoco.MjModel, box: np.ndarray, margin: float, gain: float = 0.85) -> None:
        self.model = model
        half = 0.5 * (box[:, 1] - box[:, 0])
        shrink = np.minimum(margin, 0.5 * half)  # a foot narrower than twice the margin keeps half its size
        self.box = np.stack([box[:, 0] + shrink, box[:, 1] - shrink], axis=1)
        """(2, 2) the rectangle the centre of mass stays in, relative to the ankles' middle, robot frame, m."""
        self.gain = gain
        self._normals = np.zeros((4, 2))
        self._bounds = np.zeros(4)
        self.active = False
        self._jac = np.zeros((3, model.nv))

    def set_support(self, ankles: np.ndarray, yaw: float) -> None:
        """Place the rectangle at the ankles (2, 3) (world, m) of a robot turned by ``yaw`` (rad)."""
        c, s = np.cos(yaw), np.sin(yaw)
        ex, ey = np.array([c, s]), np.array([-s, c])
        mid = np.asarray(ankles, dtype=np.float64)[:, :2].mean(axis=0)
        self._normals = np.array([ex, -ex, ey, -ey])
        self._bounds = np.array([self.box[0, 1], -self.box[0, 0], self.box[1, 1], -self.box[1, 0]]) \
            + self._normals @ mid
        self.active = True

    def clear(self) -> None:
        """No support polygon (a foot is stepping)."""
        self.active = False

    def inside(self, com: np.ndarray) -> bool:
        """Whether the horizontal position ``com`` (2+,) (world, m) is inside the placed rectangle."""
        return bool(np.all(self._normals @ np.asarray(com)[:2] <= self._bounds + 1e-9))

    def compute_qp_inequalities(self, configuration: mink.Configuration, dt: float) -> mink.Constraint:
        if not self.active:
            return mink.Constraint()
        d = configuration.data
        mujoco.mj_jacSubtreeCom(self.model, d, self._jac, 1)
        G = self._normals @ self._jac[:2]
        h = np.maximum(self.gain * (self._bounds - self._normals @ d.subtree_com[1, :2]), 0.0)
        return mink.Constraint(G=G, h=h)
