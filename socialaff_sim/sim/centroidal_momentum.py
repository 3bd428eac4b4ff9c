"""The whole body's angular momentum about its centre of mass (or about its feet) as rows of the balance QP.

A standing robot's swinging arm needs a reaction: the trunk's counter-rotation, the centre of mass's shift or a
moment of the floor's forces about the centre of mass (the feet's centres of pressure and friction torques). The
balance QP's torso, centre-of-mass and joint tasks leave the choice to their weights, and it falls on whichever is
lighter (docs/design.md §5, "The standing mode's high fives on 144–151 ..."). :class:`CentroidalMomentum` gives
rows for the rate of the centroidal angular momentum

    k = Σ_b (I_b ω_b + m_b (x_b − c) × v_b) = A q̇,     A = Σ_b (I_b J_ω,b + m_b [x_b − c]× J_v,b),

(b the robot's bodies, x_b their centres of mass, I_b their inertias in the world at x_b, c the robot's centre of
mass; J_v,b, J_ω,b the Jacobians of x_b), whose rate is k̇ = A q̈ + ḃ with the bias

    ḃ = Σ_b (I_b J̇_ω,b q̇ + ω_b × I_b ω_b + m_b (x_b − c) × J̇_v,b q̇)

(Σ_b m_b (v_b − ċ) × v_b = 0), so that the wanted rate k̇* = ω_k (k_ref − k) is the row ``A q̈ = k̇* − ḃ``. The
reference k_ref is the plan's momentum at the measured posture: ``A`` times the plan's velocity over the frame
(:func:`plan_velocity`; with ``BalanceConfig.angmom_root_still`` the root's six set to zero, the arm's swing with the
trunk held), so that the floor's moment, not the trunk's counter-rotation, takes the swing's
reaction. About a fixed point p instead of c (``BalanceConfig.angmom_about_feet``: the mean of the feet's contact
points) the same sums hold with the lever arms x_b − p (k_p = k + m (c − p) × ċ; Σ_b m_b v_b × v_b = 0 again): the
whole body's tipping over its feet, the centre of mass's motion included. The rows are divided by the robot's mass
(m²/s², as the QP's rows in m/s² times a length).
"""

from __future__ import annotations

import mujoco
import numpy as np

from ..retarget.kinematic_tree import subtree_mask

__all__ = ["CentroidalMomentum", "plan_velocity"]


class CentroidalMomentum:
    """The centroidal angular momentum of one model's robot (see the module docstring): ``root`` its root body,
    ``vadr`` (n,) its velocity coordinates (the free joint's six first), ``bandwidth`` ω_k (1/s)."""

    def __init__(self, m: mujoco.MjModel, root: int, vadr: np.ndarray, bandwidth: float) -> None:
        inside = subtree_mask(m, root)
        self._bodies = np.flatnonzero(inside & (m.body_mass > 0.0))
        self._root, self._vadr, self.bandwidth = int(root), np.asarray(vadr), float(bandwidth)
        self._mass = m.body_mass[self._bodies].copy()
        self._inertia = m.body_inertia[self._bodies].copy()  # (B, 3) principal moments, body-inertia frame
        self.mass = float(self._mass.sum())
        B = len(self._bodies)
        self._jp, self._jr = np.zeros((B, 3, m.nv)), np.zeros((B, 3, m.nv))
        self._dp, self._dr = np.zeros((B, 3, m.nv)), np.zeros((B, 3, m.nv))

    def _jacobians(self, m: mujoco.MjModel, d: mujoco.MjData, rates: bool) -> None:
        for i, b in enumerate(self._bodies.tolist()):
            mujoco.mj_jacBodyCom(m, d, self._jp[i], self._jr[i], b)
            if rates:
                mujoco.mj_jacDot(m, d, self._dp[i], self._dr[i], d.xipos[b], b)

    def _world_inertia(self, d: mujoco.MjData) -> np.ndarray:
        """(B, 3, 3) each body's inertia at its centre of mass, world axes."""
        R = d.ximat[self._bodies].reshape(-1, 3, 3)
        return np.einsum("bij,bj,bkj->bik", R, self._inertia, R)

    def _origin(self, d: mujoco.MjData, point: np.ndarray | None) -> np.ndarray:
        return d.subtree_com[self._root] if point is None else point

    def matrix(self, m: mujoco.MjModel, d: mujoco.MjData, rates: bool = False,
               point: np.ndarray | None = None) -> np.ndarray:
        """(3, n) A at the state of ``d`` (after ``mj_kinematics``, ``mj_comPos``; with ``rates`` the velocities
        too, for :meth:`rows`): k = A q̇[vadr], kg·m²/s; about the fixed ``point`` (3,) instead of the centre of mass
        if given (the lever arms x_b − p)."""
        self._jacobians(m, d, rates)
        r = d.xipos[self._bodies] - self._origin(d, point)  # (B, 3)
        I = self._world_inertia(d)
        jp, jr = self._jp[:, :, self._vadr], self._jr[:, :, self._vadr]
        lever = np.cross(r[:, :, None], jp, axisa=1, axisb=1, axisc=1)  # (B, 3, n): (x_b − c) × J_v,b
        return np.einsum("bij,bjn->in", I, jr) + np.einsum("b,bin->in", self._mass, lever)

    def bias(self, d: mujoco.MjData, qv: np.ndarray, point: np.ndarray | None = None) -> np.ndarray:
        """(3,) ḃ (N·m) at the velocities ``qv`` (n,) of the robot, from the Jacobians and their rates of the last
        :meth:`matrix` call with ``rates``; about the fixed ``point`` if given (Σ_b m_b v_b × v_b = 0 there too)."""
        r = d.xipos[self._bodies] - self._origin(d, point)
        I = self._world_inertia(d)
        w = self._jr[:, :, self._vadr] @ qv  # (B, 3) angular velocities
        Iw = np.einsum("bij,bj->bi", I, w)
        dw = self._dr[:, :, self._vadr] @ qv
        dv = self._dp[:, :, self._vadr] @ qv
        return (np.einsum("bij,bj->i", I, dw) + np.cross(w, Iw).sum(axis=0)
                + (self._mass[:, None] * np.cross(r, dv)).sum(axis=0))

    def rows(self, m: mujoco.MjModel, d: mujoco.MjData, qd_plan: np.ndarray,
             point: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(A / m (3, n), (k̇* − ḃ) / m (3,)): the task rows at the state of ``d`` (after ``mj_step1``), the
        reference k_ref = A ``qd_plan`` (n,), the plan's velocities (the root's six first, as ``qvel``'s); about the
        fixed ``point`` (3,) if given, else the centre of mass."""
        A = self.matrix(m, d, rates=True, point=point)
        qv = d.qvel[self._vadr]
        return A / self.mass, (self.bandwidth * (A @ (qd_plan - qv)) - self.bias(d, qv, point)) / self.mass


def plan_velocity(q_start: np.ndarray, q_end: np.ndarray, duration: float) -> np.ndarray:
    """(nq_r − 1,) the robot's velocity (as ``qvel``: the free joint's linear velocity in the world, its angular
    velocity in its own frame, then the hinges') that carries its coordinates ``q_start`` to ``q_end`` (nq_r,: a
    free joint, then hinges) in ``duration`` (s, > 0)."""
    out = np.empty(len(q_start) - 1)
    out[:3] = (q_end[:3] - q_start[:3]) / duration
    mujoco.mju_subQuat(out[3:6], q_end[3:7], q_start[3:7])
    out[3:6] /= duration
    out[6:] = (q_end[7:] - q_start[7:]) / duration
    return out
