"""A caught robot's planted feet planted again where they physically stand (``FootLockConfig.follow_caught``).

While the harness holds a robot it has caught, the balance controller is off and the legs' position servos track
the IK's leg angles; the IK puts each planted ankle at the foot lock's planted point. A released robot's feet drift
from those points (the balance controller holds a foot where it stands, not where it was planted: 2–9 cm in
Stubby's pull-ups), so after a catch the servos drag the planted feet back across the floor to them (traced in six
pull-ups: about half of the feet's path while held or within the catch's blend was toward the planted point;
docs/design.md §5). Planting them again at their physical ankle frames leaves the servos nothing to drag: the
harness carries the robot and the feet stay where they stand. :class:`~.footlock.FootLock` does this only once a
sub-goal's contact has held (in the walk-up the harness carries a caught robot's feet along its plan).
"""

from __future__ import annotations

import numpy as np

from ..errors import SimulationError

__all__ = ["follow_physical"]


def follow_physical(planted: list[np.ndarray | None], physical: np.ndarray) -> list[np.ndarray | None]:
    """The planted points (each (3,) world m, or ``None`` for a foot that steps) moved horizontally onto the
    physical ankle frames ``physical`` (2, 3) (world, m); each keeps its height (the ankle's home height) and a
    stepping foot stays ``None``. Returns new arrays; the inputs are not changed."""
    phys = np.asarray(physical, dtype=np.float64)
    if phys.shape != (2, 3) or len(planted) != 2:
        raise SimulationError(f"follow_physical: expected two planted points and (2, 3) ankle frames, found "
                              f"{len(planted)} and {phys.shape}")
    out: list[np.ndarray | None] = []
    for s, p in enumerate(planted):
        if p is None:
            out.append(None)
        else:
            out.append(np.array([phys[s, 0], phys[s, 1], float(p[2])]))
    return out
