"""The harness's release after a touch at ``release_tilt_touched`` in a high five instead of a throw
(BalanceConfig(release_tilt_touched_above=True)): the gate by task (a task with a contact counted above the shoulders
gets θ_t, a throw's catch task does not; without the option the reverse), by robot (a robot whose feet's roll is not
freed gets none either way), the release's decision after the gate, the setting's check, Stubby's standing high five
bit for bit, and the H1's: its high five gets θ_t and changes, its throw gets none."""

from __future__ import annotations

import dataclasses
import functools

import mujoco
import numpy as np
import pytest

from conftest import assert_gate_keeps_stubby, shared_robot, standing_with, synthetic_instance
from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.harness_release import HarnessRelease
from socialaff_sim.sim.sim_config import STANDING_BALANCE
from socialaff_sim.sim.support_box import SupportBox

_cfg = functools.partial(standing_with, "balance")  # SimConfig.standing() with these balance fields


THROWS = dataclasses.replace(STANDING_BALANCE, release_tilt_touched=8.0)
ABOVE = dataclasses.replace(THROWS, release_tilt_touched_above=True)
BOX = SupportBox(np.array([[-0.1, -0.15], [0.1, -0.15], [-0.1, 0.15], [0.1, 0.15]]), np.array([1.0, 0.0]))
MIDDLE = np.zeros(2)


def _gated(scene, config, roll_freed: bool, catch: bool, above: bool) -> HarnessRelease:  # noqa: ANN001
    h = HarnessRelease(scene, config, roll_freed)
    h.gate_touched(catch, above)
    return h


@pytest.mark.parametrize("catch, above, option, expected", [
    (False, True, True, 8.0),  # a high five with the option: θ_t
    (True, False, True, None),  # a throw with the option: in place of the catch task, none
    (False, False, True, None),  # a handshake: none
    (True, False, False, 8.0),  # without the option, a throw: θ_t (as before)
    (False, True, False, None),  # without the option, a high five: none
])
def test_the_gate_by_task(scene, catch: bool, above: bool, option: bool, expected) -> None:  # noqa: ANN001
    config = ABOVE if option else THROWS
    assert _gated(scene, config, True, catch, above).tilt_touched == expected
    assert _gated(scene, config, False, catch, above).tilt_touched is None  # a robot whose feet's roll is not freed


def test_a_high_five_releases_up_to_the_touched_tilt(scene) -> None:  # noqa: ANN001
    def released(config, roll_freed: bool, catch: bool, above: bool, tilt: float, touched: bool) -> bool:  # noqa: ANN001
        h = _gated(scene, config, roll_freed, catch, above)
        h.decide(mujoco.MjData(scene.model), 0.2, True, tilt, BOX, MIDDLE, touched)
        return h.released

    assert released(ABOVE, True, False, True, 7.9, True)  # a high five after the touch: up to 8°
    assert released(ABOVE, True, False, True, 8.0, True)  # the bound included
    assert not released(ABOVE, True, False, True, 8.1, True)
    assert not released(ABOVE, True, False, True, 6.0, False)  # before the touch: release_tilt (5°)
    assert not released(ABOVE, True, True, False, 6.0, True)  # a throw with the option: release_tilt
    assert not released(THROWS, True, False, True, 6.0, True)  # a high five without it: release_tilt
    assert not released(ABOVE, False, False, True, 6.0, True)  # Stubby's kind of feet: release_tilt


def test_release_tilt_touched_above_is_checked() -> None:
    with pytest.raises(ConfigError, match="release_tilt_touched_above"):
        dataclasses.replace(STANDING_BALANCE, release_tilt_touched_above=True)
    assert ABOVE.release_tilt_touched_above


def test_stubby_runs_bit_for_bit_as_without_it() -> None:
    # ungated: the release's tilt raised for every robot, before and after the touch
    assert_gate_keeps_stubby(synthetic_instance("high_five", 1), _cfg(),
                             _cfg(release_tilt_touched=8.0, release_tilt_touched_above=True), _cfg(release_tilt=8.0))


KEYS = ("support", "subgoals", "success", "failures")


def test_the_h1_high_five_gets_the_bound_and_changes_its_throw_none() -> None:
    """The H1 (skipped without ../shared/robots): on spent high_five_728, which A holds caught through its contact
    phase (50 % outside support), the harness gets θ_t and lets go earlier (support 0.505 → 0.445 in session 36's
    probe); a throw's harness gets none with the option."""
    from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
    from socialaff_sim.retarget.robot import load_robot
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode
    from socialaff_sim.sim.simulator import Simulator

    spec = load_robot("unitree_h1", mjcf=shared_robot("unitree_h1", "h1.xml"))
    inter = synthetic_instance("high_five", 728)
    assert inter.instance_id == "high_five_728"
    on = _cfg(release_tilt_touched=8.0, release_tilt_touched_above=True)
    runs = {}
    for name, cfg in (("off", _cfg()), ("throws", _cfg(release_tilt_touched=8.0)), ("on", on)):
        sim = Simulator(spec, "high_five", cfg)
        runs[name] = run_episode(sim, GroundTruthSource(), inter)
        assert sim._stage.stepper.balance.harness.tilt_touched == (8.0 if name == "on" else None)
    assert all(runs["throws"][k] == runs["off"][k] for k in KEYS)  # without the option the high five is as A's
    assert any(runs["on"][k] != runs["off"][k] for k in KEYS)
    assert runs["on"]["success"]
    throw = list(generate_dataset(0, SyntheticConfig(interactions=("throw_catch",), instances_per_interaction=1)))[0]
    sim = Simulator(spec, "throw_catch", on)
    sim.reset(throw)
    assert sim._stage.stepper.balance.harness.tilt_touched is None
