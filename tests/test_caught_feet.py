"""The caught robot's planted feet planted again where they stand (``FootLockConfig.follow_caught``,
:mod:`socialaff_sim.sim.caught_feet`): while the harness holds a robot it has caught after a sub-goal's contact first held, each planted foot's point is
its physical ankle frame (horizontally, at the home height), so the servos do not drag the feet back."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import FOOT_ANKLES as ANKLES, FOOT_HOME as HOME, planted_lock

from socialaff_sim.errors import SimulationError
from socialaff_sim.sim.caught_feet import follow_physical
from socialaff_sim.sim.footlock import FootLock, FootLockConfig
from socialaff_sim.sim.sim_config import STANDING_FOOT_LOCK, SimConfig

# The physical ankles 4 cm behind and 1.5 cm outward of where they were planted, the right one 0.6 cm rolled up.
PHYSICAL = ANKLES + [[-0.04, 0.015, 0.0], [-0.04, -0.015, 0.006]]


def test_follow_physical_moves_each_planted_point_onto_its_ankle_horizontally_and_keeps_its_height() -> None:
    planted = [ANKLES[0].copy(), None]
    before = [p if p is None else p.copy() for p in planted]
    out = follow_physical(planted, PHYSICAL)
    # By hand: x, y of the physical left ankle, z of the planted point; the stepping foot stays None.
    assert out[1] is None
    np.testing.assert_allclose(out[0], [-0.04, 0.115, 0.08])
    np.testing.assert_array_equal(planted[0], before[0])  # the input untouched
    both = follow_physical([ANKLES[0], ANKLES[1] + [0.0, 0.0, 0.01]], PHYSICAL)
    np.testing.assert_allclose(both[1], [-0.04, -0.115, 0.09])
    with pytest.raises(SimulationError):
        follow_physical([ANKLES[0]], PHYSICAL)
    with pytest.raises(SimulationError):
        follow_physical([ANKLES[0], ANKLES[1]], PHYSICAL[:, :2])


def test_a_caught_robots_feet_are_planted_where_they_stand_and_not_otherwise() -> None:
    on = dataclasses.replace(STANDING_FOOT_LOCK, follow_caught=True)
    lock = planted_lock(on)
    out = lock.apply(ANKLES, touching=True, physical=PHYSICAL, caught=True)
    expect = np.array([[-0.04, 0.115, 0.08], [-0.04, -0.115, 0.08]])
    np.testing.assert_allclose(out, expect)
    assert lock.standing == (True, True)
    np.testing.assert_allclose(np.array(lock.planted), expect)
    # Not caught (released, or held before any catch): the points stay where the feet came down.
    lock = planted_lock(on)
    out = lock.apply(ANKLES, touching=True, physical=PHYSICAL, caught=False)
    np.testing.assert_allclose(out, ANKLES)
    # Caught before any contact held (the walk-up): the harness carries the feet along the plan as before.
    lock = planted_lock(on)
    out = lock.apply(ANKLES, touching=False, physical=PHYSICAL, caught=True)
    np.testing.assert_allclose(out, ANKLES)
    # ... and once a contact has held, also in a frame whose contact lapsed.
    lock.apply(ANKLES, touching=True, physical=ANKLES, caught=False)
    out = lock.apply(ANKLES, touching=False, physical=PHYSICAL, caught=True)
    np.testing.assert_allclose(out, [[-0.04, 0.115, 0.08], [-0.04, -0.115, 0.08]])
    # Without the option a caught robot's feet stay planted where they came down too.
    lock = planted_lock(STANDING_FOOT_LOCK)
    out = lock.apply(ANKLES, touching=True, physical=PHYSICAL, caught=True)
    np.testing.assert_allclose(out, ANKLES)


def test_a_stepping_foot_is_not_planted_by_it_and_the_other_follows() -> None:
    on = FootLockConfig(follow_caught=True)
    lock = planted_lock(on)
    raised = ANKLES + [[0.0, 0.0, 0.0], [0.0, 0.0, 0.2]]  # the right foot's target 20 cm up: a step
    out = lock.apply(raised, touching=True, physical=PHYSICAL, caught=True)
    assert lock.standing == (True, False)
    np.testing.assert_allclose(out[0], [-0.04, 0.115, 0.08])
    np.testing.assert_allclose(out[1], raised[1])


def test_it_needs_the_physical_ankles_and_is_off_by_default() -> None:
    assert FootLockConfig().follow_caught is False
    assert SimConfig.standing().foot_lock.follow_caught is False  # type: ignore[union-attr]
    assert not FootLock(HOME, FootLockConfig()).needs_physical
    lock = FootLock(HOME, FootLockConfig(follow_caught=True))
    assert lock.needs_physical
    with pytest.raises(SimulationError):
        lock.apply(ANKLES)
