"""The standing controller (sim/stance.py): when the harness lets go of a planted robot and catches it again,
the steadied base target, the centre-of-mass feedback, and, in physics, a catch on Stubby's own feet."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.retarget.ik import IKConfig
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim.episode import run_episode, support_caption, support_summary
from socialaff_sim.sim.scene import Scene
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.stage_build import leg_bandwidth
from socialaff_sim.sim.stance import StanceConfig, StanceControl

LAYOUT = get_layout("kinect_v2")


@pytest.fixture(scope="module")
def ours():
    return load_robot("ours")


def _control(scene: Scene, **kw: object) -> StanceControl:
    return StanceControl(scene, StanceConfig(**kw))  # type: ignore[arg-type]


STEADY = (0.5, 0.005)  # torso tilt (deg) and centre-of-mass offset (m) of a robot standing still


def test_harness_lets_go_after_the_planted_frames_it_asks_for(scene: Scene) -> None:
    ctl = _control(scene, release_after=3)
    assert [ctl.decide(True, *STEADY) for _ in range(4)] == [False, False, True, True]
    # A step (a foot not planted) catches the robot and starts the count afresh.
    assert ctl.decide(False, *STEADY) is False
    assert ctl.decide(True, *STEADY) is False


def test_harness_holds_a_robot_that_is_not_steady(scene: Scene) -> None:
    c = StanceConfig()
    for tilt, offset in ((c.release_tilt + 0.5, 0.0), (0.0, c.release_com + 0.005)):
        ctl = _control(scene, release_after=1)
        assert not any(ctl.decide(True, tilt, offset) for _ in range(5))
    ctl = _control(scene, release_after=1)
    assert ctl.decide(True, c.release_tilt - 0.5, c.release_com - 0.005)


def test_a_released_robot_stays_released_until_it_tilts_past_the_catch(scene: Scene) -> None:
    c = StanceConfig()
    ctl = _control(scene, release_after=1)
    assert ctl.decide(True, *STEADY)
    # Swaying more than a robot may start from, but less than a fall: it stays on its feet.
    between = 0.5 * (c.release_tilt + c.catch_tilt)
    assert ctl.decide(True, between, 2 * c.release_com)
    assert not ctl.decide(True, c.catch_tilt + 1.0, 0.0)
    # Caught, it is let go again only once steady.
    assert not ctl.decide(True, between, 0.0)
    assert ctl.decide(True, *STEADY)


def test_release_off_keeps_the_harness(scene: Scene) -> None:
    ctl = _control(scene, release=False, release_after=1)
    assert not any(ctl.decide(True, *STEADY) for _ in range(5))


def test_the_decision_switches_the_harness_weld(scene: Scene) -> None:
    d = mujoco.MjData(scene.model)
    weld = mujoco.mj_name2id(scene.model, mujoco.mjtObj.mjOBJ_EQUALITY, "robot_anchor")
    ctl = _control(scene, release_after=1)
    ctl.decide(True, *STEADY)
    ctl.apply(d)
    assert d.eq_active[weld] == 0
    ctl.decide(False, *STEADY)
    ctl.apply(d)
    assert d.eq_active[weld] == 1


def test_base_target_is_low_pass_filtered_while_standing(scene: Scene, rng: np.random.Generator) -> None:
    a = 0.8
    ctl = _control(scene, base_smoothing=a)
    raw = rng.normal(size=(6, 3))
    got = [ctl.steady_base(b, True) for b in raw]
    expected = [raw[0]]
    for b in raw[1:]:
        expected.append(a * expected[-1] + (1 - a) * b)
    np.testing.assert_allclose(got, expected, atol=1e-12)
    # A step passes the target through and restarts the filter.
    np.testing.assert_array_equal(ctl.steady_base(raw[1], False), raw[1])
    np.testing.assert_array_equal(ctl.steady_base(raw[2], True), raw[2])


def test_centre_of_mass_target_leans_against_the_measured_offset(scene: Scene) -> None:
    ctl = _control(scene, com_gain=1.0)
    centre = np.array([0.3, -0.2])
    # A centre of mass 4 cm ahead of the middle (pulled forward): the plan puts it 4 cm behind.
    np.testing.assert_allclose(ctl.com_target(np.array([0.34, -0.2, 0.7]), centre), [0.26, -0.2], atol=1e-12)
    np.testing.assert_allclose(_control(scene, com_gain=0.0).com_target(np.array([0.34, -0.2, 0.7]), centre),
                               centre, atol=1e-12)


def test_box_centre_is_the_middle_of_the_feet_turned_with_the_robot(ours) -> None:
    sim = Simulator(ours, "shake_hands", SimConfig())
    sim.reset(generate_dataset(seed=0).of_label("shake_hands")[0])
    balance = sim._stage.ik.balance  # type: ignore[union-attr]
    ankles = np.array([[1.0, 2.0, 0.1], [1.2, 2.2, 0.1]])
    mid = balance.box.mean(axis=1)
    yaw = 0.7
    turned = np.array([np.cos(yaw) * mid[0] - np.sin(yaw) * mid[1], np.sin(yaw) * mid[0] + np.cos(yaw) * mid[1]])
    np.testing.assert_allclose(balance.box_centre(ankles, yaw), [1.1, 2.1] + turned, atol=1e-12)
    # Stubby's feet reach farther forward than back from the ankles: the middle is ahead of them.
    assert mid[0] > 0.02


def _catch(ours, stance: StanceConfig | None) -> tuple[dict, list]:
    inter = generate_dataset(seed=0).of_label("throw_catch")[0]
    config = SimConfig.harness(stance=stance)
    # The stance's release as it was measured: without the hand target on the ball's flight (on by default since
    # issue 25's rule; with it this mode's contact phase here hangs 18 % of the weight on the harness,
    # docs/benchmarks.md, "The catch options' two failures traced …").
    config = dataclasses.replace(config, contact_completion=dataclasses.replace(
        config.contact_completion, catch_flight=False, catch_approach=False))
    sim = Simulator(ours, "throw_catch", config)
    metrics = run_episode(sim, GroundTruthSource(), inter)
    contact = [r.support for r in sim.results if any(r.subgoals_now.values())]
    return metrics, contact


def test_stubby_catches_the_ball_on_its_own_feet(ours) -> None:
    # throw_catch_000: both feet stay planted, and in the catch and the hold the harness has let go.
    metrics, contact = _catch(ours, StanceConfig())
    assert metrics["success"]
    phase = metrics["support"]["contact_phase"]
    assert phase["frames"] >= 10
    assert phase["outside_support_mean"] <= 0.05
    assert phase["torso_tilt_deg_max"] <= 10.0
    # Released frames carry nothing from outside: the weld is off, not merely slack.
    assert sum(f.outside_peak == 0.0 for f in contact) >= 0.8 * len(contact)
    # The same catch with the harness kept (only the base steadied) hangs a sixth of the weight on it.
    held, _ = _catch(ours, StanceConfig(release=False))
    assert held["support"]["contact_phase"]["outside_support_mean"] >= 0.1


def test_stance_defaults_are_off_and_leg_gains_follow_the_controller(ours) -> None:
    assert SimConfig().stance is None and SimConfig.harness().stance is None
    assert not SimConfig.standing().stance.release and leg_bandwidth(SimConfig.standing()) is None
    assert leg_bandwidth(SimConfig.harness(stance=StanceConfig(leg_bandwidth=7.0))) == 7.0
    assert leg_bandwidth(SimConfig.harness(stance=StanceConfig(release=False))) is None
    assert leg_bandwidth(dataclasses.replace(SimConfig.harness(stance=StanceConfig()), stance_bandwidth=12.0)) == 12.0
    assert IKConfig().com_cost == 0.0  # the IK's own centre-of-mass task stays off outside released frames


def test_box_centre_falls_back_to_the_home_centre_of_mass_without_a_box(ours) -> None:
    sim = Simulator(ours, "shake_hands", SimConfig())
    sim.reset(generate_dataset(seed=0).of_label("shake_hands")[0])
    balance = sim._stage.ik.balance  # type: ignore[union-attr]
    ankles = np.array([[1.0, 2.0, 0.1], [1.2, 2.2, 0.1]])
    with_box = balance.box_centre(ankles, 0.3)
    balance.box = None
    np.testing.assert_allclose(balance.box_centre(ankles, 0.3), balance.support_centre(ankles, 0.3), atol=1e-12)
    assert np.linalg.norm(with_box - balance.support_centre(ankles, 0.3)) > 0.01


def test_every_figure_names_the_stance_control(ours) -> None:
    inter = generate_dataset(seed=0).of_label("high_five")[0]
    modes = {}
    for name, stance in (("off", None), ("steady", StanceConfig(release=False)), ("release", StanceConfig())):
        sim = Simulator(ours, "high_five", SimConfig.harness(stance=stance))
        sim.reset(inter)
        sim.step(sim.home_key_frames)
        modes[name] = (support_summary(sim)["mode"], support_caption(sim))
    assert modes["off"][0] == "real weight, on the harness" and modes["off"][1].startswith("harness: outside support")
    assert "steadied base" in modes["steady"][0] and modes["steady"][1].startswith("steady base: outside support")
    assert "harness let go" in modes["release"][0] and modes["release"][1].startswith("stance: outside support")
