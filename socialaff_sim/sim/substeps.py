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
object grips it. A frame can be run in pieces (:meth:`FrameStepper.plan`, then
:meth:`~FrameStepper.advance` to a physics step, any number of times; the
environment's control period), and the robot's part re-planned from the step
reached toward a new IK solution (:meth:`~FrameStepper.replan`); run whole
(:meth:`~FrameStepper.run`) it is the same computation, bit for bit. The per-step work is arranged as whole-array copies (all mocap
rows, all controls) prepared once per frame, which keeps the Python overhead per
physics step small next to ``mujoco.mj_step`` itself.
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np

from .._norms import norms
from .carry import grip_on_contact
from .scene import Scene
from .scoring import SubgoalScorer
from .balance_control import BalanceController
from .feedforward import StandingFeedforward
from .support import SupportMeter

__all__ = ["FrameStepper", "nlerp"]


def nlerp(q0: np.ndarray, q1: np.ndarray, a: float | np.ndarray) -> np.ndarray:
    """Normalised linear interpolation of quaternions (..., 4), shortest way round."""
    sign = np.where(np.add.reduce(q0 * q1, axis=-1, keepdims=True) < 0, -1.0, 1.0)
    q = (1.0 - a) * q0 + a * sign * q1
    return q / norms(q, keepdims=True)


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
        feet touching the floor now). The same as :meth:`plan`, :meth:`advance` to ``n`` and :meth:`end_frame`.
        """
        self.plan(n, fps, q_prev, q_new, human_pos, human_quat, grip=grip, carry=carry, feet=feet)
        time = self.advance(n, time, subevent)
        return time, self.end_frame()

    def plan(self, n: int, fps: float, q_prev: np.ndarray, q_new: np.ndarray,
             human_pos: tuple[np.ndarray, np.ndarray], human_quat: tuple[np.ndarray, np.ndarray], *,
             grip: bool = True, carry: Callable[[int, float], bool] | None = None,
             feet: tuple[bool, bool] | None = None) -> None:
        """Start a frame of ``n`` physics steps (arguments as in :meth:`run`); :meth:`advance` runs them."""
        sc, d = self.scene, self.data
        self.n, self.k, self.force, self.fps = n, 0, 0.0, fps
        self._carry, self._grip_on = carry, grip and self._grip
        a = (np.arange(1, n + 1) / n)[:, None]
        self._q_prev = q_prev
        self._qs = np.empty((n, len(q_prev)))
        self._ctrls = np.empty((n, len(sc.act_ids)))
        mp = np.repeat(np.array(d.mocap_pos)[None], n, axis=0)
        mq = np.repeat(np.array(d.mocap_quat)[None], n, axis=0)
        p0, p1 = human_pos
        mp[:, sc.human_mocap] = (1.0 - a[:, :, None]) * p0 + a[:, :, None] * p1
        mq[:, sc.human_mocap] = nlerp(human_quat[0], human_quat[1], a[:, :, None])
        self._mp, self._mq = mp, mq
        self._robot_refs(q_prev, q_new, feet)

    def replan(self, q_new: np.ndarray, feet: tuple[bool, bool] | None = None) -> None:
        """A new robot target ``q_new`` (nq_r,) for the frame's end, from the next physics step on: the servo
        references and the anchor go there in a straight line from where they are now (the person's motion
        and the carried object stay as planned)."""
        q_from = self._qs[self.k - 1] if self.k else self._q_prev
        self._robot_refs(q_from, q_new, feet)

    def _robot_refs(self, q_from: np.ndarray, q_new: np.ndarray, feet: tuple[bool, bool] | None) -> None:
        """Servo references and anchor poses of physics steps k … n−1, interpolated from ``q_from`` (at step
        k − 1) to ``q_new`` (at step n − 1), the frame's joint velocity fed forward through the damping."""
        sc, d, k, n = self.scene, self.data, self.k, self.n
        m = sc.model
        a = (np.arange(1, n - k + 1) / (n - k))[:, None]
        qs = (1.0 - a) * q_from + a * q_new  # (n - k, nq_r)
        qs[:, 3:7] = nlerp(q_from[3:7], q_new[3:7], a)
        full = np.repeat(d.qpos[None], n - k, axis=0)
        full[:, sc.robot_qadr] = qs
        vel = np.zeros(m.nv)
        vel[sc.robot_vadr[6:]] = (q_new[7:] - q_from[7:]) * (self.fps * n / (n - k) if k else self.fps)
        ctrls = sc.ctrl_for(full, vel)  # (n - k, n_act)
        if self.feedforward is not None:  # hold the frame's target pose against gravity, on the feet now down
            ctrls += self.feedforward.ctrl_offset(full[-1], self.support.feet_down if feet is None else feet)
        self._qs[k:], self._ctrls[k:] = qs, ctrls
        self._hinge_vel = vel[sc.robot_vadr[6:]]
        if self.balance is not None:  # the balance controller's plan: the frame's (new) target
            self.balance.begin_frame(q_new, feet, q_from, (n - k) * m.opt.timestep)
        if sc.anchor_mocap >= 0:
            self._mp[k:, sc.anchor_mocap] = qs[:, :3]
            self._mq[k:, sc.anchor_mocap] = qs[:, 3:7]

    def advance(self, k_end: int, time: float, subevent: str | None) -> float:
        """Run the planned physics steps up to (not including) step ``k_end``; returns the simulated time after."""
        sc, d, scorer = self.scene, self.data, self.scorer
        m = sc.model
        mp, mq, ctrls, carry, grip = self._mp, self._mq, self._ctrls, self._carry, self._grip_on
        dt = m.opt.timestep
        force = self.force
        mocap_pos, mocap_quat, ctrl = d.mocap_pos, d.mocap_quat, d.ctrl
        bal, hinge_vel, qs = self.balance, self._hinge_vel, self._qs
        for k in range(self.k, min(k_end, self.n)):
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
                bal.carried = carry is not None  # the person still carries the object (its track holds it)
                bal.step(m, d, qs[k], hinge_vel)
            time += dt
            scorer.update(d, dt, time, subevent)
            self.support.update(d)
            force += scorer.last_force
            if grip and scorer.robot_on_object:
                grip_on_contact(sc, d)
        self.k, self.force, self._carry = max(self.k, min(k_end, self.n)), force, carry
        return time

    def end_frame(self) -> float:
        """Close the frame (the support meter's per-frame figures); returns the mean force on the human, N."""
        self.support.end_frame()
        return self.force / self.n
