"""The hands held where the IK put them in the world, under the balance QP (``BalanceConfig.hand_weight``).

The balance controller's joint rows track the IK's hinge angles, so a hand lands where the IK put it only if the
root and torso are where the IK put them too. A robot standing on its own feet is not: its feet stand a few
centimetres from the IK's, its pelvis pitches a few degrees off the plan's, and the centre of mass's rows (weight
100 against the joints' 1) move the trunk under the arms. At the shoulder's lever arm these add up: on Stubby's
high fives the wrist ended 20 cm (median over the strike) from where the IK put it in the world, though only 6 cm
from it relative to the pelvis (docs/benchmarks.md, issue 25). A high five missed by 1–5 cm was the result.

:class:`HandTask` adds, for each wrist (the key frames 1 and 2), three rows in world coordinates on the arm's own
hinges (J_arm: the wrist's translational Jacobian J with every other column zero):

    J_arm q̈ = a* = ω_h² (x_ref − x) + 2 ω_h (ẋ_ref − J q̇) − J̇ q̇,

x_ref the wrist's position in the IK's plan at this physics step (the forward kinematics of the step's robot
reference, base included) plus the hand's give (:mod:`~.hand_yield`: the world offset ``offset`` and its rate),
ẋ_ref the reference's velocity (its backward difference over the last physics step, where the reference moves in a
straight line in joint space, plus the give's rate), J the wrist point's translational Jacobian and J̇ q̇ its
velocity-product acceleration (:func:`mujoco.mj_jacDot`). The arms then reach for the world point the IK aimed at
whatever the trunk does (its position and velocity are fed back; its acceleration is left out, so that the rows do
not drive the trunk: with all of J's columns they tipped it 11° to reach, and the harness caught it); the joint
rows keep the arm's posture in the remaining freedom.

The rows carry their weight where a hand must meet something: each wrist's share is 1 while its reference is
within ``near`` of the person's hands (or of the free object, not yet gripped), 0 beyond ``far``, linear in
between; times 1 − |f| / ``release`` (at least 0), f the person's filtered force on that arm (:mod:`~.hand_yield`),
so a hand in contact is left to the give and the joint rows (always on, the rows raised the pull-ups' outside
support 9 → 21 %, the hand overs' 0 → 7 %, on instances 000–007).
"""

from __future__ import annotations

import mujoco
import numpy as np

from ..retarget.kinematic_tree import subtree_mask
from .scene import Scene

__all__ = ["HandTask", "hand_rows", "reach_points"]


def reach_points(scene: Scene, d: mujoco.MjData) -> np.ndarray:
    """(K, 3) what a robot's hand may have to meet in ``d`` (world, m): the person's two hands and, in a scene
    with an object not gripped by the robot, the object."""
    pts = [d.geom_xpos[g] for g in np.asarray(scene.human_geom_ids)[-2:]]
    if scene.has_object and not d.eq_active[np.asarray(scene.grip_eq)].any():
        pts.append(d.geom_xpos[int(scene.object_geom)])
    return np.array(pts)


def hand_rows(J: np.ndarray, Jdot_qv: np.ndarray, x: np.ndarray, v: np.ndarray, x_ref: np.ndarray,
              v_ref: np.ndarray, bandwidth: float) -> tuple[np.ndarray, np.ndarray]:
    """The rows (A (3, n), b (3,)) of one wrist: ``J`` (3, n) its translational Jacobian (m per unit of q̇),
    ``Jdot_qv`` (3,) J̇ q̇ (m/s²), ``x`` / ``v`` (3,) its position (m) and velocity (m/s), ``x_ref`` / ``v_ref`` (3,)
    the reference's, ``bandwidth`` ω_h (rad/s): ``A q̈ = b`` is the critically damped wrist acceleration."""
    w = float(bandwidth)
    return J, w * w * (x_ref - x) + 2.0 * w * (v_ref - v) - Jdot_qv


class HandTask:
    """The world-frame wrist rows of one physics scene (module docstring); :meth:`reset` per episode,
    :meth:`reference` every physics step the controller sees, :meth:`rows` when it solves."""

    def __init__(self, scene: Scene, bandwidth: float, weight: float, near: float = 0.3, far: float = 0.5,
                 release: float = 20.0) -> None:
        m = scene.model
        self.scene, self.bandwidth, self.weight = scene, float(bandwidth), float(weight)
        self.near, self.far, self.release = float(near), float(far), float(release)
        self.vadr = np.asarray(scene.robot_vadr)
        self.qadr = np.asarray(scene.robot_qadr)
        self._kinds = [scene.frame_kinds[1 + s] for s in (0, 1)]
        self._ids = [int(scene.frame_ids[1 + s]) for s in (0, 1)]
        self._bodies = [int(m.site_bodyid[i]) if k == "site" else i for k, i in zip(self._kinds, self._ids, strict=True)]
        self._plan = mujoco.MjData(m)
        self._arm = []  # (n,) bool per arm: its hinges (the shoulder's subtree)
        for s in (0, 1):
            arm = subtree_mask(m, int(scene.limb_body_ids[s]))[m.dof_bodyid[self.vadr]]
            arm[:6] = False
            self._arm.append(arm)
        self._jp = np.zeros((3, m.nv))
        self._jd = np.zeros((3, m.nv))
        self.reset()

    def reset(self) -> None:
        """No reference seen yet."""
        self.x_ref = np.full((2, 3), np.nan)
        """(2, 3) the wrists' reference positions at the latest physics step (world, m; before the give)."""
        self.v_ref = np.zeros((2, 3))
        """(2, 3) their velocities (m/s): the backward difference over the step (0 at the first)."""
        self._last = -2

    def _points(self, d: mujoco.MjData) -> np.ndarray:
        """(2, 3) the wrists' key-frame positions in ``d`` (world, m)."""
        return np.array([d.site_xpos[i] if k == "site" else d.xpos[i] for k, i in zip(self._kinds, self._ids,
                                                                                      strict=True)])

    def reference(self, m: mujoco.MjModel, step: int, q_ref: np.ndarray) -> None:
        """The robot reference ``q_ref`` (nq_r,) of physics step ``step`` (a counter the caller increments by one per
        step): its wrists' world positions, and their velocity from the previous step's (0 after a gap)."""
        p = self._plan
        p.qpos[self.qadr] = q_ref
        mujoco.mj_kinematics(m, p)
        x = self._points(p)
        self.v_ref = (x - self.x_ref) / m.opt.timestep if step == self._last + 1 else np.zeros((2, 3))
        self.x_ref, self._last = x, step

    def gates(self, d: mujoco.MjData, force: np.ndarray | None) -> np.ndarray:
        """(2,) in [0, 1]: each wrist's rows' share of the weight."""
        P = reach_points(self.scene, d)
        dist = np.linalg.norm(self.x_ref[:, None, :] - P[None], axis=2).min(axis=1)
        g = np.clip((self.far - dist) / (self.far - self.near), 0.0, 1.0)
        if force is not None:
            g = g * np.clip(1.0 - np.linalg.norm(force, axis=1) / self.release, 0.0, 1.0)
        return g

    def rows(self, m: mujoco.MjModel, d: mujoco.MjData, offset: np.ndarray | None = None,
             rate: np.ndarray | None = None, force: np.ndarray | None = None) -> list[tuple[np.ndarray, np.ndarray, float]]:
        """The tasks (A (3, n), b (3,), weight) of both wrists at the state ``d`` (after ``mj_step1``), toward the
        reference moved by ``offset`` (2, 2) (world, horizontal, m) at ``rate`` (2, 2) (m/s) (the hands' give)."""
        va = self.vadr
        qv = d.qvel[va]
        x = self._points(d)
        out = []
        gate = self.gates(d, force)
        for s in (0, 1):
            if gate[s] <= 0.0:
                continue
            mujoco.mj_jac(m, d, self._jp, None, x[s], self._bodies[s])
            mujoco.mj_jacDot(m, d, self._jd, None, x[s], self._bodies[s])
            J = self._jp[:, va].copy()
            x_ref, v_ref = self.x_ref[s].copy(), self.v_ref[s].copy()
            if offset is not None:
                x_ref[:2] += offset[s]
            if rate is not None:
                v_ref[:2] += rate[s]
            # Only the arm's own hinges carry the rows: the trunk's motion is fed back through x and J q̇, not
            # driven (with all columns the rows tipped the trunk 11° to reach, and the harness caught it).
            A, b = hand_rows(np.where(self._arm[s], J, 0.0), self._jd[:, va] @ qv, x[s], J @ qv, x_ref, v_ref,
                             self.bandwidth)
            out.append((A, b, self.weight * gate[s]))
        return out
