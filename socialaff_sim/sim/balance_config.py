"""Settings of the physics-rate balance controller (:mod:`~socialaff_sim.sim.balance_control`)."""

from __future__ import annotations

from dataclasses import dataclass

from .balance_checks import COM_REFERENCES, SOLVERS, check_balance_config

__all__ = ["BalanceConfig", "COM_REFERENCES", "SOLVERS"]


@dataclass(frozen=True)
class BalanceConfig:
    """A physics-rate balance controller for a robot standing on both feet (see
    :mod:`~socialaff_sim.sim.balance_control`).

    Fields by concept
    -----------------
    - Tracking: joint_bandwidth, torso_bandwidth, torso_bandwidth_roll_free, foot_damping, foot_stiffness
    - Balance: com_bandwidth, com_damping, com_reference, com_shift, shift_weight, shift_until_touch,
      com_plan_velocity, torso_plan_velocity, plan_velocity_until_touch, plan_velocity_raised,
      plan_velocity_tilt, angmom_weight, angmom_bandwidth,
      angmom_root_still, angmom_about_feet,
      support_margin, external_forces, external_filter
    - Contact forces: solver, friction, touch_friction, shear_spread, shear_spread_touched, shear_couple,
      shear_couple_form, shear_couple_touched, w_dynamics, w_feet, w_com, w_torso, w_joint, upper_weight, w_force,
      cop_margin, cop_foot_axes, cop_corner_share, min_foot_load, torque_fraction, flat_feet, yaw_first,
      flat_roll_free
    - Self-collision: self_clearance, clearance_detection, clearance_bandwidth
    - Hands that give way: hand_yield, yield_damping, yield_return, yield_twist, yield_carried
    - Arms on a turned trunk: arm_compensation, compensation_release, compensation_gate,
      hand_task, hand_task_bandwidth, hand_task_touched, hand_task_roll_free,
      hand_task_arm_weight, hand_task_plan_velocity, hand_task_velocity_until_touch
    - Harness: sole_gap, release, release_delay, release_tilt, release_margin, release_settled, release_settled_above,
      release_settled_causal_only, release_settled_raised, release_settled_latch,
      release_settled_until_touch, release_front_catch, release_front_long,
      release_ahead_catch,
      release_tilt_touched, release_tilt_touched_above,
      tilt_from_plan,
      catch_tilt, catch_tilt_lean_roll_free, catch_tilt_lean_touched, catch_margin, catch_blend, catch_follow_feet,
      catch_follow_chair, drive_harnessed
    - Rate: qp_every, hold_gain, hold_near, hold_touch, qp_kernel
    """

    joint_bandwidth: float = 20.0
    """ω_q [rad/s]: the joints' wanted acceleration is q̈* = ω_q² (q_ref − q) + 2 ω_q (q̇_ref − q̇), the IK's
    joint targets and the frame's joint velocity as reference (critically damped)."""
    torso_bandwidth: float = 10.0
    """ω_o [rad/s]: the torso's wanted angular acceleration is ω_o² e − 2 ω_o ω, e the rotation vector (world)
    from its measured attitude to the IK's."""
    torso_bandwidth_roll_free: float | None = None
    """ω_r [rad/s]: ``torso_bandwidth`` on a robot whose feet's roll ``flat_roll_free`` frees (the H1, not Stubby): the
    H1's torso, released, falls past the plan's strike lean (22° for 10°; docs/design.md §5, session 35,
    wip/h1lean). ``None``: ``torso_bandwidth`` on every robot."""
    foot_damping: float = 20.0
    """k_f [1/s]: a planted foot's wanted acceleration (linear and angular) is −k_f times its velocity, plus
    the ``foot_stiffness`` term."""
    foot_stiffness: float = 100.0
    """k_x [1/s²]: ... plus k_x times its displacement (position, and rotation vector) from where it stood when
    the robot came to stand on both feet (a foot that creeps is drawn back; 0: velocity only)."""
    com_bandwidth: float = 6.0
    """ω_c [rad/s]: the centre of mass's wanted horizontal acceleration is ω_c² (c* − c) − 2 ζ ω_c ċ."""
    com_damping: float = 1.0
    """ζ [—]: damping ratio of the centre-of-mass feedback."""
    com_reference: str = "plan"
    """[—]: c*: ``plan`` (the IK's centre of mass relative to its feet, moved onto the physical feet) or ``middle``
    (the middle of the feet's contact points); each is kept ``support_margin`` inside the box."""
    com_shift: float | None = None
    """s_max [m]: with ``com_reference="plan"``, the reference is moved forward by the feet's shortfall along their
    heading (the plan's feet's middle ahead of the physical feet's), at most s_max, and the centre of mass's rows are
    weighted from ``w_com`` up to ``shift_weight`` in proportion (:mod:`~.com_shift`: the body stands where the plan
    has it along the approach, without following feet that land off to the side, and without stiffening the centre
    of mass against the arms where the feet stand where planned). ``None``: no shift."""
    shift_weight: float = 1e4
    """w_s [—]: ``com_shift``: the centre of mass's rows' weight at a shift of s_max."""
    shift_until_touch: bool = False
    """[—]: ``com_shift`` only until an arm first touches the person or the object in the episode (the latch of
    ``compensation_gate``, which it needs): the approach of a contact, not a grasp a person pulls on."""
    com_plan_velocity: bool = False
    """[—]: the centre of mass's damping tracks the plan's velocity over the frame: its wanted acceleration is
    ω_c² (c* − c) + 2 ζ ω_c (v_c − ċ), v_c the change of the plan's centre of mass's offset from its feet over the
    frame divided by its duration (:mod:`~.plan_velocity`). ``False`` (the default): toward rest, − 2 ζ ω_c ċ,
    which brakes a centre of mass the plan moves (traced: Stubby's high fives' strikes, docs/design.md §5)."""
    torso_plan_velocity: bool = False
    """[—]: the torso's damping tracks the plan's angular velocity over the frame: its wanted angular acceleration is
    ω_o² e + 2 ω_o (ω_t − ω), ω_t the plan's torso rotation from the frame's start to its end divided by its
    duration (:mod:`~.plan_velocity`). ``False`` (the default): toward rest, − 2 ω_o ω."""
    plan_velocity_until_touch: bool = False
    """[—]: ``com_plan_velocity`` and ``torso_plan_velocity`` only until an arm first touches the person or the object
    in the episode (the touch latch of ``compensation_gate``, which it needs): the reach toward a contact follows the
    plan's swing; once in contact the damping is toward rest again (traced: the plan's velocities in the contact
    phases of hand overs and catches lengthened the planted feet's slide, docs/design.md §5)."""
    plan_velocity_raised: float | None = None
    """h_r [m]: ``com_plan_velocity`` and ``torso_plan_velocity`` only in a frame whose plan (at the frame's end)
    holds a wrist at least h_r above that arm's shoulder (world heights; may be negative): the strike of a reach above
    the shoulder, not the approach's walk or a reach at the chest's height, whose following of the plan's trunk left
    the robot leaning at the touch and its feet sliding after it (docs/design.md §5). ``None``: in every frame."""
    plan_velocity_tilt: float | None = None
    """θ_v [deg]: ``com_plan_velocity`` and ``torso_plan_velocity`` only at a physics step whose torso tilts at most
    θ_v (from upright, or with ``tilt_from_plan`` from the plan's torso, as ``catch_tilt``); beyond, the damping is
    toward rest: the lean the plan's trunk may bring in a strike is bounded below the harness's catch (traced: strikes
    caught for tilt at the touch, their contact phases then held by the harness, docs/design.md §5). ``None``: no
    bound."""
    angmom_weight: float | None = None
    """w_k [—]: rows for the whole body's angular momentum about its centre of mass in the balance's solve, of this
    weight: its rate toward ω_k (k_ref − k), k_ref the momentum of the plan's velocity over the frame at the posture now
    (:mod:`~.centroidal_momentum`): the floor's moment about the centre of mass takes a swinging arm's reaction,
    not the trunk. ``None``: no such rows."""
    angmom_bandwidth: float = 10.0
    """ω_k [1/s]: ``angmom_weight``: the rate of the momentum's approach to the plan's."""
    angmom_about_feet: bool = False
    """[—]: ``angmom_weight``: the momentum about the feet's contact points' mean (fixed over the step; the whole
    body's tipping over its feet, the centre of mass's motion included) instead of about the centre of mass."""
    angmom_root_still: bool = False
    """[—]: ``angmom_weight``: k_ref of the plan's joint velocities with the root still (the trunk's own turn in the
    plan not asked for); ``False``: of the plan's whole velocity over the frame, the root's included."""
    support_margin: float = 0.03
    """[m]: the centre-of-mass reference is kept this far inside the box of the feet's contact points
    (axes along the robot's heading)."""
    external_forces: bool = False
    """[—]: Whether the contact forces of the person, the object and the chair on the robot (measured at the
    previous step, :mod:`~socialaff_sim.sim.external_force`) enter the inverse dynamics as known loads and move
    the centre-of-mass reference so that their moment is carried by the feet (c* − p = (−M_y, M_x) / (m g), M
    their moment about the reference's point p on the floor: a robot pulled forward leans back)."""
    external_filter: float = 0.05
    """[s]: time constant of the low-pass filter on the measured external forces."""
    solver: str = "lsq"
    """[—]: ``lsq`` (weighted least squares, the torques clipped at their limits by MuJoCo afterwards) or ``qp``
    (a quadratic program: the root's rows, the torque limits and each foot's centre of pressure hold as
    constraints; ``w_dynamics`` is then unused)."""
    friction: float = 0.7
    """μ [—]: friction coefficient of the contact forces' linearised cones (the floor's is 1)."""
    touch_friction: float | None = None
    """μ_t [—]: the cones' friction coefficient once an arm has touched the person or the object in the episode
    (the latch :attr:`~socialaff_sim.sim.arm_compensation.ArmCompensation.touched`; needs ``arm_compensation`` and
    ``compensation_gate``); before the first touch ``friction``. A lower bound on each planned contact's
    tangential-to-normal ratio keeps the shear off the lightly loaded corners of a sole that rocks in a pull
    (traced: a sole on one corner carried 0.5–0.7 of its load as shear and slipped; docs/design.md §5, issue 25,
    session 34, wip/pullslip). ``None``: ``friction`` throughout."""
    shear_spread: float | None = None
    """w_s [—]: ``qp``: a cost ½ w_s Σ_p ‖t_p − t̄‖² on the planned contact forces' horizontal components t_p about
    their mean t̄ over the feet's contact points (forces divided by the robot's mass, m/s², as ``w_force``'s;
    :mod:`~.shear_spread`): the feet's opposed shears (a sideways squeeze, a turn about the vertical) cost w_s, the
    net horizontal force nothing more (traced: Stubby's pull-ups' soles slip on an edge under the QP's own opposed
    shears, docs/design.md §5, issue 25, session 35, wip/pullslip2). ``None``: no such cost."""
    shear_spread_touched: bool = False
    """[—]: ``shear_spread``'s cost only once an arm has touched the person or the object in the episode (the latch
    ``touch_friction`` reads; needs ``arm_compensation`` and ``compensation_gate``): a high five's strike, before the
    touch, as without it. ``False``: at every solve."""
    shear_couple: float | None = None
    """w_c [—]: ``qp``: a cost ½ w_c (n · s)² on the two feet's planned shear resultants' internal split
    s = (T₁ − T₀)/2 across the line between the feet (n: its horizontal normal; forces divided by the robot's mass,
    m/s², as ``shear_spread``'s; :func:`~.shear_spread.shear_couple_cost`): the feet's couple about the vertical,
    the larger part of the split traced in Stubby's pull-ups (docs/design.md §5, issue 25, session 35, wip/pullslip2
    and wip/pullslip3). A net force shared by the feet and the shear's distribution within a foot cost nothing.
    ``None``: no such cost."""
    shear_couple_form: str = "couple"
    """[—]: what ``shear_couple`` prices (:func:`~.shear_spread.shear_couple_cost`): ``"couple"``: the split across
    the feet's line; ``"split"``: the whole split ‖s‖² (the squeeze along the line too); ``"moment"``: the floor's
    whole moment about the vertical through the feet's midpoint over their distance (each sole's torsion too)."""
    shear_couple_touched: bool = False
    """[—]: ``shear_couple``'s cost only once an arm has touched the person or the object in the episode (the latch
    ``touch_friction`` reads; needs ``arm_compensation`` and ``compensation_gate``). ``False``: at every solve."""
    w_dynamics: float = 1000.0
    """[—]: weight of the equation of motion's unactuated rows (root) in the least squares (nearly hard)."""
    w_feet: float = 30.0
    """[—]: weight of the planted feet's acceleration rows."""
    w_com: float = 100.0
    """[—]: weight of the centre of mass's horizontal acceleration rows."""
    w_torso: float = 0.3
    """[—]: weight of the torso's angular acceleration rows."""
    w_joint: float = 1.0
    """[—]: weight of each joint's acceleration row."""
    upper_weight: float = 1.0
    """[—]: factor on ``w_joint`` for the joints above the torso (arms, head): below 1 their tracking gives way
    to the balance first."""
    w_force: float = 1e-3
    """[—]: weight of the contact forces' regularisation (forces divided by the robot's mass)."""
    cop_margin: float = 0.01
    """[m]: ``qp``: each foot's centre of pressure is kept this far inside its sole (along the heading's axes;
    within the foot's contact points in any case)."""
    cop_foot_axes: bool = False
    """[—]: ``qp``: each foot's centre-of-pressure interval (``cop_margin``) is taken along that foot's
    own forward and left axes (:mod:`~.foot_cop`) instead of the support box's (the feet's mean heading): a foot
    turned by ψ from the heading projects wider than its sole, and near the sole's ends the box's interval reaches its
    long edges (``False``: the box's axes)."""
    cop_corner_share: float | None = None
    """λ [—]: ``qp``: each planted foot's centre of pressure is also kept where a rigid sole on four equal corner
    springs loads every corner with at least this share of the foot's load (a diamond |X| + |Y| ≤ 1 − 4λ in
    half-extents along the foot's own axes, :mod:`~.sole_corners_load`): inside the box's corners the far corner
    unloads and the foot rocks on one (``None``: the box's rows only)."""
    min_foot_load: float = 0.05
    """[—]: ``qp``: each planted foot in contact pushes on the floor with at least this fraction of the robot's
    weight (an unloaded foot lifts off by a hair and its contacts flicker)."""
    flat_feet: bool = False
    """[—]: ``qp``: every planted foot on the floor stands flat on its whole sole (:mod:`~.flat_feet`): the QP's
    contact points are the sole's four corners (the centre-of-pressure bounds then span the whole sole) and the
    foot's acceleration toward where it stood, level, is a hard constraint (``False``: the live contact points, and
    the feet's task in the objective toward the attitude they came down in)."""
    yaw_first: bool = False
    """[—]: ``flat_feet``: where the QP cannot hold the feet's hard rows together with the torque limits, the two rows
    of the feet's turn about the vertical are dropped first (the soles' friction and the feet's task in the
    objective then hold it) and the other rows stay hard; only if that fails too are all of them dropped
    (``False``: all at once). On the H1 (legs of five joints: no ankle roll) the first QP failed in a third of the
    driven steps, each solvable without those two rows (docs/design.md §5, "The H1's first balance QP …")."""
    flat_roll_free: bool = False
    """[—]: ``flat_feet``: a foot whose leg has fewer than six joint degrees of freedom from the root (the H1's five:
    no ankle roll) is held by its hard rows except its roll about its own forward axis, which its feet's task in the
    objective (``w_feet``) then holds: all six over-constrain such a leg, and the QP met them by pitching the H1's
    trunk at 100–190 rad/s² against its torso task in the 0.1 s after a release (docs/design.md §5, "The H1's trunk
    pitched by its feet's hard rows …"). Legs of six or more: unchanged. ``False``: all six rows for every foot."""
    self_clearance: float | None = None
    """d_min [m]: ``qp``: the forearms and hands are kept this far from the rest of the robot (and from each other)
    by hard rows of the QP (:mod:`~.self_clearance`: a critically damped barrier on each close pair's distance);
    ``None``: no such rows (the arms then trail their references as the balance allows, and may swing into the
    body: Stubby's forearms into its pelvis, 2.1–2.8 cm deep, with ``flat_feet``)."""
    clearance_detection: float = 0.1
    """[m]: a pair of geoms farther apart than this gets no row of ``self_clearance``."""
    clearance_bandwidth: float = 30.0
    """ω_s [rad/s]: the barrier d̈ ≥ −2 ω_s ḋ − ω_s² (d − d_min) of ``self_clearance``: a pair entering
    ``clearance_detection`` − d_min away stops short of d_min if it approaches at most ω_s times that (30 rad/s,
    9 cm: 2.7 m/s)."""
    hand_yield: float | None = None
    """κ [—]: the arms give way while the horizontal force of the person or object on them exceeds κ times the
    force the feet can carry at that height (F_feet = W (e − m − ξ·u) / h, :mod:`~.hand_yield`): each wrist's
    reference moves along the force on its arm (a force-limited grasp). ``None``: the arms track their
    references whatever pushes them (a pull-up's 50–145 N at Stubby's hands tips it over its heels)."""
    yield_damping: float = 50.0
    """b [N·s/m]: a wrist gives way at (|f| − κ F_feet) / b along the force (25 N over the allowance: 0.5 m/s; a
    person's hand that keeps coming at v is met with b·v over the allowance)."""
    yield_return: float = 1.0
    """τ [s]: while the force is within the allowance, a wrist's offset returns as ȯ = −o / τ."""
    yield_twist: float | None = None
    """σ [m]: ``hand_yield``: the feet's allowance is also at most the force whose moment about the vertical through
    the support box's middle is σ W (W the weight; :func:`~.hand_yield.twist_allowance`): the arms give way to a
    person's push across the robot before it twists the feet on the floor (traced, a handshake's 20–60 N sideways at
    the hand twisted Stubby by a median 14.5 N·m, and its planted feet turned 17°). ``None``: tipping alone."""
    yield_carried: bool = False
    """[—]: ``hand_yield``: while the person still carries the object (before its release the recorded track holds
    it), the object's forces on the robot, its grip welds' and its contacts', count as the person's
    (:meth:`~.hand_yield.HandYield.measure`): the person holds the robot's hand through the object (traced, a hand
    over's cup gripped while the person's track still moved it pulled Stubby's hand by 15–77 N and twisted it
    about its feet by up to 46 N·m, and 85–92 % of the contact phase's foot slide fell before the release).
    ``False``: the person's own contacts only."""
    arm_compensation: float | None = None
    """c [—]: the arms' hinge references move, at each driven step, by c times the damped least-squares step that
    puts each wrist, on the trunk as it is, where the plan's wrist is in the world (:mod:`~.arm_compensation`: a
    released trunk rolled or pitched 5–11° off the plan by an arm's swing moves the hand 10–30 cm from the plan's).
    ``None``: the arms track their joint references on whatever the trunk does (Stubby's hand then stops short of
    a high five, and the contact completion's reach gate shuts)."""
    compensation_release: float = 20.0
    """F_r [N]: ``arm_compensation`` fades out linearly as the person's force on that arm reaches F_r (in a grasp
    the hand is where the person holds it; the hands' give, ``hand_yield``, decides there)."""
    compensation_gate: float | None = None
    """d_g [m]: ``arm_compensation`` confined to the approach of a contact: an arm is compensated only while its
    plan's wrist is within d_g of a geom of the person or of the free object (their centres) and until that arm
    first touches the person or the object in the episode (``inf``: the touch alone ends it). ``None``: ungated (an
    arm is compensated until the person's force on it reaches ``compensation_release``, a held pull-up too)."""
    hand_task: float | None = None
    """w_h [—]: each wrist's world position as a task of this weight in the balance QP, toward the plan's wrist at
    the frame's end (:mod:`~.hand_task`: the QP otherwise tracks joint angles, and a released trunk carries the hand
    10–30 cm off the plan's). ``None``: no such task."""
    hand_task_bandwidth: float = 10.0
    """ω_h [rad/s]: ``hand_task``'s bandwidth: the wanted wrist acceleration ω_h² (x* − x) − 2 ω_h ẋ."""
    hand_task_touched: bool = False
    """[—]: ``hand_task`` only for an arm that has touched the person or the object (the compensation's touch latch;
    needs ``arm_compensation`` and ``compensation_gate``). ``False``: both arms throughout."""
    hand_task_roll_free: bool = False
    """[—]: ``hand_task`` only for a robot that ``flat_roll_free`` changes (a foot whose leg has fewer than six joint
    degrees of freedom, :func:`~.hand_task.hand_task_wanted`; the H1): the task mends the handshakes the freed roll
    loses, and a robot whose six-joint legs keep all six rows (Stubby) runs as without either (needs ``hand_task`` and
    ``flat_roll_free``). ``False``: ``hand_task`` for every robot."""
    hand_task_arm_weight: float | None = None
    """w_a [—]: the joint rows of the arms ``hand_task`` drives weighted by this factor (on top of ``upper_weight``;
    :func:`~.hand_task.arm_row_scale`): a released trunk off the plan's base makes the arm's joint references and
    its wrist's target disagree, and the arm's joint rows (bandwidth ``joint_bandwidth``) outvote the hand's three
    rows, leaving the wrist 5–10 cm short of its target through a clasp (traced, session 33). Only where the hand
    task runs (with ``hand_task_roll_free``: the H1, not Stubby); needs ``hand_task``, not ``hand_task_touched``.
    ``None``: the arm's rows as the other joints'."""
    hand_task_plan_velocity: bool = False
    """[—]: ``hand_task``'s target velocity ẋ* the planned wrist's mean velocity over the frame, (x*(end) −
    x*(start)) / T (the references' start and their time T to the end): ω_h² (x* − x) + 2 ω_h (ẋ* − ẋ); a strike
    keeps its speed where the wrist's rows (with ``hand_task_arm_weight``) outvote the joints' velocity references
    (needs ``hand_task``). ``False``: the target at rest, ẋ* = 0."""
    hand_task_velocity_until_touch: bool = False
    """[—]: ``hand_task_plan_velocity`` only for an arm that has not yet touched the person or the object (the
    compensation's touch latch; needs ``hand_task_plan_velocity``, ``arm_compensation`` and ``compensation_gate``): a
    clasp or a grasp then holds the plan's wrist at rest. ``False``: the velocity throughout."""
    sole_gap: float = 0.0
    """[m]: a planted foot without contacts whose sole is at most this high above the floor still counts for the
    support box of the harness's decisions (0: only feet in contact; a contact lost for a step then shrinks the
    box to one foot)."""
    torque_fraction: float = 0.98
    """[—]: ``qp``: the torques asked are kept within this fraction of each actuator's limit (``forcerange``,
    the joint's ``actuatorfrcrange``, the control range's reach; a margin under MuJoCo's clip)."""
    release: bool = True
    """[—]: Whether the harness lets go of a robot standing under the controller (``False``: it stays on, and
    the controller drives the joints only if ``drive_harnessed``)."""
    release_delay: float = 0.1
    """[s]: both feet planted and on the floor for this long before the harness may let go."""
    release_tilt: float = 5.0
    """[deg]: the harness lets go only while the torso tilts at most this much from upright."""
    release_margin: float = 0.01
    """[m]: ... and while the capture point c + ċ/ω₀ (ω₀ = √(g / c_z)) lies this far inside the box of the
    feet's contact points."""
    release_front_catch: float | None = None
    """m_f [m]: in a throw (a ``catch`` sub-goal), on a robot whose feet's roll ``flat_roll_free`` frees (the H1), the
    harness lets go only while the capture point also lies m_f behind the support box's front face (docs/design.md
    §5, session 37, wip/h1throw2: let go at the toes, it is caught again). ``None``: off. Needs ``flat_roll_free``."""
    release_front_long: float = 0.0
    """L_f [m]: ``release_front_catch`` only while the box is at least L_f long along the heading (0: always)."""
    release_ahead_catch: float | None = None
    """ρ_a [m]: as ``release_front_catch``, let go only while the capture point lies at most ρ_a ahead of the centre
    of mass along the heading. ``None``: off. Needs ``flat_roll_free``."""
    release_settled: float | None = None
    """ρ [m]: the harness lets go only while the capture point also lies within ρ of the centre of mass
    (|ξ − c| ≤ ρ, horizontal: the centre of mass moving at most ρ ω₀), so that a robot swinging back in the
    harness (after a high five's strike) is not released mid-swing, its centre of mass carried on behind c*
    (traced: docs/design.md §5, issue 25, session 36, wip/stubdef2). ``None``: no such bound."""
    release_settled_above: bool = False
    """[—]: ``release_settled`` only in a task with a contact sub-goal counted above the robot's shoulders (the
    high five); the simulator drops it in any other task."""
    release_settled_causal_only: bool = False
    """[—]: ``release_settled`` only in an episode whose robot is driven by a causal synthesis (the simulator's
    ``causal``); a replay of a recording (ground truth) keeps the release without it."""
    release_settled_raised: float | None = None
    """h_s [m]: ``release_settled`` only in a data frame whose plan (the IK's, at the frame's end) holds a wrist at
    least h_s above that arm's shoulder (world heights; may be negative): the strike of a reach above the shoulder,
    not the walk-up, whose first release the bound otherwise moves (high_five_760, docs/design.md §5, issue 25,
    session 36, wip/stubdef3). With ``release_settled_latch`` from the first such frame on. ``None``: in every frame."""
    release_settled_until_touch: bool = False
    """[—]: ``release_settled`` not after an arm's first touch of the person or the object (the episode's latch of
    ``arm_compensation``): the harness lets go at the touch as without the bound (high_five_752 held through its
    first contact frames, docs/design.md §5, issue 25, session 36, wip/stubdef3)."""
    release_settled_latch: bool = False
    """[—]: with ``release_settled_raised``, the bound acts from the episode's first raised frame to its end (the
    release after the strike's swing, when the plan's wrist may have come down), not only in raised frames."""
    release_tilt_touched: float | None = None
    """θ_t [deg]: in a task with a ``catch`` sub-goal (an object thrown to the robot), on a robot whose flat feet's
    roll ``flat_roll_free`` frees (legs that cannot roll a foot: the H1), after an arm's first touch of the person or
    the object (the compensation's touch latch) the harness lets go while the torso tilts at most θ_t, in place of
    ``release_tilt`` (the harness's ``catch_tilt`` unchanged): the H1, caught by the step it takes toward the ball in
    its flight, leans 5–7° in the harness through the catch, and ``release_tilt`` alone then keeps it held for a third
    of its throws' contact-phase support (traced; docs/design.md §5, issue 25, session 34, wip/h1throw). ``None``:
    ``release_tilt`` throughout. Needs ``flat_roll_free``, ``arm_compensation`` and ``compensation_gate``; at least
    ``release_tilt``, below ``catch_tilt``."""
    release_tilt_touched_above: bool = False
    """[—]: ``release_tilt_touched`` in a task with a contact sub-goal counted above the robot's shoulders (the high
    five: the H1 caught at the strike held past its touch) in place of a task with a ``catch`` sub-goal."""
    tilt_from_plan: bool = False
    """[—]: Whether ``release_tilt`` and ``catch_tilt`` read the torso's angle from the plan's torso attitude (the
    IK's, the controller's goal) rather than from upright: a lean the plan asks for (the H1 reaching with a spine
    that turns about the vertical only) neither keeps the harness on nor makes it catch."""
    catch_tilt: float = 12.0
    """[deg]: a released robot whose torso tilts more than this is caught by the harness again at once."""
    catch_tilt_lean_roll_free: float | None = None
    """κ [—]: on a robot whose feet's roll ``flat_roll_free`` frees (the H1), with ``tilt_from_plan``, the catch's
    tilt bound is ``catch_tilt`` + κ λ, λ the plan's torso lean from upright (deg; the IK's torso, the controller's
    goal): the H1 over-follows the high five's strike lean (rule #45; its torso at ~22° for the plan's 10°, read
    12–13° from the plan) and is caught for tilt at the strike (traced: docs/design.md §5, issue 25, session 35,
    wip/h1lean; session 36, wip/h1hf). ``None``: ``catch_tilt`` throughout (Stubby always)."""
    catch_tilt_lean_touched: bool = False
    """[—]: ``catch_tilt_lean_roll_free`` only after an arm's first touch of the person or the object (the
    compensation's touch latch): the catches before the touch, which hold the H1 on the plan into its reach, stay."""
    catch_margin: float = 0.03
    """[m]: ... as is one whose capture point leaves the contact box by more than this (a fall under way)."""
    catch_blend: float = 0.3
    """[s]: a caught robot is held where it is caught (the harness's anchor at its measured root), and the anchor
    then moves over this time onto the IK's base (0: at once onto the IK's base, which yanks the robot by as
    much as it strayed from the plan while released)."""
    catch_follow_feet: float | None = None
    """d_m [m]: while the harness holds a robot it has caught and a sub-goal's gap at the end of the last data frame
    is at most this (the meeting near), its anchor (the IK's base, or the catch's blend onto it) is shifted
    horizontally by the mean offset of the planted feet's physical ankle frames from their planted targets (as of the
    data frame's start; no shift while neither foot is planted): the harness holds the root over the feet where they
    stand, instead of leading it onto the plan's feet and dragging the planted feet after it (Stubby's pull-ups: 53 %
    of the soles' slip while caught; docs/design.md §5, issue 25, session 36, wip/pullslide). In the walk-up (beyond
    d_m) the harness carries the caught robot along its plan as without it (everywhere, the caught robot is held
    behind its plan and never reaches the person). ``None``: the anchor is the IK's base."""
    catch_follow_chair: bool = False
    """[—]: ``catch_follow_feet`` only in a task whose person sits on a chair at the start (``TaskSpec.chair``: the
    pull-up, where the person's pull drags the caught robot's feet); elsewhere the anchor is the IK's base as without
    it (on spent 672–687 the ungated option raised the high fives' and handshakes' support, +4.4 and +6.3 points, and
    lost shake_hands_675, ``contact_lost``: a robot caught just before a handshake or a strike and held behind its
    plan's feet falls short of the person; wip/pullslide). ``False``: in every task."""
    drive_harnessed: bool = False
    """[—]: Whether the controller's torques drive the joints also while the harness holds a standing robot
    (``False``: the position servos and the standing feed-forward do, as without the controller)."""

    qp_every: int = 1
    """k [steps]: the torques are solved at one driven physics step in k and held on the k − 1 after it
    (:mod:`~socialaff_sim.sim.torque_hold`; a switch of the harness solves again at once). 1: every driven step."""
    hold_gain: float = 1.0
    """g_h [—]: with ``qp_every`` > 1, a held torque is corrected by g_h times the joints' PD (ω_q, the diagonal
    inertias of the solve) on their errors' change since the solve; 0: held as solved."""
    hold_near: float = 0.06
    """d_h [m]: with ``qp_every`` > 1 and ``self_clearance``, nothing is held after a solve in which an arm is
    within d_h of the body (a self-clearance pair's distance), which only a solve keeps clear."""
    hold_touch: bool = False
    """[—]: with ``qp_every`` > 1, nothing is held after a physics step in which anything but the floor touches the
    robot (the person, the object): the torques are then solved at every driven step."""
    qp_kernel: str = "numpy"
    """[—]: how the controller's arithmetic runs with ``solver="qp"``: ``"numpy"`` (the reference) or ``"numba"``
    (the extra ``[fast]``; not bit for bit: its sums run in their own order): the QP's cost and rows in one compiled
    loop (:mod:`~socialaff_sim.sim.qp_kernel`) and, since session 34, the feet's contacts and support box, their tasks
    and flat contacts, the centre-of-pressure rows, the torque bounds, the self-clearance rows and the arms' steps
    (:mod:`~socialaff_sim.sim.compiled_pieces`)."""

    def __post_init__(self) -> None:
        check_balance_config(self)
