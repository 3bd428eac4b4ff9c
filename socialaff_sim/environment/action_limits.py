"""What the robot's body can do with a key-frame target: the envelope actions are projected into.

The action space is a box (:class:`~socialaff_sim.environment.config.EnvConfig`); much of
it asks for what no body can do: a base 2 m up or 3 m away within one frame, a foot at
head height, a wrist twice the arm's length from its shoulder. Sent to the IK as they
are, such targets make it drag the robot's root through its harness and swing the legs
into the person, and the contact forces that follow (10⁵ N on the replayed person's
forearms in a measured case) make MuJoCo's solver diverge ("Nan, Inf or huge value in
QACC"), after which MuJoCo resets the state. :class:`FeasibleTargets` projects every
(5, 3) target array, robot frame, onto an envelope the robot can follow, in this order:

1. base: its height to [h₀ − δ·L, a₀ + h_hip + (1 + λ)·L], with h₀ the base's height at
   home, L the leg length, a₀ the ankles' height at home, h_hip the hips' depth below the
   base and δ = ``base_drop``, λ = ``base_lift`` (a little above straight legs on the floor:
   the harness carries it); then its move from the previous base target to at most v_h/f
   horizontally and v_v/f vertically (f the recording's frame rate);
2. ankles: height to [φ·a₀, a₀ + η·L] (φ = ``ankle_floor``, η = ``step_height``), on the
   own side of the base (the left ankle at least ``stance``·|y_hip| left of the base, the
   right one as far right: legs never cross), then horizontally into the disc of radius
   √(((1 + σ_L)·L)² − Δz²) about its hip, Δz the hip's height above the ankle (σ_L = ``leg_slack``);
3. wrists: into the ball of radius (1 + σ_A)·A about their shoulder, A the arm's length
   (σ_A = ``arm_slack``: bending and leaning the trunk carries the shoulder a long way).

The slack (λ, σ_L, σ_A, φ, and v_h above a walk) is there because the retargeted recording itself
asks for a little more than the bare limbs give (the scaler's push toward a contact, a base
the harness lifts a few centimetres): with it, replaying the recorded agent 1 through the
projection leaves every one of its targets untouched (docs/environment.md, "Actions").

Shoulder and hip offsets are the robot's at home, in the robot frame (the robot keeps the
yaw it was given at reset, :class:`~socialaff_sim.sim.simulator.Simulator`). The
projection is idempotent and leaves a target already inside the envelope untouched
(tested); docs/environment.md gives the figures for the recorded agent 1's targets.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError

__all__ = ["EnvelopeConfig", "BodyEnvelope", "FeasibleTargets"]


@dataclass(frozen=True)
class EnvelopeConfig:
    """How far the projection lets key-frame targets go (the environment's, not the paper's)."""

    base_speed: float = 3.0
    """v_h [m/s]: largest horizontal move of the base target per second (a run)."""
    base_climb: float = 1.5
    """v_v [m/s]: largest vertical move of the base target per second."""
    base_drop: float = 0.35
    """δ [—]: the base may sink this fraction of the leg length below its height at home (a crouch)."""
    base_lift: float = 0.15
    """λ [—]: the base may rise this fraction of the leg length above straight legs on the floor."""
    step_height: float = 0.4
    """η [—]: an ankle may rise this fraction of the leg length above its height at home (a step)."""
    ankle_floor: float = 0.3
    """φ [—]: an ankle stays above this fraction of its height at home (a foot tipped on its edge)."""
    leg_slack: float = 0.25
    """σ_L [—]: an ankle may ask for this fraction more than the leg's length from its hip."""
    arm_slack: float = 1.0
    """σ_A [—]: a wrist may ask for this fraction more than the arm's length from its shoulder at home offset."""
    stance: float = 0.25
    """[—]: each ankle stays at least this fraction of its hip's sideways offset on its own side of the base."""

    def __post_init__(self) -> None:
        for name in ("base_speed", "base_climb", "base_drop", "step_height"):
            if not float(getattr(self, name)) > 0:
                raise ConfigError(f"EnvelopeConfig.{name}: expected a number > 0, found {getattr(self, name)!r}")
        for name in ("base_lift", "leg_slack", "arm_slack", "stance", "ankle_floor"):
            if not 0.0 <= float(getattr(self, name)) <= 1.0:
                raise ConfigError(f"EnvelopeConfig.{name}: expected a fraction in [0, 1], found {getattr(self, name)!r}")


@dataclass(frozen=True)
class BodyEnvelope:
    """The robot's dimensions the projection needs, robot frame at home, metres."""

    arm: float
    """Shoulder-to-wrist chain length."""
    leg: float
    """Hip-to-ankle chain length."""
    shoulders: np.ndarray
    """(2, 3) left/right shoulder offsets from the base."""
    hips: np.ndarray
    """(2, 3) left/right hip offsets from the base."""
    base_height: float
    """Height of the base at home."""
    ankle_height: float
    """Height of the ankle frames at home (mean of both)."""


class FeasibleTargets:
    """Projects (5, 3) robot-frame key-frame targets onto what the robot's body can follow."""

    def __init__(self, body: BodyEnvelope, limits: EnvelopeConfig | None = None) -> None:
        self.body = body
        self.limits = lim = limits or EnvelopeConfig()
        hip_depth = float(-np.mean(body.hips[:, 2]))
        self.base_z = (body.base_height - lim.base_drop * body.leg,
                       body.ankle_height + hip_depth + (1.0 + lim.base_lift) * body.leg)
        """[m]: (lowest, highest) base target height."""
        self.ankle_z = (lim.ankle_floor * body.ankle_height, body.ankle_height + lim.step_height * body.leg)
        """[m]: (lowest, highest) ankle target height."""
        self.side = lim.stance * np.abs(body.hips[:, 1])
        """(2,) [m]: least sideways distance of the left / right ankle from the base, on its own side."""
        self._hips = [[float(v) for v in h] for h in body.hips]
        self._shoulders = [[float(v) for v in h] for h in body.shoulders]
        self._sign = [1.0 if h[1] >= 0 else -1.0 for h in self._hips]

    def project(self, targets: np.ndarray, previous_base: np.ndarray, fps: float) -> np.ndarray:
        """(5, 3) the targets ``targets`` (5, 3) inside the envelope, the base moved from ``previous_base`` (3,)
        (the last base target) at most one frame of 1/``fps`` s at the limits' speeds."""
        # Plain floats: five rows of three, where NumPy's per-call overhead would dominate.
        body, lim = self.body, self.limits
        rows = [[float(v) for v in row] for row in np.asarray(targets, dtype=np.float64)]
        px, py, pz = (float(v) for v in previous_base)
        bx, by, bz = rows[0]
        bz = min(max(bz, self.base_z[0]), self.base_z[1])
        dx, dy = bx - px, by - py
        reach = lim.base_speed / fps
        dist = math.hypot(dx, dy)
        if dist > reach:
            bx, by = px + dx * (reach / dist), py + dy * (reach / dist)
        climb = lim.base_climb / fps
        bz = min(max(bz, max(self.base_z[0], pz - climb)), min(self.base_z[1], pz + climb))
        rows[0] = [bx, by, bz]
        # Ankles: height band, own side of the base, then into the leg's disc at that height.
        leg = (1.0 + lim.leg_slack) * body.leg
        for s, k in ((0, 3), (1, 4)):
            ax, ay, az = rows[k]
            az = min(max(az, self.ankle_z[0]), self.ankle_z[1])
            sign = self._sign[s]
            ay = by + sign * max(sign * (ay - by), float(self.side[s]))
            hx, hy, hz = bx + self._hips[s][0], by + self._hips[s][1], bz + self._hips[s][2]
            radius = math.sqrt(max(leg * leg - (hz - az) ** 2, 0.0))
            gx, gy = ax - hx, ay - hy
            r = math.hypot(gx, gy)
            if r > radius:
                ax, ay = hx + gx * (radius / r), hy + gy * (radius / r)
            rows[k] = [ax, ay, az]
        # Wrists: within the (slack) arm's length of the shoulder.
        arm = (1.0 + lim.arm_slack) * body.arm
        for s, k in ((0, 1), (1, 2)):
            sx, sy, sz = bx + self._shoulders[s][0], by + self._shoulders[s][1], bz + self._shoulders[s][2]
            gx, gy, gz = rows[k][0] - sx, rows[k][1] - sy, rows[k][2] - sz
            r = math.sqrt(gx * gx + gy * gy + gz * gz)
            if r > arm:
                rows[k] = [sx + gx * (arm / r), sy + gy * (arm / r), sz + gz * (arm / r)]
        return np.array(rows)
