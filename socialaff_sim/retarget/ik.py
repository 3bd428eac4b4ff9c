"""Differential inverse kinematics of the robot's five key frames with mink.

Tasks: one :class:`mink.FrameTask` per key frame (positions; plus orientation for
the base, kept upright and facing the partner, and the feet, kept flat) and a
:class:`mink.PostureTask` toward the home posture that settles the redundancy.
Limits: :class:`mink.ConfigurationLimit` (joint ranges), :class:`mink.VelocityLimit`
(every hinge), and two :class:`mink.CollisionAvoidanceLimit`: one keeps the whole
robot ``min_distance`` clear of the human's capsules, except the pairs the task
requires to touch (a robot hand or forearm and the named human parts), and the
forearms and hands clear of the rest of the robot; the other lets those required
pairs touch, at most ``contact_depth`` deep.

Each call of :meth:`RobotIK.solve` runs up to ``iterations`` QP steps for one
data frame of period ``dt``; the velocity limit bounds the joints' total change
over the frame to ``v_max · dt``; it stops early once every key frame is within
``tolerance`` or an iteration no longer helps.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mink
import mujoco
import numpy as np

from ..errors import SimulationError

__all__ = ["IKConfig", "IKModel", "IKResult", "RobotIK", "JointBoxLimit", "ActiveRowsLimit"]


class JointBoxLimit(mink.Limit):
    """A mink ConfigurationLimit and VelocityLimit on the same joints, merged into one box per frame.

    Row for row it is the tighter of the two limits' bounds on Δq, computed from
    their ranges, gain and velocities: ``gain·(q_max − q)`` (and below) and
    ``v_max·dt``. The velocity bound applies to the whole data frame: across the
    IK iterations of one frame the joints may move at most ``v_max·dt`` from where
    the frame started (:meth:`begin_frame`), so a single iteration can use all of
    it. Merging halves the QP's inequality rows.
    """

    def __init__(self, model: mujoco.MjModel, config_limit: mink.ConfigurationLimit,
                 velocity_limit: mink.VelocityLimit) -> None:
        if not np.array_equal(config_limit.indices, velocity_limit.indices):
            raise SimulationError("joint limits: the velocity limit must cover exactly the range-limited joints, in order")
        if len(config_limit._ball_qposadr):
            raise SimulationError("joint limits: ball joints are not supported")
        self.config_limit = config_limit
        self.velocity_limit = velocity_limit
        dofs = np.asarray(config_limit.indices, dtype=np.int64)
        self._qadr = model.jnt_qposadr[model.dof_jntid[dofs]] if dofs.size else np.zeros(0, dtype=np.int64)
        # Hinge and slide coordinates are scalars: q_max ⊖ q is a plain difference, and G never changes.
        self._lower = config_limit.lower[self._qadr]
        self._upper = config_limit.upper[self._qadr]
        self._G = (np.vstack([config_limit.projection_matrix, -config_limit.projection_matrix])
                   if config_limit.projection_matrix is not None else None)
        self._start = np.zeros(len(self._qadr))

    def begin_frame(self, q: np.ndarray) -> None:
        """Remember the configuration (nq,) the current frame starts from."""
        self._start = np.asarray(q)[self._qadr].copy()

    def compute_qp_inequalities(self, configuration: mink.Configuration, dt: float) -> mink.Constraint:
        if self._G is None:
            return mink.Constraint()
        q = configuration.data.qpos[self._qadr]
        gain = self.config_limit.gain
        step = self.velocity_limit.limit * dt
        moved = q - self._start
        upper = np.maximum(np.minimum(gain * (self._upper - q), step - moved), 0.0)
        lower = np.maximum(np.minimum(gain * (q - self._lower), step + moved), 0.0)
        return mink.Constraint(G=self._G, h=np.concatenate([upper, lower]))


class ActiveRowsLimit(mink.Limit):
    """A mink collision limit with its inactive rows dropped and its bound put in Δq units.

    ``mink.solve_ik`` solves for the displacement Δq (its configuration and velocity
    limits bound Δq), but mink 1.3's :class:`mink.CollisionAvoidanceLimit` returns
    the bound gain·(d − d_min)/dt, a velocity. Multiplying by dt makes it the
    intended displacement bound gain·(d − d_min) for any frame period (the two
    agree only for dt = 1 s). Rows without a nearby pair (infinite bound) are
    dropped before the QP, whose solve time grows with its rows.
    """

    def __init__(self, inner: mink.CollisionAvoidanceLimit) -> None:
        self.inner = inner

    def compute_qp_inequalities(self, configuration: mink.Configuration, dt: float) -> mink.Constraint:
        c = self.inner.compute_qp_inequalities(configuration, dt)
        if c.inactive:
            return c
        keep = np.isfinite(c.h)
        if not keep.any():
            return mink.Constraint()
        return mink.Constraint(G=c.G[keep], h=c.h[keep] * dt)


@dataclass(frozen=True)
class IKConfig:
    """Weights, limits and stopping rule of the retargeting IK."""

    position_cost: float = 1.0
    """Cost of a key frame's position error (per metre)."""
    base_orientation_cost: float = 2.0
    """Cost of the base's orientation error (per radian)."""
    foot_orientation_cost: float = 0.05
    """Cost of each foot's orientation error (per radian)."""
    posture_cost: float = 0.01
    """Cost of departing from the home posture (per radian)."""
    damping: float = 1e-4
    """Levenberg-Marquardt damping of the QP."""
    iterations: int = 3
    """Most QP steps per data frame."""
    tolerance: float = 0.015
    """Stop once every key frame is this close to its target, metres."""
    min_progress: float = 0.002
    """Also stop when an iteration reduced the largest key-frame error by less than this, metres
    (the target is out of reach: a limit or the collision avoidance holds the frame back)."""
    min_distance: float = 0.01
    """Distance collision avoidance keeps between a robot hand and the human, metres."""
    contact_depth: float = 0.0
    """How far a hand may press into the human where the task wants them to touch, metres."""
    detection_distance: float = 0.1
    """Distance below which a hand-human pair enters the QP, metres."""
    collision_gain: float = 0.85
    """Fraction of the remaining gap a hand may close per step."""
    solver: str = "daqp"
    """QP solver name understood by qpsolvers."""


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


@dataclass(frozen=True)
class IKResult:
    """One frame's solution."""

    qpos: np.ndarray
    """(nq,) robot configuration (free joint then hinges), world frame."""
    errors: np.ndarray
    """(5,) distance of each key frame to its target, metres."""
    iterations: int
    """QP steps taken."""


class RobotIK:
    """mink IK on one :class:`IKModel`; keeps its own MjData (one instance per simulator)."""

    def __init__(self, ik_model: IKModel, config: IKConfig | None = None) -> None:
        self.spec = ik_model
        self.config = c = config or IKConfig()
        m = ik_model.model
        if m.nq != len(ik_model.home_qpos):
            raise SimulationError(f"IK model has nq = {m.nq}, home posture has {len(ik_model.home_qpos)} values")
        self.configuration = mink.Configuration(m, ik_model.home_qpos)
        self.frame_tasks = []
        for k, (kind, fid) in enumerate(zip(ik_model.frame_kinds, ik_model.frame_ids, strict=True)):
            rot = c.base_orientation_cost if k == 0 else (c.foot_orientation_cost if k >= 3 else 0.0)
            self.frame_tasks.append(
                mink.FrameTask(frame_name=int(fid), frame_type=kind, position_cost=c.position_cost, orientation_cost=rot)
            )
        self.posture_task = mink.PostureTask(m, cost=c.posture_cost)
        self.posture_task.set_target(ik_model.home_qpos)
        hinges = [m.joint(j).name for j in range(m.njnt) if int(m.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))]
        self.config_limit = mink.ConfigurationLimit(m)
        limited = [n for n in hinges if m.jnt_limited[m.joint(n).id]]
        self.velocity_limit = mink.VelocityLimit(m, {n: ik_model.max_joint_velocity for n in limited})
        self._box = JointBoxLimit(m, self.config_limit, self.velocity_limit)
        self.collision_limit: mink.CollisionAvoidanceLimit | None = None
        self.contact_limit: mink.CollisionAvoidanceLimit | None = None
        robot = [int(g) for g in ik_model.robot_geoms]
        self._self_pairs = [
            ([int(g) for g in ik_model.arm_geoms[s]], [g for g in robot if g not in set(ik_model.arm_geoms[s].tolist())])
            for s in (0, 1)
        ]
        self.set_contact_exemptions([])
        self._home_rot = self._frame_rotations(ik_model.home_qpos)


    # -- set-up ---------------------------------------------------------------------
    def _frame_rotations(self, q: np.ndarray) -> list[np.ndarray]:
        self.configuration.update(q)
        d = self.configuration.data
        out = []
        for kind, fid in zip(self.spec.frame_kinds, self.spec.frame_ids, strict=True):
            xmat = d.site_xmat[fid] if kind == "site" else d.xmat[fid]
            out.append(np.array(xmat).reshape(3, 3))
        return out

    def _avoidance(self, pairs: list[tuple[list[int], list[int]]], min_distance: float) -> mink.CollisionAvoidanceLimit | None:
        pairs = [(a, b) for a, b in pairs if a and b]
        if not pairs:
            return None
        c = self.config
        return mink.CollisionAvoidanceLimit(
            self.spec.model, geom_pairs=pairs, gain=c.collision_gain,
            minimum_distance_from_collisions=min_distance, collision_detection_distance=c.detection_distance,
        )

    def set_contact_exemptions(self, exempt: Sequence[tuple[int, Sequence[int]]]) -> None:
        """Rebuild the human collision avoidance; (hand side 0/1, human geom ids) pairs may touch.

        The listed human geoms may touch that side's hand and forearm: those pairs keep
        a limit too, but one that lets them press ``contact_depth`` into the human
        instead of stopping ``min_distance`` short, so a required contact happens
        without the hand being driven deep into the person.
        Call it again whenever the human's capsule sizes change (the limit caches bounding radii).
        """
        free: dict[int, set[int]] = {0: set(), 1: set()}
        for side, geoms in exempt:
            free[int(side)].update(int(g) for g in geoms)
        human = [int(g) for g in self.spec.human_geoms]
        arms = {int(g) for side in (0, 1) for g in self.spec.arm_geoms[side]}
        trunk = [int(g) for g in self.spec.robot_geoms if int(g) not in arms]
        apart, touch = [(trunk, human)], []
        for side in (0, 1):
            arm = [int(g) for g in self.spec.arm_geoms[side]]
            apart.append((arm, [g for g in human if g not in free[side]]))
            touch.append((arm, sorted(free[side])))
        c = self.config
        self._apart = apart
        self.collision_limit = self._avoidance(apart + self._self_pairs, c.min_distance)
        self.contact_limit = self._avoidance(touch, -c.contact_depth)

    def limits(self) -> list[mink.Limit]:
        """The limits passed to the QP."""
        out: list[mink.Limit] = [self._box]
        for lim in (self.collision_limit, self.contact_limit):
            if lim is not None:
                out.append(ActiveRowsLimit(lim))
        return out

    def reset(self, qpos: np.ndarray) -> None:
        """Start from configuration ``qpos`` (nq,), at rest."""
        self.configuration.update(np.asarray(qpos, dtype=np.float64))

    def set_human(self, pos: np.ndarray, quat: np.ndarray) -> None:
        """Place the human's mocap bodies: ``pos`` (G, 3) metres, ``quat`` (G, 4) (w, x, y, z)."""
        d = self.configuration.data
        d.mocap_pos[self.spec.human_mocap] = pos
        d.mocap_quat[self.spec.human_mocap] = quat

    # -- solving --------------------------------------------------------------------
    def frame_positions(self) -> np.ndarray:
        """(5, 3) current key-frame positions, world frame."""
        d = self.configuration.data
        return np.array([d.site_xpos[i] if k == "site" else d.xpos[i]
                         for k, i in zip(self.spec.frame_kinds, self.spec.frame_ids, strict=True)])

    def solve(self, targets: np.ndarray, yaw: float, dt: float) -> IKResult:
        """Move toward world-frame ``targets`` (5, 3) over one frame of ``dt`` seconds.

        ``yaw`` (rad) turns the base's and the feet's home orientations to face the partner.
        """
        targets = np.asarray(targets, dtype=np.float64)
        if targets.shape != (5, 3) or not np.isfinite(targets).all():
            raise SimulationError(f"IK targets: expected a finite (5, 3) array, found shape {targets.shape}")
        if dt <= 0:
            raise SimulationError(f"IK frame period: expected dt > 0, found {dt}")
        cy, sy = np.cos(yaw), np.sin(yaw)
        rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
        cfg = self.configuration
        current = self._frame_rotations(cfg.q)
        for k, task in enumerate(self.frame_tasks):
            # Wrists are points: their target turns with them, so the SE(3) error is purely translational.
            r = current[k] if k in (1, 2) else rz @ self._home_rot[k]
            task.set_target(mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(r), targets[k]))
        tasks = [*self.frame_tasks, self.posture_task]
        c = self.config
        limits = self.limits()
        self._box.begin_frame(cfg.q)
        errors = np.linalg.norm(self.frame_positions() - targets, axis=1)
        it = 0
        while it < c.iterations and errors.max() > c.tolerance:
            vel = mink.solve_ik(configuration=cfg, tasks=tasks, dt=dt, solver=c.solver, damping=c.damping, limits=limits)
            cfg.integrate_inplace(vel, dt)
            before = errors.max()
            errors = np.linalg.norm(self.frame_positions() - targets, axis=1)
            it += 1
            if before - errors.max() < c.min_progress:
                break
        return IKResult(qpos=cfg.q, errors=errors, iterations=it)
