"""The leaned reach's grip led toward the toes (``ReachLeanConfig.lead``): the centre-of-mass reference's forward move
against a hand-computed reference (only once an arm has touched, only with the lead set, only with a compensation
latch), the setting's checks, and the simulator setting the controller's lead only where the lean acts (its robot and
task gates) and only with the option."""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.com_reference import ComReference
from socialaff_sim.sim.reach_lean import ReachLeanConfig
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.support_box import SupportBox

HEADING = math.radians(30.0)  # the box's forward axis, 30° from world x
FORWARD = np.array([math.cos(HEADING), math.sin(HEADING)])
FEET = np.array([[0.4, 0.1, 0.05], [0.2, -0.3, 0.05]])  # two foot bodies' positions (world, m)


def _reference(touched: tuple[bool, bool] | None, lead: float | None) -> tuple[np.ndarray, float]:
    """:meth:`ComReference.goal` of a reference on ``FEET`` (``com_reference="plan"``, no plan offset yet) with an arms'
    compensation whose touch latch is ``touched`` (``None``: no compensation) and :attr:`ComReference.lead` ``lead``."""
    comp = None if touched is None else SimpleNamespace(touched=np.array(touched, dtype=bool))
    ref = ComReference(BalanceConfig(com_reference="plan"), np.array([0, 1]), 0, comp)  # type: ignore[arg-type]
    ref.lead = lead
    box = SupportBox.of(np.array([FORWARD, [-FORWARD[1], FORWARD[0]]]), np.array([-0.1, -0.2]), np.array([0.2, 0.2]))
    return ref.goal(SimpleNamespace(xpos=FEET), box)  # type: ignore[arg-type]


def test_the_lead_moves_the_reference_forward_once_an_arm_has_touched() -> None:
    middle = np.array([0.3, -0.1])  # the feet's middle, by hand
    goal, weight = _reference((False, True), 0.04)
    np.testing.assert_allclose(goal, middle + 0.04 * np.array([math.sqrt(3) / 2, 0.5]), atol=1e-12)
    assert weight == BalanceConfig().w_com


@pytest.mark.parametrize("touched, lead", [
    ((False, False), 0.04),  # before the first touch: no lead
    ((True, True), None),  # the option off
    (None, 0.04),  # no compensation latch: never
    ((True, False), 0.0),  # a zero lead is no lead
])
def test_no_lead_without_a_touch_or_the_option(touched: tuple[bool, bool] | None, lead: float | None) -> None:
    goal, _ = _reference(touched, lead)
    np.testing.assert_array_equal(goal, _reference((False, False), None)[0])  # bit for bit the reference without
    np.testing.assert_allclose(goal, np.array([0.3, -0.1]), atol=1e-12)  # the feet's middle, by hand


@pytest.mark.parametrize("lead", [-0.01, 0.25, math.nan])
def test_the_lead_is_checked(lead: float) -> None:
    with pytest.raises(ConfigError):
        ReachLeanConfig(lead=lead)


@pytest.mark.parametrize("label, option, roll_free, expected", [
    ("pull_up", True, False, 0.03),  # the lean acts (its robot gate off for Stubby): the lead too
    ("pull_up", True, True, None),  # Stubby's legs roll their feet: no lean, no lead
    ("pull_up", False, False, None),  # the lead unset
    ("shake_hands", True, False, None),  # the person stands (seated_only): no lean, no lead
])
def test_the_simulator_sets_the_lead_only_where_the_lean_acts(label: str, option: bool, roll_free: bool,
                                                              expected: float | None) -> None:
    inter = list(generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=1)).of_label(label))[0]
    lean = ReachLeanConfig(roll_free=roll_free, lead=0.03 if option else None)
    sim = Simulator("ours", label, dataclasses.replace(SimConfig.standing(), reach_lean=lean))
    sim.reset(inter)
    assert sim._stage.stepper.balance.com.lead == expected
    plain = Simulator("ours", label, SimConfig.standing())  # without reach_lean: never a lead
    plain.reset(inter)
    assert plain._stage.stepper.balance.com.lead is None
