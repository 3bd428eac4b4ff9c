"""The MuJoCo scene: robots on the floor, the replayed human's capsules, real contacts, servos."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from socialaff_sim.data.interaction import Interaction
from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.errors import SimulationError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.human import FOOT_CLEARANCE, bone_quaternions, human_body, pose_human, world_offset
from socialaff_sim.sim.scene import ObjectSpec, Scene, build_scene, pose_compliant, set_human_sizes
from socialaff_sim.sim.reach import ReachModel, point_segment_distance, reachable_targets
from socialaff_sim.sim.robot_mjcf import limit_hand_force
from socialaff_sim.sim.simulator import SimConfig, Simulator

LAYOUT = get_layout("kinect_v2")


@pytest.fixture(scope="module")
def data():
    return generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=1))


@pytest.fixture(scope="module", params=["ours", "cmu"])
def scene(request: pytest.FixtureRequest) -> Scene:
    return build_scene(load_robot(request.param), LAYOUT, ObjectSpec("sphere", (0.1,), 0.15))


def posed(scene: Scene, human_at: np.ndarray | None = None) -> mujoco.MjData:
    d = mujoco.MjData(scene.model)
    d.qpos[scene.robot_qadr] = scene.home_qpos
    far = np.array([10.0, 10.0, 1.0]) if human_at is None else human_at
    n = len(scene.human_mocap)
    pos = far + np.arange(n)[:, None] * [0.0, 0.3, 0.0]
    quat = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    d.mocap_pos[scene.human_mocap] = pos
    d.mocap_quat[scene.human_mocap] = quat
    pose_compliant(scene, d, pos, quat)
    qa = scene.object_qadr
    d.qpos[qa:qa + 3] = (-5.0, -5.0, 0.1)
    mujoco.mj_forward(scene.model, d)
    return d


def test_robot_stands_on_the_floor_at_home(scene: Scene) -> None:
    d = posed(scene)
    m = scene.model
    fromto = np.zeros(6)
    robot = np.flatnonzero(scene.robot_geom & (m.geom_contype != 0))
    gap = min(mujoco.mj_geomDistance(m, d, int(g), scene.floor_geom, 1.0, fromto) for g in robot)
    np.testing.assert_allclose(gap, 0.0, atol=1e-3)
    # No part of the robot touches another at home.
    pairs = [(c.geom1, c.geom2) for c in d.contact[: d.ncon]]
    assert not [p for p in pairs if scene.robot_geom[p[0]] and scene.robot_geom[p[1]]]


def test_proportions_of_our_robot_differ_from_a_person() -> None:
    sc = build_scene(load_robot("ours"), LAYOUT, physics=False)
    d = mujoco.MjData(sc.model)
    d.qpos[:] = sc.home_qpos
    mujoco.mj_forward(sc.model, d)
    head = sc.model.geom("robot/head").id  # an upright box: its top is centre + half height
    top = d.geom_xpos[head, 2] + sc.model.geom_size[head, 2]
    assert 1.25 < top < 1.35
    upper = np.linalg.norm(d.xpos[sc.model.body("robot/left_forearm").id] - d.xpos[sc.model.body("robot/left_upper_arm").id])
    arm = np.linalg.norm(d.site_xpos[sc.model.site("robot/left_wrist").id] - d.xpos[sc.model.body("robot/left_forearm").id]) + upper
    leg = 0.26 + 0.24
    # A person: arm ≈ 0.31 and leg ≈ 0.49 of the stature; this robot: very long arms, short legs.
    np.testing.assert_allclose(arm, 0.84, atol=1e-9)
    assert arm / top > 0.6 and leg / top < 0.4


def test_hand_force_caps_the_arm_torques() -> None:
    sc = build_scene(load_robot("ours"), LAYOUT, None)
    before = sc.model.actuator_forcerange.copy()
    limit_hand_force(sc, 50.0)
    m = sc.model
    d = mujoco.MjData(m)
    d.qpos[sc.robot_qadr] = sc.home_qpos
    mujoco.mj_kinematics(m, d)
    wrist = d.site_xpos[m.site("robot/left_wrist").id]
    # The hand's far end: the palm box's corner farthest from the wrist, by hand (box half sizes 0.025, 0.05, 0.055
    # centred 0.06 below the wrist) against the thumb capsule; the bounding sphere of each bounds it from above.
    palm = m.geom("robot/left_palm").id
    reach = np.linalg.norm(d.geom_xpos[palm] - wrist) + m.geom_rbound[palm]
    for name in ("left_shoulder_pitch", "left_elbow"):
        a = m.actuator(f"robot/{name}").id
        j = m.actuator_trnid[a, 0]
        lever = np.linalg.norm(wrist - d.xanchor[j]) + reach
        np.testing.assert_allclose(m.actuator_forcerange[a], [-50.0 * lever, 50.0 * lever], rtol=1e-9)
        assert m.actuator_forcelimited[a]
    # Legs and waist keep the model's own limits; a cap never raises a limit.
    for name in ("left_knee", "waist_pitch"):
        a = m.actuator(f"robot/{name}").id
        np.testing.assert_array_equal(m.actuator_forcerange[a], before[a])
    a = m.actuator("robot/left_wrist_roll").id
    capped = m.actuator_forcerange[a].copy()
    assert capped[1] < before[a, 1]  # 50 N at a lever of a hand length is below the wrist servo's 15 N·m
    limit_hand_force(sc, 1e6)
    np.testing.assert_array_equal(m.actuator_forcerange[a], capped)


def test_point_segment_distance_against_sampling(rng: np.random.Generator) -> None:
    p = rng.normal(size=(7, 3))
    a, b = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    b[0] = a[0]  # a point-like segment
    s = np.linspace(0.0, 1.0, 20001)
    brute = np.array([[np.linalg.norm(pi - (aj + s[:, None] * (bj - aj)), axis=1).min() for aj, bj in zip(a, b, strict=True)]
                      for pi in p])
    np.testing.assert_allclose(point_segment_distance(p, a, b), brute, atol=1e-6)


def test_reachable_targets_by_hand() -> None:
    model = ReachModel(arm=0.5, leg=0.4, shoulders=np.array([[0.0, 0.2, 0.4], [0.0, -0.2, 0.4]]),
                       hips=np.array([[0.0, 0.1, 0.0], [0.0, -0.1, 0.0]]), hand_reach=np.array([0.1, 0.1]),
                       hand_centre=np.array([0.05, 0.05]), trunk_radius=0.2, shoulder_height=0.4, base_height=0.6,
                       height=1.3, clearance=0.01)
    base = np.array([0.0, 0.0, 0.6])
    targets = np.array([base, base + (0.45, 0.2, 0.4), base + (0.3, -0.2, 0.9), base + (0.0, 0.1, -0.39),
                        base + (0.0, -0.1, -0.41)])
    # One person capsule: a vertical segment 1 m ahead, radius 0.1.
    seg_a, seg_b, r = np.array([[1.0, 0.0, 0.0]]), np.array([[1.0, 0.0, 2.0]]), np.array([0.1])
    out = reachable_targets(model, targets, targets, seg_a, seg_b, r)
    # Left wrist 0.45 from its shoulder (≤ 0.5) and 0.45 from the capsule (≥ 0.1 + 0.01): reachable. Right wrist
    # 0.5 above and 0.3 ahead of its shoulder: 0.58 > 0.5. Left ankle 0.39 below its hip (≤ 0.4), right 0.41.
    np.testing.assert_array_equal(out, [True, True, False, True, False])
    # The capsule 0.2 m straight ahead of the left wrist (surface 0.1 m away): within the hand's reach plus clearance.
    near_a, near_b = seg_a + (-0.35, 0.2, 0.0), seg_b + (-0.35, 0.2, 0.0)
    np.testing.assert_array_equal(reachable_targets(model, targets, targets, near_a, near_b, r)[1], False)
    # The capsule 0.25 m from the base's axis (< 0.2 + 0.1 + 0.01): the base, and so everything, is out of reach.
    assert not reachable_targets(model, targets, targets, seg_a - (0.75, 0, 0), seg_b - (0.75, 0, 0), r).any()


def test_bone_quaternions_turn_z_onto_the_bone(rng: np.random.Generator) -> None:
    dirs = rng.normal(size=(50, 3))
    dirs[0] = (0, 0, 1)
    dirs[1] = (0, 0, -1)
    q = bone_quaternions(dirs)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-12)
    for qi, di in zip(q, dirs, strict=True):
        out = np.zeros(3)
        mujoco.mju_rotVecQuat(out, np.array([0.0, 0.0, 1.0]), qi)
        np.testing.assert_allclose(out, di / np.linalg.norm(di), atol=1e-12)
    np.testing.assert_allclose(bone_quaternions(np.zeros(3)), [1, 0, 0, 0])


def test_capsules_join_the_skeleton_joints(scene: Scene, data) -> None:
    inter = data.of_label("shake_hands")[0]
    offset = world_offset(inter)
    pose = pose_human(scene.body, inter, offset)
    set_human_sizes(scene, pose.half_lengths)
    d = posed(scene)
    t = inter.n_frames // 2
    d.mocap_pos[scene.human_mocap] = pose.pos[t]
    d.mocap_quat[scene.human_mocap] = pose.quat[t]
    pose_compliant(scene, d, pose.pos[t], pose.quat[t])
    mujoco.mj_kinematics(scene.model, d)
    joints = pose.joints[t]
    for b, (p, c) in enumerate(scene.body.bones):
        g = scene.human_geom_ids[b]
        axis = d.geom_xmat[g].reshape(3, 3)[:, 2]
        half = scene.model.geom_size[g, 1]
        length = np.linalg.norm(joints[c] - joints[p])
        # The ends sit on the joints up to the difference between this frame's bone length and the median.
        slack = abs(length - 2 * half) / 2 + 1e-9
        assert np.linalg.norm(d.geom_xpos[g] - axis * half - joints[p]) <= slack + 1e-9
        assert np.linalg.norm(d.geom_xpos[g] + axis * half - joints[c]) <= slack + 1e-9
    hand = scene.human_geom_ids[scene.n_bones + 1]
    np.testing.assert_allclose(d.geom_xpos[hand], joints[LAYOUT.index("right_hand")], atol=1e-9)


def test_world_offset_puts_the_floor_at_zero() -> None:
    T = 6
    joints = np.zeros((T, 2, LAYOUT.n_joints, 3))
    joints[..., 2] = 1.0
    joints[:, :, LAYOUT.index("left_foot"), 2] = 0.5
    joints[:, 0, :, 0] = 2.0
    joints[:, 1, :, 0] = 3.0
    inter = Interaction("shake_hands", 10.0, joints, LAYOUT.joint_names, ("a", "b"))
    np.testing.assert_allclose(world_offset(inter), [-2.5, 0.0, -(0.5 - FOOT_CLEARANCE)], atol=1e-12)


def test_a_robot_hand_touches_a_human_hand(scene: Scene) -> None:
    m = scene.model
    d = posed(scene)
    # Put the human's right hand sphere right on the robot's right hand.
    hand_geom = np.flatnonzero(scene.hand_geom[1])[0]
    target = d.geom_xpos[hand_geom] + (0.02, 0.0, 0.0)
    sphere = scene.n_bones + 1
    pos = np.array(d.mocap_pos[scene.human_mocap])
    pos[sphere] = target
    quat = np.array(d.mocap_quat[scene.human_mocap])
    d.mocap_pos[scene.human_mocap] = pos
    pose_compliant(scene, d, pos, quat)
    mujoco.mj_forward(m, d)
    sphere_geom = scene.human_geom_ids[sphere]
    hits = [i for i in range(d.ncon)
            if {d.contact.geom1[i], d.contact.geom2[i]} & {sphere_geom} and (scene.hand_geom[1][d.contact.geom1[i]] or scene.hand_geom[1][d.contact.geom2[i]])]
    assert hits
    force = np.zeros(6)
    mujoco.mj_contactForce(m, d, hits[0], force)
    assert force[0] > 0.0


def test_collision_bits(scene: Scene) -> None:
    m = scene.model
    h = scene.human_geom_ids
    assert (m.geom_contype[h] == 2).all() and (m.geom_conaffinity[h] == 0).all()  # not with itself or the floor
    r = np.flatnonzero(scene.robot_geom & (m.geom_contype != 0))
    assert (m.geom_conaffinity[r] & 2).all()  # the robot feels the human
    # Per-body filters agree with the geoms' bits (MuJoCo's broadphase uses both).
    for g in r:
        b = m.geom_bodyid[g]
        assert m.body_conaffinity[b] & m.geom_conaffinity[g] == m.geom_conaffinity[g]


def test_servos_hold_their_targets_and_are_critically_damped(scene: Scene) -> None:
    m = scene.model
    d = posed(scene)
    target = d.qpos.copy()
    d.ctrl[scene.act_ids] = scene.ctrl_for(target)
    mujoco.mj_forward(m, d)
    np.testing.assert_allclose(d.actuator_force[scene.act_ids], 0.0, atol=1e-6)
    # Displace one joint: the servo pushes back with kp·δ, kp = I·ω² (I from the mass matrix).
    a = 0
    qa, va = scene.act_qadr[a], scene.act_vadr[a]
    d.qpos[qa] -= 0.01
    mujoco.mj_forward(m, d)
    M = np.zeros((m.nv, m.nv))
    d2 = posed(scene)
    mujoco.mj_fullM(m, d2, M)
    inertia = M[va, va] + m.dof_armature[va]
    lo, hi = m.actuator_forcerange[scene.act_ids[a]]
    expected = np.clip(inertia * 25.0**2 * 0.01, lo, hi)
    np.testing.assert_allclose(d.actuator_force[scene.act_ids[a]], expected, rtol=1e-6)
    np.testing.assert_allclose(-m.actuator_biasprm[scene.act_ids[a], 2], 2 * inertia * 25.0, rtol=1e-9)


def test_human_body_groups_for_every_layout() -> None:
    for name in ("kinect_v2", "sbu15", "zed_body34", "nuitrack10", "key5"):
        body = human_body(get_layout(name))
        B = body.n_bones
        assert body.groups["body"] == tuple(range(B + 2))
        assert B in body.groups["left_hand"] and B + 1 in body.groups["right_hand"]
        assert set(body.groups["hands"]) <= set(body.groups["wrists"])
        assert set(body.compliant) >= set(body.groups["wrists"])


def test_simulators_share_nothing(data) -> None:
    inter = data.of_label("shake_hands")[0]
    a, b = (Simulator("ours", "shake_hands", SimConfig.harness()) for _ in range(2))
    a.reset(inter)
    b.reset(inter)
    assert a.scene.model is not b.scene.model and a.data is not b.data
    before = b.data.qpos.copy()
    for _ in range(3):
        a.step(a.robot_key_frames() + (0.05, 0.0, 0.0))
    np.testing.assert_array_equal(b.data.qpos, before)
    assert b.frame == 0 and a.frame == 3


def test_simulator_api_contract(data) -> None:
    inter = data.of_label("hand_over")[0]
    sim = Simulator("ours", "hand_over", SimConfig.harness())
    with pytest.raises(SimulationError, match="reset"):
        sim.step(np.zeros((5, 3)))
    sim.reset(inter)
    human = sim.human_key_joints()
    assert human.shape == (5, 3) and human[0, 0] > 0.3  # the partner stands ahead, along +x
    assert sim.object_position() is not None
    q, qd = sim.joint_state()
    assert q.shape == qd.shape == (len(sim.scene.robot_joint_names) - 1,)
    keys = sim.robot_key_frames()
    targets = keys.copy()
    targets[3:] = np.nan  # unknown ankles keep their home offsets from the base
    res = sim.step(targets)
    assert res.frame == 1 and np.isfinite(res.targets).all() and res.ik_error.shape == (5,)
    with pytest.raises(SimulationError, match=r"shape \(5, 3\)"):
        sim.step(np.zeros((4, 3)))
    while not sim.done:
        sim.step(sim.robot_key_frames())
    with pytest.raises(SimulationError, match="has ended"):
        sim.step(keys)


def test_causal_placement_ignores_agent1_future(data) -> None:
    """With placement_frames, the robot's stance and scale come from agent 1's first frames only."""
    inter = data.of_label("shake_hands")[0]
    joints = inter.joints.copy()
    joints[12:, 1, :, :2] += 0.6  # agent 1's future moves far away
    moved = inter.replace(joints=joints)
    sim = Simulator("ours", "shake_hands", SimConfig.harness())
    frames = {}
    for name, x, n in (("orig", inter, 10), ("moved", moved, 10), ("orig_all", inter, None), ("moved_all", moved, None)):
        sim.reset(x, placement_frames=n)
        frames[name] = (sim.frame_R.origin.copy(), sim.scaler.k, sim.offset.copy())
    for a, b in zip(frames["orig"], frames["moved"], strict=True):
        np.testing.assert_allclose(a, b, atol=1e-12)
    assert not np.allclose(frames["orig_all"][0], frames["moved_all"][0], atol=1e-3)  # the whole track does move it
    with pytest.raises(SimulationError, match="placement_frames"):
        sim.reset(inter, placement_frames=0)


def test_run_episode_places_a_causal_source_from_its_frames(data, monkeypatch: pytest.MonkeyPatch) -> None:
    from socialaff_sim.retarget.model_source import ModelSource
    from socialaff_sim.inference.synthesis import SynthesisConfig
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode

    class Causal(GroundTruthSource):
        placement_frames = 7

    inter = data.of_label("shake_hands")[0]
    sim = Simulator("ours", "shake_hands", SimConfig.harness())
    seen: list[int | None] = []
    reset = Simulator.reset

    def spy(self, interaction, initial_targets=None, *, placement_frames=None):  # noqa: ANN001, ANN202
        seen.append(placement_frames)
        return reset(self, interaction, initial_targets, placement_frames=placement_frames)

    monkeypatch.setattr(Simulator, "reset", spy)
    run_episode(sim, Causal(), inter)
    run_episode(sim, GroundTruthSource(), inter)
    assert seen == [7, None]
    assert ModelSource(None, config=SynthesisConfig(n_observed=12)).placement_frames == 12  # type: ignore[arg-type]
