"""The five key frames' tasks as one mink task, evaluated in a single pass.

:class:`KeyFramesTask` is a :class:`mink.Task` holding, for each of the five key
frames (base, wrists, ankles), a position task (error p(q) − p*, world frame,
metres) and, where its orientation cost is non-zero (the base, kept upright and
facing the partner, and the feet, kept flat), an orientation task (error: the
rotation from the target to the frame, as a rotation vector in the target's
frame, radians). It is what five :class:`mink.FrameTask` objects express, with
the wrists free to turn; stacking them lets one call fetch the frames' poses and
Jacobians (``mujoco.mj_jacSite`` / ``mj_jacBody``) instead of building SE(3)
objects frame by frame, which dominated the per-frame IK time.

The orientation rows use the exact Jacobian of that error, ``J_r(e)⁻¹·Rᵀ·J_ω``
(``J_r`` the right Jacobian of SO(3), R the frame's rotation, ``J_ω`` its angular
Jacobian in world axes).
"""

from __future__ import annotations

from collections.abc import Sequence

import mink
import mujoco
import numpy as np

__all__ = ["KeyFramesTask"]


def _right_jacobian_inverse(e: np.ndarray) -> np.ndarray:
    """(3, 3) inverse right Jacobian of SO(3) at rotation vector ``e`` (3,)."""
    theta = float(np.linalg.norm(e))
    K = np.array([[0.0, -e[2], e[1]], [e[2], 0.0, -e[0]], [-e[1], e[0], 0.0]])
    if theta < 1e-6:
        return np.eye(3) + 0.5 * K + K @ K / 12.0
    c = 1.0 / theta**2 - (1.0 + np.cos(theta)) / (2.0 * theta * np.sin(theta))
    return np.eye(3) + 0.5 * K + c * (K @ K)


class KeyFramesTask(mink.Task):
    """Position (and, for some, orientation) tasks of several frames of one model, stacked.

    ``kinds`` (``"site"``/``"body"``) and ``ids`` name the frames; ``position_costs``
    (per metre, one per frame, or one for all) and ``orientation_costs`` (per radian,
    one per frame; only the positive ones make orientation rows).
    """

    def __init__(self, model: mujoco.MjModel, kinds: Sequence[str], ids: Sequence[int],
                 position_costs: float | Sequence[float], orientation_costs: Sequence[float]) -> None:
        self.model = model
        self.kinds = tuple(kinds)
        self.ids = [int(i) for i in ids]
        n = len(self.ids)
        costs = np.asarray(orientation_costs, dtype=np.float64)
        if costs.shape != (n,):
            raise ValueError(f"KeyFramesTask: expected {n} orientation costs, found {costs.shape}")
        self.oriented = [k for k in range(n) if costs[k] > 0]
        pos = np.broadcast_to(np.asarray(position_costs, dtype=np.float64), (n,))
        cost = np.concatenate([np.repeat(pos, 3), np.repeat(costs[self.oriented], 3)])
        super().__init__(cost=cost, gain=1.0, lm_damping=0.0)
        sites = np.array([k == "site" for k in self.kinds])
        self._site_rows, self._body_rows = np.flatnonzero(sites), np.flatnonzero(~sites)
        self._site_ids = np.array(self.ids)[sites]
        self._body_ids = np.array(self.ids)[~sites]
        self.target_positions = np.zeros((n, 3))
        """(n, 3) target positions, world frame, metres."""
        self.target_quats = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
        """(n, 4) target orientations (w, x, y, z); only the oriented frames' are used."""
        self._jacp = np.zeros((n, 3, model.nv))
        self._jacr = np.zeros((3, model.nv))
        self._quat = np.zeros(4)
        self._diff = np.zeros(3)
        self._rot = np.zeros(9)

    def set_targets(self, positions: np.ndarray, quats: np.ndarray | None = None) -> None:
        """Targets: ``positions`` (n, 3) metres and, optionally, ``quats`` (n, 4) (w, x, y, z)."""
        self.target_positions = np.array(positions, dtype=np.float64).reshape(-1, 3)
        if quats is not None:
            self.target_quats = np.array(quats, dtype=np.float64).reshape(-1, 4)

    def positions(self, data: mujoco.MjData) -> np.ndarray:
        """(n, 3) current frame positions, world frame."""
        out = np.empty((len(self.ids), 3))
        out[self._site_rows] = data.site_xpos[self._site_ids]
        out[self._body_rows] = data.xpos[self._body_ids]
        return out

    def _error_and_jacobian(self, configuration: mink.Configuration) -> tuple[np.ndarray, np.ndarray]:
        m, d = self.model, configuration.data
        n = len(self.ids)
        rows_e, rows_j = [], []
        for k, (kind, fid) in enumerate(zip(self.kinds, self.ids, strict=True)):
            if kind == "site":
                mujoco.mj_jacSite(m, d, self._jacp[k], self._jacr if k in self.oriented else None, fid)
            else:
                mujoco.mj_jacBody(m, d, self._jacp[k], self._jacr if k in self.oriented else None, fid)
            if k in self.oriented:
                mujoco.mju_mat2Quat(self._quat, d.site_xmat[fid] if kind == "site" else d.xmat[fid])
                target = self.target_quats[k]
                # Rotation from the target to the frame, in the target's axes: q_t ⊗ exp(e) = q.
                mujoco.mju_subQuat(self._diff, self._quat, target)
                mujoco.mju_quat2Mat(self._rot, self._quat)
                rows_e.append(self._diff.copy())
                # q = q_t ⊗ exp(e): the frame's body angular velocity Rᵀω is J_r(e)·ė, so ė = J_r(e)⁻¹·Rᵀ·J_ω·q̇.
                rows_j.append(_right_jacobian_inverse(self._diff) @ (self._rot.reshape(3, 3).T @ self._jacr))
        error = np.concatenate([(self.positions(d) - self.target_positions).ravel(), *rows_e])
        jac = np.concatenate([self._jacp.reshape(3 * n, m.nv), *rows_j]) if rows_j else self._jacp.reshape(3 * n, m.nv).copy()
        return error, jac

    def compute_error(self, configuration: mink.Configuration) -> np.ndarray:
        return self._error_and_jacobian(configuration)[0]

    def compute_jacobian(self, configuration: mink.Configuration) -> np.ndarray:
        return self._error_and_jacobian(configuration)[1]

    def compute_qp_residual(self, configuration: mink.Configuration) -> tuple[np.ndarray, np.ndarray, float]:
        error, jacobian = self._error_and_jacobian(configuration)
        return self._weighted_residual(error, jacobian)
