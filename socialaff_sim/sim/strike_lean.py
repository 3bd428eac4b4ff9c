"""The plan's trunk leaned into an upward reach: how far the IK's base target pitches forward.

A person striking a high five leans 11–13° into it; the retargeting plan's trunk stays upright (its base
orientation is the home one turned to face the partner, the spine held at home), so in the standing mode the
balance controller's torso rows hold the trunk upright while the striking arm's reaction tips it back (traced on
Stubby's high fives, docs/design.md §5). With ``StanceConfig.strike_lean`` k_l the plan leans its base forward,
about the heading's lateral axis, by

    θ = min(θ_max, k_l · max_i max(0, (w_i − s_i) · x))   over the arms i whose wrist target stands at least h_l
    above that arm's shoulder ((w_i − s_i) · z ≥ h_l),

w_i the wrist target and s_i the shoulder at its home offset from the base target, both in the robot's frame (x its
heading toward the partner, z up): the farther the raised wrist reaches ahead of its shoulder, the more the trunk
leans, at most θ_max (the issue's rule: the torso within 10° of upright unless the motion calls for a lean). A reach
at or below the shoulder (a handshake, a hand over, a pull-up's grasp) or behind it leans nothing.

With ``StanceConfig.strike_lean_out`` N the lean is ramped out once every contact sub-goal of the task has been met
(the hands have met): n frames after the meeting the plan leans θ · max(0, 1 − n/N) (:func:`lean_out`), so that the
leaned plan stops pressing the person after the meeting instead of holding the lean to the episode's end.
"""

from __future__ import annotations

import numpy as np

from .sim_config import StepResult
from .stance import StanceConfig

__all__ = ["PlanLean", "lean_out", "strike_lean"]


def strike_lean(targets: np.ndarray, shoulders: np.ndarray, gain: float, most: float, raised: float) -> float:
    """The plan's forward lean θ (radians, ≥ 0) for robot-frame key-frame ``targets`` (5, 3) (base, left wrist,
    right wrist, left ankle, right ankle; metres) and the shoulders' home offsets from the base ``shoulders`` (2, 3)
    (left, right; metres, robot frame): ``gain`` k_l (degrees per metre of the raised wrist's reach ahead of its
    shoulder), ``most`` θ_max (degrees), ``raised`` h_l (metres, the wrist's least height above its shoulder).
    A wrist target that is not finite leans nothing."""
    t = np.asarray(targets, dtype=np.float64)
    s = t[0] + np.asarray(shoulders, dtype=np.float64)  # (2, 3) the shoulders, robot frame
    d = t[1:3] - s  # (2, 3) each wrist target from its shoulder
    ok = np.isfinite(d).all(axis=1) & (d[:, 2] >= raised)
    if not ok.any():
        return 0.0
    ahead = float(np.max(np.where(ok, d[:, 0], 0.0)))
    return float(np.radians(min(most, gain * max(0.0, ahead))))


def lean_out(lean: float, since: int | None, frames: int | None) -> float:
    """The lean ``lean`` (radians) ramped out ``since`` frames (≥ 0) after the task's sub-goals were all met, over
    ``frames`` N frames: θ · max(0, 1 − since/N); ``since`` ``None`` (not met yet) or ``frames`` ``None`` (the option
    off): the lean as given; N ≤ 0 drops it at the meeting."""
    if since is None or frames is None:
        return float(lean)
    if frames <= 0:
        return 0.0
    return float(lean) * max(0.0, 1.0 - max(0, since) / frames)


class PlanLean:
    """The plan's lean through one episode (``StanceConfig.strike_lean`` and its options): :func:`strike_lean` of each
    frame's targets, only in a task with a contact counted above the shoulders (``counts_above``,
    ``TaskSpec.counts_above``) when ``strike_lean_above`` says so,
    ramped out after the task's sub-goals are all met (``strike_lean_out``, :func:`lean_out`) or ended for the rest of
    the episode once the harness holds the robot caught after that meeting (``strike_lean_caught``)."""

    def __init__(self, config: StanceConfig | None, counts_above: bool, roll_freed: bool = False) -> None:
        self.config = config
        self.active = config is not None and config.strike_lean is not None and (
            not config.strike_lean_above or counts_above)
        """Whether this episode leans at all."""
        self.most = 0.0 if config is None else (config.strike_lean_max_roll_free if roll_freed and (
            config.strike_lean_max_roll_free is not None) else config.strike_lean_max)
        """[deg] The largest lean: ``strike_lean_max_roll_free`` on a robot whose feet's roll is freed
        (``roll_freed``) where set, else ``strike_lean_max``."""
        fall = None if config is None else config.strike_lean_fall_roll_free
        self.fall = float(np.radians(fall)) if roll_freed and fall is not None else None
        """[rad/frame] ``strike_lean_fall_roll_free`` where it acts (a robot whose feet's roll is freed), else
        ``None``: the most the lean falls from one data frame to the next (:meth:`limit`)."""
        self._last: tuple[int, float] | None = None  # (frame, lean) of the last frame before the one being solved
        self._now: tuple[int, float] | None = None  # (frame, lean) of the latest call
        self.met: int | None = None
        """The frame by which every sub-goal was met (``None``: not yet)."""
        self.dropped = False
        """Whether ``strike_lean_caught`` has ended the lean."""

    def frame(self, targets: np.ndarray, shoulders: np.ndarray, last: StepResult | None, caught: bool,
              t: int) -> float:
        """The lean θ (radians, ≥ 0) for frame ``t``'s robot-frame key-frame ``targets`` (5, 3) m and the shoulders'
        home offsets ``shoulders`` (2, 3) m, given the last frame's result ``last`` and whether the harness holds the
        robot caught (``caught``)."""
        return self.limit(self._frame(targets, shoulders, last, caught, t), t)

    def limit(self, lean: float, t: int) -> float:
        """Frame ``t``'s lean ``lean`` (radians) falling at most :attr:`fall` per frame from the last earlier frame's
        (a solve again within frame ``t`` is limited from the same earlier frame); without :attr:`fall` as given."""
        if self.fall is None:
            return lean
        if self._now is not None and self._now[0] != t:
            self._last = self._now
        if self._last is not None:
            lean = max(lean, self._last[1] - self.fall * max(t - self._last[0], 0))
        self._now = (t, lean)
        return lean

    def _frame(self, targets: np.ndarray, shoulders: np.ndarray, last: StepResult | None, caught: bool,
               t: int) -> float:
        c = self.config
        if not self.active or c is None:
            return 0.0
        lean = strike_lean(targets, shoulders, c.strike_lean, self.most, c.strike_lean_raised)  # type: ignore[arg-type]
        if c.strike_lean_out is None and not c.strike_lean_caught:
            return lean
        if self.met is None and last is not None and last.subgoals and all(last.subgoals.values()):
            self.met = last.frame
        self.dropped = self.dropped or (c.strike_lean_caught and self.met is not None and caught)
        return 0.0 if self.dropped else lean_out(lean, None if self.met is None else t - self.met, c.strike_lean_out)
