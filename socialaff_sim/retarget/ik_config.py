"""Settings of the retargeting IK (:class:`~.ik.RobotIK`): task costs, limits and the per-frame stopping rule."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["IKConfig"]


@dataclass(frozen=True)
class IKConfig:
    """Weights, limits and stopping rule of the retargeting IK.

    Fields by concept
    -----------------
    - Task costs: position_cost, unreachable_weight, base_position_cost, base_orientation_cost,
      foot_orientation_cost, posture_cost, torso_posture_cost
    - Standing balance: support_margin, com_cost, planted_base_cost, planted_foot_cost,
      planted_foot_orientation_cost
    - Damping and stopping rule: damping, max_worsening, damping_growth, max_damping, iterations, tolerance,
      min_progress, patience
    - Collision avoidance: min_distance, contact_depth, detection_distance, self_detection_distance, leg_clearance,
      push_self, collision_gain, collision_slack, backtracks, max_push
    - Speed limits and solver: max_base_speed, max_base_turn, solver
    """

    position_cost: float = 1.0
    """[1/m]: Cost of a wrist's or an ankle's position error (per metre)."""
    unreachable_weight: float = 0.3
    """[—]: Factor on the position cost of a target the caller marks out of reach (``care``)."""
    base_position_cost: float = 5.0
    """[1/m]: Cost of the base's position error (per metre): the robot stands where it is placed, and a
    wrist out of reach does not drag it along."""
    base_orientation_cost: float = 2.0
    """[1/rad]: Cost of the base's orientation error (per radian)."""
    foot_orientation_cost: float = 0.05
    """[1/rad]: Cost of each foot's orientation error (per radian)."""
    posture_cost: float = 0.01
    """[1/rad]: Cost of departing from the home posture (per radian)."""
    torso_posture_cost: float = 0.5
    """[1/rad]: Cost of departing from the home posture (per radian) of the spine's joints
    (``IKModel.torso_dofs``): above ``posture_cost`` it keeps the torso upright rather than leaning it toward
    a target. At 0.01 (the posture cost) Stubby's torso leaned 20–26° in the contact phases of
    shake_hands_000 and pull_up_000; at 0.1, 7° (high_five_000: 2°), every sub-goal still met. At 0.3 (6–9°)
    two wrist targets of a catch (throw_catch instance 3) ended 3.2 cm off: the torso's lean is part of the
    reach. With a centre-of-mass task (``com_cost`` = 10) the torso leans back to carry the centre of mass
    over the feet: at 0.1 the largest tilt per contact phase had a median of 18° (Stubby, 2 instances of
    each interaction); at 0.5, 4° with every sub-goal met (0.3: 6°; 1.0: 4°, one handshake lost)."""
    support_margin: float | None = 0.03
    """[m]: While both feet are planted, the centre of mass may not leave the support rectangle (the feet's
    horizontal extent at home, placed at the planted ankles) shrunk by this much on every side
    (:class:`~.support_limit.SupportPolygonLimit`, a limit of the QP); ``None``: no such limit."""
    com_cost: float = 0.0
    """[1/m]: Cost of the horizontal distance (per metre) between the centre of mass and the centre of the
    support polygon while both feet are planted (:class:`mink.ComTask`, no cost on its height); 0: no such
    task (the default; ``support_margin`` keeps the centre of mass over the feet). The centre: the middle of
    the planted ankle targets plus the offset of the centre of mass from the ankles' middle at home (where
    the robot stands balanced), turned with the robot. A 0.75 m reach of both arms keeps Stubby's centre of
    mass within 1 cm of it at 10 (13 cm forward without), at the price of 11 cm of reach. At 10 the harness
    carried 28 % of Stubby's weight in the contact phases instead of 34 % (2 synthetic instances per
    interaction), but on a real handover (handover_h2h motion_normal_1) the wrists met their reachable targets
    in 79–82 % of the frames instead of 98–100 % (73 % of all key-frame targets within 2 cm instead of 94 %);
    at 1 and 3, the same."""
    planted_base_cost: float = 0.5
    """[1/m]: Cost of the base's horizontal position error (per metre) while the centre-of-mass task is active
    (``com_cost`` > 0 and both feet planted): the hips may move to carry the centre of mass over the feet (with ``com_cost`` = 10 and this at
    ``base_position_cost``, 5, 6 of 10 Stubby episodes met every sub-goal instead of 10)."""
    planted_foot_cost: float = 50.0
    """[1/m]: Cost of a planted foot's position error (per metre), replacing ``position_cost``: a planted foot
    is pinned where it came down (the caller says which feet are planted)."""
    planted_foot_orientation_cost: float = 5.0
    """[1/rad]: Cost of a planted foot's orientation error (per radian): flat on the floor."""
    damping: float = 1e-4
    """[—]: Levenberg-Marquardt damping of the QP."""
    max_worsening: float | None = 0.01
    """[—]: A QP step after a frame's first that raises the key frames' root-mean-square position error,
    weighted by their costs (a target out of reach at ``unreachable_weight``), by more than this,
    metres, is undone, and the next one taken with ``damping_growth`` times the damping (two hands
    closing on a ball 2–3 cm apart can otherwise trade places step after step, the collision
    avoidance between them pushing one off as the other arrives); ``None``: no step is undone."""
    damping_growth: float = 10.0
    """[—]: Factor on the damping after an undone step (and its inverse after a kept one, down to ``damping``)."""
    max_damping: float = 10.0
    """[—]: Most damping the growth reaches."""
    iterations: int = 30
    """[—]: Most QP steps per data frame (taken only while a target within reach is off by more than
    ``tolerance``)."""
    tolerance: float = 0.01
    """[m]: Stop once every key frame is this close to its target, metres."""
    min_progress: float = 0.001
    """[m]: Progress that counts: a step that brings the largest error among the targets worth it this much
    below the smallest so far this frame, metres."""
    patience: int = 6
    """[—]: Also stop after this many steps in a row without progress (a limit or the collision avoidance
    holds the frame back)."""
    min_distance: float = 0.01
    """[m]: Distance collision avoidance keeps between the robot and the person, metres."""
    contact_depth: float | None = 0.05
    """[m]: How far a hand or forearm may press into the person where the task wants them to touch,
    metres (``None``: no limit there; physics alone resolves the contact)."""
    detection_distance: float = 0.1
    """[m]: Distance below which a robot-person geom pair enters the QP, metres."""
    self_detection_distance: float = 0.05
    """[m]: Distance below which a pair of robot geoms (a forearm or hand and the rest, or a geom of each leg)
    enters the QP, metres."""
    leg_clearance: float | None = 0.01
    """d_legs [m]: Distance the IK keeps between each geom of the left leg and each of the right leg (the
    subtrees of the robot's hip limb roots: thighs, shins, feet), metres; a pair found closer is pushed apart
    (at most ``max_push`` per step). ``None``: the legs may pass through each other. The ankle targets come
    from the recorded person, whose ankles may be close or crossed (a step, tracking noise): without this limit
    Stubby settled with its feet inside each other on 56 of the 150 recorded handovers (2.7 cm deep in the
    median, 9.2 cm at most), 35 of them failing with ``self_collision`` on the first step; with it, on none
    (docs/robots.md, "Feet apart")."""
    push_self: bool = False
    """[—]: Whether a forearm or hand found inside the rest of the robot is pushed back out (at most
    ``max_push`` per step), as the legs are; ``False`` (the default): held where it is (its rows only forbid
    going deeper, and they are linear). Held, a forearm creeps into the torso over the reset's settle, whose QP
    steps are a whole second long, by a few millimetres per solve: 3.3 cm deep for Stubby on SBU
    s04s02_07_001, 4–5 cm for the H1 on four SBU and handover recordings, each failing with ``self_collision``
    on its first step; pushed, none of these (docs/robots.md, "Feet apart"). Not the default: pushed, Stubby's
    torso tilted 11.0° in the catch of throw_catch_000 with ``SimConfig.stance`` (the stance test's bound is
    10°), and its effect on the other figures was not measured."""
    collision_gain: float = 0.85
    """[—]: Fraction of the remaining gap a pair may close per step."""
    collision_slack: float = 0.003
    """[m]: A QP step that leaves a collision pair more than this inside its limit, where it was not before
    the step, is solved again with that pair in the QP, metres (the QP sees only pairs within the
    detection distance: a long step can pass a hand through the thigh)."""
    backtracks: int = 3
    """[—]: Most re-solves of such a step, then most halvings before it is dropped (0: no check)."""
    max_push: float = 0.02
    """[m]: Most a step moves the robot's trunk and legs back out of a person who has moved into them, metres."""
    max_base_speed: float = 2.0
    """[m/s]: Speed limit of the floating base's translation, m/s (bounds each QP step to this times dt)."""
    max_base_turn: float = 3.0
    """[rad/s]: Speed limit of the floating base's rotation, rad/s (bounds each QP step to this times dt)."""
    solver: str = "daqp"
    """[—]: QP solver name understood by qpsolvers."""
