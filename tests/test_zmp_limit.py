"""The centre of mass's wanted acceleration limited to what the soles can push (``BalanceConfig.zmp_limit``):
:func:`zmp_limited` against a point mass's zero-moment point written out here, and the controller's centre-of-mass
row with and without the option."""

from __future__ import annotations

import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim import balance_control
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.support_box import SupportBox
from socialaff_sim.sim.zmp_limit import zmp_limited

from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.scene import Scene, build_scene

from test_balance_control import LAYOUT, standing_far

G = 9.81
TURN = np.radians(30.0)
FWD = np.array([np.cos(TURN), np.sin(TURN)])
LEFT = np.array([-FWD[1], FWD[0]])
# a box 0.30 m deep (forward) and 0.20 m wide, turned by 30°, its middle at (1, 2)
MID = np.array([1.0, 2.0])
BOX = SupportBox(np.array([MID + sx * 0.15 * FWD + sy * 0.10 * LEFT for sx in (-1, 1) for sy in (-1, 1)]), FWD)


@pytest.fixture(scope="module")
def scene() -> Scene:
    return build_scene(load_robot("ours"), LAYOUT, harness_time_constant=0.02)


def _zmp(com: np.ndarray, a: np.ndarray, h: float) -> np.ndarray:
    """A point mass's zero-moment point on the floor: where the floor's force acts so that its moment about the
    mass balances m·a at height h: p = c − a h / g (in the box's frame for the checks below)."""
    return np.array([(com - a * h / G) @ FWD - MID @ FWD, (com - a * h / G) @ LEFT - MID @ LEFT])


@pytest.mark.parametrize("a_fwd, a_left", [(0.5, 0.2), (-1.0, 0.0), (0.0, -0.5)])
def test_an_acceleration_the_soles_can_push_is_unchanged(a_fwd: float, a_left: float) -> None:
    com, h = MID + 0.02 * FWD, 0.9
    a = a_fwd * FWD + a_left * LEFT
    assert np.all(np.abs(_zmp(com, a, h)) <= [0.15 - 0.03, 0.10 - 0.03])  # inside the shrunk box (the case's premise)
    out = zmp_limited(BOX, com, a, h, G, 0.03)
    assert np.array_equal(out, a)


@pytest.mark.parametrize("a_fwd, a_left", [(-3.0, 0.0), (2.5, 0.3), (0.4, -4.0), (-6.0, 6.0)])
def test_an_acceleration_past_the_soles_is_cut_to_the_shrunk_boxs_edge(a_fwd: float, a_left: float) -> None:
    # The wanted acceleration's zero-moment point lies outside the box shrunk by 3 cm; the limited one's lies on its
    # edge, each axis clipped on its own (the box's axes), and the limit keeps each axis's sign.
    com, h, m = MID + np.array([0.01, -0.02]), 1.0, 0.03
    a = a_fwd * FWD + a_left * LEFT
    p = _zmp(com, a, h)
    half = np.array([0.15 - m, 0.10 - m])
    assert np.any(np.abs(p) > half)
    out = zmp_limited(BOX, com, a, h, G, m)
    q = _zmp(com, out, h)
    np.testing.assert_allclose(q, np.clip(p, -half, half), atol=1e-12)
    assert not np.allclose(out, a)
    assert np.all(np.sign(out @ np.array([FWD, LEFT]).T) * np.sign([a_fwd, a_left]) >= 0)


def test_the_higher_the_centre_of_mass_the_smaller_the_acceleration_allowed() -> None:
    com, a = MID.copy(), 10.0 * FWD
    lo, hi = zmp_limited(BOX, com, a, 0.5, G, 0.0), zmp_limited(BOX, com, a, 1.0, G, 0.0)
    np.testing.assert_allclose(lo @ FWD, 0.15 * G / 0.5)  # the zero-moment point at the heel: a = 0.15 g / h
    np.testing.assert_allclose(hi @ FWD, 0.15 * G / 1.0)


def test_zmp_limit_rejects_a_negative_margin() -> None:
    with pytest.raises(ConfigError, match="zmp_limit"):
        BalanceConfig(zmp_limit=-0.01)


@pytest.mark.parametrize("limit", [None, 0.02])
def test_the_controllers_centre_of_mass_row_asks_only_what_the_soles_can_push(scene: Scene, monkeypatch,
                                                                             limit: float | None) -> None:
    # Stubby at home, its centre of mass ~2 cm behind the middle of its feet, held at the middle with ω_c = 30 rad/s:
    # the feedback asks ~18 m/s² forward, a zero-moment point far behind the heels. With the option the row the QP
    # gets asks for the acceleration whose zero-moment point is on the shrunk box's edge; without it, the feedback's.
    seen = []
    real = balance_control.solve_contact_qp

    def spy(M, h, unactuated, jac, edges, tasks, *args, **kwargs):
        seen.append(tasks)
        return real(M, h, unactuated, jac, edges, tasks, *args, **kwargs)

    monkeypatch.setattr(balance_control, "solve_contact_qp", spy)
    cfg = BalanceConfig(solver="qp", com_reference="middle", com_bandwidth=30.0, support_margin=0.0,
                        drive_harnessed=True, release=False, zmp_limit=limit)
    d, q, ctl, ctrl0 = standing_far(scene, cfg)
    m = scene.model
    ctl.begin_frame(q, (True, True))
    captured = {}
    real_box = balance_control.SupportBox

    def box_spy(xy, fwd):
        captured["box"] = real_box(xy, fwd)
        return captured["box"]

    monkeypatch.setattr(balance_control, "SupportBox", box_spy)
    for _ in range(50):  # until both feet are on the floor and the controller drives
        d.ctrl[scene.act_ids] = ctrl0
        ctl.step(m, d, q, np.zeros(len(scene.robot_vadr) - 6))
        if seen:
            break
    assert len(seen) == 1 and ctl.active
    com_task = seen[0][len(ctl._feet)]  # after the feet's tasks: (J, b, w) of the centre of mass
    assert com_task[0].shape[0] == 2
    b = com_task[1]
    box = captured["box"]
    # the state the controller saw (after mj_step1 the kinematics are those of the step's start)
    com = np.array(d.subtree_com[scene.root_body])
    pts = ctl.feet.contacts(d)[0]
    h = com[2] - pts[:, 2].mean()
    p = box.R @ (com[:2] - b * h / G)
    shrink = 0.0 if limit is None else limit
    inside = bool(np.all(p >= box.lo + shrink - 2e-3) and np.all(p <= box.hi - shrink + 2e-3))
    assert inside == (limit is not None)
    assert np.linalg.norm(b) > (1.0 if limit is not None else 5.0)
