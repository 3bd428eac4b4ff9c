"""``BalanceConfig.catch_tilt_lean_roll_free`` κ: on a robot whose feet's roll ``flat_roll_free`` frees (the H1), the
harness's catch for tilt waits for ``catch_tilt`` + κ λ, λ the plan's torso lean from upright. The decision (on such
a robot the raised bound, boundary included; on another robot, without the option or with the plan upright
``catch_tilt``; the catch's cause counted against the raised bound), the settings' check, the plan's lean against
an independent reference (a rotation built by hand), and the gate: Stubby's controller gets no gain and its standing
high five runs bit for bit as without the option, while ``catch_tilt`` itself raised changes it (so that check can
fail); the H1's controller gets the gain and passes the plan's lean to the harness."""

from __future__ import annotations

import dataclasses
import functools

import mujoco
import numpy as np
import pytest

from conftest import assert_gate_keeps_stubby, shared_robot, spy_harness_decide, standing_with, synthetic_instance
from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.harness_release import HarnessRelease
from socialaff_sim.sim.sim_config import STANDING_BALANCE
from socialaff_sim.sim.support_box import SupportBox

_cfg = functools.partial(standing_with, "balance")  # SimConfig.standing() with these balance fields


ON = dataclasses.replace(STANDING_BALANCE, catch_tilt_lean_roll_free=1.0)
BOX = SupportBox(np.array([[-0.1, -0.15], [0.1, -0.15], [-0.1, 0.15], [0.1, 0.15]]), np.array([1.0, 0.0]))
MIDDLE = np.zeros(2)


def _caught(scene, config, roll_freed: bool, tilt: float, lean: float) -> tuple[bool, dict]:  # noqa: ANN001
    """Released at 1°, then one step at ``tilt`` with the plan leaning ``lean``: (caught, the causes)."""
    h = HarnessRelease(scene, config, roll_freed)
    d = mujoco.MjData(scene.model)
    h.decide(d, 0.2, True, 1.0, BOX, MIDDLE)  # planted 0.2 s (> release_delay), steady: let go
    assert h.released
    h.decide(d, 0.002, True, tilt, BOX, MIDDLE, plan_lean=lean)
    return not h.released, dict(h.catch_reasons)


def test_a_roll_freed_robot_is_caught_past_the_raised_bound(scene) -> None:  # noqa: ANN001
    for tilt, lean, roll_freed, config, expected in (
            (12.1, 10.0, True, ON, False),  # the H1 leaning 10° in the plan: bound 22°
            (22.0, 10.0, True, ON, False),  # the bound included
            (22.1, 10.0, True, ON, True),
            (12.1, 0.0, True, ON, True),  # the plan upright: catch_tilt
            (12.1, -3.0, True, ON, True),  # (a negative lean never lowers it)
            (12.1, 10.0, False, ON, True),  # a robot whose feet's roll is not freed: catch_tilt
            (12.1, 10.0, True, STANDING_BALANCE, True),  # off
            (11.9, 10.0, True, STANDING_BALANCE, False)):
        caught, why = _caught(scene, config, roll_freed, tilt, lean)
        assert caught == expected, (tilt, lean, roll_freed, config.catch_tilt_lean_roll_free)
        assert why["tilt"] == int(expected) and why["capture"] == 0
    h = HarnessRelease(scene, dataclasses.replace(ON, catch_tilt_lean_roll_free=0.5), True)
    assert h.lean_gain == 0.5 and h.catch_tilt(10.0) == 17.0 and h.catch_tilt(0.0) == 12.0
    assert HarnessRelease(scene, ON, False).lean_gain is None and HarnessRelease(scene, ON, False).catch_tilt(10.0) == 12.0
    assert HarnessRelease(scene, STANDING_BALANCE, True).catch_tilt(10.0) == 12.0


def test_the_capture_catch_is_unchanged(scene) -> None:  # noqa: ANN001
    h = HarnessRelease(scene, ON, True)
    d = mujoco.MjData(scene.model)
    h.decide(d, 0.2, True, 1.0, BOX, MIDDLE)
    h.decide(d, 0.002, True, 15.0, BOX, np.array([0.2, 0.0]), plan_lean=10.0)  # capture 10 cm off the box
    assert not h.released and h.catch_reasons == {"tilt": 0, "capture": 1, "step": 0}


@pytest.mark.parametrize("kw", [{"catch_tilt_lean_roll_free": 0.0}, {"catch_tilt_lean_roll_free": 6.0},
                                {"catch_tilt_lean_roll_free": 1.0, "tilt_from_plan": False},
                                {"catch_tilt_lean_roll_free": 1.0, "flat_roll_free": False,
                                 "hand_task_roll_free": False}])
def test_the_setting_is_checked(kw) -> None:  # noqa: ANN001
    with pytest.raises(ConfigError, match="catch_tilt_lean_roll_free"):
        dataclasses.replace(STANDING_BALANCE, **kw)
    assert STANDING_BALANCE.catch_tilt_lean_roll_free is None


def test_the_plan_lean_against_a_rotation_by_hand() -> None:
    from socialaff_sim.sim.simulator import Simulator

    inter = synthetic_instance("high_five", 1)
    bal = Simulator("ours", "high_five", _cfg(catch_tilt_lean_roll_free=None))._get_stage(inter).stepper.balance
    up = bal.attitude.up
    for deg, axis in ((10.0, (0.0, 1.0, 0.0)), (25.0, (1.0, 0.0, 0.0)), (0.0, (0.0, 1.0, 0.0))):
        # a rotation by `deg` about a horizontal axis applied to the home torso (Rodrigues' formula by hand)
        k = np.array(axis)
        kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        t = np.radians(deg)
        r = np.eye(3) + np.sin(t) * kx + (1 - np.cos(t)) * kx @ kx
        home = np.eye(3)
        if abs(up[2]) < 0.999:  # a torso whose up axis is not the body's z: bring it upright first
            home = _align(up)
        bal.attitude.goal = r @ home
        assert bal.attitude.plan_lean() == pytest.approx(deg, abs=1e-6)


def _align(up: np.ndarray) -> np.ndarray:
    """A rotation taking ``up`` onto the world's vertical (for the check above)."""
    z = np.array([0.0, 0.0, 1.0])
    v, c = np.cross(up, z), float(up @ z)
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + vx + vx @ vx / (1.0 + c)


def test_stubby_runs_bit_for_bit_as_without_it() -> None:
    inter = synthetic_instance("high_five", 1)
    # ungated: a changed catch for every robot
    assert_gate_keeps_stubby(inter, _cfg(), _cfg(catch_tilt_lean_roll_free=1.0), _cfg(catch_tilt=3.0, release_tilt=3.0))


def test_the_gain_by_robot_and_the_lean_passed() -> None:
    from socialaff_sim.retarget.robot import load_robot
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode
    from socialaff_sim.sim.simulator import Simulator

    inter = synthetic_instance("high_five", 1)
    assert Simulator("ours", "high_five", _cfg(catch_tilt_lean_roll_free=1.0))._get_stage(
        inter).stepper.balance.harness.lean_gain is None
    spec = load_robot("unitree_h1", mjcf=shared_robot("unitree_h1", "h1.xml"))
    assert Simulator(spec, "high_five", _cfg())._get_stage(inter).stepper.balance.harness.lean_gain is None
    sim = Simulator(spec, "high_five", _cfg(catch_tilt_lean_roll_free=1.0))
    leans: list[float] = []

    run_episode(sim, GroundTruthSource(), inter, on_frame=spy_harness_decide(
        lambda a, k: leans.append(float(a[8]) if len(a) > 8 else float(k.get("plan_lean", 0.0)))))
    bal = sim._stage.stepper.balance
    assert bal.roll_freed and bal.harness.lean_gain == 1.0
    assert max(leans) > 3.0  # the high five's strike lean reaches the harness


def test_the_touched_gate() -> None:
    """``catch_tilt_lean_touched``: the catch reads the plan's lean only once an arm has touched (the compensation's
    latch); without it from the start; with the gain not acting (Stubby) never."""
    from socialaff_sim.retarget.robot import load_robot
    from socialaff_sim.sim.simulator import Simulator

    inter = synthetic_instance("high_five", 1)
    spec = load_robot("unitree_h1", mjcf=shared_robot("unitree_h1", "h1.xml"))
    for touched_only in (True, False):
        bal = Simulator(spec, "high_five", _cfg(catch_tilt_lean_roll_free=1.0, catch_tilt_lean_touched=touched_only)
                        )._get_stage(inter).stepper.balance
        t = np.radians(10.0)  # the plan 10° about y from upright
        bal.attitude.goal = np.array([[np.cos(t), 0, np.sin(t)], [0, 1, 0], [-np.sin(t), 0, np.cos(t)]]) @ _align(
            bal.attitude.up)
        bal.compensation.touched[:] = False
        assert bal._catch_lean() == (0.0 if touched_only else pytest.approx(10.0))
        bal.compensation.touched[0] = True
        assert bal._catch_lean() == pytest.approx(10.0)
    stubby = Simulator("ours", "high_five", _cfg(catch_tilt_lean_roll_free=1.0, catch_tilt_lean_touched=True)
                       )._get_stage(inter).stepper.balance
    stubby.compensation.touched[:] = True
    assert stubby._catch_lean() == 0.0
    with pytest.raises(ConfigError, match="catch_tilt_lean_touched"):
        dataclasses.replace(STANDING_BALANCE, catch_tilt_lean_touched=True)
