"""The gates of ``FootLockConfig.restep_gap`` (a planted foot that landed short steps again): ``restep_above`` (only in
a task whose contact counts above the shoulders, the high five) and ``restep_roll_free`` (only on a robot whose feet's
roll the balance controller frees, the H1): the gates' cases in :meth:`FootLockConfig.for_episode`, the checks,
Stubby's standing high five bit for bit with both (``assert_gate_keeps_stubby``), and the H1's spent high_five_789,
whose walk-up's last steps land 32–37 cm short of their planted points, changed only in a high five."""

from __future__ import annotations

import dataclasses

import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.footlock import FootLockConfig
from socialaff_sim.sim.simulator import SimConfig

from conftest import assert_gate_keeps_stubby, shared_robot, synthetic_instance


def _lock(**kw) -> FootLockConfig:  # noqa: ANN003
    return dataclasses.replace(SimConfig.standing().foot_lock, restep_gap=0.25, **kw)


@pytest.mark.parametrize(("above", "roll_free", "counts_above", "roll_freed", "kept"), [
    (True, True, True, True, True),
    (True, True, False, True, False),  # not a high five
    (True, True, True, False, False),  # Stubby
    (True, True, False, False, False),
    (True, False, True, False, True),  # no robot gate
    (True, False, False, False, False),
    (False, True, False, True, True),  # no task gate
    (False, True, False, False, False),
    (False, False, False, False, True),  # neither gate: everywhere
])
def test_the_gates_keep_restep_gap_only_where_they_say(above: bool, roll_free: bool, counts_above: bool,
                                                      roll_freed: bool, kept: bool) -> None:
    out = _lock(restep_above=above, restep_roll_free=roll_free).for_episode(
        plan_feet=True, causal=False, counts_above=counts_above, roll_freed=roll_freed)
    assert out.restep_gap == (0.25 if kept else None)
    assert out.glide_step == 0.05  # the glide step itself is not the gates'


def test_the_gates_need_restep_gap_off_by_default_and_on_in_the_standing_mode() -> None:
    for kw in ({"restep_above": True}, {"restep_roll_free": True}):
        with pytest.raises(ConfigError, match="restep"):
            FootLockConfig(glide_step=0.05, **kw)
    c = FootLockConfig()
    assert c.restep_gap is None and not c.restep_above and not c.restep_roll_free
    s = SimConfig.standing().foot_lock  # rule #64 (session 37) adopted them there
    assert s.restep_gap == 0.25 and s.restep_above and s.restep_roll_free


def _without_restep(cfg: SimConfig) -> SimConfig:
    return dataclasses.replace(cfg, foot_lock=dataclasses.replace(cfg.foot_lock, restep_gap=None, restep_above=False,
                                                                  restep_roll_free=False))


def test_stubby_is_bit_for_bit_with_the_robot_gate() -> None:
    """Stubby's standing high five (spent high_five_144): the same states with ``restep_gap`` and both gates (a high
    five keeps the task gate; Stubby's roll is not freed); without ``restep_roll_free`` they change (at 0.05 m, where
    Stubby's feet land short of it; at 0.25 m they never do on 144–151)."""
    base = _without_restep(SimConfig.standing())
    on = dataclasses.replace(base, foot_lock=dataclasses.replace(base.foot_lock, restep_gap=0.05, restep_above=True,
                                                                 restep_roll_free=True))
    ungated = dataclasses.replace(on, foot_lock=dataclasses.replace(on.foot_lock, restep_roll_free=False))
    assert_gate_keeps_stubby(synthetic_instance("high_five", 144), base, on, ungated)


KEYS = ("support", "subgoals", "success", "failures")


def test_the_h1s_short_walk_up_is_restepped_in_a_high_five_only() -> None:
    """The H1 (skipped without ../shared/robots): spent high_five_789 (A: 50.7 % outside support over its two contact
    frames, its feet 32–37 cm behind their planted points) changes with ``restep_gap=0.25`` and both gates, and its
    foot lock re-steps (more steps begun); a hand over's foot lock gets no ``restep_gap``."""
    from socialaff_sim.retarget.robot import load_robot
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode
    from socialaff_sim.sim.simulator import Simulator

    spec = load_robot("unitree_h1", mjcf=shared_robot("unitree_h1", "h1.xml"))
    inter = synthetic_instance("high_five", 789)
    assert inter.instance_id == "high_five_789"
    on = SimConfig.standing()  # rule #64's settings
    base = _without_restep(on)
    runs = {}
    for name, cfg in (("off", base), ("on", on)):
        sim = Simulator(spec, "high_five", cfg)
        runs[name] = (run_episode(sim, GroundTruthSource(), inter), sim._footlock.steps, sim._footlock.config.restep_gap)
    assert runs["off"][2] is None and runs["on"][2] == 0.25
    assert runs["on"][1] > runs["off"][1]
    assert any(runs["on"][0][k] != runs["off"][0][k] for k in KEYS)
    ho = Simulator(spec, "hand_over", on)
    ho.reset(list(generate_dataset(0, SyntheticConfig(interactions=("hand_over",), instances_per_interaction=1)))[0])
    assert ho._footlock.config.restep_gap is None
