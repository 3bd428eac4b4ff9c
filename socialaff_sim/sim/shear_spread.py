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

__all__ = ["FORMS", "feet_shear_cost", "shear_couple", "shear_couple_cost", "shear_spread", "shear_spread_cost"]


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


FORMS = ("couple", "split", "moment")
"""``BalanceConfig.shear_couple_form``'s values (:func:`shear_couple_cost`)."""


def _line(which: np.ndarray, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The vector from foot 0's contact centroid to foot 1's (horizontal) and their midpoint."""
    c0, c1 = pts[which == 0, :2].mean(axis=0), pts[which == 1, :2].mean(axis=0)
    return c1 - c0, 0.5 * (c0 + c1)


def shear_couple_cost(edges: np.ndarray, which: np.ndarray, pts: np.ndarray, weight: float,
                      form: str = "couple") -> np.ndarray:
    """(4P, 4P) W with ``½ β'ᵀ W β' = ½ w_c q²`` for the cone edges ``edges`` (P, 3, 4; world), each point's foot
    ``which`` (P,; 0 or 1), its position ``pts`` (P, 3; world) and ``weight`` w_c [—] (``BalanceConfig.shear_couple``).
    s = (T₁ − T₀)/2 is the two feet's shear resultants' internal split (T_f = Σ_{p ∈ f} t_p, scaled as
    :func:`shear_spread_cost`'s), d the horizontal vector between the feet's contact centroids, n its unit normal.
    ``form``: ``"couple"``: q = n · s, the feet's couple about the vertical (the moment of T₀ and T₁ about the
    centroids' midpoint over |d|); ``"split"``: q² = ‖s‖² (the couple and the squeeze along the line);
    ``"moment"``: q = M_z / |d| with M_z = Σ_p ((r_p − mid) × t_p)_z the floor's whole moment about the vertical
    through the midpoint (each sole's own torsion included). A net horizontal force shared equally by the feet costs
    nothing in every form, shear moved between one foot's points keeping its resultant nothing in the first two.
    Zeros unless both feet have a point."""
    P = len(edges)
    K = 4 * P
    which = np.asarray(which)
    if P < 2 or not ((which == 0).any() and (which == 1).any()):
        return np.zeros((K, K))
    d, mid = _line(which, pts)
    length = max(float(np.hypot(*d)), 1e-9)
    if form == "moment":
        r = pts[:, :2] - mid
        u = ((r[:, 0:1] * edges[:, 1, :] - r[:, 1:2] * edges[:, 0, :]) / length).reshape(1, K)
    else:
        sign = np.where(which == 1, 0.5, -0.5)  # s = ½ T₁ − ½ T₀
        u = (edges[:, :2, :] * sign[:, None, None]).transpose(1, 0, 2).reshape(2, K)  # (2, 4P): s per unit weight
        if form == "couple":
            u = (np.array([-d[1], d[0]]) / length @ u)[None, :]
    return weight * (u.T @ u)


def shear_couple(forces: np.ndarray, which: np.ndarray, pts: np.ndarray, form: str = "couple") -> float:
    """q² (N²; :func:`shear_couple_cost`'s q) of the contact forces ``forces`` (P, 3; world) on the feet ``which`` at
    ``pts``, summed foot by foot (the reference the tests hold it to)."""
    f = np.asarray(forces, dtype=np.float64)[:, :2]
    which = np.asarray(which)
    if not ((which == 0).any() and (which == 1).any()):
        return 0.0
    d, mid = _line(which, pts)
    if form == "moment":
        r = pts[:, :2] - mid
        return float(((r[:, 0] * f[:, 1] - r[:, 1] * f[:, 0]).sum() / np.linalg.norm(d)) ** 2)
    s = 0.5 * (f[which == 1].sum(axis=0) - f[which == 0].sum(axis=0))
    if form == "split":
        return float(s @ s)
    return float((np.array([-d[1], d[0]]) @ s / np.linalg.norm(d)) ** 2)


def feet_shear_cost(spread: np.ndarray | None, spread_on: bool, couple: float | None, couple_on: bool,
                    form: str, edges: np.ndarray, which: np.ndarray, pts: np.ndarray) -> np.ndarray | None:
    """The balance QP's ``force_cost`` at one solve: ``spread`` (:func:`shear_spread_cost` of these edges, or
    ``None``) where ``spread_on``, plus w_c = ``couple``'s :func:`shear_couple_cost` of ``form`` where ``couple_on``;
    ``None`` when neither applies."""
    cost = spread if spread_on else None
    if couple is not None and couple_on:
        w = shear_couple_cost(edges, which, pts, couple, form)
        cost = w if cost is None else cost + w
    return cost
