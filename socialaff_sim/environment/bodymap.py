"""The robot's key frames mapped back onto agent 1's body, for scoring by a model learned on people.

:class:`~socialaff_sim.retarget.scaling.KeyJointScaler` maps agent 1's key joints
onto the robot: placement scaled by k about the partner's base, base height and
legs by s_leg, arms by s_arm about the shoulders and hips, and near the partner a
blend toward agent 1's recorded wrist. :class:`RobotToAgent` inverts it:

* base: horizontally p₀ + (b − p₀)/k with p₀ the partner's base; height
  h_h + (z − h_r)/s_leg (exact);
* ankles: base + R(hip_h + (a − b − hip_r)/s_leg) (exact; R is the robot frame's
  rotation, which is also agent 1's heading frame's);
* wrists: the scaler's target of a world wrist x is
  y = w (x + w δ u) + (1 − w)(C + s_arm x), with C fixed by the base and the
  shoulders, w = W(x) the smoothstep contact weight of x's distance to the nearest
  joint of the partner (or the object) and u the unit vector toward that joint
  (toward the object only with ``ScalingConfig.push_to_object``). The pure scaling inverse (C + s_arm x = y) is the
  answer when it lies beyond d_far of the partner (w = 0 there); otherwise Newton's
  method (finite-difference Jacobian) solves y(x) = target, warm-started from the
  previous frame's wrist, and from four fresh starts when that does not converge.

The scaler is not one-to-one near contacts (a target pushed past the partner's joint
has a second preimage on the joint's other side), so the inverse returns *a*
preimage, one the scaler maps onto the robot's key frame again (tested against the
scaler itself): the continuation of the previous frame's one, so the reading stays
on one branch; from fresh starts the one with the largest contact weight (a robot
hand on the person's hand reads as agent 1's hand there); the closest image when
there is none (a robot wrist the scaler can never produce, or where Newton's method
fails near the scaler's kinks, which happens on a few frames in a hundred).
"""

from __future__ import annotations

import numpy as np

from ..errors import SimulationError
from ..retarget.scaling import KeyJointScaler, smoothstep
from ..sim.simulator import Simulator

__all__ = ["RobotToAgent", "NEWTON_STEPS", "TOLERANCE"]

NEWTON_STEPS = 4
"""Most Newton steps per solve of the wrist inverse."""
TOLERANCE = 1e-6
"""Metres: a wrist whose image lies this close to its target counts as an exact preimage."""
_FD = 1e-6
"""Metres: finite-difference step of the Newton Jacobian."""


class _WristMap:
    """The scaler's target y(x) (world frame) of world wrists x near the partner's joints and the object."""

    def __init__(self, anchors: np.ndarray, n_joints: int, scaler: KeyJointScaler, C: np.ndarray) -> None:
        self.anchors = anchors
        c = scaler.config
        # The scaler pushes toward the partner's joints, and toward the object too when configured so.
        self.is_joint = (np.arange(len(anchors)) < n_joints) | bool(getattr(c, "push_to_object", False))
        self.far, self.push = c.contact_far, c.contact_push
        self.inv_band = 1.0 / (c.contact_far - c.contact_near)
        self.s = float(scaler.s_arm)
        self.C = C  # (2, 3): one per wrist

    def weight(self, x: np.ndarray) -> np.ndarray:
        """Contact weight W (...) of wrists x (..., 3)."""
        d = np.sqrt(np.min(np.sum((self.anchors - x[..., None, :]) ** 2, axis=-1), axis=-1))
        return smoothstep((self.far - d) * self.inv_band)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """y (2, ..., 3) of wrists x (2, ..., 3): w (x + w δ u) + (1 − w)(C + s_arm x)."""
        flat = x.reshape(-1, 3)
        gap = self.anchors - flat[:, None, :]  # (M, A, 3)
        d2 = np.einsum("mak,mak->ma", gap, gap)
        j = d2.argmin(axis=1)
        rows = np.arange(len(flat))
        d = np.sqrt(d2[rows, j])[:, None]
        z = np.clip((self.far - d) * self.inv_band, 0.0, 1.0)
        w = z * z * (3.0 - 2.0 * z)
        push = (w * self.push * self.is_joint[j][:, None] / np.maximum(d, 1e-9)) * gap[rows, j]
        C = np.broadcast_to(self.C.reshape((2,) + (1,) * (x.ndim - 2) + (3,)), x.shape).reshape(-1, 3)
        return (w * (flat + push) + (1.0 - w) * (C + self.s * flat)).reshape(x.shape)

    def newton(self, x: np.ndarray, y: np.ndarray, converged: slice) -> np.ndarray:
        """Newton iterations on starts x (2, S, 3) toward targets y (2, 3); stops early once the
        starts ``converged`` selects are exact for both wrists."""
        eye = np.eye(3) * _FD
        for _ in range(NEWTON_STEPS):
            f = self(np.concatenate([x[:, :, None], x[:, :, None] + eye], axis=2))  # (2, S, 4, 3)
            r = f[:, :, 0] - y[:, None]
            if np.abs(r[:, converged]).max() <= 0.1 * TOLERANCE:
                break
            J = (f[:, :, 1:] - f[:, :, :1]).transpose(0, 1, 3, 2) / _FD  # column k: ∂y/∂x_k
            J = np.where(np.abs(np.linalg.det(J))[..., None, None] > 1e-9, J, np.eye(3))
            x = x - np.linalg.solve(J, r[..., None])[..., 0]
        return x

    def fresh_starts(self, y: np.ndarray) -> np.ndarray:
        """(2, 4, 3): the target, the target moved δ to and from its nearest joint (the push undone
        on either side), and the unpushed solution for w = ½."""
        gap = self.anchors - y[:, None]
        d = np.linalg.norm(gap, axis=-1)
        j = d.argmin(axis=1)
        u = gap[[0, 1], j] / np.maximum(d[[0, 1], j], 1e-9)[:, None]
        mid = (y - 0.5 * self.C) / (0.5 + 0.5 * self.s)
        return np.stack([y, y - self.push * u, y + self.push * u, mid], axis=1)

    def solve(self, y: np.ndarray, previous: np.ndarray | None) -> np.ndarray:
        """(2, 3) preimages of the targets y (2, 3), continuing ``previous`` (2, 3) where possible."""
        out = (y - self.C) / self.s  # the w = 0 reading: exact when it is farther than d_far from the partner
        todo = self.weight(out) > 0.0
        if not todo.any():
            return out
        if previous is not None:
            x = self.newton(previous[:, None], y, slice(0, 1))[:, 0]
            res = np.linalg.norm(self(x[:, None])[:, 0] - y, axis=-1)
            if (res[todo] <= TOLERANCE).all():
                return np.where(todo[:, None], x, out)
        x = self.newton(self.fresh_starts(y), y, slice(0, 4))
        res = np.linalg.norm(self(x) - y[:, None], axis=-1)  # (2, 4)
        exact = res <= TOLERANCE
        score = np.where(exact, self.weight(x), -res)  # exact preimages by weight, else the closest image
        best = x[np.arange(2), np.argmax(score, axis=1)]
        return np.where(todo[:, None], best, out)


class RobotToAgent:
    """Agent-1-equivalent key joints of the robot's key frames, frame after frame of one episode."""

    def __init__(self) -> None:
        self._previous: np.ndarray | None = None

    def reset(self) -> None:
        """Forget the previous frame (call at the start of every episode)."""
        self._previous = None

    def __call__(self, sim: Simulator, robot_keys: np.ndarray, t: int) -> np.ndarray:
        """(5, 3) data frame, metres: agent 1's key joints for robot-frame key frames ``robot_keys`` (5, 3) at frame ``t``."""
        inter = sim.interaction
        if inter is None:
            raise SimulationError("RobotToAgent: the simulator has not been reset")
        sc = sim.scaler
        h, r = sc.human, sc.robot
        out_r = np.asarray(robot_keys, dtype=np.float64)
        frame = sc.frame
        R = frame.rotation
        partner = sim.pose.joints[t]
        idx = inter.layout.key_indices[0]
        p0 = partner[0 if idx is None else idx]
        if not np.isfinite(p0).all():
            p0 = frame.origin + R[:, 0]
        base_world = frame.to_world(out_r[0])
        keys = np.empty((5, 3))
        keys[0, :2] = p0[:2] + (base_world[:2] - p0[:2]) / sc.k
        keys[0, 2] = h.base_height + (out_r[0, 2] - r.base_height) / sc.s_leg
        keys[3:5] = keys[0] + (h.hips + (out_r[3:5] - out_r[0] - r.hips) / sc.s_leg) @ R.T
        # Wrists: the scaled target of a world wrist x is C + s_arm·x (C from the base and the shoulders).
        y = frame.to_world(out_r[1:3])
        C = frame.to_world(out_r[0] + r.shoulders - sc.s_arm * h.shoulders) - sc.s_arm * keys[0]
        # The same object anchors the scaler reacts to: the object and its path just ahead.
        obj = sim.object_anchors(t)
        anchors = partner if obj is None else np.vstack([partner, obj])
        keys[1:3] = self._previous = _WristMap(anchors, len(partner), sc, C).solve(y, self._previous)
        return keys - sim.offset
