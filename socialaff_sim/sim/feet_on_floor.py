"""The robot's feet on the floor, as the balance controller (:mod:`~.balance_control`) reads them: which geoms
belong to which foot, each foot's sole (found at home from its contacts with the floor), the feet's live contacts
with the floor, the support's footprint and the feet's heading."""

from __future__ import annotations

import mujoco
import numpy as np

from .._norms import norm
from ..retarget.kinematic_tree import subtree_mask
from .flat_feet import sole_corners
from .support_box import SupportBox
from .scene import Scene

__all__ = ["FeetOnFloor"]


class FeetOnFloor:
    """The two feet of one physics scene (the key frames 3 and 4): their bodies (:attr:`bodies`), soles and contacts."""

    def __init__(self, scene: Scene, sole_gap: float) -> None:
        m = scene.model
        self.sole_gap = sole_gap
        self.qadr = np.asarray(scene.robot_qadr)
        self._feet: list[int] = []
        foot_geom = np.full(m.ngeom, -1, dtype=np.int64)
        for s, k in enumerate((3, 4)):
            body = scene.frame_body(k)
            self._feet.append(body)
            foot_geom[subtree_mask(m, body)[m.geom_bodyid] & scene.robot_geom] = s
        self._foot_geom = foot_geom
        self._floor = int(scene.floor_geom)
        self.bodies = self._feet
        """The feet's body ids (left, right)."""
        d0 = scene.home_data()
        # Each foot's own axis that points forward at home (the robot faces +x there).
        self.forward = np.array([d0.xmat[b].reshape(3, 3).T @ np.array([1.0, 0.0, 0.0]) for b in self._feet])
        """(2, 3) each foot's forward axis at home, in its own frame."""
        self._foot_fwd = self.forward
        self.soles = self._sole = self._soles(m, scene)
        """Each foot's sole box (8, 3) in its frame (``None``: not found; the live contacts are used)."""
        self.corners = [None if sole is None else sole_corners(sole) for sole in self._sole]
        """Each sole's four bottom corners (:func:`~.flat_feet.sole_corners`), or ``None``."""
        self.home_rot = [d0.xmat[b].reshape(3, 3).copy() for b in self._feet]
        """Each foot's attitude at home (3, 3)."""
        self.home_z = [float(d0.xpos[b][2]) for b in self._feet]
        """Each foot body's height at home, m."""

    def _soles(self, m: mujoco.MjModel, scene: Scene) -> list[np.ndarray | None]:
        """Each foot's sole: the corners (8, 3) of the box, in the foot body's frame, of its contact points with
        the floor at home pressed 2 mm into it (``None``: no contact found; the live contacts are used)."""
        d = mujoco.MjData(m)
        d.qpos[self.qadr] = scene.home_qpos
        d.qpos[self.qadr[2]] -= 0.002
        mujoco.mj_forward(m, d)
        pts, _, which = self.contacts(d)
        out: list[np.ndarray | None] = []
        for s, body in enumerate(self._feet):
            mine = pts[which == s]
            if len(mine) < 3:
                out.append(None)
                continue
            local = (mine - d.xpos[body]) @ d.xmat[body].reshape(3, 3)
            lo, hi = local.min(axis=0), local.max(axis=0)
            out.append(np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]))
        return out

    def soles_at(self, d: mujoco.MjData) -> list[np.ndarray | None]:
        """Each foot's sole box's corners (8, 3), world (m), at the state of ``d`` (``None``: sole unknown)."""
        return [None if sole is None else d.xpos[body] + sole @ d.xmat[body].reshape(3, 3).T
                for body, sole in zip(self._feet, self._sole, strict=True)]

    def support(self, d: mujoco.MjData, pts: np.ndarray, which: np.ndarray) -> tuple[list[np.ndarray | None],
                                                                                      SupportBox]:
        """:meth:`soles_at` of ``d`` and the :class:`~.support_box.SupportBox` of :meth:`footprint` along
        :meth:`heading`: the feet's support at a step they stand, their contacts ``pts`` (P, 3), ``which`` (P,)."""
        fwd = self.heading(d)
        soles = self.soles_at(d)
        return soles, SupportBox(self.footprint(d, pts, which, soles), fwd)

    def footprint(self, d: mujoco.MjData, pts: np.ndarray, which: np.ndarray,
                  soles: list[np.ndarray | None] | None = None) -> np.ndarray:
        """(K, 2) world points whose box is the feet's support: the soles of the feet on the floor now (the live
        contact points of a foot whose sole is unknown), and of a foot whose sole is within ``sole_gap`` of it
        (the soles' boxes were found pressed 2 mm into the floor). ``soles``: :meth:`soles_at` of ``d``, when
        the caller has it."""
        out = []
        floor = float(pts[:, 2].min())
        for s, sole in enumerate(self.soles_at(d) if soles is None else soles):
            if not (which == s).any() and (sole is None or float(sole[:, 2].min()) > floor + self.sole_gap + 0.002
                                           or self.sole_gap <= 0.0):
                continue
            out.append(pts[which == s, :2] if sole is None else sole[:, :2])
        return np.vstack(out)

    def _on_floor(self, d: mujoco.MjData) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Of ``d``'s contacts: which are a foot's with the floor (ncon,) bool, whose foot (ncon,) (−1: none), and
        whether the floor is the contact's first geom (ncon,) bool."""
        g = d.contact.geom[: d.ncon]
        floor0, floor1 = g[:, 0] == self._floor, g[:, 1] == self._floor
        side = self._foot_geom[np.where(floor0, g[:, 1], g[:, 0])]
        return (floor0 | floor1) & (side >= 0), side, floor0

    def contacts(self, d: mujoco.MjData) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The feet's contacts with the floor: points (P, 3), frames (P, 3, 3) (normal first, pointing from the
        floor into the foot) and the foot (P,) of each (0 left, 1 right)."""
        nc = d.ncon
        if not nc:
            return np.zeros((0, 3)), np.zeros((0, 3, 3)), np.zeros(0, dtype=np.int64)
        con = d.contact
        keep, side, floor0 = self._on_floor(d)
        frames = con.frame[:nc][keep].reshape(-1, 3, 3).copy()
        # MuJoCo's normal points from geom 0 to geom 1: from the floor into the foot when the floor is geom 0.
        flip = ~floor0[keep]
        frames[flip] *= -1.0
        return con.pos[:nc][keep].copy(), frames, side[keep]

    def forces(self, m: mujoco.MjModel, d: mujoco.MjData) -> np.ndarray:
        """(2, 3) the floor's force on each foot (world, N): the sum of :func:`mujoco.mj_contactForce` over the
        foot's contacts with the floor (after ``mj_step2``, or ``mj_forward``)."""
        out = np.zeros((len(self._feet), 3))
        if not d.ncon:
            return out
        keep, side, floor0 = self._on_floor(d)
        f6 = np.zeros(6)
        for i in np.flatnonzero(keep).tolist():
            mujoco.mj_contactForce(m, d, i, f6)
            f = d.contact.frame[i].reshape(3, 3).T @ f6[:3]  # world, on the second geom
            out[side[i]] += f if floor0[i] else -f
        return out

    def heading(self, d: mujoco.MjData) -> np.ndarray:
        """(2,) unit: the feet's forward direction on the floor."""
        f = sum(d.xmat[b].reshape(3, 3) @ a for b, a in zip(self._feet, self._foot_fwd, strict=True))[:2]
        nrm = norm(f)
        return f / nrm if nrm > 1e-9 else np.array([1.0, 0.0])
