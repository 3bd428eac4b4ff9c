"""The walk-up's glide gap and the caught robot's (FootLockConfig(glide_gap_far=..., glide_gap_caught=...,
glide_far=...)): the gaps' decision (no measured gap within d_f, boundary included as near; unmeasured gaps never
count; off without either option), the glide's decision (far: a foot standing farther than d_gf from its target steps
although within ``glide_gap``; near and caught: d_gc decides; near and released: ``glide_gap``), the physical frames
they need, the settings' check, and the simulator passing the last frame's gaps (a standing Stubby high five gets
``far=True`` in its walk-up and ``far=False`` near the meeting, only with an option)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import FOOT_ANKLES as ANKLES, FOOT_HOME as HOME, foot_lock_keyword

from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.errors import ConfigError, SimulationError
from socialaff_sim.sim.footlock import FootLock, FootLockConfig
from socialaff_sim.sim.simulator import SimConfig, Simulator

H = 0.05
ON = FootLockConfig(glide_step=H, glide_gap=0.12, glide_gap_far=0.06, glide_far=0.15)
MOVED = ANKLES + [[0.0, 0.0, 0.0], [0.06, 0.0, 0.0]]  # the right target 6 cm along the floor: a glide


def test_walking_up_is_no_measured_gap_within_glide_far() -> None:
    lock = FootLock(HOME, ON)
    assert lock.walking_up([0.1500001]) and lock.walking_up([None, 0.4]) and lock.walking_up([None])
    assert lock.walking_up([])  # before any gap is measured: the walk-up
    assert not lock.walking_up([0.15]) and not lock.walking_up([0.6, 0.02]) and not lock.walking_up([-0.01])
    off = FootLock(HOME, dataclasses.replace(ON, glide_gap_far=None))
    assert not off.walking_up([0.9]) and not off.walking_up([])  # off: never
    caught = FootLock(HOME, dataclasses.replace(ON, glide_gap_far=None, glide_gap_caught=0.06))
    assert caught.walking_up([0.9]) and not caught.walking_up([0.1])  # glide_gap_caught needs the gaps too


@pytest.mark.parametrize(("behind", "far", "steps"), [(0.081, True, 1), (0.059, True, 0), (0.081, False, 0),
                                                      (0.121, False, 1)])
def test_far_the_walk_ups_gap_decides_a_glide_near_the_meeting_glide_gap(behind: float, far: bool, steps: int) -> None:
    """The physical right ankle ``behind`` m short of the glide's new point: in the walk-up (``far``) it steps beyond
    d_gf = 6 cm; near the meeting beyond d_g = 12 cm only; a foot that does not step is planted at the new point."""
    lock = FootLock(HOME, ON)
    lock.apply(ANKLES, physical=ANKLES)
    physical = MOVED - [[0.0, 0.0, 0.0], [behind, 0.0, 0.0]]
    out = lock.apply(MOVED, physical=physical, far=far)
    assert lock.glide_steps == steps
    if steps:
        assert lock.standing == (True, False)
        np.testing.assert_allclose(out[1], MOVED[1] + [0.0, 0.0, H])
    else:
        assert lock.standing == (True, True)
        np.testing.assert_allclose(out, MOVED)


@pytest.mark.parametrize(("behind", "far", "caught", "steps"), [
    (0.081, False, True, 1), (0.059, False, True, 0),  # near and caught: d_gc = 6 cm decides
    (0.081, False, False, 0), (0.121, False, False, 1),  # near and released: glide_gap's 12 cm
    (0.081, True, False, 0), (0.081, True, True, 0)])  # far: d_gf (here unset: glide_gap), caught or not
def test_near_the_meeting_a_caught_robots_glide_steps_beyond_glide_gap_caught(behind: float, far: bool, caught: bool,
                                                                             steps: int) -> None:
    lock = FootLock(HOME, dataclasses.replace(ON, glide_gap_far=None, glide_gap_caught=0.06))
    assert lock.needs_physical
    lock.apply(ANKLES, physical=ANKLES)
    lock.apply(MOVED, physical=MOVED - [[0.0, 0.0, 0.0], [behind, 0.0, 0.0]], far=far, caught=caught)
    assert lock.glide_steps == steps


def test_without_the_option_far_changes_nothing() -> None:
    for far in (False, True):
        lock = FootLock(HOME, dataclasses.replace(ON, glide_gap_far=None))
        lock.apply(ANKLES, physical=ANKLES)
        lock.apply(MOVED, physical=MOVED - [[0.0, 0.0, 0.0], [0.081, 0.0, 0.0]], far=far, caught=not far)
        assert lock.glide_steps == 0  # within glide_gap's 12 cm: planted at once


def test_glide_gap_far_needs_the_physical_frames_and_is_checked() -> None:
    lock = FootLock(HOME, FootLockConfig(glide_step=H, glide_gap_far=0.06))
    assert lock.needs_physical
    with pytest.raises(SimulationError):
        lock.apply(ANKLES)
    assert not FootLock(HOME, FootLockConfig(glide_gap_far=0.06)).needs_physical  # without glide_step: nothing
    for bad in (0.0, -0.01, float("nan")):
        with pytest.raises(ConfigError, match="glide_gap_far"):
            FootLockConfig(glide_gap_far=bad)
    for bad in (-0.01, float("nan")):
        with pytest.raises(ConfigError, match="glide_far"):
            FootLockConfig(glide_far=bad)
        with pytest.raises(ConfigError, match="glide_gap_caught"):
            FootLockConfig(glide_gap_caught=bad)
    assert FootLockConfig().glide_gap_far is None and FootLockConfig().glide_far == 0.15
    assert FootLockConfig().glide_gap_caught is None
    assert FootLock(HOME, FootLockConfig(glide_step=H, glide_gap_caught=0.06)).needs_physical


def test_the_simulator_passes_far_from_the_last_frames_gaps() -> None:
    """A standing Stubby high five (spent instance high_five_001): with the option the foot lock gets ``far=True`` in
    the walk-up and ``far=False`` once the hands come within d_f; without it never ``True``."""
    inter = next(i for i in generate_dataset(seed=0) if i.instance_id == "high_five_001")
    base = SimConfig.standing()
    assert base.foot_lock.glide_gap_far is None  # off in the standing mode
    off, _ = foot_lock_keyword(base, inter, "far")
    on, lock = foot_lock_keyword(dataclasses.replace(base, foot_lock=dataclasses.replace(
        base.foot_lock, glide_gap_far=0.06)), inter, "far")
    assert off and not any(off)
    assert on[0] and any(on) and not all(on)
    assert lock.glide_gap_far == 0.06


@pytest.mark.parametrize(("causal_only", "placement", "kept"), [(True, 5, True), (True, None, False),
                                                               (False, None, True)])
def test_glide_gap_causal_only_drops_both_gaps_on_a_recordings_replay(causal_only: bool, placement: int | None,
                                                                      kept: bool) -> None:
    """A standing Stubby high five (spent instance high_five_001) reset as a causal source (``placement_frames``, as
    the model's synthesis) keeps ``glide_gap_far`` and ``glide_gap_caught``; as a replay (no ``placement_frames``)
    the simulator drops them under ``glide_gap_causal_only``, and keeps them without it."""
    inter = next(i for i in generate_dataset(seed=0) if i.instance_id == "high_five_001")
    base = SimConfig.standing()
    lock = dataclasses.replace(base.foot_lock, glide_gap_far=0.06, glide_gap_caught=0.07,
                               glide_gap_causal_only=causal_only)
    sim = Simulator("ours", "high_five", dataclasses.replace(base, foot_lock=lock))
    sim.reset(inter, placement_frames=placement)
    got = sim._footlock.config
    assert (got.glide_gap_far, got.glide_gap_caught) == ((0.06, 0.07) if kept else (None, None))
