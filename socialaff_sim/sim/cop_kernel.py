"""The balance QP's centre-of-pressure rows along the support box's axes in one compiled loop (``qp_kernel="numba"``).

:func:`~.cop_constraints.cop_constraint_rows` (its default: the box's axes, no corner shares) finds each planted
foot's centre-of-pressure interval (:func:`~.support_box.cop_intervals`) and writes its four rows
(:func:`~.contact_qp.cop_rows`) with some two dozen NumPy calls per driven physics step. :func:`compiled_cop_rows`
does the same arithmetic in one no-Python loop (:func:`~socialaff_sim.inference.compiled.njit`, fast-math off).
Minima, maxima, the margin's and the lever arms' differences and their products with the edges' vertical
components are the same IEEE operations; the projections on the box's axes (two products and a sum per point) are
not bit for bit BLAS's (which fuses them), so the rows differ from NumPy's in their last digits: an alternative
evaluation, judged with ``qp_kernel="numba"`` by its rule (docs/design.md §5, session 34). NumPy stays the reference.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..inference.compiled import njit, once

__all__ = ["compiled_cop_rows", "cop_kernel"]


def _cop(points, edges, foot, axes, soles, has_sole, margin):  # pragma: no cover - compiled; tested through compiled_cop_rows
    P = points.shape[0]
    F = soles.shape[0]
    # the feet with points (foot ≥ 0), in order
    count = np.zeros(F, dtype=np.int64)
    for p in range(P):
        if foot[p] >= 0:
            count[foot[p]] += 1
    n_on = 0
    for s in range(F):
        if count[s] > 0:
            n_on += 1
    rows = np.zeros((4 * n_on, 4 * P))
    if n_on == 0:
        return rows
    coord = np.empty((P, 2))
    for p in range(P):
        for a in range(2):
            coord[p, a] = points[p, 0] * axes[a, 0] + points[p, 1] * axes[a, 1]
    bounds = np.zeros((F, 2, 2))
    k = 0
    for s in range(F):
        if count[s] == 0:
            continue
        for a in range(2):
            p_lo, p_hi = np.inf, -np.inf
            for p in range(P):
                if foot[p] == s:
                    x = coord[p, a]
                    p_lo = min(p_lo, x)
                    p_hi = max(p_hi, x)
            if has_sole[s]:
                lo_, hi_ = np.inf, -np.inf
                for i in range(soles.shape[1]):
                    x = soles[s, i, 0] * axes[a, 0] + soles[s, i, 1] * axes[a, 1]
                    lo_ = min(lo_, x)
                    hi_ = max(hi_, x)
            else:  # no sole: the foot's contact points
                lo_, hi_ = p_lo, p_hi
            s_lo, s_hi = lo_ + margin, hi_ - margin
            mid = 0.5 * (lo_ + hi_)
            s_lo, s_hi = min(s_lo, mid), max(s_hi, mid)
            lo, hi = max(s_lo, p_lo), min(s_hi, p_hi)
            if lo > hi:  # the two do not overlap: the points' end nearest to the shrunk sole
                near = min(max(0.5 * (s_lo + s_hi), p_lo), p_hi)
                lo, hi = near, near
            bounds[s, a, 0], bounds[s, a, 1] = lo, hi
        for p in range(P):  # the foot's four rows: Σ f_z (r − lo) ≥ 0, Σ f_z (hi − r) ≥ 0 per axis
            if foot[p] != s:
                continue
            arms = (coord[p, 0] - bounds[s, 0, 0], bounds[s, 0, 1] - coord[p, 0],
                    coord[p, 1] - bounds[s, 1, 0], bounds[s, 1, 1] - coord[p, 1])
            for j in range(4):
                for e in range(4):
                    rows[4 * k + j, 4 * p + e] = arms[j] * edges[p, 2, e]
        k += 1
    return rows


def cop_kernel() -> Any:
    """The compiled :func:`_cop` (made and warmed up once per process; numba missing: a ConfigError)."""
    return once(__name__, lambda: njit(_cop), _warm)


def _warm(fn: Any) -> None:
    """One call of the argument types :func:`compiled_cop_rows` passes (the cone edges a read-only array)."""
    edges = np.ones((2, 3, 4))
    edges.flags.writeable = False
    fn(np.zeros((2, 3)), edges, np.zeros(2, dtype=np.int64), np.eye(2), np.zeros((2, 8, 2)),
       np.ones(2, dtype=np.bool_), 0.01)


def compiled_cop_rows(points: np.ndarray, edges: np.ndarray, foot: np.ndarray, axes: np.ndarray,
                      soles_now: list[np.ndarray | None], margin: float) -> np.ndarray:
    """(4F', 4P) :func:`~.cop_constraints.cop_constraint_rows`' rows along the box's axes (``cop_foot_axes`` off, no
    ``cop_corner_share``), compiled: ``points`` (P, 3), ``edges`` (P, 3, 4), ``foot`` (P,) each point's foot (−1:
    unbounded), ``axes`` (2, 2), ``soles_now`` per foot its sole's corners (S, 3) in the world (``None``: its contact
    points instead), ``margin`` (m)."""
    F = len(soles_now)
    S = max((len(s) for s in soles_now if s is not None), default=1)
    soles = np.zeros((F, S, 2))
    has = np.zeros(F, dtype=np.bool_)
    for s, so in enumerate(soles_now):
        if so is not None:
            if len(so) != S:  # (feet with soles of other point counts: not this kernel's)
                raise ValueError("compiled_cop_rows: soles of different point counts")
            soles[s] = so[:, :2]
            has[s] = True
    return cop_kernel()(np.ascontiguousarray(points, dtype=np.float64), edges,
                        np.asarray(foot, dtype=np.int64), np.ascontiguousarray(axes, dtype=np.float64), soles, has,
                        float(margin))
