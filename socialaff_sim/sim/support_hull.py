"""The feet's support polygon: the convex hull of the soles on the floor, and how deep a point lies inside it.

The support box (:mod:`~.support_box`) is the rectangle of the soles' corners along the feet's heading. For feet side
by side it is nearly their hull; for a staggered stance (one foot ahead of the other) two of its corners lie beside
the feet where nothing supports the robot: the hull's front edge runs slanted from the rear foot's toes to the front
foot's, and a capture point inside the box there lies outside the hull. The H1's soles are 3 cm wide and its feet
stood up to 37 cm apart along the heading (median 18 cm) where its harness let go before a tilt catch, the capture
point outside the contact points' hull in 31 of 36 such releases (median 6 cm, at most 20 cm); the trunk then fell
forward past ``catch_tilt`` (docs/design.md §5, session 38, wip/h1wide). ``BalanceConfig.release_hull_roll_free``
bounds the release by the hull (:class:`~.harness_release.HarnessRelease`); on development it moved the H1's
contact-phase support from catches to holds rather than lowering it, and stays off.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, QhullError

__all__ = ["convex_hull", "hull_depth", "sole_points"]


def sole_points(soles: list[np.ndarray | None], pts: np.ndarray, which: np.ndarray) -> np.ndarray:
    """(K, 2) world points whose convex hull is the feet's support polygon: the sole corners ``soles[f]`` (S, 3)
    (world, m) of each foot f with a contact with the floor (``which`` (P,) the foot of each contact point ``pts``
    (P, 3)), or that foot's contact points where its sole is unknown (``None``); feet without a contact are left
    out."""
    out = [pts[which == s, :2] if sole is None else np.asarray(sole)[:, :2]
           for s, sole in enumerate(soles) if (which == s).any()]
    return np.vstack(out) if out else np.zeros((0, 2))


def convex_hull(points: np.ndarray) -> np.ndarray:
    """(H, 2) the convex hull's vertices of ``points`` (K, 2), counter-clockwise (Qhull, through
    :class:`scipy.spatial.ConvexHull`, which lists a 2-D hull's vertices that way), collinear points dropped; fewer
    than three (the distinct points, at most two of them) when the points span no area."""
    p = np.unique(np.asarray(points, dtype=np.float64).reshape(-1, 2), axis=0)
    if len(p) < 3:
        return p
    try:
        return p[ConvexHull(p).vertices]
    except QhullError:  # all on one line (or one point): no interior, as a hull of two vertices
        return p[[0, -1]]


def hull_depth(hull: np.ndarray, p: np.ndarray) -> float:
    """[m] How far ``p`` (2,) lies inside the convex polygon ``hull`` (H, 2) (counter-clockwise, :func:`convex_hull`):
    the least distance from ``p`` to the lines of its edges, each signed positive on the inner side. Inside, the
    distance to the boundary; outside, negative (minus the largest distance beyond an edge's line: at most the true
    distance's size, never of the wrong sign). ``-inf`` for a hull of fewer than three vertices (no interior)."""
    if len(hull) < 3:
        return -np.inf
    a, b = hull, np.roll(hull, -1, axis=0)
    e = b - a
    n = np.stack([-e[:, 1], e[:, 0]], axis=1) / np.linalg.norm(e, axis=1)[:, None]  # inward (left of each edge)
    return float(((np.asarray(p, dtype=np.float64) - a) * n).sum(axis=1).min())
