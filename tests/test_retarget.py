"""Robot mappings, body measurements and the human-to-robot scaling of key joints."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from socialaff_sim.data.interaction import Interaction
from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.errors import ConfigError
from socialaff_sim.resources import asset_path
from socialaff_sim.retarget.robot import available_robots, load_robot
from socialaff_sim.retarget.scaling import (
    LOOKAHEAD_POINTS,
    BodyMeasurements,
    KeyJointScaler,
    ScalingConfig,
    measure_human,
    measure_robot,
    object_anchors,
    smoothstep,
)
from socialaff_sim.sim.scene import build_scene

LAYOUT = get_layout("kinect_v2")


def standing(T: int = 4, height: float = 1.0, x: float = 0.0, facing: float = 1.0, arm=(0.3, 0.25)) -> np.ndarray:
    """(T, 25, 3) a Kinect v2 skeleton standing at x, facing +x (facing=1) or -x (-1), arms hanging."""
    n = LAYOUT.joint_names
    j = np.zeros((len(n), 3))
    y = lambda side: (0.18 if side == "left" else -0.18) * facing  # noqa: E731
    hip = lambda side: (0.09 if side == "left" else -0.09) * facing  # noqa: E731
    j[n.index("spine_base")] = (x, 0, height)
    j[n.index("spine_mid")] = (x, 0, height + 0.25)
    j[n.index("spine_shoulder")] = (x, 0, height + 0.45)
    j[n.index("neck")] = (x, 0, height + 0.52)
    j[n.index("head")] = (x, 0, height + 0.65)
    for s in ("left", "right"):
        sh = np.array([x, y(s), height + 0.45])
        j[n.index(f"{s}_shoulder")] = sh
        j[n.index(f"{s}_elbow")] = sh - (0, 0, arm[0])
        j[n.index(f"{s}_wrist")] = sh - (0, 0, arm[0] + arm[1])
        j[n.index(f"{s}_hand")] = sh - (0, 0, arm[0] + arm[1] + 0.08)
        j[n.index(f"{s}_hand_tip")] = sh - (0, 0, arm[0] + arm[1] + 0.15)
        j[n.index(f"{s}_thumb")] = sh - (-0.03 * facing, 0, arm[0] + arm[1] + 0.1)
        hp = np.array([x, hip(s), height - 0.05])
        j[n.index(f"{s}_hip")] = hp
        j[n.index(f"{s}_knee")] = hp - (0, 0, 0.45)
        j[n.index(f"{s}_ankle")] = hp - (0, 0, 0.88)
        j[n.index(f"{s}_foot")] = hp - (-0.1 * facing, 0, 0.93)
    return np.repeat(j[None], T, axis=0)


def pair(distance: float = 1.2, height1: float = 1.0, arm1=(0.3, 0.25)) -> Interaction:
    a0 = standing(height=1.0, x=0.0, facing=1.0)
    a1 = standing(height=height1, x=distance, facing=-1.0, arm=arm1)
    return Interaction("shake_hands", 10.0, np.stack([a0, a1], axis=1), LAYOUT.joint_names, ("a", "b"))


def test_shipped_robots_and_mapping_contents() -> None:
    assert {"cmu", "ours"} <= set(available_robots())
    ours = load_robot("ours")
    assert ours.mjcf_path == asset_path("robots/ours.xml").resolve()
    assert [f.name for f in ours.frames] == ["base", "left_wrist", "right_wrist", "left_ankle", "right_ankle"]
    cmu = load_robot("cmu")
    assert cmu.builtin == "dm_control.cmu_humanoid" and cmu.mjcf_path is None
    assert cmu.build_mjcf().find("body", "lwrist") is not None


def test_unknown_robot_lists_choices() -> None:
    with pytest.raises(ConfigError, match=r"unknown robot 'r2d2'; shipped robots: 'cmu', 'ours', 'unitree_g1' or 'unitree_h1'"):
        load_robot("r2d2")


def _mapping(tmp_path: Path, replace: tuple[str, str] | None = None) -> Path:
    text = asset_path("robots/ours.toml").read_text().replace('mjcf = "ours.xml"', f'mjcf = "{asset_path("robots/ours.xml")}"')
    if replace:
        text = text.replace(*replace)
    path = tmp_path / "mine.toml"
    path.write_text(text)
    return path


def test_a_mapping_file_anywhere_works(tmp_path: Path) -> None:
    spec = load_robot(_mapping(tmp_path))
    assert spec.name == "ours" and spec.posture_keyframe == "home"


@pytest.mark.parametrize(
    ("old", "new", "pattern"),
    [
        ('base = "site:base"', 'base = "joint:base"', r"key 'frames\.base': expected 'site:NAME', 'body:NAME' or \{ body"),
        ('left_wrist = "site:left_wrist"', "", r"key 'frames\.left_wrist': expected a value"),
        ("max_joint_velocity = 20.0", "max_joint_velocity = -1.0", r"limits\.max_joint_velocity'.*\[0\.001, 1000\.0\]"),
        ('keyframe = "home"', 'keyframe = "rest"', r"posture\.keyframe 'rest' is not in the model; keyframes: 'home'"),
        ('base = "site:base"', 'base = "site:pelvis_site"', r"frame 'site:pelvis_site' is not in the robot model; sites present: 'base'"),
        ('name = "ours"', 'name = "ours"\nphysics = "floating"', r"key 'physics'.*'floating'; valid choices: 'harness' or 'standing'"),
    ],
)
def test_mapping_errors(tmp_path: Path, old: str, new: str, pattern: str) -> None:
    path = _mapping(tmp_path, (old, new))
    with pytest.raises(ConfigError, match=pattern) as info:
        spec = load_robot(path)
        spec.build_mjcf()
    assert str(path) in str(info.value)


def test_robot_measurements_match_the_model_by_hand() -> None:
    # ours.xml: upper arm 0.44 + forearm 0.40; thigh 0.26 + shin 0.24; shoulders 0.235 out, 0.40 above the torso joint.
    scene = build_scene(load_robot("ours"), LAYOUT, physics=False)
    m = measure_robot(scene.model, scene.home_qpos, scene.frame_kinds, scene.frame_ids, scene.limb_body_ids)
    np.testing.assert_allclose(m.arm, 0.84, atol=1e-9)
    np.testing.assert_allclose(m.leg, 0.50, atol=1e-9)
    np.testing.assert_allclose(m.shoulders[:, 1], [0.235, -0.235], atol=1e-9)
    np.testing.assert_allclose(m.shoulders[:, 2], 0.08 + 0.40, atol=1e-9)  # torso joint + shoulder height
    # Standing on the floor: base height = 0.62 minus how far the feet sink below their soles.
    np.testing.assert_allclose(m.base_height, 0.62 - (0.08 - 0.08), atol=3e-3)


def test_human_measurements() -> None:
    h = measure_human(pair(), 1, np.zeros(3))
    np.testing.assert_allclose(h.arm, 0.55, atol=1e-9)
    np.testing.assert_allclose(h.leg, 0.88, atol=1e-9)
    np.testing.assert_allclose(h.base_height, 1.0, atol=1e-9)
    # Agent 1 faces -x, toward agent 0: its heading frame's +y (left) is world -y.
    np.testing.assert_allclose(h.shoulders, [[0.0, 0.18, 0.45], [0.0, -0.18, 0.45]], atol=1e-9)


def test_smoothstep() -> None:
    x = np.linspace(-0.5, 1.5, 21)
    y = smoothstep(x)
    ref = np.where(x < 0, 0.0, np.where(x > 1, 1.0, 3 * x**2 - 2 * x**3))
    np.testing.assert_allclose(y, ref, atol=1e-12)


ROBOT = BodyMeasurements(arm=0.4, leg=0.5, base_height=0.6, shoulders=np.array([[0, 0.2, 0.3], [0, -0.2, 0.3]]),
                         hips=np.array([[0, 0.1, -0.05], [0, -0.1, -0.05]]))


def test_scaling_closed_form_far_from_the_partner() -> None:
    inter = pair(distance=3.0)
    scaler = KeyJointScaler(ROBOT)
    frame = scaler.reset(inter, np.zeros(3))
    # Placement: k = (arm0 + arm_r) / (arm0 + arm1) of the way from agent 0.
    k = (0.55 + 0.4) / (0.55 + 0.55)
    np.testing.assert_allclose(frame.origin, [3.0 * k, 0, 0], atol=1e-9)
    np.testing.assert_allclose(frame.yaw, np.pi, atol=1e-9)
    keys = inter.key_joints()[0, 1].copy()
    keys[1] += (-0.2, 0.0, 0.3)  # left wrist raised toward the partner, still far from it
    out = scaler(keys, inter.joints[0, 0])
    np.testing.assert_allclose(scaler.contact_weights(keys, inter.joints[0, 0]), [0.0, 0.0], atol=1e-12)
    s_arm, s_leg = 0.4 / 0.55, 0.5 / 0.88
    np.testing.assert_allclose(out[0], [0, 0, 0.6], atol=1e-9)
    # In the robot frame x points at the partner: the raise toward it is +0.2 forward.
    local_wrist = np.array([0.2, 0.18, 1.45 - 0.55 + 0.3]) - np.array([0, 0, 1.0])
    expect = out[0] + ROBOT.shoulders[0] + s_arm * (local_wrist - np.array([0, 0.18, 0.45]))
    np.testing.assert_allclose(out[1], expect, atol=1e-9)
    expect_ankle = out[0] + ROBOT.hips[1] + s_leg * (np.array([0, -0.09, 0.07 - 1.0]) - np.array([0, -0.09, -0.05]))
    np.testing.assert_allclose(out[4], expect_ankle, atol=1e-9)


def test_contact_preservation_uses_the_recording_near_the_partner() -> None:
    inter = pair(distance=1.0)
    # No push at all: δ = 0 and hands of equal length (the human's wrist→hand is 0.08 m in `standing`).
    scaler = KeyJointScaler(dataclasses.replace(ROBOT, hand=0.08), ScalingConfig(contact_push=0.0))
    scaler.reset(inter, np.zeros(3))
    np.testing.assert_allclose(scaler.push, 0.0, atol=1e-12)
    partner = inter.joints[0, 0]
    keys = inter.key_joints()[0, 1].copy()
    hand0 = partner[LAYOUT.index("right_hand")]
    keys[2] = hand0 + (0.05, 0.0, 0.0)  # agent 1's right wrist 5 cm from agent 0's hand
    out = scaler(keys, partner)
    np.testing.assert_allclose(scaler.frame.to_world(out[2]), keys[2], atol=1e-9)
    assert scaler.contact_weights(keys, partner)[1] == 1.0
    # With the push, the wrist goes δ + hand_h − hand_r further, straight toward the partner's nearest joint:
    # the middle of the robot's hand (here 0 m past its wrist) lands δ past the middle of agent 1's (0.08 m).
    pushed = KeyJointScaler(ROBOT)
    pushed.reset(inter, np.zeros(3))
    np.testing.assert_allclose(pushed.human.hand, 0.08, atol=1e-9)
    np.testing.assert_allclose(pushed.push, 0.05 + 0.08 - 0.0, atol=1e-12)
    assert pushed.config.contact_push == pushed.push  # what the config reports is what is applied
    moved = pushed.frame.to_world(pushed(keys, partner)[2])
    nearest = min(partner, key=lambda p: float(np.linalg.norm(p - keys[2])))
    u = (nearest - keys[2]) / np.linalg.norm(nearest - keys[2])
    np.testing.assert_allclose(moved, keys[2] + 0.13 * u, atol=1e-9)


def test_object_anchors_follow_a_ballistic_path() -> None:
    fps = 12.0
    t = np.arange(6) / fps
    p0, v0 = np.array([0.0, 1.0, 1.5]), np.array([3.0, -0.5, 2.0])
    track = p0 + v0 * t[:, None] - 0.5 * 9.81 * t[:, None] ** 2 * np.array([0.0, 0.0, 1.0])
    anchors = object_anchors(track, 3, fps, lookahead=0.25)
    assert anchors.shape == (1 + LOOKAHEAD_POINTS, 3)
    np.testing.assert_allclose(anchors[0], track[3], atol=1e-12)
    # From the frame-to-frame velocity (exact for this track up to the half-step gravity term).
    v = (track[3] - track[2]) * fps
    s = np.linspace(0.25 / LOOKAHEAD_POINTS, 0.25, LOOKAHEAD_POINTS)
    expect = track[3] + v * s[:, None] - 0.5 * 9.81 * s[:, None] ** 2 * np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(anchors[1:], expect, atol=1e-12)
    np.testing.assert_allclose(object_anchors(track, 0, fps, 0.25), track[:1], atol=0)  # no previous frame
    np.testing.assert_allclose(object_anchors(track, 4, fps, 0.0), track[4:5], atol=0)  # no lookahead


def touching(meet: np.ndarray) -> Interaction:
    """:func:`pair` 1.2 m apart, agent 1's right wrist meeting agent 0's right hand about ``meet`` (3,) in every frame."""
    inter = pair(distance=1.2)
    joints = np.array(inter.joints)
    n = LAYOUT.joint_names
    joints[:, 0, n.index("right_hand")] = meet + (-0.05, 0.0, 0.0)
    joints[:, 1, n.index("right_wrist")] = meet + (0.05, 0.0, 0.0)
    return inter.replace(joints=joints)


def test_contact_placement_keeps_the_contact_within_reach() -> None:
    # Agent 1 (1.2 m away) touches agent 0's right hand with its right wrist in every frame.
    inter = touching(np.array([0.6, -0.05, 1.0]))
    joints, n = inter.joints, LAYOUT.joint_names
    scaler = KeyJointScaler(ROBOT, ScalingConfig(max_extension=0.9, body_clearance=0.0))
    scaler.reset(inter, np.zeros(3))
    # Independent check: at the chosen k the robot's right shoulder is exactly e·arm_r from the wrist,
    # e = agent 1's own extension there (capped at 0.9), and no farther k would do.
    wrist = joints[0, 1, n.index("right_wrist")]
    e = min(np.linalg.norm(wrist - joints[0, 1, n.index("right_shoulder")]) / scaler.human.arm, 0.9)

    def shoulder_gap(k: float) -> float:
        base = np.array([1.2 * k, 0.0, ROBOT.base_height + scaler.s_leg * (1.0 - scaler.human.base_height)])
        shoulder = base + scaler.frame.rotation @ ROBOT.shoulders[1]
        return float(np.linalg.norm(wrist - shoulder))

    assert scaler.contact_k is not None
    np.testing.assert_allclose(scaler.k, scaler.contact_k, atol=1e-12)
    np.testing.assert_allclose(shoulder_gap(scaler.k), e * ROBOT.arm, atol=1e-9)
    assert shoulder_gap(scaler.k + 0.01) > e * ROBOT.arm
    # Without contact samples the arm ratio places it.
    far = KeyJointScaler(ROBOT, ScalingConfig(contact_radius=0.01))
    far.reset(inter, np.zeros(3))
    assert far.contact_k is None
    np.testing.assert_allclose(far.k, (0.55 + ROBOT.arm) / (0.55 + far.human.arm), atol=1e-9)


def test_online_placement_moves_in_on_a_contact_of_the_given_keys() -> None:
    # Placed from a recording without a contact (arms hanging), the robot starts at the arm ratio; a causal
    # source then reaches agent 0's right hand with agent 1's right wrist.
    inter = pair(distance=1.2)
    n = LAYOUT.joint_names
    meet = np.array([0.6, -0.05, 1.0])
    partner = np.array(inter.joints[0, 0])
    partner[n.index("right_hand")] = meet + (-0.05, 0.0, 0.0)
    keys = np.array(inter.key_joints()[0, 1])
    keys[2] = meet + (0.05, 0.0, 0.0)  # right wrist
    far_keys = np.array(inter.key_joints()[0, 1])
    cfg = ScalingConfig(max_extension=0.9, body_clearance=0.0, placement_speed=0.6)
    scaler = KeyJointScaler(ROBOT, cfg)
    scaler.reset(inter, np.zeros(3))
    k0 = (0.55 + ROBOT.arm) / (0.55 + scaler.human.arm)
    assert scaler.contact_k is None
    np.testing.assert_allclose(scaler.k, k0, atol=1e-9)
    scaler(far_keys, partner)  # no wrist near the partner: the robot stays
    np.testing.assert_allclose(scaler.k, k0, atol=1e-12)
    # Independent check of where it ends: the robot's right shoulder exactly e·arm_r from the wrist there.
    shoulder_h = keys[0] + np.array([0.0, 0.18, 0.45])  # agent 1 faces -x: its right shoulder is at +y
    e = min(np.linalg.norm(keys[2] - shoulder_h) / scaler.human.arm, 0.9)

    def shoulder_gap(k: float) -> float:
        base = np.array([1.2 * k, 0.0, ROBOT.base_height + scaler.s_leg * (1.0 - scaler.human.base_height)])
        return float(np.linalg.norm(keys[2] - (base + scaler.frame.rotation @ ROBOT.shoulders[1])))

    ks = [scaler.k]
    for _ in range(40):
        scaler(keys, partner)
        ks.append(scaler.k)
    steps = -np.diff(ks)
    # At most placement_speed / fps metres of base motion a frame (1.2 m from the partner), never back out.
    assert (steps >= 0).all() and steps.max() <= 0.6 / 10.0 / 1.2 + 1e-12 and steps[0] > 0
    np.testing.assert_allclose(shoulder_gap(scaler.k), e * ROBOT.arm, atol=1e-9)
    assert scaler.k < k0
    final = scaler.k
    for _ in range(3):
        scaler(far_keys, partner)
    assert scaler.k == final  # a wrist moving away does not move the robot back
    # Off: the robot keeps its first placement.
    fixed = KeyJointScaler(ROBOT, dataclasses.replace(cfg, online_placement=False))
    fixed.reset(inter, np.zeros(3))
    for _ in range(5):
        fixed(keys, partner)
    np.testing.assert_allclose(fixed.k, k0, atol=1e-9)
    with pytest.raises(ConfigError, match=r"placement_speed: expected a speed ≥ 0 m/s, found -1"):
        ScalingConfig(placement_speed=-1.0)


def test_body_clearance_moves_the_robot_back() -> None:
    inter = pair(distance=0.5)
    robot = dataclasses.replace(ROBOT, trunk_radius=0.3)
    scaler = KeyJointScaler(robot, ScalingConfig(contact_placement=False, body_clearance=0.1))
    scaler.reset(inter, np.zeros(3))
    # Brute force: the smallest k on a 0.01 grid from the arm ratio at which the robot's axis is at least
    # 0.3 + 0.1 from every trunk, head and leg joint of agent 0 (horizontally).
    k0 = (0.55 + 0.4) / (0.55 + 0.55)
    n = LAYOUT.joint_names
    body = np.array([inter.joints[0, 0, j, :2] for j, name in enumerate(n)
                     if not any(p in name for p in ("elbow", "wrist", "hand", "thumb", "tip"))])
    ks = np.arange(k0, 2.0 + 1e-9, 0.01)
    clear = [np.linalg.norm(body - np.array([0.5 * k, 0.0]), axis=1).min() >= 0.4 for k in ks]
    np.testing.assert_allclose(scaler.k, ks[int(np.argmax(clear))], atol=1e-9)
    assert scaler.k > k0


def test_a_contact_wrist_stays_clear_of_the_robots_trunk() -> None:
    # Agent 0 reaches in to 10 cm in front of agent 1 (1.2 m away), where agent 1's right wrist meets its
    # hand in every frame: a broad robot placed by reach alone would meet it inside its own trunk.
    inter = touching(np.array([1.05, -0.05, 1.0]))
    robot = dataclasses.replace(ROBOT, trunk_radius=0.3)
    scaler = KeyJointScaler(robot, ScalingConfig(body_clearance=0.0, wrist_clearance=0.05))
    scaler.reset(inter, np.zeros(3))
    # Closed form: the base on the line at 1.2·k, the wrist at (1.1, −0.05): (1.2k − 1.1)² + 0.05² = 0.35².
    k = (1.1 + np.sqrt(0.35**2 - 0.05**2)) / 1.2
    np.testing.assert_allclose(scaler.k, k, atol=1e-9)
    np.testing.assert_allclose(scaler.trunk_k, k, atol=1e-9)
    # It is the reach's upper bound that gives way: by reach alone the robot would stand closer.
    assert scaler.contact_k is not None and scaler.contact_k < k - 0.05
    slim = KeyJointScaler(ROBOT, ScalingConfig(body_clearance=0.0))
    slim.reset(inter, np.zeros(3))
    assert slim.trunk_k is None
    np.testing.assert_allclose(slim.k, scaler.contact_k, atol=1e-12)
    # Without a contact sample in reach the bound still holds, over the arm ratio.
    short = KeyJointScaler(dataclasses.replace(robot, arm=0.05), ScalingConfig(body_clearance=0.0))
    short.reset(inter, np.zeros(3))
    assert short.contact_k is None and short.trunk_k is not None
    k0 = (0.55 + 0.05) / (0.55 + short.human.arm)
    np.testing.assert_allclose(short.k, max(k0, short.trunk_k), atol=1e-12)
    # No clearance asked: the trunk's radius alone.
    flush = KeyJointScaler(robot, ScalingConfig(body_clearance=0.0, wrist_clearance=0.0))
    flush.reset(inter, np.zeros(3))
    np.testing.assert_allclose(flush.k, (1.1 + np.sqrt(0.3**2 - 0.05**2)) / 1.2, atol=1e-9)
    with pytest.raises(ConfigError, match=r"wrist_clearance: expected a distance ≥ 0 m, found -0.1"):
        ScalingConfig(wrist_clearance=-0.1)
