"""The walk-up's and the caught robot's glide gaps in a high five only (``FootLockConfig.glide_gap_above``,
:mod:`socialaff_sim.sim.footlock`): ``glide_gap_far`` and ``glide_gap_caught`` kept for a task with a contact sub-goal
counted above the robot's shoulders, dropped by the simulator for any other task (and, with
``glide_gap_causal_only``, on a recording's replay as before); the setting's check; the lock so made steps a glide
between the two gaps only where the option is kept."""

from __future__ import annotations

import dataclasses

import pytest
from conftest import FOOT_ANKLES as ANKLES, FOOT_HOME as HOME

from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.footlock import FootLock, FootLockConfig
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.tasks import load_task

H = 0.05
MOVED = ANKLES + [[0.0, 0.0, 0.0], [0.06, 0.0, 0.0]]  # the right target 6 cm along the floor: a glide
BEHIND = 0.081  # the physical right ankle 8.1 cm short of the new point: beyond d_gf 6 cm, within glide_gap 12 cm


def _lock(**changes: object) -> FootLockConfig:
    base = SimConfig.standing().foot_lock
    fields = {"glide_gap_far": 0.06, "glide_gap_caught": 0.06, "glide_far": 1.0, "glide_gap_above": True}
    return dataclasses.replace(base, **{**fields, **changes})


def test_glide_gap_above_needs_a_gap_to_gate_and_is_off_in_the_standing_mode() -> None:
    with pytest.raises(ConfigError):
        FootLockConfig(glide_step=H, glide_gap=0.12, glide_gap_above=True)
    FootLockConfig(glide_step=H, glide_gap=0.12, glide_gap_far=0.06, glide_gap_above=True)
    FootLockConfig(glide_step=H, glide_gap=0.12, glide_gap_caught=0.06, glide_gap_above=True)
    assert not SimConfig.standing().foot_lock.glide_gap_above
    assert not FootLockConfig().glide_gap_above


def _made(task, instance: str, lock: FootLockConfig, placement: int | None = 5) -> FootLockConfig:  # noqa: ANN001
    data = generate_dataset(seed=0)
    sim = Simulator(load_robot("ours"), task, SimConfig.standing(foot_lock=lock))
    sim.reset(next(i for i in data if i.instance_id == instance), placement_frames=placement)
    return sim._footlock.config


def _steps(config: FootLockConfig) -> int:
    """Glide steps of a lock of ``config`` whose right foot glides 6 cm while its physical ankle stands 8.1 cm short,
    in the walk-up (``far``)."""
    lock = FootLock(HOME, config)
    lock.apply(ANKLES, physical=ANKLES)
    lock.apply(MOVED, physical=MOVED - [[0.0, 0.0, 0.0], [BEHIND, 0.0, 0.0]], far=True)
    return lock.glide_steps


@pytest.mark.parametrize("above", [False, True])
def test_glide_gap_above_keeps_the_gaps_only_for_a_task_that_scores_above_the_shoulders(above: bool) -> None:
    """The high five's task (its contact counted above the robot's shoulders) keeps both gaps, and its lock steps the
    8.1 cm glide; the same task with that condition dropped loses them, and its lock plants the glide at once (within
    ``glide_gap``'s 12 cm), as without the options."""
    task = load_task("high_five")
    assert any(sg.above == "robot_shoulders" for sg in task.subgoals)
    if not above:
        task = dataclasses.replace(task, subgoals=tuple(dataclasses.replace(sg, above="none") for sg in task.subgoals))
    c = _made(task, "high_five_001", _lock())
    assert (c.glide_gap_far, c.glide_gap_caught, c.glide_gap_above) == ((0.06, 0.06, True) if above else
                                                                        (None, None, False))
    assert _steps(c) == (1 if above else 0)


@pytest.mark.parametrize("label", ["shake_hands", "pull_up", "hand_over", "throw_catch"])
def test_glide_gap_above_drops_the_gaps_in_the_other_four_interactions(label: str) -> None:
    c = _made(label, f"{label}_001", _lock())
    assert (c.glide_gap_far, c.glide_gap_caught) == (None, None)
    # Without glide_gap_above the gaps stay in every task.
    c = _made(label, f"{label}_001", _lock(glide_gap_above=False))
    assert (c.glide_gap_far, c.glide_gap_caught) == (0.06, 0.06)


@pytest.mark.parametrize(("placement", "kept"), [(5, True), (None, False)])
def test_glide_gap_above_with_causal_only_keeps_the_gaps_only_for_a_causal_high_five(placement: int | None,
                                                                                    kept: bool) -> None:
    """Both gates: a causal high five (``placement_frames``) keeps the gaps; its replay drops them (and the gate)."""
    c = _made("high_five", "high_five_001", _lock(glide_gap_causal_only=True), placement)
    assert (c.glide_gap_far, c.glide_gap_caught) == ((0.06, 0.06) if kept else (None, None))
    assert c.glide_gap_above == kept
