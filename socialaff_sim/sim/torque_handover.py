"""The joints handed over from the position servos to the balance controller's torques over a ramp.

While the harness holds a standing robot its joints are driven by the position servos (the IK's targets and the
standing feed-forward); once it lets go, the balance controller (:mod:`~.balance_control`) sets every actuator's
torque from its whole-body solve. Switched at once, the torques jump at the release: traced on the H1
(shake_hands_000, docs/benchmarks.md, "The released H1's joints handed over gradually …"), the QP's first torques
differ from the servos' last by up to 1.3 times the actuator's limit (the ankles, hip pitches and knees), and the
torso pitches past the catch within 20 physics steps. With ``BalanceConfig.torque_handover`` = T_h the actuators
exert, k physics steps (of Δt) after the controller took the joints over,

    τ_k = (1 − a_k) τ_servo + a_k τ_QP,    a_k = min(k Δt / T_h, 1),

τ_servo the force the servo would exert at this state with the command the stepper gave it (``gain·ctrl + b₀ +
b₁q + b₂q̇``, clipped as MuJoCo clips: :func:`servo_torque`), τ_QP the controller's. At k = 0 it is the servo's
torque, from k Δt ≥ T_h on the controller's, exactly; in between a convex combination of two torques within the
actuator's limits at this state, so within them too. The ramp starts again at every take-over (each release after
a catch; with ``drive_harnessed``, each time the robot comes to stand on both feet).
"""

from __future__ import annotations

import numpy as np

from .contact_qp import actuator_limits

__all__ = ["TorqueHandover", "blend", "handover_weight", "servo_torque"]


def handover_weight(k: int, timestep: float, ramp: float) -> float:
    """a_k ∈ [0, 1]: the controller's share of the torque ``k`` physics steps of ``timestep`` (s) after it took the
    joints over, on a linear ``ramp`` (s) from the servos' (0) to the controller's (1)."""
    return min(k * timestep / ramp, 1.0)


def blend(servo: np.ndarray, controller: np.ndarray, a: float) -> np.ndarray:
    """(A,) (1 − a) ``servo`` + a ``controller`` (N·m); exactly ``servo`` at a = 0 and ``controller`` at a = 1."""
    if a >= 1.0:
        return np.asarray(controller, dtype=np.float64).copy()
    if a <= 0.0:
        return np.asarray(servo, dtype=np.float64).copy()
    return (1.0 - a) * np.asarray(servo) + a * np.asarray(controller)


def servo_torque(m: object, act_ids: np.ndarray, ctrl: np.ndarray, gain: np.ndarray, bias: np.ndarray,
                 q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(A,) the force (N·m) the affine actuators ``act_ids`` (A,) exert with the command ``ctrl`` (A,) at the joint
    state ``q``, ``v`` (A,): ``gain·ctrl + b₀ + b₁q + b₂q̇`` (``gain`` (A,), ``bias`` (A, 3)) clipped as MuJoCo clips
    it (the control range's reach, the force range, the joint's actuator force range: :func:`actuator_limits`)."""
    lim = actuator_limits(m, act_ids, q, v)  # type: ignore[arg-type]
    return np.clip(gain * ctrl + bias[:, 0] + bias[:, 1] * q + bias[:, 2] * v, lim[:, 0], lim[:, 1])


class TorqueHandover:
    """The ramp of ``BalanceConfig.torque_handover`` (see the module docstring): :meth:`torque` per driven step."""

    def __init__(self, ramp: float, timestep: float) -> None:
        self.ramp, self.timestep = float(ramp), float(timestep)
        self.reset()

    def reset(self) -> None:
        """Not driving: the next driven step is a take-over."""
        self._k: int | None = None
        self.ramp_steps = 0
        """Driven steps whose torque was a blend (a < 1), over the episode."""

    def idle(self) -> None:
        """A step the controller did not drive: the next one it drives starts the ramp again."""
        self._k = None

    def torque(self, servo: np.ndarray, controller: np.ndarray) -> np.ndarray:
        """(A,) the torque of this driven step, from the servos' ``servo`` and the controller's ``controller``."""
        self._k = 0 if self._k is None else self._k + 1
        a = handover_weight(self._k, self.timestep, self.ramp)
        self.ramp_steps += int(a < 1.0)
        self.last = (servo, controller, a)
        """The last driven step's servo torque, controller torque (A,) (N·m) and the controller's share a."""
        return blend(servo, controller, a)
