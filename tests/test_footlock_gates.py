"""FootLockConfig.for_episode: each gate drops its options when its condition says "no", and only then."""

import pytest

from socialaff_sim.sim.footlock_config import FootLockConfig

YES = dict(plan_feet=True, causal=True, counts_above=True, roll_freed=True)

ALL_ON = FootLockConfig(glide_step=0.05, restep_gap=0.08, glide_gap_far=0.06, glide_gap_caught=0.06,
                        glide_gap_causal_only=True, glide_gap_above=True, plant_caught=True, plant_caught_above=True,
                        hold_in_contact=True, hold_near=0.1, hold_near_roll_free=True, land_gap=0.1,
                        hold_step_gap=0.3, hold_step_flight=3)

# condition -> the fields it drops when False
DROPS = {
    "plan_feet": {"restep_gap": None},
    "causal": {"glide_gap_far": None, "glide_gap_caught": None},
    "counts_above": {"glide_gap_far": None, "glide_gap_caught": None, "plant_caught": False},
    "roll_freed": {"hold_near": None, "land_gap": None, "hold_step_gap": None, "hold_step_flight": None},
}


def test_every_gate_open_keeps_every_option():
    assert ALL_ON.for_episode(**YES) == ALL_ON


@pytest.mark.parametrize("condition", sorted(DROPS))
def test_a_shut_gate_drops_its_options_and_only_them(condition):
    got = ALL_ON.for_episode(**{**YES, condition: False})
    for name, value in DROPS[condition].items():
        assert getattr(got, name) == value, name
    kept = {"glide_step", "hold_in_contact", "radius", "lift"} | (
        set().union(*(d.keys() for c, d in DROPS.items() if c != condition)) - set(DROPS[condition]))
    for name in kept:
        assert getattr(got, name) == getattr(ALL_ON, name), name


@pytest.mark.parametrize("flag, condition", [("glide_gap_causal_only", "causal"), ("glide_gap_above", "counts_above"),
                                             ("plant_caught_above", "counts_above"), ("hold_near_roll_free", "roll_freed")])
def test_without_its_flag_a_gate_drops_nothing(flag, condition):
    lock = FootLockConfig(**{**{f: getattr(ALL_ON, f) for f in ("glide_step", "glide_gap_far", "glide_gap_caught",
                                                                "plant_caught", "hold_in_contact", "hold_near",
                                                                "land_gap", "hold_step_gap", "hold_step_flight")},
                             flag: False})
    got = lock.for_episode(**{**YES, condition: False})
    for name in DROPS[condition]:
        assert getattr(got, name) == getattr(lock, name), name
