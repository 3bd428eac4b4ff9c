"""Standing on its own feet: while both feet are planted the harness may let go of the robot.

With its real weight the robot's root hangs from a compliant harness
(:func:`~socialaff_sim.sim.scene.build_scene`) that follows the IK's base path.
:class:`StanceControl` decides, once per data frame, what the robot does while it
stands (both feet planted by the foot lock, :mod:`~socialaff_sim.sim.footlock`):

1. **A steady base.** The retargeted base target carries the recording's jitter
   (on the synthetic set its second difference is 2–3 cm per frame, about 3 m/s²
   at 10 fps, which the legs pass on to the whole body: a centre-of-mass
   acceleration that moves the zero-moment point by ~20 cm, farther than a foot is
   long). While standing, the base target is low-pass filtered:
   b̂ₜ = α b̂ₜ₋₁ + (1 − α) bₜ (``base_smoothing`` α); a step resets the filter.
   With ``base_over_feet`` the base target is first carried back onto the feet the robot stands on: where the
   plan's ankles stand more than d_f ahead of the physical feet, the base target moves back by the excess, so that
   the plan's base stands over the physical feet as it stands over its own. A synthesized reaction glides its ankles along
   the floor with its base (a linear path between re-planned configurations never lifts a foot); the foot lock
   steps or holds the physical feet behind such a plan, and without this the IK put the base where the plan has
   it, 10–30 cm ahead of the feet, and the harness held the robot up (docs/design.md §5).
2. **Letting go.** The harness weld is switched off (its force is then zero by
   construction) once the robot has stood ``release_after`` frames and is steady:
   the torso within ``release_tilt`` of upright and the measured centre of mass
   within ``release_com`` of the middle of the feet's support rectangle. Released,
   it stays off while the robot stands and the torso tilts at most ``catch_tilt``;
   beyond (a fall under way) or at a step, the harness catches the robot again.
3. **Balance while released.** The IK draws the centre of mass (a
   :class:`mink.ComTask` at ``com_cost``) to the middle of the support rectangle
   moved against the measured error: c* = s − k_p (c − s), with c the physics
   centre of mass and s the rectangle's middle (``com_gain`` k_p): a robot pulled
   forward by a handshake plans its hips back.

The legs need servos stiff enough to stand on (``SimConfig.stance_bandwidth``; when
that is ``None`` the controller's ``leg_bandwidth`` is used).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from ..errors import ConfigError
from .scene import Scene

__all__ = ["StanceConfig", "StanceControl"]


@dataclass(frozen=True)
class StanceConfig:
    """How a standing robot is treated (see :mod:`~socialaff_sim.sim.stance`).

    Fields by concept
    -----------------
    - Steady base: base_smoothing, base_over_feet
    - The plan's lean: strike_lean, strike_lean_max, strike_lean_max_roll_free, strike_lean_fall_roll_free,
      strike_lean_raised, strike_lean_above, strike_lean_out, strike_lean_caught
    - Letting go: release, release_after, release_tilt, release_com, catch_tilt, leg_bandwidth
    - Balance while released: com_cost, com_gain
    """

    base_smoothing: float = 0.8
    """α [—]: while both feet are planted, the base target is b̂ₜ = α b̂ₜ₋₁ + (1 − α) bₜ (0: the target as
    retargeted). Stubby with the harness, 4 synthetic instances per interaction: outside support in the contact
    phases 25 % instead of 33 %, foot sliding median 3.9 cm instead of 9.3 (docs/benchmarks.md)."""
    base_over_feet: float | None = None
    """d_f [m]: while both feet are planted, the plan's ankles' middle (the retargeted ankle targets before the
    foot lock) standing more than this ahead of the physical feet's middle along the robot's heading h moves the
    base target back along h by the excess (e = max(0, (p − f)·h − d_f), p and f the plan's and the physical feet's
    middles; before ``base_smoothing``): the base stands over the feet the robot stands on as the plan's stands over
    its own, instead of ahead of them where the plan has it in the world. Plans whose feet are behind or beside the
    physical ones are left alone (a pull-up's helper stepping back while the robot's feet are held leans back
    against the pull). ``None``: the base target as retargeted (docs/design.md §5: a synthesized reaction's ankles
    glide ahead of feet that stand behind them)."""
    strike_lean: float | None = None
    """k_l [deg/m]: the IK's base target pitched forward (about the heading's lateral axis) by k_l degrees per metre
    that a wrist target raised at least ``strike_lean_raised`` above its shoulder stands ahead of it along the
    heading, at most ``strike_lean_max`` (:mod:`~.strike_lean`): the plan's trunk leans into an upward reach as a
    person's does into a high five, and the balance controller's torso rows hold that lean against the striking
    arm's reaction instead of holding the trunk upright (traced, docs/design.md §5). ``None``: the base target
    upright."""
    strike_lean_max: float = 10.0
    """θ_max [deg]: ``strike_lean``'s largest lean."""
    strike_lean_max_roll_free: float | None = None
    """θ_r [deg]: on a robot whose feet's roll the balance controller frees (``BalanceConfig.flat_roll_free`` on legs
    that cannot roll a foot: the H1, not Stubby), ``strike_lean``'s largest lean in place of ``strike_lean_max``: the
    H1's torso, released, overshoots the plan's 10° lean to 20–24° at the strike and the harness catches it
    (docs/design.md §5, issue 25, session 35, wip/h1lean). ``None``: ``strike_lean_max`` on every robot."""
    strike_lean_fall_roll_free: float | None = None
    """δ [deg/frame]: on a robot whose feet's roll the balance controller frees (the H1, not Stubby), the plan's lean
    (``strike_lean``) falls by at most δ per data frame (it rises as planned): the strike's wrist target dipping
    below its shoulder for a frame or two dropped the H1's plan from 10° to upright at once, its torso, still leaned
    15–19°, read that far from the plan, and the harness caught it at the touch (docs/design.md §5, issue 25,
    session 36, wip/h1hf). ``None``: the lean as planned, frame by frame."""
    strike_lean_raised: float = 0.0
    """h_l [m]: ``strike_lean`` only for a wrist target at least this high above its shoulder (world heights)."""
    strike_lean_above: bool = False
    """[—]: ``strike_lean`` only in a task with a contact sub-goal counted above the robot's shoulders
    (``SubgoalSpec.above``: the high five; the simulator drops the lean elsewhere): a handshake's or a catch's wrist
    target raised above the shoulder for a frame leans nothing. ``False``: in every task."""
    strike_lean_out: int | None = None
    """N [frames]: once every contact sub-goal of the task has been met (the hands have met), ``strike_lean``'s lean
    is ramped out over N data frames, θ · max(0, 1 − n/N) n frames after the meeting (:func:`~.strike_lean.lean_out`):
    a robot whose trunk is caught leaned stops pressing the person after the meeting (high_five_007, docs/design.md
    §5). ``None``: the lean as planned to the episode's end."""
    strike_lean_caught: bool = False
    """[—]: once every contact sub-goal of the task has been met, the first solve in which the harness holds a caught
    robot ends ``strike_lean``'s lean for the rest of the episode (a robot caught leaned after the meeting stops
    pressing the person; one that meets released keeps its lean). ``False``: not."""
    release: bool = True
    """[—]: Whether the harness lets go of a steady standing robot (``False``: only the base is steadied)."""
    release_after: int = 2
    """[frames]: data frames in a row with both feet planted before the harness may let go."""
    release_tilt: float = 3.0
    """[deg]: the harness lets go only when the torso tilted at most this much in the last frame."""
    release_com: float = 0.02
    """[m]: the harness lets go only when the measured centre of mass is also at most this far (horizontally)
    from the middle of the feet's support rectangle (at 4 cm and 5° Stubby was let go while still swaying)."""
    catch_tilt: float = 10.0
    """[deg]: a released robot whose torso tilts more than this in a frame is caught by the harness again."""
    com_cost: float = 10.0
    """[1/m]: cost of the IK's centre-of-mass task while the robot stands released (replaces
    ``IKConfig.com_cost`` in those frames)."""
    com_gain: float = 1.0
    """k_p [—]: the centre-of-mass target is the rectangle's middle moved by −k_p times the measured centre
    of mass's horizontal offset from it (0: the middle itself; at 2, 33 % instead of 22 % outside support)."""
    leg_bandwidth: float = 10.0
    """ω_s [rad/s]: the leg servos' standing bandwidth when ``SimConfig.stance_bandwidth`` is ``None``."""

    def __post_init__(self) -> None:
        if self.strike_lean_fall_roll_free is not None and not self.strike_lean_fall_roll_free > 0.0:
            raise ConfigError(f"StanceConfig.strike_lean_fall_roll_free: expected None or a rate > 0 deg/frame, "
                              f"found {self.strike_lean_fall_roll_free!r}")


class StanceControl:
    """The per-frame standing decisions of one physics scene; :meth:`reset` per episode."""

    def __init__(self, scene: Scene, config: StanceConfig | None = None) -> None:
        self.scene = scene
        self.config = config or StanceConfig()
        m = scene.model
        self.weld = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, "robot_anchor")
        """Id of the harness weld (-1: none)."""
        self._jac = np.zeros((3, m.nv))
        self.reset()

    def reset(self) -> None:
        """A new episode: harnessed, not standing, no base filtered yet."""
        self._run = 0
        self._base: np.ndarray | None = None
        self.released = False
        """Whether the harness is off for the frame being run."""

    def over_feet(self, base: np.ndarray, standing: bool, feet: np.ndarray, plan_feet: np.ndarray | None,
                  heading: np.ndarray) -> np.ndarray:
        """(3,) the base target (world, m) ``base`` (3,) moved back along the robot's ``heading`` (2,) unit vector,
        world, by how far the plan's feet's middle ``plan_feet`` (2,) stands ahead of the physical feet's ``feet`` (2,)
        beyond ``base_over_feet``, while ``standing`` (both feet planted); as given otherwise (off, not standing, no
        plan feet, or the plan's feet not that far ahead)."""
        base = np.array(base, dtype=np.float64)
        d = self.config.base_over_feet
        if d is None or not standing or plan_feet is None:
            return base
        h = np.asarray(heading, dtype=np.float64)
        ahead = float((np.asarray(plan_feet, dtype=np.float64)[:2] - np.asarray(feet, dtype=np.float64)[:2]) @ h)
        if ahead > d:
            base[:2] -= (ahead - d) * h
        return base

    def steady_base(self, base: np.ndarray, standing: bool) -> np.ndarray:
        """(3,) the base target (world, m) to use for the retargeted one ``base`` (3,): filtered while
        ``standing`` (both feet planted), as given otherwise (and the filter starts afresh)."""
        base = np.asarray(base, dtype=np.float64)
        a = self.config.base_smoothing
        out = base if not standing or self._base is None else a * self._base + (1.0 - a) * base
        self._base = out.copy() if standing else None
        return out

    def decide(self, standing: bool, tilt_deg: float, com_offset: float) -> bool:
        """Whether the harness is off for the next frame.

        ``standing``: both feet planted; ``tilt_deg``: the torso's largest tilt in the last frame (degrees);
        ``com_offset``: the measured centre of mass's horizontal distance from the middle of the support
        rectangle (m)."""
        c = self.config
        self._run = self._run + 1 if standing else 0
        steady = tilt_deg <= c.release_tilt and com_offset <= c.release_com
        self.released = (c.release and self._run >= c.release_after and tilt_deg <= c.catch_tilt
                         and (self.released or steady))
        return self.released

    def apply(self, data: mujoco.MjData) -> None:
        """Switch the harness weld in ``data`` off or on as decided."""
        if self.weld >= 0 and self.config.release:  # without release the weld is left alone (it stays on, or a
            data.eq_active[self.weld] = 0 if self.released else 1  # physics-rate controller switches it)

    def measured_com(self, data: mujoco.MjData) -> np.ndarray:
        """(3,) the robot's centre of mass in ``data`` (world, m; as of its last kinematics pass)."""
        return np.array(data.subtree_com[self.scene.root_body])

    def frame(self, data: mujoco.MjData, base: np.ndarray, standing: bool, centre: np.ndarray,
              tilt_deg: float, plan_centre: np.ndarray | None = None, yaw: float = 0.0
              ) -> tuple[np.ndarray, np.ndarray | None]:
        """One frame of the standing robot: the base target (:meth:`over_feet`, :meth:`steady_base`), the harness
        let go of or caught (:meth:`decide`, :meth:`apply` to ``data``), and the IK's centre-of-mass target ((2,)
        world, m) while released, else ``None``; ``centre`` (2,) the support rectangle's middle (world, m) with the
        physical feet, ``plan_centre`` (2,) the same with the plan's ankle targets (``None``: not known), ``yaw``
        (rad) the robot's heading, ``tilt_deg`` the torso's largest tilt in the last frame."""
        heading = np.array([np.cos(yaw), np.sin(yaw)])
        base = self.steady_base(self.over_feet(base, standing, centre, plan_centre, heading), standing)
        com = self.measured_com(data)
        released = self.decide(standing, tilt_deg, float(np.linalg.norm(com[:2] - centre)))
        self.apply(data)
        return base, (self.com_target(com, centre) if released else None)

    def com_target(self, com: np.ndarray, centre: np.ndarray) -> np.ndarray:
        """(2,) the IK's horizontal centre-of-mass target (world, m): the support rectangle's middle
        ``centre`` (2,) moved against the measured centre of mass ``com`` (2+,)'s offset from it."""
        centre = np.asarray(centre, dtype=np.float64)
        return centre - self.config.com_gain * (np.asarray(com, dtype=np.float64)[:2] - centre)
