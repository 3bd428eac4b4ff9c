"""The support box of a standing robot: the box of its feet's soles on the floor, axes along its heading."""

from __future__ import annotations

import numpy as np

__all__ = ["SupportBox", "cop_interval", "cop_intervals"]


class SupportBox:
    """The box of the feet's contact points on the floor, axes along the heading (forward, left)."""

    def __init__(self, xy: np.ndarray, forward: np.ndarray) -> None:
        self.R = np.array([forward, [-forward[1], forward[0]]])  # rows: forward, left
        local = xy @ self.R.T
        self.lo, self.hi = local.min(axis=0), local.max(axis=0)

    @classmethod
    def of(cls, R: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> SupportBox:
        """The box with rows ``R`` (2, 2) (forward, left; world) and extents ``lo``, ``hi`` (2,) along them (m), as
        found elsewhere (:mod:`~.support_kernel`)."""
        box = cls.__new__(cls)
        box.R, box.lo, box.hi = R, lo, hi
        return box

    def middle(self) -> np.ndarray:
        """(2,) the box's middle, world."""
        return (0.5 * (self.lo + self.hi)) @ self.R

    def clip(self, p: np.ndarray, margin: float) -> np.ndarray:
        """(2,) ``p`` (2,) world moved into the box shrunk by ``margin`` (its middle where that is empty)."""
        lo, hi = self.lo + margin, self.hi - margin
        mid = 0.5 * (self.lo + self.hi)
        lo, hi = np.minimum(lo, mid), np.maximum(hi, mid)
        return np.minimum(np.maximum(self.R @ p, lo), hi) @ self.R  # (np.clip's min(max(x, lo), hi))

    def behind_front(self, p: np.ndarray) -> float:
        """[m] How far ``p`` (2,) world lies behind the box's front face along the heading (negative: ahead of it)."""
        return float(self.hi[0] - self.R[0] @ p)

    def inside(self, p: np.ndarray, margin: float) -> bool:
        """Whether ``p`` (2,) world lies inside the box shrunk by ``margin`` (grown where negative)."""
        x = self.R @ p
        return bool((x >= self.lo + margin).all() and (x <= self.hi - margin).all())


def cop_interval(axes: np.ndarray, sole_xy: np.ndarray, point_xy: np.ndarray, margin: float) -> np.ndarray:
    """(2, 2) per axis of ``axes`` (2, 2) (rows: unit horizontal axes, world) the interval [lo, hi] (m, along the
    axis) a foot's centre of pressure is kept in: the extent of its sole ``sole_xy`` (S, 2) shrunk by ``margin``
    (m; its middle where narrower than twice the margin), within the extent of its contact points ``point_xy``
    (K, 2) (the centre of pressure cannot leave them; where the two do not overlap, the contact points' end
    nearest to the shrunk sole). One foot of :func:`cop_intervals`."""
    return cop_intervals(axes, [sole_xy], [point_xy], margin)[0]


def cop_intervals(axes: np.ndarray, soles_xy: list[np.ndarray], points_xy: list[np.ndarray],
                  margin: float) -> np.ndarray:
    """(F, 2, 2) :func:`cop_interval` of F feet at once, foot f's sole ``soles_xy[f]`` (S_f, 2) and contact points
    ``points_xy[f]`` (K_f, 2) (world, m): the projections foot by foot, the rest element-wise over the feet."""
    sole_lo, sole_hi = _extents([xy @ axes.T for xy in soles_xy])  # (F, 2)
    s_lo, s_hi = sole_lo + margin, sole_hi - margin
    mid = 0.5 * (sole_lo + sole_hi)
    s_lo, s_hi = np.minimum(s_lo, mid), np.maximum(s_hi, mid)
    p_lo, p_hi = _extents([xy @ axes.T for xy in points_xy])
    lo, hi = np.maximum(s_lo, p_lo), np.minimum(s_hi, p_hi)
    empty = lo > hi
    near = np.clip(0.5 * (s_lo + s_hi), p_lo, p_hi)
    lo, hi = np.where(empty, near, lo), np.where(empty, near, hi)
    return np.stack([lo, hi], axis=2)


def _extents(coords: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(F, 2) the least and (F, 2) the greatest of each array (K_f, 2) of ``coords`` along its first axis: stacked
    when all have the same length (two flat feet's corners), else foot by foot (minima and maxima are exact)."""
    if len({len(c) for c in coords}) == 1:
        both = np.stack(coords)
        return both.min(axis=1), both.max(axis=1)
    return np.array([c.min(axis=0) for c in coords]), np.array([c.max(axis=0) for c in coords])
