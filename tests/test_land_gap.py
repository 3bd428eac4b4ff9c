"""Steps near the grip that last one frame (FootLockConfig(land_gap=...)): the gap's decision (within d_l, boundary
included; unmeasured gaps never count; off without the option), the landing's decision (a foot lifted in an earlier
frame is put down at its target's horizontal point at the home height whatever its target's height, only in a new
frame and only with ``land``; a foot that lifts in this frame is not put down in it) and the settings' check. The
simulator passing the last frame's gaps to ``land`` is tested with ``hold_step_gap``'s ``still`` in
tests/test_hold_step_gap.py (one parametrized test for both options)."""

from __future__ import annotations

import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.footlock import FootLock, FootLockConfig

HOME = (0.08, 0.08)
ANKLES = np.array([[0.0, 0.1, 0.08], [0.0, -0.1, 0.08]])
ON = FootLockConfig(hold_lift=0.12, hold_in_contact=True, land_gap=0.1)
LIFTED = ANKLES + np.array([[0.07, 0.02, 0.09], [0.0, 0.0, 0.0]])  # the left target 7 cm on, 9 cm up (a step)
HIGHER = ANKLES + np.array([[0.09, 0.03, 0.10], [0.0, 0.0, 0.0]])  # the next frame: 2 cm on, still 10 cm up


def _lifted_lock(config: FootLockConfig, land_first: bool = False) -> FootLock:
    lock = FootLock(HOME, config)
    lock.apply(ANKLES)
    lock.apply(LIFTED, land=land_first)  # the left foot steps (beyond radius, above lift)
    assert lock.planted[0] is None  # lifted in this frame: not put down in it, land or not
    return lock


def test_landing_is_the_gap_within_land_gap() -> None:
    lock = FootLock(HOME, ON)
    assert lock.landing([0.1]) and lock.landing([None, 0.05]) and lock.landing([-0.02])
    assert not lock.landing([0.1000001]) and not lock.landing([None]) and not lock.landing([])
    assert not FootLock(HOME, FootLockConfig(hold_in_contact=True)).landing([0.0])  # off: never


def test_a_lifted_foot_is_put_down_at_its_targets_point_in_the_next_frame_only_with_land() -> None:
    lock = _lifted_lock(ON, land_first=True)
    out = lock.apply(HIGHER, land=True)
    # put down at the target's horizontal point (0.09, 0.13) at the home height 0.08, not at the target's 0.18
    assert np.allclose(out[0], [0.09, 0.13, 0.08]) and np.allclose(lock.planted[0], [0.09, 0.13, 0.08])
    assert np.allclose(out[1], ANKLES[1])  # the standing foot as before
    lock = _lifted_lock(ON)
    out = lock.apply(HIGHER, land=False)  # not near: the step goes on (the target followed, 10 cm up)
    assert lock.planted[0] is None and np.allclose(out[0], HIGHER[0])
    lock = _lifted_lock(ON)
    out = lock.apply(HIGHER, new_frame=False, land=True)  # a solve again within the frame: not put down
    assert lock.planted[0] is None and np.allclose(out[0], HIGHER[0])
    off = FootLockConfig(hold_lift=0.12, hold_in_contact=True)
    lock = _lifted_lock(off)
    lock.apply(HIGHER, land=False)
    assert lock.planted[0] is None


def test_land_gap_is_checked() -> None:
    with pytest.raises(ConfigError, match="land_gap"):
        FootLockConfig(land_gap=-0.01)
    assert FootLockConfig().land_gap is None and FootLockConfig(land_gap=0.0).land_gap == 0.0
