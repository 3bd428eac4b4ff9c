"""Reading a MuJoCo model's body tree: which bodies hang below a given one, and which above."""

from __future__ import annotations

import mujoco
import numpy as np

__all__ = ["ancestry", "shared_ancestor", "subtree_mask"]


def subtree_mask(m: mujoco.MjModel, root: int) -> np.ndarray:
    """(nbody,) bool: body ``root`` and its descendants."""
    inside = np.zeros(m.nbody, dtype=bool)
    inside[root] = True
    for b in range(root + 1, m.nbody):  # MuJoCo numbers a body after its parent
        inside[b] = inside[m.body_parentid[b]]
    return inside


def ancestry(m: mujoco.MjModel, body: int) -> list[int]:
    """``body`` and its ancestors, nearest first, up to (not including) the world."""
    out = [body]
    while int(m.body_parentid[out[-1]]) > 0:
        out.append(int(m.body_parentid[out[-1]]))
    return out


def shared_ancestor(m: mujoco.MjModel, a: int, b: int, default: int) -> int:
    """The lowest proper ancestor of body ``a`` that body ``b`` also hangs from (or is), else ``default``
    (e.g. the torso: the body both shoulders hang from, given the two wrists)."""
    other = set(ancestry(m, b))
    return next((x for x in ancestry(m, a)[1:] if x in other), default)
