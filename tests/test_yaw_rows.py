"""``BalanceConfig.yaw_ratio``: each foot's moment about the vertical bounded by γ times its vertical force in the
balance QP (:func:`~socialaff_sim.sim.contact_qp.yaw_rows`; issue 25, the standing mode's feet)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.contact_dynamics import cone_edges
from socialaff_sim.sim.contact_qp import solve_contact_qp, yaw_rows
from test_balance_control import BIPED
from test_balance_qp import MU, _problem


def _moments(forces: np.ndarray, pts: np.ndarray, foot: np.ndarray, centres: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each foot's moment about the vertical through its centre (np.cross) and its vertical force."""
    mz = np.array([np.cross(pts[foot == s] - centres[s], forces[foot == s])[:, 2].sum() for s in range(len(centres))])
    fz = np.array([forces[foot == s, 2].sum() for s in range(len(centres))])
    return mz, fz


def test_rows_hold_exactly_when_each_foots_moment_is_within_gamma_times_its_load(rng) -> None:
    gamma = 0.03
    for _ in range(300):
        P = 8
        sides = np.array([[0.0, 0.1]] * 4 + [[0.0, -0.1]] * 4)
        pts = np.concatenate([rng.uniform(-0.1, 0.1, (P, 2)) + sides, np.zeros((P, 1))], axis=1)
        foot = np.repeat([0, 1], 4)
        foot[rng.integers(P)] = -1  # a point of no foot: left out
        centres = np.array([[0.01, 0.1, 0.0], [-0.02, -0.1, 0.0]])
        yaw = rng.uniform(-0.5, 0.5, P)  # contact frames turned about the vertical
        frames = np.array([[[0.0, 0.0, 1.0], [np.cos(a), np.sin(a), 0.0], [-np.sin(a), np.cos(a), 0.0]] for a in yaw])
        edges = cone_edges(frames, MU)
        beta = rng.exponential(size=(P, 4)) * (rng.random((P, 4)) < 0.7)
        forces = np.einsum("pik,pk->pi", edges, beta)
        keep = foot >= 0
        mz, fz = _moments(forces[keep], pts[keep], foot[keep], centres)
        rows = yaw_rows(pts, edges, foot, centres, gamma) @ beta.ravel()
        assert rows.shape == (4,)
        np.testing.assert_allclose(rows, np.ravel(np.column_stack([gamma * fz - mz, gamma * fz + mz])), atol=1e-9)
        assert bool((rows >= 0).all()) == bool((np.abs(mz) <= gamma * fz).all())


def test_a_foot_without_points_gets_no_rows() -> None:
    pts = np.zeros((2, 3))
    edges = cone_edges(np.tile(np.eye(3)[[2, 0, 1]], (2, 1, 1)), MU)
    assert yaw_rows(pts, edges, np.array([1, 1]), np.zeros((2, 3)), 0.02).shape == (2, 8)
    assert yaw_rows(pts, edges, np.array([-1, -1]), np.zeros((2, 3)), 0.02).shape == (0, 8)


def test_the_bound_binds_on_a_trunk_asked_to_turn_and_the_turn_gives() -> None:
    # The biped standing straight, its trunk asked for a yaw acceleration: the floor must twist it.
    m = mujoco.MjModel.from_xml_string(BIPED)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    tasks = [(np.eye(m.nv)[3:6], np.array([0.0, 0.0, 8.0]), 10.0), (np.eye(m.nv)[:3], np.zeros(3), 100.0),
             (np.eye(m.nv)[6:], np.zeros(m.nv - 6), 1.0)]
    pr = _problem(m, d, tasks)
    foot = np.where(pr["bodies"] == m.body("rfoot").id, 1, 0)
    centres = np.array([pr["pts"][foot == s].mean(axis=0) for s in (0, 1)])
    n = m.nv
    lim = np.tile([-np.inf, np.inf], (n, 1))

    def solve(gamma: float | None):
        cop = None if gamma is None else yaw_rows(pr["pts"], pr["edges"], foot, centres, gamma)
        return solve_contact_qp(pr["M"], pr["h"], pr["unactuated"], pr["point_jac"], pr["edges"], tasks, pr["mass"],
                                pr["w_force"], lim, cop, foot, 0.0)

    free = solve(None)
    mz_free, fz_free = _moments(free.forces, pr["pts"], foot, centres)
    gamma = 0.25 * float((np.abs(mz_free) / fz_free).max())  # a quarter of what the free solution asks
    assert gamma > 1e-3
    held = solve(gamma)
    mz, fz = _moments(held.forces, pr["pts"], foot, centres)
    assert (np.abs(mz) <= gamma * fz + 1e-6 * pr["mass"]).all()
    assert (np.abs(mz_free) > gamma * fz_free).any()  # the free solution breaks the bound: it binds
    assert abs(held.qacc[5]) < abs(free.qacc[5])  # the trunk's turn gives, not the feet's bound
    assert held.found and np.abs(held.tau[:6]).max() <= 1e-6 * pr["mass"] * 9.81


def test_yaw_ratio_needs_the_qp_and_a_length() -> None:
    assert BalanceConfig(solver="qp", yaw_ratio=0.02).yaw_ratio == 0.02
    with pytest.raises(ConfigError, match="yaw_ratio"):
        BalanceConfig(yaw_ratio=0.02)  # least squares
    with pytest.raises(ConfigError, match="yaw_ratio"):
        BalanceConfig(solver="qp", yaw_ratio=-0.01)
