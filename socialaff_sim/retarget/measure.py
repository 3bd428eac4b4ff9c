"""Measurements of a body for the human-to-robot scaling: limb lengths, offsets, hand length.

:func:`measure_human` measures one agent of a recording (medians over frames; typical
adult values where the layout lacks the joints), :func:`measure_robot` a robot model
at its home posture.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from ..data.interaction import Interaction

__all__ = ["BodyMeasurements", "RobotFrame", "measure_human", "measure_robot", "heading_matrix"]


@dataclass(frozen=True)
class BodyMeasurements:
    """Limb lengths and offsets of one body, metres."""

    arm: float
    """Shoulder→elbow→wrist chain length (mean of both sides)."""
    leg: float
    """Hip→knee→ankle chain length (mean of both sides)."""
    base_height: float
    """Height of the base above the floor when standing."""
    shoulders: np.ndarray
    """(2, 3) left/right shoulder offset from the base in the body's heading frame (x forward, z up)."""
    hips: np.ndarray
    """(2, 3) left/right hip offset from the base in the heading frame."""
    hand: float = 0.0
    """Distance (m) from the wrist to the middle of the hand: the recorded hand joint for a person (0 where
    the layout's wrist key is itself a hand), the hand's centre of mass for a robot."""
    trunk_radius: float = 0.0
    """Horizontal extent (m) of everything but the arms around the base's vertical axis (robots;
    used to keep the robot's body clear of the partner's)."""
    height: float = 0.0
    """Height (m) of the body's top above the floor (robots; 0 when unknown)."""


# Typical adult proportions used where a layout lacks the joints to measure them.
_DEFAULT_HUMAN = BodyMeasurements(
    arm=0.56, leg=0.84, base_height=0.95,
    shoulders=np.array([[0.0, 0.18, 0.45], [0.0, -0.18, 0.45]]),
    hips=np.array([[0.0, 0.09, -0.05], [0.0, -0.09, -0.05]]),
)


def heading_matrix(heading: np.ndarray) -> np.ndarray:
    """(3, 3) rotation whose columns are the heading frame's axes in world coordinates."""
    x = np.array([heading[0], heading[1], 0.0])
    n = np.linalg.norm(x)
    x = np.array([1.0, 0.0, 0.0]) if n < 1e-9 else x / n
    z = np.array([0.0, 0.0, 1.0])
    return np.stack([x, np.cross(z, x), z], axis=1)


def _chain(joints: np.ndarray, names: tuple[str, ...], parts: tuple[str, ...]) -> float | None:
    if not all(p in names for p in parts):
        return None
    idx = [names.index(p) for p in parts]
    seg = np.linalg.norm(np.diff(joints[:, idx], axis=1), axis=-1)  # (T, len-1)
    ok = np.isfinite(seg).all(axis=1)
    if not ok.any():
        return None
    return float(np.median(seg[ok], axis=0).sum())


def measure_human(inter: Interaction, agent: int, offset: np.ndarray) -> BodyMeasurements:
    """Limb lengths of one agent (medians over frames); typical adult values where joints are missing.

    ``offset`` (3,) shifts the data into the world frame (floor at z = 0).
    """
    joints = inter.filled_joints()[:, agent] + offset
    names = inter.joint_names
    key = inter.key_joints()[:, agent] + offset
    other = inter.key_joints()[0, 1 - agent] + offset
    heading = heading_matrix(other[0] - key[0, 0])
    arms = [_chain(joints, names, (f"{s}_shoulder", f"{s}_elbow", f"{s}_wrist")) for s in ("left", "right")]
    if None in arms:
        arms = [_chain(joints, names, (f"{s}_shoulder", f"{s}_elbow", f"{s}_hand")) for s in ("left", "right")]
    legs = [_chain(joints, names, (f"{s}_hip", f"{s}_knee", f"{s}_ankle")) for s in ("left", "right")]
    if None in legs:
        legs = [_chain(joints, names, (f"{s}_hip", f"{s}_knee", f"{s}_foot")) for s in ("left", "right")]
    base = key[:, 0]
    d = _DEFAULT_HUMAN

    def offsets(kind: str, default: np.ndarray) -> np.ndarray:
        out = default.copy()
        for i, s in enumerate(("left", "right")):
            n = f"{s}_{kind}"
            if n in names:
                rel = (joints[:, names.index(n)] - base) @ heading
                ok = np.isfinite(rel).all(axis=1)
                if ok.any():
                    out[i] = np.median(rel[ok], axis=0)
        return out

    height = float(np.nanmedian(base[:, 2])) if np.isfinite(base[:, 2]).any() else d.base_height
    hands = [_chain(joints, names, (f"{s}_wrist", f"{s}_hand")) for s in ("left", "right")]
    hand = float(np.mean([h for h in hands if h is not None])) if any(h is not None for h in hands) else 0.0
    return BodyMeasurements(
        arm=float(np.mean(arms)) if None not in arms else d.arm,  # type: ignore[arg-type]
        leg=float(np.mean(legs)) if None not in legs else d.leg,  # type: ignore[arg-type]
        base_height=height,
        shoulders=offsets("shoulder", d.shoulders),
        hips=offsets("hip", d.hips),
        hand=hand,
    )


def _path_length(model: mujoco.MjModel, data: mujoco.MjData, root_body: int, kind: str, fid: int) -> float:
    """Length of the chain of body origins from ``root_body`` down to a site or body."""
    if kind == "site":
        body = int(model.site_bodyid[fid])
        total = float(np.linalg.norm(data.site_xpos[fid] - data.xpos[body]))
    else:
        body, total = fid, 0.0
    while body != root_body:
        parent = int(model.body_parentid[body])
        if parent <= 0:
            raise ValueError(f"body {model.body(root_body).name!r} is not an ancestor of the key frame")
        total += float(np.linalg.norm(data.xpos[body] - data.xpos[parent]))
        body = parent
    return total


def measure_robot(model: mujoco.MjModel, qpos: np.ndarray, frame_kinds: tuple[str, ...], frame_ids: np.ndarray,
                  limb_body_ids: np.ndarray) -> BodyMeasurements:
    """Measurements of a robot at ``qpos`` (its home posture, robot frame, facing +x).

    ``limb_body_ids`` (4,): bodies where the left/right arm and left/right leg chains start.
    """
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)

    def pos(kind: str, i: int) -> np.ndarray:
        return np.array(data.site_xpos[i] if kind == "site" else data.xpos[i])

    base = pos(frame_kinds[0], int(frame_ids[0]))
    arms = [_path_length(model, data, int(limb_body_ids[s]), frame_kinds[1 + s], int(frame_ids[1 + s])) for s in (0, 1)]
    legs = [_path_length(model, data, int(limb_body_ids[2 + s]), frame_kinds[3 + s], int(frame_ids[3 + s])) for s in (0, 1)]
    return BodyMeasurements(
        arm=float(np.mean(arms)),
        leg=float(np.mean(legs)),
        base_height=float(base[2]),
        shoulders=np.array([data.xpos[int(limb_body_ids[s])] - base for s in (0, 1)]),
        hips=np.array([data.xpos[int(limb_body_ids[2 + s])] - base for s in (0, 1)]),
    )


@dataclass(frozen=True)
class RobotFrame:
    """The robot frame in world coordinates: a point on the floor and a yaw."""

    origin: np.ndarray
    """(3,) metres, z = 0."""
    rotation: np.ndarray
    """(3, 3): columns are the robot frame's x, y, z axes in world coordinates."""

    @property
    def yaw(self) -> float:
        """Heading angle, radians."""
        return float(np.arctan2(self.rotation[1, 0], self.rotation[0, 0]))

    def to_world(self, p: np.ndarray) -> np.ndarray:
        """Points (..., 3) from the robot frame to the world frame."""
        return np.asarray(p) @ self.rotation.T + self.origin

    def to_robot(self, p: np.ndarray) -> np.ndarray:
        """Points (..., 3) from the world frame to the robot frame."""
        return (np.asarray(p) - self.origin) @ self.rotation
