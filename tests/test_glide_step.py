"""A gliding foot steps (``FootLockConfig.glide_step``, :mod:`socialaff_sim.sim.footlock`): a planted foot whose
target slides along the floor beyond the lock's radius is lifted for a frame instead of being planted again at
once, so that the standing robot's physical foot follows its plan."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import FOOT_ANKLES as ANKLES, FOOT_HOME as HOME, planted_feet_error, planted_lock

from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.errors import ConfigError, SimulationError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.footlock import FootLock, FootLockConfig
from socialaff_sim.sim.sim_config import STANDING_FOOT_LOCK
from socialaff_sim.sim.simulator import SimConfig, Simulator

GLIDE = np.array([0.06, 0.0, 0.0])  # 6 cm along the floor: beyond the lock's 5 cm radius
H = 0.05


def test_a_gliding_foot_steps_for_one_frame_then_is_put_down_and_without_the_option_is_planted_at_once() -> None:
    moved = ANKLES + [[0.0, 0.0, 0.0], GLIDE]
    lock = planted_lock(FootLockConfig(glide_step=H), physical=False)
    out = lock.apply(moved)
    assert lock.standing == (True, False) and lock.glide_steps == 1
    np.testing.assert_allclose(out[1], ANKLES[1] + GLIDE + [0.0, 0.0, H])  # over its new point, raised by h_g
    np.testing.assert_allclose(out[0], ANKLES[0])
    out = lock.apply(moved)  # the next frame: down on the new point
    assert lock.standing == (True, True)
    np.testing.assert_allclose(out, moved)
    # Without the option the foot is planted at the new point at once and never counts as stepping.
    lock = planted_lock(FootLockConfig(), physical=False)
    np.testing.assert_allclose(lock.apply(moved), moved)
    assert lock.standing == (True, True) and lock.glide_steps == 0


def test_a_slide_within_the_radius_or_a_lifted_step_is_not_a_glide() -> None:
    lock = planted_lock(FootLockConfig(glide_step=H), physical=False)
    out = lock.apply(ANKLES + [[0.0, 0.0, 0.0], [0.049, 0.0, 0.0]])  # within r: stands where planted
    np.testing.assert_allclose(out, ANKLES)
    assert lock.standing == (True, True) and lock.glide_steps == 0
    # 1 mm beyond h_lift (4 cm) on the way: a recorded step, followed as the target says (not raised by h_g)
    up = ANKLES[1] + GLIDE + [0.0, 0.0, 0.041]
    out = lock.apply(np.array([ANKLES[0], up]))
    np.testing.assert_allclose(out[1], up)
    assert lock.standing == (True, False) and lock.glide_steps == 0
    lock = planted_lock(FootLockConfig(glide_step=H), physical=False)  # 1 mm below h_lift: a glide
    out = lock.apply(np.array([ANKLES[0], up - [0.0, 0.0, 0.002]]))
    assert lock.glide_steps == 1 and out[1, 2] == pytest.approx(0.08 + H)


def test_one_foot_at_a_time_the_farther_first_and_the_other_held_until_the_first_has_landed() -> None:
    lock = planted_lock(FootLockConfig(glide_step=H), physical=False)
    both = ANKLES + [GLIDE, 1.5 * GLIDE]  # both glide, the right farther
    out = lock.apply(both)
    assert lock.standing == (True, False)
    np.testing.assert_allclose(out[0], ANKLES[0])  # held where it stands, not planted at its target
    out = lock.apply(both)  # the right lands; the left, still gliding, is held while it does
    assert lock.standing == (True, True)
    np.testing.assert_allclose(out, [ANKLES[0], both[1]])
    out = lock.apply(both)  # then the left steps
    assert lock.standing == (False, True) and lock.glide_steps == 2
    np.testing.assert_allclose(out[0], both[0] + [0.0, 0.0, H])
    # Mirrored: the farther foot steps first whichever side it is.
    lock = planted_lock(FootLockConfig(glide_step=H), physical=False)
    lock.apply(ANKLES + [1.5 * GLIDE, GLIDE])
    assert lock.standing == (False, True)


def test_no_glide_step_while_the_other_foot_steps_or_a_contact_holds_with_hold_in_contact() -> None:
    lock = planted_lock(FootLockConfig(glide_step=H), physical=False)
    lock.apply(np.array([ANKLES[0] + [0.0, 0.0, 0.2], ANKLES[1]]))  # the left foot steps (in the air)
    assert lock.standing == (False, True)
    out = lock.apply(np.array([ANKLES[0] + [0.0, 0.0, 0.2], ANKLES[1] + GLIDE]))
    assert lock.standing == (False, True) and lock.glide_steps == 0  # planted at once: the robot keeps a foot
    np.testing.assert_allclose(out[1], ANKLES[1] + GLIDE)
    for hold, steps in ((True, 0), (False, 1)):
        lock = planted_lock(FootLockConfig(glide_step=H, hold_in_contact=hold), physical=False)
        lock.apply(ANKLES + [[0.0, 0.0, 0.0], GLIDE], touching=True)
        assert lock.glide_steps == steps


def test_solved_again_within_a_frame_the_glide_step_stands_and_reset_clears_it() -> None:
    lock = planted_lock(FootLockConfig(glide_step=H), physical=False)
    moved = ANKLES + [[0.0, 0.0, 0.0], GLIDE]
    first = lock.apply(moved)
    for _ in range(3):
        np.testing.assert_allclose(lock.apply(moved + [[0.0, 0.0, 0.0], GLIDE], new_frame=False), first)
    assert lock.standing == (True, False) and lock.glide_steps == 1
    lock.reset()
    assert lock.standing == (False, False) and lock.glide_steps == 0


def test_with_glide_until_contact_glides_step_only_until_a_contact_first_holds() -> None:
    moved = ANKLES + [[0.0, 0.0, 0.0], GLIDE]
    for latch, steps in ((True, 0), (False, 1)):
        lock = planted_lock(FootLockConfig(glide_step=H, glide_until_contact=latch), physical=False)
        lock.apply(ANKLES, touching=True)  # a contact held at the end of the last frame (the feet stay)
        lock.apply(moved, touching=False)  # the contact has ended: the latch stays
        assert lock.glide_steps == steps and lock.standing == ((True, False) if steps else (True, True))
        lock.reset()  # a new episode: the latch is cleared
        lock.apply(ANKLES)
        lock.apply(moved)
        assert lock.glide_steps == 1


def test_with_glide_gap_a_glide_steps_only_when_the_physical_foot_stands_farther_than_d_g_from_its_target() -> None:
    moved = ANKLES + [[0.0, 0.0, 0.0], GLIDE]  # the new point is 6 cm from where the foot was planted
    for behind, steps in ((0.081, 1), (0.079, 0)):  # the physical right ankle 8.1 / 7.9 cm short of the new point
        lock = FootLock(HOME, FootLockConfig(glide_step=H, glide_gap=0.08))
        assert lock.needs_physical
        lock.apply(ANKLES, physical=ANKLES)
        physical = moved - [[0.0, 0.0, 0.0], [behind, 0.0, 0.0]]
        out = lock.apply(moved, physical=physical)
        assert lock.glide_steps == steps
        if not steps:  # planted at the new point at once, as without glide_step
            np.testing.assert_allclose(out, moved)
            assert lock.standing == (True, True)
    with pytest.raises(SimulationError, match="glide_gap"):
        FootLock(HOME, FootLockConfig(glide_step=H, glide_gap=0.08)).apply(ANKLES)
    assert not FootLock(HOME, FootLockConfig(glide_gap=0.08)).needs_physical  # without glide_step it does nothing


def test_glide_step_is_checked() -> None:
    for bad in (0.0, -0.01, float("nan")):
        with pytest.raises(ConfigError, match="glide_step"):
            FootLockConfig(glide_step=bad)
        with pytest.raises(ConfigError, match="glide_gap"):
            FootLockConfig(glide_gap=bad)


def _gliding(inter):  # noqa: ANN001, ANN202
    """``inter`` with agent 1's ankles and feet kept at their lowest recorded height: its walk-up slides the feet
    along the floor (as the demo's causal synthesis of pull_up_001 does) instead of stepping."""
    names = inter.joint_names
    idx = [k for k, n in enumerate(names) if "ankle" in n or "foot" in n]
    joints = inter.joints.copy()
    joints[:, 1, idx, 2] = np.nanmin(joints[:, 1, idx, 2], axis=0)
    return dataclasses.replace(inter, joints=joints)


def test_a_gliding_walk_up_leaves_the_standing_robots_feet_behind_unless_they_glide_step() -> None:
    """Stubby in the standing mode replaying pull_up_001 (synthetic, seed 0) with its walk-up turned into a glide:
    without the option the physical feet stand far from the points the lock planted them on (the balance controller
    holds them where they first stood); with it they follow."""
    robot = load_robot("ours")
    inter = _gliding(next(i for i in generate_dataset(seed=0) if i.instance_id == "pull_up_001"))
    errors, steps = [], []
    bare = dataclasses.replace(STANDING_FOOT_LOCK, glide_until_contact=False, glide_gap=None)
    # without the option; h_g alone; the standing mode's (h_g, the latch and d_g = 12 cm)
    for lock in (dataclasses.replace(bare, glide_step=None), dataclasses.replace(bare, glide_step=H), STANDING_FOOT_LOCK):
        sim = Simulator(robot, "pull_up", SimConfig.standing(foot_lock=lock))
        errors.append(planted_feet_error(sim, inter))
        steps.append(sim._footlock.glide_steps)
    assert steps[0] == 0 and steps[1] > 0 and steps[2] > 0
    # measured: 7.5, 3.3 and 3.9 cm (16.0 and 3.4 cm before the standing mode's hands gave way against the twist)
    assert errors[0] > 0.05 and errors[1] < 0.5 * errors[0] and errors[2] < 0.6 * errors[0], errors


def test_the_standing_mode_glide_steps_in_the_walk_up_only_a_foot_left_more_than_12_cm_behind() -> None:
    """The rule of docs/design.md §5 ("… the glide step confined to a walk-up far behind its plan") put h_g = 5 cm,
    the latch at the first contact and d_g = 12 cm into the standing mode; the harness has no glide step."""
    lock = SimConfig.standing().foot_lock
    assert (lock.glide_step, lock.glide_until_contact, lock.glide_gap) == (0.05, True, 0.12)
    assert (lock.hold_lift, lock.hold_in_contact) == (0.12, True)  # the earlier rule's settings kept
    assert SimConfig.harness().foot_lock.glide_step is None
    moved = ANKLES + [[0.0, 0.0, 0.0], GLIDE]
    for behind, steps in ((0.121, 1), (0.119, 0)):  # the physical right ankle 12.1 / 11.9 cm short of the new point
        fl = FootLock(HOME, lock)
        fl.apply(ANKLES, physical=ANKLES)
        out = fl.apply(moved, physical=moved - [[0.0, 0.0, 0.0], [behind, 0.0, 0.0]])
        assert fl.glide_steps == steps
        np.testing.assert_allclose(out[1], moved[1] + [0.0, 0.0, 0.05 * steps])  # raised by h_g, or planted at once
    fl = FootLock(HOME, lock)  # after the first contact a glide far behind is planted at once (the walk-up is over)
    fl.apply(ANKLES, touching=True, physical=ANKLES)
    out = fl.apply(moved, physical=moved - [[0.0, 0.0, 0.0], [0.5, 0.0, 0.0]])
    assert fl.glide_steps == 0
    np.testing.assert_allclose(out, moved)
