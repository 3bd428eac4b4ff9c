"""Feet planted where they physically stand (``FootLockConfig.plant_physical``, ``replant``, ``plant_base``): the IK
plans the robot over its feet as they are, the step still judged by the target."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import shared_robot

from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.errors import ConfigError, SimulationError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.footlock import FootLock, FootLockConfig
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.stage import key_frames

HOME = (0.08, 0.09)
TARGETS = np.array([[0.40, 0.10, 0.08], [0.35, -0.10, 0.09]])  # both targets down on the floor
# The physical feet 25 and 20 cm short of them, a little off to the side and above the floor (a rocking sole)
PHYSICAL = np.array([[0.15, 0.12, 0.095], [0.15, -0.07, 0.1]])
ON = FootLockConfig(plant_physical=True)


def test_a_foot_is_planted_where_it_physically_stands_at_its_home_height() -> None:
    lock = FootLock(HOME, ON)
    assert lock.needs_physical
    out = lock.apply(TARGETS, physical=PHYSICAL)
    expected = np.column_stack([PHYSICAL[:, :2], HOME])  # the physical point, horizontally, at home height
    np.testing.assert_allclose(out, expected)
    np.testing.assert_allclose(np.array(lock.planted), expected)
    np.testing.assert_allclose(np.array(lock.aim), np.column_stack([TARGETS[:, :2], HOME]))  # the step's aim: the target
    # Without the option: at the target, the physical feet not needed
    off = FootLock(HOME, FootLockConfig())
    assert not off.needs_physical
    np.testing.assert_allclose(off.apply(TARGETS, physical=PHYSICAL), np.column_stack([TARGETS[:, :2], HOME]))


def test_the_step_is_judged_by_the_target_against_its_aim_not_the_planted_point() -> None:
    lock = FootLock(HOME, ON)  # radius 5 cm
    lock.apply(TARGETS, physical=PHYSICAL)
    # Targets 4.9 cm from their aims (30 cm from the planted points): both stay planted where they stand
    near = TARGETS + [[0.049, 0.0, 0.0], [0.0, -0.049, 0.0]]
    out = lock.apply(near, physical=PHYSICAL)
    assert lock.standing == (True, True)
    np.testing.assert_allclose(out, np.column_stack([PHYSICAL[:, :2], HOME]))
    # The left target 5.1 cm from its aim: it steps (followed again), the right stays
    far = TARGETS + [[0.051, 0.0, 0.0], [0.0, 0.0, 0.0]]
    out = lock.apply(far + [[0.0, 0.0, 0.1], [0.0, 0.0, 0.0]], physical=PHYSICAL)
    assert lock.standing == (False, True)
    np.testing.assert_allclose(out[0], far[0] + [0.0, 0.0, 0.1])
    assert lock.aim[0] is None and lock.planted[0] is None


def test_replant_moves_a_planted_point_to_a_foot_that_moved_beyond_d_p_at_a_new_frame_only() -> None:
    lock = FootLock(HOME, FootLockConfig(plant_physical=True, replant=0.02))
    lock.apply(TARGETS, physical=PHYSICAL)
    moved = PHYSICAL + [[0.019, 0.0, 0.0], [0.0, 0.021, 0.0]]  # left within d_p, right beyond
    out = lock.apply(TARGETS, physical=moved, new_frame=False)  # within a frame: nothing re-planted
    np.testing.assert_allclose(out[:, :2], PHYSICAL[:, :2])
    out = lock.apply(TARGETS, physical=moved)
    np.testing.assert_allclose(out[0, :2], PHYSICAL[0, :2])
    np.testing.assert_allclose(out[1], [moved[1, 0], moved[1, 1], HOME[1]])
    np.testing.assert_allclose(lock.aim[1], [TARGETS[1, 0], TARGETS[1, 1], HOME[1]])  # the aim stays
    # Also while a contact holds with hold_in_contact (the feet returned as planted)
    lock = FootLock(HOME, FootLockConfig(plant_physical=True, replant=0.02, hold_in_contact=True))
    lock.apply(TARGETS, physical=PHYSICAL)
    out = lock.apply(TARGETS + [[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]], True, physical=moved)
    assert lock.standing == (True, True)
    np.testing.assert_allclose(out[1, :2], moved[1, :2])
    np.testing.assert_allclose(out[0, :2], PHYSICAL[0, :2])
    # Without replant a planted point stays where the foot came down
    lock = FootLock(HOME, ON)
    lock.apply(TARGETS, physical=PHYSICAL)
    np.testing.assert_allclose(lock.apply(TARGETS, physical=moved + 0.1)[:, :2], PHYSICAL[:, :2])


def test_replant_waits_until_both_feet_have_stood_n_r_frames_and_works_without_plant_physical() -> None:
    lock = FootLock(HOME, FootLockConfig(replant=0.02, replant_after=3))
    assert lock.needs_physical
    target_pts = np.column_stack([TARGETS[:, :2], HOME])
    for k in range(3):  # frames 1-3 of standing: planted at the targets (no plant_physical), not re-planted yet
        out = lock.apply(TARGETS, physical=PHYSICAL)
        np.testing.assert_allclose(out, target_pts)
        assert lock.stood == k
    out = lock.apply(TARGETS, physical=PHYSICAL)  # the 4th: both have stood 3 frames in a row
    assert lock.stood == 3
    np.testing.assert_allclose(out, np.column_stack([PHYSICAL[:, :2], HOME]))
    np.testing.assert_allclose(np.array(lock.aim), target_pts)
    # A step starts the count afresh
    lock.apply(TARGETS + [[0.3, 0.0, 0.2], [0.0, 0.0, 0.0]], physical=PHYSICAL)
    assert lock.standing == (False, True)
    lock.apply(TARGETS, physical=PHYSICAL)
    assert lock.stood == 0 and lock.standing == (True, True)
    np.testing.assert_allclose(lock.planted[0], target_pts[0])  # put down at its target again


def test_the_base_moves_by_the_planted_feet_mean_offset_from_their_targets() -> None:
    lock = FootLock(HOME, FootLockConfig(plant_physical=True, plant_base=0.5))
    lock.apply(TARGETS, physical=PHYSICAL)
    expected = 0.5 * np.mean([PHYSICAL[k, :2] - TARGETS[k, :2] for k in (0, 1)], axis=0)
    np.testing.assert_allclose(lock.base_offset(), expected)
    base = np.array([0.3, 0.0, 0.9])
    lock.shift_base(base)
    np.testing.assert_allclose(base, [0.3 + expected[0], expected[1], 0.9])
    # One foot stepping: the other's offset alone
    lock.apply(TARGETS + [[0.2, 0.0, 0.2], [0.0, 0.0, 0.0]], physical=PHYSICAL)
    assert lock.standing == (False, True)
    np.testing.assert_allclose(lock.base_offset(), 0.5 * (PHYSICAL[1, :2] - TARGETS[1, :2]))
    # No foot planted: nothing; without the option: the base untouched even with feet planted
    lock.reset()
    np.testing.assert_array_equal(lock.base_offset(), np.zeros(2))
    off = FootLock(HOME, FootLockConfig())
    off.apply(TARGETS)
    base = np.array([0.3, 0.0, 0.9])
    off.shift_base(base)
    np.testing.assert_array_equal(base, [0.3, 0.0, 0.9])
    np.testing.assert_array_equal(off.base_offset(), np.zeros(2))


def test_the_settings_are_checked_and_the_physical_feet_required() -> None:
    with pytest.raises(SimulationError, match="plant_physical"):
        FootLock(HOME, ON).apply(TARGETS)
    for kw in ({"plant_base": -0.1}, {"replant": -0.01}, {"replant_after": -1}, {"plant_physical": True, "touchdown": 0.05},
               {"replant": 0.02, "touchdown": 0.05}):
        with pytest.raises(ConfigError):
            FootLockConfig(**kw)


def test_the_h1_is_planned_over_its_physical_feet() -> None:
    """The H1 replaying shake_hands_001 (synthetic, seed 0) in the standing mode: without the option the IK's feet
    (the planted points) stand a median of several centimetres, up to tens, from the physical ankles once both are
    down (the walk-up's steps land short); with it, within 2 cm at the end of every frame in which both stand
    (they were put there, and re-planted beyond 2 cm), and the IK's base is moved back with them."""
    h1 = load_robot("unitree_h1", mjcf=shared_robot("unitree_h1", "h1.xml"))
    inter = next(i for i in generate_dataset(seed=0) if i.instance_id == "shake_hands_001")
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode

    medians, shifts = [], []
    for on in (False, True):
        lock = FootLockConfig(hold_lift=0.12, hold_in_contact=True, plant_physical=on, replant=0.02 if on else None)
        sim = Simulator(h1, "shake_hands", SimConfig.standing(foot_lock=lock))
        gaps: list[float] = []
        shift: list[float] = []

        def frame(s, r, _, gaps=gaps, shift=shift) -> None:  # noqa: ANN001
            fl = s._footlock
            shift.append(float(np.linalg.norm(fl.base_offset())))
            if r is not None and all(fl.standing):  # the IK's planted feet (at the frame's solve) against physics
                phys = key_frames(s.scene, s.data)[3:5]
                gaps.append(max(float(np.linalg.norm(phys[k, :2] - fl.planted[k][:2])) for k in (0, 1)))

        run_episode(sim, GroundTruthSource(), inter, on_frame=frame)
        medians.append(float(np.median(gaps)))
        shifts.append(max(shift))
    assert medians[0] > 0.05 and medians[1] < 0.5 * medians[0], medians
    assert shifts[0] == 0.0 and shifts[1] > 0.05, shifts
