"""Standing on its own feet at the physics rate: a whole-body balance controller and the harness it lets go of.

With its real weight the robot hangs from a compliant harness that follows the IK's base
(:func:`~socialaff_sim.sim.scene.build_scene`), and its position servos track the IK's joint targets,
planned once per data frame. :class:`BalanceController` replaces the servos' action, at every physics step
while both feet are planted (by the foot lock) and on the floor, by torques computed from the measured state:

1. wanted accelerations: every joint toward the IK's target (PD of bandwidth ω_q, the frame's joint velocity
   as reference), the torso's attitude toward the IK's (ω_o), the planted feet held where they stood when both
   came down (k_x, k_f: a creeping foot is drawn back), and the centre of mass's horizontal position toward a
   reference c* over the feet (ω_c, ζ; :mod:`~.com_reference`): the IK's centre of mass relative to its feet carried
   over to the physical feet (or the middle of the feet; with ``com_shift`` moved forward by the feet's shortfall
   behind the plan's, :mod:`~.com_shift`), optionally moved to lean against the measured external forces
   (:mod:`~.external_force`), kept inside the support box (the feet's soles, found at home from their contacts
   with the floor, where they stand now) shrunk by a margin; with ``hand_yield`` the arms' references give way
   to a person's force beyond what the feet carry (:mod:`~.hand_yield`);
2. floating-base inverse dynamics with the floor's contact forces: at the feet's contact points as MuJoCo found
   them, forces inside friction cones that balance the root's six unactuated rows, q̈ as close to the wanted one
   as the weights allow (the arms' and head's joints by ``upper_weight`` less); τ = M q̈ + h − Jᵀf on the hinges.
   ``solver="lsq"``: weighted least squares (:mod:`~.contact_dynamics`); ``solver="qp"``: a quadratic program
   (:mod:`~.contact_qp`) in which the root's rows, each actuator's torque limit at this state (times
   ``torque_fraction``), each foot's centre of pressure ``cop_margin`` inside its sole and a minimum load per
   foot hold as constraints (with ``self_clearance`` also the arms' distances to the body, :mod:`~.self_clearance`);
3. the servos are made to exert τ exactly: ctrl = (τ − b₀ − b₁ q − b₂ q̇) / g for force = g·ctrl + b₀ + b₁q +
   b₂q̇ (MuJoCo clips it at the actuator's force limit, which the support meter reports as saturation).

The harness weld lets go (``eq_active = 0``; its force is then zero by construction) of a steady standing robot
and catches it again (:mod:`~.harness_release`, which the controller feeds the torso's tilt from upright, or with
``tilt_from_plan`` from the plan's torso attitude, and the capture point ξ = c + ċ/ω₀ against the support box: the
soles of the feet in contact, and of a planted foot within ``sole_gap`` of the floor). Everything is decided per
physics step; the per-frame part is the IK's plan (:meth:`begin_frame`).

The step is split (:func:`mujoco.mj_step1`, the controller, :func:`mujoco.mj_step2`) so that the controller
reads the mass matrix, bias forces and contacts of the state it acts on; a weld switched after ``mj_step1``
takes effect at the next step (4 ms).
"""

from __future__ import annotations

import math
from functools import partial

import mujoco
import numpy as np

from ..retarget.kinematic_tree import shared_ancestor, subtree_mask
from .arm_compensation import ArmCompensation
from .balance_config import BalanceConfig
from .centroidal_momentum import CentroidalMomentum, plan_velocity
from .contact_dynamics import cone_edges, solve_contact_dynamics
from .com_reference import ComReference
from .compiled_pieces import CompiledPieces
from .contact_qp import ActuatorLimits, solve_contact_qp
from .cop_constraints import cop_constraint_rows
from .external_force import ExternalForces, FilteredExternal, lean_offset
from .feet_on_floor import FeetOnFloor
from .flat_feet import flat_attitude, flat_contacts, foot_feedback, roll_free_axes, roll_freed, yaw_rows
from .hand_task import HandTask, arm_row_scale, hand_task_wanted
from .hand_yield import HandYield
from .harness_release import HarnessRelease
from .plan_velocity import PlanVelocity
from .scene import Scene
from .self_clearance import SelfClearance
from .shear_spread import feet_shear_cost, shear_spread_cost
from .support_box import SupportBox
from .torque_hold import TorqueHold
from .torso_attitude import TorsoAttitude

__all__ = ["BalanceController", "BalanceConfig", "lean_offset"]


class BalanceController:
    """The physics-rate balance control of one physics scene (see the module docstring); :meth:`reset` per
    episode, :meth:`begin_frame` per data frame, :meth:`step` in place of ``mujoco.mj_step``."""

    def __init__(self, scene: Scene, config: BalanceConfig | None = None) -> None:
        self.scene = scene
        self.config = config or BalanceConfig()
        m = scene.model
        self.vadr = np.asarray(scene.robot_vadr)
        self.qadr = np.asarray(scene.robot_qadr)
        n = len(self.vadr)
        where = {int(v): i for i, v in enumerate(self.vadr)}
        self._act_rows = np.array([where[int(v)] for v in scene.act_vadr], dtype=np.int64)
        self.unactuated = np.ones(n, dtype=bool)
        self.unactuated[self._act_rows] = False
        robot = subtree_mask(m, scene.root_body)
        self.mass = float(m.body_mass[robot].sum())
        self._g = float(np.linalg.norm(m.opt.gravity))
        self.feet = FeetOnFloor(scene, self.config.sole_gap)
        """The feet, their soles and their contacts with the floor (:mod:`~.feet_on_floor`)."""
        f = self.feet
        self._feet, self._foot_fwd, self._corners = f.bodies, f.forward, f.corners
        self._home_rot, self._home_z = f.home_rot, f.home_z
        # flat_roll_free: the forward axis (body frame) of each foot whose leg cannot roll it, else None
        self._roll_free = roll_free_axes(m, f.bodies, f.forward, scene.root_body) if self.config.flat_roll_free else None
        self.roll_freed = roll_freed(self._roll_free)
        """Whether ``flat_roll_free`` frees some foot's roll rows on this robot (a leg that cannot roll it: the H1)."""
        self.torso_bandwidth = (self.config.torso_bandwidth_roll_free if self.roll_freed and
                                self.config.torso_bandwidth_roll_free is not None else self.config.torso_bandwidth)
        """[rad/s] The torso task's ω_o: ``torso_bandwidth_roll_free`` where this robot's roll is freed and it is set."""
        # the body both shoulders hang from (as SupportMeter measures tilt)
        self._torso = shared_ancestor(m, int(scene.limb_body_ids[0]), int(scene.limb_body_ids[1]), scene.root_body)
        upper = subtree_mask(m, self._torso)
        upper[self._torso] = False
        self._upper = upper[m.dof_bodyid[self.vadr[6:]]]  # (n − 6,) the hinges above the torso (arms, head)
        ids = scene.act_ids
        self._gain = m.actuator_gainprm[ids, 0].copy()
        self._bias = m.actuator_biasprm[ids, :3].copy()
        self._act_q, self._act_v = np.asarray(scene.act_qadr), np.asarray(scene.act_vadr)
        self.attitude = TorsoAttitude(scene, self._torso, self.config.tilt_from_plan)
        """The torso's tilt and the plan's lean (:mod:`~.torso_attitude`)."""
        self._external = ExternalForces(scene)
        self.external = FilteredExternal(self._external, self.config.external_filter)
        """``external_forces``: the external contacts' filtered estimate (:mod:`~.external_force`)."""
        c = self.config
        self._clearance = None if c.self_clearance is None else SelfClearance.of_scene(
            scene, c.self_clearance, c.clearance_detection, c.clearance_bandwidth)
        self.hand_yield = None if c.hand_yield is None else HandYield(scene, c.hand_yield, c.yield_damping,
                                                                      c.yield_return, c.external_filter,
                                                                      c.yield_twist, c.yield_carried, c.qp_kernel)
        """``hand_yield``: the arms' give (:mod:`~.hand_yield`), else ``None``."""
        self.compensation = None if c.arm_compensation is None else ArmCompensation(
            scene, c.arm_compensation, c.compensation_release, c.external_filter, c.compensation_gate, c.qp_kernel)
        """``arm_compensation``: the arms' references on the trunk as it is (:mod:`~.arm_compensation`), else ``None``."""
        limits = ActuatorLimits(m, scene.act_ids)
        self._kernel = CompiledPieces(m, c, self.feet, self.vadr, self._act_rows, limits, self._clearance,
                                      self.roll_freed) if c.qp_kernel == "numba" else None  # (:mod:`~.compiled_pieces`)
        self._bounds = partial(limits.bounds, rows=self._act_rows, n=n, fraction=c.torque_fraction) if (
            self._kernel is None) else self._kernel.limits  # the QP's torque bounds at a state
        self.hold = None if c.qp_every == 1 else TorqueHold(c.qp_every, c.hold_gain, c.joint_bandwidth)
        """``qp_every`` > 1: the torques held between solves (:mod:`~.torque_hold`), else ``None``."""
        self._hinge_ref = self._act_rows + 1  # each actuator's entry in the robot coordinates (free joint's 7 first)
        self.hands = HandTask(scene, c.hand_task, c.hand_task_bandwidth, c.hand_task_touched,
                              c.hand_task_plan_velocity, c.hand_task_velocity_until_touch) if hand_task_wanted(
            c.hand_task, c.hand_task_roll_free, self._roll_free) else None
        """``hand_task`` (``hand_task_roll_free``: where the feet's roll is freed): :mod:`~.hand_task`'s rows, or ``None``."""
        self.com = ComReference(c, self._feet, scene.root_body, self.compensation)
        """The centre of mass's reference c* (:mod:`~.com_reference`)."""
        self._plan = mujoco.MjData(m)
        self.plan_velocity = PlanVelocity.of_scene(scene, self._feet, self._torso, c.plan_velocity_raised,
            c.plan_velocity_until_touch, c.plan_velocity_tilt) if c.com_plan_velocity or c.torso_plan_velocity else None
        """``com_plan_velocity`` / ``torso_plan_velocity``: :mod:`~.plan_velocity` over the frame, or ``None``."""
        self.angmom = None if c.angmom_weight is None else CentroidalMomentum(m, scene.root_body, self.vadr,
                                                                           c.angmom_bandwidth)
        """``angmom_weight``: the centroidal angular momentum's rows (:mod:`~.centroidal_momentum`), else ``None``."""
        self._plan_qvel = np.zeros(len(self.vadr))  # angmom_weight: the plan's velocity over the frame
        self._Mix = np.ix_(self.vadr, self.vadr)  # made once
        scale = np.sqrt(np.where(self._upper, c.upper_weight, 1.0))  # per-row weights inside the joints' task
        if self.hands is not None and c.hand_task_arm_weight is not None:  # the hands' arms' rows lighter
            scale = arm_row_scale(scale, self.hands.arm_columns(m, self._torso, self.vadr), c.hand_task_arm_weight)
        self._joint_scale, self._joint_rows = scale, np.eye(n)[6:] * scale[:, None]
        self._joint_diag = np.concatenate([np.zeros(6), scale])  # the same rows as the QP's diagonal task
        self._foot_scratch = (np.zeros((6, m.nv)), np.zeros((6, m.nv)))
        self._edges: tuple[bytes, np.ndarray] = (b"", np.zeros((0, 3, 4)))  # the last frames' cone edges
        self._spread: np.ndarray | None = None  # shear_spread: their cost on the shear's spread (:mod:`~.shear_spread`)
        self._soles_now: list[np.ndarray | None] = [None] * len(self._feet)  # the step's soles, world (soles_at)
        self._M = np.zeros((m.nv, m.nv))
        self._jp, self._jr, self._quat, self._rot = np.zeros((3, m.nv)), np.zeros((3, m.nv)), np.zeros(4), np.zeros(3)
        self.harness = HarnessRelease(scene, self.config, self.roll_freed)
        """The harness: when it lets go and catches, the counts of both (:mod:`~.harness_release`)."""
        self.reset()

    # -- episode and frame ----------------------------------------------------------------------------------
    def reset(self) -> None:
        """A new episode: harnessed, nothing planted, counters at zero."""
        self.harness.reset()
        self.carried = False
        """Whether the person carries the object at this step (set by the frame stepper before each step; read by
        ``yield_carried``)."""
        self.active = False
        """Whether the controller's torques drove the last step."""
        self._planted = (False, False)
        self._anchor: list[tuple[np.ndarray, np.ndarray]] | None = None
        self.external.clear()
        self.attitude.goal = np.eye(3)
        self.com.reset()
        self.steps = self.active_steps = 0
        """Physics steps run; driven by the controller."""
        self.limit_steps = self.relaxed_steps = self.qp_failures = self.yaw_dropped_steps = 0
        """``qp``: driven steps with a torque on its limit's bound; solved again without the foot loads and
        centre-of-pressure bounds; whose QP DAQP did not solve (the least-squares torques were used); (``yaw_first``)
        solved without the feet's rows about the vertical alone."""
        self.clearance_steps = self.clearance_dropped_steps = 0
        """``self_clearance``: driven steps with a clearance row in the QP; of them, those whose rows were dropped."""
        self.held_steps = 0
        """``qp_every`` > 1: driven steps whose torques were held (not solved)."""
        if self.hold is not None:
            self.hold.reset()
        self._capture = np.zeros(2)
        if self.hand_yield is not None:
            self.hand_yield.reset()
        if self.compensation is not None:
            self.compensation.reset()
        if self.plan_velocity is not None:
            self.plan_velocity.clear()

    def begin_frame(self, q_target: np.ndarray, planted: tuple[bool, bool] | None, q_start: np.ndarray | None = None,
                    duration: float = 0.0) -> None:
        """The IK's plan for the frame: robot coordinates ``q_target`` (nq_r,) at its end; ``planted`` (left,
        right): the foot lock's planted feet (``None``: no foot lock, the controller stays off); ``q_start`` (nq_r,):
        the references' start, ``duration`` (s) the time they take to ``q_target`` (the plan's velocities, read by
        ``com_plan_velocity`` and ``torso_plan_velocity``; ``None`` or 0 s: none)."""
        self._planted = (False, False) if planted is None else (bool(planted[0]), bool(planted[1]))
        m, p = self.scene.model, self._plan
        p.qpos[self.qadr] = q_target
        mujoco.mj_kinematics(m, p)
        mujoco.mj_comPos(m, p)
        self.com.begin_frame(p)
        self.harness.see_plan(p)  # (release_settled_raised: the strike's frames)
        self.attitude.goal = p.xmat[self._torso].reshape(3, 3).copy()
        if self.hands is not None:  # hand_task: the plan's wrists at the frame's end
            self.hands.begin_frame(p, q_start, duration)
        if self.angmom is not None:  # the plan's velocity over the frame (none without a start)
            self._plan_qvel = (np.zeros(len(self.vadr)) if q_start is None or duration <= 0.0 else
                               plan_velocity(q_start, q_target, duration))
            if self.config.angmom_root_still:
                self._plan_qvel[:6] = 0.0
        if self.plan_velocity is not None:
            if q_start is not None and duration > 0.0:
                self.plan_velocity.measure(q_start, p, duration)
            else:
                self.plan_velocity.clear()

    # -- the physics step -----------------------------------------------------------------------------------
    def step(self, m: mujoco.MjModel, d: mujoco.MjData, q_ref: np.ndarray, qd_ref: np.ndarray) -> None:
        """One physics step of ``d``: ``mj_step1``, the harness decision and (while standing) the torques toward
        the robot coordinates ``q_ref`` (nq_r,) with hinge velocities ``qd_ref`` (nv_r − 6,), ``mj_step2``."""
        self.harness.blend_anchor(m, d)
        mujoco.mj_step1(m, d)
        self.steps += 1
        c = self.config
        feet = self.feet if self._kernel is None else self._kernel.support  # (qp_kernel="numba": compiled)
        pts, frames, which = feet.contacts(d)
        standing = self._planted[0] and self._planted[1] and len(pts) > 0
        if not (self._planted[0] and self._planted[1]):
            self._anchor = None  # a step: the feet are held where they next stand
        tilt = self._step_tilt = self.attitude.tilt(d)  # (the plan's velocities' tilt bound reads it in _torques)
        box, capture, cxy = None, self._capture, None
        if standing:
            self._soles_now, box = feet.support(d, pts, which)  # the soles in the world (the _cop's bounds), the box
            com = d.subtree_com[self.scene.root_body]
            self._jp[:] = 0.0
            mujoco.mj_jacSubtreeCom(m, d, self._jp, self.scene.root_body)
            jcom = self._jp[:, self.vadr].copy()  # (C order: the BLAS products round as before)
            comvel = jcom @ d.qvel[self.vadr]
            height = max(float(com[2] - pts[:, 2].sum() / len(pts)), 1e-3)  # (the mean's arithmetic)
            capture = self._capture = com[:2] + comvel[:2] / math.sqrt(self._g / height)
            cxy = com[:2]
        touch = ((self.harness.tilt_touched is not None or c.release_settled_until_touch)
                 and self.compensation is not None and bool(self.compensation.touched.any()))
        self.harness.decide(d, m.opt.timestep, standing, tilt, box, capture, touch, cxy, self._catch_lean())
        released = self.harness.released
        self.active = standing and (released or c.drive_harnessed)
        if self.active:
            self.active_steps += 1
            q, v = d.qpos[self._act_q], d.qvel[self._act_v]
            hold = self.hold
            if hold is not None and not hold.due(released):
                self.held_steps += 1
                tau = hold.torques(q_ref[self._hinge_ref] - q, qd_ref[self._act_rows - 6] - v)
            else:
                tau = self._torques(m, d, q_ref, qd_ref, pts, frames, which, box, com, jcom, comvel)  # type: ignore[arg-type]
                if hold is not None and self._near_body:  # an arm close to the body: the next step solves too
                    hold.drop()
                elif hold is not None:
                    hold.store(tau, self._M[self._act_v, self._act_v], q_ref[self._hinge_ref] - q,
                               qd_ref[self._act_rows - 6] - v, released)
            b = self._bias
            d.ctrl[self.scene.act_ids] = (tau - b[:, 0] - b[:, 1] * q - b[:, 2] * v) / self._gain
        elif self.hold is not None:
            self.hold.drop()
        mujoco.mj_step2(m, d)
        # the step's contacts with anything but the floor, read once for every part that folds them in
        contacts = self._external.contacts(m, d) if standing and (
            self.hand_yield is not None or self.compensation is not None or c.external_forces) else None
        if self.hold is not None and c.hold_touch and standing and len(
                (contacts if contacts is not None else self._external.contacts(m, d)).geoms):
            self.hold.drop()  # touched by anything but the floor: the next driven step solves
        if standing and self.hand_yield is not None:
            self.hand_yield.measure(m, contacts, d, self.carried)  # type: ignore[arg-type]
        if standing and self.compensation is not None:
            self.compensation.measure(m, contacts)  # type: ignore[arg-type]
        if standing and c.external_forces:
            self.external.measure(m, d, contacts)  # type: ignore[arg-type]
        else:
            self.external.clear()

    def _torques(self, m: mujoco.MjModel, d: mujoco.MjData, q_ref: np.ndarray, qd_ref: np.ndarray, pts: np.ndarray,
                 frames: np.ndarray, which: np.ndarray, box: SupportBox, com: np.ndarray, jcom: np.ndarray,
                 comvel: np.ndarray) -> np.ndarray:
        """(n_act,) actuator torques (N·m) of the whole-body balance at the state after ``mj_step1``."""
        c = self.config
        va = self.vadr
        self._near_body = False  # (set below: an arm within hold_near of the body in this solve)
        mujoco.mj_fullM(m, d, self._M)
        M = self._M[self._Mix]
        # The external forces as known loads on the root's rows only: the feet's forces then carry them, while the
        # joints stay as compliant as their PD (feeding them to the arms' rows stiffened the arms against the
        # person, who pushed back harder a step later).
        h = d.qfrc_bias[va] - d.qfrc_passive[va] - np.where(self.unactuated, self.external.gen, 0.0)
        qv = d.qvel[va]
        tasks: list[tuple[np.ndarray, np.ndarray, float]] = []
        if self._anchor is None:  # where the feet stand (level, at the home ankle height, with flat_feet)
            self._anchor = [(d.xpos[b].copy(), d.xmat[b].reshape(3, 3).copy()) for b in self._feet]
            if c.flat_feet:
                self._anchor = [(np.array([p[0], p[1], self._home_z[s]]), flat_attitude(r, self._home_rot[s],
                                 self._foot_fwd[s])) for s, (p, r) in enumerate(self._anchor)]
        # planted feet held where they stand; with flat_feet the same rows, less their drift, hold as equalities
        flat = None if self._kernel is None else self._kernel.flat
        if flat is not None:  # qp_kernel="numba": both, compiled (:mod:`~.feet_kernel`)
            feet, pts, frames, which, eq = flat(m, d, self._anchor, pts, frames, which)
        else:
            feet = [foot_feedback(m, d, body, va, pos, rot, c.foot_stiffness, c.foot_damping, self._foot_scratch[0])
                    for body, (pos, rot) in zip(self._feet, self._anchor, strict=True)]
            eq = None
        tasks.extend((J, b, c.w_feet) for J, b in feet)
        if c.flat_feet and flat is None:
            pts, frames, which, eq = flat_contacts(m, d, self._feet, self._corners, self._anchor, va, pts, frames,
                                                   which, c.sole_gap, c.foot_stiffness, c.foot_damping,
                                                   self._foot_scratch, feet, self._roll_free)
        floor = float(pts[:, 2].sum() / len(pts))  # the contacts' mean height (m), for the lean and the hands' give
        full = np.empty((len(pts), 3, m.nv))  # each point's Jacobian written in place, the robot's columns taken once
        for i, (p, s) in enumerate(zip(pts, which.tolist(), strict=True)):
            mujoco.mj_jac(m, d, full[i], None, p, self._feet[s])
        jac = full[:, :, va]
        goal, w_com = self.com.goal(d, box)  # the shifted reference, the feet read once
        wc, zc = c.com_bandwidth, c.com_damping
        if c.external_forces:  # lean so that the feet carry the external forces' moment about the goal's point
            p = np.array([goal[0], goal[1], floor])
            goal = goal + lean_offset(self.external.moment, self.external.force, p, self.mass * self._g)
        goal = box.clip(goal, c.support_margin)
        touched = self.compensation is not None and bool(self.compensation.touched.any())  # the episode's latch
        moving = self.plan_velocity is not None and self.plan_velocity.follows(touched, self._step_tilt)
        if c.com_plan_velocity and moving:  # the damping toward the plan's velocity (relative to the feet), not rest
            tasks.append((jcom[:2], wc * wc * (goal - com[:2]) + 2.0 * zc * wc * (self.plan_velocity.com - comvel[:2]),  # type: ignore[union-attr]
                          w_com))
        else:
            tasks.append((jcom[:2], wc * wc * (goal - com[:2]) - 2.0 * zc * wc * comvel[:2], w_com))
        mujoco.mj_jacBody(m, d, self._jp, self._jr, self._torso)
        Jt = self._jr[:, va].copy()  # (C order, as jcom's)
        err = self.attitude.goal @ d.xmat[self._torso].reshape(3, 3).T  # world rotation from now to the goal
        mujoco.mju_mat2Quat(self._quat, err.ravel())
        mujoco.mju_quat2Vel(self._rot, self._quat, 1.0)
        wo = self.torso_bandwidth
        if c.torso_plan_velocity and moving:  # toward the plan's angular velocity, not toward rest
            tasks.append((Jt, wo * wo * self._rot + 2.0 * wo * (self.plan_velocity.torso - Jt @ qv), c.w_torso))  # type: ignore[union-attr]
        else:
            tasks.append((Jt, wo * wo * self._rot - 2.0 * wo * (Jt @ qv), c.w_torso))
        if self.angmom is not None:  # the floor's moment, not the trunk, takes the swing's reaction
            tasks.append((*self.angmom.rows(m, d, self._plan_qvel, pts.mean(axis=0) if c.angmom_about_feet else None),
                          c.angmom_weight))
        hinge_q = d.qpos[self.qadr[7:]]
        wq = c.joint_bandwidth
        dq, dv = (0.0, 0.0) if self.hand_yield is None else self.hand_yield.references(  # the arms give way to a
            m, d, box, self._capture, floor, c.cop_margin, self.mass * self._g)  # force too large
        if self.compensation is not None:  # the arms' references on the trunk as it is
            dq = dq + self.compensation.offsets(m, d, q_ref)
        want = wq * wq * (q_ref[7:] + dq - hinge_q) + 2.0 * wq * (qd_ref + dv - qv[6:])
        joints = want * self._joint_scale  # per-row weights inside one task
        if self.hands is not None:  # (before the joints' task, which the QP takes last)
            tasks.extend(self.hands.tasks(m, d, va, None if self.compensation is None else self.compensation.touched))
        tasks.append((self._joint_rows, joints, c.w_joint))
        key = frames.tobytes()  # with flat_feet the same level frames step after step: their edges made once
        mu = c.friction
        if c.touch_friction is not None and touched:
            mu, key = c.touch_friction, key + b"t"  # after the first touch: the touch's cones
        if key != self._edges[0]:
            self._edges = (key, cone_edges(frames, mu))
            self._edges[1].flags.writeable = False
            self._spread = None if c.shear_spread is None else shear_spread_cost(self._edges[1], c.shear_spread)
        edges = self._edges[1]
        if c.solver == "lsq":
            return solve_contact_dynamics(M, h, self.unactuated, jac, edges, tasks, self.mass, c.w_dynamics,
                                          c.w_force).tau[self._act_rows]
        limits = self._bounds(d.qpos[self._act_q], d.qvel[self._act_v])  # (n, 2): the actuators' limits, ±inf
        # The loads and centre-of-pressure bounds only for feet on an area (three contacts or more): on fewer, β ≥ 0
        # already keeps the centre of pressure on them, and the bounds' box may miss their segment.
        area = np.bincount(which, minlength=len(self._feet)) >= 3
        foot = np.where(area[which], which, -1)
        ineq = None if self._clearance is None else (self._clearance.rows(m, d) if self._kernel is None else
                                                     self._kernel.clearance_rows(m, d))  # type: ignore[misc]
        near = None if ineq is None else self._clearance.last_distance  # type: ignore[union-attr]
        self._near_body = near is not None and bool((near < c.hold_near).any())
        # the joints' rows as the QP's diagonal task: no (n − 6) × n products of zeros
        qp_tasks = [*tasks[:-1], (self._joint_diag, np.concatenate([np.zeros(6), joints]), c.w_joint)]
        res = solve_contact_qp(M, h, self.unactuated, jac, edges, qp_tasks, self.mass, c.w_force, limits,
                               cop_constraint_rows(c, pts, edges, foot, box.R, self._soles_now, d.xmat, self._feet,
                                                   self._foot_fwd, c.qp_kernel), foot, c.min_foot_load * self.mass * self._g,
                               equalities=eq, inequalities=ineq, kernel=c.qp_kernel,
                               force_cost=feet_shear_cost(self._spread, touched or not c.shear_spread_touched,
                                                          c.shear_couple, touched or not c.shear_couple_touched,
                                                          c.shear_couple_form, edges, which, pts),
                               optional=None if eq is None or not c.yaw_first else yaw_rows(len(eq[1])))
        self.yaw_dropped_steps += int(res.optional_dropped)
        self.limit_steps += int(res.at_limit.any())
        self.relaxed_steps += int(res.relaxed)
        self.clearance_steps += int(ineq is not None)
        self.clearance_dropped_steps += int(res.inequalities_dropped)
        if not res.found:  # (not seen since the rows are scaled) the least-squares torques instead of none
            self.qp_failures += 1
            return solve_contact_dynamics(M, h, self.unactuated, jac, edges, tasks, self.mass, c.w_dynamics,
                                          c.w_force).tau[self._act_rows]
        return res.tau[self._act_rows]

    # -- measurements ---------------------------------------------------------------------------------------
    def _catch_lean(self) -> float:
        """The plan's lean the harness's catch reads (``catch_tilt_lean_roll_free``; 0 where it does not act, or
        with ``catch_tilt_lean_touched`` before an arm's first touch)."""
        if self.harness.lean_gain is None or (self.config.catch_tilt_lean_touched and not (
                self.compensation is not None and bool(self.compensation.touched.any()))):
            return 0.0
        return self.attitude.plan_lean()
