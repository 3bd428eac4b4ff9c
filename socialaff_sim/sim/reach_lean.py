"""The plan's trunk leaned into a reach down and ahead that the upright robot's arm cannot make.

The retargeting plan's trunk stays upright (its base orientation is the home one turned to face the partner; the key
joints carry no trunk attitude), so a robot whose shoulders stand high above short arms cannot bring its hand down to
a seated person's hand: the H1's shoulders are 1.47 m above the floor and its arm is 0.554 m long (shoulder to wrist
frame), while the seated person's hands at the pull-up's grip are 0.55–0.95 m high; the recorded helper (arm about
0.6 m, shoulders 1.24–1.54 m) bends over, 7–11° on average while in contact and up to 15–25° (docs/design.md §5,
issue 25, session 36, wip/h1pull). With ``SimConfig.reach_lean`` the plan leans its base forward, about the heading's
lateral axis through the base, by the least angle

    θ = min over θ ≥ 0 with |w_i − R(θ) s_i| ≤ arm, for every arm i whose wrist target reaches down and ahead,

capped at θ_max (``ReachLeanConfig.most``), ``w_i`` the wrist target and ``s_i`` the shoulder's home offset, both from
the base target in the robot's frame (x toward the partner, z up), R(θ) the pitch forward by θ. An arm "reaches down
and ahead" when its wrist target lies at least ``ahead`` before its shoulder (along x) and ``below`` under it (along
z): a hanging arm or a raised one leans nothing; a wrist target within the arm's reach upright leans nothing. The
least θ has a closed form (:func:`least_lean`): with A = d_x s_x + d_z s_z, B = d_x s_z − d_z s_x (d = w_i), the
squared distance is |d|² + |s|² − 2(A cos θ + B sin θ + d_y s_y), so the reach needs
A cos θ + B sin θ ≥ K = (|d|² + |s|² − arm²)/2 − d_y s_y, i.e. ρ cos(θ − φ) ≥ K with ρ = √(A² + B²), φ = atan2(B, A):
θ = max(0, φ − arccos(K/ρ)) when K ≤ ρ and φ + arccos(K/ρ) ≥ 0 (else no forward lean reaches: θ_max).

With ``roll_free`` (the gate) the lean acts only on a robot whose legs cannot roll their feet (fewer than six joint
degrees of freedom from the base to a foot, :func:`~socialaff_sim.sim.flat_feet.leg_dofs`: the H1, not Stubby): the
robots the balance controller's ``*_roll_free`` gates pick, known here from the model alone so that it holds on the
harness too, where no balance controller runs. With ``seated_only`` it acts only in a task whose person sits on a
chair at the start (``TaskSpec.chair``: the pull-up).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from ..errors import ConfigError
from .flat_feet import leg_dofs

__all__ = ["ReachLean", "ReachLeanConfig", "least_lean", "reach_lean", "rolls_no_foot"]


@dataclass(frozen=True)
class ReachLeanConfig:
    """Settings of the plan's lean into a reach down and ahead (:func:`reach_lean`).

    Fields by concept
    -----------------
    - How far: most
    - Which reaches: ahead, below
    - Which robots and tasks: roll_free, seated_only
    - The grip: lead
    """

    most: float = 30.0
    """θ_max [deg]: the largest lean (a reach that no lean up to it brings within the arm's length leans this much)."""
    ahead: float = 0.1
    """a [m]: an arm's wrist target counts only when it lies at least this far ahead of its shoulder (toward the
    partner), so that a hanging arm leans nothing."""
    below: float = 0.0
    """b [m]: ... and at least this far below its shoulder (a raised reach leans by ``StanceConfig.strike_lean``)."""
    roll_free: bool = True
    """[—]: Whether the lean acts only on a robot whose legs cannot roll their feet (fewer than six joint degrees of
    freedom from the base to a foot: the H1, not Stubby), the robots the ``*_roll_free`` gates pick."""
    seated_only: bool = True
    """[—]: Whether the lean acts only in a task whose person sits at the start (``TaskSpec.chair``: the pull-up),
    whose hands lie below a standing robot's reach. Off, handshakes, hand overs and throws lean too (development:
    the H1's hand overs met 7 → 16 of 16 but its handshakes' and throws' contact-phase support rose by 10 points)."""
    lead: float | None = None
    """d_g [m]: in the episodes the lean acts in (the gates above), once an arm has touched the person (the arms'
    compensation's latch, ``BalanceConfig.arm_compensation``), the balance controller's centre-of-mass reference is
    moved d_g forward along the support box's heading (:meth:`~.com_reference.ComReference.goal`, before the box's
    clip): the leaned H1's grip is caught with its capture point behind its heels (docs/design.md §5, issue 25,
    session 39, wip/h1pull3; the force's direction was not recorded, so the cause is not traced). ``None``: no
    lead; without a balance controller (the harness mode) nothing."""

    def __post_init__(self) -> None:
        if not 0.0 <= self.most < 90.0:
            raise ConfigError(f"ReachLeanConfig.most: expected an angle in [0, 90) degrees, found {self.most}")
        if not np.isfinite(self.ahead) or not np.isfinite(self.below):
            raise ConfigError(f"ReachLeanConfig: expected finite ahead and below (m), found {self.ahead}, {self.below}")
        if self.lead is not None and not 0.0 <= self.lead <= 0.2:
            raise ConfigError(f"ReachLeanConfig.lead: expected None or a distance in [0, 0.2] m, found {self.lead}")


def least_lean(d: np.ndarray, s: np.ndarray, arm: float) -> float:
    """The least forward pitch θ ≥ 0 (radians) about the base that brings the shoulder at offset ``s`` (3,) within
    ``arm`` (m) of the wrist target at offset ``d`` (3,) (both from the base, robot frame: x ahead, z up; the pitch
    R(θ) turns z toward x); ``inf`` when no pitch does (the closed form of the module docstring)."""
    d = np.asarray(d, dtype=np.float64)
    s = np.asarray(s, dtype=np.float64)
    if float(np.linalg.norm(d - s)) <= arm:
        return 0.0
    a = d[0] * s[0] + d[2] * s[2]
    b = d[0] * s[2] - d[2] * s[0]
    k = 0.5 * (float(d @ d) + float(s @ s) - arm * arm) - d[1] * s[1]
    rho = float(np.hypot(a, b))
    if rho <= 0.0 or k > rho:
        return float("inf")
    phi, half = float(np.arctan2(b, a)), float(np.arccos(k / rho))
    if phi + half < 0.0:  # the reach lies behind: leaning forward only moves the shoulder away
        return float("inf")
    return max(0.0, phi - half)


def reach_lean(targets: np.ndarray, shoulders: np.ndarray, arm: float, config: ReachLeanConfig) -> float:
    """The plan's forward lean θ (radians, ≥ 0) for robot-frame key-frame ``targets`` (5, 3) (base, left wrist, right
    wrist, left ankle, right ankle; metres), the shoulders' home offsets from the base ``shoulders`` (2, 3) and the
    arm's length ``arm`` (m): the largest of the arms' least leans (:func:`least_lean`) over the arms whose wrist
    target reaches down and ahead (``config.ahead``, ``config.below``), at most ``config.most`` degrees. A wrist target
    that is not finite leans nothing."""
    t = np.asarray(targets, dtype=np.float64)
    sh = np.asarray(shoulders, dtype=np.float64)
    most = float(np.radians(config.most))
    lean = 0.0
    for i in (0, 1):
        d = t[1 + i] - t[0]
        if not np.isfinite(d).all():
            continue
        if d[0] - sh[i, 0] < config.ahead or sh[i, 2] - d[2] < config.below:
            continue
        lean = max(lean, min(most, least_lean(d, sh[i], arm)))
    return lean


def rolls_no_foot(m: mujoco.MjModel, feet: list[int], root: int) -> bool:
    """Whether some leg, from the body ``root`` to a body of ``feet``, has fewer than six joint degrees of freedom
    (:func:`~socialaff_sim.sim.flat_feet.leg_dofs`: it cannot roll its foot; the H1's five-joint legs): the robots
    ``ReachLeanConfig.roll_free`` picks."""
    return any(leg_dofs(m, int(b), int(root)) < 6 for b in feet)


class ReachLean:
    """The lean of one robot in one scene (``SimConfig.reach_lean``): :func:`reach_lean` of each frame's targets,
    where the gate lets it act (:attr:`active`)."""

    def __init__(self, config: ReachLeanConfig, model: mujoco.MjModel, feet: list[int], root: int, arm: float,
                 shoulders: np.ndarray, seated: bool) -> None:
        self.config = config
        self.arm = float(arm)
        self.shoulders = np.asarray(shoulders, dtype=np.float64)
        self.active = (not config.roll_free or rolls_no_foot(model, feet, root)) and (seated or not config.seated_only)
        """Whether this robot leans at all in this task (``roll_free``: only a robot whose legs cannot roll their feet;
        ``seated_only``: only where the person sits, ``seated``)."""

    def frame(self, targets: np.ndarray) -> float:
        """The lean θ (radians, ≥ 0) for robot-frame key-frame ``targets`` (5, 3) m; 0 where the gate says no."""
        return reach_lean(targets, self.shoulders, self.arm, self.config) if self.active else 0.0
