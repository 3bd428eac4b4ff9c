"""Object tracks: a ball in free flight and objects carried in a hand.

The object track of an instance is the object's centre, (T, 3) metres. While
held it is rigidly offset from the holder's hand joint; in flight it follows
the closed-form projectile motion under gravity (no drag), which passes through
the release point at the release time and the catching hands at the catch time.
"""

from __future__ import annotations

import numpy as np

__all__ = ["GRAVITY", "BALL_RADIUS", "CUP_RADIUS", "launch_velocity", "ballistic"]

GRAVITY = 9.81
"""g, gravitational acceleration in m/s²."""
BALL_RADIUS = 0.1
"""Radius of the thrown ball in metres (a 20 cm play ball)."""
CUP_RADIUS = 0.045
"""Radius of the handed-over cup in metres; a grasping palm centre sits this far from the cup's axis."""

_G = np.array([0.0, 0.0, -GRAVITY])


def launch_velocity(start: np.ndarray, end: np.ndarray, duration: float) -> np.ndarray:
    """(3,) initial velocity (m/s) of a projectile going from ``start`` to ``end`` (metres) in ``duration`` s."""
    if duration <= 0:
        raise ValueError(f"flight duration must be > 0 s, found {duration}")
    return (np.asarray(end) - np.asarray(start) - 0.5 * _G * duration**2) / duration


def ballistic(t: np.ndarray, t_release: float, t_catch: float, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """(T, 3) projectile positions at times ``t`` (s), from ``start`` at ``t_release`` to ``end`` at ``t_catch``.

    Positions are ``start + v0·s + ½·g·s²`` with ``s = t − t_release``, also
    outside the flight (callers keep only the frames they need).
    """
    v0 = launch_velocity(start, end, t_catch - t_release)
    s = (t - t_release)[:, None]
    return np.asarray(start) + v0 * s + 0.5 * _G * s**2
