"""The MuJoCo scene, built with dm_control's mjcf: a robot facing a replayed human.

Contents of the world:

* a floor plane;
* the robot, attached under a free joint (``robot/root/``), with its real
  weight (or, ``gravity_compensation=True``, gravity compensation on its bodies);
* in the physics scene, a mocap body ``robot_anchor`` welded to the robot's root:
  the base is *held by a weld to a moving mocap anchor* (like a harness on a
  gantry). The robot keeps the same free-joint coordinates as in the IK model, so
  an IK solution maps one to one onto the physics state, and the forces the base
  takes show up in the weld's constraint force;
* the human: one mocap body per skeleton bone carrying a capsule, and one sphere
  per hand (see :mod:`socialaff_sim.sim.human`; its bodies, sizes and compliant
  parts are set by :mod:`socialaff_sim.sim.scene_human`);
* the object, when the task has one: a free body, with one inactive weld per
  robot hand (``grip_left``/``grip_right``) that the simulator switches on when
  that hand touches it (a suction-style gripper, see :mod:`.simulator`).

Collision bits: robot (contype 1, conaffinity 3) touches itself, the human, the
floor and the object; human (2, 0) touches only the robot and the object; floor
(4, 1) touches the robot and the object; object (1, 3) touches everything (but the person while the person
carries it: :func:`~socialaff_sim.sim.carry.person_contact` clears its bit 2 then).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from dm_control import mjcf

from ..data.skeletons import SkeletonLayout
from ..errors import SimulationError
from ..retarget.kinematic_tree import subtree_mask
from ..retarget.robot import RobotSpec
from .chair import add_chair
from .human import HumanBody, human_body
from .lowest_point import lowest_point
from .robot_mjcf import robot_mjcf, tune_servos
from .scene_human import HUMAN_RGBA, PERSON_CONTYPE, add_human, part_names, pose_compliant, set_human_sizes

__all__ = ["ObjectSpec", "Scene", "build_scene", "set_human_sizes", "pose_compliant", "HUMAN_RGBA", "ROBOT_RGBA", "OBJECT_RGBA",
           "OBJECT_AFFINITY", "PERSON_CONTYPE", "FLOOR_SOLMIX"]

ROBOT_RGBA = (0.25, 0.75, 0.3, 1.0)
HARNESS_IMPEDANCE = 0.9
"""d of the compliant harness's soft weld (MuJoCo solimp): the share of the constraint's correction applied.
Standing still on its feet, the H1 took 2.5 % of its weight from it at τ = 0.02 s (1.7 % at 0.05 s), and
hanging sagged by 3.5 cm (4.4 cm); the rigid weld (0.008 s, d = 0.99): 11.5 % standing."""
FLOOR_SOLMIX = 1000.0
"""[—]: ``floor_time_constant``: the floor's weight (the other geom's 1) in MuJoCo's mix of a contact's ``solref``."""
OBJECT_RGBA = (0.95, 0.8, 0.2, 1.0)
OBJECT_AFFINITY = 3
"""``conaffinity`` of the object: bit 1 (the robot, and the floor through its own affinity) and bit 2
(:data:`~socialaff_sim.sim.scene_human.PERSON_CONTYPE`, the person)."""
GRIP_SOLREF = (0.01, 1.0)
"""Time constant (s) and damping ratio of the grip welds between a robot hand and the object."""


@dataclass(frozen=True)
class ObjectSpec:
    """The free object of an interaction (ball, cup)."""

    shape: str
    """``"sphere"``, ``"cylinder"`` or ``"box"``."""
    size: tuple[float, ...]
    """MuJoCo geom size, metres (radius; radius and half-height; three half-sizes)."""
    mass: float
    """kg."""


@dataclass
class Scene:
    """A compiled scene and the indices the simulator needs."""

    model: mujoco.MjModel
    robot: RobotSpec
    body: HumanBody
    has_object: bool
    robot_qadr: np.ndarray
    """(nq_r,) qpos addresses of the robot: free joint (7) then its hinges, in robot order."""
    robot_vadr: np.ndarray
    """(nv_r,) dof addresses of the robot."""
    robot_joint_names: tuple[str, ...]
    """Names of the robot's joints (scene names), free joint first."""
    robot_joint_ids: np.ndarray
    """Ids of the same joints."""
    frame_kinds: tuple[str, ...]
    """Kind of each of the five key frames (``"site"``/``"body"``)."""
    frame_ids: np.ndarray
    """(5,) ids of the key frames."""
    limb_body_ids: np.ndarray
    """(4,) body ids where the left/right arm and left/right leg chains start."""
    limb_kinds: tuple[str, ...]
    limb_ids: np.ndarray
    root_body: int
    """Body id of the robot's free-joint body."""
    robot_geom: np.ndarray
    """(ngeom,) bool: geoms of the robot."""
    hand_geom: np.ndarray
    """(2, ngeom) bool: collidable geoms of the left and right hand."""
    arm_geom: np.ndarray
    """(2, ngeom) bool: collidable geoms of the left and right forearm and hand (the subtree of the
    wrist frame's parent body)."""
    human_geom_ids: np.ndarray
    """(B + 2,) geom ids of the human's capsules then hand spheres."""
    human_mocap: np.ndarray
    """(B + 2,) mocap indices of the bodies (or, for compliant parts, the weld targets) posed by the recording."""
    human_free_qadr: np.ndarray
    """(B + 2,) qpos address of each part's free joint (-1 for the rigid mocap parts)."""
    human_free_vadr: np.ndarray
    """(B + 2,) dof address of the same (-1 for the rigid parts)."""
    anchor_mocap: int
    """Mocap index of the robot's anchor (-1 in the IK scene)."""
    object_body: int
    object_geom: int
    object_qadr: int
    object_vadr: int
    floor_geom: int
    act_ids: np.ndarray
    """(n_act,) position-like actuators driving robot joints."""
    act_qadr: np.ndarray
    """(n_act,) qpos address of each one's joint."""
    act_vadr: np.ndarray
    """(n_act,) dof address of each one's joint."""
    grip_eq: np.ndarray
    """(2,) ids of the left and right grip welds (-1 without an object)."""
    grip_body: np.ndarray
    """(2,) body id each grip weld holds the object to."""
    home_qpos: np.ndarray
    """(nq_r,) robot qpos at home in the robot frame: on the floor at the origin, facing +x."""

    @property
    def n_bones(self) -> int:
        return self.body.n_bones

    def frame_body(self, k: int) -> int:
        """The body of the robot's key frame ``k`` (0 base, 1–2 wrists, 3–4 ankles): the frame itself, or a site's body."""
        fid = int(self.frame_ids[k])
        return int(self.model.site_bodyid[fid]) if self.frame_kinds[k] == "site" else fid

    def home_data(self) -> mujoco.MjData:
        """A new data of the scene, the robot at its home posture (the rest at ``qpos0``), its kinematics computed."""
        d = mujoco.MjData(self.model)
        d.qpos[self.robot_qadr] = self.home_qpos
        mujoco.mj_kinematics(self.model, d)
        return d

    def ctrl_for(self, qpos: np.ndarray, qvel: np.ndarray | None = None) -> np.ndarray:
        """Controls (..., n_act) making the servos track scene ``qpos`` (..., nq) and, if given, ``qvel`` (..., nv).

        Inverts force = gain·ctrl + b0 + b1·q + b2·q̇ for the wanted
        force −b1·(q_ref − q) − b2·(q̇_ref − q̇) (gain type fixed, bias affine), which
        covers MuJoCo's position actuators and dm_control's scaled ones; the
        velocity reference is a feed-forward term through the servo's damping.
        """
        m = self.model
        ids = self.act_ids
        b = m.actuator_biasprm[ids]
        ref = -(b[:, 0] + b[:, 1] * np.asarray(qpos)[..., self.act_qadr])
        if qvel is not None:
            ref = ref - b[:, 2] * np.asarray(qvel)[..., self.act_vadr]
        ctrl = ref / m.actuator_gainprm[ids, 0]
        # The reference stays inside the joint's range (the control itself may go beyond it: a
        # feed-forward torque is added as an offset of the reference, see sim.feedforward).
        jnt = m.actuator_trnid[ids, 0]
        lo, hi = m.jnt_range[jnt, 0], m.jnt_range[jnt, 1]
        limited = m.jnt_limited[jnt].astype(bool) | m.actuator_ctrllimited[ids].astype(bool)
        lo = np.where(m.jnt_limited[jnt].astype(bool), lo, m.actuator_ctrlrange[ids, 0])
        hi = np.where(m.jnt_limited[jnt].astype(bool), hi, m.actuator_ctrlrange[ids, 1])
        return np.where(limited, np.clip(ctrl, lo, hi), ctrl)


def build_scene(robot: RobotSpec, layout: SkeletonLayout, obj: ObjectSpec | None = None,
                *, physics: bool = True, timestep: float = 0.004, servo_bandwidth: float | None = 25.0,
                gravity_compensation: bool = False, harness_time_constant: float | None = None,
                stance_bandwidth: float | None = None, chair: bool = False, compliant_person: bool = True,
                floor_time_constant: float | None = None) -> Scene:
    """Compile the scene for one robot, one skeleton layout and an optional object.

    ``physics=False`` gives the IK scene: robot and human only (no floor, object,
    anchor or grips), used by the retargeter's collision avoidance.
    ``servo_bandwidth`` (rad/s): see :func:`tune_servos`; ``None`` keeps the model's gains.
    ``gravity_compensation``: every robot body gets ``gravcomp = 1`` (a weightless, kinematic puppet).
    ``harness_time_constant`` (s): the root hangs from the anchor by a soft weld of this time constant and
    impedance :data:`HARNESS_IMPEDANCE` (a compliant harness); ``None``: by a rigid weld.
    ``stance_bandwidth`` (rad/s): leg servos stiff enough to stand on (see :func:`tune_servos`); ``None``: not.
    ``chair``: the physics scene gets a chair (:func:`~socialaff_sim.sim.chair.add_chair`).
    ``compliant_person``: the person's forearms and hands are free bodies on soft welds in the physics scene;
    ``False``: every part of the person is a mocap body (a pure replay; see ``SimConfig.compliant_person``).
    ``floor_time_constant`` (s): the floor's contacts' MuJoCo time constant (``solref``, weighted :data:`FLOOR_SOLMIX`
    in the mix; ``SimConfig.floor_time_constant``); ``None``: MuJoCo's default (0.02 s).
    """
    root = mjcf.RootElement(model="socialaff_scene")
    root.compiler.angle = "radian"
    root.option.timestep = timestep
    root.option.integrator = "implicitfast"
    root.visual.headlight.ambient = (0.45, 0.45, 0.45)
    root.visual.headlight.diffuse = (0.5, 0.5, 0.5)
    getattr(root.visual, "global").offwidth = 1280
    getattr(root.visual, "global").offheight = 960
    root.asset.add("texture", name="grid", type="2d", builtin="checker", width=256, height=256,
                   rgb1=(0.82, 0.84, 0.87), rgb2=(0.72, 0.75, 0.78))
    root.asset.add("material", name="grid", texture="grid", texrepeat=(8, 8))
    root.asset.add("texture", name="sky", type="skybox", builtin="gradient", width=128, height=128,
                   rgb1=(0.55, 0.68, 0.85), rgb2=(0.95, 0.96, 0.98))
    root.visual.quality.shadowsize = 1024  # software EGL renders 4096² shadow maps slowly
    if physics:
        floor = root.worldbody.add("geom", name="floor", type="plane", size=(6, 6, 0.1), material="grid",
                                   contype=4, conaffinity=1)
        if floor_time_constant is not None:  # the floor's own stiffness; friction and condim mix as before
            floor.solref, floor.solmix = (floor_time_constant, 1.0), FLOOR_SOLMIX
        root.worldbody.add("light", pos=(0, 0, 4), dir=(0, 0, -1), diffuse=(0.5, 0.5, 0.5))

    rob, home = robot_mjcf(robot, physics, gravity_compensation)
    frame = root.worldbody.attach(rob)
    frame.add("freejoint", name="root")
    body = human_body(layout)
    add_human(root, body, physics and compliant_person)
    if physics:
        anchor = root.worldbody.add("body", name="robot_anchor", mocap=True)
        # Rigid by default (a gantry); a compliant harness is a soft weld: MuJoCo then moves the root
        # toward the anchor with time constant τ and lets through only the share d of the correction,
        # and the solver handles it implicitly (a stiff explicit spring would need a heavy carriage).
        solref, solimp = (0.008, 1.0), (0.99, 0.999, 0.001, 0.5, 2)
        if harness_time_constant is not None:
            solref, solimp = (harness_time_constant, 1.0), (HARNESS_IMPEDANCE, HARNESS_IMPEDANCE, 0.001, 0.5, 2)
        root.equality.add("weld", name="robot_anchor", body1=anchor, body2="robot/",
                          relpose=(0, 0, 0, 1, 0, 0, 0), solref=solref, solimp=solimp)
    if physics and chair:
        add_chair(root)
    if physics and obj is not None:
        ob = root.worldbody.add("body", name="object", pos=(0, 0, -5))
        ob.add("freejoint", name="object")
        ob.add("geom", name="object", type=obj.shape, size=list(obj.size), mass=obj.mass,
               contype=1, conaffinity=OBJECT_AFFINITY, rgba=OBJECT_RGBA, condim=4, friction=(1.0, 0.02, 0.002))
        for side, names in zip(("left", "right"), robot.hands, strict=True):
            root.equality.add("weld", name=f"grip_{side}", body1=f"robot/{names[0]}", body2=ob,
                              active=False, solref=GRIP_SOLREF)
    try:
        model = mujoco.MjModel.from_xml_string(root.to_xml_string(), root.get_assets())
    except ValueError as exc:
        raise SimulationError(f"robot {robot.name!r} ({robot.mapping_file}): the scene does not compile: {exc}") from None
    scene = _index(model, robot, body, rob, home, physics and obj is not None, physics)
    if physics and servo_bandwidth is not None:
        tune_servos(scene.model, scene.robot_qadr, scene.home_qpos, scene.act_ids, scene.robot_joint_ids[1:],
                    servo_bandwidth, stance_roots=() if stance_bandwidth is None else scene.limb_body_ids[2:4],
                    stance_bandwidth=stance_bandwidth or 0.0)
    return scene


def _mj_id(model: mujoco.MjModel, kind: str, name: str) -> int:
    obj = {"site": mujoco.mjtObj.mjOBJ_SITE, "body": mujoco.mjtObj.mjOBJ_BODY,
           "geom": mujoco.mjtObj.mjOBJ_GEOM, "joint": mujoco.mjtObj.mjOBJ_JOINT}[kind]
    i = mujoco.mj_name2id(model, obj, name)
    if i < 0:
        raise SimulationError(f"scene has no {kind} {name!r}")
    return int(i)


def _index(model: mujoco.MjModel, robot: RobotSpec, body: HumanBody, rob: mjcf.RootElement,
           home: dict[str, float], has_object: bool, physics: bool) -> Scene:
    root_body = _mj_id(model, "body", "robot/")
    free = _mj_id(model, "joint", "robot/root/")
    rbodies = subtree_mask(model, root_body)
    jnt_ids = [free] + [j for j in range(model.njnt) if model.jnt_bodyid[j] != root_body and rbodies[model.jnt_bodyid[j]]]
    for j in jnt_ids[1:]:
        if int(model.jnt_type[j]) not in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            raise SimulationError(f"robot {robot.name!r}: only hinge and slide joints are supported below the root, "
                                  f"found joint {model.joint(j).name!r} of type {int(model.jnt_type[j])}")
    qadr = np.concatenate([np.arange(7) + model.jnt_qposadr[free], model.jnt_qposadr[jnt_ids[1:]]])
    vadr = np.concatenate([np.arange(6) + model.jnt_dofadr[free], model.jnt_dofadr[jnt_ids[1:]]])
    names = tuple(model.joint(j).name for j in jnt_ids)

    robot_geom = rbodies[model.geom_bodyid]
    collide = robot_geom & ((model.geom_contype != 0) | (model.geom_conaffinity != 0))
    model.geom_contype[collide] = 1
    model.geom_conaffinity[collide] = 3
    # MuJoCo's broadphase also filters on per-body unions of these bits, fixed at compile time.
    for b in np.unique(model.geom_bodyid[collide]):
        mine = model.geom_bodyid == b
        model.body_contype[b] = np.bitwise_or.reduce(model.geom_contype[mine])
        model.body_conaffinity[b] = np.bitwise_or.reduce(model.geom_conaffinity[mine])
    model.geom_rgba[robot_geom] = ROBOT_RGBA
    model.geom_matid[robot_geom] = -1
    hand_geom = np.zeros((2, model.ngeom), dtype=bool)
    for s, names_s in enumerate(robot.hands):
        for bname in names_s:
            hb = _mj_id(model, "body", f"robot/{bname}")
            hand_geom[s] |= subtree_mask(model, hb)[model.geom_bodyid] & collide

    limb_kinds = tuple(f.kind for f in robot.limb_roots)
    limb_ids = np.array([_mj_id(model, f.kind, f"robot/{f.name}") for f in robot.limb_roots])
    limb_body_ids = np.array([i if k == "body" else model.site_bodyid[i] for k, i in zip(limb_kinds, limb_ids, strict=True)])
    frame_kinds = tuple(f.kind for f in robot.frames)
    frame_ids = np.array([_mj_id(model, f.kind, f"robot/{f.name}") for f in robot.frames])
    arm_geom = np.zeros((2, model.ngeom), dtype=bool)
    for s in (0, 1):
        kind, fid = frame_kinds[1 + s], int(frame_ids[1 + s])
        wrist_body = int(model.site_bodyid[fid]) if kind == "site" else fid
        top = int(model.body_parentid[wrist_body])
        arm_geom[s] = subtree_mask(model, top)[model.geom_bodyid] & collide

    hnames = part_names(body)
    human_geom_ids = np.array([_mj_id(model, "geom", n) for n in hnames])
    human_body_ids = [_mj_id(model, "body", n) for n in hnames]
    mocap_bodies = [b if model.body_mocapid[b] >= 0 else _mj_id(model, "body", f"{n}_target")
                    for b, n in zip(human_body_ids, hnames, strict=True)]
    human_mocap = np.array([model.body_mocapid[b] for b in mocap_bodies])
    free_q, free_v = [], []
    for b in human_body_ids:
        if model.body_jntnum[b]:
            j = int(model.body_jntadr[b])
            free_q.append(int(model.jnt_qposadr[j]))
            free_v.append(int(model.jnt_dofadr[j]))
        else:
            free_q.append(-1)
            free_v.append(-1)
    anchor_mocap = int(model.body_mocapid[_mj_id(model, "body", "robot_anchor")]) if physics else -1
    if has_object:
        ob = _mj_id(model, "body", "object")
        oj = _mj_id(model, "joint", "object")
        object_body, object_geom = ob, _mj_id(model, "geom", "object")
        object_qadr, object_vadr = int(model.jnt_qposadr[oj]), int(model.jnt_dofadr[oj])
    else:
        object_body = object_geom = object_qadr = object_vadr = -1
    floor_geom = _mj_id(model, "geom", "floor") if physics else -1
    grip_body = np.array([_mj_id(model, "body", f"robot/{names[0]}") for names in robot.hands])
    if has_object:
        grip_eq = np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, f"grip_{s}") for s in ("left", "right")])
    else:
        grip_eq = np.array([-1, -1])

    act_ids, act_qadr, act_vadr = [], [], []
    for a in range(model.nu):
        if int(model.actuator_trntype[a]) != int(mujoco.mjtTrn.mjTRN_JOINT):
            continue
        j = int(model.actuator_trnid[a, 0])
        if j not in jnt_ids or int(model.actuator_gaintype[a]) != int(mujoco.mjtGain.mjGAIN_FIXED):
            continue
        if int(model.actuator_biastype[a]) != int(mujoco.mjtBias.mjBIAS_AFFINE) or model.actuator_biasprm[a, 1] >= 0:
            continue  # not a position servo
        act_ids.append(a)
        act_qadr.append(int(model.jnt_qposadr[j]))
        act_vadr.append(int(model.jnt_dofadr[j]))

    home_q = np.zeros(len(qadr))
    home_q[3:7] = robot.root_quat
    for k, n in enumerate(names[1:], start=7):
        short = n.removeprefix("robot/")
        home_q[k] = home.get(short, 0.0)
        j = jnt_ids[k - 6]
        if model.jnt_limited[j]:
            home_q[k] = np.clip(home_q[k], *model.jnt_range[j])
    home_q[2] = -lowest_point(model, qadr, home_q, robot_geom)
    scene = Scene(
        model=model, robot=robot, body=body, has_object=has_object, robot_qadr=qadr, robot_vadr=vadr,
        robot_joint_names=names, robot_joint_ids=np.array(jnt_ids), frame_kinds=frame_kinds, frame_ids=frame_ids, limb_body_ids=limb_body_ids,
        limb_kinds=limb_kinds, limb_ids=limb_ids, root_body=root_body, robot_geom=robot_geom,
        hand_geom=hand_geom, arm_geom=arm_geom, human_geom_ids=human_geom_ids, human_mocap=human_mocap,
        human_free_qadr=np.array(free_q), human_free_vadr=np.array(free_v), anchor_mocap=anchor_mocap,
        object_body=object_body, object_geom=object_geom, object_qadr=object_qadr, object_vadr=object_vadr,
        floor_geom=floor_geom, act_ids=np.array(act_ids, dtype=np.int64), act_qadr=np.array(act_qadr, dtype=np.int64),
        act_vadr=np.array(act_vadr, dtype=np.int64),
        grip_eq=grip_eq, grip_body=grip_body, home_qpos=home_q,
    )
    return scene

