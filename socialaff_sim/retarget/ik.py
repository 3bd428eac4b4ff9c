"""Differential inverse kinematics of the robot's five key frames with mink.

Tasks: a frame task per key frame (positions; plus orientation for the base, kept
upright and facing the partner, and the feet, kept flat), stacked into one mink
task (:class:`~.key_task.KeyFramesTask`), a :class:`mink.PostureTask` toward
the home posture that settles the redundancy, and standing balance: a planted
foot is pinned (its position and orientation costs raised to ``planted_foot_cost``
/ ``planted_foot_orientation_cost``), and while both are planted the centre of mass
may not leave their support rectangle (:class:`~.support_limit.SupportPolygonLimit`,
``support_margin``); a :class:`mink.ComTask` toward the rectangle's centre
(``com_cost``) is optional.
Limits: :class:`mink.ConfigurationLimit` (joint ranges) and
:class:`mink.VelocityLimit` (every hinge), merged into one box on Δq per data frame
(:class:`~.joint_limits.JointBoxLimit`), and collision avoidance
(:class:`~.collision.GeomPairLimit`): the whole robot keeps ``min_distance``
clear of the person, except that a hand may press at most
``contact_depth`` into the parts the task wants touched; the forearms and hands
keep clear of the rest of the robot, and the two legs of each other
(``leg_clearance``: ankle targets closer together than the feet are wide put the
feet side by side, not inside each other). A person moving into the robot pushes it
back out (at most ``max_push`` per step), and so does a leg found inside the other
(the pairs and their distances: :mod:`~.ik_pairs`).

Each call of :meth:`RobotIK.solve` takes one data frame of period ``dt``: it warm
starts from the previous frame's solution and runs QP steps (at least one) until
every key frame worth it is within ``tolerance`` of its target, ``iterations``
steps were taken, or ``patience`` steps in a row brought no progress
(``min_progress``) on the best error of the frame. Smoothly moving targets need one
step (the Gauss-Newton step of a frame's motion is nearly exact); a target that
moves by decimetres in a frame (a fast swing) is overshot by the first step, which
may leave it farther off than before, and met by the next two to five.

A step is checked against the collision pairs the QP did not see: when it carries
one through its limit (a fast hand sweeping into the thigh from beyond the
detection distance), it is solved again with that pair in the QP (``backtracks``).
A step after the first that makes the weighted RMS error grow by more than
``max_worsening`` is undone and the next one damped more (two hands closing on a
ball, each pushing the other off its target, otherwise trade places step after step).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import mink
import mujoco
import numpy as np

from .._norms import norms
from ..errors import SimulationError
from .collision import GeomPairLimit
from .ik_config import IKConfig
from .ik_pairs import GeomGroups, arm_self_pairs, pair_limit, set_collision_bits
from .joint_limits import JointBoxLimit
from .key_task import KeyFramesTask
from .balance import StandingBalance

__all__ = ["IKConfig", "IKModel", "IKResult", "RobotIK", "JointBoxLimit", "GeomPairLimit", "KeyFramesTask"]


@dataclass(frozen=True)
class IKModel:
    """What the IK needs to know about its MuJoCo model (robot on a free joint, human as mocap)."""

    model: mujoco.MjModel
    frame_kinds: tuple[str, ...]
    """Kind (``"site"``/``"body"``) of the five key frames."""
    frame_ids: np.ndarray
    """(5,) ids of the key frames."""
    home_qpos: np.ndarray
    """(nq,) home posture in the robot frame."""
    hand_geoms: tuple[np.ndarray, np.ndarray]
    """Geom ids of the left and right hand."""
    arm_geoms: tuple[np.ndarray, np.ndarray]
    """Geom ids of the left and right forearm and hand."""
    robot_geoms: np.ndarray
    """Ids of all collidable robot geoms (for self-collision avoidance of the arms)."""
    human_geoms: np.ndarray
    """(G,) geom ids of the human."""
    human_mocap: np.ndarray
    """(G,) mocap index of each human geom's body."""
    max_joint_velocity: float
    """rad/s for every hinge."""
    leg_geoms: tuple[np.ndarray, np.ndarray] = field(
        default_factory=lambda: (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)))
    """Geom ids of the left and right leg (thigh, shin, foot: the subtree of each hip limb root), kept
    ``IKConfig.leg_clearance`` apart; empty: no such pairs."""
    torso_dofs: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    """Dof indices of the spine: the joints between the base and the torso (the body both shoulders hang
    from). Their posture cost is ``IKConfig.torso_posture_cost``, which keeps the torso upright."""


@dataclass(frozen=True)
class IKResult:
    """One frame's solution."""

    qpos: np.ndarray
    """(nq,) robot configuration (free joint then hinges), world frame."""
    errors: np.ndarray
    """(5,) distance of each key frame to its target, metres."""
    iterations: int
    """QP steps taken (a step solved again for a collision pair counts once; an undone step counts)."""
    undone: int = 0
    """Steps undone for making matters worse (``IKConfig.max_worsening``)."""


class RobotIK:
    """mink IK on one :class:`IKModel`; keeps its own MjData (one instance per simulator)."""

    def __init__(self, ik_model: IKModel, config: IKConfig | None = None) -> None:
        self.spec = ik_model
        self.config = c = config or IKConfig()
        for name, low in (("iterations", 1), ("patience", 1), ("backtracks", 0), ("damping_growth", 1.0),
                          ("max_damping", c.damping)):
            if not getattr(c, name) >= low:
                raise SimulationError(f"IKConfig.{name}: expected at least {low}, found {getattr(c, name)}")
        if c.max_worsening is not None and not c.max_worsening >= 0:
            raise SimulationError(f"IKConfig.max_worsening: expected a distance ≥ 0 m or None, found {c.max_worsening}")
        m = ik_model.model
        if m.nq != len(ik_model.home_qpos):
            raise SimulationError(f"IK model has nq = {m.nq}, home posture has {len(ik_model.home_qpos)} values")
        self.configuration = mink.Configuration(m, ik_model.home_qpos)
        orientation = [c.base_orientation_cost, 0.0, 0.0, c.foot_orientation_cost, c.foot_orientation_cost]
        self._position_cost = np.array([c.base_position_cost] + [c.position_cost] * 4)
        self.key_task = KeyFramesTask(m, ik_model.frame_kinds, ik_model.frame_ids, self._position_cost, orientation)
        posture_cost = np.full(m.nv, c.posture_cost)
        posture_cost[np.asarray(ik_model.torso_dofs, dtype=np.int64)] = c.torso_posture_cost
        self.posture_task = mink.PostureTask(m, cost=posture_cost)
        self.posture_task.set_target(ik_model.home_qpos)
        self.config_limit = mink.ConfigurationLimit(m)
        hinge = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
        limited = [m.joint(j).name for j in range(m.njnt) if int(m.jnt_type[j]) in hinge and m.jnt_limited[j]]
        self.velocity_limit = mink.VelocityLimit(m, {n: ik_model.max_joint_velocity for n in limited})
        free = [j for j in range(m.njnt) if int(m.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_FREE)]
        free_dofs = (m.jnt_dofadr[free[0]] + np.arange(6)) if free else None
        free_speed = np.array([c.max_base_speed] * 3 + [c.max_base_turn] * 3)
        self._box = JointBoxLimit(m, self.config_limit, self.velocity_limit, free_dofs, free_speed)
        robot = np.asarray(ik_model.robot_geoms, dtype=np.int64)
        self._groups = GeomGroups.of(ik_model.human_geoms, robot, ik_model.arm_geoms, ik_model.hand_geoms,
                                     ik_model.leg_geoms)
        set_collision_bits(m, self._groups, legs=c.leg_clearance is not None)
        self._self_pairs = arm_self_pairs(m, self._groups)
        self.collision_limit: GeomPairLimit
        self.set_contact_exemptions([])
        self._home_quat = self._frame_quats(ik_model.home_qpos)
        self.configuration.update(ik_model.home_qpos)
        d = self.configuration.data
        self.balance = StandingBalance(m, d, self.key_task.positions(d)[3:5], ik_model.frame_kinds,
                                       ik_model.frame_ids, robot, c)
        self._oriented = list(self.key_task.oriented)
        self._tasks: list[mink.Task] = [self.key_task, self.posture_task]
        self._fixed_yaw: tuple[float, float] | None = None
        self._damping = c.damping

    # -- set-up ---------------------------------------------------------------------
    def _frame_quats(self, q: np.ndarray) -> np.ndarray:
        """(5, 4) orientations (w, x, y, z) of the key frames at configuration ``q``."""
        self.configuration.update(q)
        d = self.configuration.data
        out = np.zeros((5, 4))
        for k, (kind, fid) in enumerate(zip(self.spec.frame_kinds, self.spec.frame_ids, strict=True)):
            mujoco.mju_mat2Quat(out[k], d.site_xmat[fid] if kind == "site" else d.xmat[fid])
        return out

    def com(self) -> np.ndarray:
        """(3,) the robot's centre of mass at the current configuration, world frame, metres."""
        return np.array(self.configuration.data.subtree_com[1])

    def set_contact_exemptions(self, exempt: Sequence[tuple[int, Sequence[int]]]) -> None:
        """Rebuild the collision pairs; (hand side 0/1, human geom ids): those parts may be touched.

        The listed human geoms may touch that side's hand (its forearm keeps clear): the pairs keep
        a limit, but one that lets them press ``contact_depth`` into the person
        instead of stopping ``min_distance`` short (or none, with ``contact_depth=None``),
        so a required contact happens without the hand being driven deep into the person.
        Call it again whenever the human's capsule sizes change (the limit caches bounding radii).
        """
        free: dict[int, set[int]] = {0: set(), 1: set()}
        for side, geoms in exempt:
            free[int(side)].update(int(g) for g in geoms)
        self.collision_limit = pair_limit(self.spec.model, self._groups, self._self_pairs, free, self.config)

    def limits(self) -> list[mink.Limit]:
        """The limits passed to the QP."""
        return [self._box, self.collision_limit, *self.balance.limits()]

    def reset(self, qpos: np.ndarray) -> None:
        """Start from configuration ``qpos`` (nq,), at rest."""
        self.configuration.update(np.asarray(qpos, dtype=np.float64))

    def set_human(self, pos: np.ndarray, quat: np.ndarray) -> None:
        """Place the human's mocap bodies: ``pos`` (G, 3) metres, ``quat`` (G, 4) (w, x, y, z)."""
        d = self.configuration.data
        d.mocap_pos[self.spec.human_mocap] = pos
        d.mocap_quat[self.spec.human_mocap] = quat
        self.configuration.update()  # mocap poses reach geom_xpos only through the kinematics

    # -- solving --------------------------------------------------------------------
    def frame_positions(self) -> np.ndarray:
        """(5, 3) current key-frame positions, world frame."""
        return self.key_task.positions(self.configuration.data)

    def _set_targets(self, targets: np.ndarray, yaw: float, lean: float = 0.0) -> None:
        """Point the key-frame task at ``targets`` (5, 3): base and feet at their home orientation
        turned by ``yaw`` (the wrists' orientation is free); the base's also pitched forward by ``lean`` (rad)
        about the heading's lateral axis (before the turn: about the home frame's y axis)."""
        if self._fixed_yaw != (yaw, lean):
            turn = np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])
            quats = np.zeros((5, 4))
            for k in range(5):
                mujoco.mju_mulQuat(quats[k], turn, self._home_quat[k])
            if lean != 0.0:
                pitch = np.array([np.cos(lean / 2), 0.0, np.sin(lean / 2), 0.0])
                leaned = np.zeros(4)
                mujoco.mju_mulQuat(leaned, pitch, self._home_quat[0])
                mujoco.mju_mulQuat(quats[0], turn, leaned)
            self._target_quats = quats
            self._fixed_yaw = (yaw, lean)
        self.key_task.set_targets(targets, self._target_quats)

    def _step(self, dt: float) -> np.ndarray:
        """One QP step; a push-out the QP cannot meet together with the joint limits is dropped."""
        c, cfg = self.config, self.configuration
        tasks = self._tasks
        lim = self.collision_limit
        try:
            return mink.solve_ik(configuration=cfg, tasks=tasks, dt=dt, solver=c.solver, damping=self._damping,
                                 limits=self.limits())
        except mink.NoSolutionFound:
            lim.allow_push = False
            try:
                return mink.solve_ik(configuration=cfg, tasks=tasks, dt=dt, solver=c.solver, damping=self._damping,
                                     limits=self.limits())
            except mink.NoSolutionFound:
                return np.zeros(cfg.model.nv)
            finally:
                lim.allow_push = True

    def _take_step(self, dt: float) -> None:
        """One QP step that carries no collision pair through its limit.

        The QP sees only the pairs within their detection distance; when the step brings another
        pair inside its limit (:meth:`GeomPairLimit.crossed`: a fast hand sweeping into the thigh), it
        is solved again with that pair watched, at most ``backtracks`` times. If the step still
        crosses (each new step can meet new pairs, and the rows are linear in Δq), it is halved, at
        most ``backtracks`` times, and the shortest kept.
        """
        c, cfg, lim = self.config, self.configuration, self.collision_limit
        v = self._step(dt)
        start = cfg.q
        cfg.integrate_inplace(v, dt)
        resolves = halvings = 0
        while c.backtracks and len(crossing := lim.crossed(cfg, c.collision_slack)):
            cfg.update(start)
            if resolves < c.backtracks and lim.watch(crossing):
                resolves += 1
                v = self._step(dt)
            elif halvings < c.backtracks:
                halvings += 1
                v = 0.5 * v
            else:
                cfg.integrate_inplace(v, dt)  # the shortest step is kept (dropping it can freeze the robot)
                break
            cfg.integrate_inplace(v, dt)
        lim.unwatch()

    def solve(self, targets: np.ndarray, yaw: float, dt: float, care: np.ndarray | None = None,
              planted: tuple[bool, bool] = (False, False), com_target: np.ndarray | None = None,
              com_cost: float | None = None, iterations: int | None = None, lean: float = 0.0) -> IKResult:
        """Move toward world-frame ``targets`` (5, 3) over one frame of ``dt`` seconds.

        ``yaw`` (rad) turns the base's and the feet's home orientations to face the partner.
        ``care`` (5,) bool, optional: the targets within reach. The first step (always taken)
        moves toward all five, those out of reach with ``unreachable_weight`` times their cost;
        more steps are taken only while one within reach is farther than ``tolerance``
        (a target the person's body or a limb's length puts out of reach cannot be met, and
        chasing it would only spend time).
        ``planted`` (left, right): the feet standing on the floor at their targets; each is pinned,
        and with both the centre of mass is kept over their support rectangle (and, with ``com_cost``,
        drawn to its centre, or to ``com_target`` (2,) world m when given; ``com_cost``, when given, replaces
        ``IKConfig.com_cost`` for this frame). ``iterations``, when given, caps the QP steps below
        ``IKConfig.iterations`` (e.g. one step for a correction within a frame already solved). ``lean`` (rad):
        the base's orientation target pitched forward by this much about the heading's lateral axis
        (``StanceConfig.strike_lean``; 0: upright).
        """
        targets = np.asarray(targets, dtype=np.float64)
        if targets.shape != (5, 3) or not np.isfinite(targets).all():
            raise SimulationError(f"IK targets: expected a finite (5, 3) array, found shape {targets.shape}")
        if dt <= 0:
            raise SimulationError(f"IK frame period: expected dt > 0, found {dt}")
        watch = np.ones(5, dtype=bool) if care is None else np.asarray(care, dtype=bool)
        c, cfg = self.config, self.configuration
        # A target out of reach still draws its limb, but more weakly: through the joints the limbs share
        # (the waist) it would otherwise pull the reachable targets off theirs.
        weight = self._position_cost * np.where(watch, 1.0, c.unreachable_weight)
        feet = np.asarray(planted, dtype=bool)
        weight[3:5] = np.where(feet, c.planted_foot_cost / c.position_cost, 1.0) * weight[3:5]
        self.key_task.cost[:15] = np.repeat(weight, 3)
        for row, k in enumerate(self._oriented):
            if k in (3, 4):
                cost = c.planted_foot_orientation_cost if feet[k - 3] else c.foot_orientation_cost
                self.key_task.cost[15 + 3 * row:18 + 3 * row] = cost
        balance = self.balance.update(targets[3:5], yaw, bool(feet.all()), com_target, com_cost)
        self._tasks = [self.key_task, self.posture_task, *balance]
        if balance:
            # Standing, the base may give way horizontally: the hips, not a leaning torso, carry the centre of
            # mass back over the feet when the arms reach out.
            self.key_task.cost[:2] = c.planted_base_cost * (weight[0] / c.base_position_cost)
        self._box.begin_frame(cfg.q)
        errors = norms(self.frame_positions() - targets, axis=1)
        it = 0
        self._set_targets(targets, yaw, lean)
        # The first step is always taken (the limits hold even when the targets are already met: a person
        # moving into the robot pushes it out); more only while a target worth it is off by > tolerance.
        # A step may make matters worse before the next ones converge (a long move linearised in one step
        # overshoots), so only ``patience`` steps in a row without progress on the best so far end the frame.
        best = errors[watch].max(initial=0.0)
        stalled = 0
        self._damping = c.damping
        undone = 0
        cap = c.iterations if iterations is None else max(1, min(int(iterations), c.iterations))
        while it < cap and (it == 0 or errors[watch].max(initial=0.0) > c.tolerance):
            start, start_errors = cfg.q.copy(), errors
            self._take_step(dt)
            errors = norms(self.frame_positions() - targets, axis=1)
            it += 1
            # Not the first step: that one must stand (it may push the robot out of a person moving into it).
            if (it > 1 and c.max_worsening is not None
                    and _rms(errors, weight) > _rms(start_errors, weight) + c.max_worsening):
                cfg.update(start)
                errors = start_errors
                undone += 1
                self._damping = min(self._damping * c.damping_growth, c.max_damping)
            else:
                self._damping = max(self._damping / c.damping_growth, c.damping)
            worst = errors[watch].max(initial=0.0)
            if worst < best - c.min_progress:
                best, stalled = worst, 0
            else:
                best, stalled = min(best, worst), stalled + 1
                if stalled >= c.patience:
                    break
        return IKResult(qpos=cfg.q, errors=errors, iterations=it, undone=undone)



def _rms(errors: np.ndarray, weight: np.ndarray) -> float:
    """Root mean square of the key frames' ``errors`` (5,) metres, weighted by ``weight`` (5,) (their costs)."""
    return float(np.sqrt(np.sum(weight * errors**2) / np.sum(weight)))
