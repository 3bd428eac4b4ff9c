"""Locomotion and resting postures: stepping feet, pelvis height, swinging arms.

A walk moves the pelvis along a straight segment at a cruising speed with
smooth start and stop (:func:`.motion.cruise`). The feet step alternately: the pelvis progress is split into n + 1
equal slices, in slice m one foot swings (minimum-jerk along the ground, a
sine-shaped lift) to its next foothold while the other stays planted, and the
last slice brings the trailing foot beside the leading one. The pelvis height
then follows from the legs: it dips where the feet are spread (double support).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .body import LEG_EXTENSION, SIDE_SIGN, Actor, Torso
from .ik import apply, rot_z
from .motion import cruise, minjerk

__all__ = ["WalkSegment", "stance_feet", "walk", "settle_height", "hanging_hands", "STANCE_MARGIN"]

STANCE_MARGIN = 0.025
"""Metres each ankle sits outside its hip in a relaxed stance."""


@dataclass(frozen=True)
class WalkSegment:
    """Walk from the current position to ``end`` (x, y) metres between times ``t0`` and ``t1`` seconds."""

    t0: float
    t1: float
    end: tuple[float, float]


def _lateral(actor: Actor, yaw: float) -> np.ndarray:
    """(2, 2) horizontal offsets of the left / right ankle from the pelvis in a relaxed stance."""
    left = np.array([-np.sin(yaw), np.cos(yaw)])
    width = actor.hip_half_width + STANCE_MARGIN
    return np.stack([s * width * left for s in SIDE_SIGN])


def stance_feet(actor: Actor, xy: Sequence[float], yaw: float) -> np.ndarray:
    """(2, 3) left / right ankle positions of a relaxed stance at pelvis ``xy`` (metres) facing ``yaw``."""
    feet = np.empty((2, 3))
    feet[:, :2] = np.asarray(xy, dtype=np.float64) + _lateral(actor, yaw)
    feet[:, 2] = actor.ankle_height
    return feet


def walk(
    t: np.ndarray,
    actor: Actor,
    yaw: float,
    start: Sequence[float],
    segments: Sequence[WalkSegment],
    *,
    lead: int = 1,
    lift: float = 0.1,
    step: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Pelvis path and stepping ankles for walks facing a fixed heading (forward, backward or sideways).

    Args:
        t: (T,) frame times, seconds.
        actor: whose legs set the stance width and the step length.
        yaw: heading in radians (constant during the walks).
        start: (x, y) pelvis position before the first segment, metres.
        segments: walks in time order; the agent stands still between them.
        lead: side (0 left, 1 right) that steps first in each segment.
        lift: peak height a swinging ankle rises, metres.
        step: largest pelvis advance per step, metres (default 0.55 × leg length).

    Returns:
        ``(root_xy, ankles)``: (T, 2) pelvis (x, y) and (T, 2, 3) left / right ankles, metres.
    """
    step = 0.55 * actor.leg_length if step is None else step
    lateral = _lateral(actor, yaw)
    pos = np.asarray(start, dtype=np.float64)
    root = np.broadcast_to(pos, (t.shape[0], 2)).copy()
    ankles = np.broadcast_to(stance_feet(actor, pos, yaw), (t.shape[0], 2, 3)).copy()
    feet = ankles[0, :, :2].copy()  # current footholds
    for seg in segments:
        end = np.asarray(seg.end, dtype=np.float64)
        delta = end - pos
        dist = float(np.linalg.norm(delta))
        if dist < 1e-4 or seg.t1 <= seg.t0:
            pos = end
            continue
        s = cruise((t - seg.t0) / (seg.t1 - seg.t0))
        root += s[:, None] * delta[None, :]
        n = max(1, int(np.ceil(dist / step)))
        for m in range(n + 1):
            side = (lead + m) % 2
            along = min(m + 1, n) / n
            land = pos + along * delta + lateral[side]
            v = np.clip(s * (n + 1) - m, 0.0, 1.0)
            ankles[:, side, :2] += minjerk(v)[:, None] * (land - feet[side])[None, :]
            ankles[:, side, 2] += lift * np.sin(np.pi * v)
            feet[side] = land
        pos = end
    return root, ankles


def settle_height(
    actor: Actor, root_xy: np.ndarray, yaw: np.ndarray | float, ankles: np.ndarray, base: np.ndarray | float
) -> np.ndarray:
    """(T,) pelvis height: ``base`` lowered where a foot is too far from its hip to reach.

    A leg reaches at most 0.995 of its length, so where the feet are spread
    (double support) the pelvis dips, as in real walking.
    """
    yaw = np.broadcast_to(np.asarray(yaw, dtype=np.float64), root_xy.shape[:1])
    heading = rot_z(yaw)
    z = np.broadcast_to(np.asarray(base, dtype=np.float64), root_xy.shape[:1]).copy()
    longest = min(0.995, LEG_EXTENSION + 0.01) * actor.leg_length
    for side in (0, 1):
        hip = root_xy + apply(heading, np.array([0.0, SIDE_SIGN[side] * actor.hip_half_width, 0.0]))[:, :2]
        horizontal = np.linalg.norm(ankles[:, side, :2] - hip, axis=-1)
        reach_z = ankles[:, side, 2] + np.sqrt(np.maximum(longest**2 - horizontal**2, 0.0)) + actor.hip_drop
        z = np.minimum(z, reach_z)
    return z


def hanging_hands(
    actor: Actor,
    body: Torso,
    root_xy: np.ndarray,
    ankles: np.ndarray,
    *,
    palm: tuple[bool, bool] = (False, False),
    swing: float = 0.7,
    extension: float = 0.94,
) -> np.ndarray:
    """(T, 2, 3) hand targets of relaxed arms hanging beside the body, swinging with the legs.

    Each arm swings forward by ``swing`` radians per metre that the opposite
    ankle is ahead of the pelvis (arms counter the legs in a gait), and hangs
    slightly outward and forward. Targets are for the wrist, or for the hand
    joint where ``palm`` is set.
    """
    heading = body.pelvis_rot
    fwd = heading[:, :2, 0]
    ahead = np.einsum("tsk,tk->ts", ankles[:, :, :2] - root_xy[:, None, :], fwd)
    out = np.empty((root_xy.shape[0], 2, 3))
    for side in (0, 1):
        phi = 0.06 + swing * ahead[:, 1 - side]
        direction = np.stack([np.sin(phi), np.full_like(phi, 0.16 * SIDE_SIGN[side]), -np.cos(phi)], axis=-1)
        direction /= np.linalg.norm(direction, axis=-1, keepdims=True)
        out[:, side] = body.shoulders[:, side] + extension * actor.reach(palm[side]) * apply(heading, direction)
    return out
