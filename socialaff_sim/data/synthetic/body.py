"""Synthetic actors and the forward kinematics of a 25-joint Kinect v2 body.

An :class:`Actor` is a set of segment lengths scaled from a stature H with
average human proportions (segment-to-stature ratios of the classic
anthropometric tables), perturbed per actor. A :class:`BodyTrack` describes a
motion by the pelvis (``spine_base``) position, heading, torso lean and twist,
and targets for the ankles and hands; :func:`forward_kinematics` turns it into
joints with limbs placed by analytic two-link IK (:mod:`.ik`). Bones keep their
lengths exactly, so every bone of an actor has one length in all frames.

Body frame: x forward, y to the agent's left, z up. Side index 0 is the left
limb, 1 the right one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..skeletons import get_layout
from .config import SyntheticConfig
from .ik import apply, rot_y, rot_z, two_link_ik, unit

__all__ = [
    "Actor",
    "BodyTrack",
    "Torso",
    "JOINT",
    "SIDE_SIGN",
    "N_JOINTS",
    "make_actors",
    "torso",
    "forward_kinematics",
    "hand_joint_indices",
]

_LAYOUT = get_layout("kinect_v2")
JOINT: dict[str, int] = {name: i for i, name in enumerate(_LAYOUT.joint_names)}
"""Kinect v2 joint name → array index."""
N_JOINTS = _LAYOUT.n_joints
SIDE_SIGN = np.array([1.0, -1.0])
"""Lateral sign of side 0 (left, +y in the body frame) and side 1 (right, −y)."""
_SIDES = ("left", "right")

# Segment lengths as fractions of stature H (average adult proportions).
_RATIO = {
    "ankle_height": 0.039,
    "shank": 0.246,
    "thigh": 0.245,
    "hip_drop": 0.030,
    "trunk": 0.265,
    "neck": 0.035,
    "head": 0.075,
    "shoulder_half_width": 0.100,
    "shoulder_drop": 0.012,
    "hip_half_width": 0.050,
    "upper_arm": 0.186,
    "forearm": 0.146,
    "hand": 0.050,
    "hand_tip": 0.045,
    "thumb": 0.035,
    "foot_forward": 0.065,
    "foot_height": 0.012,
}
_HEAD_FORWARD, _HEAD_UP = 0.2, float(np.sqrt(1.0 - 0.2**2))  # the head's centre is a little ahead of the neck
LEG_EXTENSION = 0.985
"""Hip-to-ankle distance of a standing leg as a fraction of thigh + shank (knees slightly soft)."""


@dataclass(frozen=True)
class Actor:
    """One synthetic person: an id and segment lengths in metres."""

    actor_id: str
    height: float
    """H, stature in metres."""
    ankle_height: float
    shank: float
    thigh: float
    hip_drop: float
    """Vertical drop from ``spine_base`` to the hip joints."""
    spine_lower: float
    """``spine_base`` → ``spine_mid``."""
    spine_upper: float
    """``spine_mid`` → ``spine_shoulder``."""
    neck: float
    head: float
    shoulder_half_width: float
    shoulder_drop: float
    hip_half_width: float
    upper_arm: float
    forearm: float
    hand: float
    """``wrist`` → ``hand`` (palm centre)."""
    hand_tip: float
    thumb: float
    foot_forward: float
    foot_height: float

    @property
    def leg_length(self) -> float:
        """Thigh + shank, metres."""
        return self.thigh + self.shank

    @property
    def arm_length(self) -> float:
        """Upper arm + forearm (shoulder to wrist at full extension), metres."""
        return self.upper_arm + self.forearm

    def reach(self, palm: bool) -> float:
        """Full length of the arm chain to the wrist (``palm=False``) or to the hand joint, metres."""
        return self.arm_length + (self.hand if palm else 0.0)

    @property
    def standing_root_height(self) -> float:
        """Height of ``spine_base`` when standing upright, metres."""
        return self.ankle_height + LEG_EXTENSION * self.leg_length + self.hip_drop

    @property
    def standing_head_height(self) -> float:
        """Height of the ``head`` joint when standing upright, metres."""
        return self.standing_root_height + self.spine_lower + self.spine_upper + self.neck + _HEAD_UP * self.head

    @property
    def shoulder_height(self) -> float:
        """Height of the shoulder joints when standing upright, metres."""
        return self.standing_root_height + self.spine_lower + self.spine_upper - self.shoulder_drop


def make_actors(rng: np.random.Generator, config: SyntheticConfig) -> tuple[Actor, ...]:
    """Draw ``config.n_actors`` actors with ids ``a01``, ``a02``, ...

    Statures are stratified over ``config.height_range`` (one per equal-width
    stratum, strata shuffled), so all actors differ in height; arm, leg and
    width proportions vary by ±``config.proportion_jitter``. A longer leg makes
    the trunk shorter, so the stature stays H.
    """
    n = config.n_actors
    lo, hi = config.height_range
    order = rng.permutation(n)
    heights = lo + (hi - lo) * (order + rng.uniform(0.15, 0.85, n)) / n
    jit = config.proportion_jitter
    factors = 1.0 + rng.uniform(-jit, jit, size=(n, 3))  # arms, legs, widths
    actors = []
    for k in range(n):
        h = float(heights[k])
        arm, leg, width = factors[k]
        r = {key: ratio * h for key, ratio in _RATIO.items()}
        for key in ("upper_arm", "forearm", "hand", "hand_tip", "thumb"):
            r[key] *= arm
        for key in ("thigh", "shank"):
            r[key] *= leg
        for key in ("shoulder_half_width", "hip_half_width"):
            r[key] *= width
        trunk = r.pop("trunk") + (1.0 - leg) * LEG_EXTENSION * (_RATIO["thigh"] + _RATIO["shank"]) * h
        actors.append(
            Actor(actor_id=f"a{k + 1:02d}", height=h, spine_lower=0.51 * trunk, spine_upper=0.49 * trunk, **r)
        )
    return tuple(actors)


@dataclass(frozen=True)
class BodyTrack:
    """A scripted motion of one agent over T frames (all metres / radians, world frame)."""

    root: np.ndarray
    """(T, 3) ``spine_base`` position."""
    yaw: np.ndarray
    """(T,) heading: the pelvis faces (cos yaw, sin yaw, 0)."""
    lean: np.ndarray
    """(T,) forward pitch of the trunk (negative leans back)."""
    ankles: np.ndarray
    """(T, 2, 3) left / right ankle targets."""
    hands: np.ndarray
    """(T, 2, 3) left / right targets for the wrist, or for the hand joint where ``palm_target``."""
    palm_target: tuple[bool, bool] = (False, False)
    """Per side: whether ``hands`` targets the hand joint (palm centre) instead of the wrist."""
    twist: np.ndarray | None = None
    """(T,) trunk yaw relative to the pelvis; ``None`` means zero."""


class Torso(NamedTuple):
    """Trunk joints and frames of one agent, each (T, 3) unless noted."""

    pelvis_rot: np.ndarray
    """(T, 3, 3) pelvis frame (heading only)."""
    chest_rot: np.ndarray
    """(T, 3, 3) upper-trunk frame (heading, twist, lean)."""
    spine_mid: np.ndarray
    spine_shoulder: np.ndarray
    neck: np.ndarray
    head: np.ndarray
    shoulders: np.ndarray
    """(T, 2, 3) left / right shoulder joints."""
    hips: np.ndarray
    """(T, 2, 3) left / right hip joints."""


def torso(
    actor: Actor, root: np.ndarray, yaw: np.ndarray, lean: np.ndarray, twist: np.ndarray | None = None
) -> Torso:
    """Forward kinematics of the trunk (no limbs): ``root`` (T, 3), angles (T,) radians."""
    yaw = np.asarray(yaw, dtype=np.float64)
    lean = np.asarray(lean, dtype=np.float64)
    twist = np.zeros_like(yaw) if twist is None else np.asarray(twist, dtype=np.float64)
    pelvis = rot_z(yaw)
    turned = pelvis @ rot_z(twist)
    lower = turned @ rot_y(0.6 * lean)
    chest = turned @ rot_y(lean)
    head_rot = turned @ rot_y(0.4 * lean)
    spine_mid = root + apply(lower, np.array([0.0, 0.0, actor.spine_lower]))
    spine_shoulder = spine_mid + apply(chest, np.array([0.0, 0.0, actor.spine_upper]))
    neck = spine_shoulder + apply(head_rot, np.array([0.0, 0.0, actor.neck]))
    head = neck + apply(head_rot, np.array([_HEAD_FORWARD * actor.head, 0.0, _HEAD_UP * actor.head]))
    shoulders = np.stack(
        [
            spine_shoulder + apply(chest, np.array([0.0, s * actor.shoulder_half_width, -actor.shoulder_drop]))
            for s in SIDE_SIGN
        ],
        axis=-2,
    )
    hips = np.stack(
        [root + apply(pelvis, np.array([0.0, s * actor.hip_half_width, -actor.hip_drop])) for s in SIDE_SIGN],
        axis=-2,
    )
    return Torso(pelvis, chest, spine_mid, spine_shoulder, neck, head, shoulders, hips)


def _arm(
    actor: Actor, shoulder: np.ndarray, target: np.ndarray, pole: np.ndarray, palm: bool
) -> tuple[np.ndarray, ...]:
    """Elbow, wrist, hand, hand tip and thumb (each (T, 3)) of one arm."""
    if palm:
        elbow, hand, bend = two_link_ik(shoulder, target, actor.upper_arm, actor.forearm + actor.hand, pole)
        direction = unit(hand - elbow)
        wrist = elbow + actor.forearm * direction
    else:
        elbow, wrist, bend = two_link_ik(shoulder, target, actor.upper_arm, actor.forearm, pole)
        direction = unit(wrist - elbow)
        hand = wrist + actor.hand * direction
    tip = hand + actor.hand_tip * direction
    # The thumb points away from the elbow's bend side, 40 degrees off the hand's axis.
    away = -bend - np.sum(-bend * direction, axis=-1, keepdims=True) * direction
    thumb = hand + actor.thumb * unit(np.cos(0.7) * direction + np.sin(0.7) * unit(away))
    return elbow, wrist, hand, tip, thumb


def forward_kinematics(actor: Actor, track: BodyTrack) -> np.ndarray:
    """(T, 25, 3) float64 joints in Kinect v2 order, metres, world frame z up.

    The trunk follows ``track.root``/``yaw``/``lean``/``twist``; legs reach the
    ankle targets with knees bending forward, arms reach the hand targets with
    elbows bending down, out and back; feet lie flat along the heading, so a
    foot on the floor has its ``foot`` joint at ``actor.foot_height``.
    """
    t = torso(actor, track.root, track.yaw, track.lean, track.twist)
    T = track.root.shape[0]
    out = np.empty((T, N_JOINTS, 3))
    out[:, JOINT["spine_base"]] = track.root
    out[:, JOINT["spine_mid"]] = t.spine_mid
    out[:, JOINT["spine_shoulder"]] = t.spine_shoulder
    out[:, JOINT["neck"]] = t.neck
    out[:, JOINT["head"]] = t.head
    for side, name in enumerate(_SIDES):
        sign = SIDE_SIGN[side]
        knee_pole = apply(t.pelvis_rot, np.array([1.0, 0.1 * sign, 0.0]))
        knee, ankle, _ = two_link_ik(t.hips[:, side], track.ankles[:, side], actor.thigh, actor.shank, knee_pole)
        toe_out = 0.12 * sign
        foot_vec = np.array(
            [actor.foot_forward * np.cos(toe_out), actor.foot_forward * np.sin(toe_out),
             actor.foot_height - actor.ankle_height]
        )
        out[:, JOINT[f"{name}_hip"]] = t.hips[:, side]
        out[:, JOINT[f"{name}_knee"]] = knee
        out[:, JOINT[f"{name}_ankle"]] = ankle
        out[:, JOINT[f"{name}_foot"]] = ankle + apply(t.pelvis_rot, foot_vec)

        elbow_pole = apply(t.chest_rot, np.array([-0.5, 0.7 * sign, -1.0]))
        arm = _arm(actor, t.shoulders[:, side], track.hands[:, side], elbow_pole, track.palm_target[side])
        out[:, JOINT[f"{name}_shoulder"]] = t.shoulders[:, side]
        for joint, value in zip(("elbow", "wrist", "hand", "hand_tip", "thumb"), arm, strict=True):
            out[:, JOINT[f"{name}_{joint}"]] = value
    return out


def hand_joint_indices(side: int) -> tuple[int, ...]:
    """Indices of the wrist, hand, hand tip and thumb of one side (the joints occluded in contact)."""
    name = _SIDES[side]
    return tuple(JOINT[f"{name}_{j}"] for j in ("wrist", "hand", "hand_tip", "thumb"))
