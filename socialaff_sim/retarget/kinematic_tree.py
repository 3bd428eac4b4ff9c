"""Reading a MuJoCo model's body tree: which bodies hang below a given one."""

from __future__ import annotations

import mujoco
import numpy as np

__all__ = ["subtree_mask"]


def subtree_mask(m: mujoco.MjModel, root: int) -> np.ndarray:
    """(nbody,) bool: body ``root`` and its descendants."""
    inside = np.zeros(m.nbody, dtype=bool)
    inside[root] = True
    for b in range(root + 1, m.nbody):  # MuJoCo numbers a body after its parent
        inside[b] = inside[m.body_parentid[b]]
    return inside
