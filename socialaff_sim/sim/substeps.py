"""The physics of one data frame: n MuJoCo steps between two IK solutions and two human poses.

Over the frame, every physics step gets, linearly interpolated between the
frame's start and end (quaternions normalised, shortest way round):

* the human's mocap targets (the recorded pose of frame t → t + 1);
* the robot's anchor (the IK's base pose) and its servo references (the IK's
  joint angles, with the frame's joint velocity fed forward through the servos'
  damping);
* the carried object on its recorded track until the release, which happens on
  the step that reaches the release frame.

After each step the scorer reads the contacts, and a robot hand touching the
object grips it. The per-step work is arranged as whole-array copies (all mocap
rows, all controls) prepared once per frame, which keeps the Python overhead per
physics step small next to ``mujoco.mj_step`` itself.
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np

from .carry import grip_on_contact
from .scene import Scene
from .scoring import SubgoalScorer
from .balance_control import BalanceController
from .feedforward import StandingFeedforward
from .support import SupportMeter

__all__ = ["FrameStepper", "nlerp"]


def nlerp(q0: np.ndarray, q1: np.ndarray, a: float | np.ndarray) -> np.ndarray:
    """Normalised linear interpolation of quaternions (..., 4), shortest way round."""
    sign = np.where(np.sum(q0 * q1, axis=-1, keepdims=True) < 0, -1.0, 1.0)
    q = (1.0 - a) * q0 + a * sign * q1
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


class FrameStepper:
    """Runs the physics steps of one data frame on ``scene`` / ``data``; one per simulator stage."""

    def __init__(self, scene: Scene, data: mujoco.MjData, scorer: SubgoalScorer, support: SupportMeter,
                 feedforward: StandingFeedforward | None = None, balance: BalanceController | None = None) -> None:
        self.scene, self.data, self.scorer, self.support = scene, data, scorer, support
        self.feedforward = feedforward
        self.balance = balance
        """The physics-rate balance controller (``SimConfig.balance``), which then runs each physics step."""

        m = scene.model
        self.nmocap = m.nmocap
        self._all_ctrl = bool(len(scene.act_ids) == m.nu and np.array_equal(scene.act_ids, np.arange(m.nu)))
        self._grip = scene.object_geom >= 0

    def run(self, n: int, fps: float, q_prev: np.ndarray, q_new: np.ndarray, human_pos: tuple[np.ndarray, np.ndarray],
            human_quat: tuple[np.ndarray, np.ndarray], time: float, subevent: str | None, *,
            grip: bool = True, carry: Callable[[int, float], bool] | None = None,
            feet: tuple[bool, bool] | None = None) -> tuple[float, float]:
        """Advance ``n`` physics steps; returns (simulated time at the end, mean force on the human N).

        ``q_prev``, ``q_new`` (nq_r,): robot coordinates (free joint then hinges) at the frame's
        start and end; ``human_pos`` / ``human_quat``: the mocap poses (G, 3) / (G, 4) at the start
        and the end. ``carry(k, t)``, when given, is called before step k (at simulated time t) to
        place (or release) the carried object; it returns whether to call it again on the next step.
        ``feet`` (left, right): which feet carry the weight in the feed-forward torques (``None``: the
        feet touching the floor now).
        """
        sc, d, scorer = self.scene, self.data, self.scorer
        m = sc.model
        a = (np.arange(1, n + 1) / n)[:, None]
        qs = (1.0 - a) * q_prev + a * q_new  # (n, nq_r)
        qs[:, 3:7] = nlerp(q_prev[3:7], q_new[3:7], a)
        full = np.repeat(d.qpos[None], n, axis=0)
        full[:, sc.robot_qadr] = qs
        vel = np.zeros(m.nv)
        vel[sc.robot_vadr[6:]] = (q_new[7:] - q_prev[7:]) * fps
        ctrls = sc.ctrl_for(full, vel)  # (n, n_act)
        if self.feedforward is not None:  # hold the frame's target pose against gravity, on the feet now down
            ctrls += self.feedforward.ctrl_offset(full[-1], self.support.feet_down if feet is None else feet)
        mp = np.repeat(np.array(d.mocap_pos)[None], n, axis=0)
        mq = np.repeat(np.array(d.mocap_quat)[None], n, axis=0)
        p0, p1 = human_pos
        mp[:, sc.human_mocap] = (1.0 - a[:, :, None]) * p0 + a[:, :, None] * p1
        mq[:, sc.human_mocap] = nlerp(human_quat[0], human_quat[1], a[:, :, None])
        if sc.anchor_mocap >= 0:
            mp[:, sc.anchor_mocap] = qs[:, :3]
            mq[:, sc.anchor_mocap] = qs[:, 3:7]
        dt = m.opt.timestep
        force = 0.0
        grip = grip and self._grip
        mocap_pos, mocap_quat, ctrl = d.mocap_pos, d.mocap_quat, d.ctrl
        bal = self.balance
        if bal is not None:
            bal.begin_frame(q_new, feet)
            hinge_vel = vel[sc.robot_vadr[6:]]
        for k in range(n):
            mocap_pos[:] = mp[k]
            mocap_quat[:] = mq[k]
            if self._all_ctrl:
                ctrl[:] = ctrls[k]
            else:
                ctrl[sc.act_ids] = ctrls[k]
            if carry is not None and not carry(k, time):
                carry = None
            if bal is None:
                mujoco.mj_step(m, d)
            else:
                bal.step(m, d, qs[k], hinge_vel)
            time += dt
            scorer.update(d, dt, time, subevent)
            self.support.update(d)
            force += scorer.last_force
            if grip and scorer.robot_on_object:
                grip_on_contact(sc, d)
        self.support.end_frame()
        return time, force / n
