"""Each foot's centre-of-pressure rows along that foot's own axes (``BalanceConfig.cop_foot_axes``).

:meth:`~.balance_control.BalanceController._cop` bounds every foot's centre of pressure along the support box's
axes (the feet's mean heading): the interval per axis is the sole's extent projected onto those axes, shrunk by
``cop_margin``. A foot turned by ψ from that heading projects wider than it is: across the box's axis its sole spans
w cos ψ + l sin ψ (w, l the sole's width and length), so near the sole's ends the box reaches the sole's long edges
and the margin across the foot is gone (Stubby's 22 × 11 cm sole at ψ = 4°: 0.77 cm more each side, most of the
1 cm margin). The foot then may be planned pressed on its edge and rolls onto it. Here each foot's interval is taken
along its own forward and left axes instead, so the margin holds across its own width whatever its turn.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from .contact_qp import cop_rows
from .support_box import cop_intervals

__all__ = ["each_foot", "foot_axes", "foot_cop_rows"]


def foot_axes(forward_xy: np.ndarray) -> np.ndarray:
    """(2, 2) the horizontal unit axes (forward, left) of a foot whose forward direction on the floor is
    ``forward_xy`` (2,) (any length > 0)."""
    f = np.asarray(forward_xy, dtype=np.float64)
    f = f / np.hypot(f[0], f[1])
    return np.array([f, [-f[1], f[0]]])


def each_foot(points: np.ndarray, which: np.ndarray, soles_xy: list[np.ndarray | None], forward_xy: np.ndarray
              ) -> Iterator[tuple[int, np.ndarray, np.ndarray, np.ndarray]]:
    """Per foot with contact points, in foot order: (s, mine (P,) bool: its points among ``points`` (P, 3),
    axes (2, 2): :func:`foot_axes` of ``forward_xy[s]``, sole (S, 2): ``soles_xy[s]``, or its points on the floor
    where that is ``None``); ``which`` (P,) each point's foot (−1: none)."""
    which = np.asarray(which)
    for s in range(len(soles_xy)):
        mine = which == s
        if mine.any():
            yield s, mine, foot_axes(forward_xy[s]), points[mine, :2] if soles_xy[s] is None else soles_xy[s]


def foot_cop_rows(points: np.ndarray, edges: np.ndarray, which: np.ndarray, soles_xy: list[np.ndarray | None],
                  forward_xy: np.ndarray, margin: float) -> np.ndarray:
    """(R, 4P) rows C with ``C β ≥ 0`` iff every foot's centre of pressure lies inside its sole, shrunk by ``margin``
    (m) (:func:`~.support_box.cop_intervals`), along that foot's own axes: ``points`` (P, 3) the contact
    points, ``edges`` (P, 3, 4) their cones' edges, ``which`` (P,) each point's foot (−1: none, left unbounded),
    ``soles_xy`` per foot its sole's corners (S, 2) on the floor (``None``: its contact points instead),
    ``forward_xy`` (F, 2) each foot's forward direction on the floor. Four rows per foot with points, in foot order
    (:func:`~.contact_qp.cop_rows` of each foot alone, along its axes)."""
    out = []
    for s, mine, axes, sole in each_foot(points, which, soles_xy, forward_xy):
        bounds = np.zeros((s + 1, 2, 2))
        bounds[s] = cop_intervals(axes, [sole], [points[mine, :2]], margin)[0]
        out.append(cop_rows(points, edges, np.where(mine, s, -1), axes, bounds))
    return np.concatenate(out) if out else np.zeros((0, 4 * len(points)))
