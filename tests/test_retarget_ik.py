"""mink IK: the limits bind (joint range, velocity, collision), reachable targets are met."""

from __future__ import annotations

from pathlib import Path

import mink
import mujoco
import numpy as np
import pytest

from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.retarget.ik import IKConfig, IKModel, RobotIK
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.scene import Scene, build_scene, set_human_sizes

LAYOUT = get_layout("kinect_v2")

STICK_XML = """
<mujoco model="stick">
  <compiler angle="radian" autolimits="true"/>
  <default><geom contype="1" conaffinity="3"/></default>
  <worldbody>
    <body name="pelvis" pos="0 0 1">
      <site name="base"/>
      <geom name="pelvis" type="box" size="0.1 0.15 0.1" mass="5"/>
      <body name="larm" pos="0 0.25 0.3">
        <joint name="lsh" axis="0 1 0" range="-1 1"/>
        <geom name="larm" type="capsule" fromto="0 0 -0.05 0 0 -0.45" size="0.03" mass="1"/>
        <body name="lhand" pos="0 0 -0.5">
          <site name="lwrist"/>
          <geom name="lpalm" type="sphere" size="0.04" mass="0.2"/>
        </body>
      </body>
      <body name="rarm" pos="0 -0.25 0.3">
        <joint name="rsh" axis="0 1 0" range="-1 1"/>
        <geom name="rarm" type="capsule" fromto="0 0 -0.05 0 0 -0.45" size="0.03" mass="1"/>
        <body name="rhand" pos="0 0 -0.5">
          <site name="rwrist"/>
          <geom name="rpalm" type="sphere" size="0.04" mass="0.2"/>
        </body>
      </body>
      <body name="lleg" pos="0 0.1 -0.1">
        <joint name="lhip" axis="0 1 0" range="-0.5 0.5"/>
        <geom name="lleg" type="capsule" fromto="0 0 -0.1 0 0 -0.75" size="0.04" mass="2"/>
        <body name="lfoot" pos="0 0 -0.85"><site name="lankle"/><geom name="lfoot" type="sphere" size="0.04"/></body>
      </body>
      <body name="rleg" pos="0 -0.1 -0.1">
        <joint name="rhip" axis="0 1 0" range="-0.5 0.5"/>
        <geom name="rleg" type="capsule" fromto="0 0 -0.1 0 0 -0.75" size="0.04" mass="2"/>
        <body name="rfoot" pos="0 0 -0.85"><site name="rankle"/><geom name="rfoot" type="sphere" size="0.04"/></body>
      </body>
    </body>
  </worldbody>
  <keyframe><key name="home" qpos="0 0 0 0"/></keyframe>
</mujoco>
"""

STICK_TOML = """
name = "stick"
mjcf = "stick.xml"
[frames]
base = "site:base"
left_wrist = "site:lwrist"
right_wrist = "site:rwrist"
left_ankle = "site:lankle"
right_ankle = "site:rankle"
[limbs]
left_shoulder = "body:larm"
right_shoulder = "body:rarm"
left_hip = "body:lleg"
right_hip = "body:rleg"
[hands]
left = ["lhand"]
right = ["rhand"]
[posture]
keyframe = "home"
[limits]
max_joint_velocity = 2.0
"""


def ik_for(scene: Scene, vmax: float, config: IKConfig | None = None) -> RobotIK:
    m = scene.model
    collidable = scene.robot_geom & ((m.geom_contype != 0) | (m.geom_conaffinity != 0))
    spec = IKModel(
        model=m, frame_kinds=scene.frame_kinds, frame_ids=scene.frame_ids, home_qpos=scene.home_qpos,
        hand_geoms=tuple(np.flatnonzero(h) for h in scene.hand_geom),
        arm_geoms=tuple(np.flatnonzero(a) for a in scene.arm_geom),
        robot_geoms=np.flatnonzero(collidable), human_geoms=scene.human_geom_ids, human_mocap=scene.human_mocap,
        max_joint_velocity=vmax,
    )
    ik = RobotIK(spec, config)
    n = len(scene.human_mocap)
    far = np.tile([0.0, 0.0, -20.0], (n, 1)) + np.arange(n)[:, None] * [0.5, 0.0, 0.0]
    ik.set_human(far, np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)))
    ik.reset(scene.home_qpos)
    return ik


@pytest.fixture(scope="module")
def stick(tmp_path_factory: pytest.TempPathFactory) -> Scene:
    folder: Path = tmp_path_factory.mktemp("stick")
    (folder / "stick.xml").write_text(STICK_XML)
    (folder / "stick.toml").write_text(STICK_TOML)
    return build_scene(load_robot(folder / "stick.toml"), LAYOUT, physics=False)


def qpos_of(scene: Scene, ik: RobotIK, joint: str) -> float:
    return float(ik.configuration.q[scene.model.jnt_qposadr[scene.model.joint(f"robot/{joint}").id]])


def test_a_new_robot_works_through_its_mapping_file(stick: Scene) -> None:
    assert stick.robot.name == "stick"
    assert stick.robot_joint_names == ("robot/root/", "robot/lsh", "robot/rsh", "robot/lhip", "robot/rhip")
    # Standing on the floor: the feet (spheres of 4 cm at 1.85 m below the frame origin... ) touch z = 0.
    ik = ik_for(stick, 2.0)
    np.testing.assert_allclose(ik.frame_positions()[3, 2], 0.04, atol=1e-9)


def test_joint_range_binds(stick: Scene) -> None:
    ik = ik_for(stick, 50.0)
    targets = ik.frame_positions().copy()
    # Left arm swung to 2 rad (range ends at 1 rad): shoulder at (0, .25, .3) from the base, arm 0.5 m.
    shoulder = targets[0] + (0.0, 0.25, 0.3)
    targets[1] = shoulder + 0.5 * np.array([-np.sin(2.0), 0.0, -np.cos(2.0)])
    for _ in range(15):
        ik.solve(targets, 0.0, dt=0.1)
    q = qpos_of(stick, ik, "lsh")
    assert q <= 1.0 + 1e-9
    np.testing.assert_allclose(q, 1.0, atol=2e-3)


def test_velocity_limit_caps_each_frame(stick: Scene) -> None:
    vmax, dt = 2.0, 0.05
    ik = ik_for(stick, vmax)
    targets = ik.frame_positions().copy()
    shoulder = targets[0] + (0.0, 0.25, 0.3)
    targets[1] = shoulder + 0.5 * np.array([-np.sin(0.9), 0.0, -np.cos(0.9)])  # 0.9 rad away, reachable
    previous = qpos_of(stick, ik, "lsh")
    steps = []
    for _ in range(12):
        ik.solve(targets, 0.0, dt=dt)
        q = qpos_of(stick, ik, "lsh")
        steps.append(abs(q - previous))
        previous = q
    steps = np.array(steps)
    assert (steps <= vmax * dt + 1e-9).all()
    np.testing.assert_allclose(steps[:3], vmax * dt, rtol=1e-6)  # binding while far from the target
    np.testing.assert_allclose(previous, 0.9, atol=5e-3)  # and the target is reached in the end


def test_collision_pair_keeps_its_distance(stick: Scene) -> None:
    config = IKConfig(min_distance=0.02)
    ik = ik_for(stick, 1.0, config)  # slow enough that the 10 cm detection range sees it coming
    targets = ik.frame_positions().copy()
    hand = targets[1].copy()
    targets[1] = hand + (0.3, 0.0, 0.0)  # straight ahead...
    # ...through a human capsule standing upright 12 cm in front of the hand.
    pos = np.array(ik.configuration.data.mocap_pos[stick.human_mocap])
    quat = np.tile([1.0, 0.0, 0.0, 0.0], (len(pos), 1))
    bone = stick.body.bone_names.index("spine_mid__spine_shoulder")
    pos[bone] = hand + (0.12 + 0.04 + 0.05, 0.0, 0.0)
    half = np.full(stick.n_bones, 0.05)
    half[bone] = 0.3
    set_human_sizes(stick, half)
    ik.set_contact_exemptions([])  # rebuild: the capsule changed size
    ik.set_human(pos, quat)
    palm = stick.model.geom("robot/lpalm").id
    capsule = stick.human_geom_ids[bone]
    fromto = np.zeros(6)
    for _ in range(20):
        res = ik.solve(targets, 0.0, dt=0.05)
        d = mujoco.mj_geomDistance(stick.model, ik.configuration.data, palm, int(capsule), 1.0, fromto)
        assert d >= config.min_distance - 2e-3
    assert res.errors[1] > 0.1  # the target behind the capsule stays out of reach
    # Exempted (a contact the task wants), the same pair may touch but not sink in.
    ik.set_contact_exemptions([(0, [int(capsule)])])
    for _ in range(20):
        ik.solve(targets, 0.0, dt=0.05)
    d = mujoco.mj_geomDistance(stick.model, ik.configuration.data, palm, int(capsule), 1.0, fromto)
    np.testing.assert_allclose(d, -config.contact_depth, atol=5e-3)


def test_solve_ik_gets_keywords(stick: Scene, monkeypatch: pytest.MonkeyPatch) -> None:
    seen = []
    real = mink.solve_ik

    def spy(*args: object, **kwargs: object) -> np.ndarray:
        seen.append((len(args), dict(kwargs)))
        return real(*args, **kwargs)

    monkeypatch.setattr(mink, "solve_ik", spy)
    ik = ik_for(stick, 2.0)
    targets = ik.frame_positions() + (0.05, 0.0, 0.0)
    ik.solve(targets, 0.0, dt=0.1)
    assert seen and all(n == 0 for n, _ in seen)  # everything by keyword
    assert all(kw["solver"] == "daqp" and {"configuration", "tasks", "dt", "limits"} <= set(kw) for _, kw in seen)


@pytest.mark.parametrize("robot", ["ours", "cmu"])
def test_reachable_targets_are_met_within_2cm(robot: str, rng: np.random.Generator) -> None:
    scene = build_scene(load_robot(robot), LAYOUT, physics=False)
    m = scene.model
    ik = ik_for(scene, 8.0)
    # A smooth random motion inside the joint ranges; its forward kinematics gives reachable targets.
    T, dt = 40, 1 / 15
    hinge = np.arange(7, m.nq)
    lo, hi = m.jnt_range[1:, 0], m.jnt_range[1:, 1]
    centre = np.clip(scene.home_qpos[hinge], lo, hi)
    amp = 0.25 * rng.uniform(0.0, 1.0, len(hinge))
    phase = rng.uniform(0, 2 * np.pi, len(hinge))
    d = mujoco.MjData(m)
    pairs = [(a, b) for arm, rest in ik._self_pairs for a in arm for b in rest
             if m.geom_bodyid[a] != m.geom_bodyid[b] and m.body_parentid[m.geom_bodyid[a]] != m.geom_bodyid[b]]
    fromto = np.zeros(6)
    errors, clear = [], []
    for t in range(T):
        q = scene.home_qpos.copy()
        q[hinge] = np.clip(centre + amp * np.sin(2 * np.pi * t / 30 + phase), lo, hi)
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        targets = np.array([d.site_xpos[i] if k == "site" else d.xpos[i] for k, i in zip(scene.frame_kinds, scene.frame_ids, strict=True)])
        # Reachable under the self-collision avoidance only if the reference pose keeps its forearms clear.
        gap = min(mujoco.mj_geomDistance(m, d, a, b, 0.1, fromto) for a, b in pairs)
        clear.append(gap >= 0.02)
        errors.append(ik.solve(targets, 0.0, dt=dt).errors)
    errors, clear = np.array(errors), np.array(clear)
    assert clear.sum() >= 10
    assert errors[clear].max() <= 0.02, errors[clear].max(axis=0)
