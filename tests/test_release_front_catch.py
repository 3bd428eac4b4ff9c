"""The harness's release in a throw held until the capture point lies m_f behind the support box's front face, on a
robot whose feet's roll is freed (``BalanceConfig.release_front_catch`` = m_f): the box's distance against a hand
computation, the decision (boundary included; a point behind the back face or beside the box still held by
``release_margin``; off, on another robot or outside a catch task: ``release_margin`` alone), the catch unchanged,
the settings' check, and the gates in episodes (Stubby's standing throw bit for bit as without the option while a
release change for every robot changes it; the H1's throw gets m_f and changes, its handshake gets none); and
``release_ahead_catch`` = ρ_a (the capture point at most ρ_a ahead of the centre of mass along the heading): its
decision, gates and check."""

from __future__ import annotations

import dataclasses
import functools

import mujoco
import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.balance_control import BalanceConfig
from socialaff_sim.sim.harness_release import HarnessRelease
from socialaff_sim.sim.sim_config import STANDING_BALANCE
from socialaff_sim.sim.support_box import SupportBox

from conftest import assert_gate_keeps_stubby, shared_robot, standing_with

_cfg = functools.partial(standing_with, "balance")  # SimConfig.standing() with these balance fields


BASE = STANDING_BALANCE  # (flat_roll_free, which the option needs)
ON = dataclasses.replace(BASE, release_front_catch=0.05)
# a box 0.2 m long (x: −0.1 … 0.1) and 0.3 m wide, heading +x
BOX = SupportBox(np.array([[-0.1, -0.15], [0.1, -0.15], [-0.1, 0.15], [0.1, 0.15]]), np.array([1.0, 0.0]))


def test_the_distance_behind_the_front_face() -> None:
    assert BOX.behind_front(np.array([0.02, 0.1])) == pytest.approx(0.08)
    assert BOX.behind_front(np.array([0.13, 0.0])) == pytest.approx(-0.03)  # ahead of the toes
    # a box heading +y: its front face is the points' largest y
    c, s = np.cos(np.pi / 2), np.sin(np.pi / 2)
    pts = np.array([[-0.15, -0.1], [0.15, -0.1], [-0.15, 0.1], [0.15, 0.1]])
    turned = SupportBox(pts, np.array([c, s]))
    assert turned.behind_front(np.array([0.0, 0.04])) == pytest.approx(0.06)


def _released(scene, config: BalanceConfig, roll_freed: bool, capture, catch: bool = True) -> bool:  # noqa: ANN001
    h = HarnessRelease(scene, config, roll_freed)
    h.gate_touched(catch)
    d = mujoco.MjData(scene.model)
    h.decide(d, 0.2, True, 0.0, BOX, np.asarray(capture, float))  # planted 0.2 s (> release_delay), upright
    return h.released


def test_the_release_waits_for_the_capture_point_behind_the_front_face(scene) -> None:  # noqa: ANN001
    for x, y, expected in (
            (0.0, 0.0, True),  # 10 cm behind the front face: let go
            (0.05, 0.0, True),  # 5 cm behind: the bound included
            (0.051, 0.0, False),  # 4.9 cm: held
            (0.08, 0.0, False),  # 2 cm (inside release_margin's 1 cm): held
            (-0.085, 0.0, True),  # near the heels: the front bound lets it go, release_margin (1 cm) too
            (-0.095, 0.0, False),  # within 1 cm of the heels: release_margin holds it
            (0.0, 0.145, False)):  # within 1 cm of the side: release_margin holds it
        assert _released(scene, ON, True, (x, y)) == expected, (x, y)
    for x, y in ((0.05, 0.0), (0.051, 0.0), (0.08, 0.0)):  # without the bound: let go within release_margin
        assert _released(scene, BASE, True, (x, y))
        assert _released(scene, ON, False, (x, y))  # a robot whose feet's roll is not freed
        assert _released(scene, ON, True, (x, y), catch=False)  # a task without a catch sub-goal


AHEAD = dataclasses.replace(BASE, release_ahead_catch=0.05)


def _released_moving(scene, config: BalanceConfig, roll_freed: bool, capture, com, catch: bool = True) -> bool:  # noqa: ANN001
    h = HarnessRelease(scene, config, roll_freed)
    h.gate_touched(catch)
    d = mujoco.MjData(scene.model)
    h.decide(d, 0.2, True, 0.0, BOX, np.asarray(capture, float), False, np.asarray(com, float))
    return h.released


def test_release_ahead_catch_waits_for_a_robot_not_moving_forward(scene) -> None:  # noqa: ANN001
    """``release_ahead_catch`` ρ_a = 5 cm: let go only while the capture point lies at most ρ_a ahead of the centre of
    mass along the heading (+x); behind it or sideways any distance is allowed."""
    for capture, com, expected in (
            ((0.04, 0.0), (0.0, 0.0), True),  # 4 cm ahead: let go
            ((0.03, 0.0), (-0.02, 0.0), True),  # 5 cm: the bound included
            ((0.04, 0.0), (-0.011, 0.0), False),  # 5.1 cm: held
            ((0.05, 0.0), (-0.05, 0.0), False),  # 10 cm ahead: held
            ((-0.05, 0.0), (0.05, 0.0), True),  # moving back 10 cm: let go
            ((0.0, 0.1), (0.0, -0.05), True)):  # sideways 15 cm: let go
        assert _released_moving(scene, AHEAD, True, capture, com) == expected, (capture, com)
        assert _released_moving(scene, BASE, True, capture, com)  # off: let go
        assert _released_moving(scene, AHEAD, False, capture, com)  # feet's roll not freed
        assert _released_moving(scene, AHEAD, True, capture, com, catch=False)  # no catch sub-goal
    h = HarnessRelease(scene, AHEAD, True)
    assert h.ahead == 0.05
    h.gate_touched(False)
    assert h.ahead is None
    for kw in ({"release_ahead_catch": -0.01}, {"release_ahead_catch": 0.05, "flat_roll_free": False,
                                                 "hand_task_roll_free": False}):
        with pytest.raises(ConfigError, match="release_ahead_catch"):
            dataclasses.replace(BASE, **kw)
    assert BASE.release_ahead_catch is None


def test_release_front_long_bounds_only_a_long_box(scene) -> None:  # noqa: ANN001
    """``release_front_long`` L_f: the front bound only while the box is at least L_f long along the heading (BOX:
    0.2 m); a shorter box is let go within ``release_margin`` as without the bound."""
    held = (0.08, 0.0)  # 2 cm behind the toes: m_f = 5 cm holds it
    assert not _released(scene, dataclasses.replace(ON, release_front_long=0.2), True, held)  # 0.2 m: the bound acts
    assert not _released(scene, dataclasses.replace(ON, release_front_long=0.0), True, held)
    assert _released(scene, dataclasses.replace(ON, release_front_long=0.21), True, held)  # the box shorter: let go
    for kw in ({"release_front_long": -0.1}, {"release_front_long": 0.35, "release_front_catch": None}):
        with pytest.raises(ConfigError, match="release_front_long"):
            dataclasses.replace(ON, **kw)


def test_the_gate(scene) -> None:  # noqa: ANN001
    h = HarnessRelease(scene, ON, True)
    assert h.front == 0.05
    h.gate_touched(False)
    assert h.front is None
    h.gate_touched(True)
    assert h.front == 0.05
    assert HarnessRelease(scene, ON, False).front is None
    assert HarnessRelease(scene, BASE, True).front is None


def test_the_catch_is_unchanged(scene) -> None:  # noqa: ANN001
    h = HarnessRelease(scene, ON, True)
    h.gate_touched(True)
    d = mujoco.MjData(scene.model)
    h.decide(d, 0.2, True, 0.0, BOX, np.zeros(2))
    assert h.released
    h.decide(d, 0.002, True, 0.0, BOX, np.array([0.12, 0.0]))  # 2 cm ahead of the toes, within catch_margin (3 cm)
    assert h.released and h.catches == 0
    h.decide(d, 0.002, True, 0.0, BOX, np.array([0.135, 0.0]))
    assert not h.released and h.catch_reasons["capture"] == 1


@pytest.mark.parametrize("kw", [{"release_front_catch": 0.05, "flat_roll_free": False, "hand_task_roll_free": False},
                                {"release_front_catch": 0.0}, {"release_front_catch": -0.02}])
def test_the_setting_is_checked(kw) -> None:  # noqa: ANN001
    with pytest.raises(ConfigError, match="release_front_catch"):
        dataclasses.replace(BASE, **kw)
    assert BASE.release_front_catch is None and BalanceConfig().release_front_catch is None


def _inter(label: str, instance: int):  # noqa: ANN202
    from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset

    return generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=instance + 1)).by_id(
        f"{label}_{instance}")


def test_stubby_runs_bit_for_bit_as_without_it() -> None:
    """Stubby's feet's roll is not freed: its standing throw (spent throw_catch_120) is the same, state for state,
    with either bound; a release margin of 12 cm for every robot changes it (so the check can fail)."""
    assert_gate_keeps_stubby(_inter("throw_catch", 120), _cfg(), _cfg(release_front_catch=0.05, release_front_long=0.35,
                                                                      release_ahead_catch=0.0),
                             _cfg(release_margin=0.12))


def _run(spec, label: str, instance: int, **balance):  # noqa: ANN001, ANN003, ANN202
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode
    from socialaff_sim.sim.simulator import Simulator

    sim = Simulator(spec, label, _cfg(**balance))
    m = run_episode(sim, GroundTruthSource(), _inter(label, instance))
    return sim._stage.stepper.balance.harness, m


def test_the_h1_throw_gets_the_bound_and_changes() -> None:
    """The H1 (skipped without ../shared/robots): in its throw (spent throw_catch_560, released at the touch with the
    capture point 1.4 cm behind the toes in A) the harness keeps m_f and the episode changes; in its handshake
    (shake_hands_560) the simulator drops it."""
    from socialaff_sim.retarget.robot import load_robot

    spec = load_robot("unitree_h1", mjcf=shared_robot("unitree_h1", "h1.xml"))
    h_off, m_off = _run(spec, "throw_catch", 560)
    h_on, m_on = _run(spec, "throw_catch", 560, release_front_catch=0.05)
    assert h_off.front is None and h_on.front == 0.05
    assert any(m_on[k] != m_off[k] for k in ("support", "subgoals", "success", "failures"))
    h_hs, _ = _run(spec, "shake_hands", 560, release_front_catch=0.05)
    assert h_hs.front is None
