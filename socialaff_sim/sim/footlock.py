"""Planting the robot's feet: an ankle target that barely moves near the floor is held still on it.

A recorded person's ankles wander by a centimetre or two while they stand (the
skeleton tracker's noise, small shifts of weight), and the human-to-robot
scaling passes this on. A robot standing on its own feet cannot follow it: a
foot that rises by a centimetre drops the robot's weight onto the other one or
onto its harness, and one that moves sideways on the floor slides. :class:`FootLock`
holds an ankle target at the place where its foot came down (on the floor, at
the robot's home ankle height) while the target stays within ``radius`` of that
place and below ``lift`` above home height (``hold_lift``, when set, for a foot already planted); a
target that leaves that ball (a step) is followed again. With ``pace`` the targets' walk-up steps are first slowed to a
pace the swing leg follows (:mod:`~.step_pace`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError
from .step_pace import StepPace

__all__ = ["FootLock", "FootLockConfig"]


@dataclass(frozen=True)
class FootLockConfig:
    """When an ankle target counts as standing."""

    lift: float = 0.04
    """h_lift [m]: a target at most this far above the ankle's home height may be planted."""
    radius: float = 0.05
    """r [m]: a planted foot stays put while its target stays within this horizontal distance of where it was
    planted; beyond, the foot steps (the target is followed again)."""
    hold_lift: float | None = None
    """h_hold [m]: a foot already planted stays planted while its target is at most this far above the ankle's
    home height (and within ``radius``): a recorded heel or toe rise of a person leaning into a pull is not a
    step. ``None``: ``lift`` (no hysteresis). At least ``lift``."""
    hold_in_contact: bool = False
    """[—]: While a sub-goal's contact held at the end of the last frame (the robot holds the person's hand), a
    foot planted stays planted wherever its target goes: the robot does not step while it holds on (the recorded
    helper of a pull-up steps back to keep the arms taut; a robot whose hands give way,
    ``BalanceConfig.hand_yield``, needs no step). ``False``: the targets decide as at any other time."""

    pace: float | None = None
    """v_s [m/s]: an ankle target moves at most v_s / fps (horizontally) per data frame; one that the recording
    moves farther is carried at that pace, raised by at least ``pace_height``, one foot at a time, until it has
    caught up (:mod:`~.step_pace`). ``None``: the recording's targets as they are (the H1's swing leg does not
    keep up with a recorded walk-up: docs/benchmarks.md, "The H1's outside support in the contact phases,
    diagnosed …")."""
    pace_base: bool = False
    """[—]: With ``pace``, the base's target is held back with the feet: moved by the paced feet's mean horizontal
    offset from the recording's (``False``: the base follows the recording while the feet lag, and the IK reaches
    for it over feet held back, up to a metre in a pull-up)."""
    pace_height: float = 0.08
    """h_s [m]: a carried ankle target is at least this far above the ankle's home height (above ``lift``, so
    that the foot counts as stepping)."""

    def __post_init__(self) -> None:
        if self.pace is not None and not (self.pace > 0.0 and self.pace_height > self.lift):
            raise ConfigError(f"FootLockConfig: expected pace None or > 0 m/s and pace_height > lift ({self.lift} m), "
                              f"found {self.pace}, {self.pace_height}")
        if not (self.lift >= 0.0 and self.radius >= 0.0):
            raise ConfigError(f"FootLockConfig: expected lift ≥ 0 and radius ≥ 0 in metres, found {self.lift}, {self.radius}")
        if self.hold_lift is not None and not self.hold_lift >= self.lift:
            raise ConfigError(f"FootLockConfig.hold_lift: expected None or a height ≥ lift ({self.lift} m), found "
                              f"{self.hold_lift}")


class FootLock:
    """Holds standing ankle targets still (see the module docstring); :meth:`reset` per episode."""

    def __init__(self, home_height: tuple[float, float], config: FootLockConfig | None = None,
                 fps: float | None = None) -> None:
        self.home_height = np.asarray(home_height, dtype=np.float64)
        """(2,) left, right ankle height at the robot's home posture, m."""
        self.config = config or FootLockConfig()
        self.planted: list[np.ndarray | None] = [None, None]
        """Where each foot is planted (world, (3,) m), or ``None`` while it steps."""
        c = self.config
        if c.pace is not None and not (fps is not None and fps > 0.0):
            raise ConfigError(f"FootLockConfig.pace: needs the data's frame rate (fps > 0), found {fps}")
        self.pace = None if c.pace is None else StepPace(c.pace, c.pace_height, fps, self.home_height)  # type: ignore[arg-type]
        """The walk-up's pace (``pace``), else ``None``."""

    def reset(self) -> None:
        """No foot planted."""
        self.planted = [None, None]
        if self.pace is not None:
            self.pace.reset()

    @property
    def standing(self) -> tuple[bool, bool]:
        """(left, right): whether each foot stands (is planted)."""
        return (self.planted[0] is not None, self.planted[1] is not None)

    def apply(self, ankles: np.ndarray, touching: bool = False, new_frame: bool = True) -> np.ndarray:
        """(2, 3) world ankle targets (left, right), m → the same with standing feet held where they were planted;
        ``touching``: a sub-goal's contact holds (with ``hold_in_contact``, planted feet then stay planted);
        ``new_frame``: ``False`` for a solve again within a data frame (``pace`` then keeps the frame's decision)."""
        out = np.array(ankles, dtype=np.float64) if self.pace is None else self.pace(ankles, new_frame)
        c = self.config
        if touching and c.hold_in_contact and all(p is not None for p in self.planted):
            return np.array([np.array(p) for p in self.planted])
        hold = c.lift if c.hold_lift is None else c.hold_lift
        for s in (0, 1):
            t = out[s]
            rise = t[2] - self.home_height[s]
            p = self.planted[s]
            if p is not None and rise <= hold and np.linalg.norm(t[:2] - p[:2]) <= c.radius:
                out[s] = p  # stands
            elif rise <= c.lift:
                self.planted[s] = np.array([t[0], t[1], self.home_height[s]])
                out[s] = self.planted[s]
            else:
                self.planted[s] = None
        return out
