"""The centre of mass's wanted acceleration limited to what the feet can push (``BalanceConfig.zmp_limit``).

A point mass m at height h above the floor accelerating horizontally by a needs the floor's resultant force to act
at the zero-moment point p = c − a h / g (c the centre of mass's horizontal position): the feet can push only from
inside their support box, so the largest acceleration the soles alone can give is the one whose p lies in the box.
The balance controller's centre-of-mass feedback a* = ω_c² (c* − c) − 2 ζ ω_c ċ knows nothing of this: traced on
the H1 released by the harness (docs/design.md §5, "The H1's weight on the harness …"), the centre of mass stood a median
6 cm (a quarter over 13 cm) ahead of its reference at the release, a* asked for 2 m/s² and more, i.e. a zero-moment
point 20 cm ahead of the centre of mass, past the toes, and the QP bought it by pitching the trunk (the hip
strategy) 4 → 12° within 0.1 s, where the harness caught it.

:func:`zmp_limited` moves the zero-moment point that a* implies into the support box shrunk by a margin (along the
box's axes, as :meth:`~.support_box.SupportBox.clip`), and returns the acceleration of the moved point: a wanted
acceleration the soles can give is returned unchanged.
"""

from __future__ import annotations

import numpy as np

from .support_box import SupportBox

__all__ = ["zmp_limited"]


def zmp_limited(box: SupportBox, com: np.ndarray, acceleration: np.ndarray, height: float, gravity: float,
                margin: float) -> np.ndarray:
    """(2,) the horizontal acceleration (world, m/s²) ``acceleration`` (2,) of the centre of mass at ``com`` (2+,)
    (world, m; its horizontal part used), ``height`` (m, > 0) above the floor, limited so that its zero-moment point
    p = c − a h / g (``gravity`` g, m/s²) lies in ``box`` shrunk by ``margin`` (m): p moved into it along the box's
    axes and a = (c − p) g / h. Unchanged where p already lies inside."""
    c = np.asarray(com, dtype=np.float64)[:2]
    a = np.asarray(acceleration, dtype=np.float64)
    p = c - a * (height / gravity)
    if box.inside(p, margin):
        return a
    return (c - box.clip(p, margin)) * (gravity / height)
