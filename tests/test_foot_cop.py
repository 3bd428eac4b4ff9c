"""Each foot's centre-of-pressure rows along its own axes (``BalanceConfig.cop_foot_axes``, an option, off; issue 25,
session 32): the axes, the rows against the centre of pressure worked out directly in the foot's frame (brute force
over random forces), a foot turned 4° from the heading planned onto its long edge with the box's rows and not with
its own, two feet each with their own rows, and a standing handshake whose planted feet slide less with it
(docs/design.md §5, "The standing mode's centre-of-pressure bounds along each foot's own axes …")."""

from __future__ import annotations

import dataclasses

import numpy as np

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.contact_dynamics import cone_edges
from socialaff_sim.sim.contact_qp import cop_rows
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.foot_cop import foot_axes, foot_cop_rows
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.support_box import cop_intervals

HALF = np.array([0.11, 0.055])
"""Stubby's sole's half-extents (its foot box's 0.22 × 0.11 m bottom face, ``assets/robots/ours.xml``), m."""


def _sole(mid: np.ndarray, yaw: float) -> np.ndarray:
    """(4, 2) the corners of a sole whose middle is ``mid`` and forward axis turned ``yaw`` (rad) from +x."""
    c, s = np.cos(yaw), np.sin(yaw)
    local = np.array([[x, y] for x in (-HALF[0], HALF[0]) for y in (-HALF[1], HALF[1])])
    return mid + local @ np.array([[c, s], [-s, c]])


def _setup(soles: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The feet's corners as contact points on the floor, their level cones' edges (μ 0.8), each point's foot."""
    pts = np.concatenate([np.column_stack([s, np.zeros(4)]) for s in soles])
    frames = np.tile(np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]), (len(pts), 1, 1))  # normal up
    return pts, cone_edges(frames, 0.8), np.repeat(np.arange(len(soles)), 4)


def test_the_axes_are_the_forward_direction_and_its_left() -> None:
    ax = foot_axes(np.array([3.0, 4.0]))
    np.testing.assert_allclose(ax, [[0.6, 0.8], [-0.8, 0.6]], atol=1e-12)
    np.testing.assert_allclose(ax @ ax.T, np.eye(2), atol=1e-12)
    assert ax[0, 0] * ax[1, 1] - ax[0, 1] * ax[1, 0] > 0  # left of forward, not right


def test_the_rows_hold_exactly_when_the_centre_of_pressure_is_inside_the_shrunk_sole_in_its_own_frame() -> None:
    """Brute force: random non-negative edge weights on a foot turned 20°; the centre of pressure worked out from the
    vertical forces and taken into the foot's frame, against the rows' verdict."""
    yaw, margin, mid = np.radians(20.0), 0.01, np.array([0.3, -0.1])
    sole = _sole(mid, yaw)
    pts, edges, which = _setup([sole])
    fwd = np.array([[np.cos(yaw), np.sin(yaw)]])
    C = foot_cop_rows(pts, edges, which, [sole], fwd, margin)
    assert C.shape == (4, 16)
    rng = np.random.default_rng(0)
    agree = inside_seen = outside_seen = 0
    for _ in range(2000):
        beta = rng.dirichlet(np.full(16, 0.15)) * rng.uniform(1.0, 500.0)  # skewed: many near an edge or corner
        fz = (edges[:, 2, :] * beta.reshape(4, 4)).sum(axis=1)
        if fz.sum() < 1e-9:
            continue
        cop = (fz[:, None] * pts[:, :2]).sum(axis=0) / fz.sum() - mid
        local = np.array([cop @ fwd[0], cop @ np.array([-fwd[0, 1], fwd[0, 0]])])
        inside = bool(np.all(np.abs(local) <= HALF - margin + 1e-12))
        held = bool(np.all(C @ beta >= -1e-12))
        agree += inside == held
        inside_seen += inside
        outside_seen += not inside
    assert inside_seen > 100 and outside_seen > 100
    assert agree == inside_seen + outside_seen


def test_a_turned_foot_is_kept_off_its_long_edge_by_its_own_rows_and_not_by_the_box_s() -> None:
    """A foot turned 4° left of the heading (the +x axis), pressed 6 cm behind its middle at 0.95 of its half-width
    to the left across its own axis: inside the box's interval (the sole's extent along the heading's axes, less 1 cm:
    its rear half's left edge lies inside it) and outside its own (less 1 cm across its width: 0.82)."""
    yaw, margin, mid = np.radians(4.0), 0.01, np.zeros(2)
    sole = _sole(mid, yaw)
    pts, edges, which = _setup([sole])
    f, left = np.array([np.cos(yaw), np.sin(yaw)]), np.array([-np.sin(yaw), np.cos(yaw)])
    target = -0.06 * f + 0.95 * HALF[1] * left  # the wanted centre of pressure
    # vertical weights on the corners giving it: bilinear in the foot's frame (all non-negative)
    u, v = (target @ f) / HALF[0], (target @ left) / HALF[1]
    local = np.array([[x, y] for x in (-1, 1) for y in (-1, 1)])
    w = np.array([(1 + x * u) * (1 + y * v) / 4 for x, y in local])
    assert np.all(w >= 0)
    beta = np.repeat(w, 4) / edges[:, 2, :].sum(axis=1).repeat(4)  # equal edges per corner: f_z,i = w_i
    fz = (edges[:, 2, :] * beta.reshape(4, 4)).sum(axis=1)
    np.testing.assert_allclose((fz[:, None] * pts[:, :2]).sum(axis=0) / fz.sum(), target, atol=1e-12)
    box = np.eye(2)
    box_rows = cop_rows(pts, edges, which, box, cop_intervals(box, [sole], [sole], margin)[None, 0])
    own = foot_cop_rows(pts, edges, which, [sole], f[None], margin)
    assert np.all(box_rows @ beta >= 0.0)  # the heading's box lets it through ...
    assert np.any(own @ beta < 0.0)  # ... the foot's own rows do not
    # and pressed at 0.75 of its half-width the foot's own rows hold it too
    v = 0.75
    w = np.array([(1 + x * u) * (1 + y * v) / 4 for x, y in local])
    assert np.all(foot_cop_rows(pts, edges, which, [sole], f[None], margin) @ (
        np.repeat(w, 4) / edges[:, 2, :].sum(axis=1).repeat(4)) >= 0.0)


def test_two_feet_each_get_four_rows_on_their_own_points_along_their_own_axes() -> None:
    yaws = np.radians([10.0, -25.0])
    soles = [_sole(np.array([0.0, 0.1]), yaws[0]), _sole(np.array([0.0, -0.1]), yaws[1])]
    pts, edges, which = _setup(soles)
    fwd = np.column_stack([np.cos(yaws), np.sin(yaws)])
    C = foot_cop_rows(pts, edges, which, soles, fwd, 0.01)
    assert C.shape == (8, 32)
    assert not C[:4, 16:].any() and not C[4:, :16].any()  # foot 0's rows zero on foot 1's points and back
    for s in range(2):
        alone = foot_cop_rows(pts[which == s], edges[which == s], np.zeros(4, dtype=int), [soles[s]], fwd[s:s + 1],
                              0.01)
        np.testing.assert_allclose(C[4 * s:4 * s + 4, 16 * s:16 * s + 16], alone, atol=1e-15)
    # a point left unbounded (−1) gets no rows; a foot without points none either
    which2 = which.copy()
    which2[which == 1] = -1
    C2 = foot_cop_rows(pts, edges, which2, soles, fwd, 0.01)
    assert C2.shape == (4, 32) and not C2[:, 16:].any()
    # with no sole known the foot's contact points stand for it (here the same corners)
    np.testing.assert_allclose(foot_cop_rows(pts, edges, which, [None, None], fwd, 0.01), C, atol=1e-15)


def test_off_by_default() -> None:
    assert BalanceConfig().cop_foot_axes is False
    assert SimConfig.standing().balance.cop_foot_axes is False


def test_standing_handshake_slides_less_with_each_foot_bounded_along_its_own_axes() -> None:
    """shake_hands_122 (a spent instance), ground truth, the standing mode: the contact phase's slide path (the support
    meter's) with each foot's centre-of-pressure rows along its own axes against the heading's (2.58 → 2.00 cm in
    development; its feet turn 4–7° from the heading); the handshake is met either way."""
    inter = list(generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=123)).of_label(
        "shake_hands"))[122]
    out = {}
    for own in (False, True):
        base = SimConfig.standing()
        cfg = SimConfig.standing(balance=dataclasses.replace(base.balance, cop_foot_axes=own))
        out[own] = run_episode(Simulator(load_robot("ours"), "shake_hands", cfg), GroundTruthSource(), inter)
    before = out[False]["support"]["contact_phase"]["foot_slide_cm"]
    after = out[True]["support"]["contact_phase"]["foot_slide_cm"]
    assert out[False]["success"] and out[True]["success"]
    assert after < before - 0.4, (before, after)
