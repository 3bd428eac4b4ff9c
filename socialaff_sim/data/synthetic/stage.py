"""Placing two actors for a contact, and the shared approach walk.

Scripts work in a local stage frame: agent 0's pelvis ends at the origin facing
+x (yaw 0) and agent 1 faces −x (yaw π) from x > 0. Contact points are chosen
as fractions of each actor's arm reach from the actual shoulder positions, so
they are always reachable and the hands really meet; the generator turns and
shifts the whole stage into the room afterwards.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .body import Actor, Torso, torso
from .gait import WalkSegment, settle_height, walk
from .motion import Timeline

__all__ = [
    "FACING",
    "Meeting",
    "shoulder_offset",
    "face_to_face",
    "pair_height",
    "approach",
    "walk_in",
    "standing_root",
    "trunk",
    "meet_between",
]

FACING = (0.0, np.pi)
"""Stage headings of agent 0 (toward +x) and agent 1 (toward −x), radians."""


def shoulder_offset(actor: Actor, yaw: float, lean: float, side: int) -> np.ndarray:
    """(3,) vector from ``spine_base`` to one shoulder for a given heading and lean, metres."""
    body = torso(actor, np.zeros((1, 3)), np.array([yaw]), np.array([lean]))
    return body.shoulders[0, side]


def _horizontal(dy: float, dz: float, radius: float, minimum: float) -> float:
    """Horizontal distance putting a point at ``radius`` from a shoulder, at least ``minimum``."""
    return float(np.sqrt(max(radius**2 - dy**2 - dz**2, minimum**2)))


@dataclass(frozen=True)
class Meeting:
    """Where two face-to-face agents stand and put their hands for a contact (stage frame, metres)."""

    root1: np.ndarray
    """(3,) agent 1's pelvis (agent 0's is at (0, 0, z0))."""
    end0: np.ndarray
    """(3,) agent 0's hand target at contact."""
    end1: np.ndarray
    """(3,) agent 1's hand target at contact (``end0 + (gap, 0, 0)``)."""


def face_to_face(
    actors: tuple[Actor, Actor],
    *,
    sides: tuple[int, int],
    leans: tuple[float, float],
    fractions: tuple[float, float],
    palm: bool,
    height: float,
    gap: float,
    lateral: float,
    skew: float = 0.0,
    root_z: tuple[float, float] | None = None,
    min_horizontal: float = 0.12,
) -> Meeting:
    """Solve agent 1's position so both agents reach a contact at ``height``.

    Agent 0 stands at the origin facing +x; agent 1 faces −x at y = ``lateral``.
    Agent 0's hand target lies midway (plus ``skew``) between the two used
    shoulders in y, at ``fractions[0]`` of its reach; agent 1's target is ``gap``
    further along +x and at ``fractions[1]`` of its reach, which fixes agent 1's x.
    Where a fraction is too short to get down or up to ``height``, the hand is
    kept ``min_horizontal`` in front of the shoulder instead.
    """
    a0, a1 = actors
    z0, z1 = root_z if root_z is not None else (a0.standing_root_height, a1.standing_root_height)
    s0 = np.array([0.0, 0.0, z0]) + shoulder_offset(a0, 0.0, leans[0], sides[0])
    off1 = shoulder_offset(a1, np.pi, leans[1], sides[1])
    s1_y = lateral + off1[1]
    s1_z = z1 + off1[2]
    y_m = 0.5 * (s0[1] + s1_y) + skew
    h0 = _horizontal(y_m - s0[1], height - s0[2], fractions[0] * a0.reach(palm), min_horizontal)
    end0 = np.array([s0[0] + h0, y_m, height])
    end1 = end0 + np.array([gap, 0.0, 0.0])
    h1 = _horizontal(y_m - s1_y, height - s1_z, fractions[1] * a1.reach(palm), min_horizontal)
    root1 = np.array([end1[0] + h1 - off1[0], lateral, z1])
    return Meeting(root1=root1, end0=end0, end1=end1)


def approach(
    tl: Timeline,
    actor: Actor,
    rng: np.random.Generator,
    *,
    yaw: float,
    end: np.ndarray,
    distance: float,
    phase: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Walk forward along the heading for ``distance`` metres during sub-event ``phase``, ending at ``end``.

    The walk starts and stops at slightly random moments inside the sub-event
    and begins with a random foot. Returns ``(root_xy (T, 2), ankles (T, 2, 3))``.
    """
    heading = np.array([np.cos(yaw), np.sin(yaw)])
    t0, t1 = tl.start(phase), tl.end(phase)
    span = t1 - t0
    w0 = t0 + rng.uniform(0.0, 0.12) * span
    w1 = t1 - rng.uniform(0.0, 0.08) * span
    start = np.asarray(end[:2], dtype=np.float64) - distance * heading
    lead = int(rng.integers(2))
    lift = rng.uniform(0.07, 0.12)
    segment = WalkSegment(w0, w1, (float(end[0]), float(end[1])))
    return walk(tl.t, actor, yaw, start, [segment], lead=lead, lift=lift)


def walk_in(
    tl: Timeline, actors: tuple[Actor, Actor], meet: Meeting, rng: np.random.Generator
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Both agents walk face to face into their contact stance during sub-event 0.

    They cover 1.0–2.2 m together, each a random share of it. Returns
    ``(root_xy (T, 2), ankles (T, 2, 3))`` per agent.
    """
    total = rng.uniform(1.0, 2.2)
    share = rng.uniform(0.25, 0.75)
    ends = (np.zeros(3), meet.root1)
    return [
        approach(tl, actors[i], rng, yaw=FACING[i], end=ends[i], distance=total * (share if i == 0 else 1 - share))
        for i in (0, 1)
    ]


def pair_height(actors: tuple[Actor, Actor], low: float, high: float, rng: np.random.Generator) -> float:
    """A contact height, U(low, high) times a stature weighted toward the shorter actor, metres."""
    h = sorted(a.height for a in actors)
    return float(rng.uniform(low, high) * (0.6 * h[0] + 0.4 * h[1]))


def standing_root(
    actor: Actor, root_xy: np.ndarray, yaw: np.ndarray | float, ankles: np.ndarray, dip: np.ndarray | float = 0.0
) -> np.ndarray:
    """(T, 3) pelvis of a standing or walking agent: standing height minus ``dip``, settled onto the legs."""
    z = settle_height(actor, root_xy, yaw, ankles, actor.standing_root_height - np.asarray(dip))
    return np.concatenate([root_xy, z[:, None]], axis=1)


def trunk(
    actor: Actor, root: np.ndarray, yaw: np.ndarray | float, lean: np.ndarray, twist: np.ndarray | None = None
) -> Torso:
    """Trunk joints for a root track and a (T,) lean (and twist), with a constant or (T,) heading."""
    return torso(actor, root, np.broadcast_to(np.asarray(yaw, dtype=np.float64), lean.shape), lean, twist)


def meet_between(
    s0: np.ndarray, s1: np.ndarray, r0: float | np.ndarray, r1: float | np.ndarray, gap: float, across: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Hand targets of a two-person grip hanging between two shoulders.

    Agent 0's hand goes to a point at distance ``r0`` from ``s0`` and agent 1's,
    ``gap`` further along ``across`` (T, 3) unit horizontal, at ``r1`` from ``s1``:
    the lowest point of the intersection of the two spheres. Where the shoulders
    are too far apart the hands lie on the line between them, shared in
    proportion to ``r0`` and ``r1``.

    Returns:
        ``(end0, end1)``: (T, 3) each, metres.
    """
    shifted = s1 - gap * across
    d = shifted - s0
    dist = np.linalg.norm(d, axis=-1, keepdims=True)
    e = d / np.maximum(dist, 1e-9)
    r0 = np.broadcast_to(np.asarray(r0, dtype=np.float64), dist.shape[:1])[:, None]
    r1 = np.broadcast_to(np.asarray(r1, dtype=np.float64), dist.shape[:1])[:, None]
    along = np.where(dist < r0 + r1, (dist**2 + r0**2 - r1**2) / (2.0 * dist), dist * r0 / (r0 + r1))
    drop = np.sqrt(np.maximum(r0**2 - along**2, 0.0))
    down = np.array([0.0, 0.0, -1.0]) + e[:, 2:3] * e  # minus its component along e
    down /= np.maximum(np.linalg.norm(down, axis=-1, keepdims=True), 1e-9)
    end0 = s0 + along * e + drop * down
    return end0, end0 + gap * across
