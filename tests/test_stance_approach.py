"""The steadied base's smoothing lifted as a hand closes in (StanceConfig.approach_near / approach_far, off by
default): the approach share against a brute-force nearest pair, the filter against its recursion written out,
the object counted only while not gripped, the settings' checks, and the default left bitwise as it was."""

from __future__ import annotations

import itertools

import mujoco
import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.hand_task import reach_points
from socialaff_sim.sim.scene import build_scene
from socialaff_sim.sim.stance import StanceConfig, StanceControl
from socialaff_sim.sim.tasks import load_task

LAYOUT = get_layout("kinect_v2")


@pytest.fixture(scope="module")
def scene():
    return build_scene(load_robot("ours"), LAYOUT, load_task("hand_over").object.spec, harness_time_constant=0.02)


def _data(scene) -> mujoco.MjData:
    d = mujoco.MjData(scene.model)
    d.qpos[scene.robot_qadr] = scene.home_qpos
    mujoco.mj_forward(scene.model, d)
    return d


def _share_brute(wrists: np.ndarray, points: np.ndarray, near: float, far: float) -> float:
    best = min(float(np.sqrt(((w - p) ** 2).sum())) for w, p in itertools.product(wrists, points))
    return 1.0 if best <= near else 0.0 if best >= far else (far - best) / (far - near)


def test_the_share_is_one_near_zero_far_and_linear_between_by_the_nearest_pair(scene, rng) -> None:
    ctl = StanceControl(scene, StanceConfig(approach_near=0.3, approach_far=0.5))
    points = rng.normal(size=(3, 3))
    u = np.array([0.6, 0.0, 0.8])
    for gap, want in ((0.1, 1.0), (0.35, 0.75), (0.45, 0.25), (0.7, 0.0)):
        # the right wrist at ``gap`` from the second point, the left far from everything
        wrists = np.array([points[1] + 5.0 * u, points[1] + gap * u])
        assert ctl.approach(wrists, points) == pytest.approx(want, abs=1e-9)
        assert ctl.approach(wrists, points) == pytest.approx(_share_brute(wrists, points, 0.3, 0.5), abs=1e-12)
    for _ in range(20):
        wrists = points[rng.integers(3)] + rng.uniform(-0.4, 0.4, size=(2, 3))
        assert ctl.approach(wrists, points) == pytest.approx(_share_brute(wrists, points, 0.3, 0.5), abs=1e-12)
    # Off (the default): no share, wherever the hands are.
    assert StanceControl(scene).approach(points[:2], points) == 0.0


def test_the_base_follows_the_plan_as_the_share_rises(scene, rng) -> None:
    a = 0.8
    ctl = StanceControl(scene, StanceConfig(base_smoothing=a, approach_far=0.5))
    raw = rng.normal(size=(6, 3))
    shares = [0.0, 0.0, 0.5, 1.0, 0.25, 0.0]
    got = [ctl.steady_base(b, True, s) for b, s in zip(raw, shares, strict=True)]
    want = [raw[0]]
    for b, s in zip(raw[1:], shares[1:], strict=True):
        ae = a * (1.0 - s)
        want.append(ae * want[-1] + (1.0 - ae) * b)
    np.testing.assert_allclose(got, want, atol=1e-12)
    np.testing.assert_array_equal(got[3], raw[3])  # share 1: the plan's base as retargeted
    assert np.linalg.norm(got[1] - raw[1]) > 1e-3  # share 0: still steadied


def test_a_frame_lifts_the_smoothing_only_for_a_wrist_near_the_persons_hand(scene, rng) -> None:
    d = _data(scene)
    hand = d.geom_xpos[np.asarray(scene.human_geom_ids)[-1]].copy()
    centre = np.zeros(2)
    b0, b1 = np.array([0.0, 0.0, 0.6]), np.array([0.1, 0.0, 0.6])
    up = np.array([0.0, 0.0, 1.0])

    def second_base(wrist_gap: float, far: float | None) -> np.ndarray:
        ctl = StanceControl(scene, StanceConfig(base_smoothing=0.8, approach_near=0.3, approach_far=far, release=False))
        wrists = np.array([hand + 3.0 * up, hand + wrist_gap * up])
        ctl.frame(d, b0, True, centre, 0.0, wrists)
        return ctl.frame(d, b1, True, centre, 0.0, wrists)[0]

    np.testing.assert_allclose(second_base(0.1, 0.5), b1, atol=1e-12)  # in contact approach: the plan's lean
    far_from_all = min(np.linalg.norm(p - (hand + 2.0 * up)) for p in reach_points(scene, d))
    assert far_from_all > 0.5
    np.testing.assert_allclose(second_base(2.0, 0.5), 0.8 * b0 + 0.2 * b1, atol=1e-12)  # elsewhere: steadied
    np.testing.assert_allclose(second_base(0.1, None), 0.8 * b0 + 0.2 * b1, atol=1e-12)  # the option off


def test_the_object_counts_until_the_robot_grips_it(scene) -> None:
    d = _data(scene)
    pts = reach_points(scene, d)
    hands = d.geom_xpos[np.asarray(scene.human_geom_ids)[-2:]]
    assert len(pts) == 3
    np.testing.assert_array_equal(pts[:2], hands)
    np.testing.assert_array_equal(pts[2], d.geom_xpos[scene.object_geom])
    d.eq_active[np.asarray(scene.grip_eq)[0]] = 1
    np.testing.assert_array_equal(reach_points(scene, d), hands)


@pytest.mark.parametrize("near,far", [(0.5, 0.5), (0.6, 0.5), (-0.1, 0.5)])
def test_the_settings_are_checked(near: float, far: float) -> None:
    with pytest.raises(ConfigError, match="approach_near"):
        StanceConfig(approach_near=near, approach_far=far)
    StanceConfig(approach_near=near, approach_far=None)  # off: the distances are not used
