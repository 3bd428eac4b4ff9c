"""The plan's trunk leaned into an upward reach (``StanceConfig.strike_lean``): the lean's decisions (a raised wrist
ahead of its shoulder leans, one below the threshold, behind or not finite does not; the larger arm's; the cap), its
size against a hand computation, the IK's base target pitched forward about the heading's lateral axis (against a
rotation built from its axis and angle), and the simulator passing no lean without the option."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim import strike_lean as lean_module
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.scene import Scene, build_scene
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.stance import StanceConfig
from socialaff_sim.sim.strike_lean import lean_out, strike_lean

from conftest import spy_ik_leans
from test_retarget_ik import LAYOUT, STICK_TOML, STICK_XML, ik_for


@pytest.fixture(scope="module")
def stick(tmp_path_factory: pytest.TempPathFactory) -> Scene:
    folder = tmp_path_factory.mktemp("stick_lean")
    (folder / "stick.xml").write_text(STICK_XML)
    (folder / "stick.toml").write_text(STICK_TOML)
    return build_scene(load_robot(folder / "stick.toml"), LAYOUT, physics=False)


SHOULDERS = np.array([[0.0, 0.2, 0.4], [0.0, -0.2, 0.4]])  # left, right: 0.4 m above the base


def _targets(left: tuple[float, float, float], right: tuple[float, float, float]) -> np.ndarray:
    t = np.zeros((5, 3))
    t[0] = [1.0, 2.0, 0.9]  # the base target (robot frame): the wrists are read from it
    t[1] = t[0] + left
    t[2] = t[0] + right
    t[3] = [1.0, 2.1, 0.05]
    t[4] = [1.0, 1.9, 0.05]
    return t


@pytest.mark.parametrize("left, right, expected_deg", [
    # a raised wrist 0.2 m ahead of its shoulder: 30 deg/m x 0.2 m = 6 deg
    ((0.2, 0.2, 0.6), (0.0, -0.2, -0.3), 6.0),
    # the same wrist below the threshold height (0.05 above the shoulder, threshold 0.1): no lean
    ((0.2, 0.2, 0.45), (0.0, -0.2, -0.3), 0.0),
    # raised but behind its shoulder: no lean
    ((-0.2, 0.2, 0.6), (0.0, -0.2, -0.3), 0.0),
    # both raised: the arm reaching farther ahead leans (0.3 m: 9 deg)
    ((0.1, 0.2, 0.6), (0.3, -0.2, 0.6), 9.0),
    # far ahead: capped at 10 deg
    ((0.6, 0.2, 0.6), (0.0, -0.2, -0.3), 10.0),
    # a far reach at the chest's height (below the shoulder): none
    ((0.6, 0.2, 0.2), (0.6, -0.2, 0.2), 0.0),
])
def test_the_lean_decisions_and_size(left: tuple, right: tuple, expected_deg: float) -> None:
    got = strike_lean(_targets(left, right), SHOULDERS, gain=30.0, most=10.0, raised=0.1)
    assert math.degrees(got) == pytest.approx(expected_deg, abs=1e-9)


def test_a_wrist_target_not_finite_leans_nothing() -> None:
    t = _targets((0.3, 0.2, 0.6), (0.3, -0.2, 0.6))
    t[1] = np.nan
    assert math.degrees(strike_lean(t, SHOULDERS, 30.0, 10.0, 0.0)) == pytest.approx(9.0)
    t[2] = np.nan
    assert strike_lean(t, SHOULDERS, 30.0, 10.0, 0.0) == 0.0


def _axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    """(3, 3) the rotation by ``angle`` about unit ``axis`` (Rodrigues), an independent reference."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)


@pytest.mark.parametrize("yaw, lean", [(0.3, 0.15), (-1.2, 0.1), (2.0, 0.0)])
def test_the_base_target_leans_forward_about_the_lateral_axis(stick: Scene, yaw: float, lean: float) -> None:
    ik = ik_for(stick, 2.0)
    ik._set_targets(ik.frame_positions(), yaw, lean)
    got = np.zeros(9)
    mujoco.mju_quat2Mat(got, ik.key_task.target_quats[0])
    home = np.zeros(9)
    mujoco.mju_quat2Mat(home, ik._home_quat[0])
    heading = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    lateral = np.array([-math.sin(yaw), math.cos(yaw), 0.0])  # the heading's left
    want = _axis_angle(lateral, lean) @ _axis_angle(np.array([0.0, 0.0, 1.0]), yaw) @ home.reshape(3, 3)
    np.testing.assert_allclose(got.reshape(3, 3), want, atol=1e-12)
    up = got.reshape(3, 3) @ (home.reshape(3, 3).T @ np.array([0.0, 0.0, 1.0]))  # the home up axis, leaned
    assert float(up @ heading) == pytest.approx(math.sin(lean), abs=1e-12)  # forward (toward the partner), not back
    for k in (3, 4):  # the feet's targets are not leaned
        feet = np.zeros(9)
        mujoco.mju_quat2Mat(feet, ik.key_task.target_quats[k])
        mujoco.mju_quat2Mat(home, ik._home_quat[k])
        np.testing.assert_allclose(feet.reshape(3, 3), _axis_angle(np.array([0.0, 0.0, 1.0]), yaw) @ home.reshape(3, 3),
                                   atol=1e-12)


def test_the_target_quaternions_follow_a_change_of_lean(stick: Scene) -> None:
    ik = ik_for(stick, 2.0)
    ik._set_targets(ik.frame_positions(), 0.3, 0.0)
    upright = ik.key_task.target_quats[0].copy()
    ik._set_targets(ik.frame_positions(), 0.3, 0.2)
    assert not np.allclose(ik.key_task.target_quats[0], upright)  # not the cached upright target
    ik._set_targets(ik.frame_positions(), 0.3, 0.0)
    np.testing.assert_array_equal(ik.key_task.target_quats[0], upright)


def test_the_config_defaults_lean_nothing() -> None:
    c = StanceConfig()
    assert c.strike_lean is None
    assert dataclasses.replace(c, strike_lean=30.0).strike_lean_max == 10.0


def test_the_simulator_leans_only_with_the_option(monkeypatch: pytest.MonkeyPatch) -> None:
    inter = list(generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=1)).of_label("high_five"))[0]
    calls: list[float] = []
    orig = lean_module.strike_lean
    monkeypatch.setattr(lean_module, "strike_lean", lambda *a: calls.append(orig(*a)) or calls[-1])
    leans = spy_ik_leans(monkeypatch)
    base = SimConfig.standing()
    for stance, leaning in ((dataclasses.replace(base.stance, strike_lean=None), False),
                           (dataclasses.replace(base.stance, strike_lean=40.0), True)):
        calls.clear()
        leans.clear()
        run_episode(Simulator("ours", "high_five", dataclasses.replace(base, stance=stance)), GroundTruthSource(), inter)
        assert bool(calls) is leaning
        assert (max(leans) > 0.0) is leaning  # the high five's strike raises a wrist ahead of its shoulder
        assert max(leans) <= math.radians(10.0) + 1e-12


@pytest.mark.parametrize("label, above, leaning", [
    ("shake_hands", False, True),  # a handshake's wrist target rises above the shoulder for a frame: it leans
    ("shake_hands", True, False),  # ... not with strike_lean_above (no contact counted above the shoulders)
    ("high_five", True, True),  # the high five's contact is counted above the shoulders
])
def test_the_lean_only_in_a_task_above_the_shoulders(monkeypatch: pytest.MonkeyPatch, label: str, above: bool,
                                                      leaning: bool) -> None:
    data = generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=146))
    inter = list(data.of_label(label))[145]  # shake_hands_145: its wrist target above the shoulder at frame 25
    leans = spy_ik_leans(monkeypatch)
    base = SimConfig.standing()
    stance = dataclasses.replace(base.stance, strike_lean=40.0, strike_lean_above=above)
    run_episode(Simulator("ours", label, dataclasses.replace(base, stance=stance)), GroundTruthSource(), inter)
    assert (max(leans) > 0.0) is leaning


@pytest.mark.parametrize("since, frames, expected", [
    (None, 4, 0.2),  # not met yet: the lean as given
    (0, None, 0.2),  # the option off
    (0, 4, 0.2),  # the meeting's own frame: 1 − 0/4
    (1, 4, 0.15),  # a frame after: 0.2 · (1 − 1/4)
    (2, 4, 0.1),
    (4, 4, 0.0),  # ramped out
    (9, 4, 0.0),  # and stays out (not negative)
    (1, 0, 0.0),  # N = 0: dropped at the meeting
])
def test_the_lean_ramped_out_after_the_meeting(since: int | None, frames: int | None, expected: float) -> None:
    assert lean_out(0.2, since, frames) == pytest.approx(expected, abs=1e-12)


def test_the_simulator_ramps_the_lean_out_once_the_hands_have_met(monkeypatch: pytest.MonkeyPatch) -> None:
    """With ``strike_lean_out`` the IK gets no lean from the frame after the sub-goal's success on (N = 0), while
    without it the plan still leans after the meeting (high_five_000, ground truth: fails if the decision is
    inverted or the meeting's frame is not read)."""
    inter = list(generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=1)).of_label("high_five"))[0]
    base = SimConfig.standing()
    after: dict[object, list[float]] = {}
    for out in (None, 0):
        leans = spy_ik_leans(monkeypatch)
        sim = Simulator("ours", "high_five", dataclasses.replace(
            base, stance=dataclasses.replace(base.stance, strike_lean=30.0, strike_lean_out=out)))
        met: list[int] = []

        def on_frame(s, r, sub, met=met):  # noqa: ANN001
            if r is not None and not met and all(r.subgoals.values()):
                met.append(len(leans))  # solves made up to the meeting's frame's end

        run_episode(sim, GroundTruthSource(), inter, on_frame=on_frame)
        monkeypatch.undo()
        assert met, "the high five is met in both arms up to the meeting"
        assert max(leans[:met[0]]) > 0.0  # leaned into the strike before the meeting
        after[out] = leans[met[0]:]
    assert max(after[None]) > 0.0  # without the option the lean runs on after the meeting
    assert max(after[0]) == 0.0  # with it (N = 0) none after


def _leans_of(monkeypatch: pytest.MonkeyPatch, instance: int, **stance: object) -> tuple[list[float], int]:
    """The leans the IK got in standing high_five_<instance> (ground truth) with ``stance``'s fields, and how many
    solves were made up to the end of the frame that met the sub-goal (-1: never met)."""
    inter = list(generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=instance + 1))
                 .of_label("high_five"))[instance]
    base = SimConfig.standing()
    leans = spy_ik_leans(monkeypatch)
    met: list[int] = []

    def on_frame(s, r, sub):  # noqa: ANN001
        if r is not None and not met and all(r.subgoals.values()):
            met.append(len(leans))

    run_episode(Simulator("ours", "high_five", dataclasses.replace(
        base, stance=dataclasses.replace(base.stance, **stance))), GroundTruthSource(), inter, on_frame=on_frame)
    monkeypatch.undo()
    return list(leans), (met[0] if met else -1)


def test_the_lean_ends_when_caught_after_the_meeting(monkeypatch: pytest.MonkeyPatch) -> None:
    """high_five_007 (ground truth, standing) meets its sub-goal while the harness holds it caught: with
    ``strike_lean_caught`` the plan leans no more from then on; without it the lean runs on (to 10°)."""
    off, met_off = _leans_of(monkeypatch, 7)
    on, met_on = _leans_of(monkeypatch, 7, strike_lean_caught=True)
    assert met_off > 0 and met_on == met_off
    assert on[:met_on] == off[:met_off]  # the same until the meeting
    assert max(off[met_off:]) > 0.0
    assert max(on[met_on:]) == 0.0


def test_the_lean_runs_on_when_met_released(monkeypatch: pytest.MonkeyPatch) -> None:
    """high_five_001 meets its sub-goal released and is not caught after: ``strike_lean_caught`` changes none of
    its leans (fails if the decision is inverted: dropping the lean of a robot not caught)."""
    off, met_off = _leans_of(monkeypatch, 1)
    on, met_on = _leans_of(monkeypatch, 1, strike_lean_caught=True)
    assert met_off > 0 and max(off[met_off:]) > 0.0
    assert on == off
