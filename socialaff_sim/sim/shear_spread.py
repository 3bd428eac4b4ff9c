"""The feet's shear beyond the net: a cost on the balance QP's contact forces (``BalanceConfig.shear_spread``).

The floor's horizontal force on a standing robot has a net part (the sum over the contact points, which moves the
centre of mass) and a spread: each point's horizontal force t_p less the points' mean t̄ = (1/P) Σ_p t_p. The spread
sums to zero; it is the feet pushed sideways against each other and their turn about the vertical (the two feet's
opposed shears, session 34's "internal split": median 24 N in Stubby's pull-ups, planned by the QP and realised by
MuJoCo's floor alike, docs/design.md §5). On a sole rocked onto an edge that shear lands on one or two lightly
loaded contacts, which slip. :func:`shear_spread_cost` is the quadratic form of

    ½ w_s Σ_p ‖t_p − t̄‖²  =  ½ β'ᵀ W β',    W = w_s (TᵀT − (1/P) SᵀS),

t_p = T_p β'_p the horizontal (world x, y) components of the point's cone edges times their weights (β' = β / m, the
QP's scaled variables, so the cost is in (m/s²)² as the QP's other rows), T (2P, 4P) block-diagonal of the points'
T_p, S = Σ_p T_p (2, 4P) the net: ``Σ_p ‖t_p − t̄‖² = Σ_p ‖t_p‖² − P ‖t̄‖²``. The net is left to the QP's tasks as
before; the spread costs w_s, so the QP plans a turn or a sideways squeeze of the feet only where its tasks gain
more than that. W is symmetric and positive semidefinite (a sum of squares); the net's directions are its null space.
"""

from __future__ import annotations

import numpy as np

__all__ = ["shear_spread", "shear_spread_cost"]


def shear_spread_cost(edges: np.ndarray, weight: float) -> np.ndarray:
    """(4P, 4P) W with ``½ β'ᵀ W β' = ½ w_s Σ_p ‖t_p − t̄‖²`` (module docstring) for the cone edges ``edges``
    (P, 3, 4; world frame, z up) and ``weight`` w_s [—]; zeros for fewer than two points (no spread)."""
    P = len(edges)
    K = 4 * P
    if P < 2:
        return np.zeros((K, K))
    tan = np.ascontiguousarray(edges[:, :2, :])  # (P, 2, 4): each edge's horizontal components per unit weight
    W = np.zeros((K, K))
    for p in range(P):  # TᵀT: block-diagonal, one 4 × 4 block per point
        W[4 * p:4 * p + 4, 4 * p:4 * p + 4] = tan[p].T @ tan[p]
    S = tan.transpose(1, 0, 2).reshape(2, K)  # (2, 4P): the net's horizontal components per edge
    W -= (S.T @ S) / P
    return weight * W


def shear_spread(forces: np.ndarray) -> float:
    """Σ_p ‖t_p − t̄‖² (N²) of the contact forces ``forces`` (P, 3; world, z up): the horizontal forces' spread
    about their mean (the reference the tests hold :func:`shear_spread_cost` to; 0 for fewer than two points)."""
    t = np.asarray(forces, dtype=np.float64)[:, :2]
    if len(t) < 2:
        return 0.0
    return float(((t - t.mean(axis=0)) ** 2).sum())
