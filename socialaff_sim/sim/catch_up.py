"""Catch-up steps: a planted foot that is not where the IK plans it steps there.

The foot lock (:mod:`~.footlock`) plants a foot at its target, and the IK plans the robot standing on that
point. A robot whose physical foot did not get there (the H1's steps in a walk-up fall short by 10–45 cm:
the recorded foot moves 0.3–0.4 m in a data frame, its servos lag, and a loaded foot does not slide) then
stands elsewhere than planned: its legs strain toward feet it does not have, its centre of mass is not where
the balance controller's reference carries it over the feet, and the harness holds it. :class:`CatchUp`
decides, once per data frame, which foot steps to its planted point: while both feet are planted (and no
contact holds, with ``FootLockConfig.hold_in_contact``), the foot farther than ``catch_up`` (horizontally)
from its point is lifted: its target for the frame is its point raised by ``catch_up_height``, and it counts
as stepping (not planted). It is put down on its point once it is within half of ``catch_up`` of it, or after
``catch_up_frames`` frames lifted. One foot at a time, and not in the frame after a foot was put down (the
weight goes back onto it first).
"""

from __future__ import annotations

import numpy as np

__all__ = ["CatchUp"]


class CatchUp:
    """Which planted foot is lifted to step onto its planted point (see the module docstring)."""

    def __init__(self, distance: float, height: float, frames: int) -> None:
        self.distance = float(distance)
        """d_c [m]: a planted foot farther than this from its point steps there."""
        self.height = float(height)
        """h_c [m]: how far above its point a lifted foot's target is."""
        self.frames = int(frames)
        """N_c: at most this many frames lifted before it is put down."""
        self.reset()

    def reset(self) -> None:
        """Nothing lifted."""
        self.lifted = [0, 0]
        """Frames each foot (left, right) has been lifted for (0: down)."""
        self._rest = 0
        self.steps = 0
        """Catch-up steps begun in the episode."""

    def update(self, planted: list[np.ndarray | None], physical: np.ndarray, allowed: bool) -> None:
        """One data frame: ``planted`` the feet's planted points (world, (3,) m, ``None``: stepping),
        ``physical`` (2, 3) the physical ankle frames (world, m); ``allowed``: whether a new step may begin
        (``False`` also puts a lifted foot down)."""
        err = [np.inf if p is None else float(np.linalg.norm(np.asarray(physical)[s, :2] - p[:2]))
               for s, p in enumerate(planted)]
        for s in (0, 1):
            if not self.lifted[s]:
                continue
            if not allowed or planted[s] is None or err[s] <= 0.5 * self.distance or self.lifted[s] >= self.frames:
                self.lifted[s] = 0
                self._rest = 1
            else:
                self.lifted[s] += 1
        if any(self.lifted) or not allowed or self._rest:
            self._rest = 0
            return
        far = [s for s in (0, 1) if planted[0] is not None and planted[1] is not None and err[s] > self.distance]
        if far:
            self.lifted[max(far, key=lambda s: err[s])] = 1
            self.steps += 1

    def targets(self, planted: list[np.ndarray | None], out: np.ndarray) -> np.ndarray:
        """(2, 3) the ankle targets ``out`` (2, 3) with each lifted foot's replaced by its point raised by
        ``height``."""
        out = np.array(out, dtype=np.float64)
        for s in (0, 1):
            if self.lifted[s] and planted[s] is not None:
                out[s] = np.asarray(planted[s]) + np.array([0.0, 0.0, self.height])
        return out
