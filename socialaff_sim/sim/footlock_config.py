"""The foot lock's settings (:class:`FootLockConfig`): when an ankle target counts as standing, and the options
that plant, hold or step a foot near a meeting. The lock itself is :class:`~.footlock.FootLock`."""

from __future__ import annotations

from dataclasses import dataclass, replace

from ..errors import ConfigError

__all__ = ["FootLockConfig"]


@dataclass(frozen=True)
class FootLockConfig:
    """When an ankle target counts as standing."""

    lift: float = 0.04
    """h_lift [m]: a target at most this far above the ankle's home height may be planted."""
    radius: float = 0.05
    """r [m]: a planted foot stays put while its target stays within this horizontal distance of where it was
    planted; beyond, the foot steps (the target is followed again)."""
    hold_lift: float | None = None
    """h_hold [m]: a foot already planted stays planted while its target is at most this far above the ankle's
    home height (and within ``radius``): a recorded heel or toe rise of a person leaning into a pull is not a
    step. ``None``: ``lift`` (no hysteresis). At least ``lift``."""
    hold_in_contact: bool = False
    """[—]: While a sub-goal's contact held at the end of the last frame (the robot holds the person's hand), a
    foot planted stays planted wherever its target goes: the robot does not step while it holds on (the recorded
    helper of a pull-up steps back to keep the arms taut; a robot whose hands give way,
    ``BalanceConfig.hand_yield``, needs no step). ``False``: the targets decide as at any other time."""
    hold_near: float | None = None
    """d_n [m]: with ``hold_in_contact``, while a sub-goal's gap at the end of the last frame is at most this (the
    hands about to meet, or just parted in a contact that flickers), a planted foot whose target moves away from the
    person (its horizontal displacement from where it stands points away from the person's key joints' mean) stays
    planted; a step toward the person is taken as without the option. The recorded helper of a pull-up steps back
    around the grip "to keep the arms taut", and a step is a catch of the harness (docs/design.md §5, issue 25,
    session 33, wip/h1pull). ``None``: only a contact that holds keeps the feet planted. Nothing without
    ``hold_in_contact``."""
    hold_near_roll_free: bool = False
    """[—]: ``hold_near`` only on a robot whose flat feet's roll the balance controller frees
    (``BalanceConfig.flat_roll_free`` on legs that cannot roll a foot: the H1, not Stubby; as
    ``hand_task_roll_free``). ``False``: on every robot."""

    hold_step_gap: float | None = None
    """d_s [m]: while a sub-goal's gap at the end of the last frame is at most this (the hands or the object about to
    meet, in a contact, or just parted), a planted foot does not step: a target that leaves ``radius`` or rises above
    the planted bound plants the foot at once at the target's horizontal point (at the home ankle height), as a glide
    is planted without ``glide_step``, and no glide steps. The plan steps, the foot stays planted: the balance
    controller holds the physical foot where it stands and carries the centre of mass toward the plan's (its
    reference, with ``com_shift`` the feet's shortfall), and the harness catches no step. A robot on a 3 cm sole
    cannot take a quick step without the harness catching it: on the H1 the catch of a recorded step at the meeting
    held 8.5 of the high fives' 16.3 points (docs/design.md §5, issue 25, session 35, wip/h1hold). ``hold_near``'s
    backing steps are held where they stand as without it. ``None``: the targets decide. ``hold_near_roll_free``
    drops it with ``hold_near`` (on Stubby)."""
    hold_step_gap_glide: bool = False
    """[—]: ``hold_step_gap`` kept on a robot whose feet's roll is not freed (Stubby, where ``hold_near_roll_free``
    drops it) in an episode where ``glide_gap_far`` or ``glide_gap_caught`` act (after ``glide_gap_causal_only`` and
    ``glide_gap_above``: a causal high five). The smaller glide gaps keep a synthesized high five's feet up with its
    plan, but their extra glide steps fall also in the last half metre before the touch, where a step is a catch of
    the harness (or restarts its release's delay) and the robot is then held through the touch at 40–100 % of its
    weight (high_five_753, 756; docs/design.md §5, issue 25, session 37, wip/stubhf); within ``hold_step_gap`` of
    the meeting no foot steps. Needs ``hold_step_gap``; nothing on Stubby without ``glide_gap_far`` or
    ``glide_gap_caught``, nothing on a robot whose feet's roll is freed (it has ``hold_step_gap`` anyway). ``False``:
    ``hold_near_roll_free`` drops ``hold_step_gap`` on such a robot in every episode, as without it."""
    hold_step_ahead: float | None = None
    """k [frames]: with ``hold_step_gap`` d_s, a planted foot also does not step while a sub-goal's gap, extrapolated
    k frames ahead from its last two frames' ends (g₁ − k·(g₀ − g₁), g₀ the earlier: a closing gap's is nearer),
    is within d_s: a strike whose gap closes faster than d_s per frame (the H1's high_five_794: 0.83, 0.50, then
    0.02 m, its step at the meeting caught by the harness into its lone contact frame) is held as one already within
    it (docs/design.md §5, issue 25, session 37, wip/h1hf3). Nothing without ``hold_step_gap``; dropped with it (on
    Stubby, by ``hold_near_roll_free``). ``None``: off, the last frame's gap alone decides."""
    hold_step_ahead_above: bool = False
    """[—]: ``hold_step_ahead`` only in a task whose contact counts above the shoulders (the high five's strike);
    elsewhere dropped (:meth:`for_episode`). On the H1's spent 720–735 the pull-ups' steps it held raised their
    support. ``False``: in every task."""
    hold_step_caught: float | None = None
    """d_c [m]: while the harness holds a robot it has caught
    (:attr:`~socialaff_sim.sim.harness_release.HarnessRelease.holds_caught`) and a sub-goal's gap at the end of the
    last frame is at most this, a planted foot does not step, as within ``hold_step_gap``: the plan steps, the foot
    stays planted. A caught robot whose plan steps a foot forward near the meeting (the recorded helper's step) is led
    by the harness onto its plan while its other foot, planted, is dragged along the floor (pull_up_561: 15 cm;
    docs/design.md §5, issue 25, session 36, the lead; wip/pullslide). Not dropped by ``hold_near_roll_free`` (meant
    for Stubby). ``None``: off."""
    hold_step_flight: int | None = None
    """L_f [frames]: in a task with a ``catch`` sub-goal (a thrown object), from this many frames before the frame in
    which the person lets go of the object (0: from that frame; negative: after it) to the episode's end, a planted
    foot does not step, as within ``hold_step_gap``: the plan steps, the foot stays planted (the caller passes
    ``flight``, :meth:`FootLock.in_flight`). The recorded catcher steps toward the ball in its flight, 0–9 frames
    after the release and 0–10 before the touch, at gaps beyond ``hold_step_gap``; on the H1 a step is a catch of the
    harness, which holds the landed robot into the catch. Held steps lose the reach: on spent H1 throws 560–591 with
    L_f = 0 the catches fell from 25 to 7 of 32 (the hands 2–28 cm short of the ball; docs/design.md §5, issue 25,
    session 36, wip/h1throw; not adopted). ``None``: off. ``hold_near_roll_free`` drops it with ``hold_near`` (on
    Stubby)."""
    hold_step_flight_after: int = 0
    """n_f [steps]: with ``hold_step_flight``, the flight's hold begins only once this many steps (a planted foot
    unplanted, glide steps included) have begun since its first frame: the first n_f steps toward the ball are taken
    as recorded, later ones are planted in the plan at once. 0: from the flight's first frame."""
    land_gap: float | None = None
    """d_l [m]: while a sub-goal's gap at the end of the last frame is at most this (the hands about to meet, in
    contact, or just parted), a foot that is not planted at a frame's start is put down at its target's horizontal
    point (on the floor, at the home ankle height) whatever its target's height: a step near the grip lasts one
    frame. The recorded helper of a pull-up lifts a foot 4–10 cm for 4–7 frames just before and in the grip, and the
    harness holds the robot throughout a step and its release's delay after it, into the contact phase
    (docs/design.md §5, issue 25, session 34, wip/h1pull2). ``None``: a foot is put down only once its target is
    within ``lift``. ``hold_near_roll_free`` drops it with ``hold_near`` (on Stubby)."""
    glide_step: float | None = None
    """h_g [m]: a planted foot whose target leaves ``radius`` without rising above ``lift`` (a glide) steps for
    one frame, its target the new point raised by this, instead of being planted there at once; one foot at a
    time and only while the other stands (of two gliding feet the one farther from where it stands steps; the
    other is held where it stands until its partner has landed). ``None``: planted at the new point at once (a
    balance controller then holds the physical foot where it stood: the demo's pull-up stood 53–63 cm behind its
    plan; docs/design.md §5). Not while a contact holds with ``hold_in_contact``. ``SimConfig.standing()``: 0.05,
    with ``glide_until_contact`` and ``glide_gap`` 0.12 m."""
    glide_gap: float | None = None
    """d_g [m]: with ``glide_step``, a glide steps only while its physical ankle frame stands farther than this
    (horizontally) from the new point; nearer, it is planted at once (a standing foot's creep of a few centimetres
    is left to the balance controller, which holds the foot where it stands). ``None``: wherever it stands."""
    glide_gap_far: float | None = None
    """d_gf [m]: with ``glide_step``, while no sub-goal's gap at the end of the last frame is within ``glide_far``
    (the walk-up: the hands or the object still far apart, or no gap measured yet), a glide steps when its physical
    ankle frame stands farther than this from the new point, in place of ``glide_gap``; within ``glide_far`` of a
    meeting ``glide_gap`` decides as without it. A smaller gap in the walk-up keeps the feet up with a plan's late
    approach (the standing demo's synthesized high five: the plan's feet 9–13 cm ahead of the physical ones at the
    strike, within ``glide_gap`` 0.12), and none of its extra steps lands just before the touch, where a step is a catch
    of the harness (high_five_146 with ``glide_gap`` 0.06; docs/design.md §5, issue 25, session 35, wip/hfwalk).
    ``None``: ``glide_gap`` throughout."""
    glide_far: float = 0.15
    """d_f [m]: with ``glide_gap_far`` or ``glide_gap_caught``, the sub-goals' gap above which (every measured gap) the
    walk-up's gap d_gf applies, and at or below which (any gap) the caught robot's d_gc does."""
    glide_gap_caught: float | None = None
    """d_gc [m]: with ``glide_step``, while some sub-goal's gap at the end of the last frame is within ``glide_far``
    (the meeting near) and the harness holds a robot it has caught
    (:attr:`~socialaff_sim.sim.harness_release.HarnessRelease.holds_caught`), a glide steps when its physical ankle
    frame stands farther than this from the new point, in place of ``glide_gap``: a held robot's step costs no catch and
    brings its feet up with a plan that approaches late (the standing demo's synthesized high five is held through its
    strike, its feet 9–13 cm behind the plan's), while a released robot near the meeting steps only beyond
    ``glide_gap`` (a step just before the touch is a catch: high_five_132, 146). ``None``: ``glide_gap``."""
    glide_gap_causal_only: bool = False
    """[—]: ``glide_gap_far`` and ``glide_gap_caught`` act only in episodes whose source is causal (declares
    ``placement_frames``, as the model's synthesis does: its walk-up glides its feet along the floor with its base),
    not on a recording's replay, whose feet step (the simulator drops them there; as ``SimConfig.plan_feet_causal_only``
    does ``restep_gap``). On ground truth they cost high fives: the feet kept up with the plan, the released body lags
    behind them at the strike and is caught backward (high_five_241, 530; docs/design.md §5, session 35, wip/hfwalk).
    ``False``: on every source."""
    glide_gap_above: bool = False
    """[—]: ``glide_gap_far`` and ``glide_gap_caught`` act only in a task with a contact sub-goal counted above the
    robot's shoulders (``SubgoalSpec.above``: the high five; the simulator drops them in any other task, as
    ``plant_caught_above`` does ``plant_caught``): the smaller gaps keep a synthesized high five's feet up with its
    plan's late approach to a raised palm (the standing demo's, met with them), while a hand over's, a throw's and a
    handshake's walk-ups, which lost successes and support with them (high_five aside, rule #52 on 640–647), keep
    ``glide_gap``. ``False``: in every task (docs/design.md §5, issue 25, session 36, wip/stubdef)."""
    restep_gap: float | None = None
    """d_r [m]: with ``glide_step``, a planted foot whose physical ankle frame stands farther than this
    (horizontally) from the point it is planted at (a glide step that landed short: the balance controller then
    holds it where it stands, behind its plan) steps again, as a glide does, toward its target; under the same
    conditions (one foot at a time, the other standing; with ``glide_until_contact`` only until the first
    contact). ``None``: it stays where it landed (a synthesized walk-up's feet end 15–30 cm behind the plan's,
    docs/design.md §5)."""
    restep_above: bool = False
    """[—]: ``restep_gap`` only in a task whose contact counts above the shoulders (the high five); elsewhere dropped
    (:meth:`for_episode`). On the H1's spent 784–799 and 720–735 it re-stepped the high fives' walk-ups whose last
    steps landed 32–37 cm short (the harness then held the root at the plan, the capture point outside the feet's
    box, into the contact frames) and raised the hand overs' support (docs/design.md §5, session 37, wip/h1hf3).
    ``False``: in every task."""
    restep_roll_free: bool = False
    """[—]: ``restep_gap`` only on a robot whose flat feet's roll the balance controller frees (the H1, not Stubby; as
    ``hold_near_roll_free``). ``False``: on every robot."""
    restep_chair: float | None = None
    """d_c [m]: in a task whose person sits on a chair at the start (``TaskSpec.chair``: the pull-up), on a robot whose
    flat feet's roll the balance controller does not free (Stubby), ``restep_gap`` = d_c whatever its own gates say
    (a walk-up's foot left d_c behind its planted point steps again until the first contact); elsewhere dropped, and
    ``restep_gap`` as its gates say (:meth:`for_episode`). Stubby's pull-ups' walk-up drags a sole left 20–40 cm
    behind onto its toe (docs/design.md §5, session 38, wip/pullwalk2). ``None``: no such re-step."""
    glide_until_contact: bool = False
    """[—]: With ``glide_step``, glides step only until a sub-goal's contact first holds in the episode (the walk-up);
    afterwards they are planted at once as without ``glide_step``."""
    plant_caught: bool = False
    """[—]: With ``glide_step``, while the harness holds a robot it has caught (any of the balance controller's
    catches: a step, the torso's tilt, the capture point off the soles; until it lets the robot go again,
    :attr:`~socialaff_sim.sim.harness_release.HarnessRelease.holds_caught`) a glide is planted at once as without
    ``glide_step`` (and a short foot of ``restep_gap`` is not stepped again): the caught robot stands in the harness,
    which carries it along its plan as in the harness mode, instead of stepping against it, and is let go again
    once steady. ``False``: glides step whatever holds the robot (traced, the standing demo's synthesized high five:
    caught in the walk-up, it glide-stepped every other frame, so the release's delay never elapsed, and the last
    step's landing swung the held body 17 cm past its plan and back 20 cm in the strike; docs/design.md §5). An option,
    off: it mends that high five, but its rule (instances 200–207, synthesized) did not hold: support +3.4 points
    [−7.7, +12.3], slide +1.3 cm [−0.5, +3.2], successes 37 → 35 (the pull-ups' glides after a catch bring their feet
    under the plan)."""
    plant_caught_above: bool = False
    """[—]: With ``plant_caught``, only in a task with a contact sub-goal counted above the robot's shoulders
    (``SubgoalSpec.above``: the high five); elsewhere glides step whether caught or not, as without ``plant_caught``
    (the simulator drops the option for such a task: a caught pull-up's walk-up glides, which bring its feet under
    its plan, and a throw's catch are left as they are; docs/design.md §5). ``False``: in every task. An option,
    off: the standing demo's high five is met with it, but its rule (instances 336–343) did not hold: high fives won
    (synthesized 35 → 37 successes) by holding the caught robot, support +2.3 points [−1.6, +8.5], slide +0.38 cm
    [+0.00, +0.92]."""
    glide_step_frames: int = 1
    """n_g [frames]: with ``glide_step``, a glide step lasts this many data frames: the foot stays lifted (not
    planted, its target the glide's latest point raised by ``glide_step``, the other foot held where it stands) for
    n_g frames and is put down after them, so the swing has n_g frames to carry the physical foot to where the plan
    puts it (traced, the standing demo's high five: one-frame steps landed short, the caught body stood ahead of its
    soles and the harness never let go; docs/design.md §5). 1: one frame, as without it. An option, off: with 3
    the standing demo's high five is met, but held by the harness at the meeting (75 % of its weight), and on
    development it gains no high fives (synthesized 39 → 39 of 64, ground truth 44 → 43; no rule run)."""

    def __post_init__(self) -> None:
        if not (self.lift >= 0.0 and self.radius >= 0.0):
            raise ConfigError(f"FootLockConfig: expected lift ≥ 0 and radius ≥ 0 in metres, found {self.lift}, {self.radius}")
        if self.glide_gap is not None and not self.glide_gap > 0.0:
            raise ConfigError(f"FootLockConfig.glide_gap: expected None or a distance > 0 m, found {self.glide_gap}")
        if self.glide_gap_caught is not None and not self.glide_gap_caught > 0.0:
            raise ConfigError(f"FootLockConfig.glide_gap_caught: expected None or a distance > 0 m, found "
                              f"{self.glide_gap_caught}")
        if self.glide_gap_far is not None and not self.glide_gap_far > 0.0:
            raise ConfigError(f"FootLockConfig.glide_gap_far: expected None or a distance > 0 m, found {self.glide_gap_far}")
        if not self.glide_far >= 0.0:
            raise ConfigError(f"FootLockConfig.glide_far: expected a distance ≥ 0 m, found {self.glide_far}")
        if self.restep_gap is not None and not self.restep_gap > 0.0:
            raise ConfigError(f"FootLockConfig.restep_gap: expected None or a distance > 0 m, found {self.restep_gap}")
        if (self.restep_above or self.restep_roll_free) and self.restep_gap is None:
            raise ConfigError("FootLockConfig.restep_above, restep_roll_free: need restep_gap")
        if self.restep_chair is not None and not self.restep_chair > 0.0:
            raise ConfigError(f"FootLockConfig.restep_chair: expected None or a distance > 0 m, found {self.restep_chair}")
        if self.glide_step is not None and not self.glide_step > 0.0:
            raise ConfigError(f"FootLockConfig.glide_step: expected None or a height > 0 m, found {self.glide_step}")
        if not (isinstance(self.glide_step_frames, int) and self.glide_step_frames >= 1):
            raise ConfigError(f"FootLockConfig.glide_step_frames: expected an integer ≥ 1, found {self.glide_step_frames}")
        if self.glide_gap_above and self.glide_gap_far is None and self.glide_gap_caught is None:
            raise ConfigError("FootLockConfig.glide_gap_above: needs glide_gap_far or glide_gap_caught")
        if self.plant_caught_above and not self.plant_caught:
            raise ConfigError("FootLockConfig.plant_caught_above: needs plant_caught")
        if self.hold_lift is not None and not self.hold_lift >= self.lift:
            raise ConfigError(f"FootLockConfig.hold_lift: expected None or a height ≥ lift ({self.lift} m), found "
                              f"{self.hold_lift}")
        if self.land_gap is not None and not self.land_gap >= 0.0:
            raise ConfigError(f"FootLockConfig.land_gap: expected None or a distance ≥ 0 m, found {self.land_gap}")
        if self.hold_step_gap is not None and not self.hold_step_gap >= 0.0:
            raise ConfigError(f"FootLockConfig.hold_step_gap: expected None or a distance ≥ 0 m, found {self.hold_step_gap}")
        if self.hold_step_ahead is not None and not self.hold_step_ahead >= 0.0:
            raise ConfigError(f"FootLockConfig.hold_step_ahead: expected None or a number of frames ≥ 0, found "
                              f"{self.hold_step_ahead}")
        if self.hold_step_ahead_above and self.hold_step_ahead is None:
            raise ConfigError("FootLockConfig.hold_step_ahead_above: needs hold_step_ahead")
        if self.hold_step_caught is not None and not self.hold_step_caught >= 0.0:
            raise ConfigError(f"FootLockConfig.hold_step_caught: expected None or a distance ≥ 0 m, found "
                              f"{self.hold_step_caught}")
        if self.hold_step_flight is not None and not isinstance(self.hold_step_flight, int):
            raise ConfigError(f"FootLockConfig.hold_step_flight: expected None or an integer (frames), found "
                              f"{self.hold_step_flight}")
        if not (isinstance(self.hold_step_flight_after, int) and self.hold_step_flight_after >= 0):
            raise ConfigError(f"FootLockConfig.hold_step_flight_after: expected an integer ≥ 0 (steps), found "
                              f"{self.hold_step_flight_after}")
        if self.hold_step_gap_glide and self.hold_step_gap is None:
            raise ConfigError("FootLockConfig.hold_step_gap_glide: needs hold_step_gap")
        if self.hold_near is not None and not self.hold_near >= 0.0:
            raise ConfigError(f"FootLockConfig.hold_near: expected None or a distance ≥ 0 m, found {self.hold_near}")

    def for_episode(self, *, plan_feet: bool, causal: bool, counts_above: bool, roll_freed: bool,
                    chair: bool = False) -> FootLockConfig:
        """The settings one episode runs with: the options whose gates say "no" dropped. ``plan_feet``: the
        source's feet are planned (``SimConfig.plan_feet_causal_only``; else no ``restep_gap``); ``causal``: the
        source is causal (``glide_gap_causal_only``); ``counts_above``: the task's contact counts above the
        shoulders (``glide_gap_above``, ``plant_caught_above``, ``hold_step_ahead_above``, ``restep_above``);
        ``roll_freed``: the balance controller frees the feet's roll (``restep_roll_free``; ``hold_near_roll_free``:
        else no ``hold_near``, ``land_gap``, ``hold_step_gap`` (but with ``hold_step_gap_glide`` where the glide gaps
        act), ``hold_step_ahead``, ``hold_step_flight``); ``chair``: the person sits at the start (``restep_chair``,
        with ``plan_feet`` and not ``roll_freed``)."""
        lock = self
        if lock.restep_chair is not None:  # the pull-up's re-step on Stubby, in place of restep_gap's own gates
            act = chair and plan_feet and not roll_freed
            lock = replace(lock, restep_chair=None, **(dict(restep_gap=lock.restep_chair, restep_above=False,
                                                             restep_roll_free=False) if act else {}))
        if not plan_feet or (lock.restep_above and not counts_above) or (lock.restep_roll_free and not roll_freed):
            lock = replace(lock, restep_gap=None, restep_above=False, restep_roll_free=False)
        if lock.glide_gap_causal_only and not causal:
            lock = replace(lock, glide_gap_far=None, glide_gap_caught=None, glide_gap_causal_only=False,
                           glide_gap_above=False)
        if lock.glide_gap_above and not counts_above:
            lock = replace(lock, glide_gap_far=None, glide_gap_caught=None, glide_gap_above=False)
        if lock.hold_step_ahead_above and not counts_above:
            lock = replace(lock, hold_step_ahead=None, hold_step_ahead_above=False)
        if lock.plant_caught_above and not counts_above:
            lock = replace(lock, plant_caught=False, plant_caught_above=False)
        if lock.hold_near_roll_free and not roll_freed:  # (hold_step_gap_glide: kept where the glide gaps act)
            glides = lock.glide_gap_far is not None or lock.glide_gap_caught is not None
            keep = lock.hold_step_gap if lock.hold_step_gap_glide and glides else None
            lock = replace(lock, hold_near=None, hold_near_roll_free=False, land_gap=None, hold_step_gap=keep,
                           hold_step_ahead=None, hold_step_ahead_above=False, hold_step_flight=None,
                           hold_step_gap_glide=False)
        return lock
