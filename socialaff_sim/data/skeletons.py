"""Skeleton layouts of the supported recordings and their five key joints.

The method uses five key joints per agent: base, left wrist, right wrist, left
ankle, right ankle (the object, when present, counts as one more joint). Every
layout maps explicitly onto them; where a layout has no such joint (NuiSI has no
legs) the entry is ``None``, and where it has only a neighbouring joint (SBU has
hands, not wrists) the substitute is named in :attr:`SkeletonLayout.substitutes`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import DataError, choices

__all__ = [
    "KEY_JOINTS",
    "N_KEY",
    "SkeletonLayout",
    "LAYOUTS",
    "get_layout",
    "layout_for_joint_names",
]

KEY_JOINTS: tuple[str, ...] = ("base", "left_wrist", "right_wrist", "left_ankle", "right_ankle")
"""Names of the method's five key joints per agent, in model order."""

N_KEY = len(KEY_JOINTS)


@dataclass(frozen=True)
class SkeletonLayout:
    """A named joint order with its bone tree and its key-joint mapping."""

    name: str
    """Identifier stored in files (e.g. ``"kinect_v2"``)."""
    joint_names: tuple[str, ...]
    """Joint names in array order."""
    parents: tuple[int, ...]
    """Parent index of each joint (-1 for the root); defines the bones."""
    key_indices: tuple[int | None, ...]
    """Index of each of :data:`KEY_JOINTS` in this layout, ``None`` where absent."""
    substitutes: dict[str, str] = field(default_factory=dict)
    """Key joints stood in for by a neighbouring joint: key name -> joint used."""

    def __post_init__(self) -> None:
        n = len(self.joint_names)
        if len(self.parents) != n:
            raise ValueError(f"layout {self.name}: {len(self.parents)} parents for {n} joints")
        if len(self.key_indices) != N_KEY:
            raise ValueError(f"layout {self.name}: needs {N_KEY} key indices")

    @property
    def n_joints(self) -> int:
        """Number of joints J."""
        return len(self.joint_names)

    @property
    def key_available(self) -> np.ndarray:
        """(5,) bool: which key joints the layout has."""
        return np.array([i is not None for i in self.key_indices])

    def key_joints(self, joints: np.ndarray) -> np.ndarray:
        """(…, 5, 3) the key joints of a skeleton array ``joints`` (…, J, 3) in this layout; NaN where the layout
        has no such joint."""
        x = np.asarray(joints, dtype=np.float64)
        out = np.full(x.shape[:-2] + (N_KEY, 3), np.nan)
        for k, idx in enumerate(self.key_indices):
            if idx is not None:
                out[..., k, :] = x[..., idx, :]
        return out

    @property
    def bones(self) -> np.ndarray:
        """(B, 2) int: (parent, child) joint index pairs."""
        return np.array([(p, c) for c, p in enumerate(self.parents) if p >= 0], dtype=np.int64)

    def index(self, name: str) -> int:
        """Array index of a joint by name."""
        try:
            return self.joint_names.index(name)
        except ValueError:
            raise DataError(
                f"layout {self.name!r} has no joint {name!r}; joints: {choices(self.joint_names)}"
            ) from None


_KINECT_V2 = SkeletonLayout(
    name="kinect_v2",
    joint_names=(
        "spine_base", "spine_mid", "neck", "head",
        "left_shoulder", "left_elbow", "left_wrist", "left_hand",
        "right_shoulder", "right_elbow", "right_wrist", "right_hand",
        "left_hip", "left_knee", "left_ankle", "left_foot",
        "right_hip", "right_knee", "right_ankle", "right_foot",
        "spine_shoulder", "left_hand_tip", "left_thumb", "right_hand_tip", "right_thumb",
    ),
    parents=(-1, 0, 20, 2, 20, 4, 5, 6, 20, 8, 9, 10, 0, 12, 13, 14, 0, 16, 17, 18, 1, 7, 7, 11, 11),
    key_indices=(0, 6, 10, 14, 18),
)

_SBU15 = SkeletonLayout(
    name="sbu15",
    joint_names=(
        "head", "neck", "torso",
        "left_shoulder", "left_elbow", "left_hand",
        "right_shoulder", "right_elbow", "right_hand",
        "left_hip", "left_knee", "left_foot",
        "right_hip", "right_knee", "right_foot",
    ),
    parents=(1, 2, -1, 1, 3, 4, 1, 6, 7, 2, 9, 10, 2, 12, 13),
    key_indices=(2, 5, 8, 11, 14),
    substitutes={
        "base": "torso",
        "left_wrist": "left_hand",
        "right_wrist": "right_hand",
        "left_ankle": "left_foot",
        "right_ankle": "right_foot",
    },
)

_BODY34 = SkeletonLayout(
    name="zed_body34",
    joint_names=(
        "pelvis", "naval_spine", "chest_spine", "neck",
        "left_clavicle", "left_shoulder", "left_elbow", "left_wrist", "left_hand",
        "left_hand_tip", "left_thumb",
        "right_clavicle", "right_shoulder", "right_elbow", "right_wrist", "right_hand",
        "right_hand_tip", "right_thumb",
        "left_hip", "left_knee", "left_ankle", "left_foot",
        "right_hip", "right_knee", "right_ankle", "right_foot",
        "head", "nose", "left_eye", "left_ear", "right_eye", "right_ear",
        "left_heel", "right_heel",
    ),
    parents=(
        -1, 0, 1, 2,
        2, 4, 5, 6, 7, 8, 7,
        2, 11, 12, 13, 14, 15, 14,
        0, 18, 19, 20,
        0, 22, 23, 24,
        3, 26, 26, 26, 26, 26,
        20, 24,
    ),
    key_indices=(0, 7, 14, 20, 24),
)

_NUISI10 = SkeletonLayout(
    name="nuitrack10",
    joint_names=(
        "head", "neck", "torso", "waist",
        "left_shoulder", "left_elbow", "left_hand",
        "right_shoulder", "right_elbow", "right_hand",
    ),
    parents=(1, 2, 3, -1, 1, 4, 5, 1, 7, 8),
    key_indices=(3, 6, 9, None, None),
    substitutes={"base": "waist", "left_wrist": "left_hand", "right_wrist": "right_hand"},
)

_KEY5 = SkeletonLayout(
    name="key5",
    joint_names=KEY_JOINTS,
    parents=(-1, 0, 0, 0, 0),
    key_indices=(0, 1, 2, 3, 4),
)

LAYOUTS: dict[str, SkeletonLayout] = {
    lay.name: lay for lay in (_KINECT_V2, _SBU15, _BODY34, _NUISI10, _KEY5)
}
"""Every supported layout by name."""


def get_layout(name: str) -> SkeletonLayout:
    """Look up a layout by name; the error lists the known names."""
    try:
        return LAYOUTS[name]
    except KeyError:
        raise DataError(f"unknown skeleton layout {name!r}; known layouts: {choices(LAYOUTS)}") from None


_BY_NAMES: dict[tuple[str, ...], SkeletonLayout] = {lay.joint_names: lay for lay in LAYOUTS.values()}


def layout_for_joint_names(names: tuple[str, ...] | list[str]) -> SkeletonLayout:
    """The layout whose joint order is exactly ``names``."""
    # A dict lookup: every view of a stream asks for its layout, several times per frame.
    try:
        found = _BY_NAMES.get(tuple(names))
    except TypeError:  # unhashable names: no layout has them (the error below says so)
        found = None
    if found is not None:
        return found
    names = tuple(str(n) for n in names)
    for lay in LAYOUTS.values():
        if lay.joint_names == names:
            return lay
    raise DataError(
        f"joint names {list(names)[:4]}... (J={len(names)}) match no known layout; "
        f"known layouts: {choices(LAYOUTS)}",
        field="joint_names",
    )
