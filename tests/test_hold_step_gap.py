"""No steps near the meeting (FootLockConfig(hold_step_gap=...)): the gap's decision (within d_s, boundary included;
unmeasured gaps never count; off without the option), the step's decision (with ``still`` a planted foot whose target
lifts or leaves its radius is planted at once at the target's horizontal point on the floor, never lifted, and no glide
steps; without it the foot steps; a foot already lifted is not put down by it; ``hold_near``'s backing step held where
it stands), the settings' check, and the simulator passing the last frame's gaps (a standing Stubby pull-up gets
``still=True`` only with the option on and not gated by ``hold_near_roll_free``)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.footlock import FootLock, FootLockConfig
from socialaff_sim.sim.simulator import SimConfig

from conftest import foot_lock_keyword

HOME = (0.08, 0.08)
ANKLES = np.array([[0.0, 0.1, 0.08], [0.0, -0.1, 0.08]])
ON = FootLockConfig(hold_lift=0.12, hold_in_contact=True, hold_step_gap=0.1)
AHEAD = np.array([1.0, 0.1])  # the person ahead of the robot (+x)
TOWARD = ANKLES + np.array([[0.054, 0.0, 0.002], [0.0, 0.0, 0.0]])  # the left target 5.4 cm toward the person
LIFTED = ANKLES + np.array([[0.03, 0.06, 0.083], [0.0, 0.0, 0.0]])  # 6.7 cm sideways and 8.3 cm up
BACK = ANKLES + np.array([[-0.08, 0.0, 0.0], [0.0, 0.0, 0.0]])  # 8 cm away from the person


def _left(config: FootLockConfig, target: np.ndarray, still: bool, near: bool = False,
          person: np.ndarray = AHEAD) -> tuple[np.ndarray | None, np.ndarray]:
    """The left foot's planted point (``None``: lifted) and the targets out after a frame toward ``target``."""
    lock = FootLock(HOME, config)
    lock.apply(ANKLES)  # both planted at home
    out = lock.apply(target, False, near=near, person=person, still=still)
    assert np.allclose(out[1], ANKLES[1])  # the other foot as it stood
    if lock.planted[0] is not None:
        assert np.allclose(out[0], lock.planted[0])
    return lock.planted[0], out


def _home(t: np.ndarray) -> np.ndarray:
    return np.array([t[0], t[1], HOME[0]])  # the target's horizontal point at the home ankle height


def test_stepless_is_the_gap_within_hold_step_gap() -> None:
    lock = FootLock(HOME, ON)
    assert lock.stepless([0.1]) and lock.stepless([None, 0.05]) and lock.stepless([-0.004])
    assert not lock.stepless([0.1000001]) and not lock.stepless([None]) and not lock.stepless([])
    assert not FootLock(HOME, FootLockConfig(hold_in_contact=True, hold_near=0.1)).stepless([0.0])  # off: never


def test_a_lifted_step_of_a_planted_foot_is_planted_at_once_at_its_point_only_with_still() -> None:
    p, _ = _left(ON, LIFTED, still=True)
    assert p is not None and np.allclose(p, _home(LIFTED[0]))  # not lifted: planted where the step goes, on the floor
    p, out = _left(ON, LIFTED, still=False)
    assert p is None and np.allclose(out[0], LIFTED[0])  # the step taken: lifted, the target followed


@pytest.mark.parametrize("target", [TOWARD, BACK], ids=["toward", "back"])
def test_a_glide_is_planted_at_once_instead_of_a_glide_step_only_with_still(target: np.ndarray) -> None:
    c = dataclasses.replace(ON, glide_step=0.05)
    p, _ = _left(c, target, still=True)
    assert p is not None and np.allclose(p, _home(target[0]))
    p, out = _left(c, target, still=False)  # a glide step: lifted by glide_step for a frame
    assert p is None and np.allclose(out[0], [target[0][0], target[0][1], HOME[0] + 0.05])


def test_hold_nears_backing_step_is_still_held_where_it_stands() -> None:
    c = dataclasses.replace(ON, hold_near=0.1)
    p, _ = _left(c, BACK, still=True, near=True)  # away from the person ahead: held at its planted point
    assert p is not None and np.allclose(p, ANKLES[0])
    p, _ = _left(c, TOWARD, still=True, near=True)  # toward the person: planted where it goes
    assert p is not None and np.allclose(p, _home(TOWARD[0]))


def test_still_puts_no_lifted_foot_down_and_leaves_a_small_move_as_before() -> None:
    lock = FootLock(HOME, ON)
    lock.apply(ANKLES)
    lock.apply(LIFTED, False, person=AHEAD)  # the left foot steps
    assert lock.planted[0] is None
    higher = LIFTED + np.array([[0.02, 0.0, 0.01], [0.0, 0.0, 0.0]])
    out = lock.apply(higher, False, person=AHEAD, still=True)  # only planted feet are kept from stepping
    assert lock.planted[0] is None and np.allclose(out[0], higher[0])
    small = ANKLES + np.array([[0.02, 0.0, 0.0], [0.0, 0.0, 0.0]])  # within radius: held where it stands either way
    for still in (True, False):
        p, _ = _left(ON, small, still=still)
        assert np.allclose(p, ANKLES[0])


def test_no_glide_step_is_counted_while_still() -> None:
    c = dataclasses.replace(ON, glide_step=0.05)
    for still, steps in ((False, 1), (True, 0)):
        lock = FootLock(HOME, c)
        lock.apply(ANKLES)
        lock.apply(TOWARD, False, person=AHEAD, still=still)
        assert lock.glide_steps == steps


def test_hold_step_gap_is_checked() -> None:
    with pytest.raises(ConfigError, match="hold_step_gap"):
        FootLockConfig(hold_step_gap=-0.01)
    assert FootLockConfig().hold_step_gap is None and FootLockConfig(hold_step_gap=0.0).hold_step_gap == 0.0


@pytest.mark.parametrize(("option", "keyword"), [("hold_step_gap", "still"), ("land_gap", "land")])
def test_the_simulator_passes_the_last_frames_gaps_and_the_gate_drops_it_on_stubby(option: str, keyword: str) -> None:
    """On a standing Stubby pull-up (spent instance pull_up_120) the foot lock gets ``still=True`` (``hold_step_gap``)
    or ``land=True`` (``land_gap``) in some call only with the option on; under ``hold_near_roll_free`` (Stubby's
    feet's roll is not freed) the option is dropped."""
    inter = generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=121)).by_id("pull_up_120")
    base = SimConfig.standing()
    off = dataclasses.replace(base.foot_lock, hold_near_roll_free=False, hold_near=None, hold_step_gap=None,
                              land_gap=None)
    runs = {name: foot_lock_keyword(dataclasses.replace(base, foot_lock=lock), inter, keyword) for name, lock in (
        ("off", off), ("on", dataclasses.replace(off, **{option: 0.3})),
        ("gated", dataclasses.replace(off, **{option: 0.3}, hold_near=0.1, hold_near_roll_free=True)))}
    calls = {name: seen for name, (seen, _) in runs.items()}
    assert calls["off"] and not any(calls["off"])
    assert any(calls["on"])
    assert calls["gated"] and not any(calls["gated"])
    assert getattr(runs["gated"][1], option) is None


@pytest.mark.parametrize("gaps", [None, [], [None], [0.35, None], [0.25], [0.08, 0.9], [1.2]])
def test_the_gap_flags_are_the_four_tests_of_the_last_frames_gaps(gaps) -> None:  # noqa: ANN001
    lock = FootLock(HOME, FootLockConfig(hold_lift=0.12, hold_in_contact=True, hold_near=0.1, land_gap=0.1,
                                         hold_step_gap=0.3, glide_step=0.05, glide_gap=0.12, glide_gap_far=0.06,
                                         glide_far=1.0))
    flags = lock.gap_flags(None if gaps is None else iter(gaps))  # a view is read once per test: an iterator too
    g = [] if gaps is None else gaps
    measured = [x for x in g if x is not None]
    expected = {"near": any(x <= 0.1 for x in measured), "land": any(x <= 0.1 for x in measured),
                "still": any(x <= 0.3 for x in measured), "far": not any(x <= 1.0 for x in measured),
                "still_caught": False}  # (hold_step_caught off: tests/test_hold_step_caught.py)
    assert flags == expected
    if gaps is not None:
        assert flags == {"near": lock.near(gaps), "land": lock.landing(gaps), "still": lock.stepless(gaps),
                         "far": lock.walking_up(gaps), "still_caught": False}
