"""The base's approach to a captured contact its plan cannot reach: a bounded shift of the placement's base target.

The contact completion (:mod:`~socialaff_sim.retarget.contact_completion`) moves a wrist target onto a contact the
task wants; where that target lies beyond the arm's length from the plan's shoulder, an IK that keeps its base on
the placement's target leaves the wrist short (the Unitree H1, whose spine turns about the vertical only, stands a
few centimetres too far from a handshake: docs/design.md §5, "The H1 on its own feet …"). With
``ContactCompletionConfig.base_approach`` = c_a this stage moves the base target horizontally toward such a target.

For each hand s whose completion weight β_s is above zero (a contact the completion has captured, ramping in or out),
with completed wrist target w_s and the plan's shoulder p_s (the base target plus the robot's home shoulder offset,
both turned by the robot frame; world frame), the horizontal shift that brings w_s back to the arm's length ℓ is

    h_s = r_s − sqrt(ℓ² − z_s²)   (|z_s| < ℓ),   h_s = r_s   otherwise,

r_s the horizontal and z_s the vertical distance from p_s to w_s; it is zero when w_s lies within ℓ (h_s ≤ 0). The
wanted shift is the largest h_s, capped at c_a, along the horizontal unit vector from p_s to w_s; the applied shift
moves toward it by at most c_a·Δt / τ_a per frame (``base_approach_ramp`` = τ_a), so it ramps in over the frames a
contact is captured and back out to zero after. Only the base target moves: the wrists stay on the contact and the
feet stay where the foot lock planted them. Every input is of frame t or earlier (causal).
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError

__all__ = ["BaseApproach", "horizontal_excess", "wanted_shift"]


def horizontal_excess(wrist: np.ndarray, shoulder: np.ndarray, arm: float) -> np.ndarray:
    """(N,) metres the shoulders (N, 3) must move horizontally toward the wrists (N, 3) (world frame, z up) to bring
    each wrist to ``arm`` metres from its shoulder; ≤ 0 where the wrist is within ``arm`` already (the shoulder could
    move back that far). A wrist ``arm`` or more above or below its shoulder needs its whole horizontal distance."""
    d = np.asarray(wrist, dtype=np.float64) - np.asarray(shoulder, dtype=np.float64)
    r = np.linalg.norm(d[..., :2], axis=-1)
    z2 = d[..., 2] ** 2
    return r - np.sqrt(np.maximum(arm * arm - z2, 0.0))


def wanted_shift(wrist: np.ndarray, shoulder: np.ndarray, arm: float, captured: np.ndarray, cap: float) -> np.ndarray:
    """(2,) the horizontal shift (world frame, metres) of the base target toward the captured hands' wrist targets
    beyond reach: ``wrist`` (2, 3) the completed wrist targets, ``shoulder`` (2, 3) the plan's shoulders, ``captured``
    (2,) bool; the largest excess (:func:`horizontal_excess`) of a captured hand, at most ``cap``, along that hand's
    horizontal direction from its shoulder; zero when no captured hand is beyond reach."""
    wrist = np.asarray(wrist, dtype=np.float64)
    shoulder = np.asarray(shoulder, dtype=np.float64)
    excess = np.where(np.asarray(captured, dtype=bool), horizontal_excess(wrist, shoulder, arm), -np.inf)
    s = int(np.argmax(excess))
    if not excess[s] > 0.0:
        return np.zeros(2)
    toward = wrist[s, :2] - shoulder[s, :2]
    n = float(np.linalg.norm(toward))
    if n < 1e-9:
        return np.zeros(2)
    return toward / n * min(float(excess[s]), cap)


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

    def __call__(self, wrist: np.ndarray, shoulder: np.ndarray, arm: float, captured: np.ndarray, frame: int,
                 dt: float) -> np.ndarray:
        """(2,) the shift of ``frame`` (data frames of ``dt`` s): toward :func:`wanted_shift` by at most
        c_a·Δt/τ_a per frame (a frame asked again is recomputed from the same shift before it)."""
        if self._frame is not None and frame == self._frame:
            base, frames = self._before, 1
        elif self._frame is not None and frame > self._frame:
            base, frames = self.shift, frame - self._frame
        else:
            base, frames = np.zeros(2), 1
        self._before = base.copy()
        self._frame = frame
        want = wanted_shift(wrist, shoulder, arm, captured, self.cap)
        move = want - base
        step = np.inf if self.ramp == 0 else self.cap * frames * dt / self.ramp
        n = float(np.linalg.norm(move))
        self.shift = want if n <= step else base + move * (step / n)
        return self.shift.copy()
