"""Catch-up steps (:mod:`socialaff_sim.sim.catch_up`, ``FootLockConfig.catch_up``): a planted foot that is not
where it is planted steps there."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import planted_feet_error

from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.errors import ConfigError, SimulationError
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.catch_up import CatchUp
from socialaff_sim.sim.footlock import FootLock, FootLockConfig
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.stance import StanceConfig

HOME = (0.08, 0.08)
ANKLES = np.array([[0.0, 0.1, 0.08], [0.0, -0.1, 0.08]])


def test_a_foot_far_from_its_point_is_lifted_onto_it_and_put_down_when_there() -> None:
    lock = FootLock(HOME, FootLockConfig(catch_up=0.05, catch_up_height=0.06, catch_up_frames=3))
    out = lock.apply(ANKLES, physical=ANKLES)  # both planted where they stand: nothing to catch up
    np.testing.assert_allclose(out, ANKLES)
    assert lock.standing == (True, True)
    behind = ANKLES - np.array([[0.0, 0.0, 0.0], [0.2, 0.0, 0.0]])  # the right foot stands 20 cm short
    out = lock.apply(ANKLES, physical=behind)
    np.testing.assert_allclose(out[1], ANKLES[1] + [0.0, 0.0, 0.06])  # lifted above its point
    np.testing.assert_allclose(out[0], ANKLES[0])  # the other stays down
    assert lock.standing == (True, False) and lock.catch_up.steps == 1
    halfway = ANKLES - np.array([[0.0, 0.0, 0.0], [0.04, 0.0, 0.0]])  # 4 cm off: more than d_c / 2, still up
    out = lock.apply(ANKLES, physical=halfway)
    assert lock.standing == (True, False) and out[1, 2] == pytest.approx(0.14)
    for _ in range(3):  # solved again within the frame: the frame's decision stands (no frame counted)
        np.testing.assert_allclose(lock.apply(ANKLES, physical=halfway, new_frame=False)[1], out[1])
    assert lock.catch_up.lifted == [0, 2]
    there = ANKLES - np.array([[0.0, 0.0, 0.0], [0.02, 0.0, 0.0]])  # within d_c / 2: put down on its point
    out = lock.apply(ANKLES, physical=there)
    np.testing.assert_allclose(out, ANKLES)
    assert lock.standing == (True, True)


def test_a_foot_within_the_distance_stays_down_and_only_the_farther_foot_steps() -> None:
    lock = FootLock(HOME, FootLockConfig(catch_up=0.05))
    lock.apply(ANKLES, physical=ANKLES)
    near = ANKLES + np.array([[0.049, 0.0, 0.0], [0.0, 0.0, 0.0]])  # 4.9 cm: within d_c
    lock.apply(ANKLES, physical=near)
    assert lock.standing == (True, True)
    both = ANKLES + np.array([[0.08, 0.0, 0.0], [0.0, 0.12, 0.0]])  # both off: the farther (right) first
    lock.apply(ANKLES, physical=both)
    assert lock.standing == (True, False)


def test_a_lifted_foot_is_put_down_after_its_frames_and_rests_a_frame() -> None:
    cu = CatchUp(0.05, 0.06, 2)
    planted = [ANKLES[0].copy(), ANKLES[1].copy()]
    stuck = ANKLES + np.array([[0.0, 0.0, 0.0], [0.3, 0.0, 0.0]])  # never gets there
    cu.update(planted, stuck, True)
    assert cu.lifted == [0, 1]
    cu.update(planted, stuck, True)
    assert cu.lifted == [0, 2]
    cu.update(planted, stuck, True)  # after N_c = 2 frames: down, and no new step in this frame
    assert cu.lifted == [0, 0]
    cu.update(planted, stuck, True)  # next frame: it tries again
    assert cu.lifted == [0, 1] and cu.steps == 2


def test_no_catch_up_while_a_contact_holds_with_hold_in_contact_or_a_foot_steps() -> None:
    behind = ANKLES - np.array([[0.0, 0.0, 0.0], [0.2, 0.0, 0.0]])
    for hold, touching, lifts in ((True, True, False), (True, False, True), (False, True, True)):
        lock = FootLock(HOME, FootLockConfig(catch_up=0.05, hold_in_contact=hold))
        lock.apply(ANKLES, physical=ANKLES)
        lock.apply(ANKLES, touching, physical=behind)
        assert (lock.standing == (True, False)) == lifts
    # a lifted foot is put down when a contact begins to hold
    lock = FootLock(HOME, FootLockConfig(catch_up=0.05, hold_in_contact=True))
    lock.apply(ANKLES, physical=ANKLES)
    lock.apply(ANKLES, physical=behind)
    assert lock.standing == (True, False)
    np.testing.assert_allclose(lock.apply(ANKLES, True, physical=behind), ANKLES)
    assert lock.standing == (True, True)
    # one foot stepping (its target lifted away): the other is not lifted, however far it stands
    cu = CatchUp(0.05, 0.06, 3)
    cu.update([ANKLES[0], None], behind, True)
    assert cu.lifted == [0, 0]


def test_without_catch_up_nothing_changes_and_the_settings_are_checked() -> None:
    plain, cu = FootLock(HOME, FootLockConfig()), FootLock(HOME, FootLockConfig(catch_up=0.05))
    behind = ANKLES - np.array([[0.0, 0.0, 0.0], [0.2, 0.0, 0.0]])
    for lock in (plain, cu):
        lock.apply(ANKLES, physical=ANKLES)
    np.testing.assert_allclose(plain.apply(ANKLES, physical=behind), ANKLES)
    assert plain.standing == (True, True) and plain.catch_up is None
    with pytest.raises(SimulationError, match="catch_up"):
        cu.apply(ANKLES)
    for kw in ({"catch_up": 0.0}, {"catch_up": 0.05, "catch_up_height": 0.0}, {"catch_up": 0.05, "catch_up_frames": 0}):
        with pytest.raises(ConfigError, match="catch_up"):
            FootLockConfig(**kw)


def test_catch_up_brings_a_standing_robots_feet_to_where_the_ik_plans_them() -> None:
    """Stubby replaying shake_hands_001 (synthetic, seed 0) on the balance QP: its feet come down short of their
    planted points during the walk-up and stand there (the IK plans them elsewhere); with catch-up steps the
    physical ankles stand closer to the planted points in the frames where both feet stand, and steps were
    taken."""
    inter = next(i for i in generate_dataset(seed=0) if i.instance_id == "shake_hands_001")
    qp = BalanceConfig(solver="qp", sole_gap=0.01, w_torso=3.0)
    errors, steps = [], []
    for catch in (None, 0.05):
        lock = FootLockConfig(hold_lift=0.12, hold_in_contact=True, catch_up=catch, catch_up_quiet=10)
        sim = Simulator("ours", "shake_hands", SimConfig(foot_lock=lock, balance=qp, stance=StanceConfig(release=False)))
        errors.append(planted_feet_error(sim, inter))
        steps.append(0 if sim._footlock.catch_up is None else sim._footlock.catch_up.steps)
    assert steps[0] == 0 and steps[1] > 0
    assert errors[1] < 0.75 * errors[0]
