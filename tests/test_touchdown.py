"""Touchdown timing (:mod:`socialaff_sim.sim.touchdown`, ``FootLockConfig.touchdown``): a stepping foot is put
down on its planned foothold, not short of it."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import planted_feet_error, shared_robot

from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.errors import ConfigError, SimulationError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.footlock import FootLock, FootLockConfig
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.touchdown import Touchdown

HOME = (0.08, 0.08)
ANKLES = np.array([[0.0, 0.1, 0.08], [0.0, -0.1, 0.08]])
STEP = np.array([0.3, 0.0, 0.0])  # the right foot's recorded step
UP = np.array([0.0, 0.0, 0.2])


def _stepped(config: FootLockConfig) -> FootLock:
    """A lock with both feet planted at ANKLES, then the right foot's target in the air (a recorded step)."""
    lock = FootLock(HOME, config)
    lock.apply(ANKLES, physical=ANKLES)
    lock.apply(np.array([ANKLES[0], ANKLES[1] + 0.5 * STEP + UP]), physical=ANKLES)
    assert lock.standing == (True, False)
    return lock


def test_a_foot_landing_short_waits_over_its_foothold_and_is_put_down_once_there() -> None:
    lock = _stepped(FootLockConfig(touchdown=0.05, touchdown_height=0.06, touchdown_frames=4))
    landed = np.array([ANKLES[0], ANKLES[1] + STEP])
    short = np.array([ANKLES[0], ANKLES[1] + STEP - [0.2, 0.0, 0.0]])  # the physical foot 20 cm short
    out = lock.apply(landed, physical=short)
    np.testing.assert_allclose(out[1], ANKLES[1] + STEP + [0.0, 0.0, 0.06])  # in the air over its foothold
    np.testing.assert_allclose(out[0], ANKLES[0])
    assert lock.standing == (True, False) and lock.touchdown.waits == 1
    # 5.1 cm off (beyond d_t): still waiting; 4.9 cm off: put down on the foothold, not where the foot is
    out = lock.apply(landed, physical=landed - [[0.0, 0.0, 0.0], [0.051, 0.0, 0.0]])
    assert lock.standing == (True, False) and out[1, 2] == pytest.approx(0.14)
    out = lock.apply(landed, physical=landed - [[0.0, 0.0, 0.0], [0.049, 0.0, 0.0]])
    np.testing.assert_allclose(out, landed)
    assert lock.standing == (True, True) and lock.touchdown.waiting == [0, 0]
    assert lock.touchdown.frames_waited == 2


def test_without_touchdown_the_foot_is_put_down_wherever_the_physical_foot_is() -> None:
    lock = _stepped(FootLockConfig())
    landed = np.array([ANKLES[0], ANKLES[1] + STEP])
    out = lock.apply(landed, physical=landed - [[0.0, 0.0, 0.0], [0.2, 0.0, 0.0]])
    np.testing.assert_allclose(out, landed)
    assert lock.standing == (True, True) and lock.touchdown is None and not lock.needs_physical


def test_a_waiting_foot_is_put_down_after_its_frames() -> None:
    lock = _stepped(FootLockConfig(touchdown=0.05, touchdown_frames=2))
    landed = np.array([ANKLES[0], ANKLES[1] + STEP])
    stuck = np.array([ANKLES[0], ANKLES[1]])  # the foot never gets there
    lock.apply(landed, physical=stuck)
    lock.apply(landed, physical=stuck)
    assert lock.standing == (True, False) and lock.touchdown.waiting == [0, 2]
    for _ in range(3):  # solved again within the frame: the frame's decision stands, no frame counted
        lock.apply(landed, physical=stuck, new_frame=False)
    assert lock.standing == (True, False) and lock.touchdown.waiting == [0, 2]
    np.testing.assert_allclose(lock.apply(landed, physical=stuck), landed)  # after N_t = 2 frames: down
    assert lock.standing == (True, True)


def test_the_standing_foot_does_not_lift_while_the_other_waits_and_one_foot_waits_at_a_time() -> None:
    lock = _stepped(FootLockConfig(touchdown=0.05))
    landed = np.array([ANKLES[0], ANKLES[1] + STEP])
    short = landed - [[0.0, 0.0, 0.0], [0.2, 0.0, 0.0]]
    lock.apply(landed, physical=short)
    next_step = np.array([ANKLES[0] + 0.5 * STEP + UP, landed[1]])  # the recording lifts the left foot now
    out = lock.apply(next_step, physical=short)
    np.testing.assert_allclose(out[0], ANKLES[0])  # held down: the right foot is still in the air
    assert lock.standing == (True, False)
    out = lock.apply(next_step, physical=landed)  # the right foot is there: down, and the left may step
    assert lock.standing == (True, True)
    out = lock.apply(next_step, physical=landed)
    assert lock.standing == (False, True) and out[0, 2] == pytest.approx(next_step[0, 2])
    # Both feet landing short at once: only the farther waits, the other is put down.
    td = Touchdown(0.05, 0.06, 4)
    feet = [ANKLES[0] + STEP, ANKLES[1] + STEP]
    phys = np.array([ANKLES[0] + [0.2, 0.0, 0.0], ANKLES[1] + [0.1, 0.0, 0.0]])
    assert td.decide(feet, [True, True], phys, True, True) == [False, True]
    # and none waits unless the other foot stands
    td = Touchdown(0.05, 0.06, 4)
    assert td.decide([None, feet[1]], [False, True], phys, True, True) == [False, False]


def test_no_wait_while_a_contact_holds_with_hold_in_contact() -> None:
    for hold, waits in ((True, False), (False, True)):
        lock = _stepped(FootLockConfig(touchdown=0.05, hold_in_contact=hold))
        landed = np.array([ANKLES[0], ANKLES[1] + STEP])
        lock.apply(landed, True, physical=landed - [[0.0, 0.0, 0.0], [0.2, 0.0, 0.0]])
        assert (lock.standing == (True, False)) == waits


def test_the_waiting_target_is_lifted_where_the_foot_is_before_it_is_carried() -> None:
    td = Touchdown(0.05, 0.08, 4, stride=0.15)
    foothold, physical = np.array([0.6, 0.0, 0.07]), np.array([0.0, 0.0, 0.12])
    np.testing.assert_allclose(td.lifted(foothold, physical), [0.15, 0.0, 0.15])  # 15 cm toward, 8 cm up
    near = np.array([0.5, 0.0, 0.1])
    np.testing.assert_allclose(td.lifted(foothold, near), [0.6, 0.0, 0.15])  # within the stride: over it
    np.testing.assert_allclose(Touchdown(0.05, 0.08, 4).lifted(foothold, physical), [0.6, 0.0, 0.15])


def test_touchdown_needs_the_physical_feet_and_checks_its_settings() -> None:
    lock = FootLock(HOME, FootLockConfig(touchdown=0.05))
    assert lock.needs_physical
    with pytest.raises(SimulationError, match="touchdown"):
        lock.apply(ANKLES)
    for kw in ({"touchdown": 0.0}, {"touchdown": 0.05, "touchdown_height": 0.0}, {"touchdown": 0.05, "touchdown_frames": 0},
               {"touchdown": 0.05, "touchdown_stride": 0.0}):
        with pytest.raises(ConfigError, match="touchdown"):
            FootLockConfig(**kw)


def test_touchdown_puts_a_walking_robots_feet_down_where_the_ik_plans_them() -> None:
    """The H1 replaying shake_hands_001 (synthetic, seed 0) in the standing mode: without touchdown timing its
    swing foot comes down 25–47 cm short of its target in the walk-up and stands there; with it, the physical
    ankles stand closer to the planted points in the frames where both feet stand, and touchdowns were delayed."""
    h1 = load_robot("unitree_h1", mjcf=shared_robot("unitree_h1", "h1.xml"))
    inter = next(i for i in generate_dataset(seed=0) if i.instance_id == "shake_hands_001")
    errors, waits = [], []
    for td in (None, 0.05):
        lock = FootLockConfig(hold_lift=0.12, hold_in_contact=True, touchdown=td, touchdown_height=0.08,
                              touchdown_stride=0.25, touchdown_frames=6)
        sim = Simulator(h1, "shake_hands", SimConfig.standing(foot_lock=lock))
        errors.append(planted_feet_error(sim, inter))
        waits.append(0 if sim._footlock.touchdown is None else sim._footlock.touchdown.waits)
    assert waits[0] == 0 and waits[1] > 0
    assert errors[1] < 0.6 * errors[0], errors
