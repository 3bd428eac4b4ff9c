"""A foot that landed short steps again (``FootLockConfig.restep_gap``, :mod:`socialaff_sim.sim.footlock`): a
planted foot whose physical ankle frame stands farther than d_r from the point it is planted at is lifted for a
frame toward its target, as a glide step is, instead of being held where it landed."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import FOOT_ANKLES as ANKLES, FOOT_HOME as HOME, planted_lock

from socialaff_sim.errors import ConfigError, SimulationError
from socialaff_sim.sim.footlock import FootLock, FootLockConfig

H, GAP = 0.05, 0.08
SHORT = np.array([[0.0, 0.0, 0.0], [-0.10, 0.0, 0.0]])  # the right foot stands 10 cm behind where it is planted


def test_a_foot_standing_short_of_its_planted_point_steps_again_then_lands() -> None:
    lock = planted_lock(FootLockConfig(glide_step=H, restep_gap=GAP))
    out = lock.apply(ANKLES, physical=ANKLES + SHORT)  # the targets have not moved; the physical foot is behind
    assert lock.standing == (True, False) and lock.glide_steps == 1
    np.testing.assert_allclose(out[1], ANKLES[1] + [0.0, 0.0, H])  # over its target, raised by h_g
    np.testing.assert_allclose(out[0], ANKLES[0])
    out = lock.apply(ANKLES, physical=ANKLES)  # landed where it is planted: it stands
    assert lock.standing == (True, True) and lock.glide_steps == 1
    np.testing.assert_allclose(out, ANKLES)
    # Without the option it stays planted where the lock put it, however far behind the physical foot stands.
    lock = planted_lock(FootLockConfig(glide_step=H))
    np.testing.assert_allclose(lock.apply(ANKLES, physical=ANKLES + SHORT), ANKLES)
    assert lock.standing == (True, True) and lock.glide_steps == 0


def test_within_the_gap_or_with_the_other_foot_off_the_floor_it_stays() -> None:
    lock = planted_lock(FootLockConfig(glide_step=H, restep_gap=GAP))
    near = ANKLES + [[0.0, 0.0, 0.0], [-0.079, 0.0, 0.0]]  # 7.9 cm < d_r
    np.testing.assert_allclose(lock.apply(ANKLES, physical=near), ANKLES)
    assert lock.standing == (True, True) and lock.glide_steps == 0
    just = ANKLES + [[0.0, 0.0, 0.0], [-0.081, 0.0, 0.0]]  # 8.1 cm > d_r
    lock.apply(ANKLES, physical=just)
    assert lock.standing == (True, False) and lock.glide_steps == 1
    # The other foot lifted by its target (a recorded step): the short foot waits.
    lock = planted_lock(FootLockConfig(glide_step=H, restep_gap=GAP))
    up = np.array([ANKLES[0] + [0.0, 0.0, 0.2], ANKLES[1]])
    lock.apply(up, physical=ANKLES + SHORT)
    assert lock.standing == (False, True) and lock.glide_steps == 0


def test_not_after_the_first_contact_with_glide_until_contact_nor_while_holding_on() -> None:
    lock = planted_lock(FootLockConfig(glide_step=H, restep_gap=GAP, glide_until_contact=True))
    lock.apply(ANKLES, touching=True, physical=ANKLES)
    lock.apply(ANKLES, touching=False, physical=ANKLES + SHORT)
    assert lock.standing == (True, True) and lock.glide_steps == 0
    lock = planted_lock(FootLockConfig(glide_step=H, restep_gap=GAP, hold_in_contact=True))
    lock.apply(ANKLES, touching=True, physical=ANKLES + SHORT)
    assert lock.standing == (True, True) and lock.glide_steps == 0


def test_restep_needs_the_physical_feet_and_a_positive_gap() -> None:
    lock = planted_lock(FootLockConfig(glide_step=H, restep_gap=GAP))
    with pytest.raises(SimulationError, match="physical ankle"):
        lock.apply(ANKLES)
    assert not FootLock(HOME, FootLockConfig(restep_gap=GAP)).needs_physical  # without glide_step: unused
    for bad in (0.0, -0.1):
        with pytest.raises(ConfigError, match="restep_gap"):
            FootLockConfig(restep_gap=bad)
