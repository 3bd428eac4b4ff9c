"""The standing base carried back onto the physical feet (``StanceConfig.base_over_feet``, sim/stance.py): the base
target moves back along the heading by how far the plan's feet stand ahead of the physical ones beyond d_f, only
while both feet are planted, and the simulator gives the stance the plan's ankles from before the foot lock."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.scene import Scene
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.stance import StanceConfig, StanceControl


@pytest.fixture(scope="module")
def ours():
    return load_robot("ours")


X = np.array([1.0, 0.0])  # the robot's heading


def test_base_moves_back_by_how_far_the_plans_feet_stand_ahead_beyond_the_band(scene: Scene) -> None:
    ctl = StanceControl(scene, StanceConfig(base_over_feet=0.05))
    base = np.array([0.5, 0.1, 0.6])
    # The plan's feet 20 cm ahead of the physical ones: the base comes back by 15 cm, its height kept.
    np.testing.assert_allclose(ctl.over_feet(base, True, np.array([0.0, 0.0]), np.array([0.2, 0.0]), X),
                               [0.35, 0.1, 0.6], atol=1e-12)
    # Along the heading only: turned by 90 degrees (facing +y), the plan's feet 30 cm ahead and 40 cm to the side.
    y = np.array([0.0, 1.0])
    got = ctl.over_feet(base, True, np.array([0.0, 0.0]), np.array([0.4, 0.3]), y)
    np.testing.assert_allclose(got, [0.5, 0.1 - 0.25, 0.6], atol=1e-12)
    # A turned heading, brute force: the distance ahead is the projection on (cos, sin).
    yaw = 0.7
    h = np.array([np.cos(yaw), np.sin(yaw)])
    plan = 0.3 * h + 0.1 * np.array([-h[1], h[0]])
    got = ctl.over_feet(base, True, np.zeros(2), plan, h)
    np.testing.assert_allclose(got[:2], base[:2] - 0.25 * h, atol=1e-12)


def test_base_left_alone_within_the_band_behind_when_stepping_or_off(scene: Scene) -> None:
    base = np.array([0.5, 0.1, 0.6])
    on = StanceControl(scene, StanceConfig(base_over_feet=0.05))
    feet, plan = np.array([0.0, 0.0]), np.array([0.2, 0.0])
    np.testing.assert_array_equal(on.over_feet(base, True, feet, np.array([0.049, 0.3]), X), base)  # 4.9 cm ahead
    np.testing.assert_array_equal(on.over_feet(base, True, feet, np.array([-0.3, 0.0]), X), base)  # behind: a pull
    np.testing.assert_array_equal(on.over_feet(base, False, feet, plan, X), base)  # a foot steps
    np.testing.assert_array_equal(on.over_feet(base, True, feet, None, X), base)
    off = StanceControl(scene, StanceConfig())
    np.testing.assert_array_equal(off.over_feet(base, True, feet, plan, X), base)
    # frame(): the carried base is what the filter sees (a filter that starts afresh passes it through).
    got, _ = on.frame(mujoco.MjData(scene.model), base, True, feet, 0.0, plan, 0.0)
    np.testing.assert_allclose(got, [0.35, 0.1, 0.6], atol=1e-12)


def test_simulator_gives_the_stance_the_plans_ankles_before_the_foot_lock(ours, monkeypatch) -> None:
    inter = list(generate_dataset(0).of_label("shake_hands"))[0]
    cfg = SimConfig.standing()
    cfg = dataclasses.replace(cfg, stance=dataclasses.replace(cfg.stance, base_over_feet=0.05))
    sim = Simulator(ours, "shake_hands", cfg)
    sim.reset(inter)
    home = sim.home_key_frames
    sim.step(home)  # the foot lock plants both feet at home
    assert all(sim._footlock.standing)
    seen = {}
    real = sim._stage.stance.frame

    def spy(data, base, standing, centre, tilt, plan_centre=None, yaw=0.0):
        seen.update(standing=standing, plan=None if plan_centre is None else np.array(plan_centre), yaw=yaw)
        return real(data, base, standing, centre, tilt, plan_centre, yaw)

    monkeypatch.setattr(sim._stage.stance, "frame", spy)
    targets = home.copy()
    targets[3:5, 0] += 0.03  # both ankle targets 3 cm ahead: within the foot lock's radius, so held where planted
    sim.solve(targets)
    world = sim.frame_R.to_world(targets)
    ik = sim._stage.ik
    assert seen["standing"] and seen["yaw"] == sim._yaw
    np.testing.assert_allclose(seen["plan"], ik.balance.box_centre(world[3:5], sim._yaw), atol=1e-12)
    planted = np.array(sim._footlock.planted)
    assert np.linalg.norm(seen["plan"] - ik.balance.box_centre(planted, sim._yaw)) > 0.02


def test_causal_only_leaves_a_recordings_replay_alone(ours, monkeypatch) -> None:
    inter = list(generate_dataset(0).of_label("shake_hands"))[0]
    cfg = SimConfig.standing()
    cfg = dataclasses.replace(cfg, stance=dataclasses.replace(cfg.stance, base_over_feet=0.05),
                              foot_lock=dataclasses.replace(cfg.foot_lock, restep_gap=0.08, restep_above=False,
                                                            restep_roll_free=False), plan_feet_causal_only=True)
    sim = Simulator(ours, "shake_hands", cfg)
    seen = []
    for frames, on in ((None, False), (10, True)):  # a replay; a causal source that sees agent 1's first 10 frames
        sim.reset(inter, placement_frames=frames)
        real = sim._stage.stance.frame
        monkeypatch.setattr(sim._stage.stance, "frame",
                            lambda *a, real=real, **k: (seen.append(a[5] if len(a) > 5 else None), real(*a, **k))[1])
        assert (sim._footlock.config.restep_gap == 0.08) is on
        sim.step(sim.home_key_frames)
        assert (seen[-1] is not None) is on
        monkeypatch.undo()
    # Without the scope both act on the replay too.
    sim = Simulator(ours, "shake_hands", dataclasses.replace(cfg, plan_feet_causal_only=False))
    sim.reset(inter)
    assert sim._footlock.config.restep_gap == 0.08 and sim._plan_feet
