"""No glide step against the harness (``FootLockConfig.plant_caught``, :mod:`socialaff_sim.sim.footlock`): while the
harness holds a robot it has caught (``HarnessRelease.holds_caught``), a gliding foot is planted at once instead
of stepping for a frame."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import FOOT_ANKLES as ANKLES, planted_lock

from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim import simulator as simulator_module
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.footlock import FootLock, FootLockConfig
from socialaff_sim.sim.harness_release import HarnessRelease
from socialaff_sim.sim.sim_config import STANDING_FOOT_LOCK
from socialaff_sim.sim.simulator import SimConfig, Simulator

GLIDE = np.array([0.06, 0.0, 0.0])  # 6 cm along the floor: beyond the lock's 5 cm radius
H = 0.05


def test_a_glide_is_planted_at_once_while_caught_and_steps_otherwise() -> None:
    moved = ANKLES + [[0.0, 0.0, 0.0], GLIDE]
    behind = moved - [[0.0, 0.0, 0.0], [0.2, 0.0, 0.0]]  # the physical foot 20 cm short (beyond any glide_gap)
    on = dataclasses.replace(STANDING_FOOT_LOCK, plant_caught=True)
    lock = planted_lock(on)
    out = lock.apply(moved, physical=behind, caught=True)
    assert lock.standing == (True, True) and lock.glide_steps == 0
    np.testing.assert_allclose(out, moved)  # planted at the new point, not raised
    # Not caught: the same glide steps (raised by h_g for a frame).
    lock = planted_lock(on)
    out = lock.apply(moved, physical=behind, caught=False)
    assert lock.standing == (True, False) and lock.glide_steps == 1
    np.testing.assert_allclose(out[1], moved[1] + [0.0, 0.0, H])
    # Without the option a caught robot's glide steps too.
    lock = planted_lock(STANDING_FOOT_LOCK)
    lock.apply(moved, physical=behind, caught=True)
    assert lock.standing == (True, False) and lock.glide_steps == 1


def test_the_decision_is_per_frame_and_a_foot_that_landed_short_is_not_restepped_while_caught() -> None:
    moved = ANKLES + [[0.0, 0.0, 0.0], GLIDE]
    far = moved + [[0.0, 0.0, 0.0], GLIDE]
    on = FootLockConfig(glide_step=H, glide_gap=0.12, plant_caught=True)
    lock = planted_lock(on)
    lock.apply(moved, physical=moved - [[0.0, 0.0, 0.0], [0.2, 0.0, 0.0]], caught=True)
    assert lock.glide_steps == 0
    lock.apply(far, physical=far - [[0.0, 0.0, 0.0], [0.2, 0.0, 0.0]], caught=False)  # let go: the next glide steps
    assert lock.standing == (True, False) and lock.glide_steps == 1
    short = ANKLES - [[0.0, 0.0, 0.0], [0.10, 0.0, 0.0]]  # the right foot 10 cm behind where it is planted
    restep = FootLockConfig(glide_step=H, restep_gap=0.08, plant_caught=True)
    lock = planted_lock(restep)
    lock.apply(ANKLES, physical=short, caught=True)
    assert lock.standing == (True, True) and lock.glide_steps == 0
    lock.apply(ANKLES, physical=short, caught=False)
    assert lock.standing == (True, False) and lock.glide_steps == 1


def test_holds_caught_is_a_catch_not_yet_let_go() -> None:
    harness = object.__new__(HarnessRelease)  # the property reads the two counters only
    for catches, released, holds in ((0, False, False), (0, True, False), (1, True, False), (1, False, True),
                                     (3, False, True)):
        harness.catches, harness.released = catches, released
        assert harness.holds_caught is holds


def _gliding(inter):  # noqa: ANN001, ANN202
    """``inter`` with agent 1's ankles and feet kept at their lowest recorded height (a gliding walk-up)."""
    idx = [k for k, n in enumerate(inter.joint_names) if "ankle" in n or "foot" in n]
    joints = inter.joints.copy()
    joints[:, 1, idx, 2] = np.nanmin(joints[:, 1, idx, 2], axis=0)
    return dataclasses.replace(inter, joints=joints)


@pytest.mark.parametrize("plant", [False, True])
def test_the_simulator_tells_the_foot_lock_whether_the_harness_holds_a_caught_robot(monkeypatch, plant) -> None:
    """Stubby standing, pull_up_001 (synthetic, seed 0) with a gliding walk-up: the lock hears ``caught`` exactly
    when the balance controller holds a caught robot, and with the option no glide step begins in such a frame."""
    calls: list[tuple[bool, bool, int, int]] = []
    sims: list[Simulator] = []

    class Recording(FootLock):
        def apply(self, ankles, touching=False, physical=None, new_frame=True, caught=False, **more):  # noqa: ANN001, ANN202
            before = self.glide_steps
            out = super().apply(ankles, touching, physical, new_frame, caught, **more)
            if new_frame:
                calls.append((caught, sims[0]._stage.stepper.balance.harness.holds_caught, before, self.glide_steps))
            return out

    monkeypatch.setattr(simulator_module, "FootLock", Recording)
    inter = _gliding(next(i for i in generate_dataset(seed=0) if i.instance_id == "pull_up_001"))
    lock = dataclasses.replace(STANDING_FOOT_LOCK, glide_until_contact=False, glide_gap=None, plant_caught=plant)
    sims.append(Simulator(load_robot("ours"), "pull_up", SimConfig.standing(foot_lock=lock)))
    run_episode(sims[0], GroundTruthSource(), inter)
    assert all(c == h for c, h, _, _ in calls)  # the flag is the controller's state
    caught = [c for c, _, _, _ in calls]
    assert any(caught) and not all(caught)
    steps_caught = sum(a - b for c, _, b, a in calls if c)
    assert sum(a - b for c, _, b, a in calls if not c) > 0  # let go, the glides step
    if plant:
        assert steps_caught == 0
    else:
        assert steps_caught > 0
