"""``BalanceConfig.torso_bandwidth_roll_free`` ω_r: the torso task's bandwidth on a robot whose feet's roll
``flat_roll_free`` frees. The decision (the H1, skipped without ../shared/robots: ω_r; Stubby: ``torso_bandwidth``
whatever ω_r; without ω_r ``torso_bandwidth``), the setting's check, and a standing Stubby episode with it identical
step by step to one without, while ``torso_bandwidth`` itself at ω_r changes it (so the check can fail)."""

from __future__ import annotations

import functools

import pytest

from conftest import assert_gate_keeps_stubby, shared_robot, standing_with, synthetic_instance
from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.simulator import SimConfig, Simulator

_cfg = functools.partial(standing_with, "balance")  # SimConfig.standing() with these balance fields


def test_the_setting_is_checked() -> None:
    for bad in (0.0, -1.0):
        with pytest.raises(ConfigError, match="torso_bandwidth_roll_free"):
            BalanceConfig(torso_bandwidth_roll_free=bad)
    assert BalanceConfig().torso_bandwidth_roll_free is None
    assert SimConfig.standing().balance.torso_bandwidth_roll_free is None


def test_the_bandwidth_by_robot() -> None:
    inter = synthetic_instance("high_five", 1)
    for omega, got in ((None, 10.0), (20.0, 10.0)):  # Stubby's feet roll: torso_bandwidth whatever ω_r
        bal = Simulator("ours", "high_five", _cfg(torso_bandwidth_roll_free=omega))._get_stage(inter).stepper.balance
        assert not bal.roll_freed and bal.torso_bandwidth == got
    spec = load_robot("unitree_h1", mjcf=shared_robot("unitree_h1", "h1.xml"))
    for omega, got in ((None, 10.0), (20.0, 20.0)):  # the H1's roll is freed: ω_r where set
        bal = Simulator(spec, "high_five", _cfg(torso_bandwidth_roll_free=omega))._get_stage(inter).stepper.balance
        assert bal.roll_freed and bal.torso_bandwidth == got


def test_stubby_runs_bit_for_bit_as_without_it() -> None:
    inter = synthetic_instance("high_five", 1)
    # ungated: the same bandwidth for every robot changes Stubby
    assert_gate_keeps_stubby(inter, SimConfig.standing(), _cfg(torso_bandwidth_roll_free=20.0),
                             _cfg(torso_bandwidth=20.0))
