"""What a :class:`~socialaff_sim.sim.simulator.Simulator` compiles once per skeleton layout.

A :class:`Stage` holds the physics scene with its MjData, the IK scene (robot and
human only, :func:`~socialaff_sim.sim.scene.build_scene` with ``physics=False``)
with the mink IK on it, the sub-goal scorer, the frame stepper and the reach
model. The simulator builds one the first time it resets an instance of a layout
(:func:`compile_scenes` does the compiling) and reuses it for every later one; :meth:`Stage.start` puts its
physics, and all that measures or controls it, at the first frame of an instance.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import lru_cache

import mujoco
import numpy as np

from ..data.skeletons import SkeletonLayout
from ..errors import SimulationError
from ..retarget.ik import IKModel, RobotIK
from ..retarget.kinematic_tree import ancestry, shared_ancestor, subtree_mask
from ..retarget.robot import RobotSpec
from .carry import CarryPlan, hold_object, park_object
from .chair import chair_pose, place_chair
from .human import HumanPose
from .reach import ReachModel
from .robot_mjcf import limit_hand_force
from .scene import ObjectSpec, Scene, build_scene, pose_compliant
from .scoring import SubgoalScorer
from .substeps import FrameStepper
from .stance import StanceControl
from .tasks import SubgoalSpec

__all__ = ["Stage", "compile_scenes", "key_frames", "key_frames_at", "contact_exemptions", "leg_geoms"]


@dataclass
class Stage:
    """The compiled resources of one skeleton layout."""

    scene: Scene
    """The physics scene."""
    data: mujoco.MjData
    ik_scene: Scene
    """The IK scene: robot and human only."""
    ik: RobotIK
    scorer: SubgoalScorer
    ik_map: np.ndarray
    """(nq_ik,) position of each IK coordinate in the physics robot's coordinates."""
    stepper: FrameStepper
    reach: ReachModel
    stance: StanceControl | None = None
    """What the robot does while it stands (real weight only; ``SimConfig.stance``)."""
    exemptions_set: bool = False
    """Whether the IK's contact exemptions (the task's, the same for every instance) have been set."""
    kinematics: mujoco.MjData = field(init=False)
    """Scratch data of the IK scene for :func:`key_frames_at` (making one per call costs a millisecond)."""

    def __post_init__(self) -> None:
        self.kinematics = mujoco.MjData(self.ik_scene.model)

    def to_physics(self, q_ik: np.ndarray) -> np.ndarray:
        """Robot coordinates of the physics scene (..., nq_r) from IK ones (..., nq_ik); frozen joints at home."""
        q_ik = np.asarray(q_ik)
        out = np.broadcast_to(self.scene.home_qpos, (*q_ik.shape[:-1], len(self.scene.home_qpos))).copy()
        out[..., self.ik_map] = q_ik
        return out

    def start(self, q0: np.ndarray, pose: HumanPose, yaw: float, chair: bool, carry: CarryPlan | None,
              park_radius: float) -> None:
        """Reset the physics to an instance's first frame: the person posed at ``pose``'s first frame (and, with
        ``chair``, seated on the chair, facing the robot, whose facing is ``yaw`` rad), the robot at IK coordinates
        ``q0`` (nq_ik,) with its anchor and servo references there, the object (if the scene has one) placed by
        :meth:`place_object`; then the scorer, the support meter, the balance controller and the stance start
        from that state."""
        scene, data = self.scene, self.data
        mujoco.mj_resetData(scene.model, data)
        data.mocap_pos[scene.human_mocap] = pose.pos[0]
        data.mocap_quat[scene.human_mocap] = pose.quat[0]
        pose_compliant(scene, data, pose.pos[0], pose.quat[0])
        if chair:  # the person faces the robot, which faces them
            place_chair(scene.model, data, *chair_pose(scene.body, pose.joints[0], scene.body.radii, yaw + np.pi))
        data.qpos[scene.robot_qadr] = self.to_physics(q0)
        data.mocap_pos[scene.anchor_mocap] = q0[:3]
        data.mocap_quat[scene.anchor_mocap] = q0[3:7]
        data.ctrl[scene.act_ids] = scene.ctrl_for(data.qpos)
        if scene.object_geom >= 0:
            self.place_object(carry, 0.0, False, park_radius)
        mujoco.mj_forward(scene.model, data)
        self.scorer.reset()
        self.scorer.measure_gaps(data)
        self.stepper.support.reset()
        if self.stepper.balance is not None:
            self.stepper.balance.reset()
        if self.stance is not None:
            self.stance.reset()
            self.stance.apply(data)

    def place_object(self, carry: CarryPlan | None, s: float, moving: bool, park_radius: float) -> None:
        """Put the object on ``carry``'s track at fractional frame ``s`` (with the track's velocity if ``moving``),
        or, without a plan (the instance does not use it), park it out of the way (its radius ``park_radius``, m)."""
        if carry is None:
            park_object(self.scene, self.data, park_radius)
        else:
            hold_object(self.scene, self.data, carry, s, moving)


def compile_scenes(robot: RobotSpec, layout: SkeletonLayout, obj: ObjectSpec | None, *, timestep: float,
                   servo_bandwidth: float | None, hand_force: float | None,
                   gravity_compensation: bool = False, harness_time_constant: float | None = None,
                   stance_bandwidth: float | None = None, chair: bool = False,
                   compliant_person: bool = True,
                   floor_time_constant: float | None = None) -> tuple[Scene, Scene, IKModel, np.ndarray]:
    """The physics scene, the IK scene, the IK model on the latter and ``ik_map`` (see :class:`Stage`).

    ``timestep`` (s) and ``servo_bandwidth`` (rad/s) go to :func:`build_scene`;
    ``hand_force`` (N, ``None``: the model's limits) to :func:`~socialaff_sim.sim.robot_mjcf.limit_hand_force`;
    ``gravity_compensation``, ``harness_time_constant``, ``stance_bandwidth``: see
    :class:`~socialaff_sim.sim.simulator.SimConfig`; ``chair``: the physics scene has one (the task's);
    ``compliant_person``, ``floor_time_constant``: see :func:`build_scene`.
    """
    scene = build_scene(robot, layout, obj, timestep=timestep, servo_bandwidth=servo_bandwidth,
                        gravity_compensation=gravity_compensation, harness_time_constant=harness_time_constant,
                        stance_bandwidth=stance_bandwidth, chair=chair, compliant_person=compliant_person,
                        floor_time_constant=floor_time_constant)
    if hand_force is not None:
        limit_hand_force(scene, hand_force, weight=not gravity_compensation)
    ik_scene = build_scene(robot, layout, None, physics=False)
    collide = ik_scene.robot_geom & ((ik_scene.model.geom_contype != 0) | (ik_scene.model.geom_conaffinity != 0))
    ik_model = IKModel(
        model=ik_scene.model, frame_kinds=ik_scene.frame_kinds, frame_ids=ik_scene.frame_ids,
        home_qpos=ik_scene.home_qpos, hand_geoms=tuple(np.flatnonzero(h) for h in ik_scene.hand_geom),
        arm_geoms=tuple(np.flatnonzero(a) for a in ik_scene.arm_geom), robot_geoms=np.flatnonzero(collide),
        human_geoms=ik_scene.human_geom_ids, human_mocap=ik_scene.human_mocap,
        max_joint_velocity=robot.max_joint_velocity, torso_dofs=torso_dofs(ik_scene),
        leg_geoms=leg_geoms(ik_scene, collide),
    )
    if not np.array_equal(ik_scene.robot_qadr, np.arange(ik_scene.model.nq)):
        raise SimulationError("IK scene: the robot must own every coordinate")
    phys_index = {n: i for i, n in enumerate(scene.robot_joint_names)}
    ik_map = np.concatenate([np.arange(7), 6 + np.array([phys_index[n] for n in ik_scene.robot_joint_names[1:]], dtype=np.int64)])
    return scene, ik_scene, ik_model, ik_map


def leg_geoms(scene: Scene, collide: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The left and right leg's geom ids among ``collide`` (ngeom,) bool: the geoms of the subtree of each hip
    limb root (thigh, shin, foot)."""
    m = scene.model
    legs = [np.flatnonzero(subtree_mask(m, int(b))[m.geom_bodyid] & collide) for b in scene.limb_body_ids[2:4]]
    return legs[0], legs[1]


def torso_dofs(scene: Scene) -> np.ndarray:
    """Dof indices of the spine's tilting joints: the hinges from the torso (the lowest body both shoulders
    hang from) down to, not including, the robot's root body, whose axis at home is closer to horizontal than
    to vertical (pitch and roll; a yaw joint twists the torso without tilting it, and the H1's only torso
    joint is one: holding it lost 3 of 4 handshakes)."""
    m = scene.model
    d = scene.home_data()
    torso = shared_ancestor(m, int(scene.limb_body_ids[0]), int(scene.limb_body_ids[1]), scene.root_body)
    spine = []
    for b in ancestry(m, torso):
        if b == scene.root_body:
            break
        for j in range(int(m.body_jntadr[b]), int(m.body_jntadr[b]) + int(m.body_jntnum[b])):
            if abs(float(d.xaxis[j, 2])) < np.sqrt(0.5):
                spine.append(int(m.jnt_dofadr[j]))
    return np.array(sorted(spine), dtype=np.int64)


@lru_cache(maxsize=32)
def _key_rows(kinds: tuple[str, ...], ids: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(rows, ids) of the key frames that are sites, then of those that are bodies (``key_frames``' gather)."""
    site = np.array([k == "site" for k in kinds], dtype=bool)
    rows, index = np.arange(len(kinds)), np.asarray(ids, dtype=np.int64)
    return rows[site], index[site], rows[~site], index[~site]


def key_frames(scene: Scene, data: mujoco.MjData) -> np.ndarray:
    """(5, 3) world positions of the robot's key frames in ``data`` (kinematics already run), metres."""
    # Two gathers instead of a row per frame (it runs every control step): the same numbers, copied.
    site_rows, site_ids, body_rows, body_ids = _key_rows(scene.frame_kinds, tuple(scene.frame_ids.tolist()))
    out = np.empty((len(scene.frame_kinds), 3))
    out[site_rows] = data.site_xpos[site_ids]
    out[body_rows] = data.xpos[body_ids]
    return out


def key_frames_at(scene: Scene, qpos: np.ndarray, data: mujoco.MjData | None = None) -> np.ndarray:
    """(5, 3) world positions of the robot's key frames at scene coordinates ``qpos`` (nq,), metres.

    ``data``: scratch data of ``scene.model`` to use (its state is overwritten); ``None``: a new one."""
    d = mujoco.MjData(scene.model) if data is None else data
    d.qpos[:] = qpos
    mujoco.mj_kinematics(scene.model, d)
    return key_frames(scene, d)


def contact_exemptions(subgoals: Sequence[SubgoalSpec], ik_scene: Scene) -> list[tuple[int, list[int]]]:
    """Hand/human geom pairs the ``contact`` sub-goals need (left out of the IK's collision avoidance):
    (hand side 0 left / 1 right, human geom ids of ``ik_scene``) per robot hand of each such sub-goal."""
    sides = {"left_hand": (0,), "right_hand": (1,), "hands": (0, 1), "arms": (0, 1), "body": (0, 1)}
    out = []
    for sg in subgoals:
        if sg.kind != "contact" or sg.human is None:
            continue
        geoms = [int(g) for g in ik_scene.human_geom_ids[list(ik_scene.body.groups[sg.human])]]
        out += [(s, geoms) for s in sides[sg.robot]]
    return out
