"""Standing balance: the IK's centre-of-mass task over the support polygon and pinned feet while both feet are
planted, the stance gains of the leg servos, and the torso's tilt as the support meter measures it."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.retarget.ik import IKConfig, IKModel, RobotIK
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.feedforward import StandingFeedforward
from socialaff_sim.retarget.kinematic_tree import ancestry, shared_ancestor, subtree_mask
from socialaff_sim.sim.robot_mjcf import stance_inertia
from socialaff_sim.sim.scene import Scene, build_scene, pose_compliant
from socialaff_sim.sim.stage import key_frames_at
from socialaff_sim.sim.support import SupportMeter

LAYOUT = get_layout("kinect_v2")


@pytest.fixture(scope="module")
def ours():
    return load_robot("ours")


@pytest.fixture(scope="module")
def ik_scene(ours) -> Scene:
    return build_scene(ours, LAYOUT, physics=False)


def _ik(scene: Scene, config: IKConfig) -> RobotIK:
    m = scene.model
    collidable = scene.robot_geom & ((m.geom_contype != 0) | (m.geom_conaffinity != 0))
    ik = RobotIK(IKModel(
        model=m, frame_kinds=scene.frame_kinds, frame_ids=scene.frame_ids, home_qpos=scene.home_qpos,
        hand_geoms=tuple(np.flatnonzero(h) for h in scene.hand_geom),
        arm_geoms=tuple(np.flatnonzero(a) for a in scene.arm_geom),
        robot_geoms=np.flatnonzero(collidable), human_geoms=scene.human_geom_ids, human_mocap=scene.human_mocap,
        max_joint_velocity=8.0), config)
    n = len(scene.human_mocap)
    ik.set_human(np.tile([0.0, 0.0, -20.0], (n, 1)) + np.arange(n)[:, None] * [0.5, 0.0, 0.0],
                 np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)))
    ik.reset(scene.home_qpos)
    return ik


def _com(scene: Scene, q: np.ndarray) -> np.ndarray:
    """(3,) the robot's centre of mass at ``q``, summed here over its bodies (independent of mink's ComTask)."""
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    robot = subtree_mask(m, scene.root_body)
    mass = m.body_mass[robot]
    return (mass[:, None] * d.xipos[robot]).sum(axis=0) / mass.sum()


def _reach(scene: Scene, config: IKConfig, planted: tuple[bool, bool]) -> tuple[np.ndarray, np.ndarray, RobotIK]:
    """Both hands reach 0.75 m forward at shoulder height, feet at home; returns (com, ankles, ik) after 20 frames."""
    ik = _ik(scene, config)
    home = key_frames_at(scene, scene.home_qpos)
    targets = home.copy()
    targets[1:3, 0] += 0.75
    targets[1:3, 2] = home[0, 2] + 0.45
    for _ in range(20):
        res = ik.solve(targets, 0.0, dt=1 / 30, planted=planted)
    q = res.qpos
    return _com(scene, q), key_frames_at(scene, q)[3:5], ik


def _bound(ik: RobotIK, ankles: np.ndarray) -> float:
    """The support rectangle's front edge, m ahead of the ankles' middle (the robot faces +x)."""
    assert ik.balance.limit is not None
    return float(ik.balance.limit.box[0, 1])


def test_support_limit_keeps_the_centre_of_mass_over_the_feet_while_both_are_planted(ik_scene: Scene) -> None:
    home_ankles = key_frames_at(ik_scene, ik_scene.home_qpos)[3:5]
    mid = home_ankles[:, :2].mean(axis=0)
    com, ankles, ik = _reach(ik_scene, IKConfig(), (True, True))
    front = _bound(ik, ankles)
    # The reach carries the centre of mass forward up to the rectangle's front edge, not beyond; feet in place.
    assert com[0] - mid[0] <= front + 0.002
    assert com[0] - mid[0] >= front - 0.02
    assert np.abs(ankles - home_ankles).max() <= 0.005
    # Without the limit (or with a foot not planted, when it is inactive) the same reach leaves the rectangle.
    off, _, _ = _reach(ik_scene, IKConfig(support_margin=None), (True, True))
    assert off[0] - mid[0] >= front + 0.01
    free, _, _ = _reach(ik_scene, IKConfig(), (True, False))
    assert free[0] - mid[0] >= front + 0.01


def test_support_box_is_the_feet_extent(ik_scene: Scene) -> None:
    ik = _ik(ik_scene, IKConfig(support_margin=0.0))
    m = ik_scene.model
    d = mujoco.MjData(m)
    d.qpos[:] = ik_scene.home_qpos
    mujoco.mj_forward(m, d)
    mid = key_frames_at(ik_scene, ik_scene.home_qpos)[3:5, :2].mean(axis=0)
    # Independent: Stubby's feet are boxes; their corners from geom_size and the geoms' poses.
    feet = [g for g in range(m.ngeom) if "foot" in (m.geom(g).name or "") and m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX]
    assert len(feet) == 2
    corners = []
    for g in feet:
        for sx in (-1, 1):
            for sy in (-1, 1):
                for sz in (-1, 1):
                    corners.append(d.geom_xpos[g] + d.geom_xmat[g].reshape(3, 3) @ (m.geom_size[g] * [sx, sy, sz]))
    xy = np.array(corners)[:, :2] - mid
    expected = np.array([[xy[:, 0].min(), xy[:, 0].max()], [xy[:, 1].min(), xy[:, 1].max()]])
    np.testing.assert_allclose(ik.balance.limit.box, expected, atol=1e-9)


def test_com_task_holds_the_centre_of_mass_at_the_support_centre(ik_scene: Scene) -> None:
    cfg = IKConfig(com_cost=10.0)
    com, ankles, ik = _reach(ik_scene, cfg, (True, True))
    home_com = _com(ik_scene, ik_scene.home_qpos)
    home_ankles = key_frames_at(ik_scene, ik_scene.home_qpos)[3:5]
    centre = home_com[:2]  # at home the centre of mass is over the support centre by construction
    assert np.linalg.norm(com[:2] - centre) <= 0.01
    off, _, _ = _reach(ik_scene, dataclasses.replace(cfg, com_cost=0.0, support_margin=None), (True, True))
    assert np.linalg.norm(off[:2] - centre) >= 0.05
    assert np.abs(ankles - home_ankles).max() <= 0.005


def test_planted_feet_are_pinned_against_a_base_that_pulls_them(ik_scene: Scene) -> None:
    home = key_frames_at(ik_scene, ik_scene.home_qpos)
    errors = {}
    for planted in ((True, True), (False, False)):
        ik = _ik(ik_scene, IKConfig(com_cost=0.0))
        targets = home.copy()
        targets[0, 2] += 0.15  # a base target out of the legs' reach with the feet where they are
        for _ in range(10):
            res = ik.solve(targets, 0.0, dt=1 / 30, planted=planted)
        errors[planted] = res.errors[3:5].max()
    assert errors[(True, True)] <= 0.01
    assert errors[(False, False)] >= 2 * errors[(True, True)]


def test_support_centre_turns_with_the_robot(ik_scene: Scene, rng: np.random.Generator) -> None:
    ik = _ik(ik_scene, IKConfig())
    ankles = rng.normal(size=(2, 3))
    yaw = float(rng.uniform(-np.pi, np.pi))
    home_ankles = key_frames_at(ik_scene, ik_scene.home_qpos)[3:5]
    off = _com(ik_scene, ik_scene.home_qpos)[:2] - home_ankles[:, :2].mean(axis=0)
    R = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
    np.testing.assert_allclose(ik.balance.support_centre(ankles, yaw), ankles[:, :2].mean(axis=0) + R @ off, atol=1e-12)


LEG_XML = """
<mujoco model="leg">
  <worldbody>
    <body name="torso" pos="0 0 1.0">
      <freejoint/>
      <inertial pos="0 0 0.2" mass="10" diaginertia="0.3 0.4 0.5"/>
      <body name="shank" pos="0 0 0">
        <joint name="hip" axis="0 1 0"/>
        <inertial pos="0 0 -0.4" mass="2" diaginertia="0.05 0.06 0.01"/>
        <body name="foot" pos="0 0 -0.9">
          <joint name="ankle" axis="0 1 0"/>
          <inertial pos="0.05 0 -0.05" mass="1" diaginertia="0.01 0.01 0.01"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_stance_inertia_against_the_parallel_axis_theorem() -> None:
    m = mujoco.MjModel.from_xml_string(LEG_XML)
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    joints = np.array([m.joint("hip").id, m.joint("ankle").id])
    got = stance_inertia(m, d, joints, [m.body("shank").id])
    # Ankle at z = 0.1: above it the torso (10 kg at z = 1.2, I_yy 0.4) and the shank (2 kg at z = 0.6, I_yy 0.06);
    # the hip at z = 1.0 carries the torso (0.2 m above it). Halved: two legs share the body.
    ankle = 0.5 * (0.4 + 10 * 1.1**2 + 0.06 + 2 * 0.5**2)
    hip = 0.5 * (0.4 + 10 * 0.2**2)
    np.testing.assert_allclose(got, [hip, ankle], rtol=1e-9)


def _stand(scene: Scene, seconds: float) -> float:
    """Stand at home with no harness for ``seconds``; the torso's largest tilt (degrees)."""
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[scene.robot_qadr] = scene.home_qpos
    far = np.array([10.0, 10.0, 1.0]) + np.arange(len(scene.human_mocap))[:, None] * [0.0, 0.3, 0.0]
    d.mocap_pos[scene.human_mocap] = far
    pose_compliant(scene, d, far, np.array(d.mocap_quat[scene.human_mocap]))
    d.eq_active[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, "robot_anchor")] = 0
    mujoco.mj_forward(m, d)
    ctrl = scene.ctrl_for(d.qpos.copy()) + StandingFeedforward(scene).ctrl_offset(d.qpos.copy())
    meter = SupportMeter(scene)
    for _ in range(int(seconds / m.opt.timestep)):
        d.ctrl[scene.act_ids] = ctrl
        mujoco.mj_step(m, d)
        meter.update(d)
    return meter.end_frame().tilt_deg


def test_stance_gains_let_the_robot_stand_without_its_harness(ours) -> None:
    # The servos tuned on each leg joint's own inertia (a foot below an ankle) are too soft to stand on: the
    # robot topples within 3 s; with stance gains it stands.
    soft = _stand(build_scene(ours, LAYOUT, harness_time_constant=0.02), 3.0)
    stiff = _stand(build_scene(ours, LAYOUT, harness_time_constant=0.02, stance_bandwidth=10.0), 3.0)
    assert stiff <= 1.0
    assert soft >= 5.0


def test_torso_tilt_is_the_angle_the_robot_is_turned_by(ours) -> None:
    scene = build_scene(ours, LAYOUT)
    m = scene.model
    d = mujoco.MjData(m)
    angle = 20.0
    q = scene.home_qpos.copy()
    turn = np.array([np.cos(np.radians(angle) / 2), 0.0, np.sin(np.radians(angle) / 2), 0.0])
    mujoco.mju_mulQuat(q[3:7], turn, scene.home_qpos[3:7].copy())
    d.qpos[scene.robot_qadr] = q
    mujoco.mj_forward(m, d)
    meter = SupportMeter(scene)
    meter.update(d)
    assert meter.end_frame().tilt_deg == pytest.approx(angle, abs=1e-6)


def test_tree_ancestry_and_the_torso_against_brute_force(ik_scene: Scene) -> None:
    """kinematic_tree.ancestry / shared_ancestor (the torso of SupportMeter, BalanceController, torso_dofs)
    against the subtree masks: a is below x iff x's subtree holds a."""
    m = ik_scene.model
    for body in range(1, m.nbody):
        brute = [x for x in range(1, m.nbody) if subtree_mask(m, x)[body]]
        assert sorted(ancestry(m, body)) == brute
        assert ancestry(m, body)[0] == body
    a, b = int(ik_scene.limb_body_ids[0]), int(ik_scene.limb_body_ids[1])
    common = [x for x in range(1, m.nbody) if x != a and subtree_mask(m, x)[a] and subtree_mask(m, x)[b]]
    torso = shared_ancestor(m, a, b, default=-1)
    assert torso == max(common)  # the deepest: MuJoCo numbers a body after its parent
    assert shared_ancestor(m, a, a, default=-1) == int(m.body_parentid[a])
    assert shared_ancestor(m, a, 0, default=-7) == -7  # the world is no proper ancestor: the default
