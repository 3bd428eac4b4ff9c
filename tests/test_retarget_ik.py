"""mink IK: the limits bind (joint range, velocity, base speed, collision), the collision rows and the key-frame
task are exact derivatives (finite differences), a person moving in pushes the robot out, a fast hand does not pass
through a person, reachable targets are met (also on a fast swing)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import mink
import mujoco
import numpy as np
import pytest

from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.errors import SimulationError
from socialaff_sim.retarget.collision import collision_pairs
from socialaff_sim.retarget.ik import IKConfig, IKModel, RobotIK
from socialaff_sim.retarget.key_task import _right_jacobian_inverse
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.scene import Scene, build_scene, set_human_sizes
from socialaff_sim.sim.simulator import SimConfig, Simulator

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
    config = IKConfig(min_distance=0.02, contact_depth=0.0)
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
    ik.set_contact_exemptions([])  # rebuild the pairs for the new sizes
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


def _far_human(scene: Scene, ik: RobotIK) -> tuple[np.ndarray, np.ndarray]:
    pos = np.array(ik.configuration.data.mocap_pos[scene.human_mocap])
    return pos, np.tile([1.0, 0.0, 0.0, 0.0], (len(pos), 1))


def test_collision_rows_are_distance_gradients(stick: Scene, rng: np.random.Generator) -> None:
    """Each row G of the collision limit is −∂d/∂q: checked against finite differences of mj_geomDistance."""
    ik = ik_for(stick, 2.0)
    m = stick.model
    pos, quat = _far_human(stick, ik)
    hand = ik.frame_positions()[1]
    # A hand sphere of the person 6 cm ahead of the robot's left palm, the trunk capsule near the pelvis.
    pos[stick.n_bones] = hand + (0.04 + 0.05 + 0.06, 0.0, 0.0)
    bone = stick.body.bone_names.index("spine_base__spine_mid")
    pos[bone] = ik.frame_positions()[0] + (0.1 + 0.11 + 0.05, 0.05, 0.0)
    set_human_sizes(stick, np.full(stick.n_bones, 0.05))
    ik.set_contact_exemptions([])
    ik.set_human(pos, quat)
    ik.configuration.update(ik.configuration.q + np.concatenate([np.zeros(7), rng.uniform(-0.3, 0.3, m.nq - 7)]))
    lim = ik.collision_limit
    c = lim.compute_qp_inequalities(ik.configuration, 0.1)
    assert not c.inactive and len(c.h) >= 2
    q0 = ik.configuration.q
    fromto = np.zeros(6)
    checked = 0
    for (a, b), row, dist in zip(lim.last_active, c.G, lim.last_distance, strict=True):
        d0 = mujoco.mj_geomDistance(m, ik.configuration.data, int(a), int(b), 1.0, fromto)
        if abs(dist - d0) > 1e-6 or (lim.last_active == (a, b)).all(axis=1).sum() > 1:
            continue  # one of several contact points of a pair (a capsule along a box face): a one-sided gradient
        checked += 1
        for _ in range(3):
            v = rng.normal(size=m.nv) * 1e-5
            q = q0.copy()
            mujoco.mj_integratePos(m, q, v, 1.0)
            ik.configuration.update(q)
            d1 = mujoco.mj_geomDistance(m, ik.configuration.data, int(a), int(b), 1.0, fromto)
            ik.configuration.update(q0)
            np.testing.assert_allclose(-row @ v, d1 - d0, atol=2e-8, rtol=0.02)
    assert checked >= 2


def test_key_frames_task_is_its_own_derivative(stick: Scene, rng: np.random.Generator) -> None:
    ik = ik_for(stick, 2.0)
    task, cfg, m = ik.key_task, ik.configuration, stick.model
    ik._set_targets(ik.frame_positions() + rng.normal(0, 0.05, (5, 3)), 0.3)
    cfg.update(cfg.q + np.concatenate([np.zeros(7), rng.uniform(-0.3, 0.3, m.nq - 7)]))
    e0, J = task.compute_error(cfg), task.compute_jacobian(cfg)
    assert e0.shape == (15 + 3 * len(task.oriented),) and J.shape == (len(e0), m.nv)
    np.testing.assert_allclose(e0[:15], (ik.frame_positions() - task.target_positions).ravel(), atol=1e-12)
    q0 = cfg.q
    for _ in range(3):
        v = rng.normal(size=m.nv) * 1e-6
        q = q0.copy()
        mujoco.mj_integratePos(m, q, v, 1.0)
        cfg.update(q)
        e1 = task.compute_error(cfg)
        cfg.update(q0)
        # Positions exactly; orientation rows to first order at this (small) orientation error.
        np.testing.assert_allclose(J[:15] @ v, (e1 - e0)[:15], atol=1e-10, rtol=1e-4)
        np.testing.assert_allclose(J[15:] @ v, (e1 - e0)[15:], atol=1e-10, rtol=0.05)


def test_person_moving_in_pushes_the_trunk_out(stick: Scene) -> None:
    config = IKConfig(min_distance=0.02, max_push=0.02, iterations=1)  # one QP step per solve: the push of a step
    ik = ik_for(stick, 2.0, config)
    pos, quat = _far_human(stick, ik)
    base = ik.frame_positions()[0]
    bone = stick.body.bone_names.index("spine_base__spine_mid")
    half = np.full(stick.n_bones, 0.05)
    half[bone] = 0.3
    set_human_sizes(stick, half)
    ik.set_contact_exemptions([])
    pelvis = stick.model.geom("robot/pelvis").id
    capsule = int(stick.human_geom_ids[bone])
    fromto = np.zeros(6)
    # The person's upright capsule (r = 0.11) 5 mm into the pelvis box (half depth 0.1): 0.205 from its centre.
    pos[bone] = base + (0.205, 0.0, 0.0)
    ik.set_human(pos, quat)
    targets = ik.frame_positions().copy()
    d = [mujoco.mj_geomDistance(stick.model, ik.configuration.data, pelvis, capsule, 1.0, fromto)]
    for _ in range(4):
        ik.solve(targets, 0.0, dt=0.1)
        d.append(mujoco.mj_geomDistance(stick.model, ik.configuration.data, pelvis, capsule, 1.0, fromto))
    d = np.array(d)
    assert d[0] < 0
    steps = np.diff(d)
    assert (steps > 0).all() and (steps <= config.max_push + 1e-6).all()  # pushed out, at most max_push a step
    assert d[-1] >= config.min_distance - 1e-3


def test_base_speed_binds(stick: Scene) -> None:
    config = IKConfig(max_base_speed=0.5, iterations=1)
    ik = ik_for(stick, 2.0, config)
    targets = ik.frame_positions() + (1.0, 0.0, 0.0)  # everything one metre ahead
    before = ik.configuration.q[:3]
    ik.solve(targets, 0.0, dt=0.1)
    moved = ik.configuration.q[:3] - before
    np.testing.assert_allclose(moved[0], 0.5 * 0.1, rtol=1e-6)  # binding
    assert np.abs(moved).max() <= 0.05 + 1e-9


def test_collision_pairs_follow_mujoco_filters(stick: Scene) -> None:
    m = stick.model
    arm = np.flatnonzero(stick.arm_geom[0])
    robot = np.flatnonzero(stick.robot_geom & (m.geom_contype != 0))
    pairs = collision_pairs(m, arm, robot)
    bodies = {tuple(sorted((m.body(int(m.geom_bodyid[a])).name, m.body(int(m.geom_bodyid[b])).name))) for a, b in pairs}
    assert ("robot/larm", "robot/pelvis") not in bodies  # parent and child
    assert ("robot/lhand", "robot/pelvis") not in bodies  # lhand has no joint: welded to larm, a child of the pelvis
    assert ("robot/larm", "robot/rarm") in bodies and ("robot/lhand", "robot/rleg") in bodies
    assert not any(m.geom_bodyid[a] == m.geom_bodyid[b] for a, b in pairs)
    assert len({tuple(sorted(p)) for p in pairs.tolist()}) == len(pairs)


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
    pairs = [(int(a), int(b)) for side in ik._self_pairs for a, b in side]
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


def _frame_targets(scene: Scene, d: mujoco.MjData) -> np.ndarray:
    frames = zip(scene.frame_kinds, scene.frame_ids, strict=True)
    return np.array([d.site_xpos[i] if k == "site" else d.xpos[i] for k, i in frames])


def test_fast_swing_is_met_within_2cm() -> None:
    """Both arms raised overhead and lowered again within 0.8 s at 15 fps (peak 9.4 rad/s of the 12 allowed):
    a reachable target a frame moves by up to 0.4 m. One linearised step overshoots such a move, and stopping
    at the first step that does not help left misses of several centimetres (issue 5)."""
    scene = build_scene(load_robot("ours"), LAYOUT, physics=False)
    m = scene.model
    ik = ik_for(scene, 12.0)
    names = ["left_shoulder_pitch", "right_shoulder_pitch", "left_elbow", "right_elbow"]
    adr = np.array([m.jnt_qposadr[m.joint(f"robot/{n}").id] for n in names])
    amplitude = np.array([-2.4, -1.92, -1.6, -1.12])  # rad: inside the ranges from home (checked below)
    T, period, fps = 24, 12, 15.0
    d = mujoco.MjData(m)
    pairs = [(int(a), int(b)) for side in ik._self_pairs for a, b in side]
    fromto = np.zeros(6)
    reference, targets = [], []
    for t in range(1, T + 1):
        q = scene.home_qpos.copy()
        q[adr] += amplitude * 0.5 * (1.0 - np.cos(2.0 * np.pi * t / period))
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        # Reachable by construction: inside the ranges, the forearms clear of the body, and slow enough.
        ranges = m.jnt_range[[m.joint(f"robot/{n}").id for n in names]]
        assert ((ranges[:, 0] <= q[adr]) & (q[adr] <= ranges[:, 1])).all()
        assert min(mujoco.mj_geomDistance(m, d, a, b, 0.1, fromto) for a, b in pairs) >= 0.02
        reference.append(q)
        targets.append(_frame_targets(scene, d))
    speed = np.abs(np.diff(np.array(reference)[:, adr], axis=0)).max() * fps
    assert speed <= 0.8 * 12.0
    moves = np.linalg.norm(np.diff(np.array(targets), axis=0), axis=2).max()
    assert moves >= 0.3  # metres a frame: the fast regime
    errors = np.array([ik.solve(tg, 0.0, dt=1.0 / fps).errors for tg in targets])
    np.testing.assert_allclose(errors, 0.0, atol=0.02)
    # The sequence needs the extra steps: one QP step a frame falls far behind.
    one = ik_for(scene, 12.0, IKConfig(iterations=1))
    assert max(one.solve(tg, 0.0, dt=1.0 / fps).errors.max() for tg in targets) > 0.1


def test_fast_hand_does_not_pass_through_a_person(stick: Scene) -> None:
    """A fast hand 12 cm from a person (beyond the 10 cm at which the pair enters the QP), its target 35 cm
    ahead: without checking the step, the hand lands inside the person and is held there."""
    def run(config: IKConfig) -> tuple[np.ndarray, float]:
        ik = ik_for(stick, 40.0, config)
        targets = ik.frame_positions().copy()
        hand = targets[1].copy()
        targets[1] = hand + (0.35, 0.0, 0.0)
        pos, quat = _far_human(stick, ik)
        bone = stick.body.bone_names.index("spine_mid__spine_shoulder")
        pos[bone] = hand + (0.12 + 0.04 + stick.body.radii[bone], 0.0, 0.0)  # surface 12 cm ahead of the palm
        half = np.full(stick.n_bones, 0.05)
        half[bone] = 0.3
        set_human_sizes(stick, half)
        ik.set_contact_exemptions([])
        ik.set_human(pos, quat)
        palm, capsule = stick.model.geom("robot/lpalm").id, int(stick.human_geom_ids[bone])
        fromto = np.zeros(6)
        gaps = []
        for _ in range(6):
            res = ik.solve(targets, 0.0, dt=0.1)
            gaps.append(mujoco.mj_geomDistance(stick.model, ik.configuration.data, palm, capsule, 1.0, fromto))
        return np.array(gaps), float(res.errors[1])

    config = IKConfig(min_distance=0.02, contact_depth=0.0)
    gaps, error = run(config)
    np.testing.assert_allclose(gaps, config.min_distance, atol=config.collision_slack)
    assert error > 0.1  # stopped in front of the person
    unchecked, _ = run(dataclasses.replace(config, backtracks=0))
    assert unchecked.min() < -0.05  # the scenario is one that tunnels


def test_watched_pair_rows_are_distance_gradients(stick: Scene, rng: np.random.Generator) -> None:
    """A pair beyond its detection distance gets, once watched, the row −∂d/∂q (finite differences)."""
    ik = ik_for(stick, 2.0)
    m = stick.model
    pos, quat = _far_human(stick, ik)
    pos[stick.n_bones] = ik.frame_positions()[1] + (0.3, 0.05, 0.1)  # a hand sphere 30 cm from the palm
    set_human_sizes(stick, np.full(stick.n_bones, 0.05))
    ik.set_contact_exemptions([])
    ik.set_human(pos, quat)
    ik.configuration.update(ik.configuration.q + np.concatenate([np.zeros(7), rng.uniform(-0.3, 0.3, m.nq - 7)]))
    lim = ik.collision_limit
    palm, sphere = m.geom("robot/lpalm").id, int(stick.human_geom_ids[stick.n_bones])
    assert lim.compute_qp_inequalities(ik.configuration, 0.1).inactive  # too far to be seen
    assert lim.watch(np.array([[palm, sphere]])) and not lim.watch(np.array([[sphere, palm]]))
    c = lim.compute_qp_inequalities(ik.configuration, 0.1)
    assert len(c.h) == 1 and tuple(lim.last_active[0]) == (palm, sphere)
    fromto = np.zeros(6)
    q0 = ik.configuration.q
    d0 = mujoco.mj_geomDistance(m, ik.configuration.data, palm, sphere, 1.0, fromto)
    np.testing.assert_allclose(c.h[0], lim.gain * (d0 - IKConfig().min_distance), atol=1e-9)
    for _ in range(3):
        v = rng.normal(size=m.nv) * 1e-5
        q = q0.copy()
        mujoco.mj_integratePos(m, q, v, 1.0)
        ik.configuration.update(q)
        d1 = mujoco.mj_geomDistance(m, ik.configuration.data, palm, sphere, 1.0, fromto)
        ik.configuration.update(q0)
        np.testing.assert_allclose(-c.G[0] @ v, d1 - d0, atol=2e-9, rtol=0.01)
    lim.unwatch()
    assert lim.compute_qp_inequalities(ik.configuration, 0.1).inactive


def test_right_jacobian_inverse_against_the_closed_form(rng: np.random.Generator) -> None:
    """The inverse of J_r(e) = I − (1 − cos θ)/θ²·K + (θ − sin θ)/θ³·K² (K = [e]×), inverted numerically."""
    for e in [*rng.normal(size=(5, 3)), np.array([1e-9, -2e-9, 0.0]), np.array([0.0, 0.0, 3.0])]:
        theta = np.linalg.norm(e)
        K = np.array([[0.0, -e[2], e[1]], [e[2], 0.0, -e[0]], [-e[1], e[0], 0.0]])
        if theta < 1e-6:
            jr = np.eye(3) - 0.5 * K + K @ K / 6.0
        else:
            jr = np.eye(3) - (1 - np.cos(theta)) / theta**2 * K + (theta - np.sin(theta)) / theta**3 * K @ K
        np.testing.assert_allclose(_right_jacobian_inverse(e), np.linalg.inv(jr), atol=1e-9, rtol=1e-7)


def _replay_misses(robot: str, label: str, index: int, ik: IKConfig) -> tuple[list[tuple[int, int, float]], int]:
    """Replay the ground truth of one default synthetic instance; the reachable targets off by > 2 cm
    (frame, key frame, error) and the steps undone. The catch's wrist targets as when this was measured: without
    the hand target on the ball's flight (on by default since issue 25's rule), which changes the catch's targets
    and with them the exchange this replay shows."""
    inter = generate_dataset(seed=0).of_label(label).interactions[index]
    c = SimConfig(ik=ik)
    c = dataclasses.replace(c, contact_completion=dataclasses.replace(c.contact_completion, catch_flight=False,
                                                                      catch_approach=False))
    sim = Simulator(robot, label, c)
    sim.reset(inter)
    undone = []
    solve = sim._stage.ik.solve  # type: ignore[union-attr]

    def counting(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
        res = solve(*args, **kwargs)
        undone.append(res.undone)
        return res

    sim._stage.ik.solve = counting  # type: ignore[union-attr, method-assign]
    run_episode(sim, GroundTruthSource(), inter)
    avail = inter.key_available()
    misses = [(r.frame, k, float(r.ik_error[k])) for r in sim.results for k in range(5)
              if r.reachable[k] and avail[k] and r.ik_error[k] > 0.02]
    return misses, int(sum(undone))


def test_hands_closing_on_a_ball_do_not_trade_places() -> None:
    """The catch of default synthetic throw-and-catch instance 3 on Stubby puts its two wrist targets 2–3 cm
    apart, both pushed into the ball. Step after step the collision avoidance between the hands pushed one
    off as the other arrived, and the frame ended with both 7–9 cm off (issue 5). Undoing a step that makes
    the weighted RMS error grow by more than ``max_worsening`` lets the damped steps settle both."""
    # The torso free to lean (its posture cost as every joint's, the default until issue 25): with the
    # torso held upright (the default now) this catch no longer leads the two hands into that exchange. No
    # standing balance either (issue 25): pinned feet and the centre of mass over them move the base off its
    # target by 2–3 cm, which would count as missed.
    old = IKConfig(torso_posture_cost=0.01, com_cost=0.0, planted_foot_cost=1.0, planted_foot_orientation_cost=0.05)
    misses, undone = _replay_misses("ours", "throw_catch", 3, old)
    assert misses == [] and undone > 0
    misses, undone = _replay_misses("ours", "throw_catch", 3, dataclasses.replace(old, max_worsening=None))
    assert undone == 0 and len(misses) >= 1 and max(e for _, _, e in misses) > 0.05, misses


@pytest.mark.parametrize(("field", "value", "pattern"), [
    ("max_worsening", -0.01, r"IKConfig.max_worsening: expected a distance ≥ 0 m or None, found -0.01"),
    ("damping_growth", 0.5, r"IKConfig.damping_growth: expected at least 1.0, found 0.5"),
    ("max_damping", 1e-5, r"IKConfig.max_damping: expected at least 0.0001, found 1e-05"),
])
def test_undo_settings_are_checked(stick: Scene, field: str, value: float, pattern: str) -> None:
    with pytest.raises(SimulationError, match=pattern):
        ik_for(stick, 8.0, IKConfig(**{field: value}))
