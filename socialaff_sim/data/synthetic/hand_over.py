"""Script of ``hand_over``: agent 0 hands a cup to agent 1.

* ``approach``: both walk toward each other; agent 0 carries the cup in the
  right hand in front of the belly, the other arms swing with the gait.
* ``reach``: agent 0 holds the cup out to a meeting point between them; agent 1
  reaches for it with the right hand (the left with probability
  ``left_hand_probability``).
* ``transfer``: both palms are at the cup, one on each side; the cup drifts a
  few centimetres toward agent 1; agent 1 holds it from the last frame on.
* ``retract``: agent 1 brings the cup back in front of its own belly; agent 0's
  hand drops to the side.

The object track is the cup's centre, one cup radius in front of the holder's
palm (agent 0's before the end of ``transfer``, agent 1's after).
"""

from __future__ import annotations

import numpy as np

from .body import JOINT, SIDE_SIGN, Actor, BodyTrack, Torso, forward_kinematics
from .config import SUBEVENTS, SyntheticConfig
from .gait import hanging_hands
from .ik import apply, unit
from .motion import blend, plan_timeline, ramp
from .objects import CUP_RADIUS
from .scripted import Scripted, contact_mask
from .stage import FACING, face_to_face, pair_height, standing_root, trunk, walk_in

__all__ = ["script_hand_over", "HAND_OVER_TIMING"]

HAND_OVER_TIMING = ((1.5, 2.5), (0.6, 1.0), (0.5, 1.1), (0.6, 1.0))
"""Duration range (s) of each sub-event of ``hand_over`` before the tempo factor."""

_YAWS = FACING
_SIDE_NAMES = ("left", "right")


def _carry(actor: Actor, body: Torso, side: int, rng: np.random.Generator) -> np.ndarray:
    """(T, 3) palm target holding something in front of the belly with one hand (elbow bent)."""
    local = unit(np.array([rng.uniform(0.5, 0.65), -0.15 * SIDE_SIGN[side], -0.8]))
    return body.shoulders[:, side] + rng.uniform(0.72, 0.8) * actor.reach(True) * apply(body.pelvis_rot, local)


def script_hand_over(
    actors: tuple[Actor, Actor], fps: float, rng: np.random.Generator, config: SyntheticConfig
) -> Scripted:
    """Approach, reach, transfer and retract of a cup from agent 0 to agent 1 (stage frame)."""
    tl = plan_timeline(SUBEVENTS["hand_over"], HAND_OVER_TIMING, fps, rng, config)
    t = tl.t
    sides = (1, 0 if rng.random() < config.left_hand_probability else 1)
    leans = tuple(rng.uniform(0.03, 0.15, 2))
    meet = face_to_face(
        actors,
        sides=sides,
        leans=leans,
        fractions=tuple(rng.uniform(0.8, 0.9, 2)),
        palm=True,
        height=pair_height(actors, 0.55, 0.64, rng),
        gap=2 * CUP_RADIUS,
        lateral=rng.uniform(-0.12, 0.12),
        skew=rng.uniform(-0.04, 0.04),
    )
    along = np.array([1.0, 0.0, 0.0])
    drift = rng.uniform(0.0, 0.04) * ramp(t, tl.start(2), tl.end(2))
    cup_at_contact = 0.5 * (meet.end0 + meet.end1) + drift[:, None] * along
    walks = walk_in(tl, actors, meet, rng)
    w_reach = ramp(t, tl.start(1), tl.end(1))
    w_back = ramp(t, tl.start(3), tl.end(3))
    joints = []
    for i, actor in enumerate(actors):
        root_xy, ankles = walks[i]
        lean = np.full(t.shape, 0.02) + (leans[i] - 0.02) * (w_reach - w_back)
        root = standing_root(actor, root_xy, _YAWS[i], ankles)
        body = trunk(actor, root, _YAWS[i], lean)
        palm = (sides[i] == 0, sides[i] == 1)
        hands = hanging_hands(actor, body, root_xy, ankles, palm=palm)
        contact = cup_at_contact + (-1 if i == 0 else 1) * CUP_RADIUS * along
        if i == 0:  # carry → hold out → let go
            hand = blend(_carry(actor, body, sides[0], rng), contact, w_reach)
            hands[:, sides[0]] = blend(hand, hands[:, sides[0]], w_back)
        else:  # rest → take → carry
            hand = blend(hands[:, sides[1]], contact, w_reach)
            hands[:, sides[1]] = blend(hand, _carry(actor, body, sides[1], rng), w_back)
        track = BodyTrack(
            root=root, yaw=np.full(t.shape, _YAWS[i]), lean=lean, ankles=ankles, hands=hands, palm_target=palm
        )
        joints.append(forward_kinematics(actor, track))
    facing = [np.array([np.cos(yaw), np.sin(yaw), 0.0]) for yaw in _YAWS]
    held = [joints[i][:, JOINT[f"{_SIDE_NAMES[sides[i]]}_hand"]] + CUP_RADIUS * facing[i] for i in (0, 1)]
    switch = int(tl.bounds[3])
    cup = np.concatenate([held[0][:switch], held[1][switch:]], axis=0)
    occluded = contact_mask(tl, [2], [(0, sides[0]), (1, sides[1])])
    return Scripted(timeline=tl, joints=np.stack(joints, axis=1), object=cup, occluded=occluded)
