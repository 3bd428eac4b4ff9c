"""Touchdown timing: a stepping foot is put down where the IK plans it, not short of it.

The foot lock (:mod:`~.footlock`) plants a foot at its target as soon as the target comes down near the floor.
The recorded walk-up of a person moves a foot 0.2–0.4 m in a data frame; the H1's swing leg does not keep up,
and its foot touches down 25–47 cm short of its target (docs/benchmarks.md, "The H1's outside support in the
contact phases, diagnosed …"). A loaded foot does not slide, so the robot then stands elsewhere than the IK
plans it. :class:`Touchdown` decides, for a foot the lock would put down at a new point q, whether it waits in
the air instead: while its physical ankle frame is farther than ``distance`` (horizontally) from q, its target
is q raised by ``height``, and at most ``stride`` (horizontally) from the physical foot toward q (the foot is
lifted where it stands, then carried: a straight leg reaching for a foothold far ahead drags its toe, which
carries 120–250 N of a robot leaning on it in the harness), and it counts as stepping;
it is put down on q once within ``distance``, after ``frames`` frames of waiting, or when a contact begins
(with ``FootLockConfig.hold_in_contact``). One foot waits at a time, and only while the other stands; a foot
that stands does not lift (the recording's next step is held back) while the other waits, so the robot is
never left without a standing foot by the wait.
"""

from __future__ import annotations

import numpy as np

__all__ = ["Touchdown"]


class Touchdown:
    """Which foot waits in the air to touch down on its planned point (see the module docstring)."""

    def __init__(self, distance: float, height: float, frames: int, stride: float | None = None) -> None:
        self.distance = float(distance)
        """d_t [m]: a foot farther than this from its foothold waits before it is put down."""
        self.height = float(height)
        """h_t [m]: a waiting foot's target is its foothold raised by this."""
        self.frames = int(frames)
        """N_t: at most this many frames of waiting, then the foot is put down on its foothold."""
        self.stride = None if stride is None else float(stride)
        """s_t [m]: a waiting foot's target is at most this far (horizontally) from the physical foot
        (``None``: over the foothold)."""
        self.reset()

    def reset(self) -> None:
        """Nothing waiting."""
        self.waiting = [0, 0]
        """Frames each foot (left, right) has waited so far (0: not waiting)."""
        self.waits = 0
        """Touchdowns delayed in the episode."""
        self.frames_waited = 0
        """Frames spent waiting in the episode (both feet)."""
        self._wait = [False, False]

    def decide(self, landing: list[np.ndarray | None], standing: list[bool], physical: np.ndarray,
               allowed: bool, new_frame: bool) -> list[bool]:
        """Per foot (left, right), whether it waits in the air this frame. ``landing``: the foothold (world, (3,)
        m) a foot would be put down on now (``None``: it is not being put down at a new point); ``standing``:
        whether each foot stands without waiting (planted, or being put down); ``physical`` (2, 3): the physical
        ankle frames (world, m); ``allowed``: whether a foot may wait (``False`` puts every foot down);
        ``new_frame``: ``False`` for a solve again within a data frame (the frame's decision then stands)."""
        if not new_frame:  # the frame's decision stands for a foot still being put down
            return [self._wait[s] and landing[s] is not None for s in (0, 1)]
        err = [np.inf if q is None else float(np.linalg.norm(np.asarray(physical)[s, :2] - q[:2]))
               for s, q in enumerate(landing)]
        far = [s for s in (0, 1) if allowed and landing[s] is not None and err[s] > self.distance
               and self.waiting[s] < self.frames]
        wait = [False, False]
        if far:
            s = max(far, key=lambda i: err[i])
            wait[s] = standing[1 - s]  # only while the other foot carries the robot
        for s in (0, 1):
            self.waits += int(wait[s] and not self.waiting[s])
            self.waiting[s] = self.waiting[s] + 1 if wait[s] else 0
            self.frames_waited += int(wait[s])
        self._wait = wait
        return wait

    def lifted(self, point: np.ndarray, physical: np.ndarray) -> np.ndarray:
        """(3,) the target of a foot waiting to touch down on ``point`` (3,) whose physical ankle frame is at
        ``physical`` (3,): raised by ``height`` above the foothold, and horizontally at most ``stride`` from the
        physical foot toward it (the foot is lifted where it is before it is carried: a leg reaching straight
        for a foothold far ahead drags its toe)."""
        p = np.asarray(point, dtype=np.float64)
        gap = p[:2] - np.asarray(physical, dtype=np.float64)[:2]
        n = float(np.linalg.norm(gap))
        xy = p[:2] if self.stride is None or n <= self.stride else np.asarray(physical)[:2] + gap * (self.stride / n)
        return np.array([xy[0], xy[1], p[2] + self.height])
