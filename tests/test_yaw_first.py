"""``BalanceConfig.yaw_first`` on the Unitree H1 (skipped without ../shared/robots): in a standing handshake the H1's
first balance QP fails in a share of its driven steps (the feet's twelve hard rows, legs of five joints, the arms'
torque limits); with the option such steps are solved with the ten rows that do not turn the feet about the
vertical, and at most 1 % of the driven steps (none on the machine that measured it in session 31; one of 541 on an
AMD EPYC, whose floating point differs) still falls back to dropping all of them; without it they all do. Stubby's
configuration error too."""

from __future__ import annotations

import dataclasses

import pytest

from conftest import shared_robot
from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.simulator import SimConfig, Simulator


@pytest.fixture(scope="module")
def h1_handshake():  # noqa: ANN201
    spec = load_robot("unitree_h1", mjcf=shared_robot("unitree_h1", "h1.xml"))
    inter = list(generate_dataset(0, SyntheticConfig(interactions=("shake_hands",),
                                                     instances_per_interaction=2)))[1]
    return spec, inter


def _counts(spec, inter, yaw_first: bool) -> tuple[int, int, int]:  # noqa: ANN001
    cfg = SimConfig.standing()  # without the H1's freed roll (adopted in session 33), which removes the infeasibility
    cfg = dataclasses.replace(cfg, balance=dataclasses.replace(
        cfg.balance, yaw_first=yaw_first, flat_roll_free=False, hand_task=None, hand_task_roll_free=False,
        hand_task_arm_weight=None, hand_task_plan_velocity=False, hand_task_velocity_until_touch=False))
    sim = Simulator(spec, "shake_hands", cfg)
    run_episode(sim, GroundTruthSource(), inter)
    bal = sim._stage.stepper.balance
    return bal.active_steps, bal.relaxed_steps, bal.yaw_dropped_steps


def test_the_h1s_infeasible_steps_keep_every_row_but_the_feets_turn(h1_handshake) -> None:  # noqa: ANN001
    spec, inter = h1_handshake
    active, relaxed_without, dropped = _counts(spec, inter, False)
    assert active > 0 and relaxed_without > 0.1 * active and dropped == 0
    active, relaxed, dropped = _counts(spec, inter, True)
    # Not "== 0": which of these near-infeasible steps the solver settles differs in the last bits between CPUs.
    assert active > 0 and dropped > 0.1 * active and relaxed <= 0.01 * active and relaxed < 0.1 * relaxed_without


def test_yaw_first_needs_flat_feet() -> None:
    with pytest.raises(ConfigError, match="yaw_first"):
        BalanceConfig(solver="qp", yaw_first=True)
    assert BalanceConfig(solver="qp", flat_feet=True, yaw_first=True).yaw_first
    assert not SimConfig.standing().balance.yaw_first  # off unless a rule adopts it
