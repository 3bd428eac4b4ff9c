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

__all__ = ["feet_shear_cost", "shear_couple", "shear_couple_cost", "shear_spread", "shear_spread_cost"]


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


def shear_couple_cost(edges: np.ndarray, which: np.ndarray, pts: np.ndarray, weight: float,
                      squeeze: bool = False) -> np.ndarray:
    """(4P, 4P) W with ``½ β'ᵀ W β' = ½ w_c (n · s)²`` (``squeeze``: ``½ w_c ‖s‖²``) for the cone edges ``edges``
    (P, 3, 4; world), each point's foot ``which`` (P,; 0 or 1) and its position ``pts`` (P, 3; world) and ``weight``
    w_c [—] (``BalanceConfig.shear_couple``): s = (T₁ − T₀)/2 the two feet's shear resultants' internal split
    (T_f = Σ_{p ∈ f} t_p, scaled as :func:`shear_spread_cost`'s), n the horizontal unit normal to the line between
    the feet's contact centroids. n · s times that line's length is the feet's couple about the vertical (the moment
    of T₀ and T₁ about their midpoint); ``squeeze`` adds the split along the line (the feet pushed apart or
    together). A net horizontal force shared equally by the feet, and any shear moved between the points of one foot
    that keeps its resultant, cost nothing. Zeros unless both feet have a point."""
    P = len(edges)
    K = 4 * P
    which = np.asarray(which)
    if P < 2 or not ((which == 0).any() and (which == 1).any()):
        return np.zeros((K, K))
    sign = np.where(which == 1, 0.5, -0.5)  # s = ½ T₁ − ½ T₀
    u = (edges[:, :2, :] * sign[:, None, None]).transpose(1, 0, 2).reshape(2, K)  # (2, 4P): s per unit weight
    if not squeeze:
        line = pts[which == 1, :2].mean(axis=0) - pts[which == 0, :2].mean(axis=0)
        n = np.array([-line[1], line[0]]) / max(float(np.hypot(*line)), 1e-9)
        u = (n @ u)[None, :]
    return weight * (u.T @ u)


def shear_couple(forces: np.ndarray, which: np.ndarray, pts: np.ndarray, squeeze: bool = False) -> float:
    """(n · s)² (``squeeze``: ‖s‖²), N², of the contact forces ``forces`` (P, 3; world) on the feet ``which`` at
    ``pts`` (:func:`shear_couple_cost`'s s and n, summed foot by foot: the reference the tests hold it to)."""
    f = np.asarray(forces, dtype=np.float64)[:, :2]
    which = np.asarray(which)
    if not ((which == 0).any() and (which == 1).any()):
        return 0.0
    s = 0.5 * (f[which == 1].sum(axis=0) - f[which == 0].sum(axis=0))
    if squeeze:
        return float(s @ s)
    line = pts[which == 1, :2].mean(axis=0) - pts[which == 0, :2].mean(axis=0)
    n = np.array([-line[1], line[0]]) / np.linalg.norm(line)
    return float((n @ s) ** 2)


def feet_shear_cost(spread: np.ndarray | None, spread_on: bool, couple: float | None, couple_on: bool,
                    squeeze: bool, edges: np.ndarray, which: np.ndarray, pts: np.ndarray) -> np.ndarray | None:
    """The balance QP's ``force_cost`` at one solve: ``spread`` (:func:`shear_spread_cost` of these edges, or
    ``None``) where ``spread_on``, plus w_c = ``couple``'s :func:`shear_couple_cost` where ``couple_on``; ``None``
    when neither applies."""
    cost = spread if spread_on else None
    if couple is not None and couple_on:
        w = shear_couple_cost(edges, which, pts, couple, squeeze)
        cost = w if cost is None else cost + w
    return cost
