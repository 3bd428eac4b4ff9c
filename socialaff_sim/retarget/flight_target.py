"""A hand target on a thrown object's predicted flight (``ContactCompletionConfig.catch_flight``).

In a catch the object's own state is the robot's observation: at frame t the simulator knows where the ball is
and how fast it moves (physics, now), and nothing later. Free flight under gravity g along −z continues it in
closed form, p(τ) = p₀ + v₀·τ − ½·g·τ²·ẑ, v(τ) = v₀ − g·τ·ẑ, until the ball's centre comes down to
``floor`` + r (it lands). Of that path, over ``horizon`` seconds from the end of the frame being planned (τ₀,
``lead``), each hand aims at one point:

* the hand's contact point (its point nearest the ball now, moved with the wrist) goes to the ball's surface on the
  side the ball is heading, the hand is on and its own side of the body, d̂ = unit(v̂(τ) − û + ℓ̂), û the unit
  vector from the hand's point to the ball's centre, ℓ̂ the horizontal unit vector from the other shoulder to
  this one: the hand is put in the ball's way, its inside facing the ball coming at it, the two hands on either
  side of it (a cup; without ℓ̂ two hands coming from one side meet at one point and strike each other);
* of the path's points whose wrist target lies within the reach ρ·arm of the hand's shoulder, the earliest the
  hand can get to in time: its wrist target within v_h·τ of the commanded wrist now, ``speed`` v_h the hand's
  speed, τ the ball's time to that point (a catcher's ready position: the hand goes in front, where the ball
  enters its reach, and waits there for it); if the hand can be in time at none of them, the one it misses by
  the least (largest v_h·τ − travel);
* if none is within reach, the point of the path whose wrist target comes nearest the shoulder, the target
  clamped onto the reach sphere |w − shoulder| = ρ·arm; how far beyond the reach it lay is returned, for the
  completion's reach gate.

Every input is of frame t or before (the ball's simulated state now, the robot's own hands and shoulders).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["FlightState", "ballistic", "landing_time", "flight_targets"]


@dataclass(frozen=True)
class FlightState:
    """The free object's state now, world frame, and how far ahead the frame being planned ends."""

    position: np.ndarray
    """(3,) m: the object's centre now."""
    velocity: np.ndarray
    """(3,) m/s: its linear velocity now."""
    lead: float
    """τ₀ [s]: from now to the end of the frame whose targets are being made (its first possible contact)."""
    gravity: float = 9.81
    """g [m/s²]: gravity's magnitude, along −z (the scene's own)."""
    floor: float = 0.0
    """[m]: the floor's height; the flight ends where the centre is one radius above it."""


def ballistic(position: np.ndarray, velocity: np.ndarray, times: np.ndarray, gravity: float) -> tuple[np.ndarray, np.ndarray]:
    """Positions (K, 3) m and velocities (K, 3) m/s of free flight from ``position`` (3,) and ``velocity`` (3,)
    after ``times`` (K,) s, gravity ``gravity`` m/s² along −z."""
    tau = np.asarray(times, dtype=np.float64)[:, None]
    down = np.array([0.0, 0.0, 1.0])
    p = np.asarray(position, dtype=np.float64) + np.asarray(velocity, dtype=np.float64) * tau - 0.5 * gravity * tau ** 2 * down
    v = np.asarray(velocity, dtype=np.float64) - gravity * tau * down
    return p, v


def landing_time(state: FlightState, radius: float) -> float:
    """[s] from now until the centre comes down to ``floor`` + ``radius`` (0 if it is there or below already)."""
    h = float(state.position[2]) - state.floor - radius
    if h <= 0.0:
        return 0.0
    vz, g = float(state.velocity[2]), state.gravity
    if g <= 0.0:
        return np.inf if vz >= 0.0 else h / -vz
    return (vz + np.sqrt(vz * vz + 2.0 * g * h)) / g


def flight_targets(state: FlightState, radius: float, press: float, nearest: np.ndarray, wrist_now: np.ndarray,
                   shoulder: np.ndarray, reach: float, horizon: float, speed: float,
                   samples: int = 64) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each hand's wrist target on the object's predicted flight (see the module docstring).

    ``radius`` [m] the object's, ``press`` [m] how far inside its surface the hand's point is sent, ``nearest``
    (2, 3) each hand's point nearest the object now, ``wrist_now`` (2, 3) the commanded wrists, ``shoulder`` (2, 3)
    the shoulders the reach is measured from, ``reach`` [m] ρ·arm, ``horizon`` [s] how far past τ₀ the path is
    searched, ``speed`` [m/s] how fast a hand is taken to move, ``samples`` points on the path. Returns the wrist
    targets (2, 3) (clamped within ``reach``), how far the chosen unclamped target lay beyond the reach (2,) m
    (≤ 0: within it), the chosen times from now (2,) s and how near each hand's wrist target comes to its shoulder
    along the path (2,) m (which hand the flight passes nearest)."""
    end = max(state.lead, min(state.lead + horizon, landing_time(state, radius)))
    times = np.linspace(state.lead, end, samples)
    p, v = ballistic(state.position, state.velocity, times, state.gravity)  # (K, 3)
    near = np.asarray(nearest, dtype=np.float64)[:, None, :]  # (2, 1, 3)
    u = p[None] - near  # (2, K, 3) hand's point → ball's centre
    u /= np.maximum(np.linalg.norm(u, axis=-1, keepdims=True), 1e-9)
    vnorm = np.linalg.norm(v, axis=-1, keepdims=True)
    vhat = np.divide(v, vnorm, out=np.zeros_like(v), where=vnorm > 1e-9)
    sh = np.asarray(shoulder, dtype=np.float64)[:, None, :]
    side = sh[:, 0] - sh[::-1, 0]
    side[:, 2] = 0.0
    side /= np.maximum(np.linalg.norm(side, axis=1, keepdims=True), 1e-9)  # (2, 3) ℓ̂: outward, horizontal
    d = vhat[None] - u + side[:, None, :]  # the ball's side toward where it heads, the hand is, and its own side
    norm = np.linalg.norm(d, axis=-1, keepdims=True)
    d = np.where(norm > 1e-6, d / np.maximum(norm, 1e-12), -u)
    point = p[None] + (radius - press) * d  # (2, K, 3) where the hand's point goes
    wrist = np.asarray(wrist_now, dtype=np.float64)[:, None, :] + (point - near)
    dist = np.linalg.norm(wrist - sh, axis=-1)  # (2, K)
    inside = dist <= reach
    travel = np.linalg.norm(wrist - np.asarray(wrist_now, dtype=np.float64)[:, None, :], axis=-1)
    slack = speed * times[None] - travel  # ≥ 0: the hand can be there before the ball
    in_time = inside & (slack >= 0.0)
    first = np.argmax(in_time, axis=1)  # the earliest in time (samples are in time order)
    least_late = np.argmax(np.where(inside, slack, -np.inf), axis=1)
    pick = np.where(in_time.any(axis=1), first, np.where(inside.any(axis=1), least_late, np.argmin(dist, axis=1)))
    rows = np.arange(2)
    chosen, dchosen = wrist[rows, pick], dist[rows, pick]
    scale = np.minimum(1.0, reach / np.maximum(dchosen, 1e-12))[:, None]
    target = sh[:, 0] + (chosen - sh[:, 0]) * scale
    return target, dchosen - reach, times[pick], dist.min(axis=1)
