"""No glide step against the harness in a high five only (``FootLockConfig.plant_caught_above``,
:mod:`socialaff_sim.sim.footlock`): ``plant_caught`` kept for a task with a contact sub-goal counted above the
robot's shoulders and dropped by the simulator for any other task."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import FOOT_ANKLES as ANKLES, planted_lock

from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.footlock import FootLockConfig
from socialaff_sim.sim.sim_config import STANDING_FOOT_LOCK
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.tasks import load_task

GLIDE = np.array([0.06, 0.0, 0.0])  # 6 cm along the floor: beyond the lock's 5 cm radius
H = 0.05


def test_plant_caught_above_without_plant_caught_is_refused() -> None:
    with pytest.raises(ConfigError):
        FootLockConfig(glide_step=H, plant_caught_above=True)
    FootLockConfig(glide_step=H, plant_caught=True, plant_caught_above=True)


@pytest.mark.parametrize("above", [False, True])
def test_plant_caught_above_keeps_the_option_only_for_a_task_that_scores_above_the_shoulders(above: bool) -> None:
    """The high five's task (its contact counted above the robot's shoulders) keeps ``plant_caught``; the same task
    with that condition dropped, and a pull-up's, lose it (the lock then steps every glide, as without it)."""
    task = load_task("high_five")
    assert any(sg.above == "robot_shoulders" for sg in task.subgoals)
    if not above:
        task = dataclasses.replace(task, subgoals=tuple(dataclasses.replace(sg, above="none") for sg in task.subgoals))
    lock = dataclasses.replace(STANDING_FOOT_LOCK, plant_caught=True, plant_caught_above=True)
    data = generate_dataset(seed=0)
    sim = Simulator(load_robot("ours"), task, SimConfig.standing(foot_lock=lock))
    sim.reset(next(i for i in data if i.instance_id == "high_five_001"))
    c = sim._footlock.config
    assert (c.plant_caught, c.plant_caught_above) == ((True, True) if above else (False, False))
    # The lock so made: a caught robot's glide planted at once with the option kept, stepped without it.
    moved = ANKLES + [[0.0, 0.0, 0.0], GLIDE]
    made = planted_lock(c)
    made.apply(moved, physical=moved - [[0.0, 0.0, 0.0], [0.2, 0.0, 0.0]], caught=True)
    assert made.glide_steps == (0 if above else 1)
    pull = Simulator(load_robot("ours"), "pull_up", SimConfig.standing(foot_lock=lock))
    pull.reset(next(i for i in data if i.instance_id == "pull_up_001"))
    assert not pull._footlock.config.plant_caught
    # Without plant_caught_above the option stays for every task.
    pull = Simulator(load_robot("ours"), "pull_up", SimConfig.standing(
        foot_lock=dataclasses.replace(lock, plant_caught_above=False)))
    pull.reset(next(i for i in data if i.instance_id == "pull_up_001"))
    assert pull._footlock.config.plant_caught
