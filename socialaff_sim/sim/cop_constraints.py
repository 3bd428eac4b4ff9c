"""The balance QP's centre-of-pressure rows for the planted feet, as :class:`~.balance_config.BalanceConfig` chooses
them: each foot's centre of pressure kept ``cop_margin`` inside its sole along the support box's axes
(:func:`~.contact_qp.cop_rows`), or along each foot's own axes (``cop_foot_axes``, :mod:`~.foot_cop`); with
``cop_corner_share`` every corner of each sole also kept loaded (:mod:`~.sole_corners_load`)."""

from __future__ import annotations

import numpy as np

from .balance_config import BalanceConfig
from .contact_qp import cop_rows
from .cop_kernel import compiled_cop_rows
from .foot_cop import foot_cop_rows
from .sole_corners_load import corner_share_rows
from .support_box import cop_intervals

__all__ = ["cop_constraint_rows"]


def cop_constraint_rows(config: BalanceConfig, pts: np.ndarray, edges: np.ndarray, which: np.ndarray,
                        box_axes: np.ndarray, soles_now: list[np.ndarray | None], xmat: np.ndarray,
                        feet: np.ndarray, forward: np.ndarray, kernel: str = "numpy") -> np.ndarray:
    """(R, 4P) rows C with ``C β ≥ 0`` on the contact forces' cone weights β: ``pts`` (P, 3) the contact points
    (world, m), ``edges`` (P, 3, 4) their cones' edges, ``which`` (P,) each point's foot (−1: left unbounded),
    ``box_axes`` (2, 2) the support box's horizontal axes, ``soles_now`` per foot its sole's corners in the world
    (S, 3; ``None``: the foot's contact points instead), ``xmat`` (nbody, 9) the bodies' rotations (``MjData.xmat``),
    ``feet`` (F,) the feet's bodies and ``forward`` (F, 3) their forward axes in their frames (read only with
    ``cop_foot_axes`` or ``cop_corner_share``: each foot's own axes on the floor); ``kernel`` ``"numba"``: the box's
    rows (neither of those two) in one compiled loop (:mod:`~.cop_kernel`; soles of one point count)."""
    c = config
    if kernel == "numba" and not c.cop_foot_axes and c.cop_corner_share is None and len(
            {len(s) for s in soles_now if s is not None}) <= 1:
        return compiled_cop_rows(pts, edges, which, box_axes, soles_now, c.cop_margin)
    forward_xy = np.array([(xmat[b].reshape(3, 3) @ a)[:2] for b, a in zip(feet, forward, strict=True)]
                          ) if c.cop_foot_axes or c.cop_corner_share is not None else None
    n_feet = len(soles_now)
    bounds = np.zeros((n_feet, 2, 2))
    on = [s for s in range(n_feet) if (which == s).any()]
    if not on:
        return cop_rows(pts, edges, which, box_axes, bounds)
    mine = [pts[which == s, :2] for s in on]
    soles_xy = [None if so is None else so[:, :2] for so in soles_now]
    if c.cop_foot_axes:
        rows = foot_cop_rows(pts, edges, which, soles_xy, forward_xy, c.cop_margin)
    else:  # along the box's axes
        soles = [xy if soles_xy[s] is None else soles_xy[s] for s, xy in zip(on, mine, strict=True)]
        bounds[on] = cop_intervals(box_axes, soles, mine, c.cop_margin)
        rows = cop_rows(pts, edges, which, box_axes, bounds)
    if c.cop_corner_share is None:
        return rows
    return np.concatenate([rows, corner_share_rows(pts, edges, which, soles_xy, forward_xy, c.cop_corner_share)])
