"""The arms kept clear of the robot's own body at the physics rate: rows of the balance QP (``BalanceConfig.self_clearance``).

The IK keeps each forearm and hand a centimetre clear of the rest of the robot at the end of every data frame
(:class:`~socialaff_sim.retarget.collision.GeomPairLimit`), but not in between: the servo references go from one
frame's solution to the next in a straight line in joint space, and an arm swung down past the hip cuts the corner
through the pelvis (Stubby's right forearm, shake_hands_005: 1.2 cm clear at both ends of the frame, 1 cm inside
the pelvis half-way). While the balance controller drives the joints (:mod:`~.balance_control`), the arms also
trail their references by 0.2–0.35 rad, the QP trading their tracking for the centre of mass's, and the trailing
forearm, swung down at 2–2.5 m/s, lands 2.1–2.8 cm deep in the pelvis: past the task's 2 cm self-collision
allowance.

:class:`SelfClearance` turns every pair (a forearm or hand geom, and a robot geom of the rest of the body or of
the other arm) that MuJoCo would collide and that is within ``clearance_detection`` into one inequality on the
robot's acceleration, a critically damped barrier on the pair's distance d:

    d̈ ≥ −2 ω ḋ − ω² (d − d_min),   d̈ = nᵀ(J₂ − J₁) q̈ + nᵀ(J̇₂ − J̇₁) q̇

(n the unit normal from the pair's nearest point on the first geom to that on the second, J₁, J₂ the
translational Jacobians of those points, ω ``clearance_bandwidth``, d_min ``self_clearance``). Under it the distance
of a pair approaching at ḋ₀ from d₀ stays above d_min as long as ḋ₀ + ω (d₀ − d_min) ≥ 0: at ω = 30 rad/s a
forearm entering 10 cm out at 2.5 m/s. The rows are hard constraints of :func:`~.contact_qp.solve_contact_qp`,
dropped only when the torque limits cannot meet them.
"""

from __future__ import annotations

import mujoco
import numpy as np

from .._norms import norm, norms
from ..retarget.collision import collision_pairs
from .scene import Scene

__all__ = ["SelfClearance"]


class SelfClearance:
    """Barrier rows ``A q̈ ≥ lo`` that keep the arms ``clearance`` (m) clear of the rest of the robot.

    ``arm_geoms``: the left and right arm's collidable geoms (forearm and hand); ``robot_geoms``: all collidable
    robot geoms; ``vadr`` (n,): the robot's dof addresses (the rows' columns); ``detection`` (m): a pair farther
    apart gets no row; ``bandwidth`` ω (rad/s). The pairs are those MuJoCo's collision detection would test
    (:func:`~socialaff_sim.retarget.collision.collision_pairs`)."""

    def __init__(self, model: mujoco.MjModel, arm_geoms: tuple[np.ndarray, np.ndarray], robot_geoms: np.ndarray,
                 vadr: np.ndarray, clearance: float, detection: float, bandwidth: float) -> None:
        robot = np.asarray(robot_geoms, dtype=np.int64)
        parts = [collision_pairs(model, np.asarray(a, dtype=np.int64), np.setdiff1d(robot, a)) for a in arm_geoms]
        pairs = np.concatenate(parts) if parts else np.zeros((0, 2), dtype=np.int64)
        if len(pairs):  # a forearm against the other forearm is found from both sides: keep it once
            _, first = np.unique(np.sort(pairs, axis=1), axis=0, return_index=True)
            pairs = pairs[np.sort(first)]
        self.pairs = pairs
        """(P, 2) the geom pairs watched."""
        self.vadr = np.asarray(vadr, dtype=np.int64)
        self.clearance, self.detection, self.bandwidth = float(clearance), float(detection), float(bandwidth)
        self._reach = model.geom_rbound[pairs[:, 0]] + model.geom_rbound[pairs[:, 1]] + self.detection
        self._first, self._second = pairs[:, 0].copy(), pairs[:, 1].copy()  # contiguous index columns
        self._pair_list = [(int(a), int(b)) for a, b in pairs]
        self._body_of = model.geom_bodyid.tolist()
        self._fromto = np.zeros(6)
        nv = model.nv
        self._jac = np.zeros((2, 3, nv))
        self._jdot = np.zeros((2, 3, nv))
        self.last_distance = np.zeros(0)
        """The distances (m) of the pairs that got a row at the last :meth:`rows` call."""

    @classmethod
    def of_scene(cls, scene: Scene, clearance: float, detection: float, bandwidth: float) -> SelfClearance:
        """The rows for a physics scene's robot: its forearms and hands against its other collidable geoms."""
        m = scene.model
        collide = scene.robot_geom & ((m.geom_contype != 0) | (m.geom_conaffinity != 0))
        arms = (np.flatnonzero(scene.arm_geom[0]), np.flatnonzero(scene.arm_geom[1]))
        return cls(m, arms, np.flatnonzero(collide), np.asarray(scene.robot_vadr), clearance, detection, bandwidth)

    def rows(self, m: mujoco.MjModel, d: mujoco.MjData) -> tuple[np.ndarray, np.ndarray] | None:
        """(A (k, n), lo (k,)) with ``A q̈ ≥ lo`` for the pairs within the detection distance at the state ``d``
        (positions and velocities; its kinematics computed), or ``None`` when no pair is that close."""
        pairs = self.pairs
        if not len(pairs):
            return None
        xpos = d.geom_xpos
        centre = norms(xpos[self._first] - xpos[self._second], axis=1)
        near = np.flatnonzero(centre < self._reach).tolist()  # bounding spheres: only these can be that close
        A, lo, dist = [], [], []
        w = self.bandwidth
        qv = d.qvel
        for i in near:
            g1, g2 = self._pair_list[i]
            dd = mujoco.mj_geomDistance(m, d, g1, g2, self.detection, self._fromto)
            if dd >= self.detection:
                continue
            p1, p2 = self._fromto[:3].copy(), self._fromto[3:].copy()
            gap = p2 - p1
            length = norm(gap)
            if length < 1e-9:
                continue  # touching at a point: no direction to push along (the next step has one)
            # For geoms that overlap (dd < 0) the segment runs the other way: the normal that separates them is
            # still the one along which d grows.
            n = gap / length * (1.0 if dd >= 0 else -1.0)
            for k, (g, p) in enumerate(((g1, p1), (g2, p2))):
                body = self._body_of[g]
                mujoco.mj_jac(m, d, self._jac[k], None, p, body)
                mujoco.mj_jacDot(m, d, self._jdot[k], None, p, body)
            row = n @ (self._jac[1] - self._jac[0])
            rate = float(row @ qv)
            drift = float(n @ ((self._jdot[1] - self._jdot[0]) @ qv))
            A.append(row[self.vadr])
            lo.append(-2.0 * w * rate - w * w * (dd - self.clearance) - drift)
            dist.append(dd)
        self.last_distance = np.array(dist)
        if not A:
            return None
        return np.array(A), np.array(lo)
