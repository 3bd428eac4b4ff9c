"""Time in a scripted instance: the sub-event :class:`Timeline` and smooth interpolation.

Sub-event boundaries fall on frames, so a keyframe placed at a boundary time is
reached exactly at that frame. Motions between keyframes follow the
minimum-jerk profile 10u³ − 15u⁴ + 6u⁵ (zero velocity and acceleration at both
ends), the classic model of a point-to-point human reach.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicHermiteSpline

from ...errors import ConfigError
from .config import SyntheticConfig

__all__ = ["Timeline", "plan_timeline", "minjerk", "cruise", "ramp", "keyframes", "hermite", "blend"]


@dataclass(frozen=True)
class Timeline:
    """Frame rate and sub-event boundaries of one instance."""

    fps: float
    """Frames per second."""
    bounds: np.ndarray
    """(K + 1,) int64 frame boundaries: sub-event k covers frames ``bounds[k]:bounds[k+1]``."""
    names: tuple[str, ...]
    """K sub-event names in order."""

    @property
    def n_frames(self) -> int:
        """Number of frames T."""
        return int(self.bounds[-1])

    @property
    def t(self) -> np.ndarray:
        """(T,) frame times, seconds from the first frame."""
        return np.arange(self.n_frames) / self.fps

    def start(self, k: int) -> float:
        """Time (s) of the first frame of sub-event ``k``."""
        return float(self.bounds[k]) / self.fps

    def end(self, k: int) -> float:
        """Time (s) of the first frame after sub-event ``k`` (the next one's start)."""
        return float(self.bounds[k + 1]) / self.fps

    def at(self, k: int, fraction: float) -> float:
        """Time (s) at ``fraction`` of the way through sub-event ``k``, snapped to a frame."""
        frame = round(self.bounds[k] + fraction * (self.bounds[k + 1] - self.bounds[k]))
        return frame / self.fps

    def labels(self) -> np.ndarray:
        """(T,) int64 sub-event index of every frame."""
        return np.repeat(np.arange(len(self.names), dtype=np.int64), np.diff(self.bounds))


def plan_timeline(
    names: Sequence[str],
    ranges: Sequence[tuple[float, float]],
    fps: float,
    rng: np.random.Generator,
    config: SyntheticConfig,
    *,
    min_frames: int = 2,
) -> Timeline:
    """Draw sub-event durations and place their boundaries on frames.

    Each sub-event k lasts U(ranges[k]) seconds times one tempo factor per
    instance drawn from ``config.tempo_range``; the total is rescaled into
    ``config.duration_range``. Every sub-event gets at least ``min_frames``
    frames (fewer only if the instance is too short to allow it).
    """
    lo = np.array([r[0] for r in ranges], dtype=np.float64)
    hi = np.array([r[1] for r in ranges], dtype=np.float64)
    tempo = rng.uniform(*config.tempo_range)
    durations = rng.uniform(lo, hi) * tempo
    total = float(durations.sum())
    d_min, d_max = config.duration_range
    total_c = min(max(total, d_min), d_max)
    k = len(names)
    n = round(total_c * fps)
    n = min(max(n, math.ceil(d_min * fps - 1e-9)), math.floor(d_max * fps + 1e-9))
    if n < max(k, 3):
        raise ConfigError(
            f"SyntheticConfig.duration_range: {config.duration_range} s at {fps:.3g} fps gives {n} frames, "
            f"expected at least {max(k, 3)} for {k} sub-events"
        )
    per = max(1, min(min_frames, n // k))
    share = durations / total * n - per
    extra = np.maximum(share, 0.0)
    if extra.sum() <= 0.0:
        extra = np.ones(k)
    extra *= (n - per * k) / extra.sum()
    lengths = per + np.floor(extra).astype(np.int64)
    short = n - int(lengths.sum())
    if short > 0:
        lengths[np.argsort(-(extra - np.floor(extra)), kind="stable")[:short]] += 1
    bounds = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    return Timeline(fps=float(fps), bounds=bounds, names=tuple(names))


def minjerk(u: np.ndarray | float) -> np.ndarray:
    """Minimum-jerk profile of ``u`` clipped to [0, 1]: 0 → 1 with zero end velocities."""
    u = np.clip(np.asarray(u, dtype=np.float64), 0.0, 1.0)
    return u**3 * (10.0 - 15.0 * u + 6.0 * u**2)


def cruise(u: np.ndarray | float, accel: float = 0.3) -> np.ndarray:
    """Progress 0 → 1 over ``u`` in [0, 1] at constant speed except smooth speed-up and slow-down.

    The speed rises along a minimum-jerk profile during the first ``accel``
    fraction of the time, stays at 1/(1 − accel) and falls symmetrically at the
    end (a walk at cruising speed, not the bell-shaped speed of a reach).
    """
    u = np.clip(np.asarray(u, dtype=np.float64), 0.0, 1.0)
    a = float(accel)
    speed = 1.0 / (1.0 - a)

    def rise(v: np.ndarray) -> np.ndarray:  # distance covered while speeding up, ∫ minjerk
        x = np.clip(v / a, 0.0, 1.0)
        return speed * a * x**4 * (2.5 - 3.0 * x + x**2)

    middle = speed * (0.5 * a + (u - a))
    return np.where(u < a, rise(u), np.where(u > 1.0 - a, 1.0 - rise(1.0 - u), middle))


def ramp(t: np.ndarray, t0: float, t1: float) -> np.ndarray:
    """(T,) weight rising 0 → 1 by minimum jerk between times ``t0`` and ``t1`` (a step if t1 ≤ t0)."""
    if t1 <= t0:
        return (t >= t0).astype(np.float64)
    return minjerk((t - t0) / (t1 - t0))


def keyframes(t: np.ndarray, times: Sequence[float], values: Sequence[object]) -> np.ndarray:
    """Minimum-jerk interpolation through keyframes, held constant outside them.

    Args:
        t: (T,) query times, seconds.
        times: K non-decreasing keyframe times, seconds.
        values: K values of equal shape (scalars or arrays).

    Returns:
        (T, *value_shape) float64.
    """
    vals = np.asarray(values, dtype=np.float64)
    out = np.broadcast_to(vals[0], (t.shape[0], *vals.shape[1:])).copy()
    for k in range(1, len(times)):
        w = ramp(t, times[k - 1], times[k])
        out += w.reshape(-1, *([1] * (vals.ndim - 1))) * (vals[k] - vals[k - 1])
    return out


def hermite(
    t: np.ndarray, times: Sequence[float], values: Sequence[object], velocities: Sequence[object]
) -> np.ndarray:
    """Cubic Hermite interpolation with given values and velocities at knots, held outside.

    Args:
        t: (T,) query times, seconds.
        times: K strictly increasing knot times, seconds.
        values: K values (scalars or arrays of one shape).
        velocities: K time derivatives at the knots (same shape as values), per second.

    Returns:
        (T, *value_shape) float64.
    """
    x = np.asarray(times, dtype=np.float64)
    spline = CubicHermiteSpline(x, np.asarray(values, dtype=np.float64), np.asarray(velocities, dtype=np.float64))
    return spline(np.clip(t, x[0], x[-1]))


def blend(a: np.ndarray, b: np.ndarray, w: np.ndarray) -> np.ndarray:
    """(T, ...) ``a + w·(b − a)`` with a (T,) weight broadcast over trailing axes."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    shape = np.broadcast_shapes(a.shape, b.shape)
    return a + w.reshape(-1, *([1] * (len(shape) - 1))) * (b - a)
