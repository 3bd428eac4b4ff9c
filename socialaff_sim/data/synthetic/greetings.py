"""Scripts of the two greetings: ``shake_hands`` and ``high_five``.

Both start with the two agents walking toward each other (``approach``) and
stopping where the contact is comfortably within both actors' reach (see
:func:`.stage.face_to_face`).

* shake_hands: ``reach`` (right wrists to a meeting point between the agents at
  about elbow height, trunks leaning in), ``shake`` (hands joined, a vertical
  oscillation of a few centimetres at 2–3 Hz), ``retract`` (hands back to the sides).
* high_five: ``raise`` (one hand, the right one or with probability
  ``left_hand_probability`` the left one, lifted above the shoulder), ``strike``
  (the raised hands meet above both shoulders and rebound), ``retract``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from .body import SIDE_SIGN, Actor, BodyTrack, Torso, forward_kinematics
from .config import SUBEVENTS, SyntheticConfig
from .gait import hanging_hands
from .ik import rot_z, unit
from .motion import Timeline, blend, keyframes, plan_timeline, ramp
from .scripted import Scripted, contact_mask
from .stage import FACING, Meeting, face_to_face, pair_height, shoulder_offset, standing_root, trunk, walk_in

__all__ = ["script_shake_hands", "script_high_five", "SHAKE_HANDS_TIMING", "HIGH_FIVE_TIMING"]

SHAKE_HANDS_TIMING = ((1.5, 2.5), (0.5, 0.9), (0.9, 1.8), (0.5, 0.9))
"""Duration range (s) of each sub-event of ``shake_hands`` before the tempo factor."""
HIGH_FIVE_TIMING = ((1.5, 2.5), (0.45, 0.8), (0.35, 0.7), (0.5, 0.9))
"""Duration range (s) of each sub-event of ``high_five`` before the tempo factor."""

_YAWS = FACING

_HandMove = Callable[[int, Actor, Torso], tuple[int, np.ndarray]]
"""``(agent, actor, trunk) -> (side, target)``: which hand (0 left, 1 right) of that agent greets
and its (T, 3) track while greeting, stage frame, metres."""


def _greeting_joints(
    tl: Timeline,
    actors: tuple[Actor, Actor],
    meet: Meeting,
    leans: Sequence[float],
    rng: np.random.Generator,
    hand_move: _HandMove,
) -> np.ndarray:
    """(T, 2, J, 3) joints of both agents, stage frame, metres.

    They walk in to ``meet``, lean the trunk forward to ``leans`` (one per agent) over sub-event 1
    and back over sub-event 3, and over the same spans bring the hand ``hand_move`` names onto its
    track and back to hanging. ``hand_move`` is called once per agent, in order, after that agent's
    trunk is built (so any draws it makes from ``rng`` come after :func:`walk_in`'s).
    """
    t = tl.t
    walks = walk_in(tl, actors, meet, rng)
    w = ramp(t, tl.start(1), tl.end(1)) - ramp(t, tl.start(3), tl.end(3))
    joints = []
    for i, (actor, (root_xy, ankles)) in enumerate(zip(actors, walks, strict=True)):
        lean = keyframes(t, [tl.start(1), tl.end(1), tl.start(3), tl.end(3)], [0.02, leans[i], leans[i], 0.02])
        root = standing_root(actor, root_xy, _YAWS[i], ankles)
        body = trunk(actor, root, _YAWS[i], lean)
        hands = hanging_hands(actor, body, root_xy, ankles)
        side, target = hand_move(i, actor, body)
        hands[:, side] = blend(hands[:, side], target, w)
        track = BodyTrack(root=root, yaw=np.full(t.shape, _YAWS[i]), lean=lean, ankles=ankles, hands=hands)
        joints.append(forward_kinematics(actor, track))
    return np.stack(joints, axis=1)


def script_shake_hands(
    actors: tuple[Actor, Actor], fps: float, rng: np.random.Generator, config: SyntheticConfig
) -> Scripted:
    """Approach, reach, shake and retract with the right hands (stage frame)."""
    tl = plan_timeline(SUBEVENTS["shake_hands"], SHAKE_HANDS_TIMING, fps, rng, config)
    t = tl.t
    leans = tuple(rng.uniform(0.03, 0.14, 2))
    meet = face_to_face(
        actors,
        sides=(1, 1),
        leans=leans,
        fractions=tuple(rng.uniform(0.86, 0.94, 2)),
        palm=False,
        height=pair_height(actors, 0.6, 0.67, rng),
        gap=rng.uniform(0.04, 0.08),
        lateral=rng.uniform(-0.12, 0.12),
        skew=rng.uniform(-0.04, 0.04),
    )
    amplitude = rng.uniform(0.025, 0.055)
    freq = rng.uniform(2.0, 3.0)
    t2, t3 = tl.start(2), tl.end(2)
    u = np.clip((t - t2) / (t3 - t2), 0.0, 1.0)
    shake = amplitude * np.sin(2 * np.pi * freq * (t - t2)) * np.sin(np.pi * u)

    def right_hand(i: int, actor: Actor, body: Torso) -> tuple[int, np.ndarray]:
        return 1, (meet.end0, meet.end1)[i][None, :] + shake[:, None] * np.array([0.0, 0.0, 1.0])

    joints = _greeting_joints(tl, actors, meet, leans, rng, right_hand)
    occluded = contact_mask(tl, [2], [(0, 1), (1, 1)])
    return Scripted(timeline=tl, joints=joints, object=None, occluded=occluded)


def script_high_five(
    actors: tuple[Actor, Actor], fps: float, rng: np.random.Generator, config: SyntheticConfig
) -> Scripted:
    """Approach, raise, strike and retract with one hand each, both the same side (stage frame)."""
    tl = plan_timeline(SUBEVENTS["high_five"], HIGH_FIVE_TIMING, fps, rng, config)
    t = tl.t
    side = 0 if rng.random() < config.left_hand_probability else 1
    leans = tuple(rng.uniform(0.0, 0.1, 2))
    shoulders = np.array(
        [
            a.standing_root_height + shoulder_offset(a, yaw, lean, side)[2]
            for a, yaw, lean in zip(actors, _YAWS, leans, strict=True)
        ]
    )
    reach = np.array([a.arm_length for a in actors])
    # Above both shoulders, but no higher than the shorter actor reaches while still stretching forward.
    height = min(shoulders.max() + rng.uniform(0.12, 0.28), float(np.min(shoulders + 0.85 * reach)))
    height = max(height, shoulders.max() + 0.04)
    needed = np.sqrt((height - shoulders) ** 2 + 0.15**2 + 0.17**2) / reach  # up, forward and across
    fractions = np.clip(np.maximum(rng.uniform(0.82, 0.93, 2), needed), None, 0.97)
    meet = face_to_face(
        actors,
        sides=(side, side),
        leans=leans,
        fractions=tuple(fractions),
        palm=False,
        height=height,
        gap=rng.uniform(0.08, 0.13),
        lateral=rng.uniform(-0.15, 0.15),
        skew=rng.uniform(-0.05, 0.05),
    )
    t_contact = tl.at(2, rng.uniform(0.45, 0.65))
    rebound_share = rng.uniform(0.25, 0.5)

    def strike(i: int, actor: Actor, body: Torso) -> tuple[int, np.ndarray]:
        contact = (meet.end0, meet.end1)[i]
        # Raised hand: up, a little forward and out from the shoulder, in the agent's heading frame.
        local = unit(np.array([rng.uniform(0.15, 0.35), 0.3 * SIDE_SIGN[side], 0.9]))
        raised = body.shoulders[tl.bounds[2], side] + 0.8 * actor.arm_length * (rot_z(_YAWS[i]) @ local)
        rebound = contact + rebound_share * (raised - contact)
        return side, keyframes(t, [tl.start(2), t_contact, tl.end(2)], [raised, contact, rebound])

    joints = _greeting_joints(tl, actors, meet, leans, rng, strike)
    occluded = contact_mask(tl, [2], [(0, side), (1, side)])
    return Scripted(timeline=tl, joints=joints, object=None, occluded=occluded)
