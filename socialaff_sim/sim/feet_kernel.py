"""The planted feet's tasks and flat-sole contacts of one driven physics step in one compiled loop
(``BalanceConfig.qp_kernel = "numba"``, with ``flat_feet`` and no foot's roll freed).

:class:`~.balance_control.BalanceController` builds each planted foot's task (:func:`~.flat_feet.foot_feedback`:
its Jacobian on the robot's coordinates, the stiffness toward its anchor and the damping of its velocity) and,
with ``flat_feet``, swaps a foot's live contacts for its sole's corners and adds its hard rows
(:func:`~.flat_feet.flat_contacts`, the Jacobian's drift subtracted): some sixty NumPy and MuJoCo calls.
:class:`CompiledFeet` reads MuJoCo's Jacobians and their derivatives (:func:`mujoco.mj_jacBody`,
:func:`mujoco.mj_jacDot`) and does the rest in one no-Python loop (:func:`~socialaff_sim.inference.compiled.njit`,
fast-math off): the rotation to the anchor's attitude as a rotation vector is computed here (a quaternion by
Shepperd's method, then its angle-axis, as ``mju_mat2Quat`` and ``mju_quat2Vel`` give it to rounding), the sums of
products written out (BLAS fuses them), so the rows differ from NumPy's in their last digits: an alternative
evaluation, judged with ``qp_kernel="numba"`` by its rule (docs/design.md §5, session 34). NumPy stays the reference.
"""

from __future__ import annotations

import math
from typing import Any

import mujoco
import numpy as np

from ..inference.compiled import njit, once

__all__ = ["CompiledFeet", "feet_kernel", "rotation_vector"]


def _rotvec(E, out):  # pragma: no cover - compiled; tested through rotation_vector
    """The rotation vector (3,) of the rotation matrix E (3, 3): quaternion (Shepperd), then angle · axis with the
    angle wrapped into (−π, π]."""
    tr = E[0, 0] + E[1, 1] + E[2, 2]
    if tr > 0.0:
        s = math.sqrt(tr + 1.0) * 2.0
        w = 0.25 * s
        x = (E[2, 1] - E[1, 2]) / s
        y = (E[0, 2] - E[2, 0]) / s
        z = (E[1, 0] - E[0, 1]) / s
    elif E[0, 0] > E[1, 1] and E[0, 0] > E[2, 2]:
        s = math.sqrt(1.0 + E[0, 0] - E[1, 1] - E[2, 2]) * 2.0
        w = (E[2, 1] - E[1, 2]) / s
        x = 0.25 * s
        y = (E[0, 1] + E[1, 0]) / s
        z = (E[0, 2] + E[2, 0]) / s
    elif E[1, 1] > E[2, 2]:
        s = math.sqrt(1.0 + E[1, 1] - E[0, 0] - E[2, 2]) * 2.0
        w = (E[0, 2] - E[2, 0]) / s
        x = (E[0, 1] + E[1, 0]) / s
        y = 0.25 * s
        z = (E[1, 2] + E[2, 1]) / s
    else:
        s = math.sqrt(1.0 + E[2, 2] - E[0, 0] - E[1, 1]) * 2.0
        w = (E[1, 0] - E[0, 1]) / s
        x = (E[0, 2] + E[2, 0]) / s
        y = (E[1, 2] + E[2, 1]) / s
        z = 0.25 * s
    nq = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / nq, x / nq, y / nq, z / nq
    sin_half = math.sqrt(x * x + y * y + z * z)
    if sin_half < 1e-15:
        out[0], out[1], out[2] = 0.0, 0.0, 0.0
        return
    angle = 2.0 * math.atan2(sin_half, w)
    if angle > math.pi:
        angle -= 2.0 * math.pi
    k = angle / sin_half
    out[0], out[1], out[2] = x * k, y * k, z * k


def _feet(xpos, xmat, qvel, bodies, vadr, jac, dot, anchor_pos, anchor_rot, corners, pts, frames, which, sole_gap,
          stiffness, damping):  # pragma: no cover - compiled; tested through CompiledFeet
    F = bodies.shape[0]
    n = vadr.shape[0]
    C = corners.shape[1]
    P = pts.shape[0]
    J = np.empty((F, 6, n))
    b = np.empty((F, 6))
    E = np.empty((3, 3))
    vel = np.empty(3)
    for s in range(F):
        body = bodies[s]
        for r in range(6):
            for c in range(n):
                J[s, r, c] = jac[s, r, vadr[c]]
        for i in range(3):  # the goal's attitude relative to now, world: G Rᵀ
            for j in range(3):
                E[i, j] = (anchor_rot[s, i, 0] * xmat[body, 3 * j] + anchor_rot[s, i, 1] * xmat[body, 3 * j + 1]
                           + anchor_rot[s, i, 2] * xmat[body, 3 * j + 2])
        _ROTVEC(E, vel)
        for r in range(6):
            off = anchor_pos[s, r] - xpos[body, r] if r < 3 else vel[r - 3]
            v = 0.0
            for c in range(n):
                v += J[s, r, c] * qvel[vadr[c]]
            b[s, r] = stiffness * off - damping * v
    # flat feet: a foot that touches (or whose lowest corner is within the gap) stands on its sole's corners
    floor = np.inf
    for p in range(P):
        floor = min(floor, pts[p, 2])
    flat = np.zeros(F, dtype=np.bool_)
    world = np.empty((F, C, 3))
    for s in range(F):
        body = bodies[s]
        low = np.inf
        for i in range(C):
            for k in range(3):
                world[s, i, k] = xpos[body, k] + (corners[s, i, 0] * xmat[body, 3 * k]
                                                  + corners[s, i, 1] * xmat[body, 3 * k + 1]
                                                  + corners[s, i, 2] * xmat[body, 3 * k + 2])
            low = min(low, world[s, i, 2])
        touches = False
        for p in range(P):
            if which[p] == s:
                touches = True
        flat[s] = touches or not low > floor + sole_gap + 0.002
    kept = 0
    for p in range(P):
        if which[p] < 0 or not flat[which[p]]:
            kept += 1
    n_flat = 0
    for s in range(F):
        if flat[s]:
            n_flat += 1
    Q = kept + C * n_flat
    out_p = np.empty((Q, 3))
    out_f = np.empty((Q, 3, 3))
    out_w = np.empty(Q, dtype=np.int64)
    q = 0
    for p in range(P):
        if which[p] < 0 or not flat[which[p]]:
            out_p[q] = pts[p]
            out_f[q] = frames[p]
            out_w[q] = which[p]
            q += 1
    A = np.empty((6 * n_flat, n))
    rhs = np.empty(6 * n_flat)
    r0 = 0
    for s in range(F):
        if not flat[s]:
            continue
        for i in range(C):
            out_p[q] = world[s, i]
            out_f[q, 0, 0], out_f[q, 0, 1], out_f[q, 0, 2] = 0.0, 0.0, 1.0  # the level floor's normal, then x, y
            out_f[q, 1, 0], out_f[q, 1, 1], out_f[q, 1, 2] = 1.0, 0.0, 0.0
            out_f[q, 2, 0], out_f[q, 2, 1], out_f[q, 2, 2] = 0.0, 1.0, 0.0
            out_w[q] = s
            q += 1
        for r in range(6):  # the hard rows: the task less the drift J̇q̇
            drift = 0.0
            for c in range(qvel.shape[0]):
                drift += dot[s, r, c] * qvel[c]
            for c in range(n):
                A[r0 + r, c] = J[s, r, c]
            rhs[r0 + r] = b[s, r] - drift
        r0 += 6
    return J, b, out_p, out_f, out_w, A, rhs, n_flat


_ROTVEC: Any = None
"""The compiled :func:`_rotvec`, which the compiled :func:`_feet` calls (set by :func:`feet_kernel` before it is made)."""


def _build() -> dict[str, Any]:
    global _ROTVEC
    _ROTVEC = njit(_rotvec)
    return {"feet": njit(_feet), "rotvec": _ROTVEC}


def feet_kernel() -> Any:
    """The compiled :func:`_feet` and :func:`_rotvec` (made and warmed up once per process; numba missing: a
    ConfigError)."""
    return once(__name__, _build, _warm)


def _warm(fns: Any) -> None:
    """One call of each of the argument types :class:`CompiledFeet` passes."""
    nv, F = 8, 2
    xmat = np.tile(np.eye(3).ravel(), (3, 1))
    fns["feet"](np.zeros((3, 3)), xmat, np.zeros(nv), np.array([1, 2], dtype=np.int64), np.arange(7, dtype=np.int64),
                np.zeros((F, 6, nv)), np.zeros((F, 6, nv)), np.zeros((F, 3)), np.tile(np.eye(3), (F, 1, 1)),
                np.zeros((F, 4, 3)), np.zeros((2, 3)), np.zeros((2, 3, 3)), np.zeros(2, dtype=np.int64), 0.01, 1.0,
                1.0)
    fns["rotvec"](np.eye(3), np.empty(3))


def rotation_vector(E: np.ndarray) -> np.ndarray:
    """(3,) the rotation vector (rad) of the rotation matrix ``E`` (3, 3), compiled (as ``mju_mat2Quat`` and
    ``mju_quat2Vel`` with dt = 1 give it, to rounding)."""
    out = np.empty(3)
    feet_kernel()["rotvec"](np.ascontiguousarray(E, dtype=np.float64), out)
    return out


class CompiledFeet:
    """The feet's tasks and flat contacts of :class:`~.balance_control.BalanceController` (the module docstring) for
    the feet ``bodies`` with sole ``corners`` (each (C, 3), body frame), the robot's coordinates ``vadr``."""

    def __init__(self, m: mujoco.MjModel, bodies: list[int], corners: list[np.ndarray], vadr: np.ndarray,
                 sole_gap: float, stiffness: float, damping: float) -> None:
        self._fn = feet_kernel()["feet"]
        self._bodies = np.asarray(bodies, dtype=np.int64)
        self._vadr = np.asarray(vadr, dtype=np.int64)
        self._corners = np.ascontiguousarray(np.stack(corners), dtype=np.float64)
        F = len(bodies)
        self._jac, self._dot = np.zeros((F, 6, m.nv)), np.zeros((F, 6, m.nv))
        self._gap, self._k, self._kd = float(sole_gap), float(stiffness), float(damping)
        self._goal: tuple[np.ndarray, np.ndarray] | None = None
        self._anchor: object = None

    def __call__(self, m: mujoco.MjModel, d: mujoco.MjData, anchor: list[tuple[np.ndarray, np.ndarray]],
                 pts: np.ndarray, frames: np.ndarray, which: np.ndarray) -> tuple[Any, ...]:
        """Per foot its task (J (6, n), b (6,)) toward ``anchor`` (per foot (position (3,), attitude (3, 3))), and
        the contacts (points, frames, feet) with the flat feet's corners and their hard rows (``None``: no foot
        flat), as :func:`~.flat_feet.foot_feedback` and :func:`~.flat_feet.flat_contacts` give them."""
        if anchor is not self._anchor:  # (the controller keeps one list per planting)
            self._anchor = anchor
            self._goal = (np.array([p for p, _ in anchor], dtype=np.float64),
                          np.array([r for _, r in anchor], dtype=np.float64))
        jac, dot, xpos = self._jac, self._dot, d.xpos
        for s, body in enumerate(self._bodies.tolist()):
            mujoco.mj_jacBody(m, d, jac[s, :3], jac[s, 3:], body)
            mujoco.mj_jacDot(m, d, dot[s, :3], dot[s, 3:], xpos[body], body)
        J, b, p2, f2, w2, A, rhs, n_flat = self._fn(xpos, d.xmat, d.qvel, self._bodies, self._vadr, jac, dot,
                                                     self._goal[0], self._goal[1], self._corners, pts, frames,  # type: ignore[index]
                                                     which, self._gap, self._k, self._kd)
        return [(J[s], b[s]) for s in range(len(J))], p2, f2, w2, ((A, rhs) if n_flat else None)
