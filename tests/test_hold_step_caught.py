"""No steps of a caught robot near the meeting (FootLockConfig(hold_step_caught=...)): the gap's flag (within d_c,
boundary included; unmeasured gaps never count; off without the option), the step's decision (a planted foot's step
is planted at once only when both ``still_caught`` and ``caught`` hold; either one alone leaves the step taken), the
settings' check, the gate (not dropped on Stubby by ``hold_near_roll_free``), and the simulator passing the flag on a
standing Stubby pull-up only with the option on."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.footlock import FootLock, FootLockConfig
from socialaff_sim.sim.simulator import SimConfig

from conftest import foot_lock_keyword

HOME = (0.08, 0.08)
ANKLES = np.array([[0.0, 0.1, 0.08], [0.0, -0.1, 0.08]])
ON = FootLockConfig(hold_lift=0.12, hold_in_contact=True, hold_step_caught=0.3)
LIFTED = ANKLES + np.array([[0.26, 0.0, 0.07], [0.0, 0.0, 0.0]])  # 26 cm forward and 7 cm up (pull_up_561's step)


def _left(config: FootLockConfig, still_caught: bool, caught: bool) -> tuple[np.ndarray | None, np.ndarray]:
    lock = FootLock(HOME, config)
    lock.apply(ANKLES)  # both planted at home
    out = lock.apply(LIFTED, False, caught=caught, still_caught=still_caught)
    assert np.allclose(out[1], ANKLES[1])
    return lock.planted[0], out


@pytest.mark.parametrize("gaps", [None, [], [None], [0.35, None], [0.3], [0.08, 0.9], [1.2]])
def test_the_flag_is_a_gap_within_d_c(gaps) -> None:  # noqa: ANN001
    flags = FootLock(HOME, ON).gap_flags(None if gaps is None else iter(gaps))
    measured = [x for x in (gaps or []) if x is not None]
    assert flags["still_caught"] == any(x <= 0.3 for x in measured)
    assert not FootLock(HOME, FootLockConfig(hold_in_contact=True)).gap_flags([0.0])["still_caught"]  # off: never


def test_a_caught_robots_step_near_the_meeting_is_planted_at_once() -> None:
    p, out = _left(ON, still_caught=True, caught=True)
    assert p is not None and np.allclose(p, [LIFTED[0][0], LIFTED[0][1], HOME[0]])  # planted, on the floor
    assert np.allclose(out[0], p)


@pytest.mark.parametrize(("still_caught", "caught"), [(True, False), (False, True), (False, False)])
def test_without_both_the_step_is_taken(still_caught: bool, caught: bool) -> None:
    p, out = _left(ON, still_caught=still_caught, caught=caught)
    assert p is None and np.allclose(out[0], LIFTED[0])  # lifted: the target followed


def test_the_setting_is_checked_and_off_by_default() -> None:
    with pytest.raises(ConfigError, match="hold_step_caught"):
        FootLockConfig(hold_step_caught=-0.01)
    assert FootLockConfig().hold_step_caught is None and SimConfig.standing().foot_lock.hold_step_caught is None


def test_hold_near_roll_free_keeps_it() -> None:
    lock = FootLockConfig(hold_in_contact=True, hold_near=0.1, hold_near_roll_free=True, hold_step_caught=0.3)
    got = lock.for_episode(plan_feet=True, causal=True, counts_above=False, roll_freed=False)
    assert got.hold_step_caught == 0.3 and got.hold_near is None


def test_the_simulator_passes_the_flag_only_with_the_option() -> None:
    """A standing Stubby pull-up (spent instance pull_up_120): ``still_caught=True`` in some call only with the option."""
    inter = generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=121)).by_id("pull_up_120")
    base = SimConfig.standing()
    off, _ = foot_lock_keyword(base, inter, "still_caught")
    on, cfg = foot_lock_keyword(dataclasses.replace(base, foot_lock=dataclasses.replace(base.foot_lock,
                                                                                        hold_step_caught=0.3)),
                                inter, "still_caught")
    assert off and not any(off)
    assert any(on) and cfg.hold_step_caught == 0.3
