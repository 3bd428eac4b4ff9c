"""Script of ``pull_up``: agent 1 helps the seated agent 0 to stand up.

* ``approach``: agent 0 sits (hips at chair height, thighs level, shanks near
  vertical, hands resting on the thighs); agent 1 walks up and stops in front.
* ``reach``: agent 1 leans forward and bends the knees a little, agent 0 leans
  in; one hand each (right–right, or left–left with probability
  ``left_hand_probability``) meets in a grip hanging between their shoulders.
* ``pull``: agent 0 shifts the hips forward over the feet while leaning in,
  then rises to standing (the base rises by about a quarter of the stature);
  agent 1 leans back and steps back to keep the arms taut; the grip follows.
* ``release``: the hands let go and drop to the sides; both stand upright.
"""

from __future__ import annotations

import numpy as np

from .body import Actor, BodyTrack, forward_kinematics
from .config import SUBEVENTS, SyntheticConfig
from .gait import WalkSegment, hanging_hands, walk
from .motion import blend, keyframes, plan_timeline, ramp
from .scripted import Scripted, contact_mask
from .stage import meet_between, shoulder_offset, standing_root, trunk

__all__ = ["script_pull_up", "PULL_UP_TIMING"]

PULL_UP_TIMING = ((1.3, 2.2), (0.6, 1.0), (1.2, 1.9), (0.5, 0.9))
"""Duration range (s) of each sub-event of ``pull_up`` before the tempo factor."""


def _partner_x(
    s0: np.ndarray, off1: np.ndarray, y1: float, z1: float, gap: float, distance: float
) -> float:
    """Pelvis x of agent 1 (facing −x) putting its shoulder ``distance`` (after ``gap``) from ``s0``."""
    dy = y1 + off1[1] - s0[1]
    dz = z1 + off1[2] - s0[2]
    horizontal = np.sqrt(max(distance**2 - dy**2 - dz**2, 0.3**2))
    return float(s0[0] + gap + horizontal - off1[0])


def script_pull_up(
    actors: tuple[Actor, Actor], fps: float, rng: np.random.Generator, config: SyntheticConfig
) -> Scripted:
    """Approach, reach, pull (agent 0 rises from a chair) and release (stage frame)."""
    tl = plan_timeline(SUBEVENTS["pull_up"], PULL_UP_TIMING, fps, rng, config)
    t = tl.t
    a0, a1 = actors
    side = 0 if rng.random() < config.left_hand_probability else 1
    gap = rng.uniform(0.04, 0.08)
    across = np.array([1.0, 0.0, 0.0])
    radius = (rng.uniform(0.85, 0.93) * a0.arm_length, rng.uniform(0.85, 0.93) * a1.arm_length)
    t_p0, t_p1 = tl.start(2), tl.end(2)
    dur = t_p1 - t_p0

    # Agent 0: seated at the origin, feet planted in front, then stands up over the feet.
    foot_x = a0.thigh * rng.uniform(0.8, 0.95)
    z_seat = a0.ankle_height + a0.shank * rng.uniform(0.9, 0.98) + a0.hip_drop
    z_stand = a0.standing_root_height
    lean_seat = rng.uniform(-0.1, 0.02)
    lean_reach0 = rng.uniform(0.05, 0.2)
    lean_rise = rng.uniform(0.45, 0.6)
    width0 = a0.hip_half_width + 0.03
    ankles0 = np.broadcast_to(
        np.array([[foot_x, width0, a0.ankle_height], [foot_x, -width0, a0.ankle_height]]), (t.size, 2, 3)
    ).copy()
    x0 = keyframes(t, [t_p0, t_p0 + 0.8 * dur], [0.0, foot_x - 0.02])
    z0 = keyframes(t, [t_p0 + 0.3 * dur, t_p1], [z_seat, z_stand])
    root0 = np.stack([x0, np.zeros_like(t), z0], axis=1)
    lean0 = keyframes(
        t,
        [tl.start(1), tl.end(1), t_p0 + rng.uniform(0.35, 0.45) * dur, t_p1],
        [lean_seat, lean_reach0, lean_rise, 0.03],
    )
    body0 = trunk(a0, root0, 0.0, lean0)

    # Agent 1: walks up, leans in to reach, then leans back and steps back while pulling.
    y1 = rng.uniform(-0.1, 0.1)
    dip = rng.uniform(0.03, 0.1)
    lean_reach1 = rng.uniform(0.3, 0.5)
    lean_pull1 = rng.uniform(-0.15, -0.05)
    share = (rng.uniform(0.82, 0.92), rng.uniform(0.82, 0.92))
    s0_reach = np.array([0.0, 0.0, z_seat]) + shoulder_offset(a0, 0.0, lean_reach0, side)
    off1_reach = shoulder_offset(a1, np.pi, lean_reach1, side)
    x_near = _partner_x(s0_reach, off1_reach, y1, a1.standing_root_height - dip, gap, share[0] * sum(radius))
    x_near = max(x_near, foot_x + 0.35)
    s0_end = np.array([foot_x - 0.02, 0.0, z_stand]) + shoulder_offset(a0, 0.0, 0.03, side)
    off1_end = shoulder_offset(a1, np.pi, lean_pull1, side)
    x_far = _partner_x(s0_end, off1_end, y1, a1.standing_root_height, gap, share[1] * sum(radius))
    start1 = (x_near + rng.uniform(0.8, 1.5), y1)
    segments = [
        WalkSegment(tl.start(0) + rng.uniform(0.0, 0.15) * (tl.end(0) - tl.start(0)), tl.end(0), (x_near, y1)),
        WalkSegment(t_p0 + 0.15 * dur, t_p1 - 0.05 * dur, (x_far, y1)),
    ]
    lead, lift = int(rng.integers(2)), rng.uniform(0.07, 0.11)
    root1_xy, ankles1 = walk(t, a1, np.pi, start1, segments, lead=lead, lift=lift)
    dip1 = keyframes(t, [tl.start(1), tl.end(1), t_p0 + 0.5 * dur], [0.0, dip, 0.0])
    root1 = standing_root(a1, root1_xy, np.pi, ankles1, dip1)
    lean1 = keyframes(
        t, [tl.start(1), tl.end(1), t_p0 + 0.6 * dur, tl.start(3), tl.end(3)],
        [0.03, lean_reach1, lean_pull1, lean_pull1, 0.02],
    )
    body1 = trunk(a1, root1, np.pi, lean1)

    # The grip hangs between the two shoulders; hands blend into it and back out.
    grip0, grip1 = meet_between(
        body0.shoulders[:, side], body1.shoulders[:, side], radius[0], radius[1], gap, across
    )
    w = ramp(t, tl.start(1), tl.end(1)) - ramp(t, tl.start(3), tl.end(3))

    thigh_rest = root0[:, None, :] + np.array(
        [[0.55 * a0.thigh, width0 - 0.01, 0.1 - a0.hip_drop], [0.55 * a0.thigh, -width0 + 0.01, 0.1 - a0.hip_drop]]
    )
    hang0 = hanging_hands(a0, body0, root0[:, :2], ankles0)
    stand_w = ramp(t, t_p0 + 0.3 * dur, t_p1)
    hands0 = blend(thigh_rest, hang0, stand_w)
    hands0[:, side] = blend(hands0[:, side], grip0, w)
    hands1 = hanging_hands(a1, body1, root1_xy, ankles1)
    hands1[:, side] = blend(hands1[:, side], grip1, w)

    track0 = BodyTrack(root=root0, yaw=np.zeros_like(t), lean=lean0, ankles=ankles0, hands=hands0)
    track1 = BodyTrack(root=root1, yaw=np.full_like(t, np.pi), lean=lean1, ankles=ankles1, hands=hands1)
    joints = [forward_kinematics(a0, track0), forward_kinematics(a1, track1)]
    occluded = contact_mask(tl, [2], [(0, side), (1, side)])
    return Scripted(timeline=tl, joints=np.stack(joints, axis=1), object=None, occluded=occluded)
