"""Each planted sole's four corners kept loaded: the centre of pressure inside the sole's diamond
(``BalanceConfig.cop_corner_share``).

The balance QP (:mod:`~.flat_feet`) plans each planted foot standing on its sole's four corners, and its
centre-of-pressure rows (:func:`~.contact_qp.cop_rows`) keep the foot's centre of pressure inside a *box* (the sole
shrunk by ``cop_margin``). A rigid sole pressed on four equal springs at its corners (±a, ±b) with centre of pressure
(X a, Y b) (X, Y in [−1, 1], along the foot's own forward and left axes) loads its corners in the shares

    w(s₁, s₂) = (1 + s₁ X + s₂ Y) / 4,    s₁, s₂ ∈ {−1, +1},

(the plane of the springs' compression has three parameters: the load and two slopes; these are its corner values),
so all four carry load only inside the diamond |X| + |Y| ≤ 1; in the box's corners (Stubby's at 1 cm: X 0.91,
Y 0.82) the far corner's share is negative: the sole lifts it and stands on three corners, with 4–9 % of the load on
two of them, and then rocks on one (issue 25, session 33: pull_up_123's planned centre of pressure sat at the box's
corner on both axes at the median; its feet stood on one or two corners in 372 of 590 driven contact steps, and the
foot's ankle, 8 cm above the sole, moved with every rock). With ``cop_corner_share`` = λ the QP keeps every corner's
share at least λ: ``Σ_i f_z,i (1 − 4λ + s₁ x_i + s₂ y_i) ≥ 0`` for the four sign pairs, (x_i, y_i) each contact point's
position from the sole's middle over the half-extents along the foot's axes — linear in the cone edges' weights β, four
rows per foot beside the box's.
"""

from __future__ import annotations

import numpy as np

from .foot_cop import each_foot

__all__ = ["SIGNS", "corner_shares", "corner_share_rows"]

SIGNS = np.array([[1.0, 1.0], [1.0, -1.0], [-1.0, 1.0], [-1.0, -1.0]])
"""The four corners' sign pairs (s₁ forward, s₂ left), in the rows' order."""


def corner_shares(x: float, y: float) -> np.ndarray:
    """(4,) the corners' shares of the load (in :data:`SIGNS`' order) of a rigid sole on four equal corner springs
    whose centre of pressure is at (x a, y b) from its middle (a, b the half-extents; the module docstring)."""
    return (1.0 + SIGNS[:, 0] * x + SIGNS[:, 1] * y) / 4.0


def corner_share_rows(points: np.ndarray, edges: np.ndarray, which: np.ndarray, soles_xy: list[np.ndarray | None],
                      forward_xy: np.ndarray, share: float) -> np.ndarray:
    """(R, 4P) rows C with ``C β ≥ 0`` iff every foot's corners each keep at least ``share`` of its vertical load (the
    module docstring): ``points`` (P, 3) the contact points, ``edges`` (P, 3, 4) their cones' edges, ``which`` (P,)
    each point's foot (−1: none, left unbounded), ``soles_xy`` per foot its sole's corners (S, 2) on the floor
    (``None``: its contact points instead), ``forward_xy`` (F, 2) each foot's forward direction on the floor. The
    sole's middle and half-extents are those of its corners' extent along the foot's own axes. Four rows per foot
    with points, in foot order."""
    P = len(points)
    fz = edges[:, 2, :]  # (P, 4) each edge's vertical force per unit weight
    out = []
    for _, mine, axes, sole in each_foot(points, which, soles_xy, forward_xy):
        coord = np.asarray(sole) @ axes.T  # (S, 2) the sole's corners along the foot's axes
        lo, hi = coord.min(axis=0), coord.max(axis=0)
        mid, half = (lo + hi) / 2.0, np.maximum((hi - lo) / 2.0, 1e-9)
        xy = (points[mine, :2] @ axes.T - mid) / half  # (p, 2) the foot's points, in half-extents
        lever = 1.0 - 4.0 * share + xy @ SIGNS.T  # (p, 4 rows)
        rows = np.zeros((4, P, 4))
        rows[:, mine, :] = lever.T[:, :, None] * fz[mine][None, :, :]
        out.append(rows.reshape(4, 4 * P))
    return np.concatenate(out) if out else np.zeros((0, 4 * P))
