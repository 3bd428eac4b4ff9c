"""``qp_kernel = "numba"``'s centre-of-pressure rows (:mod:`socialaff_sim.sim.cop_kernel`): against the NumPy rows
(the reference), against rows written out by hand, and which path :func:`cop_constraint_rows` takes."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from socialaff_sim.sim import cop_constraints
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.cop_constraints import cop_constraint_rows
from socialaff_sim.sim.cop_kernel import compiled_cop_rows

pytest.importorskip("numba", reason="qp_kernel=\"numba\" needs numba (the [fast] extra)")


def _case(rng: np.random.Generator) -> tuple:
    """Random contact points (some unbounded, −1), cone edges, a turned box and two feet's soles (one may be unknown)."""
    P = int(rng.integers(1, 10))
    pts = rng.normal(size=(P, 3)) * 0.1
    edges = rng.normal(size=(P, 3, 4))
    foot = rng.integers(-1, 2, size=P)
    th = rng.uniform(0.0, 2.0 * np.pi)
    axes = np.array([[np.cos(th), np.sin(th)], [-np.sin(th), np.cos(th)]])
    soles = [None if rng.random() < 0.3 else rng.normal(size=(8, 3)) * 0.1 for _ in range(2)]
    return pts, edges, foot, axes, soles


def test_the_compiled_rows_are_numpys_to_rounding(rng) -> None:
    """Shapes equal and entries within 1e-12 (relative to the largest) of the NumPy rows, over cases with feet
    without points, points of no foot and feet whose sole is unknown (their contact points instead)."""
    c = BalanceConfig()
    shapes = set()
    for _ in range(300):
        pts, edges, foot, axes, soles = _case(rng)
        want = cop_constraint_rows(c, pts, edges, foot, axes, soles, None, None, None)
        got = compiled_cop_rows(pts, edges, foot, axes, soles, c.cop_margin)
        assert got.shape == want.shape
        shapes.add(got.shape[0])
        if want.size:
            np.testing.assert_allclose(got, want, rtol=0.0, atol=1e-12 * max(1.0, np.abs(want).max()))
    assert {0, 4, 8} <= shapes  # no foot, one foot and both feet bounded were all met


def test_the_compiled_rows_by_hand() -> None:
    """One foot on a 0.2 × 0.1 m sole along the world's axes, margin 1 cm, its four corners touching with vertical
    edges of unit weight: bounds [−0.09, 0.09] × [−0.04, 0.04]; the corner (0.1, 0.05)'s lever arms are 0.19, −0.01,
    0.09, −0.01; a point of no foot gets zero columns; an overlapping but narrower point set clips the interval."""
    corners = np.array([[x, y, 0.0] for x in (-0.1, 0.1) for y in (-0.05, 0.05)])
    sole = np.vstack([corners, corners + [0.0, 0.0, 0.02]])
    pts = np.vstack([corners, [[0.3, 0.3, 0.0]]])
    edges = np.zeros((5, 3, 4))
    edges[:, 2, :] = 1.0
    foot = np.array([0, 0, 0, 0, -1])
    rows = compiled_cop_rows(pts, edges, foot, np.eye(2), [sole, None], 0.01)
    assert rows.shape == (4, 20)
    want_arms = {(0.1, 0.05): (0.19, -0.01, 0.09, -0.01), (-0.1, -0.05): (-0.01, 0.19, -0.01, 0.09)}
    for p, (x, y, _) in enumerate(corners):
        if (x, y) in want_arms:
            for j, arm in enumerate(want_arms[(x, y)]):
                np.testing.assert_allclose(rows[j, 4 * p:4 * p + 4], arm, atol=1e-15)
    assert not rows[:, 16:].any()
    # points only on the front half: the interval along x is theirs, [0.05, 0.09] (the sole's shrunk end is 0.09)
    half = np.array([[0.05, -0.05, 0.0], [0.1, -0.05, 0.0], [0.05, 0.05, 0.0], [0.1, 0.05, 0.0]])
    rows = compiled_cop_rows(half, edges[:4], foot[:4], np.eye(2), [sole, None], 0.01)
    np.testing.assert_allclose(rows[0, 0:4], 0.0, atol=1e-15)  # (0.05 − lo) with lo = 0.05
    np.testing.assert_allclose(rows[1, 4:8], 0.09 - 0.1, atol=1e-15)  # (hi − 0.1) with hi = 0.09
    # no overlap at all (points beyond the sole's toe): lo = hi = the points' end nearest to the shrunk sole
    far = half + [0.2, 0.0, 0.0]
    rows = compiled_cop_rows(far, edges[:4], foot[:4], np.eye(2), [sole, None], 0.01)
    np.testing.assert_allclose(rows[0, 0:4], 0.0, atol=1e-15)  # (0.25 − 0.25)
    np.testing.assert_allclose(rows[1, 4:8], 0.25 - 0.3, atol=1e-15)


def test_the_kernel_setting_picks_the_rows(rng, monkeypatch) -> None:
    """``kernel="numba"`` with the box's axes goes through the compiled rows; ``"numpy"``, ``cop_foot_axes`` or
    ``cop_corner_share`` do not (their rows are NumPy's)."""
    calls = []
    real = cop_constraints.compiled_cop_rows

    def spy(*a):
        calls.append(1)
        return real(*a)

    monkeypatch.setattr(cop_constraints, "compiled_cop_rows", spy)
    pts, edges, foot, axes, _ = _case(rng)
    foot = np.zeros(len(pts), dtype=np.int64)
    soles = [rng.normal(size=(8, 3)) * 0.1, None]
    xmat = np.tile(np.eye(3).ravel(), (3, 1))
    fwd = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    base = BalanceConfig(solver="qp")
    for cfg, kernel, used in ((base, "numba", True), (base, "numpy", False),
                              (dataclasses.replace(base, cop_foot_axes=True), "numba", False),
                              (dataclasses.replace(base, cop_corner_share=0.1), "numba", False)):
        calls.clear()
        cop_constraint_rows(cfg, pts, edges, foot, axes, soles, xmat, np.array([1, 2]), fwd, kernel)
        assert bool(calls) == used, (cfg.cop_foot_axes, cfg.cop_corner_share, kernel)
