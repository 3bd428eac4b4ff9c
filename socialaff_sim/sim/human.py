"""The replayed human: capsule limbs between skeleton joints, posed kinematically.

Each bone of the skeleton layout becomes one capsule whose pose target is a mocap
body: every frame the target is placed at the bone's midpoint and turned so that
its z axis runs along the bone; the capsule's half-length is set per instance to
half the bone's median length. Two spheres mark the hands (at the layout's hand
joint, or its wrist when it has none).

The trunk, head and legs are the mocap bodies themselves: rigid, moved by the
recording, unaffected by contacts. The arms from the elbow down and the hand
spheres (:attr:`HumanBody.compliant`) are free bodies held to their mocap targets
by soft weld constraints (the weld/connect-to-mocap approach): they follow the
recording but yield a few centimetres when the robot grips or pushes them, so
contact forces stay those of flesh on a compliant arm rather than of two
immovable objects pressed together.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..data.interaction import Interaction
from ..data.skeletons import SkeletonLayout

__all__ = ["HumanBody", "HumanPose", "human_body", "pose_human", "bone_quaternions", "world_offset", "FOOT_CLEARANCE"]

# Capsule radius (m) by the name of a bone's child joint (first match wins).
_RADII: tuple[tuple[str, float], ...] = (
    ("head", 0.095),
    ("hand_tip", 0.022),
    ("thumb", 0.018),
    ("hand", 0.035),
    ("wrist", 0.038),
    ("elbow", 0.045),
    ("spine", 0.11),
    ("torso", 0.11),
    ("waist", 0.11),
    ("shoulder", 0.055),
    ("clavicle", 0.06),
    ("neck", 0.06),
    ("hip", 0.08),
    ("knee", 0.065),
    ("ankle", 0.05),
    ("foot", 0.04),
)
# Face and heel points give no useful volume; their bones are left out.
_SKIP = ("nose", "eye", "ear", "heel")
HAND_SPHERE_RADIUS = 0.05
"""Radius of the sphere marking each hand, metres."""


@dataclass(frozen=True)
class HumanBody:
    """The capsule model of one skeleton layout."""

    layout: SkeletonLayout
    bones: np.ndarray
    """(B, 2) int: parent and child joint index of each capsule."""
    radii: np.ndarray
    """(B,) float64, metres."""
    bone_names: tuple[str, ...]
    """B names ``"<parent>__<child>"`` (geom names in the scene are prefixed ``human/``)."""
    hand_joints: tuple[int, int]
    """Joint index carrying the left and the right hand sphere."""
    groups: dict[str, tuple[int, ...]]
    """Contact groups as indices into the B bones plus ``B`` (left hand sphere) and ``B + 1`` (right)."""
    compliant: tuple[int, ...]
    """Parts (same indexing) simulated as compliant bodies: the arms from the elbow down and the hand spheres."""

    @property
    def n_bones(self) -> int:
        return int(len(self.bones))


def _radius(child: str) -> float:
    for key, r in _RADII:
        if key in child:
            return r
    return 0.05


def human_body(layout: SkeletonLayout) -> HumanBody:
    """The capsule model of ``layout`` with its contact groups.

    Groups: ``left_hand``/``right_hand`` (the hand sphere and bones inside the hand),
    ``left_wrist``/``right_wrist`` (the hand plus the forearm), ``hands``, ``wrists``
    and ``body`` (everything).
    """
    names = layout.joint_names
    keep = [(p, c) for p, c in layout.bones if not any(s in names[c] for s in _SKIP)]
    bones = np.array(keep, dtype=np.int64).reshape(-1, 2)
    radii = np.array([_radius(names[c]) for _, c in bones])
    bone_names = tuple(f"{names[p]}__{names[c]}" for p, c in bones)
    B = len(bones)

    groups: dict[str, tuple[int, ...]] = {}
    hand_joints = []
    for side, sphere in (("left", B), ("right", B + 1)):
        wrist_key = layout.key_indices[1 if side == "left" else 2]
        hand_name = f"{side}_hand"
        hand = names.index(hand_name) if hand_name in names else wrist_key
        if hand is None:  # a layout without hands cannot happen for the supported ones
            raise ValueError(f"layout {layout.name} has no {side} wrist or hand")
        hand_joints.append(hand)
        hand_set = {j for j, n in enumerate(names) if n.startswith(side) and any(k in n for k in ("hand", "thumb"))}
        if wrist_key is not None:
            hand_set.add(wrist_key)
        inside = [b for b, (p, c) in enumerate(bones) if p in hand_set and c in hand_set]
        elbow = f"{side}_elbow"
        forearm = [
            b for b, (p, c) in enumerate(bones) if names[p] == elbow and (c in hand_set or c == wrist_key)
        ]
        groups[f"{side}_hand"] = (*inside, sphere)
        groups[f"{side}_wrist"] = tuple(sorted({*inside, *forearm})) + (sphere,)
    groups["hands"] = tuple(sorted({*groups["left_hand"], *groups["right_hand"]}))
    groups["wrists"] = tuple(sorted({*groups["left_wrist"], *groups["right_wrist"]}))
    groups["body"] = tuple(range(B + 2))
    distal = ("elbow", "wrist", "hand", "thumb")
    compliant = tuple(sorted({*groups["wrists"], *(b for b, (_, c) in enumerate(bones) if any(k in names[c] for k in distal))}))
    return HumanBody(layout, bones, radii, bone_names, (hand_joints[0], hand_joints[1]), groups, compliant)


def bone_quaternions(direction: np.ndarray) -> np.ndarray:
    """(..., 4) unit quaternions (w, x, y, z) turning +z onto each ``direction`` (..., 3).

    Shortest-arc rotation; a zero direction gives the identity and an exactly
    opposite one a half turn about x.
    """
    d = np.asarray(direction, dtype=np.float64)
    n = np.linalg.norm(d, axis=-1, keepdims=True)
    u = np.divide(d, n, out=np.zeros_like(d), where=n > 1e-12)
    u[(n[..., 0] <= 1e-12)] = (0.0, 0.0, 1.0)
    # q = (1 + z·u, z × u) normalised, with z = (0, 0, 1): z × u = (-u_y, u_x, 0).
    q = np.stack([1.0 + u[..., 2], -u[..., 1], u[..., 0], np.zeros_like(u[..., 0])], axis=-1)
    qn = np.linalg.norm(q, axis=-1, keepdims=True)
    flip = qn[..., 0] < 1e-9
    q[flip] = (0.0, 1.0, 0.0, 0.0)
    qn[flip] = 1.0
    return q / qn


@dataclass(frozen=True)
class HumanPose:
    """Per-frame poses of the capsule bodies of one instance, in the simulator's world frame."""

    pos: np.ndarray
    """(T, B + 2, 3) float64, metres: bone midpoints, then the left and right hand spheres."""
    quat: np.ndarray
    """(T, B + 2, 4) float64 (w, x, y, z): capsule orientations (identity for the spheres)."""
    half_lengths: np.ndarray
    """(B,) float64, metres: capsule half-lengths (median bone length / 2, minus the end caps' overlap)."""
    joints: np.ndarray
    """(T, J, 3) float64, metres: agent 0's joints in the world frame (NaN-free)."""


def pose_human(body: HumanBody, inter: Interaction, offset: np.ndarray) -> HumanPose:
    """Capsule poses for agent 0 of ``inter``, shifted by ``offset`` (3,) metres into the world frame.

    Joints the recording never tracked are put at the agent's base so that their
    capsules shrink to nothing there rather than carrying NaN.
    """
    joints = inter.filled_joints()[:, 0] + np.asarray(offset, dtype=np.float64)
    base_idx = body.layout.key_indices[0]
    base = joints[:, base_idx if base_idx is not None else 0]
    missing = ~np.isfinite(joints).all(axis=-1)
    if missing.any():
        joints = np.where(missing[..., None], base[:, None, :], joints)
    a = joints[:, body.bones[:, 0]]
    b = joints[:, body.bones[:, 1]]
    mid = 0.5 * (a + b)
    quat = bone_quaternions(b - a)
    length = np.median(np.linalg.norm(b - a, axis=-1), axis=0)
    half = np.maximum(0.5 * length, 1e-3)
    T = joints.shape[0]
    hands = joints[:, list(body.hand_joints)]
    pos = np.concatenate([mid, hands], axis=1)
    ident = np.zeros((T, 2, 4))
    ident[..., 0] = 1.0
    return HumanPose(pos=pos, quat=np.concatenate([quat, ident], axis=1), half_lengths=half, joints=joints)


FOOT_CLEARANCE = 0.03
"""Height of the lowest tracked joint (a foot or ankle) above the floor when standing, metres."""
STANDING_BASE_HEIGHT = 0.95
"""Base height assumed for a layout without legs, metres."""


def world_offset(inter: Interaction) -> np.ndarray:
    """(3,) metres added to the data to get the simulator's world frame.

    The floor goes to z = 0: it is estimated as the 5th percentile over frames of
    the lowest leg joint of either agent, minus :data:`FOOT_CLEARANCE` (for a
    layout without legs, the median base height minus :data:`STANDING_BASE_HEIGHT`).
    Horizontally, the midpoint of the two agents' bases at frame 0 goes to the origin.
    """
    layout = inter.layout
    joints = inter.joints
    valid = inter.valid if inter.valid is not None else np.ones(joints.shape[:3], dtype=bool)
    legs = [j for j, n in enumerate(layout.joint_names) if any(k in n for k in ("ankle", "foot", "heel", "knee"))]
    z = np.where(valid[..., legs], joints[..., legs, 2], np.inf) if legs else np.full((1,), np.inf)
    lowest = z.min(axis=(1, 2)) if legs else z
    lowest = lowest[np.isfinite(lowest)]
    key = inter.key_joints()
    if len(lowest):
        floor = float(np.percentile(lowest, 5)) - FOOT_CLEARANCE
    else:
        floor = float(np.nanmedian(key[:, :, 0, 2])) - STANDING_BASE_HEIGHT
    mid = 0.5 * (key[0, 0, 0] + key[0, 1, 0])
    mid = np.where(np.isfinite(mid), mid, 0.0)
    return np.array([-mid[0], -mid[1], -floor])
