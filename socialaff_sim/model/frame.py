"""The canonical interaction frame, in which the model's angles are measured.

Each instance is expressed in a frame fixed at its first frame: the origin is
agent 0's base joint projected to the floor (z = 0 of the world), the x axis
points horizontally from agent 0's base toward agent 1's base, and z points up
(the world's z). y completes a right-handed frame, so agent 1 stands near
(d, 0) and angles are measured counter-clockwise from the line between the two
agents. Online synthesis, which sees only the first frames of both agents,
can therefore build the same frame. When the two bases coincide horizontally
(closer than 1 mm) the world x axis is used instead.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..errors import DataError

__all__ = ["CanonicalFrame", "canonical_frame"]


@dataclass(frozen=True)
class CanonicalFrame:
    """A rotation about z plus a horizontal translation (world ↔ canonical)."""

    origin: np.ndarray
    """(3,) float64, metres: the canonical origin in world coordinates (z = 0)."""
    heading: float
    """Angle of the canonical x axis in the world x-y plane, radians (counter-clockwise from world x)."""

    # The generated __eq__ would compare the origin arrays' truth (an error) and the generated __hash__ would hash
    # an array (another): two frames are equal when their origins are elementwise equal and their headings are.
    def __eq__(self, other: object) -> bool:
        if not isinstance(other, CanonicalFrame):
            return NotImplemented
        return bool(np.array_equal(self.origin, other.origin)) and float(self.heading) == float(other.heading)

    def __hash__(self) -> int:
        return hash((tuple(float(v) for v in np.ravel(self.origin)), float(self.heading)))

    @cached_property
    def rotation(self) -> np.ndarray:
        """(3, 3) float64, read-only: columns are the canonical axes expressed in the world frame (computed once: a
        stream converts a few points at every frame)."""
        c, s = np.cos(self.heading), np.sin(self.heading)
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        rot.setflags(write=False)
        return rot

    def to_canonical(self, points: np.ndarray) -> np.ndarray:
        """World points ``(..., 3)`` metres → canonical ``(..., 3)`` metres (NaN stays NaN)."""
        p = np.asarray(points, float) - self.origin
        return p @ self.rotation

    def to_world(self, points: np.ndarray) -> np.ndarray:
        """Canonical points ``(..., 3)`` metres → world ``(..., 3)`` metres."""
        return np.asarray(points, float) @ self.rotation.T + self.origin

    def vectors_to_world(self, vectors: np.ndarray) -> np.ndarray:
        """Rotate displacement vectors ``(..., 3)`` from canonical to world (no translation)."""
        return np.asarray(vectors, float) @ self.rotation.T


def canonical_frame(base0: np.ndarray, base1: np.ndarray) -> CanonicalFrame:
    """The frame from agent 0's and agent 1's base positions ``(3,)`` at an instance's first frame."""
    b0 = np.asarray(base0, float)
    b1 = np.asarray(base1, float)
    if b0.shape != (3,) or b1.shape != (3,) or not (np.isfinite(b0).all() and np.isfinite(b1).all()):
        raise DataError(f"canonical frame: expected two finite base positions of shape (3,), found {b0} and {b1}")
    d = b1[:2] - b0[:2]
    heading = float(np.arctan2(d[1], d[0])) if np.hypot(*d) > 1e-3 else 0.0
    return CanonicalFrame(origin=np.array([b0[0], b0[1], 0.0]), heading=heading)
