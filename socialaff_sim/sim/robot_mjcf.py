"""Preparing a robot's MJCF for the scene, and tuning its servos once compiled.

* :func:`robot_mjcf` loads the model, reads its home posture, turns on gravity
  compensation where asked (a kinematic puppet), excludes contacts between bodies that overlap by design, and
  (for the IK model) makes rigid the joints that cannot move a key frame;
* :func:`tune_servos` gives every position servo critically damped gains;
* :func:`limit_hand_force` caps the arm servos' torques so that a hand presses
  with a bounded force.
"""

from __future__ import annotations

from typing import Protocol

from collections.abc import Sequence

import mujoco
import numpy as np
from dm_control import mjcf

from ..retarget.kinematic_tree import subtree_mask
from ..retarget.robot import RobotSpec

__all__ = ["robot_mjcf", "motors_to_servos", "tune_servos", "limit_hand_force", "SELF_CONTACT_HOPS", "ServoScene"]


def robot_mjcf(robot: RobotSpec, physics: bool, gravity_compensation: bool = False) -> tuple[mjcf.RootElement, dict[str, float]]:
    """The robot's MJCF (namespace ``robot``) and its home joint angles by joint name (rad).

    ``gravity_compensation``: every body gets ``gravcomp = 1`` (a weightless puppet); otherwise each
    body's own setting in the model is kept (0 in the shipped and Unitree models)."""
    rob, home = robot.build_model()
    rob.model = "robot"
    if gravity_compensation:
        for body in rob.find_all("body"):
            body.gravcomp = 1.0
    for b1, b2 in _near_body_pairs(robot, rob):
        rob.contact.add("exclude", body1=b1, body2=b2)
    if not physics:
        _freeze_for_ik(robot, rob, home)
    if physics:
        motors_to_servos(rob)
        for act in rob.find_all("actuator"):
            if act.tag == "general" and act.biastype == "affine":
                act.dyntype = "none"  # servos act at once: the lag comes from their gains alone
    return rob, home


def _pair(value: object) -> tuple[float, float] | None:
    if value is None:
        return None
    v = np.asarray(value, dtype=np.float64).ravel()
    return (float(v[0]), float(v[1])) if v.size == 2 and v[0] < v[1] else None


def motors_to_servos(rob: mjcf.RootElement) -> int:
    """Replace every torque actuator (``<motor>``) on a joint by a position servo with the same torque limit.

    Real robot models (Unitree H1, G1) drive their joints with motors whose control is
    a torque; the simulator drives joint angles, so each motor becomes a ``<position>``
    actuator (its gains are set later by :func:`tune_servos`) whose force range is the
    motor's torque limit: the tightest of its control range times its gear, its own
    force range and the joint's ``actuatorfrcrange``. Returns the number replaced.
    """
    n = 0
    for act in list(rob.find_all("actuator")):
        if act.tag != "motor" or act.joint is None:
            continue
        joint = act.joint if not isinstance(act.joint, str) else rob.find("joint", act.joint)
        gear = float(np.asarray(act.gear if act.gear is not None else [1.0], dtype=np.float64).ravel()[0])
        limits = []
        ctrl = _pair(act.ctrlrange)
        if ctrl is not None:
            limits.append(max(abs(ctrl[0]), abs(ctrl[1])) * abs(gear))
        for rng in (_pair(act.forcerange), _pair(getattr(joint, "actuatorfrcrange", None))):
            if rng is not None:
                limits.append(max(abs(rng[0]), abs(rng[1])))
        name = act.name
        act.remove()
        kwargs: dict[str, object] = {"joint": joint, "kp": 1.0}
        if name:
            kwargs["name"] = name
        if limits:
            kwargs["forcelimited"] = True
            kwargs["forcerange"] = [-min(limits), min(limits)]
        rob.actuator.add("position", **kwargs)
        n += 1
    return n


def _freeze_for_ik(robot: RobotSpec, rob: mjcf.RootElement, home: dict[str, float]) -> None:
    """Make rigid, in the IK model, the joints that cannot move any key frame (head, fingers, toes...).

    A joint moves a key frame only if its body is the frame's body or one of its
    ancestors. The others, when their home angle is 0, are removed (the physics
    model keeps them at home), which shrinks the IK's QP. Actuators are dropped.
    """
    movers: set = set()
    for ref in robot.frames:
        el = rob.find(ref.kind, ref.name)
        b = el if ref.kind == "body" else el.parent
        while b is not None and getattr(b, "tag", None) == "body":
            movers.add(b)
            b = b.parent
    for act in rob.find_all("actuator"):
        act.remove()
    for j in rob.find_all("joint"):
        if j.parent not in movers and abs(home.get(j.name, 0.0)) < 1e-12:
            j.remove()


SELF_CONTACT_HOPS = 3
"""Robot bodies this close in the kinematic tree (joints between them) do not collide, unless
one of them belongs to a forearm or hand, which the IK keeps clear of the body instead."""


def _near_body_pairs(robot: RobotSpec, rob: mjcf.RootElement) -> list[tuple[str, str]]:
    """Body pairs whose geoms overlap by design (shoulders into the chest, spine segments, hips)."""
    bodies = [b for b in rob.find_all("body") if b.find_all("geom", immediate_children_only=True)]
    parent = {b: b.parent for b in rob.find_all("body")}

    def chain(b: object) -> list:
        out = [b]
        while parent.get(out[-1]) is not None and parent[out[-1]] in parent:
            out.append(parent[out[-1]])
        return out

    distal: set = set()
    for ref in robot.frames[1:3]:
        el = rob.find(ref.kind, ref.name)
        wrist = el if ref.kind == "body" else el.parent
        top = wrist.parent if wrist.parent in parent else wrist
        distal.update([top, *top.find_all("body")])
    pairs = []
    chains = {b: chain(b) for b in bodies}
    for i, a in enumerate(bodies):
        for b in bodies[i + 1:]:
            if a in distal or b in distal:
                continue
            ca, cb = chains[a], chains[b]
            common = next((x for x in ca if x in cb), None)
            if common is None:
                continue
            hops = ca.index(common) + cb.index(common)
            if 1 < hops <= SELF_CONTACT_HOPS:
                pairs.append((a.name, b.name))
    return pairs


def tune_servos(model: mujoco.MjModel, robot_qadr: np.ndarray, home_qpos: np.ndarray, act_ids: np.ndarray,
                joint_ids: np.ndarray, bandwidth: float, stance_roots: Sequence[int] = (),
                stance_bandwidth: float = 10.0) -> None:
    """Make every robot position servo a critically damped PD of natural frequency ``bandwidth`` (rad/s).

    Per joint, kp = I·ω² and kv = 2·I·ω with I the joint's effective inertia
    (joint-space mass matrix diagonal plus armature) at the home posture; the
    servo's force limit is kept, its control becomes the target angle itself, and
    the joint's passive spring (some models, e.g. the CMU humanoid, have one) is
    removed so that the servo alone sets the posture.

    ``stance_roots``: the hip bodies of legs the robot stands on. The mass matrix of a
    floating robot gives a leg joint the inertia of what hangs below it (a foot: the
    ankle servo of a 50 kg robot got kp ≈ 3 N·m/rad), but standing, the joint carries
    the body above it; those joints get the larger of their own gains and those of natural
    frequency ``stance_bandwidth`` (rad/s) on :func:`stance_inertia`. Without a harness, Stubby
    and the H1 standing at home with their own gains topple within 3 s (tilt 8° and 49°); with
    ω_s = 10 rad/s they stand (tilt < 0.5° after 3 s); at ω_s = 25 rad/s the ankle servos
    (kp ≈ 6,000 N·m/rad on Stubby) saturate and chatter.
    """
    m = model
    d = mujoco.MjData(m)
    d.qpos[robot_qadr] = home_qpos
    mujoco.mj_forward(m, d)
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    ids = act_ids
    jnt = m.actuator_trnid[ids, 0]
    dof = m.jnt_dofadr[jnt]
    inertia = np.diag(M)[dof] + m.dof_armature[dof]
    if len(stance_roots):
        inertia = np.maximum(inertia, stance_inertia(m, d, jnt, stance_roots) * (stance_bandwidth / bandwidth) ** 2)
    kp = inertia * bandwidth**2
    kv = 2.0 * inertia * bandwidth
    m.actuator_gaintype[ids] = int(mujoco.mjtGain.mjGAIN_FIXED)
    m.actuator_biastype[ids] = int(mujoco.mjtBias.mjBIAS_AFFINE)
    m.actuator_gainprm[ids, :] = 0.0
    m.actuator_gainprm[ids, 0] = kp
    m.actuator_biasprm[ids, :] = 0.0
    m.actuator_biasprm[ids, 1] = -kp
    m.actuator_biasprm[ids, 2] = -kv
    m.actuator_gear[ids, 0] = 1.0
    # No control range: the reference is kept inside the joint's range by Scene.ctrl_for, and a
    # feed-forward torque may push the control beyond it (sim.feedforward).
    m.actuator_ctrllimited[ids] = 0
    m.actuator_ctrlrange[ids] = 0.0
    m.jnt_stiffness[joint_ids] = 0.0


def stance_inertia(m: mujoco.MjModel, d: mujoco.MjData, joints: np.ndarray, stance_roots: Sequence[int]) -> np.ndarray:
    """(len(joints),) inertia (kg·m²) a leg hinge turns when its foot stands on the floor, at ``d``'s posture.

    For a hinge in the subtree of one of ``stance_roots`` (a hip): the moment of inertia, about the
    joint's axis through its anchor, of every robot body not below the joint (the rest of the robot, which
    the standing leg holds up), halved because two legs share it; 0 for the other joints.
    """
    out = np.zeros(len(joints))
    root = int(m.body_rootid[int(stance_roots[0])])
    robot = subtree_mask(m, root)
    legs = np.zeros(m.nbody, dtype=bool)
    for r in stance_roots:
        legs |= subtree_mask(m, int(r))
    for i, j in enumerate(joints):
        b = int(m.jnt_bodyid[j])
        if not legs[b] or int(m.jnt_type[j]) != int(mujoco.mjtJoint.mjJNT_HINGE):
            continue
        above = np.flatnonzero(robot & ~subtree_mask(m, b))
        a, p = d.xaxis[j], d.xanchor[j]
        R = d.ximat[above].reshape(-1, 3, 3)
        local = np.einsum("nji,j->ni", R, a)  # the axis in each body's inertia frame
        rot = np.einsum("ni,ni->n", local**2, m.body_inertia[above])
        r = d.xipos[above] - p
        lever = np.linalg.norm(np.cross(r, a), axis=1)
        out[i] = 0.5 * float((rot + m.body_mass[above] * lever**2).sum())
    return out


class ServoScene(Protocol):
    """What :func:`limit_hand_force` reads of a built scene (:class:`~socialaff_sim.sim.scene.Scene`
    has it; declared here so this module does not import the scene)."""

    model: mujoco.MjModel
    robot_qadr: np.ndarray
    home_qpos: np.ndarray
    act_ids: np.ndarray
    limb_body_ids: np.ndarray
    frame_kinds: tuple[str, ...]
    frame_ids: np.ndarray
    hand_geom: np.ndarray


def limit_hand_force(scene: ServoScene, force: float, weight: bool = False) -> None:
    """Cap each arm servo's torque at ``force`` (N) times its lever arm to the hand, at home.

    ``weight``: the robot has its real weight (no gravity compensation); each cap then also
    covers the torque that holds the part of the arm beyond the joint straight out sideways
    (Σ m·g·r over its bodies, r their centres of mass's distances from the joint at home),
    so that the press on a person stays bounded while the arm can still hold itself up.

    The arm of a side is the subtree of its limb root (the shoulder body). A joint's
    lever arm is the distance from its anchor to the wrist frame plus the hand's
    reach beyond the wrist (the farthest point of the hand's geoms' bounding spheres),
    so a hand pushing on something at its far end meets at most about ``force``.
    A servo's own smaller limit is kept.
    """
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[scene.robot_qadr] = scene.home_qpos
    mujoco.mj_kinematics(m, d)
    inside = np.zeros(m.nbody, dtype=bool)
    jnt = m.actuator_trnid[scene.act_ids, 0]
    for s in (0, 1):
        inside[:] = False
        inside[int(scene.limb_body_ids[s])] = True
        for b in range(int(scene.limb_body_ids[s]) + 1, m.nbody):  # MuJoCo numbers a body after its parent
            inside[b] = inside[m.body_parentid[b]]
        kind, fid = scene.frame_kinds[1 + s], int(scene.frame_ids[1 + s])
        wrist = np.array(d.site_xpos[fid] if kind == "site" else d.xpos[fid])
        hand = np.flatnonzero(scene.hand_geom[s])
        reach = float((np.linalg.norm(d.geom_xpos[hand] - wrist, axis=1) + m.geom_rbound[hand]).max()) if len(hand) else 0.0
        for a, j in zip(scene.act_ids, jnt, strict=True):
            if not inside[m.jnt_bodyid[j]]:
                continue
            limit = force * (float(np.linalg.norm(wrist - d.xanchor[j])) + reach)
            if weight:
                below = subtree_mask(m, int(m.jnt_bodyid[j]))
                lever = np.linalg.norm(d.xipos[below] - d.xanchor[j], axis=1)
                limit += float(np.linalg.norm(m.opt.gravity) * (m.body_mass[below] * lever).sum())
            if m.actuator_forcelimited[a]:
                lo, hi = m.actuator_forcerange[a]
                limit = min(limit, -lo, hi)
            m.actuator_forcelimited[a] = 1
            m.actuator_forcerange[a] = (-limit, limit)
