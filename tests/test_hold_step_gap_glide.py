"""``hold_step_gap`` kept on Stubby where the glide gaps act (``FootLockConfig.hold_step_gap_glide``,
:mod:`socialaff_sim.sim.footlock_config`): the setting's check; ``for_episode`` keeps d_s on a robot whose feet's
roll is not freed only when the flag is set and ``glide_gap_far``/``glide_gap_caught`` survive their own gates (a
causal high five), and changes nothing on a robot whose roll is freed; the simulator's episode lock so made; and what
the kept gap does: a glide within d_s of the meeting is planted at once, beyond it the foot steps."""

from __future__ import annotations

import dataclasses

import pytest
from conftest import FOOT_ANKLES as ANKLES, FOOT_HOME as HOME

from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.footlock import FootLock, FootLockConfig
from socialaff_sim.sim.simulator import SimConfig, Simulator

FL = {"glide_gap_far": 0.06, "glide_gap_caught": 0.06, "glide_far": 1.0, "glide_gap_causal_only": True,
      "glide_gap_above": True}
YES = dict(plan_feet=True, causal=True, counts_above=True, roll_freed=False)  # Stubby, a causal high five


def _lock(**changes: object) -> FootLockConfig:
    base = SimConfig.standing().foot_lock  # hold_step_gap 0.3 with hold_near_roll_free, as main's
    return dataclasses.replace(base, **{**FL, "hold_step_gap_glide": True, **changes})


def test_the_setting_needs_hold_step_gap_and_is_off_in_the_standing_mode() -> None:
    with pytest.raises(ConfigError):
        FootLockConfig(glide_step=0.05, glide_gap_far=0.06, hold_step_gap_glide=True)
    FootLockConfig(glide_step=0.05, glide_gap_far=0.06, hold_step_gap=0.3, hold_step_gap_glide=True)
    assert not SimConfig.standing().foot_lock.hold_step_gap_glide
    assert not FootLockConfig().hold_step_gap_glide
    assert SimConfig.standing().foot_lock.hold_step_gap == 0.3 and SimConfig.standing().foot_lock.hold_near_roll_free


@pytest.mark.parametrize(("flag", "shut", "kept"), [
    (True, None, 0.3),              # a causal high five on Stubby: kept
    (False, None, None),            # without the flag: dropped, as on main
    (True, "causal", None),         # a replay: the glide gaps go (glide_gap_causal_only), and with them d_s
    (True, "counts_above", None),   # another task: the glide gaps go (glide_gap_above), and with them d_s
])
def test_for_episode_keeps_the_step_gap_on_stubby_only_where_the_glide_gaps_act(flag: bool, shut: str | None,
                                                                               kept: float | None) -> None:
    got = _lock(hold_step_gap_glide=flag).for_episode(**{**YES, **({shut: False} if shut else {})})
    assert got.hold_step_gap == kept
    assert got.hold_near is None and got.land_gap is None and got.hold_step_flight is None  # the others still go
    assert not got.hold_step_gap_glide


def test_for_episode_without_glide_gaps_keeps_nothing_on_stubby() -> None:
    got = _lock(glide_gap_far=None, glide_gap_caught=None, glide_gap_causal_only=False,
                glide_gap_above=False).for_episode(**YES)
    assert got.hold_step_gap is None


@pytest.mark.parametrize("flag", [False, True])
def test_a_robot_whose_roll_is_freed_keeps_its_step_gap_either_way(flag: bool) -> None:
    for counts_above in (False, True):
        got = _lock(hold_step_gap_glide=flag).for_episode(**{**YES, "roll_freed": True, "counts_above": counts_above})
        assert got.hold_step_gap == 0.3 and got.hold_near == 0.1


def _made(label: str, lock: FootLockConfig, placement: int | None = 5) -> FootLockConfig:
    data = generate_dataset(seed=0)
    sim = Simulator(load_robot("ours"), label, SimConfig.standing(foot_lock=lock))
    sim.reset(next(i for i in data if i.instance_id == f"{label}_001"), placement_frames=placement)
    return sim._footlock.config


@pytest.mark.parametrize(("label", "placement", "flag", "kept"), [
    ("high_five", 5, True, 0.3), ("high_five", 5, False, None), ("high_five", None, True, None),
    ("shake_hands", 5, True, None),
])
def test_the_simulators_episode_lock(label: str, placement: int | None, flag: bool, kept: float | None) -> None:
    """Stubby's episode lock: d_s kept for a causal high five with the flag; dropped without it, on the high five's
    replay, and in a causal handshake."""
    assert _made(label, _lock(hold_step_gap_glide=flag), placement).hold_step_gap == kept


@pytest.mark.parametrize(("gap", "steps"), [(0.2, 0), (0.29, 0), (0.31, 1), (0.6, 1)])
def test_the_kept_gap_plants_a_glide_near_the_meeting(gap: float, steps: int) -> None:
    """With the made lock, a right foot gliding 6 cm while its physical ankle stands 13 cm short (beyond ``glide_gap``
    12 cm) steps when the last frame's gap is beyond d_s = 0.3 m and is planted at once within it."""
    config = _made("high_five", _lock())
    lock = FootLock(HOME, config)
    lock.apply(ANKLES, physical=ANKLES)
    moved = ANKLES + [[0.0, 0.0, 0.0], [0.06, 0.0, 0.0]]
    lock.apply(moved, physical=moved - [[0.0, 0.0, 0.0], [0.13, 0.0, 0.0]], **lock.gap_flags([gap, None]))
    assert lock.glide_steps == steps
    assert lock.standing == ((True, True) if steps == 0 else (True, False))
