"""The physics loop: a robot retargeted onto key-joint targets, facing a replayed human.

One :class:`Simulator` owns its MuJoCo models and data (no global state). It is
built for one robot and one task; :meth:`Simulator.reset` loads an instance
(compiling a scene once per skeleton layout, then reusing it), and
:meth:`Simulator.step` advances one data frame: the five robot-frame targets go
through mink IK, the robot's position servos and its base anchor track the
solution over the frame's physics steps while the human moves to the next
frame, and the task's sub-goals and failures are scored on the contacts.
:meth:`Simulator.step` is :meth:`~Simulator.solve` then :meth:`~Simulator.advance` over the whole frame; the
environment's control period advances a frame in pieces and may solve again within it. A source's key joints
become a frame's targets through :meth:`Simulator.retarget` (:mod:`~.frame_targets`).
"""

from __future__ import annotations

import copy
import time
from pathlib import Path

import numpy as np

from ..data.interaction import Interaction
from ..errors import SimulationError
from ..retarget.robot import RobotSpec, load_robot
from ..retarget.scaling import RobotFrame
from .carry import CarryPlan, release_object
from .frame_targets import FrameTargets, fill_targets
from .human import HumanPose
from .reach import reachable_targets
from .scene import set_human_sizes
from .reset_cache import ResetCache, Settled, build_placement
from .stage import Stage, contact_exemptions, key_frames, key_frames_at
from .stage_build import build_stage
from .footlock import FootLock, within
from .harness_release import planted_offset
from .reach_lean import ReachLean
from .sim_config import SimConfig, StepResult
from .simulator_views import SimulatorViews
from .strike_lean import PlanLean
from .tasks import TaskSpec, load_task

__all__ = ["SimConfig", "StepResult", "Simulator"]


class Simulator(SimulatorViews):
    """A robot facing a replayed human, stepped one data frame at a time (what an observer reads of it:
    :class:`~.simulator_views.SimulatorViews`)."""

    def __init__(self, robot: str | Path | RobotSpec, task: str | Path | TaskSpec, config: SimConfig | None = None) -> None:
        self.robot = robot if isinstance(robot, RobotSpec) else load_robot(robot)
        self.task = task if isinstance(task, TaskSpec) else load_task(task)
        self.config = config or SimConfig.mode(self.robot.physics)
        self._stages: dict[str, Stage] = {}
        self._stage: Stage | None = None
        self._footlock: FootLock | None = None
        self.interaction: Interaction | None = None
        self._reset_cache = ResetCache()
        self._settled = False
        self._targets = FrameTargets(self.task, self.config.contact_completion, self.config.scaling.object_lookahead)
        self._in_frame = False
        self._park_radius = 0.0 if self.task.object is None else float(self.task.object.spec.size[0])

    # -- set-up -----------------------------------------------------------------------
    def _get_stage(self, inter: Interaction) -> Stage:
        name = inter.layout.name
        if name not in self._stages:
            first = not hasattr(self, "measurements")
            stage, self.measurements, home_keys = build_stage(
                self.robot, self.task, self.config, inter.layout, None if first else self.measurements)
            if first:
                self._home_keys = home_keys
            self._stages[name] = stage
        return self._stages[name]

    def reset(
        self, interaction: Interaction, initial_targets: np.ndarray | None = None, *, placement_frames: int | None = None
    ) -> None:
        """Load an instance at frame 0; ``initial_targets`` (5, 3) robot frame sets the starting posture.

        ``placement_frames``: place and scale the robot from agent 1's first that many frames only (a causal
        source, such as the model's synthesis after T0 observed frames, may not see agent 1's recorded
        future); None: from the whole recording (ground-truth replay)."""
        stage = self._stage = self._get_stage(interaction)
        if not stage.exemptions_set:  # the task's contact sub-goals, the same for every instance: set once
            stage.ik.set_contact_exemptions(contact_exemptions(self.task.subgoals, stage.ik_scene))
            stage.exemptions_set = True
        self.interaction = inter = interaction
        # Plans of a causal source (the model's synthesis) glide their feet (SimConfig.plan_feet_causal_only).
        self._plan_feet = not self.config.plan_feet_causal_only or placement_frames is not None
        self._causal = placement_frames is not None  # (FootLockConfig.glide_gap_causal_only)
        place = self._reset_cache.get(inter, placement_frames)
        if place is None:
            place = build_placement(inter, placement_frames, stage.scene, stage.ik_scene.home_qpos, self.measurements,
                                    self.config.scaling, self.config.timestep, self.task.object)
            self._reset_cache.put(place)
        self._placement = place
        scene = stage.scene
        self.offset = place.offset
        self._person_keys = inter.key_joints()[:, 0] + self.offset  # (T, 5, 3) agent 0's key joints, world, m
        self.pose: HumanPose = place.pose
        set_human_sizes(scene, self.pose.half_lengths)
        set_human_sizes(stage.ik_scene, self.pose.half_lengths)
        self._segments = place.segments
        self.scaler = copy.copy(place.scaler)  # its online placement moves during the episode
        self._targets.reset(place, self.scaler, scene, stage.ik, self.measurements.arm)
        self.frame_R: RobotFrame = place.frame
        self._yaw = self.frame_R.yaw
        self.carry: CarryPlan | None = place.carry
        self.n_sub = place.n_sub
        scene.model.opt.timestep = place.timestep
        ik = stage.ik
        ik.collision_limit.restore(None)  # as newly built: the exemptions are the task's, set with the stage
        ik.set_human(self.pose.pos[0], self.pose.quat[0])
        q0 = place.home
        ik.reset(q0)
        self.frame = 0
        self.time = 0.0
        self._in_frame = False
        self.results: list[StepResult] = []
        self._start(q0)
        self._settled = False
        if initial_targets is not None:
            self.settle(initial_targets)

    def settle(self, targets: np.ndarray) -> None:
        """Before the first step: put the robot straight into the IK posture for robot-frame ``targets`` (5, 3)."""
        self._require()
        if self.frame != 0:
            raise SimulationError(f"settle is only possible at frame 0, the simulator is at frame {self.frame}")
        ik = self._stage.ik  # type: ignore[union-attr]
        world = self.frame_R.to_world(fill_targets(np.asarray(targets, dtype=np.float64), self._home_keys))
        # Straight after a reset the IK starts from the instance's home pose and a clear collision memory, so
        # its outcome depends on the targets alone and is replayed from the cache when they recur.
        fresh = not self._settled
        hit = self._placement.settled_for(world) if fresh else None
        if hit is not None:
            q = hit.qpos.copy()
            ik.reset(q)
            ik.collision_limit.restore(hit.limit)
        else:
            q = self._q
            for _ in range(self.config.settle_iterations):
                q = ik.solve(world, self._yaw, dt=1.0).qpos
            if fresh:
                self._placement.remember(world, Settled(q.copy(), ik.collision_limit.memory()))
        self._settled = True
        self._start(q)

    def _start(self, q0: np.ndarray) -> None:
        stage = self._stage
        assert stage is not None
        self._q = q0.copy()
        self._released = False
        stage.start(q0, self.pose, self._yaw, self.task.chair, self.carry, self._park_radius)
        bal = stage.stepper.balance
        lock = self.config.foot_lock
        if lock is not None:
            lock = lock.for_episode(plan_feet=self._plan_feet, causal=self._causal, counts_above=self.task.counts_above,
                                    roll_freed=bal is not None and bal.roll_freed, chair=self.task.chair)
        self._lean = PlanLean(None if stage.stance is None else stage.stance.config, self.task.counts_above,
                              bal is not None and bal.roll_freed)
        rl, sc = self.config.reach_lean, stage.scene
        self._reach_lean = None if rl is None else ReachLean(rl, sc.model, [sc.frame_body(k) for k in (3, 4)],
                                                             sc.root_body, stage.reach.arm, stage.reach.shoulders,
                                                             self.task.chair)
        if bal is not None:  # the harness's gates: release_tilt_touched (a throw's catch), release_settled (per task, source)
            lean = self._reach_lean  # ReachLeanConfig.lead: the leaned grip's reference, only where the lean acts
            bal.com.lead = lean.config.lead if lean is not None and lean.active else None
            bal.harness.gate_touched(self.task.has_catch, self.task.counts_above)
            bal.harness.gate_settled(self.task.counts_above, self._causal)
            bal.harness.gate_follow(self.task.chair)
        self._footlock = None if lock is None else FootLock(
            (float(self._home_keys[3, 2]), float(self._home_keys[4, 2])), lock)
        if self.carry is not None and self.carry.release_frame == 0:
            self._release(0)
        self.last_targets = self.frame_R.to_robot(key_frames_at(stage.ik_scene, q0, stage.kinematics))

    # -- object -----------------------------------------------------------------------
    def _release(self, s: float) -> None:
        stage = self._stage
        assert stage is not None and self.carry is not None
        self._released = True
        release_object(stage.scene, stage.data, self.carry, s)
        stage.scorer.mark_release(self.time)

    # -- stepping ---------------------------------------------------------------------
    @property
    def n_frames(self) -> int:
        return 0 if self.interaction is None else self.interaction.n_frames

    @property
    def done(self) -> bool:
        return self.interaction is not None and self.frame >= self.n_frames - 1

    def retarget(self, keys: np.ndarray, frame: int | None = None, subevent: str | None = None,
                 contact: bool = False, contact_inside: bool = False, contact_inside_next: bool = False) -> np.ndarray:
        """(5, 3) robot-frame targets from agent 1's key joints ``keys`` (5, 3) in the data frame at ``frame``
        (default: the next), scaled onto the robot and, with ``SimConfig.contact_completion``, the wrists completed
        onto a contact the task wants during ``subevent`` (the source's current sub-event). ``contact``: the
        source's model makes a hand contact in that sub-event (its intent to touch: the completion captures
        a free object; ``ContactCompletionConfig.intent``); ``contact_inside``: that contact is a keyframe inside
        the sub-event (the completion captures the person's hand too); ``contact_inside_next``: such a contact
        in that sub-event or the one most likely next (a held-out hand beyond reach moves the robot in;
        ``ContactCompletionConfig.approach``)."""
        self._require()
        t = self.frame + 1 if frame is None else frame
        t = min(max(t, 0), self.n_frames - 1)
        return self._targets(keys, t, self.pose, self.frame, self.data, self._released, subevent, contact,
                             contact_inside, contact_inside_next, self.results[-1].subgoals if self.results else None)

    def object_anchors(self, frame: int) -> np.ndarray | None:
        """(K, 3) world frame: the recorded object at ``frame`` and its path over the next
        ``ScalingConfig.object_lookahead`` s (:func:`~socialaff_sim.retarget.scaling.object_anchors`);
        ``None`` without an object track. These are the object anchors the scaler reacts to."""
        self._require()
        return self._targets.object_anchors(frame)

    def step(self, targets: np.ndarray, subevent: str | None = None) -> StepResult:
        """Advance one data frame toward robot-frame ``targets`` (5, 3), metres (NaN rows: keep home offsets)."""
        self.solve(targets, subevent)
        result = self.advance(self.n_sub)
        assert result is not None
        return result

    @property
    def substep(self) -> int:
        """Physics steps of the current frame already run (0 … ``n_sub`` − 1; 0 between frames)."""
        return 0 if self._stage is None else self._stage.stepper.k if self._in_frame else 0

    def solve(self, targets: np.ndarray, subevent: str | None = None, iterations: int | None = None) -> None:
        """Solve the IK toward robot-frame ``targets`` (5, 3), metres, for the end of the current frame.

        Between frames it starts the next one (:meth:`advance` then runs its physics steps); within a frame
        (after some of its physics steps) the servo references go from where they are to the new solution
        over the frame's remaining steps, the IK's frame period being the time that remains. ``iterations``: at
        most that many IK steps (``None``: ``IKConfig.iterations``)."""
        self._require()
        if self.done:
            raise SimulationError(f"the instance has ended (frame {self.frame} of {self.n_frames}); call reset")
        stage = self._stage
        assert stage is not None
        fps = self.interaction.fps  # type: ignore[union-attr]
        t0, t1 = self.frame, self.frame + 1
        k, n = self.substep, self.n_sub
        tg = fill_targets(np.asarray(targets, dtype=np.float64), self._home_keys)
        world = self.frame_R.to_world(tg)
        plan_feet = world[3:5].copy()  # the plan's ankles, before the foot lock holds them
        bal = stage.stepper.balance
        physical = None  # the physical ankle frames (world), read once when a foot-lock setting needs them
        if self._footlock is not None:
            physical = key_frames(stage.scene, stage.data)[3:5] if self._footlock.needs_physical else None
            last = self.results[-1] if self.results else None
            before = None  # the frame before last's gaps of the same sub-goals, read only for hold_step_ahead
            if self._footlock.config.hold_step_ahead is not None and len(self.results) > 1:
                before = [self.results[-2].subgoal_gaps.get(name) for name in self.results[-1].subgoal_gaps]
            flight = self._footlock.in_flight(t1, self.carry.release_frame if self.carry is not None
                                              and self.task.has_catch else None)  # (hold_step_flight)
            world[3:5] = self._footlock.apply(world[3:5], last is not None and any(last.subgoals_now.values()),
                                              physical, new_frame=not self._in_frame,
                                              caught=bal is not None and bal.harness.holds_caught,
                                              person=self._person_xy(t1) if self._footlock.config.hold_near is not None else None,
                                              flight=flight,
                                              **self._footlock.gap_flags(None if last is None else last.subgoal_gaps.values(),
                                                                         before))
        d_m = None if bal is None else bal.harness.follow
        if d_m is not None:  # (catch_follow_feet: near a meeting the caught robot is held over its feet)
            near = self._footlock is not None and bool(self.results) and within(d_m, self.results[-1].subgoal_gaps.values())
            if near and physical is None:
                physical = key_frames(stage.scene, stage.data)[3:5]
            bal.harness.feet_offset = planted_offset(physical, world[3:5], self._footlock.standing) if near else np.zeros(2)
        seg_a, seg_b, radius = self._segments
        reachable = reachable_targets(stage.reach, tg, world, seg_a[t1], seg_b[t1], radius)
        ik = stage.ik
        tic = time.thread_time()
        ik.set_human(self.pose.pos[t1], self.pose.quat[t1])
        planted = (False, False) if self._footlock is None else self._footlock.standing
        com_target = None
        if stage.stance is not None:  # the standing robot's frame (:mod:`~.stance`)
            centre = ik.balance.box_centre(key_frames(stage.scene, stage.data)[3:5], self._yaw)
            frames = stage.stepper.support.frames
            world[0], com_target = stage.stance.frame(stage.data, world[0], planted[0] and planted[1], centre,
                                                      frames[-1].tilt_deg if frames else 0.0,
                                                      ik.balance.box_centre(plan_feet, self._yaw) if self._plan_feet
                                                      else None, self._yaw)
        lean = self._lean.frame(tg, stage.reach.shoulders, self.results[-1] if self.results else None,
                                bal is not None and bal.harness.holds_caught, t1)
        if self._reach_lean is not None:  # (SimConfig.reach_lean)
            lean = max(lean, self._reach_lean.frame(tg))
        res = ik.solve(world, self._yaw, dt=1.0 / fps if k == 0 else (n - k) / (n * fps), care=reachable, planted=planted,
                       com_target=com_target, iterations=iterations, lean=lean,
                       com_cost=None if com_target is None else stage.stance.config.com_cost)  # type: ignore[union-attr]
        ik_seconds = time.thread_time() - tic
        feet = None if self._footlock is None else planted
        self.ik_errors = res.errors
        """(5,) m: distance of each key frame from its target after the latest IK solve."""
        if self._in_frame:
            stage.stepper.replan(stage.to_physics(res.qpos), feet=feet)
            self._solved = (tg, res, reachable, self._solved[3] + ik_seconds, subevent)
            return

        plan = self.carry

        def carry(k: int, now: float) -> bool:
            """Move the carried object along its plan at sub-step ``k``; release it (False) at its frame."""
            s0 = t0 + k / n
            if s0 + 1.0 / n > plan.release_frame - 1 + 1e-9:  # type: ignore[union-attr]
                self.time = now
                self._release(s0)
                return False
            stage.place_object(plan, s0, True, self._park_radius)
            return True

        stage.stepper.plan(
            n, fps, stage.to_physics(self._q), stage.to_physics(res.qpos),
            (self.pose.pos[t0], self.pose.pos[t1]), (self.pose.quat[t0], self.pose.quat[t1]),
            grip=self.config.grip, carry=carry if plan is not None and not self._released else None, feet=feet,
        )
        self._in_frame = True
        self._solved = (tg, res, reachable, ik_seconds, subevent)

    def advance(self, steps: int) -> StepResult | None:
        """Run up to ``steps`` more physics steps of the frame :meth:`solve` started; at the frame's end, close
        it and return what the frame did (else ``None``)."""
        self._require()
        if not self._in_frame:
            raise SimulationError("Simulator.advance: no frame started; call solve(targets) first")
        stage = self._stage
        assert stage is not None
        stepper = stage.stepper
        tg, res, reachable, ik_seconds, subevent = self._solved
        f0, k0 = stepper.force, stepper.k
        self.time = stepper.advance(stepper.k + max(0, int(steps)), self.time, subevent)
        self.control_force = (stepper.force - f0) / max(1, stepper.k - k0)
        """N: mean force on the person over the physics steps of the latest :meth:`advance`."""
        if stepper.k < self.n_sub:
            return None
        force = stepper.end_frame()
        self._in_frame = False
        scorer = stage.scorer
        t1 = self.frame + 1
        self._q = res.qpos
        self.frame = t1
        self.last_targets = tg
        if self.done:
            scorer.finish(self.time)
        scorer.measure_gaps(stage.data)
        result = StepResult(
            frame=t1, time=self.time, targets=tg, ik_error=res.errors, reachable=reachable,
            ik_iterations=res.iterations, ik_seconds=ik_seconds, subevent=subevent, force_on_human=force,
            subgoals={r.name: r.success for r in scorer.subgoals}, failed=scorer.failed, done=self.done,
            subgoals_now={r.name: r.current for r in scorer.subgoals},
            subgoal_gaps={r.name: r.gap for r in scorer.subgoals},
            support=stage.stepper.support.frames[-1] if stage.stepper.support.frames else None,
            completion=self._targets.weight_at(t1),
        )
        self.results.append(result)
        return result
