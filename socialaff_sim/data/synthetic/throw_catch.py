"""Script of ``throw_catch``: agent 0 tosses a ball underhand to agent 1, 2.5–3.5 m away.

* ``wind_up``: agent 0 holds the ball on the palm in front, then swings the
  throwing arm (right, or left with probability ``left_hand_probability``) back
  and down behind the hip, turning the trunk and shifting the weight back.
* ``throw``: the opposite foot strides forward, the arm swings forward like a
  pendulum (a cubic Hermite in the arm angle, ending with the swing speed of the
  ball) and releases the ball at the sub-event's end.
* ``flight``: the ball flies ballistically (g = 9.81 m/s², an exact parabola
  from the release point to the catch point); agent 1 raises both hands to
  where the ball will arrive; agent 0 follows through.
* ``catch``: at the first frame the ball is between agent 1's palms; the hands
  give with the ball toward the chest while the knees dip.
* ``hold``: agent 1 lowers the ball to the waist; agent 0's arm hangs again.

The object track is the ball's centre: on agent 0's palm before the release,
in flight, then midway between agent 1's palms.
"""

from __future__ import annotations

import numpy as np

from .body import JOINT, SIDE_SIGN, Actor, BodyTrack, forward_kinematics
from .config import SUBEVENTS, SyntheticConfig
from .gait import hanging_hands, stance_feet
from .ik import apply, rot_z
from .motion import blend, hermite, keyframes, minjerk, plan_timeline, ramp
from .objects import BALL_RADIUS, ballistic, launch_velocity
from .scripted import Scripted, contact_mask
from .stage import shoulder_offset, standing_root, trunk

__all__ = ["script_throw_catch", "THROW_CATCH_TIMING"]

THROW_CATCH_TIMING = ((0.5, 0.9), (0.3, 0.5), (0.6, 0.9), (0.3, 0.5), (0.6, 1.2))
"""Duration range (s) of each sub-event of ``throw_catch`` before the tempo factor."""

_SIDE_NAMES = ("left", "right")


def _thrower(
    actor: Actor,
    t: np.ndarray,
    times: tuple[float, float, float, float],
    yaw: float,
    side: int,
    target: np.ndarray,
    rng: np.random.Generator,
) -> BodyTrack:
    """Agent 0's motion; ``times`` = (throw start, release, flight end, arm back at rest), seconds.

    ``target`` (3,) is the planned catch point, used to give the swing the
    ball's launch speed at the release.
    """
    t_wind, t_rel, t_fly, t_rest = times
    heading = np.array([np.cos(yaw), np.sin(yaw)])
    sign = SIDE_SIGN[side]
    stride = rng.uniform(0.2, 0.35)
    ankles = np.broadcast_to(stance_feet(actor, (0.0, 0.0), yaw), (t.size, 2, 3)).copy()
    v = np.clip((t - t_wind) / (t_rel - t_wind), 0.0, 1.0)
    ankles[:, 1 - side, :2] += minjerk(v)[:, None] * stride * heading  # stride with the other foot
    ankles[:, 1 - side, 2] += rng.uniform(0.05, 0.09) * np.sin(np.pi * v)
    shift = keyframes(t, [0.0, t_wind, t_rel], [0.0, -0.04, 0.45 * stride])
    root_xy = shift[:, None] * heading
    root = standing_root(actor, root_xy, yaw, ankles)
    lean = keyframes(t, [0.0, t_wind, t_rel, t_fly, t_rest], [0.05, 0.1, 0.2, 0.15, 0.04])
    twist = sign * keyframes(t, [0.0, t_wind, t_rel, t_rest], [0.05, 0.3, -0.15, 0.0])
    body = trunk(actor, root, yaw, lean, twist)

    # Pendulum swing of the throwing arm: angle from straight down, positive forward.
    reach = actor.reach(True)
    phi_ready, phi_back, phi_rel = rng.uniform(0.5, 0.8), -rng.uniform(0.6, 0.9), rng.uniform(0.9, 1.2)
    ext_rel = 0.95
    release = shoulder_offset(actor, yaw, 0.2, side) + np.array([*(0.45 * stride * heading), root[0, 2]])
    release += ext_rel * reach * np.array([*(np.sin(phi_rel) * heading), -np.cos(phi_rel)])
    speed = float(np.linalg.norm(launch_velocity(release, target, t_fly - t_rel)))
    secant = (phi_rel - phi_back) / (t_rel - t_wind)
    omega = min(speed / (ext_rel * reach), 2.5 * secant)
    t_follow = t_rel + 0.45 * (t_fly - t_rel)
    phi_follow = phi_rel + omega * (t_follow - t_rel) / 3.0  # keeps the Hermite segment monotonic
    knots = [0.0, t_wind, t_rel, t_follow, t_rest]
    phi = hermite(t, knots, [phi_ready, phi_back, phi_rel, phi_follow, 0.06], [0.0, 0.0, omega, 0.0, 0.0])
    ext = keyframes(t, [0.0, t_wind, t_follow, t_rest], [0.8, ext_rel, ext_rel, 0.94])
    local = np.stack([np.sin(phi), np.full_like(phi, 0.08 * sign), -np.cos(phi)], axis=-1)
    local /= np.linalg.norm(local, axis=-1, keepdims=True)
    palm = (side == 0, side == 1)
    hands = hanging_hands(actor, body, root_xy, ankles, palm=palm)
    hands[:, side] = body.shoulders[:, side] + (ext * reach)[:, None] * apply(rot_z(yaw + twist), local)
    return BodyTrack(
        root=root, yaw=np.full_like(t, yaw), lean=lean, ankles=ankles, hands=hands, palm_target=palm, twist=twist
    )


def script_throw_catch(
    actors: tuple[Actor, Actor], fps: float, rng: np.random.Generator, config: SyntheticConfig
) -> Scripted:
    """Wind-up, throw, ballistic flight, catch and hold of a ball (stage frame)."""
    tl = plan_timeline(SUBEVENTS["throw_catch"], THROW_CATCH_TIMING, fps, rng, config)
    t = tl.t
    a0, a1 = actors
    side = 0 if rng.random() < config.left_hand_probability else 1
    distance = rng.uniform(2.5, 3.5)
    yaw0 = rng.uniform(-0.15, 0.15)  # agent 1 stands a little off agent 0's initial heading
    yaw1 = yaw0 + np.pi
    t_rel, t_catch = tl.start(2), tl.start(3)

    # Agent 1: where it will catch (its own frame: ahead, a bit to a side, below the shoulders).
    root1_xy = distance * np.array([np.cos(yaw0), np.sin(yaw0)])
    heading1 = np.array([np.cos(yaw1), np.sin(yaw1), 0.0])
    left1 = np.array([-np.sin(yaw1), np.cos(yaw1), 0.0])
    catch = np.array([*root1_xy, a1.shoulder_height - rng.uniform(0.1, 0.35)])
    catch += rng.uniform(0.3, 0.45) * heading1 + rng.uniform(-0.2, 0.2) * left1
    absorb = catch - rng.uniform(0.08, 0.15) * heading1 - np.array([0.0, 0.0, rng.uniform(0.03, 0.08)])
    hold = np.array([*root1_xy, 0.6 * a1.height]) + rng.uniform(0.25, 0.32) * heading1

    t_settled = tl.end(4) - 0.2 * (tl.end(4) - tl.start(4))
    track0 = _thrower(a0, t, (tl.start(1), t_rel, tl.end(2), t_settled), yaw0, side, catch, rng)
    joints0 = forward_kinematics(a0, track0)

    ankles1 = np.broadcast_to(stance_feet(a1, root1_xy, yaw1), (t.size, 2, 3)).copy()
    dip = keyframes(t, [t_catch, tl.end(3), tl.end(4)], [0.0, rng.uniform(0.03, 0.07), 0.0])
    root1 = standing_root(a1, np.broadcast_to(root1_xy, (t.size, 2)), yaw1, ankles1, dip)
    lean1 = keyframes(t, [t_rel, t_catch, tl.end(3), tl.end(4)], [0.02, rng.uniform(0.08, 0.18), 0.05, 0.03])
    body1 = trunk(a1, root1, yaw1, lean1)
    rest1 = hanging_hands(a1, body1, root1[:, :2], ankles1, palm=(True, True))
    tau = t_catch - t_rel
    t_ready = t_catch - rng.uniform(0.1, 0.2) * tau
    centre = keyframes(t, [t_ready, t_catch, tl.end(3), t_settled], [catch, catch, absorb, hold])
    w = ramp(t, t_rel + rng.uniform(0.1, 0.25) * tau, t_ready)
    palms = np.stack([centre + BALL_RADIUS * left1, centre - BALL_RADIUS * left1], axis=1)
    hands1 = blend(rest1, palms, w)
    track1 = BodyTrack(
        root=root1, yaw=np.full_like(t, yaw1), lean=lean1, ankles=ankles1, hands=hands1, palm_target=(True, True)
    )
    joints1 = forward_kinematics(a1, track1)

    # The ball: on agent 0's palm, then a parabola, then between agent 1's palms.
    held0 = joints0[:, JOINT[f"{_SIDE_NAMES[side]}_hand"]] + np.array([0.0, 0.0, BALL_RADIUS])
    held1 = 0.5 * (joints1[:, JOINT["left_hand"]] + joints1[:, JOINT["right_hand"]])
    b_rel, b_catch = int(tl.bounds[2]), int(tl.bounds[3])
    flight = ballistic(t, t_rel, t_catch, held0[b_rel], held1[b_catch])
    ball = np.concatenate([held0[:b_rel], flight[b_rel:b_catch], held1[b_catch:]], axis=0)

    occluded = contact_mask(tl, [1], [(0, side)]) | contact_mask(tl, [3], [(1, 0), (1, 1)])
    return Scripted(timeline=tl, joints=np.stack([joints0, joints1], axis=1), object=ball, occluded=occluded)
