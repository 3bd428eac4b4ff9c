"""The balance controller's torques solved at a lower rate than the physics, held in between (an option).

With ``BalanceConfig.qp_every`` = k > 1 the controller solves its torques (the whole inverse-dynamics problem:
the tasks, the contact forces, the quadratic program) at one driven physics step in k; on the k − 1 steps after
it the actuators get the solved torques τ_s again, corrected by a joint-space PD on what has changed since:

    τ = τ_s + g_h · M_ii · (ω_q² (e − e_s) + 2 ω_q (ė − ė_s)),   e = q_ref − q,  ė = q̇_ref − q̇  (each hinge),

M_ii the joint's diagonal of the mass matrix at the solve, ω_q the joints' bandwidth (``joint_bandwidth``), g_h
``hold_gain`` (0: the torques held as they are). The hold ends early, and the next driven step solves again, when
the harness is switched (released or caught) or a step is not driven by the controller; and nothing is held after
a solve in which an arm came within ``hold_near`` of the body (a self-clearance pair's distance: only a solve keeps
the arms clear).
"""

from __future__ import annotations

import numpy as np

__all__ = ["TorqueHold"]


class TorqueHold:
    """Solved torques held for ``every`` − 1 driven physics steps after each solve (see the module docstring)."""

    def __init__(self, every: int, gain: float, bandwidth: float) -> None:
        self.every, self.gain, self.bandwidth = int(every), float(gain), float(bandwidth)
        self.reset()

    def reset(self) -> None:
        """Nothing held: the next driven step solves."""
        self._left = 0
        self._released = False
        self._tau = self._e = self._ed = self._kp = self._kd = np.zeros(0)

    def due(self, released: bool) -> bool:
        """Whether this driven step must solve: the hold is spent, or the harness was switched since the solve."""
        return self._left <= 0 or released != self._released

    def store(self, tau: np.ndarray, inertia: np.ndarray, e: np.ndarray, ed: np.ndarray, released: bool) -> None:
        """A solve's torques ``tau`` (n_act,), the joints' diagonal inertias ``inertia`` (n_act,), their position and
        velocity errors ``e``, ``ed`` (n_act,) at the solve, and whether the robot was released."""
        w = self.bandwidth
        self._tau, self._e, self._ed = tau.copy(), e.copy(), ed.copy()
        self._kp, self._kd = self.gain * w * w * inertia, self.gain * 2.0 * w * inertia
        self._left, self._released = self.every - 1, released

    def torques(self, e: np.ndarray, ed: np.ndarray) -> np.ndarray:
        """The held torques (n_act,) at errors ``e``, ``ed`` (n_act,); one step of the hold spent."""
        self._left -= 1
        return self._tau + self._kp * (e - self._e) + self._kd * (ed - self._ed)

    def drop(self) -> None:
        """End the hold (a step the controller does not drive)."""
        self._left = 0
