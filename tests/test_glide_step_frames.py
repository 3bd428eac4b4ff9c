"""Glide steps held for more than one frame (``FootLockConfig.glide_step_frames``, :mod:`socialaff_sim.sim.footlock`):
a gliding foot stays lifted toward the glide's latest point for n_g data frames, the other foot held where it
stands, and is put down after them."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import FOOT_ANKLES as ANKLES, planted_lock

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.footlock import FootLockConfig
from socialaff_sim.sim.sim_config import STANDING_FOOT_LOCK

GLIDE = np.array([0.06, 0.0, 0.0])  # 6 cm along the floor: beyond the lock's 5 cm radius
H = 0.05
RIGHT = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])


def _walk(n: int, frames: int) -> list[tuple[tuple[bool, bool], np.ndarray, int]]:
    """A right foot gliding 6 cm a frame for ``frames`` frames under ``glide_step_frames=n``; the left target stays
    where it is planted. Returns per frame (standing, targets, glide steps so far)."""
    lock = planted_lock(dataclasses.replace(STANDING_FOOT_LOCK, glide_gap=None, glide_step_frames=n))
    out = []
    for k in range(1, frames + 1):
        targets = ANKLES + k * GLIDE[0] * RIGHT
        res = lock.apply(targets, physical=targets)
        out.append((lock.standing, res, lock.glide_steps))
    return out


def test_one_frame_steps_land_at_the_next_frame() -> None:
    walk = _walk(1, 2)
    assert walk[0][0] == (True, False) and walk[0][2] == 1  # lifted in the first frame
    assert walk[1][0] == (True, True)  # put down in the second (one frame)
    np.testing.assert_allclose(walk[1][1][1], ANKLES[1] + 2 * GLIDE)


@pytest.mark.parametrize("n", [2, 3])
def test_a_step_stays_lifted_for_n_frames_toward_the_latest_point(n: int) -> None:
    walk = _walk(n, n + 1)
    for k in range(n):  # lifted n frames, one step counted, the left foot held where it is planted
        standing, res, steps = walk[k]
        assert standing == (True, False) and steps == 1
        np.testing.assert_allclose(res[1], ANKLES[1] + (k + 1) * GLIDE + [0.0, 0.0, H])  # the latest point, raised
        np.testing.assert_allclose(res[0], ANKLES[0])
    standing, res, _ = walk[n]
    assert standing == (True, True)  # put down after n frames
    np.testing.assert_allclose(res[1], ANKLES[1] + (n + 1) * GLIDE)


def test_a_solve_again_within_a_frame_does_not_count_a_frame() -> None:
    lock = planted_lock(dataclasses.replace(STANDING_FOOT_LOCK, glide_gap=None, glide_step_frames=2))
    moved = ANKLES + GLIDE * RIGHT
    lock.apply(moved, physical=moved)
    for _ in range(3):
        lock.apply(moved, physical=moved, new_frame=False)
        assert lock.standing == (True, False)
    lock.apply(moved, physical=moved)  # the second frame: still lifted
    assert lock.standing == (True, False)
    lock.apply(moved, physical=moved)  # the third: down
    assert lock.standing == (True, True)


def test_a_lifted_target_keeps_the_step_height() -> None:
    lock = planted_lock(dataclasses.replace(STANDING_FOOT_LOCK, glide_gap=None, glide_step_frames=2))
    moved = ANKLES + GLIDE * RIGHT
    lock.apply(moved, physical=moved)
    up = moved + [[0.0, 0.0, 0.0], [0.05, 0.0, 0.2]]  # a real step's target (above lift): not followed
    res = lock.apply(up, physical=up)
    np.testing.assert_allclose(res[1], moved[1] + [0.0, 0.0, H])


@pytest.mark.parametrize("bad", [0, -1, 1.5])
def test_bad_frame_counts_are_refused(bad) -> None:  # noqa: ANN001
    with pytest.raises(ConfigError):
        FootLockConfig(glide_step=H, glide_step_frames=bad)
