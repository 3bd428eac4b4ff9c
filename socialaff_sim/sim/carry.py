"""The object while the human carries it: kinematic until the release, physics after.

Until the release the object's free joint is set every physics step to the
recorded track (linearly interpolated between frames) with the track's velocity,
so it pushes the robot but nothing pushes it. The carrying hand of agent 0
is the one nearer the object (median distance over the first quarter of the
instance), and the hold offset that distance over the first frames (tracked
objects are often recorded at a point some way from the hand); the release frame
is the first frame at which the distance departs from the hold offset by more
than ``release_distance``; from the step that reaches it on, MuJoCo moves the object. Its
state at that moment comes from a least-squares fit of free flight under gravity
(p(t) = p₀ + v₀·t − ½·g·t²·ẑ) to the recorded track around the release, so a
throw leaves with the thrower's speed and direction even from a noisy track and
without the half-frame bias of a finite difference. An object that starts away
from agent 0's hands is free from the start.

While the person carries it, the object does not collide with the person: the person's hold is the
recording, not a contact, and the capsule hand overlaps the object it holds (the track is recorded at
some point of the object, not at its surface). Such contacts would push the person's compliant hand
parts off an object that is moved kinematically every step, and once a robot hand has gripped the same
object, the hand parts jammed between the two diverged (H1, hand_over_013, random actions). From the
release on, the person and the object collide again (:func:`person_contact`).

Grasping: a robot hand (or its forearm, trapping the object) that touches the
object grips it, like a suction gripper: the scene's weld between that hand and
the object is switched on with their relative pose at that moment
(:func:`grip_on_contact`) and stays on.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from ..data.interaction import Interaction
from .scene import OBJECT_AFFINITY, PERSON_CONTYPE, Scene
from .tasks import ObjectTask

__all__ = [
    "CarryPlan", "plan_carry", "fit_flight", "hold_object", "release_object", "park_object", "grip_on_contact",
    "person_contact", "GRAVITY", "FIT_FRAMES",
]

GRAVITY = 9.81
"""g, m/s², as in the simulator (MuJoCo's default gravity)."""
FIT_FRAMES = 5
"""Frames of the recorded track used to fit the object's flight at the release."""
HOLD_FRAMES = 5
"""Frames at the start over which the object's offset from the carrying hand is measured."""
MAX_HOLD_OFFSET = 0.5
"""Metres: an object starting farther than this from agent 0's carrying hand is not carried."""


@dataclass(frozen=True)
class CarryPlan:
    """How the object moves before its release, world frame."""

    track: np.ndarray
    """(T, 3) metres: the recorded object centre."""
    velocity: np.ndarray
    """(T, 3) m/s: its finite-difference velocity (forward difference, last frame repeated)."""
    hand: str
    """``"left_hand"`` or ``"right_hand"``: the carrying hand of agent 0."""
    release_frame: int
    """First frame the object is free (0: free from the start; T: never released)."""
    flight: tuple[np.ndarray, np.ndarray]
    """Fitted position (3,) m and velocity (3,) m/s at frame ``release_frame - 1`` (the last held one)."""
    fps: float
    """Frame rate of the track."""

    def release_state(self, s: float) -> tuple[np.ndarray, np.ndarray]:
        """Position (3,) and velocity (3,) of the fitted flight at fractional frame ``s``."""
        p0, v0 = self.flight
        t = (s - (self.release_frame - 1)) / self.fps
        g = np.array([0.0, 0.0, -GRAVITY])
        return p0 + v0 * t + 0.5 * g * t * t, v0 + g * t

    def position(self, t: float) -> np.ndarray:
        """(3,) track position at fractional frame ``t`` (linear interpolation)."""
        T = len(self.track)
        t = min(max(t, 0.0), T - 1.0)
        i = min(int(np.floor(t)), T - 2) if T > 1 else 0
        a = t - i
        return (1.0 - a) * self.track[i] + a * self.track[min(i + 1, T - 1)]


def plan_carry(inter: Interaction, offset: np.ndarray, task: ObjectTask, hand_joints: tuple[int, int]) -> CarryPlan:
    """Find the carrying hand and the release frame of ``inter``'s object (``inter.object`` must be set).

    An object that starts more than :data:`MAX_HOLD_OFFSET` from that hand is free from frame 0.

    ``hand_joints``: joint indices of agent 0's left and right hand; ``offset`` (3,)
    shifts the data into the world frame.
    """
    if inter.object is None:
        raise ValueError("plan_carry needs an interaction with an object track")
    track = inter.object + offset
    joints = inter.filled_joints()[:, 0] + offset
    dist = np.stack([np.linalg.norm(track - joints[:, j], axis=1) for j in hand_joints], axis=1)  # (T, 2)
    dist = np.where(np.isfinite(dist), dist, np.inf)
    T = len(track)
    head = dist[: max(HOLD_FRAMES, T // 4)]
    if task.carried_by == "auto":
        # The carrying hand is the one nearer the object (median over the first quarter).
        near = np.where(np.isfinite(head), head, np.nan)
        median = np.array([np.nanmedian(near[:, k]) if np.isfinite(near[:, k]).any() else np.inf for k in (0, 1)])
        side = int(np.argmin(median)) if np.isfinite(median).any() else 0
    else:
        side = 0 if task.carried_by == "left_hand" else 1
    grip = float(np.median(dist[:HOLD_FRAMES, side]))
    if not np.isfinite(grip) or grip > MAX_HOLD_OFFSET:
        release = 0  # never in agent 0's hand: free from the start
    else:
        moved = np.abs(dist[:, side] - grip) > task.release_distance
        release = int(np.argmax(moved)) if moved.any() else T
    vel = np.zeros_like(track)
    if len(track) > 1:
        vel[:-1] = np.diff(track, axis=0) * inter.fps
        vel[-1] = vel[-2]
    start = max(release - 1, 0)
    flight = fit_flight(track[start:start + FIT_FRAMES], inter.fps)
    return CarryPlan(track=track, velocity=vel, hand=("left_hand", "right_hand")[side], release_frame=release,
                     flight=flight, fps=inter.fps)


def fit_flight(points: np.ndarray, fps: float) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares free flight through ``points`` (K, 3) m sampled at ``fps``: (p₀, v₀) at the first sample.

    Solves p_k + ½·g·t_k²·ẑ = p₀ + v₀·t_k for each axis (gravity known). With a
    single point the velocity is zero.
    """
    pts = np.asarray(points, dtype=np.float64)
    if len(pts) < 2:
        return pts[0].copy(), np.zeros(3)
    t = np.arange(len(pts)) / fps
    rhs = pts.copy()
    rhs[:, 2] += 0.5 * GRAVITY * t**2
    A = np.stack([np.ones_like(t), t], axis=1)
    coef, *_ = np.linalg.lstsq(A, rhs, rcond=None)
    return coef[0], coef[1]


def _set_free(scene: Scene, data: mujoco.MjData, pos: np.ndarray, vel: np.ndarray) -> None:
    qa, va = scene.object_qadr, scene.object_vadr
    data.qpos[qa:qa + 3] = pos
    data.qpos[qa + 3:qa + 7] = (1.0, 0.0, 0.0, 0.0)
    data.qvel[va:va + 3] = vel
    data.qvel[va + 3:va + 6] = 0.0


def person_contact(scene: Scene, on: bool) -> None:
    """Let the object collide with the person (``on``) or not (while the person carries it); the robot and
    the floor always collide with it. Sets the object geom's and body's ``conaffinity`` in ``scene.model``."""
    m = scene.model
    g = scene.object_geom
    aff = OBJECT_AFFINITY if on else OBJECT_AFFINITY & ~PERSON_CONTYPE
    if m.geom_conaffinity[g] != aff:
        m.geom_conaffinity[g] = aff
        m.body_conaffinity[scene.object_body] = aff


def hold_object(scene: Scene, data: mujoco.MjData, plan: CarryPlan, s: float, moving: bool = True) -> None:
    """Put the object on its recorded track at fractional frame ``s`` (with the track's velocity if ``moving``);
    the person carries it, so it does not collide with the person (:func:`person_contact`)."""
    person_contact(scene, False)
    vel = plan.velocity[min(int(s), len(plan.velocity) - 1)] if moving else np.zeros(3)
    _set_free(scene, data, plan.position(s), vel)


def release_object(scene: Scene, data: mujoco.MjData, plan: CarryPlan, s: float) -> None:
    """Let the object go at fractional frame ``s`` in the fitted flight state; from now on it collides with the person."""
    person_contact(scene, True)
    pos, vel = plan.release_state(s)
    _set_free(scene, data, pos, vel)


def park_object(scene: Scene, data: mujoco.MjData, radius: float) -> None:
    """Put an object the instance does not use out of the way, at rest on the floor."""
    person_contact(scene, True)
    _set_free(scene, data, np.array([5.0, 5.0, radius + 0.01]), np.zeros(3))


def grip_on_contact(scene: Scene, data: mujoco.MjData) -> None:
    """Switch on the grip weld of every robot hand whose hand or forearm touches the object, at their current relative pose."""
    n = data.ncon
    if not n or data.eq_active[scene.grip_eq].all():
        return
    geom = data.contact.geom[:n]
    obj = scene.object_geom
    hit = geom == obj
    if not hit.any():
        return
    other = geom[:, ::-1][hit]  # the geom each object contact touches
    m = scene.model
    for side in (0, 1):
        eq = scene.grip_eq[side]
        if data.eq_active[eq] or not scene.arm_geom[side][other].any():
            continue
        hand = scene.grip_body[side]
        inv = np.empty(4)
        mujoco.mju_negQuat(inv, data.xquat[hand])
        rel = np.empty(3)
        mujoco.mju_rotVecQuat(rel, data.xpos[scene.object_body] - data.xpos[hand], inv)
        quat = np.empty(4)
        mujoco.mju_mulQuat(quat, inv, data.xquat[scene.object_body])
        m.eq_data[eq, 3:6] = rel
        m.eq_data[eq, 6:10] = quat
        data.eq_active[eq] = 1
