"""Each planted sole's corners kept loaded (``BalanceConfig.cop_corner_share``, an option, off; issue 25, session 33):
the corners' shares against MuJoCo's own contact forces on a box pressed off its middle, the diamond where all four
carry load, the rows against the shares worked out by brute force on a turned foot, the box's corner let through by
the box's rows and stopped by these, the config's checks, and a standing handshake whose planted feet slide less with
it (docs/design.md §5, "The standing mode's soles rocking on one corner …")."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.contact_qp import cop_rows
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.sole_corners_load import SIGNS, corner_share_rows, corner_shares
from socialaff_sim.sim.support_box import cop_intervals
from test_foot_cop import HALF, _setup, _sole  # (Stubby's sole, 0.22 × 0.11 m, as there)

_BOX = """
<mujoco>
  <option timestep="0.002"/>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1"/>
    <body name="foot" pos="0 0 0.03">
      <freejoint/>
      <geom name="sole" type="box" size="0.11 0.055 0.025" mass="1"/>
    </body>
  </worldbody>
</mujoco>
"""


def _pressed(x: float, y: float, load: float = 300.0) -> np.ndarray:
    """(4,) the shares of the box's weight plus ``load`` (N) pressed down at (x a, y b) from its middle that MuJoCo's
    floor contacts carry at each corner (in :data:`SIGNS`' order; 0 at a corner not in contact), at rest."""
    m = mujoco.MjModel.from_xml_string(_BOX)
    d = mujoco.MjData(m)
    body = m.body("foot").id
    for _ in range(1500):  # the force and its moment about the box's centre, held every step until at rest
        d.xfrc_applied[body, :3] = [0.0, 0.0, -load]
        d.xfrc_applied[body, 3:] = np.cross([x * HALF[0], y * HALF[1], 0.0], [0.0, 0.0, -load])
        mujoco.mj_step(m, d)
    share = np.zeros(4)
    f6 = np.zeros(6)
    for i in range(d.ncon):
        mujoco.mj_contactForce(m, d, i, f6)
        local = d.contact[i].pos[:2] - d.xpos[body, :2]
        k = int(np.argmin(np.abs(SIGNS * HALF - local).sum(axis=1)))  # the nearest corner
        share[k] += f6[0]  # the normal force
    assert np.linalg.norm(d.qvel) < 1e-3  # at rest
    return share / share.sum()


@pytest.mark.parametrize("x, y", [(0.0, 0.0), (0.5, 0.2), (-0.3, 0.6), (0.4, -0.45)])
def test_the_shares_inside_the_diamond_are_mujoco_s_corner_forces(x: float, y: float) -> None:
    np.testing.assert_allclose(_pressed(x, y), corner_shares(x, y), atol=0.02)  # (MuJoCo's soft contacts: within 1.1 points)


def test_outside_the_diamond_mujoco_lifts_the_far_corner() -> None:
    """Pressed at the 1 cm box's corner (0.91 a, 0.82 b): the shares' formula gives the far corner a negative share,
    and MuJoCo's floor carries nothing there (the sole stands on three corners)."""
    x, y = 1.0 - 0.01 / HALF[0], 1.0 - 0.01 / HALF[1]
    assert corner_shares(x, y)[3] < -0.1
    got = _pressed(x, y)
    assert got[3] < 1e-3 and got[0] > 0.8


def test_all_corners_loaded_exactly_inside_the_diamond() -> None:
    rng = np.random.default_rng(1)
    for x, y in rng.uniform(-1.0, 1.0, size=(500, 2)):
        assert (corner_shares(x, y).min() >= 0.0) == (abs(x) + abs(y) <= 1.0)
    np.testing.assert_allclose(corner_shares(0.3, -0.2).sum(), 1.0)


@pytest.mark.parametrize("share", [0.0, 0.05])
def test_the_rows_hold_exactly_when_every_corner_keeps_its_share(share: float) -> None:
    """Brute force: random non-negative edge weights on a foot turned 25°; its centre of pressure taken into the foot's
    frame, the corners' shares of a rigid sole on equal springs from a least-squares plane through the corners (not
    the module's formula), against the rows' verdict."""
    yaw, mid = np.radians(25.0), np.array([0.2, -0.1])
    sole = _sole(mid, yaw)
    pts, edges, which = _setup([sole])
    fwd = np.array([[np.cos(yaw), np.sin(yaw)]])
    C = corner_share_rows(pts, edges, which, [sole], fwd, share)
    assert C.shape == (4, 16)
    u, v = fwd[0], np.array([-fwd[0, 1], fwd[0, 0]])
    corners = np.array([[sx * HALF[0], sy * HALF[1]] for sx, sy in SIGNS])
    A = np.column_stack([np.ones(4), corners])  # the springs' compression plane at the corners: w + p x + q y
    rng = np.random.default_rng(0)
    agree = kept = lost = 0
    for _ in range(2000):
        beta = rng.dirichlet(np.full(16, 0.2)) * rng.uniform(1.0, 400.0)
        fz = (edges[:, 2, :] * beta.reshape(4, 4)).sum(axis=1)
        cop = (fz[:, None] * pts[:, :2]).sum(axis=0) / fz.sum() - mid
        local = np.array([cop @ u, cop @ v])
        # the least-norm corner forces with the total 1 and the moment of a unit load at the centre of pressure
        f = A @ np.linalg.solve(A.T @ A, np.array([1.0, local[0], local[1]]))  # A.T f = (1, cop)
        ok = bool(f.min() >= share - 1e-12)
        agree += ok == bool(np.all(C @ beta >= -1e-9))
        kept += ok
        lost += not ok
    assert kept > 100 and lost > 100
    assert agree == kept + lost


def test_the_box_s_corner_passes_the_box_s_rows_and_not_these() -> None:
    """Pressed at (0.9 a, 0.8 b) (inside the 1 cm box): the box's rows let it through, the corners' rows stop it; at
    (0.5 a, 0.3 b) both hold."""
    sole = SIGNS * HALF  # the corners in the shares' order
    pts, edges, which = _setup([sole])
    box = np.eye(2)
    bounds = cop_intervals(box, [sole], [sole], 0.01)[None, 0]
    for (x, y), held in (((0.9, 0.8), False), ((0.5, 0.3), True)):
        w = np.clip(corner_shares(x, y), 0.0, None) if held else None
        if w is None:  # three corners carrying that centre of pressure (the far one unloaded)
            M = np.column_stack([np.ones(3), (SIGNS[:3] * HALF)])
            w = np.linalg.solve(M.T, np.array([1.0, x * HALF[0], y * HALF[1]]))
            w = np.append(w, 0.0)
            assert w.min() >= 0.0
        beta = np.repeat(w, 4) / edges[:, 2, :].sum(axis=1).repeat(4)
        fz = (edges[:, 2, :] * beta.reshape(4, 4)).sum(axis=1)
        np.testing.assert_allclose((fz[:, None] * pts[:, :2]).sum(axis=0) / fz.sum(), [x * HALF[0], y * HALF[1]],
                                   atol=1e-12)
        assert np.all(cop_rows(pts, edges, which, box, bounds) @ beta >= 0.0)
        assert bool(np.all(corner_share_rows(pts, edges, which, [sole], np.array([[1.0, 0.0]]), 0.0) @ beta >= 0.0)) \
            == held


def test_two_feet_get_rows_on_their_own_points_and_an_unbounded_point_none() -> None:
    soles = [_sole(np.array([0.0, 0.1]), 0.1), _sole(np.array([0.0, -0.1]), -0.3)]
    pts, edges, which = _setup(soles)
    fwd = np.array([[np.cos(0.1), np.sin(0.1)], [np.cos(-0.3), np.sin(-0.3)]])
    C = corner_share_rows(pts, edges, which, soles, fwd, 0.05)
    assert C.shape == (8, 32)
    assert not C[:4, 16:].any() and not C[4:, :16].any()
    which2 = which.copy()
    which2[which == 0] = -1
    C2 = corner_share_rows(pts, edges, which2, soles, fwd, 0.05)
    assert C2.shape == (4, 32) and not C2[:, :16].any()
    np.testing.assert_allclose(C2, C[4:], atol=1e-15)


def test_off_by_default_and_checked() -> None:
    assert BalanceConfig().cop_corner_share is None
    assert SimConfig.standing().balance.cop_corner_share is None
    BalanceConfig(solver="qp", cop_corner_share=0.0)
    for bad in (-0.01, 0.25):
        with pytest.raises(ConfigError):
            BalanceConfig(solver="qp", cop_corner_share=bad)
    with pytest.raises(ConfigError):
        BalanceConfig(solver="lsq", cop_corner_share=0.05)


def test_standing_handshake_slides_less_with_every_corner_loaded() -> None:
    """shake_hands_122 (a spent instance), ground truth, the standing mode: the contact phase's slide path (the support
    meter's) with every sole corner kept loaded (λ = 0: 1.99 → 1.55 cm in development; λ = 0.05: 0.81 cm); met either
    way."""
    inter = list(generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=123)).of_label(
        "shake_hands"))[122]
    out = {}
    for share in (None, 0.0):
        base = SimConfig.standing()
        cfg = SimConfig.standing(balance=dataclasses.replace(base.balance, cop_corner_share=share))
        out[share] = run_episode(Simulator(load_robot("ours"), "shake_hands", cfg), GroundTruthSource(), inter)
    before = out[None]["support"]["contact_phase"]["foot_slide_cm"]
    after = out[0.0]["support"]["contact_phase"]["foot_slide_cm"]
    assert out[None]["success"] and out[0.0]["success"]
    assert after < before - 0.3, (before, after)
