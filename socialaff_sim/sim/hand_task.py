"""A task on each hand's position in the balance QP (``BalanceConfig.hand_task``).

The balance QP tracks the IK's joint angles (a PD per hinge, the arms' rows weighted by ``upper_weight``), not where
the hands are: a released trunk that rolls or pitches a few degrees carries a hand that meets its joint references
10–30 cm away from the plan's wrist in the world (the released H1's handshakes lose the clasp's duration after the
first touch, docs/design.md §5, "The released H1's handshake lost after its first touch …").

:class:`HandTask` adds, per arm, three rows on the wrist frame's world position x (the IK's wrist key frame, a site
or a body's origin):

    J q̈ = ω² (x* − x) − 2 ω ẋ − J̇ q̇

with J the frame's translational Jacobian over the robot's dofs (the whole body: the QP decides what moves), x* the
plan's wrist at the frame's end (the posed plan of :meth:`~.balance_control.BalanceController.begin_frame`), ω
``hand_task_bandwidth`` and the task's weight ``hand_task``; the J̇ q̇ term makes the rows the frame's acceleration
ẍ = J q̈ + J̇ q̇. With ``hand_task_touched`` an arm gets its rows only once it has touched the person or the object
(the arms' compensation's touch latch, :attr:`~.arm_compensation.ArmCompensation.touched`): before the touch
``arm_compensation`` steers the approach. With ``hand_task_roll_free`` only a robot whose feet ``flat_roll_free``
frees gets the task (:func:`hand_task_wanted`).
"""

from __future__ import annotations

import mujoco
import numpy as np

from ..errors import SimulationError
from .arm_contacts import wrist_frames, wrist_positions
from .flat_feet import roll_freed
from .scene import Scene

__all__ = ["HandTask", "arm_row_scale", "chain_columns", "hand_rows", "hand_task_wanted"]


def hand_task_wanted(weight: float | None, roll_free_only: bool, roll_free: list[np.ndarray | None] | None) -> bool:
    """Whether a robot gets the hands' rows: ``weight`` ``hand_task`` (``None``: never); ``roll_free_only``
    ``hand_task_roll_free``: only if some foot of ``roll_free`` (the controller's
    :func:`~.flat_feet.roll_free_axes`, ``None`` without ``flat_roll_free``) has its roll freed."""
    return weight is not None and (not roll_free_only or roll_freed(roll_free))


def chain_columns(m: mujoco.MjModel, body: int, top: int, vadr: np.ndarray) -> np.ndarray:
    """The columns into the robot's dofs ``vadr`` (each ≥ 6, past the free root) of the hinges on the chain from the
    body ``top`` (its own joints not included) down to ``body`` (included): an arm's joints, shoulder to wrist, with
    ``top`` the trunk the shoulders hang from."""
    path = np.zeros(m.nbody, dtype=bool)
    b = body
    while b != top:
        if b <= 0:
            raise SimulationError(f"body {body} does not hang from body {top}")
        path[b] = True
        b = int(m.body_parentid[b])
    return np.flatnonzero(path[m.dof_bodyid[vadr]] & (np.arange(len(vadr)) >= 6))


def arm_row_scale(scale: np.ndarray, arm_cols: list[np.ndarray], weight: float | None) -> np.ndarray:
    """(n − 6,) the joints' task's per-row scale (the square root of each row's weight) with the rows of the arms'
    hinges ``arm_cols`` (per arm, columns into the robot's dofs, each ≥ 6) weighted by ``weight`` w_a more
    (``hand_task_arm_weight``; the scale times √w_a; ``None``: ``scale`` itself). ``scale`` (n − 6,) is not
    changed."""
    if weight is None:
        return scale
    out = scale.copy()
    for cols in arm_cols:
        out[cols - 6] *= np.sqrt(weight)
    return out


def hand_rows(jac: np.ndarray, jac_dot: np.ndarray, qvel: np.ndarray, x: np.ndarray, target: np.ndarray,
              bandwidth: float, target_velocity: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(J, b): the rows J q̈ = b of a point's acceleration ω² (x* − x) + 2 ω (ẋ* − ẋ), with ``jac`` J (3, n) and
    ``jac_dot`` J̇ (3, n) its translational Jacobian and its time derivative, ``qvel`` q̇ (n,), ``x`` and ``target``
    x* (3,) world (m), ``bandwidth`` ω (rad/s), ``target_velocity`` ẋ* (3,) (m/s; ``None``: 0); ẋ = J q̇ and
    b = ω² (x* − x) + 2 ω (ẋ* − ẋ) − J̇ q̇."""
    xd = jac @ qvel
    if target_velocity is not None:
        xd = xd - target_velocity
    return jac, bandwidth * bandwidth * (target - x) - 2.0 * bandwidth * xd - jac_dot @ qvel


class HandTask:
    """The hands' position rows of one physics scene (module docstring); :meth:`begin_frame` per data frame,
    :meth:`tasks` per solve."""

    def __init__(self, scene: Scene, weight: float, bandwidth: float, touched_only: bool = False,
                 plan_velocity: bool = False, velocity_until_touch: bool = False) -> None:
        m = scene.model
        self.weight, self.bandwidth, self.touched_only = weight, bandwidth, touched_only
        self._start = mujoco.MjData(m) if plan_velocity else None  # hand_task_plan_velocity: the frame's start posed
        self._m, self._qadr = m, np.asarray(scene.robot_qadr)
        self.velocity_until_touch = velocity_until_touch
        self.velocities: np.ndarray | None = None
        """(2, 3) ``hand_task_plan_velocity``: each planned wrist's mean velocity over the frame (world, m/s), the rows'
        ẋ*; ``None``: at rest."""
        self._frames = wrist_frames(scene)
        self._bodies = [int(m.site_bodyid[f]) if site else f for f, site in self._frames]
        self.targets = np.full((2, 3), np.nan)
        """(2, 3) each wrist's planned position at the frame's end (world, m); NaN before the first frame."""
        self._jp, self._jd = np.zeros((3, m.nv)), np.zeros((3, m.nv))

    def arm_columns(self, m: mujoco.MjModel, top: int, vadr: np.ndarray) -> list[np.ndarray]:
        """Per arm (left, right): the columns into ``vadr`` of its hinges from the trunk ``top`` to its wrist frame's
        body (:func:`chain_columns`)."""
        return [chain_columns(m, b, top, vadr) for b in self._bodies]

    def positions(self, d: mujoco.MjData) -> np.ndarray:
        """(2, 3) the two wrist frames in ``d`` (world, m)."""
        return wrist_positions(d, self._frames)

    def begin_frame(self, plan: mujoco.MjData, q_start: np.ndarray | None = None, duration: float = 0.0) -> None:
        """Read the targets from ``plan``, the posed (kinematics run) plan of the frame's end; with
        ``hand_task_plan_velocity``, ``q_start`` (nq_r,) the references' start and ``duration`` (s) their time to
        the end: the velocities (x*(end) − x*(start)) / duration (none without a start or a duration)."""
        self.targets = self.positions(plan)
        self.velocities = None
        if self._start is not None and q_start is not None and duration > 0.0:
            self._start.qpos[self._qadr] = q_start
            mujoco.mj_kinematics(self._m, self._start)
            self.velocities = (self.targets - self.positions(self._start)) / duration

    def tasks(self, m: mujoco.MjModel, d: mujoco.MjData, vadr: np.ndarray, touched: np.ndarray | None
              ) -> list[tuple[np.ndarray, np.ndarray, float]]:
        """The (J (3, n), b (3,), weight) tasks of the arms that get one at the state ``d`` after ``mj_step1``
        (velocities and ``cdof_dot`` computed), over the robot's dofs ``vadr`` (n,); ``touched`` (2,) bool: the touch
        latch (``None``: no arm has touched)."""
        out, xs = [], self.positions(d)
        for s in (0, 1):
            if self.touched_only and (touched is None or not touched[s]):
                continue
            x = xs[s]
            mujoco.mj_jac(m, d, self._jp, None, x, self._bodies[s])
            mujoco.mj_jacDot(m, d, self._jd, None, x, self._bodies[s])
            target = self.targets[s]
            velocity = None if self.velocities is None or (  # hand_task_velocity_until_touch: a touched arm at rest
                self.velocity_until_touch and touched is not None and touched[s]) else self.velocities[s]
            J, b = hand_rows(self._jp[:, vadr], self._jd[:, vadr], d.qvel[vadr], x, target, self.bandwidth, velocity)
            out.append((J.copy(), b, self.weight))
        return out
