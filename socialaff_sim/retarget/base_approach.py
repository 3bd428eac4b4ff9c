"""The base's approach to a captured contact its plan cannot reach: a bounded shift of the placement's base target.

The contact completion (:mod:`~socialaff_sim.retarget.contact_completion`) moves a wrist target onto a contact the
task wants; where that target lies beyond the arm's length from the plan's shoulder, an IK that keeps its base on
the placement's target leaves the wrist short (the Unitree H1, whose spine turns about the vertical only, stands a
few centimetres too far from a handshake: docs/design.md §5, "The H1 on its own feet …"). With
``ContactCompletionConfig.base_approach`` = c_a this stage moves the base target horizontally toward such a target.

For each hand s whose completion weight β_s is above zero (a contact the completion has captured, ramping in or out),
with completed wrist target w_s and the shoulder p_s where the IK's last solution put it (world frame: the IK
solved the frame before with the base target moved by the shift a_{t−1}; its spine's yaw and its hips' give are in
that shoulder, which the robot's home shoulder offset from the base target is not), the horizontal move of that
shoulder that brings w_s back to the arm's length ℓ is

    h_s = r_s − sqrt(ℓ² − z_s²)   (|z_s| < ℓ),   h_s = r_s   otherwise,

r_s the horizontal and z_s the vertical distance from p_s to w_s; negative where w_s lies within ℓ (the shoulder
could move back by −h_s). The wanted shift is the last one plus the residual of the captured hand that needs the
most, along the horizontal unit vector u_s from p_s to w_s: a* = a_{t−1} + h_s u_s, its length capped at c_a, and
zero where a residual moving back would carry it past zero (a*·a_{t−1} ≤ 0) or no hand is captured. The applied
shift moves toward it by at most c_a·Δt / τ_a per frame (``base_approach_ramp`` = τ_a), so it ramps in over the
frames a contact is captured and back out to zero after. Only the base target moves: the wrists stay on the contact
and the feet stay where the foot lock planted them. Every input is of frame t or earlier (causal: the IK's solution
is the frame before's).
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError

__all__ = ["BaseApproach", "horizontal_excess", "residual_shift"]


def horizontal_excess(wrist: np.ndarray, shoulder: np.ndarray, arm: float) -> np.ndarray:
    """(N,) metres the shoulders (N, 3) must move horizontally toward the wrists (N, 3) (world frame, z up) to bring
    each wrist to ``arm`` metres from its shoulder; ≤ 0 where the wrist is within ``arm`` already (the shoulder could
    move back that far). A wrist ``arm`` or more above or below its shoulder needs its whole horizontal distance."""
    d = np.asarray(wrist, dtype=np.float64) - np.asarray(shoulder, dtype=np.float64)
    r = np.linalg.norm(d[..., :2], axis=-1)
    z2 = d[..., 2] ** 2
    return r - np.sqrt(np.maximum(arm * arm - z2, 0.0))


def residual_shift(wrist: np.ndarray, solved: np.ndarray, arm: float, captured: np.ndarray, before: np.ndarray,
                   cap: float) -> np.ndarray:
    """(2,) the horizontal shift (world frame, metres) of the base target wanted now: ``before`` (2,), the shift the IK
    last solved with, plus the residual :func:`horizontal_excess` h of the captured hand (``captured`` (2,) bool) that
    needs the most, measured from ``solved`` (2, 3), the shoulders of that solution, to ``wrist`` (2, 3), the
    completed wrist targets, along that hand's horizontal direction from its shoulder; its length at most ``cap``;
    zero without a captured hand, or where a residual moving back (h < 0) would carry it past zero."""
    wrist = np.asarray(wrist, dtype=np.float64)
    solved = np.asarray(solved, dtype=np.float64)
    before = np.asarray(before, dtype=np.float64)
    captured = np.asarray(captured, dtype=bool)
    if not captured.any():
        return np.zeros(2)
    excess = np.where(captured, horizontal_excess(wrist, solved, arm), -np.inf)
    s = int(np.argmax(excess))
    toward = wrist[s, :2] - solved[s, :2]
    n = float(np.linalg.norm(toward))
    if n < 1e-9:
        return before.copy()
    want = before + toward / n * float(excess[s])
    if excess[s] < 0.0 and not float(want @ before) > 0.0:
        return np.zeros(2)
    length = float(np.linalg.norm(want))
    return want if length <= cap else want * (cap / length)


class BaseApproach:
    """The shift of one episode (see the module docstring): :meth:`reset` at its start, :meth:`__call__` per frame in
    order. ``cap`` c_a (m) and ``ramp`` τ_a (s; 0: at once)."""

    def __init__(self, cap: float, ramp: float) -> None:
        if not cap > 0.0:
            raise ConfigError(f"ContactCompletionConfig.base_approach: expected metres > 0 or None, found {cap}")
        if not ramp >= 0.0:
            raise ConfigError(f"ContactCompletionConfig.base_approach_ramp: expected seconds ≥ 0, found {ramp}")
        self.cap, self.ramp = float(cap), float(ramp)
        self.reset()

    def reset(self) -> None:
        """No shift (a new episode starts on its placement)."""
        self._frame: int | None = None
        self._before = np.zeros(2)
        self.shift = np.zeros(2)
        """(2,) the horizontal shift of the last frame, world frame, metres."""

    def __call__(self, wrist: np.ndarray, solved: np.ndarray, arm: float, captured: np.ndarray, frame: int,
                 dt: float) -> np.ndarray:
        """(2,) the shift of ``frame`` (data frames of ``dt`` s): toward :func:`residual_shift` (``solved`` (2, 3): the
        shoulders of the IK's last solution, world) by at most c_a·Δt/τ_a per frame (a frame asked again is
        recomputed from the same shift before it)."""
        if self._frame is not None and frame == self._frame:
            base, frames = self._before, 1
        elif self._frame is not None and frame > self._frame:
            base, frames = self.shift, frame - self._frame
        else:
            base, frames = np.zeros(2), 1
        self._before = base.copy()
        self._frame = frame
        want = residual_shift(wrist, solved, arm, captured, base, self.cap)
        move = want - base
        step = np.inf if self.ramp == 0 else self.cap * frames * dt / self.ramp
        n = float(np.linalg.norm(move))
        self.shift = want if n <= step else base + move * (step / n)
        return self.shift.copy()
