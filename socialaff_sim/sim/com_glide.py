"""The balance controller's centre-of-mass goal glided from where the centre of mass is to where the plan puts it.

The balance controller (:mod:`~.balance_control`) draws the centre of mass toward a goal c* over the feet: the
IK's centre of mass relative to its feet, carried onto the physical feet. On the H1 the plan's feet and the
physical ones often stand apart (its walk-up steps land short), so at the harness's release the measured centre
of mass can lie 15 cm ahead of the goal (traced on shake_hands_002 in the standing mode: measured 14.4 cm ahead of
the ankles, the goal 1.7 cm behind them, the ankles' reach ending 16.1 cm ahead; docs/benchmarks.md, "The H1's
centre-of-mass goal glided …"). The feedback c̈* = ω_c² (c* − c) − 2 ζ ω_c ċ then asks at once for a centre of
pressure p = c − c̈* h / g about 3.7 × 15 cm beyond the centre of mass, far past what the ankles can hold.
(Measured: on the H1 in the standing mode the glide does not remove the catches, whose releases tip for other
reasons, a robot still moved by the harness and a body carried back over feet that stand behind the plan's; the
options stay off, docs/design.md §5.)

With ``BalanceConfig.com_glide`` = T_g the goal starts, at each take-over of the joints by the controller (the
harness's release), at the measured centre of mass c₀, and moves onto the plan's goal g(t) as a critically damped
second-order glide:

    c*(t) = g(t) + e₀ (1 + t / T_g) exp(−t / T_g),    e₀ = c₀ − g(0),

t the time since the take-over. The offset starts at e₀ with zero rate (d/dt [(1 + s) e^{−s}] = −s e^{−s} is 0 at
s = 0), so the goal does not jump or start moving at a step, and it is below 1 % of e₀ after 6.6 T_g. For a centre
of mass at rest on a goal that glides over a distance e₀, the wanted acceleration, and so the wanted centre of
pressure's distance from the centre of mass, is bounded by roughly ω_c² e₀ (T_g ω_c)⁻², far below the step's ω_c² e₀
(a worked bound in the tests: 15 cm over T_g = 1 s asks for less than 1 cm). The offset is taken in the world's
horizontal plane; the feet stand still while the controller drives (a step catches the robot and ends the glide).

With ``BalanceConfig.glide_joints`` the joints' reference glides the same way, from the joints' measured positions
at the take-over onto the IK's: the planned posture places the body over the *planned* feet, so with the physical
feet standing elsewhere the joints' rows (ω_q = 20 rad/s) would move the released body by as much, whatever the
centre of mass's goal says (traced: shake_hands_002's body swept back at 0.3–0.6 m/s after a release and past its
heels). Measured, the sweep stays with it too: the torque hand-over's servo share, the whole torque at the release,
drives the joints toward the IK's posture as well (docs/benchmarks.md).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["ComGlide", "glide_share", "rest_lead"]


def rest_lead(bandwidth: float, damping: float, pendulum: float) -> float:
    """k [s]: with ``BalanceConfig.glide_rest`` the glide starts at c₀ + k ċ₀, k = (2 ζ ω_c − ω₀) / ω_c²
    (``bandwidth`` ω_c, ``damping`` ζ, ``pendulum`` ω₀ = √(g / h), all rad/s or —): the goal at which the feedback
    c̈* = ω_c² (c* − c) − 2 ζ ω_c ċ asks for c̈* = −ω₀ ċ, i.e. a centre of pressure p = c − c̈*/ω₀² at the capture
    point c + ċ/ω₀, where a linear inverted pendulum comes to rest. From the centre of mass itself (k = 0) a
    moving one is asked to stop 2 ζ ω_c / ω₀ times harder (3.8 on the H1), with the centre of pressure that far
    beyond the capture point."""
    return (2.0 * damping * bandwidth - pendulum) / bandwidth ** 2


def glide_share(t: float, time_constant: float) -> float:
    """(1 + s) e^{−s}, s = ``t`` / ``time_constant`` (s): the share of the starting offset left ``t`` after the
    take-over; 1 at t = 0 with zero slope, falling monotonically to 0."""
    s = max(t, 0.0) / time_constant
    return (1.0 + s) * math.exp(-s)


class ComGlide:
    """The glided goal of ``BalanceConfig.com_glide`` (module docstring): :meth:`goal` per driven step,
    :meth:`idle` per step the controller does not drive."""

    def __init__(self, time_constant: float, timestep: float) -> None:
        self.time_constant, self.timestep = float(time_constant), float(timestep)
        self.reset()

    def reset(self) -> None:
        """Not driving: the next driven step is a take-over."""
        self._k: int | None = None
        self._start = np.zeros(2)
        self.takeovers = 0
        """Take-overs (glides started) since the last reset."""

    def idle(self) -> None:
        """A step the controller did not drive: the next one it drives starts a glide again."""
        self._k = None

    def goal(self, plan: np.ndarray, com: np.ndarray) -> np.ndarray:
        """(2,) world: the goal of this driven step, from the plan's goal ``plan`` (2,) and where the glide starts,
        ``com`` (2,) (m: the measured centre of mass, or with ``glide_rest`` its rest goal, :func:`rest_lead`),
        read at a take-over only; at a take-over exactly ``com``."""
        plan = np.asarray(plan, dtype=np.float64)
        if self._k is None:
            self._k = 0
            self._start = np.asarray(com, dtype=np.float64)[:2] - plan
            self.takeovers += 1
        else:
            self._k += 1
        self.last_share = glide_share(self._k * self.timestep, self.time_constant)
        """The share of the starting offset this step's goal kept."""
        # (exactly ``com`` at the take-over: plan + (com − plan) may differ from it in the last bit)
        start = np.asarray(com, dtype=np.float64)[:2].copy()
        self._last_goal = start if self._k == 0 else plan + self.last_share * self._start
        return self._last_goal

    def joints(self, reference: np.ndarray, measured: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``BalanceConfig.glide_joints``: (offset, rate) (J,) each (rad, rad/s) added to the joints' reference
        ``reference`` (J,) this driven step, so that it starts at the joints' ``measured`` positions (J,) (read at
        the take-over only) and glides onto the plan's as the goal does: offset = e_q (1 + s) e^{−s}, rate = −e_q
        (s / T_g) e^{−s}, s = t / T_g. Called after :meth:`goal` in the same step."""
        if self._k == 0:
            self._joint_start = np.asarray(measured, dtype=np.float64) - np.asarray(reference, dtype=np.float64)
        s = self._k * self.timestep / self.time_constant  # type: ignore[operator]
        rate = -(s / self.time_constant) * math.exp(-s)
        return self.last_share * self._joint_start, rate * self._joint_start
