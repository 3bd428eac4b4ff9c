"""``StanceConfig.strike_lean_fall_roll_free`` δ: on a robot whose feet's roll is freed (the H1), the plan's strike
lean falls by at most δ per data frame. The decision (a fall capped at δ per frame, a rise as planned, a solve again
within a frame limited from the same earlier frame, frames skipped allowing δ each; against a sequence worked by
hand), the gate (another robot, or the option off: the lean as given), the setting's check, and the simulator's
gate: Stubby's standing high five runs bit for bit as without the option (while a changed lean for every robot
changes it, so that check can fail), the H1's plan gets δ."""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import pytest

from conftest import assert_gate_keeps_stubby, shared_robot, standing_with, synthetic_instance
from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.sim_config import STANDING_STANCE
from socialaff_sim.sim.strike_lean import PlanLean

_cfg = functools.partial(standing_with, "stance")  # SimConfig.standing() with these stance fields


ON = dataclasses.replace(STANDING_STANCE, strike_lean_fall_roll_free=2.0)


def _run(plan: PlanLean, seq) -> list[float]:  # noqa: ANN001
    return [round(float(np.degrees(plan.limit(float(np.radians(x)), t))), 9) for t, x in seq]


def test_the_fall_is_capped_per_frame() -> None:
    seq = [(0, 10.0), (1, 0.0), (1, 0.0), (2, 0.0), (2, 9.0), (3, 10.0), (4, 0.3), (5, 0.3), (9, 0.0), (10, 1.0)]
    # by hand: 10; 10−2; a second solve of frame 1 from frame 0 again; 8−2; a second solve of frame 2 rising to 9 (the
    # planned 9 over the floor 6); 10 (a rise as planned); 10−2; 8−2; four frames later 6−8 < 0: 0; 1 (a rise)
    assert _run(PlanLean(ON, True, True), seq) == pytest.approx([10, 8, 8, 6, 9, 10, 8, 6, 0, 1], abs=1e-9)
    assert _run(PlanLean(ON, True, False), seq) == pytest.approx([x for _, x in seq])  # Stubby: as given
    assert _run(PlanLean(STANDING_STANCE, True, True), seq) == pytest.approx([x for _, x in seq])  # off
    assert PlanLean(ON, True, True).fall == pytest.approx(np.radians(2.0))
    assert PlanLean(ON, True, False).fall is None and PlanLean(STANDING_STANCE, True, True).fall is None


def test_the_frame_goes_through_the_limit() -> None:
    plan = PlanLean(ON, True, True)
    shoulders = np.array([[0.0, 0.2, 0.4], [0.0, -0.2, 0.4]])
    up = np.zeros((5, 3))
    up[0] = [0.0, 0.0, 1.0]
    up[1] = [0.5, 0.2, 1.6]  # the left wrist 20 cm above its shoulder, 50 cm ahead: θ_max
    down = up.copy()
    down[1] = [0.5, 0.2, 1.2]  # below its shoulder: no lean planned
    assert np.degrees(plan.frame(up, shoulders, None, False, 5)) == pytest.approx(10.0)
    assert np.degrees(plan.frame(down, shoulders, None, False, 6)) == pytest.approx(8.0)
    assert PlanLean(ON, True, False).frame(down, shoulders, None, False, 6) == 0.0


@pytest.mark.parametrize("bad", [0.0, -1.0])
def test_the_setting_is_checked(bad: float) -> None:
    with pytest.raises(ConfigError, match="strike_lean_fall_roll_free"):
        dataclasses.replace(STANDING_STANCE, strike_lean_fall_roll_free=bad)
    assert STANDING_STANCE.strike_lean_fall_roll_free is None


def test_stubby_runs_bit_for_bit_as_without_it() -> None:
    inter = synthetic_instance("high_five", 1)
    # ungated: a changed lean for every robot changes Stubby
    assert_gate_keeps_stubby(inter, _cfg(), _cfg(strike_lean_fall_roll_free=2.0), _cfg(strike_lean_max=5.0))


def test_the_h1s_plan_gets_the_rate() -> None:
    from socialaff_sim.retarget.robot import load_robot
    from socialaff_sim.sim.simulator import Simulator

    inter = synthetic_instance("high_five", 1)
    spec = load_robot("unitree_h1", mjcf=shared_robot("unitree_h1", "h1.xml"))
    for robot, cfg, expected in (("ours", _cfg(strike_lean_fall_roll_free=2.0), None),
                                 (spec, _cfg(), None), (spec, _cfg(strike_lean_fall_roll_free=2.0), np.radians(2.0))):
        sim = Simulator(robot, "high_five", cfg)
        sim.reset(inter)
        got = sim._lean.fall
        assert (got is None) if expected is None else got == pytest.approx(expected)
