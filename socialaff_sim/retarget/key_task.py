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

import math
from collections.abc import Sequence

import mink
import mujoco
import numpy as np

__all__ = ["KeyFramesTask"]


def _right_jacobian_inverse(e: np.ndarray) -> np.ndarray:
    """(3, 3) inverse right Jacobian of SO(3) at rotation vector ``e`` (3,): I + K/2 + c·K², K = [e]×.

    Written out in scalars: it is evaluated for three frames in every QP step.
    """
    x, y, z = float(e[0]), float(e[1]), float(e[2])
    t2 = x * x + y * y + z * z
    if t2 < 1e-12:
        c = 1.0 / 12.0
    else:
        t = math.sqrt(t2)
        c = 1.0 / t2 - (1.0 + math.cos(t)) / (2.0 * t * math.sin(t))
    xy, xz, yz = c * x * y, c * x * z, c * y * z
    return np.array([[1.0 - c * (y * y + z * z), xy - 0.5 * z, xz + 0.5 * y],
                     [xy + 0.5 * z, 1.0 - c * (x * x + z * z), yz - 0.5 * x],
                     [xz - 0.5 * y, yz + 0.5 * x, 1.0 - c * (x * x + y * y)]])


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
        self._frames = [(k, kind == "site", fid, k in self.oriented)
                        for k, (kind, fid) in enumerate(zip(self.kinds, self.ids, strict=True))]
        self._error = np.zeros(3 * n + 3 * len(self.oriented))
        self._jac = np.zeros((len(self._error), model.nv))

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
        error, jac = self._error, self._jac
        error[: 3 * n] = (self.positions(d) - self.target_positions).ravel()
        row = 3 * n
        for k, site, fid, oriented in self._frames:
            jacr = self._jacr if oriented else None
            if site:
                mujoco.mj_jacSite(m, d, self._jacp[k], jacr, fid)
            else:
                mujoco.mj_jacBody(m, d, self._jacp[k], jacr, fid)
            if oriented:
                xmat = d.site_xmat[fid] if site else d.xmat[fid]
                mujoco.mju_mat2Quat(self._quat, xmat)
                # Rotation from the target to the frame, in the target's axes: q_t ⊗ exp(e) = q.
                mujoco.mju_subQuat(self._diff, self._quat, self.target_quats[k])
                error[row:row + 3] = self._diff
                # q = q_t ⊗ exp(e): the frame's body angular velocity Rᵀω is J_r(e)·ė,
                # so ė = J_r(e)⁻¹·Rᵀ·J_ω·q̇.
                jac[row:row + 3] = (_right_jacobian_inverse(self._diff) @ xmat.reshape(3, 3).T) @ self._jacr
                row += 3
        jac[: 3 * n] = self._jacp.reshape(3 * n, m.nv)
        return error.copy(), jac.copy()

    def compute_error(self, configuration: mink.Configuration) -> np.ndarray:
        return self._error_and_jacobian(configuration)[0]

    def compute_jacobian(self, configuration: mink.Configuration) -> np.ndarray:
        return self._error_and_jacobian(configuration)[1]

    def compute_qp_residual(self, configuration: mink.Configuration) -> tuple[np.ndarray, np.ndarray, float]:
        error, jacobian = self._error_and_jacobian(configuration)
        return self._weighted_residual(error, jacobian)
