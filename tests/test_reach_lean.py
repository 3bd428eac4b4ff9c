"""The plan's trunk leaned into a reach down and ahead (``SimConfig.reach_lean``): the least lean's closed form against
a brute-force scan of rotated shoulders (an independent reference), the lean's decisions (an arm counts only reaching
ahead of and below its shoulder; within reach none; the larger arm's; the cap; a target not finite), the gate (legs
that cannot roll their feet), the config's checks, and the simulator passing the lean to the IK only with the option
and only on a robot the gate picks."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim import reach_lean as lean_module
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.reach_lean import ReachLeanConfig, least_lean, reach_lean, rolls_no_foot
from socialaff_sim.sim.simulator import SimConfig, Simulator

from conftest import spy_ik_leans

SHOULDERS = np.array([[0.0, 0.21, 0.44], [0.0, -0.21, 0.44]])  # the H1's: 0.44 m above the base
ARM = 0.554


def _scan(d: np.ndarray, s: np.ndarray, arm: float, most_deg: float = 89.0, step: float = 1e-3) -> float:
    """The least pitch (deg) on a fine grid at which the shoulder, turned by a rotation matrix about the lateral (y)
    axis that takes z toward x, lies within ``arm`` of ``d``; inf when none up to ``most_deg``."""
    for deg in np.arange(0.0, most_deg, step):
        a = math.radians(deg)
        rot = np.array([[math.cos(a), 0.0, math.sin(a)], [0.0, 1.0, 0.0], [-math.sin(a), 0.0, math.cos(a)]])
        if np.linalg.norm(d - rot @ s) <= arm:
            return float(deg)
    return math.inf


@pytest.mark.parametrize("d", [
    (0.35, 0.2, -0.1),  # a seated person's hand ahead and below: reachable by leaning
    (0.45, 0.25, 0.0),
    (0.3, 0.15, -0.15),
    (0.6, -0.1, 0.0),
])
def test_the_least_lean_against_a_scan(d: tuple[float, float, float]) -> None:
    d = np.array(d)
    got = math.degrees(least_lean(d, SHOULDERS[0], ARM))
    want = _scan(d, SHOULDERS[0], ARM)
    assert math.isfinite(want) and want > 0.0
    assert got == pytest.approx(want, abs=2e-3)
    a = math.radians(got)
    rot = np.array([[math.cos(a), 0.0, math.sin(a)], [0.0, 1.0, 0.0], [-math.sin(a), 0.0, math.cos(a)]])
    assert np.linalg.norm(d - rot @ SHOULDERS[0]) == pytest.approx(ARM, abs=1e-9)  # just reached


def test_the_least_lean_within_reach_and_beyond_any_lean() -> None:
    assert least_lean(np.array([0.2, 0.21, 0.0]), SHOULDERS[0], ARM) == 0.0  # within the arm upright
    assert least_lean(np.array([0.3, 0.21, -1.5]), SHOULDERS[0], ARM) == math.inf  # 1.5 m down: no lean reaches
    assert least_lean(np.array([-0.5, 0.21, -0.3]), SHOULDERS[0], ARM) == math.inf  # behind: leaning forward moves away
    assert _scan(np.array([-0.5, 0.21, -0.3]), SHOULDERS[0], ARM) == math.inf


def _targets(left: tuple[float, float, float], right: tuple[float, float, float]) -> np.ndarray:
    t = np.zeros((5, 3))
    t[0] = [1.0, 2.0, 1.03]  # the base target (robot frame)
    t[1] = t[0] + left
    t[2] = t[0] + right
    t[3] = [1.0, 2.1, 0.05]
    t[4] = [1.0, 1.9, 0.05]
    return t


HANG = (0.0, -0.21, -0.2)  # an arm hanging at the side, beyond the arm's length below the shoulder


@pytest.mark.parametrize("left, right, config, expected", [
    # a reach down and ahead beyond the arm: the least lean
    ((0.35, 0.2, -0.1), HANG, ReachLeanConfig(), least_lean(np.array([0.35, 0.2, -0.1]), SHOULDERS[0], ARM)),
    # the hanging arm alone (not ahead by 0.1 m): none
    ((0.05, 0.21, -0.2), HANG, ReachLeanConfig(), 0.0),
    # ... it counts once `ahead` allows it (53 and 126 degrees asked: the 30-degree cap)
    ((0.05, 0.21, -0.2), HANG, ReachLeanConfig(ahead=-1.0), math.radians(30.0)),
    # with a 60-degree cap: the hanging arm's 126 degrees capped
    ((0.05, 0.21, -0.2), HANG, ReachLeanConfig(ahead=-1.0, most=60.0), math.radians(60.0)),
    # ahead = 0: the left arm 5 cm ahead counts (53 degrees), the right 5 cm behind its shoulder does not
    ((0.05, 0.21, -0.2), (-0.05, -0.21, -0.2), ReachLeanConfig(ahead=0.0, most=60.0),
     least_lean(np.array([0.05, 0.21, -0.2]), SHOULDERS[0], ARM)),
    # ahead but above the shoulder (a raised reach): none
    ((0.7, 0.21, 0.5), HANG, ReachLeanConfig(), 0.0),
    # ahead and below, but not by `below`: none
    ((0.7, 0.21, 0.40), HANG, ReachLeanConfig(below=0.1), 0.0),
    # within reach: none
    ((0.3, 0.21, 0.2), HANG, ReachLeanConfig(), 0.0),
    # both reach down and ahead: the larger lean
    ((0.35, 0.2, -0.1), (0.3, -0.15, -0.15), ReachLeanConfig(),
     max(least_lean(np.array([0.35, 0.2, -0.1]), SHOULDERS[0], ARM),
         least_lean(np.array([0.3, -0.15, -0.15]), SHOULDERS[1], ARM))),
    # more than the cap asks: the cap
    ((0.35, 0.2, -0.1), HANG, ReachLeanConfig(most=5.0), math.radians(5.0)),
    # no lean reaches: the cap
    ((0.3, 0.21, -1.4), HANG, ReachLeanConfig(most=25.0), math.radians(25.0)),
])
def test_the_lean_decisions(left: tuple, right: tuple, config: ReachLeanConfig, expected: float) -> None:
    got = reach_lean(_targets(left, right), SHOULDERS, ARM, config)
    assert got == pytest.approx(expected, abs=1e-12)
    assert (got > 0.0) is (expected > 0.0)


def test_the_lean_sizes_of_the_table() -> None:
    """The first row's lean: 0.35 m ahead of the base, 0.1 m below it (0.54 m below the shoulder): the scan's figure,
    between 15 and 40 degrees."""
    got = math.degrees(reach_lean(_targets((0.35, 0.2, -0.1), HANG), SHOULDERS, ARM, ReachLeanConfig()))
    assert got == pytest.approx(_scan(np.array([0.35, 0.2, -0.1]), SHOULDERS[0], ARM), abs=2e-3)
    assert 15.0 < got < 40.0


def test_a_wrist_target_not_finite_leans_nothing() -> None:
    t = _targets((0.35, 0.2, -0.1), (0.35, -0.2, -0.1))
    one = reach_lean(t, SHOULDERS, ARM, ReachLeanConfig())
    t[1] = np.nan
    assert reach_lean(t, SHOULDERS, ARM, ReachLeanConfig()) == pytest.approx(one)  # the right arm's, the same
    t[2] = np.nan
    assert reach_lean(t, SHOULDERS, ARM, ReachLeanConfig()) == 0.0


@pytest.mark.parametrize("changes", [{"most": -1.0}, {"most": 90.0}, {"ahead": math.nan}, {"below": math.inf}])
def test_the_settings_are_checked(changes: dict) -> None:
    with pytest.raises(ConfigError):
        ReachLeanConfig(**changes)


def _leg(joints: int) -> mujoco.MjModel:
    """A free base with one leg of ``joints`` hinges down to its foot."""
    inner = '<body name="foot" pos="0 0 -0.1"><geom type="box" size="0.1 0.05 0.01"/></body>'
    for k in range(joints):
        inner = f'<body name="l{k}" pos="0 0 -0.1"><joint name="j{k}" type="hinge" axis="{k % 3 == 0:d} ' \
                f'{k % 3 == 1:d} {k % 3 == 2:d}"/><geom type="sphere" size="0.02"/>{inner}</body>'
    # the last hinge's body holds the foot: move the foot into it (a leg of `joints` hinges)
    xml = f'<mujoco><worldbody><body name="base" pos="0 0 1"><freejoint/><geom type="sphere" size="0.05"/>' \
          f'{inner}</body></worldbody></mujoco>'
    return mujoco.MjModel.from_xml_string(xml)


@pytest.mark.parametrize("joints, short", [(5, True), (6, False), (7, False), (4, True)])
def test_the_gate_picks_legs_that_cannot_roll_their_feet(joints: int, short: bool) -> None:
    m = _leg(joints)
    foot = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "foot")
    base = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "base")
    assert rolls_no_foot(m, [foot], base) is short


@pytest.mark.parametrize("option, gate, leaning", [
    (False, True, False),  # the option off: no lean, reach_lean never asked
    (True, True, False),  # on Stubby under the gate (its legs roll their feet): none
    (True, False, True),  # the gate off: Stubby leans as the lean says
])
def test_the_simulator_leans_only_with_the_option_on_a_gated_robot(monkeypatch: pytest.MonkeyPatch, option: bool,
                                                                   gate: bool, leaning: bool) -> None:
    inter = list(generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=1)).of_label("pull_up"))[0]
    calls: list[int] = []
    monkeypatch.setattr(lean_module, "reach_lean", lambda *a: calls.append(1) or 0.25)  # a lean of 0.25 rad
    leans = spy_ik_leans(monkeypatch)
    for mode in ("standing", "harness"):
        calls.clear()
        leans.clear()
        base = SimConfig.mode(mode)
        cfg = dataclasses.replace(base, reach_lean=ReachLeanConfig(roll_free=gate) if option else None)
        sim = Simulator("ours", "pull_up", cfg)
        run_episode(sim, GroundTruthSource(), inter)
        assert bool(calls) is leaning
        # every frame's solve leans by at least the reach's lean (the settling solves at the reset get none)
        assert sum(x >= 0.25 for x in leans) == len(calls)
        assert (max(leans) >= 0.25) is leaning
        assert (sim._reach_lean is not None) is option
        if option:
            assert sim._reach_lean.active is leaning


@pytest.mark.parametrize("label, seated_only, leaning", [
    ("shake_hands", True, False),  # the person stands: no lean under seated_only
    ("shake_hands", False, True),
    ("pull_up", True, True),  # the person sits on a chair (TaskSpec.chair)
    ("pull_up", False, True),
])
def test_the_lean_only_where_the_person_sits(label: str, seated_only: bool, leaning: bool) -> None:
    inter = list(generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=1)).of_label(label))[0]
    cfg = dataclasses.replace(SimConfig.standing(), reach_lean=ReachLeanConfig(roll_free=False, seated_only=seated_only))
    sim = Simulator("ours", label, cfg)
    sim.reset(inter)
    assert sim._reach_lean.active is leaning
