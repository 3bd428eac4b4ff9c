"""Feed-forward joint torques that hold a robot's pose against its own weight, standing on its feet.

With gravity acting on the robot (no gravity compensation), a PD servo sags by
τ_g / kp under the load of the body above it, and servos tuned for the limbs'
own inertia would fold. :class:`StandingFeedforward` computes, for a target
pose q, the joint torques of static balance when the weight is carried by the
feet on the floor:

1. g(q): the generalised gravity force (``mj_rne`` at zero velocity and
   acceleration), for the root's six coordinates and every hinge;
2. the feet's contact wrenches w = (f_l, m_l, f_r, m_r) that carry the root's
   share: J_rootᵀ w = g_root, J the feet's body Jacobians; with two feet the
   system has more unknowns (12) than equations (6) and the least-norm solution
   is taken (moments weighted by the foot's length, so that forces carry the
   load rather than ankle moments);
3. the hinges' torques τ = g_joint − J_jointᵀ w.

Whatever the feet cannot carry (a foot in the air, a centre of mass outside
the feet) shows up as force on the harness, which is measured
(:mod:`~socialaff_sim.sim.support`). The servos get τ as an offset of their
reference: ctrl = q_ref + τ / kp.
"""

from __future__ import annotations

import mujoco
import numpy as np

from .scene import Scene

__all__ = ["StandingFeedforward", "FOOT_MOMENT_ARM"]

FOOT_MOMENT_ARM = 0.1
"""m: ankle moments are weighted as forces at this lever (about half a foot's length) in the least-norm split."""


class StandingFeedforward:
    """Joint torques of static balance on the feet for a target pose (see the module docstring)."""

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        m = scene.model
        self._data = mujoco.MjData(m)
        self._feet = [scene.frame_body(k) for k in (3, 4)]
        self._jacp = np.zeros((3, m.nv))
        self._jacr = np.zeros((3, m.nv))
        self._bias = np.zeros(m.nv)
        self._root = scene.robot_vadr[:6]
        self._act_dof = scene.act_vadr
        self._kp = m.actuator_gainprm[scene.act_ids, 0].copy()

    def torques(self, qpos: np.ndarray, feet: tuple[bool, bool] = (True, True)) -> np.ndarray:
        """(n_act,) servo torques (N·m) holding the full-model ``qpos`` (nq,) still with the feet in ``feet``
        (left, right) carrying the weight; no foot down: the torques of hanging from the root."""
        m, d = self.scene.model, self._data
        d.qpos[:] = qpos
        d.qvel[:] = 0.0
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_rne(m, d, 0, self._bias)  # gravity (and nothing else at rest), generalised
        g = self._bias.copy()
        cols = []
        for body, down in zip(self._feet, feet, strict=True):
            if not down:
                continue
            mujoco.mj_jacBody(m, d, self._jacp, self._jacr, body)
            cols.append(np.vstack([self._jacp, FOOT_MOMENT_ARM * self._jacr]))  # (6, nv)
        tau = g
        if cols:
            J = np.vstack(cols)  # (6·feet, nv): rows of foot wrenches
            A = J[:, self._root].T  # (6, 6·feet)
            w = np.linalg.lstsq(A, g[self._root], rcond=None)[0]
            tau = g - J.T @ w
        return tau[self._act_dof]

    def ctrl_offset(self, qpos: np.ndarray, feet: tuple[bool, bool] = (True, True)) -> np.ndarray:
        """(n_act,) what to add to the servos' position references: τ / kp, rad."""
        return self.torques(qpos, feet) / self._kp
