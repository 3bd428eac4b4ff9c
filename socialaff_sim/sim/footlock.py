"""Planting the robot's feet: an ankle target that barely moves near the floor is held still on it.

A recorded person's ankles wander by a centimetre or two while they stand (the
skeleton tracker's noise, small shifts of weight), and the human-to-robot
scaling passes this on. A robot standing on its own feet cannot follow it: a
foot that rises by a centimetre drops the robot's weight onto the other one or
onto its harness, and one that moves sideways on the floor slides. :class:`FootLock`
holds an ankle target at the place where its foot came down (on the floor, at
the robot's home ankle height) while the target stays within ``radius`` of that
place and below ``lift`` above home height (``hold_lift``, when set, for a foot already planted); a
target that leaves that ball (a step) is followed again.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError

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

    def __post_init__(self) -> None:
        if not (self.lift >= 0.0 and self.radius >= 0.0):
            raise ConfigError(f"FootLockConfig: expected lift ≥ 0 and radius ≥ 0 in metres, found {self.lift}, {self.radius}")
        if self.hold_lift is not None and not self.hold_lift >= self.lift:
            raise ConfigError(f"FootLockConfig.hold_lift: expected None or a height ≥ lift ({self.lift} m), found "
                              f"{self.hold_lift}")


class FootLock:
    """Holds standing ankle targets still (see the module docstring); :meth:`reset` per episode."""

    def __init__(self, home_height: tuple[float, float], config: FootLockConfig | None = None) -> None:
        self.home_height = np.asarray(home_height, dtype=np.float64)
        """(2,) left, right ankle height at the robot's home posture, m."""
        self.config = config or FootLockConfig()
        self.planted: list[np.ndarray | None] = [None, None]
        """Where each foot is planted (world, (3,) m), or ``None`` while it steps."""

    def reset(self) -> None:
        """No foot planted."""
        self.planted = [None, None]

    def apply(self, ankles: np.ndarray, touching: bool = False) -> np.ndarray:
        """(2, 3) world ankle targets (left, right), m → the same with standing feet held where they were planted;
        ``touching``: a sub-goal's contact holds (with ``hold_in_contact``, planted feet then stay planted)."""
        out = np.array(ankles, dtype=np.float64)
        c = self.config
        if touching and c.hold_in_contact and all(p is not None for p in self.planted):
            return np.array([np.array(p) for p in self.planted])
        hold = c.lift if c.hold_lift is None else c.hold_lift
        for s in (0, 1):
            t = out[s]
            rise = t[2] - self.home_height[s]
            low = rise <= c.lift
            p = self.planted[s]
            if rise <= hold and p is not None and np.linalg.norm(t[:2] - p[:2]) <= c.radius:
                out[s] = p
            elif low:
                self.planted[s] = np.array([t[0], t[1], self.home_height[s]])
                out[s] = self.planted[s]
            else:
                self.planted[s] = None
        return out
