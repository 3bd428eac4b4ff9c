"""The harness's release held until the capture point lies m_h inside the soles' convex hull, on a robot whose feet's
roll is freed (``BalanceConfig.release_hull_roll_free`` = m_h): the hull and the depth against hand figures and an
independent computation (each point's distance to the polygon's boundary segments, and a point-in-polygon test by
crossings), the soles' points, the decision on a staggered stance (inside the box, outside the hull: held; the bound
included; off or on another robot: ``release_margin`` alone), the catch unchanged, the setting's check, Stubby's
standing hand over bit for bit, and the H1's hand over changed."""

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
from socialaff_sim.sim.support_hull import convex_hull, hull_depth, sole_points

from conftest import assert_gate_keeps_stubby, shared_robot, standing_with

_cfg = functools.partial(standing_with, "balance")  # SimConfig.standing() with these balance fields

BASE = STANDING_BALANCE  # (flat_roll_free, which the option needs)
ON = dataclasses.replace(BASE, release_hull_roll_free=0.02)


def _sole(x0: float, y0: float, length: float = 0.3, width: float = 0.03) -> np.ndarray:
    """(4, 2) a sole's corners, heel at x0, centred on y0."""
    return np.array([[x0, y0 - width / 2], [x0 + length, y0 - width / 2], [x0, y0 + width / 2],
                     [x0 + length, y0 + width / 2]])


# a staggered stance, heading +x: the left sole (y = +0.2) from x = −0.3 to 0.0, the right (y = −0.2) from 0.0 to 0.3
LEFT, RIGHT = _sole(-0.3, 0.2), _sole(0.0, -0.2)
STAGGERED = np.vstack([LEFT, RIGHT])
BOX = SupportBox(STAGGERED, np.array([1.0, 0.0]))  # x −0.3 … 0.3, y −0.215 … 0.215


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    t = np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
    return float(np.linalg.norm(p - (a + t * (b - a))))


def _inside(poly: np.ndarray, p: np.ndarray) -> bool:
    """Point in polygon by counting crossings of a ray toward +x (independent of the edges' orientation)."""
    n, c = len(poly), False
    for i in range(n):
        (x1, y1), (x2, y2) = poly[i], poly[(i + 1) % n]
        if (y1 > p[1]) != (y2 > p[1]) and p[0] < x1 + (p[1] - y1) * (x2 - x1) / (y2 - y1):
            c = not c
    return c


def test_the_hull_of_a_staggered_stance_by_hand() -> None:
    hull = convex_hull(STAGGERED)
    # six corners: the rear sole's heel pair and outer toe, the front sole's toe pair and outer heel
    expected = {(-0.3, 0.185), (0.0, -0.215), (0.3, -0.215), (0.3, -0.185), (0.0, 0.215), (-0.3, 0.215)}
    assert {tuple(np.round(v, 6)) for v in hull} == expected
    area = 0.5 * sum(hull[i - 1, 0] * hull[i, 1] - hull[i, 0] * hull[i - 1, 1] for i in range(len(hull)))
    assert area == pytest.approx(0.6 * 0.43 - 2 * 0.5 * 0.3 * 0.4)  # counter-clockwise: the box less two triangles
    # the front edge from (0.0, 0.215) to (0.3, −0.185): slope −0.4 / 0.3; the point (0.1, 0.1) lies beyond it
    n = np.array([0.4, 0.3]) / 0.5  # outward normal of that edge
    assert hull_depth(hull, np.array([0.1, 0.1])) == pytest.approx(-float(n @ (np.array([0.1, 0.1]) - [0.0, 0.215])))
    assert BOX.inside(np.array([0.1, 0.1]), 0.01)  # while the box counts it 11.5 cm inside
    assert hull_depth(hull, np.zeros(2)) == pytest.approx(float(n @ np.array([0.0, 0.215])))  # the middle: 12.9 cm
    assert hull_depth(convex_hull(np.array([[0, 0], [1, 1], [2, 2.0]])), np.array([1.0, 1.0])) == -np.inf  # no area


def test_the_depth_against_an_independent_computation() -> None:
    rng = np.random.default_rng(7)
    for _ in range(40):
        pts = rng.normal(size=(12, 2)) * [0.3, 0.2]
        hull = convex_hull(pts)
        for q in rng.normal(size=(20, 2)) * 0.4:
            d = hull_depth(hull, q)
            boundary = min(_segment_distance(q, hull[i], hull[(i + 1) % len(hull)]) for i in range(len(hull)))
            if _inside(hull, q):
                assert d == pytest.approx(boundary, abs=1e-12)  # inside: the distance to the boundary
            else:
                assert -boundary - 1e-12 <= d < 0.0  # outside: negative, at most the distance's size
        for q in pts:  # every input point lies in its hull (on its boundary at most)
            assert hull_depth(hull, q) >= -1e-12


def test_the_soles_points() -> None:
    soles = [np.hstack([LEFT, np.zeros((4, 1))]), None]
    pts = np.array([[0.1, -0.2, 0.0], [0.2, -0.2, 0.0], [0.15, -0.19, 0.0], [-0.1, 0.2, 0.0]])
    which = np.array([1, 1, 1, 0])
    out = sole_points(soles, pts, which)
    np.testing.assert_array_equal(out, np.vstack([LEFT, pts[:3, :2]]))  # the left's sole, the right's contacts
    out = sole_points(soles, pts[:3], which[:3])  # the left foot without a contact: left out
    np.testing.assert_array_equal(out, pts[:3, :2])


def _released(scene, config: BalanceConfig, roll_freed: bool, capture, soles=STAGGERED) -> bool:  # noqa: ANN001
    h = HarnessRelease(scene, config, roll_freed)
    d = mujoco.MjData(scene.model)
    h.decide(d, 0.2, True, 0.0, BOX, np.asarray(capture, float), soles=soles)  # planted 0.2 s, upright
    return h.released


def test_the_release_waits_for_the_capture_point_inside_the_hull(scene) -> None:  # noqa: ANN001
    n = np.array([0.4, 0.3]) / 0.5  # the front edge's outward normal (the test above)
    edge = np.array([0.0, 0.215])
    on_edge = edge + np.array([0.15, -0.2])  # the front edge's middle
    for depth, expected in ((0.05, True), (0.02, True), (0.019, False), (0.0, False), (-0.05, False)):
        p = on_edge - depth * n
        assert BOX.inside(p, 0.01)  # the box alone lets every one of them go
        assert _released(scene, ON, True, p) == expected, depth
        assert _released(scene, BASE, True, p)  # off
        assert _released(scene, ON, False, p)  # a robot whose feet's roll is not freed
    assert not _released(scene, ON, True, (0.0, 0.0), soles=STAGGERED[:2])  # a sole seen edge-on: no area, held
    assert HarnessRelease(scene, ON, True).hull == 0.02
    assert HarnessRelease(scene, ON, False).hull is None and HarnessRelease(scene, BASE, True).hull is None


def test_the_catch_is_unchanged(scene) -> None:  # noqa: ANN001
    h = HarnessRelease(scene, ON, True)
    d = mujoco.MjData(scene.model)
    h.decide(d, 0.2, True, 0.0, BOX, np.zeros(2), soles=STAGGERED)
    assert h.released
    h.decide(d, 0.002, True, 0.0, BOX, np.array([0.15, 0.15]), soles=STAGGERED)  # outside the hull, inside the box
    assert h.released and h.catches == 0


@pytest.mark.parametrize("kw", [{"release_hull_roll_free": 0.02, "flat_roll_free": False, "hand_task_roll_free": False},
                                {"release_hull_roll_free": -0.01}])
def test_the_setting_is_checked(kw) -> None:  # noqa: ANN001
    with pytest.raises(ConfigError, match="release_hull_roll_free"):
        dataclasses.replace(BASE, **kw)
    assert BASE.release_hull_roll_free is None and BalanceConfig().release_hull_roll_free is None
    assert dataclasses.replace(BASE, release_hull_roll_free=0.0).release_hull_roll_free == 0.0


def _inter(label: str, instance: int):  # noqa: ANN202
    from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset

    return generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=instance + 1)).by_id(
        f"{label}_{instance}")


def test_stubby_runs_bit_for_bit_as_without_it() -> None:
    """Stubby's feet's roll is not freed: its standing hand over (spent hand_over_120) is the same, state for state,
    with the bound; a release margin of 12 cm for every robot changes it (so the check can fail)."""
    assert_gate_keeps_stubby(_inter("hand_over", 120), _cfg(), _cfg(release_hull_roll_free=0.02),
                             _cfg(release_margin=0.12))


def test_the_h1_hand_over_gets_the_bound_and_changes() -> None:
    """The H1 (skipped without ../shared/robots): in its hand over (spent hand_over_861, let go with the capture point
    outside the soles' hull and caught for tilt eight times in A) the harness keeps m_h and the episode changes."""
    from socialaff_sim.retarget.robot import load_robot
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode
    from socialaff_sim.sim.simulator import Simulator

    spec = load_robot("unitree_h1", mjcf=shared_robot("unitree_h1", "h1.xml"))
    out = []
    for kw in ({}, {"release_hull_roll_free": 0.02}):
        sim = Simulator(spec, "hand_over", _cfg(**kw))
        m = run_episode(sim, GroundTruthSource(), _inter("hand_over", 861))
        out.append((sim._stage.stepper.balance.harness, m))
    (h_off, m_off), (h_on, m_on) = out
    assert h_off.hull is None and h_on.hull == 0.02
    assert h_on.catch_reasons != h_off.catch_reasons or h_on.released_steps != h_off.released_steps
