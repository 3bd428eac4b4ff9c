"""The harness's release after a touch at a larger tilt, in a throw's catch, on a robot whose feet's roll is freed
(BalanceConfig(release_tilt_touched=θ_t)): the decision (after a touch and on such a robot the bound θ_t, boundary
included; before a touch, on another robot, outside a catch task or without the option ``release_tilt``; the catch's
``catch_tilt`` unchanged), the settings' check, the gates (Stubby's controller gets no bound and its standing throw
runs bit for bit as without the option; the H1's gets it and its throw changes, its handshake gets none), and the
controller passing the touch latch."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.balance_control import BalanceConfig
from socialaff_sim.sim.harness_release import HarnessRelease
from socialaff_sim.sim.sim_config import STANDING_BALANCE
from socialaff_sim.sim.support_box import SupportBox

from conftest import shared_robot, spy_harness_decide

BASE = STANDING_BALANCE  # (flat_roll_free, arm_compensation and compensation_gate, which the option needs)
ON = dataclasses.replace(BASE, release_tilt_touched=8.0)
BOX = SupportBox(np.array([[-0.1, -0.15], [0.1, -0.15], [-0.1, 0.15], [0.1, 0.15]]), np.array([1.0, 0.0]))
MIDDLE = np.zeros(2)


def _released(scene, config: BalanceConfig, roll_freed: bool, tilt: float, touched: bool) -> bool:  # noqa: ANN001
    h = HarnessRelease(scene, config, roll_freed)
    d = mujoco.MjData(scene.model)
    h.decide(d, 0.2, True, tilt, BOX, MIDDLE, touched)  # planted for 0.2 s (> release_delay), capture in the middle
    return h.released


def test_after_a_touch_a_roll_freed_robot_is_let_go_up_to_the_touched_tilt(scene) -> None:  # noqa: ANN001
    on = ON
    for tilt, touched, roll_freed, expected in (
            (4.9, False, True, True),  # within release_tilt: let go with or without a touch
            (6.0, False, True, False),  # before a touch: release_tilt (5°) holds it
            (6.0, True, True, True),  # after a touch on a roll-freed robot: θ_t (8°)
            (8.0, True, True, True),  # the bound included
            (8.1, True, True, False),
            (6.0, True, False, False)):  # a robot whose feet's roll is not freed: release_tilt
        assert _released(scene, on, roll_freed, tilt, touched) == expected, (tilt, touched, roll_freed)
    assert not _released(scene, BASE, True, 6.0, True)  # off
    h = HarnessRelease(scene, on, True)
    assert h.tilt_touched == 8.0 and h.release_tilt(True) == 8.0 and h.release_tilt(False) == 5.0
    assert HarnessRelease(scene, on, False).tilt_touched is None
    assert HarnessRelease(scene, BASE, True).release_tilt(True) == 5.0
    h.gate_touched(False)  # a task without a catch sub-goal
    assert h.tilt_touched is None and h.release_tilt(True) == 5.0
    h.gate_touched(True)
    assert h.tilt_touched == 8.0


def test_the_catch_is_unchanged(scene) -> None:  # noqa: ANN001
    h = HarnessRelease(scene, ON, True)
    d = mujoco.MjData(scene.model)
    h.decide(d, 0.2, True, 7.0, BOX, MIDDLE, True)
    assert h.released
    h.decide(d, 0.002, True, 11.9, BOX, MIDDLE, True)  # within catch_tilt (12°): stays released
    assert h.released and h.catches == 0
    h.decide(d, 0.002, True, 12.1, BOX, MIDDLE, True)
    assert not h.released and h.catch_reasons["tilt"] == 1


@pytest.mark.parametrize("kw", [{"release_tilt_touched": 8.0, "flat_roll_free": False, "hand_task_roll_free": False},
                                {"release_tilt_touched": 4.0}, {"release_tilt_touched": 12.0},
                                {"release_tilt_touched": 8.0, "compensation_gate": None, "shift_until_touch": False,
                                 "plan_velocity_until_touch": False, "hand_task_velocity_until_touch": False,
                                 "touch_friction": None, "shear_couple": None, "shear_couple_touched": False}])
def test_release_tilt_touched_is_checked(kw) -> None:  # noqa: ANN001
    with pytest.raises(ConfigError, match="release_tilt_touched"):
        dataclasses.replace(BASE, **kw)
    assert dataclasses.replace(BASE, release_tilt_touched=5.0).release_tilt_touched == 5.0  # release_tilt itself is allowed


def _throw(robot, instance: str, **balance):  # noqa: ANN001, ANN003, ANN202
    from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode
    from socialaff_sim.sim.simulator import SimConfig, Simulator

    n = int(instance.rsplit("_", 1)[1]) + 1
    inter = generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=n)).by_id(instance)
    cfg = SimConfig.standing()
    cfg = dataclasses.replace(cfg, balance=dataclasses.replace(cfg.balance, **balance))
    sim = Simulator(robot, "throw_catch", cfg)
    touched: list[bool] = []

    m = run_episode(sim, GroundTruthSource(), inter, on_frame=spy_harness_decide(
        lambda a, k: touched.append(bool(a[6]) if len(a) > 6 else bool(k.get("touched", False)))))
    return sim._stage.stepper.balance, m, touched


KEYS = ("support", "subgoals", "success", "failures")


def test_stubby_runs_bit_for_bit_as_without_the_option() -> None:
    """Stubby's feet's roll is not freed: its controller gets no bound, no call passes a touch, and its standing throw
    (spent instance throw_catch_120) is the same, figure for figure."""
    bal, m_off, _ = _throw("ours", "throw_catch_120")
    bal_on, m_on, touched = _throw("ours", "throw_catch_120", release_tilt_touched=8.0)
    assert bal.roll_freed is False and bal_on.harness.tilt_touched is None
    assert touched and not any(touched)
    assert all(m_on[k] == m_off[k] for k in KEYS)


def test_the_h1_gets_the_bound_and_its_throw_changes() -> None:
    """The H1 (skipped without ../shared/robots): its controller frees the feet's roll and gets θ_t; the touch latch
    reaches the harness (calls without and then with a touch, never back), and its throw on spent throw_catch_433,
    which A holds by the release's tilt after the catch, changes (so the Stubby check above can fail)."""
    from socialaff_sim.retarget.robot import load_robot

    spec = load_robot("unitree_h1", mjcf=shared_robot("unitree_h1", "h1.xml"))
    bal, m_off, touched_off = _throw(spec, "throw_catch_433")
    assert bal.harness.tilt_touched is None and not any(touched_off)
    bal_on, m_on, touched = _throw(spec, "throw_catch_433", release_tilt_touched=8.0)
    assert bal_on.roll_freed and bal_on.harness.tilt_touched == 8.0
    assert not touched[0] and touched[-1] and touched == sorted(touched)
    assert any(m_on[k] != m_off[k] for k in KEYS)
    from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode
    from socialaff_sim.sim.simulator import SimConfig, Simulator

    # a handshake (no catch sub-goal): the simulator drops the bound at the episode's start
    cfg = SimConfig.standing()
    cfg = dataclasses.replace(cfg, balance=dataclasses.replace(cfg.balance, release_tilt_touched=8.0))
    sim = Simulator(spec, "shake_hands", cfg)
    inter = generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=121)).by_id("shake_hands_120")
    run_episode(sim, GroundTruthSource(), inter)
    assert sim._stage.stepper.balance.harness.tilt_touched is None
