"""Settings of the Gymnasium environment: observation history, action bounds, physics preset.

:class:`EnvConfig` holds everything about the environment that is not the data,
the robot, the reward or the adapter; :class:`~socialaff_sim.environment.env.SocialAffordanceEnv`
builds one from its keyword arguments (so that ``gymnasium.make(..., history=8)``
works) and validates it here, in one place.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from ..errors import ConfigError, choices
from ..sim.fall import FALL_HEIGHT, FALL_TILT
from ..sim.simulator import SimConfig
from .residual import group_matrix

__all__ = ["ACTION_MODES", "CONTROL_DT", "PHYSICS_PRESETS", "EnvConfig", "physics_config"]

ACTION_MODES = ("targets", "residual")
"""``targets``: the five key-frame targets themselves; ``residual``: offsets added to the adapter's proposal."""

PHYSICS_PRESETS = ("fast", "accurate")
CONTROL_DT = 0.015
"""The default control period, s: Gymnasium's ``Humanoid-v5`` steps 0.015 s (5 physics steps of 3 ms), so an
env step of ours simulates as much time as one of it (docs/environment.md, "Control period")."""
"""Physics settings by name; see :func:`physics_config`."""


def physics_config(preset: str) -> SimConfig:
    """The simulator settings of a physics preset.

    * ``accurate``: the simulator's defaults (:class:`~socialaff_sim.sim.simulator.SimConfig`,
      physics step Δt = 4 ms, i.e. about 20 physics steps per data frame at 12 fps);
    * ``fast``: twice the default Δt (8 ms: half as many physics steps per data frame) and at most
      three IK iterations per frame: about half the cost per env step of ``accurate`` on one core
      (two let a fast high-five swing, at the robots' 20 rad/s, miss the touch in 2 of 8 replays).
      The servos (ω = 25 rad/s) stay well resolved (ω·Δt = 0.2); contacts are softer, and replaying the
      recorded agent 1 meets every sub-goal a little less often (docs/environment.md, "Speed").

    Finer trade-offs (a kinematic person, a longer Δt, fewer IK steps) are ``SimConfig`` fields passed as
    ``sim_config=`` to the environment; their measured cost is in docs/environment.md, "Speed options".
    """
    base = SimConfig()
    if preset == "accurate":
        return base
    if preset == "fast":
        return replace(base, timestep=2.0 * base.timestep, ik=replace(base.ik, iterations=min(3, base.ik.iterations)))
    raise ConfigError(f"physics: expected {choices(PHYSICS_PRESETS)}, found {preset!r}")


@dataclass(frozen=True)
class EnvConfig:
    """How observations and actions are laid out (not the paper's: the environment is ours).

    Fields by concept
    -----------------
    - Actions: action_mode, target_low, target_high, residual_bound, residual_groups, residual_tau
    - Observations: history, position_bound, velocity_bound
    - Episodes: terminate_on_failure, fall_height, fall_tilt, max_frames, physics, control_dt, resolve_iterations
    - Rendering: render_width, render_height
    """

    action_mode: str = "targets"
    """[—]: Action mode, one of :data:`ACTION_MODES`."""
    history: int = 4
    """H [frames]: frames of the human's key joints (and of the object) in each observation."""
    target_low: tuple[float, float, float] = (-1.0, -1.5, 0.0)
    """[m]: Lower bound (x, y, z) of every key-frame target in ``targets`` mode, metres, robot frame."""
    target_high: tuple[float, float, float] = (3.0, 1.5, 2.5)
    """[m]: Upper bound (x, y, z) of every key-frame target in ``targets`` mode, metres, robot frame."""
    residual_bound: float = 0.3
    """ρ [m]: a ``residual`` action is an offset in [−ρ, ρ] per coordinate."""
    residual_groups: tuple[tuple[str, ...], ...] | None = None
    """[—]: ``residual`` mode only: groups of key joints (names of ``KEY_JOINTS``) that share one offset; the
    action is then (G, 3), one row per group, and key joints in no group get no offset
    (:mod:`~socialaff_sim.environment.residual`). ``None``: every key joint its own row, the (5, 3) action."""
    residual_tau: float | None = None
    """τ_r [s]: ``residual`` mode only: the offset sent follows the action through a first-order low-pass filter
    of this time constant (a slowly varying offset; the observation then carries it as ``residual_offset``).
    ``None``: the action's offset is sent as it is."""
    position_bound: float = 6.0
    """P [m]: positions in observations are clipped to [−P, P] (the observation bounds)."""
    velocity_bound: float = 30.0
    """V [rad/s]: joint velocities in observations are clipped to [−V, V]."""
    terminate_on_failure: bool = True
    """[—]: Whether a failure condition of the task file (self-collision, force on the person, a drop)
    ends the episode (``terminated``); otherwise it is only penalised once."""
    fall_height: float = FALL_HEIGHT
    """[—]: The robot has fallen (termination reason ``fell``) when its base is lower than this fraction
    of its height at home (the action envelope keeps base targets above 1 − 0.35·leg/height of it)."""
    fall_tilt: float = FALL_TILT
    """[deg]: The robot has also fallen when its trunk tilts more than this from its upright posture at home."""
    max_frames: int | None = None
    """[frames]: Cut every instance to its first this many frames (short episodes, e.g. in tests); ``None``: whole instances."""
    physics: str = "fast"
    """[—]: Physics preset, one of :data:`PHYSICS_PRESETS` (see :func:`physics_config`)."""
    control_dt: float | None = CONTROL_DT
    """Δt_c [s]: the control period, the simulated time one env step covers: each data frame of 1/fps s is
    split into m = round(1/(fps·Δt_c)) control steps (at least 1, at most the frame's physics steps), each
    running ⌊n/m⌋ or ⌈n/m⌉ of its n physics steps. ``None``: one env step per data frame (m = 1)."""
    resolve_iterations: int = 1
    """[steps]: IK steps (at most) when a control step within a frame changes the frame's targets (the frame's
    first control step takes the preset's, ``IKConfig.iterations``): a differential IK at the control rate."""
    render_width: int = 640
    """[px]: Width of ``rgb_array`` frames, pixels."""
    render_height: int = 480
    """[px]: Height of ``rgb_array`` frames, pixels."""

    def __post_init__(self) -> None:
        def bad(name: str, expected: str) -> ConfigError:
            return ConfigError(f"SocialAffordanceEnv: argument {name!r}: expected {expected}, found {getattr(self, name)!r}")

        if self.action_mode not in ACTION_MODES:
            raise bad("action_mode", choices(ACTION_MODES))
        if self.physics not in PHYSICS_PRESETS:
            raise bad("physics", choices(PHYSICS_PRESETS))
        if not isinstance(self.history, int) or self.history < 1:
            raise bad("history", "an integer >= 1")
        if self.max_frames is not None and (not isinstance(self.max_frames, int) or self.max_frames < 3):
            raise bad("max_frames", "None or an integer >= 3 (an episode needs at least two steps)")
        for name in ("residual_bound", "position_bound", "velocity_bound"):
            if not float(getattr(self, name)) > 0:
                raise bad(name, "a number > 0")
        if not 0.0 < float(self.fall_height) < 1.0:
            raise bad("fall_height", "a fraction of the base's height at home in (0, 1)")
        if not 0.0 < float(self.fall_tilt) <= 180.0:
            raise bad("fall_tilt", "an angle in (0, 180] degrees")
        if len(self.target_low) != 3 or len(self.target_high) != 3:
            raise bad("target_low", "three numbers (x, y, z), and three for target_high")
        if any(lo >= hi for lo, hi in zip(self.target_low, self.target_high, strict=True)):
            raise bad("target_low", f"values below target_high = {self.target_high}")
        if max(abs(v) for v in (*self.target_low, *self.target_high)) > self.position_bound:
            raise bad("target_low", f"targets within the observation bound ±{self.position_bound} m")
        if self.residual_groups is not None:
            group_matrix(self.residual_groups)  # names, empty or overlapping groups: a ConfigError naming them
            if self.action_mode != "residual":
                raise bad("residual_groups", "None unless action_mode is 'residual'")
        if self.residual_tau is not None:
            if not (isinstance(self.residual_tau, (int, float)) and 0.0 < float(self.residual_tau) <= 60.0):
                raise bad("residual_tau", "None or a time constant in (0, 60] seconds")
            if self.action_mode != "residual":
                raise bad("residual_tau", "None unless action_mode is 'residual'")
        if self.control_dt is not None and not (isinstance(self.control_dt, (int, float))
                                                and 0.0 < float(self.control_dt) <= 1.0):
            raise bad("control_dt", "None or a control period in (0, 1] seconds")
        if not isinstance(self.resolve_iterations, int) or self.resolve_iterations < 1:
            raise bad("resolve_iterations", "an integer >= 1")
        for name in ("render_width", "render_height"):
            if not isinstance(getattr(self, name), int) or not 16 <= getattr(self, name) <= 4096:
                raise bad(name, "an integer in [16, 4096] pixels")
