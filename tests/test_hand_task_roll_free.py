"""``BalanceConfig.hand_task_roll_free`` (sim/hand_task.py: hand_task_wanted): the hands' rows only for a robot whose
feet ``flat_roll_free`` frees (a leg of fewer than six joints): the decision on a model written out here (one
five-joint leg) and on Stubby (six and six), the settings checked, the controllers built with it (Stubby: no task;
the H1, skipped without ../shared/robots: the task), and a standing Stubby episode with it identical step by step to
one without ``flat_roll_free`` and ``hand_task``, while the same settings without the gate change it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from conftest import assert_gate_keeps_stubby, shared_robot, synthetic_instance
from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.feet_on_floor import FeetOnFloor
from socialaff_sim.sim.flat_feet import roll_free_axes
from socialaff_sim.sim.hand_task import hand_task_wanted
from socialaff_sim.sim.simulator import SimConfig, Simulator
from test_flat_roll_free import _legs


def _paired(gate: bool, weight: float | None = 10.0) -> SimConfig:
    """``SimConfig.standing()`` with ``flat_roll_free``, ``hand_task`` = ``weight`` and the gate."""
    cfg = SimConfig.standing()
    return dataclasses.replace(cfg, balance=dataclasses.replace(
        cfg.balance, flat_roll_free=True, hand_task=weight, hand_task_roll_free=gate))


def test_the_gate_gives_the_task_to_a_robot_with_a_freed_foot_only(scene) -> None:
    m, root, left, right = _legs()  # left leg five joints, right six
    fw = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    five = roll_free_axes(m, [left, right], fw, root)
    six = roll_free_axes(m, [right, right], fw, root)  # (both feet on six-joint legs)
    assert hand_task_wanted(10.0, True, five)
    assert not hand_task_wanted(10.0, True, six)
    assert not hand_task_wanted(10.0, True, None)  # without flat_roll_free nothing is freed
    # Stubby's legs: six joints each, nothing freed, no task.
    feet = FeetOnFloor(scene, 0.0)
    assert not hand_task_wanted(10.0, True, roll_free_axes(scene.model, feet.bodies, feet.forward, scene.root_body))
    # Without the gate every robot gets it; without hand_task none does.
    assert hand_task_wanted(10.0, False, six) and hand_task_wanted(10.0, False, None)
    assert not hand_task_wanted(None, True, five) and not hand_task_wanted(None, False, five)


def test_settings_are_checked() -> None:
    for bad in (dict(hand_task_roll_free=True), dict(hand_task=10.0, hand_task_roll_free=True),
                dict(flat_roll_free=True, hand_task_roll_free=True)):
        with pytest.raises(ConfigError, match="hand_task_roll_free"):
            BalanceConfig(solver="qp", flat_feet=True, **bad)
    assert BalanceConfig(solver="qp", flat_feet=True, flat_roll_free=True, hand_task=10.0,
                         hand_task_roll_free=True).hand_task_roll_free
    assert not BalanceConfig().hand_task_roll_free


def test_the_controllers_built_with_it_stubby_none_the_h1_the_task() -> None:
    inter = synthetic_instance("shake_hands", 1)
    for gate, has in ((True, False), (False, True)):
        bal = Simulator("ours", "shake_hands", _paired(gate))._get_stage(inter).stepper.balance
        assert (bal.hands is not None) is has
    spec = load_robot("unitree_h1", mjcf=shared_robot("unitree_h1", "h1.xml"))
    bal = Simulator(spec, "shake_hands", _paired(True))._get_stage(inter).stepper.balance
    assert bal.hands is not None and bal.hands.weight == 10.0
    assert any(a is not None for a in bal._roll_free)


def test_stubby_runs_bit_for_bit_as_without_either_option() -> None:
    inter = synthetic_instance("high_five", 1)
    # the same settings without the gate give Stubby the hands' rows, which change its motion (so the check can fail)
    assert_gate_keeps_stubby(inter, SimConfig.standing(), _paired(True), _paired(False))
