"""The balance QP's centre-of-pressure rows as the settings choose them (:func:`~socialaff_sim.sim.cop_constraints.
cop_constraint_rows`): along the support box's axes by default, along each foot's own axes with ``cop_foot_axes``, the
sole-corner rows appended with ``cop_corner_share``; each branch against the functions it must call, so that an
inverted choice fails."""

from __future__ import annotations

import numpy as np
import pytest

from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.contact_dynamics import cone_edges
from socialaff_sim.sim.contact_qp import cop_rows
from socialaff_sim.sim.cop_constraints import cop_constraint_rows
from socialaff_sim.sim.foot_cop import foot_cop_rows
from socialaff_sim.sim.sole_corners_load import corner_share_rows
from socialaff_sim.sim.support_box import cop_intervals


def _feet(yaw: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[np.ndarray | None], np.ndarray]:
    """Two 0.22 × 0.11 m soles turned ``yaw`` (rad), their corners as contact points (world, on the floor), the
    cones' edges (μ 0.8), each point's foot, the soles (4, 3) and each foot's rotation (2, 9) about z."""
    c, s = np.cos(yaw), np.sin(yaw)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    local = np.array([[x, y, 0.0] for x in (-0.11, 0.11) for y in (-0.055, 0.055)])
    soles = [np.array([0.0, y, 0.0]) + local @ rot.T for y in (0.1, -0.1)]
    pts = np.concatenate(soles)
    frames = np.tile(np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]), (len(pts), 1, 1))
    return pts, cone_edges(frames, 0.8), np.repeat([0, 1], 4), soles, np.tile(rot.reshape(9), (2, 1))


@pytest.mark.parametrize("yaw", [0.0, np.radians(5.0)])
def test_each_setting_takes_its_own_rows(yaw: float) -> None:
    pts, edges, which, soles, xmat = _feet(yaw)
    feet, forward = np.array([0, 1]), np.tile([1.0, 0.0, 0.0], (2, 1))
    box = np.eye(2)  # the support box's axes: the feet's mean heading taken as +x
    fwd = np.tile([np.cos(yaw), np.sin(yaw)], (2, 1))
    xy = [so[:, :2] for so in soles]
    bounds = np.asarray(cop_intervals(box, xy, [pts[which == s, :2] for s in (0, 1)], 0.01))
    along_box = cop_rows(pts, edges, which, box, bounds)
    own = foot_cop_rows(pts, edges, which, xy, fwd, 0.01)
    corners = corner_share_rows(pts, edges, which, xy, fwd, 0.0)

    def rows(**kw: object) -> np.ndarray:
        return cop_constraint_rows(BalanceConfig(solver="qp", **kw), pts, edges, which, box, soles, xmat, feet, forward)

    np.testing.assert_array_equal(rows(), along_box)
    np.testing.assert_array_equal(rows(cop_foot_axes=True), own)
    np.testing.assert_array_equal(rows(cop_corner_share=0.0), np.concatenate([along_box, corners]))
    np.testing.assert_array_equal(rows(cop_foot_axes=True, cop_corner_share=0.0), np.concatenate([own, corners]))
    if yaw:  # turned feet: the box's rows and the feet's own differ, so a swapped choice shows
        assert not np.allclose(along_box, own)


def test_no_foot_with_points_gives_unbounded_rows() -> None:
    pts, edges, which, soles, xmat = _feet(0.0)
    none = np.full(len(pts), -1)
    out = cop_constraint_rows(BalanceConfig(solver="qp"), pts, edges, none, np.eye(2), soles, xmat, np.array([0, 1]),
                              np.tile([1.0, 0.0, 0.0], (2, 1)))
    np.testing.assert_array_equal(out, cop_rows(pts, edges, none, np.eye(2), np.zeros((2, 2, 2))))
