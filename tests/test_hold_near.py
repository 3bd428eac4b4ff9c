"""Feet that do not step back from the person while the hands are about to meet or just parted
(FootLockConfig(hold_near=...), with hold_in_contact): the gap's decision (within d_n, beyond it the targets decide;
unmeasured gaps never count; off without the option or without hold_in_contact), the direction's decision (a step
away from the person held, one toward it taken; the sign written out by hand), the settings' check, and the
simulator passing the last frame's gaps and the person (a standing Stubby pull-up changes only with the option)."""

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
AWAY = ANKLES + np.array([[0.3, 0.0, 0.1], [0.0, 0.0, 0.0]])  # the left target steps 30 cm, 10 cm up


BEHIND = np.array([-1.0, 0.1])  # the person behind the left foot's step (+x): the step moves away from them
AHEAD = np.array([1.0, 0.1])  # the person ahead: the step moves toward them


def _left_stays(config: FootLockConfig, gaps: list[float | None], touching: bool = False,
                person: np.ndarray | None = BEHIND) -> bool:
    lock = FootLock(HOME, config)
    lock.apply(ANKLES)
    out = lock.apply(AWAY, touching, near=lock.near(gaps), person=person)
    stays = bool(np.allclose(out[0], ANKLES[0]))
    assert (lock.planted[0] is not None) == stays
    return stays


def test_near_is_the_gap_within_hold_near() -> None:
    lock = FootLock(HOME, FootLockConfig(hold_in_contact=True, hold_near=0.1))
    assert lock.near([0.1]) and lock.near([None, 0.05]) and lock.near([-0.02])
    assert not lock.near([0.1000001]) and not lock.near([None]) and not lock.near([])
    assert not FootLock(HOME, FootLockConfig(hold_in_contact=True)).near([0.0])  # off: never near


def test_planted_feet_do_not_step_away_while_a_gap_is_within_hold_near() -> None:
    on = FootLockConfig(hold_lift=0.12, hold_in_contact=True, hold_near=0.1)
    assert _left_stays(on, [0.05])  # near, stepping away from the person: held
    assert not _left_stays(on, [0.05], person=AHEAD)  # near, stepping toward the person: taken
    assert not _left_stays(on, [0.05], person=None)
    assert not _left_stays(on, [0.15])  # farther: the target decides (it steps)
    assert not _left_stays(on, [None])
    assert _left_stays(on, [0.5], touching=True)  # touching holds as before
    off = FootLockConfig(hold_lift=0.12, hold_in_contact=True)
    assert not _left_stays(off, [0.05])
    no_hold = FootLockConfig(hold_lift=0.12, hold_near=0.1)  # needs hold_in_contact
    assert not _left_stays(no_hold, [0.05])


def test_backing_is_the_sign_of_the_step_along_the_direction_to_the_person() -> None:
    lock = FootLock(HOME, FootLockConfig(hold_in_contact=True, hold_near=0.1))
    lock.apply(ANKLES)  # planted at (0, ±0.1)
    t = ANKLES + np.array([[0.1, 0.0, 0.0], [0.0, 0.05, 0.0]])  # left +x; right +y (toward the left foot's side)
    # person at (0.5, 1.0): from the left foot (0, 0.1) the direction (0.5, 0.9): left step (0.1, 0)·(0.5, 0.9) > 0
    # (toward); from the right foot (0, -0.1) (0.5, 1.1): right step (0, 0.05)·(0.5, 1.1) > 0 (toward)
    assert lock.backing(t, np.array([0.5, 1.0])) == (False, False)
    # person at (-0.5, -1.0): left (0.1, 0)·(-0.5, -1.1) < 0, right (0, 0.05)·(-0.5, -0.9) < 0: both away
    assert lock.backing(t, np.array([-0.5, -1.0])) == (True, True)
    # person at (0.5, -1.0): left (0.1, 0)·(0.5, -1.1) > 0 toward; right (0, 0.05)·(0.5, -0.9) < 0 away
    assert lock.backing(t, np.array([0.5, -1.0])) == (False, True)
    lock.planted[1] = None
    assert lock.backing(t, np.array([-0.5, -1.0])) == (True, False)  # a foot not planted never backs


def test_near_does_not_count_as_a_touch_for_the_glides() -> None:
    """``glide_until_contact`` latches on a contact that held, not on a near gap."""
    c = FootLockConfig(hold_lift=0.12, hold_in_contact=True, hold_near=0.1, glide_step=0.05,
                       glide_until_contact=True)
    lock = FootLock(HOME, c)
    lock.apply(ANKLES)
    lock.apply(ANKLES, False, near=True, person=BEHIND)
    assert not lock._touched
    lock.apply(ANKLES, True)
    assert lock._touched


def test_hold_near_is_checked() -> None:
    with pytest.raises(ConfigError, match="hold_near"):
        FootLockConfig(hold_in_contact=True, hold_near=-0.01)
    assert FootLockConfig().hold_near is None
    assert FootLockConfig(hold_near=0.0).hold_near == 0.0


def test_the_simulator_passes_the_last_frames_gaps() -> None:
    """On a standing Stubby pull-up (spent instance pull_up_120) the foot lock gets ``near=True`` in some call only
    with the option on and not gated by ``hold_near_roll_free`` (Stubby's feet's roll is not freed)."""
    inter = generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=121)).by_id("pull_up_120")
    base = SimConfig.standing()
    off = dataclasses.replace(base.foot_lock, hold_near=None, hold_near_roll_free=False)
    calls = {name: foot_lock_keyword(dataclasses.replace(base, foot_lock=lock), inter, "near")[0] for name, lock in (
        ("off", off), ("on", dataclasses.replace(off, hold_near=0.5)),
        ("gated", dataclasses.replace(off, hold_near=0.5, hold_near_roll_free=True)))}
    assert calls["off"] and not any(calls["off"])
    assert any(calls["on"])
    assert calls["gated"] and not any(calls["gated"])  # Stubby's feet's roll is not freed: the gate keeps it off
