"""A foot lock's step taken by the balance controller (BalanceConfig(single_support="swing" | "stand")): the step's
phases (each transition, inverted, fails), the lift only in "swing", the harness during a step (a released robot stays
released by the catch criteria, a held one is not let go and its delay waits), the stance sole's box (against the
sole's corners projected by hand), the swing leg's hinges, the settings' check, and the gate (Stubby's controller gets
no phase and its standing pull-up is the same figure for figure; the H1's gets it, steps in it and its pull-up
changes)."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.harness_release import HarnessRelease
from socialaff_sim.sim.sim_config import STANDING_BALANCE
from socialaff_sim.sim.single_support import SingleSupport, next_phase, stance_box
from socialaff_sim.sim.support_box import SupportBox

from conftest import shared_robot

BOTH, LEFT, RIGHT, NONE = (True, True), (True, False), (False, True), (False, False)
BOX = SupportBox(np.array([[-0.1, -0.15], [0.1, -0.15], [-0.1, 0.15], [0.1, 0.15]]), np.array([1.0, 0.0]))
MIDDLE = np.zeros(2)


@pytest.mark.parametrize(("phase", "planted", "released", "expected"), [
    ("stand", BOTH, True, "stand"), ("shift", BOTH, True, "stand"), ("swing", BOTH, False, "stand"),
    ("off", BOTH, False, "stand"),
    ("stand", LEFT, True, "shift"), ("stand", RIGHT, True, "shift"),  # a step begins released: taken
    ("stand", LEFT, False, "off"),  # a step begins held: today's
    ("shift", LEFT, True, "shift"), ("swing", RIGHT, True, "swing"),  # continues
    ("shift", LEFT, False, "off"), ("swing", RIGHT, False, "off"),  # caught during the step: today's
    ("off", LEFT, True, "off"),  # a step that began held stays today's
    ("stand", NONE, True, "off"), ("shift", NONE, True, "off")])
def test_the_step_phase(phase: str, planted: tuple[bool, bool], released: bool, expected: str) -> None:
    assert next_phase(phase, planted, released) == expected


def test_advance_lift_and_counts() -> None:
    s = SingleSupport()
    assert s.advance(BOTH, True) is False and s.phase == "stand" and s.stance == -1
    assert s.advance(RIGHT, True) is False and s.phase == "shift" and s.stance == 1 and s.stepping and s.lifting
    s.lift()
    assert s.phase == "swing" and s.lifts == 1 and not s.lifting and s.stepping
    assert s.advance(RIGHT, True) is False and s.phase == "swing"  # the lift stands
    assert s.advance(BOTH, True) is True and s.phase == "stand" and s.stance == -1  # the step ended: re-read the feet
    assert (s.shift_steps, s.swing_steps) == (1, 1)
    s.advance(LEFT, False)  # a step that begins held
    assert s.phase == "off" and not s.stepping and s.stance == -1
    assert s.advance(BOTH, True) is False  # from "off" nothing to re-read (the controller dropped the feet already)
    stand = SingleSupport(lift=False)  # "stand": the step is stood through, never lifted
    stand.advance(BOTH, True)
    stand.advance(LEFT, True)
    stand.lift()
    assert stand.phase == "shift" and stand.lifts == 0 and not stand.lifting and stand.stepping
    s.reset()
    assert (s.phase, s.lifts, s.shift_steps, s.swing_steps) == ("stand", 0, 0, 0)


def _harness(scene, released: bool):  # noqa: ANN001, ANN202
    h = HarnessRelease(scene, STANDING_BALANCE)
    d = mujoco.MjData(scene.model)
    if released:
        h.decide(d, 0.2, True, 0.0, BOX, MIDDLE)
        assert h.released
    return h, d


def test_the_harness_during_a_step(scene) -> None:  # noqa: ANN001
    c = STANDING_BALANCE
    h, d = _harness(scene, True)
    h.decide(d, 0.004, True, c.catch_tilt - 0.1, BOX, np.array([0.1 + c.catch_margin - 0.001, 0.0]), stepping=True)
    assert h.released and h.catches == 0  # within the catch criteria: stays released through the step
    h.decide(d, 0.004, True, 0.0, BOX, np.array([0.1 + c.catch_margin + 0.001, 0.0]), stepping=True)
    assert not h.released and h.catch_reasons == {"tilt": 0, "capture": 1, "step": 0}
    h, d = _harness(scene, True)
    h.decide(d, 0.004, True, c.catch_tilt + 0.1, BOX, MIDDLE, stepping=True)
    assert not h.released and h.catch_reasons["tilt"] == 1
    h, d = _harness(scene, True)
    h.decide(d, 0.004, False, 0.0, None, MIDDLE, stepping=True)  # the stance foot off the floor: a step's catch
    assert not h.released and h.catch_reasons["step"] == 1
    h, d = _harness(scene, False)
    h.decide(d, 1.0, True, 0.0, BOX, MIDDLE, stepping=True)  # held: not let go during a step however long
    assert not h.released
    h.decide(d, c.release_delay / 2, True, 0.0, BOX, MIDDLE)  # the delay counts from the step's end
    assert not h.released
    h.decide(d, c.release_delay / 2, True, 0.0, BOX, MIDDLE)
    assert h.released
    h, d = _harness(scene, False)
    h.decide(d, 1.0, True, 0.0, BOX, MIDDLE)  # without stepping the same call lets go (the test above can fail)
    assert h.released


def test_the_stance_sole_box(scene) -> None:  # noqa: ANN001
    from socialaff_sim.sim.feet_on_floor import FeetOnFloor

    feet = FeetOnFloor(scene, STANDING_BALANCE.sole_gap)
    d = scene.home_data()
    soles = feet.soles_at(d)
    fwd = feet.heading(d)
    R = np.array([fwd, [-fwd[1], fwd[0]]])
    pts = np.vstack([soles[0][:3], soles[1][:3]])  # some points of each foot (stand-ins for contacts)
    which = np.array([0, 0, 0, 1, 1, 1])
    for s in (0, 1):
        box = stance_box(feet, d, pts, which, s, soles)
        local = soles[s][:, :2] @ R.T  # the sole's corners in the heading's axes, by hand
        assert np.allclose(box.lo, local.min(axis=0)) and np.allclose(box.hi, local.max(axis=0))
        other = soles[1 - s][:, :2].mean(axis=0)
        assert not box.inside(other, 0.0) and box.inside(soles[s][:, :2].mean(axis=0), 0.0)
    assert stance_box(feet, d, pts[:3], which[:3], 1, soles) is None  # the stance foot without contact


@pytest.mark.parametrize("kw", [{"single_support": "walk"}, {"single_support": "swing", "qp_kernel": "numba"},
                                {"single_support": "stand", "flat_roll_free": False, "hand_task_roll_free": False}])
def test_single_support_is_checked(kw) -> None:  # noqa: ANN001
    with pytest.raises(ConfigError, match="single_support"):
        dataclasses.replace(STANDING_BALANCE, **kw)
    assert dataclasses.replace(STANDING_BALANCE, single_support="swing").single_support == "swing"


def _pull(robot, instance: str, **balance):  # noqa: ANN001, ANN003, ANN202
    from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode
    from socialaff_sim.sim.simulator import SimConfig, Simulator

    n = int(instance.rsplit("_", 1)[1]) + 1
    inter = generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=n)).by_id(instance)
    cfg = SimConfig.standing()
    cfg = dataclasses.replace(cfg, balance=dataclasses.replace(cfg.balance, **balance))
    sim = Simulator(robot, instance.rsplit("_", 1)[0], cfg)
    m_ = run_episode(sim, GroundTruthSource(), inter)
    return sim._stage.stepper.balance, m_


KEYS = ("support", "subgoals", "success", "failures")


def test_stubby_runs_bit_for_bit_as_without_the_option() -> None:
    """Stubby's feet's roll is not freed: its controller gets no phase, and its standing pull-up (spent pull_up_120)
    is the same, figure for figure."""
    bal, m_off = _pull("ours", "pull_up_120")
    bal_on, m_on = _pull("ours", "pull_up_120", single_support="swing")
    assert bal.single is None and bal_on.single is None and bal_on.roll_freed is False
    assert all(m_on[k] == m_off[k] for k in KEYS)


def test_the_h1_takes_its_steps_in_the_phases_and_its_pull_up_changes() -> None:
    """The H1 (skipped without ../shared/robots): its controller gets the phase, each leg's hinges are its five, the
    pull-up on spent pull_up_435 steps released (``shift`` steps) and changes (so the Stubby check above can fail)."""
    from socialaff_sim.retarget.robot import load_robot

    spec = load_robot("unitree_h1", mjcf=shared_robot("unitree_h1", "h1.xml"))
    bal, m_off = _pull(spec, "pull_up_435")
    assert bal.single is None
    bal_on, m_on = _pull(spec, "pull_up_435", single_support="swing")
    assert bal_on.single is not None and bal_on.single.lift_allowed and bal_on.single.shift_steps > 0
    legs = [~k for k in bal_on._legs]  # the hinges above each foot
    assert [int(k.sum()) for k in legs] == [5, 5] and not (legs[0] & legs[1]).any()
    assert bal_on.harness.catch_reasons["step"] < bal.harness.catch_reasons["step"]
    assert any(m_on[k] != m_off[k] for k in KEYS)
