"""Settings of the physics loop (:class:`SimConfig`) and what one step of it did (:class:`StepResult`).

Both are used by :class:`~socialaff_sim.sim.simulator.Simulator` (and re-exported there).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigError
from ..retarget.contact_completion import ContactCompletionConfig
from ..retarget.ik import IKConfig
from ..retarget.robot import PHYSICS_MODES
from ..retarget.scaling import ScalingConfig
from .balance_config import BalanceConfig
from .footlock import FootLockConfig
from .reach_lean import ReachLeanConfig
from .stance import StanceConfig
from .support import FrameSupport

__all__ = ["SimConfig", "StepResult", "PHYSICS_MODES", "STANDING_BALANCE", "STANDING_FOOT_LOCK", "STANDING_FLOOR",
           "STANDING_STANCE"]

# PHYSICS_MODES, the named modes (:meth:`SimConfig.harness` and :meth:`SimConfig.standing`), is defined with the
# robot mappings that name one as a robot's own (retarget/robot.py) and re-exported here.

STANDING_BALANCE = BalanceConfig(solver="qp", sole_gap=0.01, w_torso=3.0, flat_feet=True, self_clearance=0.01,
                                 hand_yield=0.5, yield_damping=50.0, yield_twist=0.02, yield_carried=True,
                                 arm_compensation=1.0, compensation_gate=1e9, com_shift=0.1, shift_until_touch=True,
                                 com_plan_velocity=True, torso_plan_velocity=True, plan_velocity_until_touch=True,
                                 plan_velocity_raised=0.0, plan_velocity_tilt=4.0, flat_roll_free=True, hand_task=10.0,
                                 hand_task_roll_free=True, hand_task_arm_weight=0.1, hand_task_plan_velocity=True,
                                 hand_task_velocity_until_touch=True, tilt_from_plan=True,
                                 touch_friction=0.35, shear_couple=300.0, shear_couple_form="moment",
                                 shear_couple_touched=True, catch_follow_feet=0.3, catch_follow_chair=True)
"""The balance controller of :meth:`SimConfig.standing`: the quadratic program with the feet flat on their soles,
the arms kept 1 cm clear of the body, hands that give way (before a push tips the robot or twists its feet, also to
the person's pull through an object both still hold), each arm's references made up for the trunk's pose error
until that arm first touches the person or the object, and the centre of mass moved forward by up to 10 cm of the
feet's shortfall behind the plan's until then; the centre of mass's and the torso's damping toward the plan's
velocities in a frame whose plan lifts a wrist above its shoulder, until the first touch and while the torso tilts
at most 4° (the strike of a high five; docs/design.md §5, issue 25). For a robot whose legs cannot roll a flat foot
(fewer than six joints, the H1): that roll row left free, and each wrist held at the plan's by a position task whose
arm's joint rows weigh a tenth, its target moving with the plan's wrist until the arm's first touch (rule on the
H1's 392–423, session 33); Stubby's six-joint legs get none of it. The harness's release and catch read the torso's
tilt from the plan's torso (``tilt_from_plan``), so that :data:`STANDING_STANCE`'s planned lean neither keeps the
harness on nor makes it catch (rule on Stubby's 528–535, session 34). Once an arm has touched the person or the
object, the floor forces the controller plans stay within a friction cone of 0.35 instead of 0.7, so a sole rocked
onto an edge is not asked for the sideways force that slides it (rule on Stubby's and the H1's 560–575, session 34);
and from then on the QP pays ½·300·q² for the floor's moment about the vertical through the feet's midpoint over the
feet's distance, q (the feet's opposed shears that rock a sole onto its edge; rule #53 on Stubby's 672–687, session
35). In a task whose person sits on a chair (the pull-up), while the harness holds a robot it has caught within 0.3 m
of a meeting, its anchor is shifted by the planted feet's offset from their targets: it holds the root over the feet
where they stand instead of dragging them after the plan's step (rule #60 on Stubby's 800–815, session 36)."""
STANDING_FOOT_LOCK = FootLockConfig(hold_lift=0.12, hold_in_contact=True, glide_step=0.05, glide_until_contact=True,
                                    glide_gap=0.12, hold_near=0.1, hold_near_roll_free=True, hold_step_gap=0.3,
                                    restep_gap=0.25, restep_above=True, restep_roll_free=True)
"""The foot lock of :meth:`SimConfig.standing`: a planted foot stays planted up to 12 cm of recorded rise, and
whatever the recording's feet do while a sub-goal's contact holds; in the walk-up (before the first contact) a
foot whose target glides along the floor while the physical foot stands more than 12 cm behind it steps (raised
5 cm for a frame), so that the robot does not stay behind its plan; on a robot whose feet's roll is freed (the H1),
a planted foot does not step away from the person while a sub-goal's gap is within 10 cm, and while a gap is
within 30 cm a recorded step is planted in the plan at once while the physical foot stays (rule #51, session 35),
and, in a high five on such a robot, a planted foot standing more than 25 cm from its planted point (a walk-up step
that landed short) steps again until the first contact (rule #64, session 37; docs/design.md §5, issue 25)."""


STANDING_STANCE = StanceConfig(release=False, strike_lean=30.0, strike_lean_above=True)
"""The stance of :meth:`SimConfig.standing`: a steadied base (the balance controller, not the stance, lets the harness
go), whose plan leans the trunk forward into a high five's upward reach by 30° per metre that a raised wrist target
stands ahead of its shoulder, at most 10°, in a task whose contact counts above the shoulders only (the high five;
rule on Stubby's 528–535, docs/design.md §5, issue 25, session 34, wip/hf8)."""


STANDING_FLOOR = 0.01
"""τ_f [s] of :meth:`SimConfig.standing`: the floor's contacts with a time constant of 0.01 s instead of MuJoCo's
0.02 s (``SimConfig.floor_time_constant``): the planted feet slide back and forth less on it (adopted by the rule of
docs/design.md §5, "The feet's slide in the standing mode …", issue 25)."""

@dataclass(frozen=True)
class SimConfig:
    """Settings of the physics loop.

    The defaults are the harness mode (:meth:`harness`: the robot's real weight, position servos tracking the IK,
    its root hanging from a compliant harness throughout); :meth:`standing` stands it on its own feet while they
    are planted (the balance QP, the harness let go of a steady robot). Which to default to was decided by the
    rule of docs/design.md §5 (issue 25): the standing mode cut the contact phases' outside support from 34 to
    4 % but lost 13 of 80 successes, so the harness stays the default.

    Fields by concept
    -----------------
    - Physics: timestep, servo_bandwidth, hand_force, grip, compliant_person, floor_time_constant, settle_iterations
    - Weight and support: gravity_compensation, harness_time_constant, foot_lock, stance_bandwidth, stance,
      balance, plan_feet_causal_only
    - Retargeting: ik, scaling, contact_completion, reach_lean, trunk_vertices
    """

    timestep: float = 0.004
    """Δt [s]: physics step in seconds (shortened so a data frame holds a whole number of steps)."""
    servo_bandwidth: float | None = 25.0
    """ω [rad/s]: natural frequency of the critically damped joint servos, rad/s (``None``: the model's own gains)."""
    gravity_compensation: bool = False
    """[—]: Kinematic-puppet mode: every robot body gets MuJoCo's gravity compensation (``gravcomp = 1``), so
    the robot is weightless and its servos never hold anything up; its root is held by a rigid weld. Off by
    default: gravity acts on the robot, and the support it then gets from its harness is measured
    (:mod:`~socialaff_sim.sim.support`); every figure says which mode ran (``metrics.json``'s ``support.mode``)."""
    foot_lock: FootLockConfig | None = field(default_factory=FootLockConfig)
    """[—]: When a standing foot's target is held where the foot came down (:mod:`~socialaff_sim.sim.footlock`);
    ``None``: ankle targets are followed as given (:meth:`standing` uses :data:`STANDING_FOOT_LOCK`)."""
    harness_time_constant: float = 0.02
    """τ_h [s]: with the robot's real weight, its root hangs from the IK's base pose by a compliant harness,
    a soft weld of this time constant (:func:`~socialaff_sim.sim.scene.build_scene`). Standing still at home
    on its feet, the robot takes 2.9 % (Stubby), 6.2 % (H1) or 1.7 % (G1) of its weight from it; a robot
    whose feet do not reach sags by about 3.5 cm and hangs. At 0.05 s the base lagged the IK's by up to 8 cm
    while walking and Stubby's handshake of shake_hands_000 missed. With gravity compensation the root is
    held by the rigid weld (0.008 s; with weight it would carry 11.5 % of the standing H1's weight)."""
    stance_bandwidth: float | None = None
    """ω_s [rad/s]: the leg servos' natural frequency on the inertia of the body they hold up when standing
    (:func:`~socialaff_sim.sim.robot_mjcf.tune_servos`); ``None``: the legs keep ``servo_bandwidth`` on their
    own inertia (too soft to stand on without the harness). Not used with gravity compensation."""
    stance: StanceConfig | None = None
    """[—]: While both feet are planted: a steadied base target and, once the robot is steady, no harness
    (:mod:`~socialaff_sim.sim.stance`); ``None`` (the default): the harness follows the retargeted base
    throughout. Off by default: on the synthetic set it lowered Stubby's outside support in the contact phases
    from 33 % to 24 % (25 % with the base filter alone), short of the 5 % target, and did not lower the H1's
    (54 %; docs/benchmarks.md, "Standing without the harness"). Not used with gravity compensation."""
    balance: BalanceConfig | None = None
    """[—]: A physics-rate balance controller while both feet are planted: whole-body inverse dynamics with the
    floor's contact forces at every physics step, and the harness let go of a steady robot
    (:mod:`~socialaff_sim.sim.balance_control`); ``None`` (the default): the position servos track the IK with the
    standing feed-forward, on the harness. Needs ``foot_lock``; not with ``stance.release`` (both would switch the
    harness). Not used with gravity compensation. :meth:`standing` uses :data:`STANDING_BALANCE`; the rule for
    making it the default failed on successes (docs/design.md §5, issue 25)."""
    plan_feet_causal_only: bool = False
    """[—]: ``FootLockConfig.restep_gap`` and ``StanceConfig.base_over_feet`` act only in episodes whose source is
    causal (declares ``placement_frames``, as the model's synthesis does: its ankles glide along the floor with its
    base), not on a recording's replay, whose feet step (docs/design.md §5). ``False``: on every source."""
    hand_force: float | None = 60.0
    """F_max [N]: the arm servos' torque limits are set so that a hand pushes with at most about
    this force (each arm joint's limit is F_max times its lever arm to the hand's far end at home,
    never above the model's own limit); ``None`` keeps the model's limits. With gravity compensation
    the arms need little torque to move, so this mostly bounds how hard the robot can press on a person."""
    ik: IKConfig = field(default_factory=IKConfig)
    """[—]: Retargeting IK settings."""
    scaling: ScalingConfig = field(default_factory=ScalingConfig)
    """[—]: Human-to-robot scaling settings."""
    contact_completion: ContactCompletionConfig | None = field(default_factory=ContactCompletionConfig)
    """[—]: Between the scaled targets and the IK, a wrist the model brings near a contact the task wants is
    blended onto it (:mod:`~socialaff_sim.retarget.contact_completion`; applied by
    :meth:`~socialaff_sim.sim.simulator.Simulator.retarget`); ``None``: the scaled targets go to the IK as
    they are."""
    reach_lean: ReachLeanConfig | None = None
    """[—]: The plan's trunk leaned forward into a wrist target down and ahead that the upright arm cannot reach (a
    seated person's hand below a tall robot's short arms; :mod:`~socialaff_sim.sim.reach_lean`), in either physics
    mode; ``None`` (the default): the plan's trunk leans only by ``StanceConfig.strike_lean`` (docs/design.md §5,
    issue 25, session 36, wip/h1pull)."""
    trunk_vertices: bool = False
    """[—]: Whether the robot's trunk radius r_t (the horizontal extent of its collidable geoms but the arms about
    the base's vertical axis, at home: :attr:`~socialaff_sim.sim.reach.ReachModel.trunk_radius`, which the
    placement keeps the contact samples' wrists and the person's body clear of and the reach criterion reads) takes
    a mesh geom's extent from the mesh's vertices rather than from its bounding sphere. A robot of primitive geoms
    (Stubby) gets the same radius either way; the H1's, all meshes, is 0.537 m from its thighs' bounding spheres
    against 0.322 m from the vertices (its feet), and every H1 hand over on 608–623 was placed by it, standing back
    with the cup 0.7–1.0 m from its shoulders (arm 0.55 m; docs/design.md §5, "The H1's hand overs"). Off: the
    bounding spheres."""
    grip: bool = True
    """[—]: Whether a robot hand touching the object grips it (its grip weld switches on and stays on)."""
    compliant_person: bool = True
    """[—]: Whether the replayed person's forearms and hands are simulated: free bodies held to the recording
    by soft welds (:mod:`~socialaff_sim.sim.scene_human`), so that they yield a few centimetres when the robot
    grips or pushes them. ``False``: every part of the person is a mocap body, a pure replay that nothing
    pushes (the robot's contacts with it, its contact forces and the sub-goals are still scored); the physics
    then has the robot's and the object's degrees of freedom only (Stubby: 111 → 39), which makes a physics
    step about twice as fast. See docs/environment.md, "Speed", for the measured effect."""
    floor_time_constant: float | None = None
    """τ_f [s]: the floor's contacts get this MuJoCo time constant (``solref``, damping ratio 1; the floor's weight in
    the mix 1000 to 1, :data:`~socialaff_sim.sim.scene.FLOOR_SOLMIX`): a stiffer floor. MuJoCo's default, 0.02 s, is
    a spring of 50 rad/s under the feet; a standing robot's planted feet rock and slide back and forth on it at
    about that frequency (traced: 80 % of the ankle's contact-phase path is the sole's own motion at ~8 Hz, its
    friction ratio at the median 0.06–0.16, the net drift under a fifth of the path; docs/design.md §5, "The
    feet's slide in the standing mode …"). MuJoCo raises a time constant under two physics steps to two (its
    ``refsafe``: the environment's ``fast`` preset, 8 ms, gets 0.016 s).
    ``None``: MuJoCo's default; :meth:`standing`: :data:`STANDING_FLOOR`."""
    settle_iterations: int = 20
    """[—]: IK solves spent at reset to reach the first frame's targets before physics starts."""

    @classmethod
    def harness(cls, **changes: object) -> SimConfig:
        """The robot hanging from its compliant harness: position servos tracking the IK, the harness following
        the retargeted base throughout, the foot lock's own settings, no balance controller (``changes``: other
        fields). The defaults: ``SimConfig.harness() == SimConfig()``."""
        return cls(**{"foot_lock": FootLockConfig(), "stance": None, "balance": None, **changes})  # type: ignore[arg-type]

    @classmethod
    def standing(cls, **changes: object) -> SimConfig:
        """The robot standing on its own feet while they are planted: the balance QP (:data:`STANDING_BALANCE`)
        on a steadied base that leans into a high five (:data:`STANDING_STANCE`), the harness let go of a steady
        robot, the foot lock :data:`STANDING_FOOT_LOCK`, the stiffer floor :data:`STANDING_FLOOR` (``changes``:
        other fields)."""
        return cls(**{"foot_lock": STANDING_FOOT_LOCK, "stance": STANDING_STANCE,  # type: ignore[arg-type]
                      "balance": STANDING_BALANCE, "floor_time_constant": STANDING_FLOOR, **changes})

    @classmethod
    def mode(cls, name: str, **changes: object) -> SimConfig:
        """The physics mode called ``name`` (one of :data:`PHYSICS_MODES`) with ``changes`` to other fields."""
        if name not in PHYSICS_MODES:
            raise ConfigError(f"physics mode: expected one of {', '.join(PHYSICS_MODES)}, found {name!r}")
        return cls.harness(**changes) if name == "harness" else cls.standing(**changes)

    def __post_init__(self) -> None:
        if self.balance is not None and self.stance is not None and self.stance.release:
            raise ConfigError("SimConfig: balance and stance.release both switch the harness; use "
                              "stance=StanceConfig(release=False) (a steadied base) or stance=None with balance")
        if self.balance is not None and self.foot_lock is None:
            raise ConfigError("SimConfig.balance: needs foot_lock (the controller acts while both feet are planted)")
        if self.floor_time_constant is not None and not self.floor_time_constant > 0.0:
            raise ConfigError(f"SimConfig.floor_time_constant: expected None or a time > 0 s, found "
                              f"{self.floor_time_constant}")


@dataclass(frozen=True)
class StepResult:
    """What one :meth:`Simulator.step` did."""

    frame: int
    """The data frame reached."""
    time: float
    """Simulated time, s."""
    targets: np.ndarray
    """(5, 3) robot-frame targets used (NaN entries replaced by the home offsets), metres."""
    ik_error: np.ndarray
    """(5,) IK residual of each key frame, metres."""
    reachable: np.ndarray
    """(5,) bool: whether each target is reachable by the criterion of :mod:`socialaff_sim.sim.reach`
    (within the limb's length, the hand or trunk clear of the person by its own size); IK error is
    judged on these."""
    ik_iterations: int
    ik_seconds: float
    """CPU time of the IK in the calling thread, s."""
    subevent: str | None
    force_on_human: float
    """Total normal force of the robot on the human, averaged over the step's physics steps, N."""
    subgoals: dict[str, bool]
    """Success so far of each sub-goal (``object_in_hand`` is only judged at the end)."""
    failed: bool
    """Whether a failure condition has triggered (now or earlier)."""
    done: bool
    """Whether the last frame has been reached."""
    subgoals_now: dict[str, bool] = field(default_factory=dict)
    """Whether each sub-goal's contact holds now, at the frame's last physics step (not latched)."""
    subgoal_gaps: dict[str, float | None] = field(default_factory=dict)
    """Each sub-goal's gap (m) between its two groups' geoms at the end of the frame (``None``: beyond 1 m)."""
    completion: np.ndarray | None = None
    """(2,) the contact completion's blend weight β of each wrist's target at this frame (0: the model's target,
    1: the contact); ``None`` when the targets did not come from :meth:`Simulator.retarget` with completion on."""
    support: FrameSupport | None = None
    """The frame's outside support, foot sliding, penetration and effort (:mod:`~socialaff_sim.sim.support`)."""
