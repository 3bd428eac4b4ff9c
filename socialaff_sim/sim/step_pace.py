"""Walk-up steps paced to what the robot's swing leg can follow.

A recorded person moves a foot 0.1–0.3 m in a data frame of a walk-up (up to about 4 m/s); the Unitree H1's swing
leg, under its real torque limits, covers 0.02–0.19 m in the same frames, and the foot lock
(:mod:`~.footlock`) puts the foot down at its target when the recording's foot comes down, wherever the
physical foot is: it lands 11–47 cm short and, loaded, does not slide there (docs/benchmarks.md, "The H1's
outside support in the contact phases, diagnosed …"). :class:`StepPace` gives the foot lock, per data frame,
ankle targets whose horizontal move is capped at ``speed`` / fps per frame: a target that moves farther in a
frame is carried that far toward the recording's target, raised to at least ``height`` above the ankle's home
height (so the lock counts the foot as stepping, not standing), and it keeps being carried in the following frames
until the recording's target is within one frame's move; then it follows the recording again (and comes down
where the recording's foot stands). The robot lags the recording while it walks and catches up when the
recording's feet stand; it reads only the current frame's target (causal). One foot is carried at a time: a
foot whose target moves farther than a frame's move while the other is being carried waits where it is (its
target stays at the last one given, usually a standing foot), and is carried once the other has caught up, so
the robot always has a foot the lock may plant.
"""

from __future__ import annotations

import numpy as np

__all__ = ["StepPace"]


class StepPace:
    """Caps each ankle target's horizontal move per data frame (see the module docstring); :meth:`reset` per
    episode."""

    def __init__(self, speed: float, height: float, fps: float, home_height: np.ndarray) -> None:
        self.step = float(speed) / float(fps)
        """c [m]: the largest horizontal move of an ankle target in one data frame (v_s / fps)."""
        self.height = float(height)
        """h_s [m]: a carried target is at least this far above its ankle's home height."""
        self.home_height = np.asarray(home_height, dtype=np.float64)
        """(2,) left, right ankle height at the robot's home posture, m."""
        self.reset()

    def reset(self) -> None:
        """Nothing given yet: the first targets pass unchanged."""
        self.paced: np.ndarray | None = None
        """(2, 3) the latest frame's ankle targets as given (world, m), or ``None`` before the first."""
        self.carried = [False, False]
        """(left, right): whether each foot's target is being carried behind the recording's."""
        self.lag = np.zeros(2)
        """(2,) m: the paced feet's mean horizontal offset from the recording's (zero while none is held back)."""
        self.carried_frames = 0
        """Frames in which a foot's target was carried (summed over the feet), for the figures."""
        self._base: tuple[np.ndarray | None, list[bool]] = (None, [False, False])

    def __call__(self, ankles: np.ndarray, new_frame: bool = True) -> np.ndarray:
        """(2, 3) world ankle targets (left, right) of the recording, m → the paced targets; ``new_frame``:
        ``False`` for a solve again within a data frame (decided again from the frame's start, not advanced)."""
        raw = np.asarray(ankles, dtype=np.float64)
        if new_frame:
            self._base = (None if self.paced is None else self.paced.copy(), list(self.carried))
        prev, was = self._base
        if prev is None:
            self.paced = raw.copy()
            self.carried = [False, False]
            self.lag = np.zeros(2)
            return raw.copy()
        out = raw.copy()
        gap = np.linalg.norm(raw[:, :2] - prev[:, :2], axis=1)
        far = gap > self.step
        # The foot already being carried keeps the turn (and, once it has caught up, the other waits a frame
        # more, while it is put down); else the one whose target moved farther.
        if was[0] or was[1]:
            s0 = 0 if was[0] else 1
            mover = s0 if far[s0] else None
        else:
            s0 = int(np.argmax(gap))
            mover = s0 if far[s0] else None
        carried = [False, False]
        for s in (0, 1):
            if s == mover:
                out[s, :2] = prev[s, :2] + (raw[s, :2] - prev[s, :2]) * (self.step / gap[s])
                out[s, 2] = max(raw[s, 2], self.home_height[s] + self.height)
                carried[s] = True
            elif far[s] or mover is not None or was[1 - s]:
                out[s] = prev[s]  # waits (does not lift either) while the other foot is carried or put down
        if new_frame:
            self.carried_frames += sum(carried)
        self.paced, self.carried = out.copy(), carried
        self.lag = (out[:, :2] - raw[:, :2]).mean(axis=0)
        return out
