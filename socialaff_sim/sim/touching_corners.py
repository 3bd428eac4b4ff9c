"""The sole corners a tipped foot stands on: the balance QP's contact points for ``BalanceConfig.touch_gap``.

With ``flat_feet`` the balance QP models every planted foot on the floor as standing on its sole's four corners,
whatever corners the floor touches now. Traced step by step (docs/design.md §5, "The standing mode's feet tipping
onto their edges …"), most of the remaining slide falls in steps where a foot stands on one or two corners only,
rolled about its long axis: the QP then plans forces at corners the floor does not push, and the ankle's torque,
computed for them, keeps the foot rocking on its edge. With ``touch_gap`` the QP's contact points of a foot in
contact are only the corners that touch (:func:`touching_corners`): a corner counts while its height is at most g
above the foot's highest live contact with the floor (MuJoCo's box-on-plane contacts sit at the pressed corners,
halfway into the floor, so the pressed corners lie below them and a lifted corner above). The foot's hard rows
toward level (:func:`~.flat_feet.foot_rows`) stay: the QP then turns the foot back onto its sole with the forces
it can have. On fewer than three corners the foot carries no centre-of-pressure rows and no minimum load (the
balance controller's rule for points that span no area): β ≥ 0 keeps its centre of pressure on the edge.

Geometry only; :func:`~.flat_feet.flat_contacts` calls it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["touching_corners"]


def touching_corners(corner_z: np.ndarray, contact_z: np.ndarray, gap: float) -> np.ndarray:
    """(4,) bool: which of a foot's sole corners, at heights ``corner_z`` (4,) (world, m), touch the floor: those at
    most ``gap`` (m, ≥ 0) above the highest of the foot's live contacts with the floor ``contact_z`` (K,) (world,
    m; K ≥ 1). At least one: where none qualifies (a contact that is no corner's), the lowest corner."""
    keep = corner_z <= float(np.max(contact_z)) + gap
    if not keep.any():
        keep = corner_z == corner_z.min()
    return keep
