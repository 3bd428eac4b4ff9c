"""The robot's feet stay apart (``IKConfig.leg_clearance``): ankle targets closer together than the feet are wide
(a recording whose person's ankles are close or crossed) put the feet side by side, not inside each other, in the
IK and in physics from the reset on; without the limit they interpenetrate (the old behaviour, which failed
recorded handovers on their first step). A forearm found inside the body is pushed out (``IKConfig.push_self``),
held without it. Distances are checked with MuJoCo's ``mj_geomDistance`` on the geoms themselves, not with the
limit's own rows."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from socialaff_sim.data.interaction import Interaction
from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.retarget.collision import collision_pairs
from socialaff_sim.retarget.ik import IKConfig, RobotIK
from socialaff_sim.retarget.ik_pairs import GeomGroups
from socialaff_sim.retarget.kinematic_tree import subtree_mask
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.stage import compile_scenes, key_frames_at

ROBOT = load_robot("ours")
CLEARANCE = IKConfig().leg_clearance


def _leg_distance(model: mujoco.MjModel, data: mujoco.MjData, legs: tuple[np.ndarray, np.ndarray]) -> float:
    """Smallest signed distance (m) between a left-leg and a right-leg geom (negative: interpenetrating)."""
    return min(mujoco.mj_geomDistance(model, data, int(a), int(b), 1.0, None) for a in legs[0] for b in legs[1])


def _ik(config: IKConfig) -> tuple[RobotIK, np.ndarray]:
    """Stubby's IK (person far away) and its home key frames (5, 3), world frame."""
    _, ik_scene, ik_model, _ = compile_scenes(ROBOT, get_layout("kinect_v2"), None, timestep=0.004,
                                             servo_bandwidth=25.0, hand_force=None)
    ik = RobotIK(ik_model, config)
    n = len(ik_scene.human_mocap)
    ik.set_human(np.tile([0.0, 0.0, -20.0], (n, 1)) + np.arange(n)[:, None] * [0.5, 0.0, 0.0],
                 np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)))
    ik.reset(ik_scene.home_qpos)
    return ik, key_frames_at(ik_scene, ik_scene.home_qpos)


@pytest.mark.parametrize("clearance", [CLEARANCE, None])
def test_ik_keeps_the_feet_apart_only_with_the_limit(clearance: float | None) -> None:
    ik, home = _ik(dataclasses.replace(IKConfig(), leg_clearance=clearance))
    m, d = ik.spec.model, ik.configuration.data
    legs = ik._groups.legs  # the groups the limit was built from
    assert len(legs[0]) and len(legs[1])
    targets = home.copy()
    targets[3:5, 1] = 0.5 * (home[3, 1] + home[4, 1])  # both ankles on the centre line: the feet would overlap
    for _ in range(10):
        ik.solve(targets, 0.0, dt=1.0 / 30)
    gap = _leg_distance(m, d, legs)
    if clearance is None:
        assert gap < -0.03  # the old behaviour: the feet settle inside each other
    else:
        assert gap >= clearance - 0.003  # the limit's own slack (``collision_slack``)
        # ... and the feet still go as far toward the targets as the limit lets them.
        width = float(np.linalg.norm(home[3, :2] - home[4, :2]))
        assert np.linalg.norm(ik.frame_positions()[3, :2] - ik.frame_positions()[4, :2]) < width


def test_leg_pairs_are_watched_only_with_the_limit() -> None:
    on, _ = _ik(IKConfig())
    off, _ = _ik(dataclasses.replace(IKConfig(), leg_clearance=None))
    legs = on._groups.legs
    lims = {}
    for name, ik in (("on", on), ("off", off)):
        p = ik.collision_limit.pairs
        left, right = np.isin(p, legs[0]), np.isin(p, legs[1])
        lims[name] = (left[:, 0] & right[:, 1]) | (left[:, 1] & right[:, 0])
    expected = collision_pairs(on.spec.model, legs[0], legs[1])
    assert len(expected)  # the feet, shins and thighs of Stubby can collide
    got = {tuple(sorted(p)) for p in on.collision_limit.pairs[lims["on"]].tolist()}
    assert got == {tuple(sorted(p)) for p in expected.tolist()}
    assert not lims["off"].any()
    rows = on.collision_limit
    k = np.flatnonzero(lims["on"])
    np.testing.assert_allclose(rows.min_distance[k], CLEARANCE)
    assert rows.push[k].all()  # a leg found inside the other is pushed out, unlike an arm against the body
    # The rest of the trunk still has no self pairs: a foot against the pelvis is not watched.
    trunk = on._groups.trunk
    both_trunk = np.isin(on.collision_limit.pairs, trunk).all(axis=1)
    assert not (both_trunk & ~lims["on"]).any()


def test_geom_groups_keep_arms_out_of_the_legs() -> None:
    g = GeomGroups.of(np.array([9]), np.array([1, 2, 3, 4, 5]), (np.array([1]), np.array([2])),
                      (np.array([1]), np.array([2])), (np.array([1, 3, 7]), np.array([4])))
    np.testing.assert_array_equal(g.legs[0], [3])  # 1 is an arm's, 7 is not a collidable robot geom
    np.testing.assert_array_equal(g.legs[1], [4])
    np.testing.assert_array_equal(g.trunk, [3, 4, 5])


def _ankles_together(inter: Interaction) -> Interaction:
    """Agent 1's ankles moved onto their midpoint at every frame (a recording's crossed or touching ankles)."""
    joints = inter.joints.copy()
    names = inter.joint_names
    la, ra = names.index("left_ankle"), names.index("right_ankle")
    mid = 0.5 * (joints[:, 1, la] + joints[:, 1, ra])
    joints[:, 1, la] = mid
    joints[:, 1, ra] = mid
    return inter.replace(joints=joints)


@pytest.fixture(scope="module")
def handover() -> Interaction:
    ds = generate_dataset(0, SyntheticConfig(interactions=("hand_over",), instances_per_interaction=1))
    return _ankles_together(ds.interactions[0].slice(0, 12))


@pytest.mark.parametrize("clearance", [CLEARANCE, None])
def test_feet_do_not_interpenetrate_at_reset_and_step_one(handover: Interaction, clearance: float | None) -> None:
    config = SimConfig()
    config = dataclasses.replace(config, ik=dataclasses.replace(config.ik, leg_clearance=clearance))
    sim = Simulator(ROBOT, "hand_over", config)
    sim.reset(handover)
    keys = handover.key_joints()[:, 1]
    sim.settle(sim.retarget(keys[0], frame=0))
    m, d = sim.scene.model, sim.data
    legs = [np.flatnonzero(subtree_mask(m, int(b))[m.geom_bodyid] & sim.scene.robot_geom
                           & ((m.geom_contype != 0) | (m.geom_conaffinity != 0))) for b in sim.scene.limb_body_ids[2:4]]
    at_reset = _leg_distance(m, d, (legs[0], legs[1]))
    sim.step(sim.retarget(keys[1], frame=1))
    at_step = _leg_distance(m, d, (legs[0], legs[1]))
    failed = [f.kind for f in sim.scorer.failures if f.triggered]
    if clearance is None:
        assert min(at_reset, at_step) < -0.02  # the old behaviour: a self-collision beyond the task's 2 cm
        assert "self_collision" in failed
    else:
        assert at_reset >= clearance - 0.003
        assert at_step > -0.002  # physics may let the feet touch, not sink into each other
        assert "self_collision" not in failed


# Stubby's right arm folded across its chest, every joint inside its range: the forearm 1.7 cm inside the
# torso box (found by a grid search over the arm's joints, checked below with mj_geomDistance).
FOLDED = {"right_shoulder_pitch": -0.6, "right_shoulder_roll": 0.0, "right_shoulder_yaw": 1.4, "right_elbow": -2.4}


@pytest.mark.parametrize("push", [True, False])
def test_a_forearm_inside_the_torso_is_pushed_out_only_with_push_self(push: bool) -> None:
    ik, _ = _ik(dataclasses.replace(IKConfig(), push_self=push))
    m, d = ik.spec.model, ik.configuration.data
    q = ik.configuration.q.copy()
    for name, value in FOLDED.items():
        q[m.jnt_qposadr[m.joint(f"robot/{name}").id]] = value
    ik.reset(q)
    forearm, torso = m.geom("robot/right_forearm").id, m.geom("robot/torso").id
    start = mujoco.mj_geomDistance(m, d, forearm, torso, 1.0, None)
    assert -0.02 < start < -0.015
    targets = ik.frame_positions().copy()  # every key frame where it is: only the limit moves the arm
    for _ in range(10):
        ik.solve(targets, 0.0, dt=1.0 / 30)
    end = mujoco.mj_geomDistance(m, d, forearm, torso, 1.0, None)
    if push:
        assert end >= IKConfig().min_distance - 0.003
    else:
        assert end < 0.0  # held inside: the rows only forbid going deeper
