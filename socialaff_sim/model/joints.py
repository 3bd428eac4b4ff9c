"""The model's "joints": five key joints per agent plus the object, in the canonical frame.

Index ``j = 5 a + k`` is key joint ``k`` (:data:`~socialaff_sim.data.skeletons.KEY_JOINTS`) of
agent ``a`` (0: observed human, 1: the agent the robot plays); index 10 is the object.
A joint the data lacks (the layout has no such key joint, e.g. NuiSI ankles, or the
interaction has no object) is *absent*: it is fixed out of the grouping (neither Null
nor affordable) and contributes no potential.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..data.interaction import Interaction
from ..data.skeletons import KEY_JOINTS, N_KEY
from .frame import CanonicalFrame, canonical_frame

__all__ = [
    "JOINT_NAMES",
    "N_JOINTS",
    "OBJECT",
    "BASES",
    "AGENT_OF",
    "LONE_REFERENCE",
    "ENTITY_OF",
    "reference_row",
    "instance_frame",
    "canonical_joints",
    "available_joints",
]

JOINT_NAMES: tuple[str, ...] = tuple(f"agent{a}.{k}" for a in (0, 1) for k in KEY_JOINTS) + ("object",)
"""Names of the 11 model joints in index order."""

N_JOINTS = len(JOINT_NAMES)
OBJECT = 2 * N_KEY
"""Index of the object joint."""
BASES = (0, N_KEY)
"""Indices of agent 0's and agent 1's base joints."""
AGENT_OF = np.array([0] * N_KEY + [1] * N_KEY + [-1])
"""(11,) int: the agent of each joint (-1 for the object)."""

LONE_REFERENCE = np.zeros((N_JOINTS, N_JOINTS))
"""(11, 11) float64: a lone affordable joint's reference point as weights over joints.

An agent's joint alone in its group is placed relative to the *other* agent's base; the
object alone is placed relative to the midpoint of the two bases (where a passed or
thrown object is expected).
"""
LONE_REFERENCE[:N_KEY, BASES[1]] = 1.0
LONE_REFERENCE[N_KEY : 2 * N_KEY, BASES[0]] = 1.0
LONE_REFERENCE[OBJECT, BASES[0]] = 0.5
LONE_REFERENCE[OBJECT, BASES[1]] = 0.5
LONE_REFERENCE.setflags(write=False)


ENTITY_OF = np.array([0] * N_KEY + [1] * N_KEY + [2])
"""(11,) int: the entity of each joint (0: agent 0, 1: agent 1, 2: the object)."""


def reference_row(
    j: int, others: list[int] | np.ndarray, other_side: bool, include_self: bool = False
) -> np.ndarray:
    """(11,) weights of the spatial reference point of affordable joint ``j`` with group mates ``others``.

    The reference is the mass centre (mean) of the group mates, restricted to those of other
    entities than ``j``'s own when ``other_side``, and of ``j`` itself too when ``include_self``
    (the mass centre of the whole group); with no (remaining) mates it is :data:`LONE_REFERENCE`
    of ``j`` (a one-joint group's own mass centre is the joint, a zero offset).
    """
    others = np.asarray(others, dtype=np.int64)
    if other_side and others.size:
        others = others[ENTITY_OF[others] != ENTITY_OF[j]]
    if others.size == 0:
        return LONE_REFERENCE[j].copy()
    if include_self:
        others = np.append(others, j)
    w = np.zeros(N_JOINTS)
    w[others] = 1.0 / others.size
    return w


def instance_frame(inter: Interaction) -> CanonicalFrame:
    """The canonical frame of an instance (from both bases at its first frame)."""
    key = inter.key_joints()
    return canonical_frame(key[0, 0, 0], key[0, 1, 0])


def canonical_joints(inter: Interaction, frame: CanonicalFrame | None = None, *, keys: np.ndarray | None = None) -> np.ndarray:
    """(T, 11, 3) float64, metres, canonical frame: the model joints of an instance; NaN where absent. ``keys``: its
    :meth:`~socialaff_sim.data.interaction.Interaction.key_joints` if the caller has them (read, not changed)."""
    key = inter.key_joints() if keys is None else keys
    if frame is None:
        frame = canonical_frame(key[0, 0, 0], key[0, 1, 0])
    out = np.full((inter.n_frames, N_JOINTS, 3), np.nan)
    out[:, : 2 * N_KEY] = key.reshape(inter.n_frames, 2 * N_KEY, 3)
    if inter.object is not None:
        out[:, OBJECT] = inter.object
    return frame.to_canonical(out)


def available_joints(tracks: Sequence[np.ndarray]) -> np.ndarray:
    """(11,) bool: joints finite in every frame of every track ``(T, 11, 3)``; the others are absent."""
    ok = np.ones(N_JOINTS, dtype=bool)
    for x in tracks:
        ok &= np.isfinite(x).all(axis=(0, 2))
    return ok
