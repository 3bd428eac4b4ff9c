"""Where a carried or thrown object is about to be: the anchors the scaler's wrists react to."""

from __future__ import annotations

import numpy as np

__all__ = ["GRAVITY", "LOOKAHEAD_POINTS", "object_anchors"]

LOOKAHEAD_POINTS = 4
"""Points of the object's extrapolated path used as anchors (besides the object itself)."""
GRAVITY = 9.81
"""g, m/s²."""


def object_anchors(track: np.ndarray, t: int, fps: float, lookahead: float) -> np.ndarray:
    """(1 + LOOKAHEAD_POINTS, 3) the object at frame ``t`` of ``track`` (T, 3) and where it is about to be.

    The path is a ballistic extrapolation over ``lookahead`` s from the velocity of frames
    t − 1 → t (causal: nothing after frame t is read). A still or carried object's path stays
    near it; without a previous frame or a lookahead only the object itself is returned.
    """
    here = np.asarray(track[t], dtype=np.float64)
    if t < 1 or lookahead <= 0:
        return here[None]
    v = (here - track[t - 1]) * fps
    s = np.linspace(lookahead / LOOKAHEAD_POINTS, lookahead, LOOKAHEAD_POINTS)[:, None]
    ahead = here + v * s - 0.5 * GRAVITY * s**2 * np.array([0.0, 0.0, 1.0])
    return np.vstack([here[None], ahead])
