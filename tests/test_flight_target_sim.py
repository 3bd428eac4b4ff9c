"""The catch's flight target inside the simulator: its window, the ball's state it reads, and moving in."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.retarget.flight_target import FlightState
from socialaff_sim.sim.contact_targets import ContactAnchors
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.tasks import load_task


def _first(label: str):  # noqa: ANN202
    return generate_dataset(0, SyntheticConfig(interactions=(label,), instances_per_interaction=1))[0]


@pytest.fixture(scope="module")
def catch_sim() -> Simulator:
    c = SimConfig()
    sim = Simulator("ours", "throw_catch", dataclasses.replace(c, contact_completion=dataclasses.replace(
        c.contact_completion, catch_flight=True, catch_approach=True)))
    sim.reset(_first("throw_catch"))
    return sim


def test_the_window_is_a_catch_subgoals_free_ungripped_object_only(catch_sim: Simulator) -> None:
    sim = catch_sim
    anchors = ContactAnchors(sim.scene, sim.task)
    sc, d = sim.scene, sim.data
    d.qpos[sc.object_qadr + 2] = 1.2
    assert anchors.catch_window(d, None, free=True)
    assert not anchors.catch_window(d, None, free=False)  # still in the thrower's hand
    d.qpos[sc.object_qadr + 2] = anchors.radius[2]  # on the floor: landed, nothing left to catch
    assert not anchors.catch_window(d, None, free=True)
    d.qpos[sc.object_qadr + 2] = anchors.radius[2] + 0.05  # just above it, still falling
    assert anchors.catch_window(d, None, free=True)
    d.qpos[sc.object_qadr + 2] = 1.2
    eq = sim.scene.grip_eq[0]
    sim.data.eq_active[eq] = 1
    try:
        assert not anchors.catch_window(sim.data, None, free=True)  # a hand grips it: the catch is made
    finally:
        sim.data.eq_active[eq] = 0
    # a hand over's cup, let go, is no catch: the option leaves every other interaction alone
    hand_over = Simulator("ours", "hand_over", SimConfig.harness())
    hand_over.reset(_first("hand_over"))
    hand_over.data.qpos[hand_over.scene.object_qadr + 2] = 1.2  # in the air, let go
    assert not ContactAnchors(hand_over.scene, hand_over.task).catch_window(hand_over.data, None, free=True)
    # a catch sub-goal listing sub-events opens its window during those only
    task = load_task("throw_catch")
    during = dataclasses.replace(task, subgoals=(dataclasses.replace(task.subgoals[0], subevents=("catch",)),))
    rule = ContactAnchors(sim.scene, during)
    assert rule.catch_window(sim.data, "catch", free=True) and not rule.catch_window(sim.data, "flight", free=True)


def test_the_flight_read_is_the_balls_simulated_state_and_the_scenes_gravity(catch_sim: Simulator) -> None:
    sim = catch_sim
    sc, d = sim.scene, sim.data
    d.qpos[sc.object_qadr:sc.object_qadr + 3] = (0.4, 0.1, 1.5)
    d.qvel[sc.object_vadr:sc.object_vadr + 3] = (-2.0, 0.2, 1.0)
    f = ContactAnchors(sc, sim.task).flight(d, 0.1)
    np.testing.assert_array_equal(f.position, [0.4, 0.1, 1.5])
    np.testing.assert_array_equal(f.velocity, [-2.0, 0.2, 1.0])
    assert f.gravity == pytest.approx(-sc.model.opt.gravity[2]) and f.lead == 0.1 and f.floor == 0.0


def _keys(sim: Simulator, t: int) -> tuple[np.ndarray, np.ndarray]:
    inter = sim.interaction
    return inter.key_joints()[t, 1] + sim._targets.place.offset, sim.pose.joints[t]


def test_a_flight_beyond_reach_moves_the_robot_in_and_one_within_reach_does_not(catch_sim: Simulator) -> None:
    sim = catch_sim
    targets = sim._targets
    keys, partner = _keys(sim, 15)
    shoulders = sim.data.xpos[sim.scene.limb_body_ids[:2]]
    # a ball dropped straight down just beside the right shoulder: within reach, the robot stays
    near = FlightState(shoulders[1] + [0.2, 0.0, 0.0], np.zeros(3), lead=0.1, gravity=9.81)
    sim.scaler.stand_cap = np.inf
    targets._approach_flight(near, 0.1, sim.data, keys, partner)
    assert sim.scaler.stand_cap == np.inf
    # the same drop 1.5 m in front of the robot, toward the thrower: it moves in, by one frame's step at most
    toward = sim._targets.place.frame.rotation[:, 0]
    far = FlightState(shoulders[1] + 1.5 * toward, np.zeros(3), lead=0.1, gravity=9.81)
    targets._approach_flight(far, 0.1, sim.data, keys, partner)
    cap = sim.scaler.stand_cap
    assert np.isfinite(cap)
    spread = float(np.linalg.norm(keys[0, :2] - partner[sim.scaler._partner_base, :2]))
    step = sim.scaler.config.approach_speed / sim.interaction.fps
    assert sim.scaler.k * spread - step - 1e-9 <= cap < sim.scaler.k * spread
    sim.scaler.stand_cap = np.inf


def test_the_recordings_placement_moves_in_for_a_flight_only_when_asked(catch_sim: Simulator) -> None:
    sim = catch_sim
    scaler = sim.scaler
    assert not scaler._online  # the ground truth's placement: once, from the whole recording
    keys, partner = _keys(sim, 15)
    toward = sim._targets.place.frame.rotation[:, 0]
    point = sim.data.xpos[sim.scene.limb_body_ids[1]] + 1.5 * toward
    scaler.stand_cap = np.inf
    assert not scaler.approach(point, np.array([1]), keys, partner)
    assert scaler.stand_cap == np.inf
    assert scaler.approach(point, np.array([1]), keys, partner, flight=True)
    assert np.isfinite(scaler.stand_cap)
    scaler.stand_cap = np.inf
