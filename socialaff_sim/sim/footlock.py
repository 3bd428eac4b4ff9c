"""Planting the robot's feet: an ankle target that barely moves near the floor is held still on it.

A recorded person's ankles wander by a centimetre or two while they stand (the
skeleton tracker's noise, small shifts of weight), and the human-to-robot
scaling passes this on. A robot standing on its own feet cannot follow it: a
foot that rises by a centimetre drops the robot's weight onto the other one or
onto its harness, and one that moves sideways on the floor slides. :class:`FootLock`
holds an ankle target at the place where its foot came down (on the floor, at
the robot's home ankle height) while the target stays within ``radius`` of that
place and below ``lift`` above home height (``hold_lift``, when set, for a foot already planted); a
target that leaves that ball (a step) is followed again.

A target that leaves the ball along the floor, never rising above ``lift`` (a glide: a synthesized walk-up may
slide its feet), is planted again at once at its new point: the foot counts as planted throughout, so a balance
controller that holds planted feet where they stood (:mod:`~.balance_control`) never lets the physical foot
follow, and the robot stays behind its plan. With ``glide_step`` such a foot steps instead: for one frame it is
not planted and its target is the new point raised by ``glide_step``; then it is put down as any other.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError, SimulationError

__all__ = ["FootLock", "FootLockConfig"]


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
        if self.hold_step_flight is not None and not isinstance(self.hold_step_flight, int):
            raise ConfigError(f"FootLockConfig.hold_step_flight: expected None or an integer (frames), found "
                              f"{self.hold_step_flight}")
        if not (isinstance(self.hold_step_flight_after, int) and self.hold_step_flight_after >= 0):
            raise ConfigError(f"FootLockConfig.hold_step_flight_after: expected an integer ≥ 0 (steps), found "
                              f"{self.hold_step_flight_after}")
        if self.hold_near is not None and not self.hold_near >= 0.0:
            raise ConfigError(f"FootLockConfig.hold_near: expected None or a distance ≥ 0 m, found {self.hold_near}")


def _within(distance: float | None, gaps: Iterable[float | None]) -> bool:
    """Whether any of the sub-goals' ``gaps`` (m; ``None``: not measured) is at most ``distance`` (m; ``None``:
    the option off, never)."""
    return distance is not None and any(g is not None and g <= distance for g in gaps)


class FootLock:
    """Holds standing ankle targets still (see the module docstring); :meth:`reset` per episode."""

    def __init__(self, home_height: tuple[float, float], config: FootLockConfig | None = None) -> None:
        self.home_height = np.asarray(home_height, dtype=np.float64)
        """(2,) left, right ankle height at the robot's home posture, m."""
        self.config = config or FootLockConfig()
        self.planted: list[np.ndarray | None] = [None, None]
        """Where each foot is planted (world, (3,) m), or ``None`` while it steps."""
        self.reset()

    def reset(self) -> None:
        """No foot planted."""
        self.planted = [None, None]
        self.glide_steps = 0
        """Glides turned into a step in the episode (``glide_step``)."""
        self._glide: tuple[int, np.ndarray] | None = None  # this frame's gliding foot and its raised target
        self._glide_left = 0  # further frames the gliding foot stays lifted (``glide_step_frames``)
        self._last: int | None = None  # the foot that glide-stepped in the last frame
        self._touched = False  # a sub-goal's contact has held in the episode (``glide_until_contact``)
        self._wait = [False, False]  # this frame's gliding feet held where they stand
        self.steps = 0
        """Steps begun in the episode (a planted foot unplanted, glide steps included)."""
        self._flight_from: int | None = None  # ``steps`` at the flight's first frame (``hold_step_flight``)

    def near(self, gaps: Iterable[float | None]) -> bool:
        """Whether any of the sub-goals' ``gaps`` (m; ``None``: not measured) is within ``hold_near``; ``False``
        without it."""
        return _within(self.config.hold_near, gaps)

    def stepless(self, gaps: Iterable[float | None]) -> bool:
        """Whether any of the sub-goals' ``gaps`` (m; ``None``: not measured) is within ``hold_step_gap``; ``False``
        without it."""
        return _within(self.config.hold_step_gap, gaps)

    def in_flight(self, frame: int, release_frame: int | None) -> bool:
        """Whether the frame that ends at ``frame`` lies within ``hold_step_flight`` of a thrown object's release
        (the person lets go at the start of frame ``release_frame`` − 1; ``None``: no thrown object): ``frame`` ≥
        ``release_frame`` − L_f, and ``hold_step_flight_after`` steps begun since the first such frame (the first
        call that finds ``frame`` in the flight marks it); ``False`` without the option."""
        L = self.config.hold_step_flight
        if L is None or release_frame is None or frame < release_frame - L:
            return False
        if self._flight_from is None:
            self._flight_from = self.steps
        return self.steps - self._flight_from >= self.config.hold_step_flight_after

    def landing(self, gaps: Iterable[float | None]) -> bool:
        """Whether any of the sub-goals' ``gaps`` (m; ``None``: not measured) is within ``land_gap``; ``False``
        without it."""
        return _within(self.config.land_gap, gaps)

    def walking_up(self, gaps: Iterable[float | None]) -> bool:
        """Whether no sub-goal's gap in ``gaps`` (m; ``None``: not measured) is within ``glide_far`` (``glide_gap_far``
        then decides a glide; ``glide_gap_caught`` does not); ``False`` without either option."""
        c = self.config
        return (c.glide_gap_far is not None or c.glide_gap_caught is not None) and not _within(c.glide_far, gaps)

    def gap_flags(self, gaps: Iterable[float | None] | None) -> dict[str, bool]:
        """:meth:`apply`'s keywords ``near``, ``land``, ``still`` and ``far`` from the last frame's sub-goal ``gaps``
        (m; ``None`` in a gap: not measured; ``None`` for all: no frame yet), by :meth:`near`, :meth:`landing`,
        :meth:`stepless` and :meth:`walking_up`."""
        if gaps is None:
            return {"near": False, "land": False, "still": False, "far": self.walking_up(())}
        g = list(gaps)
        return {"near": self.near(g), "land": self.landing(g), "still": self.stepless(g), "far": self.walking_up(g)}

    def backing(self, ankles: np.ndarray, person: np.ndarray) -> tuple[bool, bool]:
        """For targets ``ankles`` (2, 3) (world, m) and the person at ``person`` (2,): whether each planted foot's
        target moves away from the person (its horizontal displacement from the planted point has a negative
        component along the direction from that point to the person); ``False`` for a foot not planted."""
        out = [False, False]
        for s in (0, 1):
            p = self.planted[s]
            if p is not None:
                out[s] = float((ankles[s][:2] - p[:2]) @ (np.asarray(person)[:2] - p[:2])) < 0.0
        return out[0], out[1]

    @property
    def needs_physical(self) -> bool:
        """Whether :meth:`apply` needs the physical ankle frames (``glide_gap`` or ``restep_gap``)."""
        c = self.config
        return c.glide_step is not None and any(d is not None for d in (c.glide_gap, c.restep_gap, c.glide_gap_far,
                                                                          c.glide_gap_caught))

    @property
    def standing(self) -> tuple[bool, bool]:
        """(left, right): whether each foot stands (is planted)."""
        return (self.planted[0] is not None, self.planted[1] is not None)

    def apply(self, ankles: np.ndarray, touching: bool = False, physical: np.ndarray | None = None,
              new_frame: bool = True, caught: bool = False, near: bool = False,
              person: np.ndarray | None = None, land: bool = False, still: bool = False,
              far: bool = False, flight: bool = False) -> np.ndarray:
        """(2, 3) world ankle targets (left, right), m → the same with standing feet held where they were planted;
        ``touching``: a sub-goal's contact holds (with ``hold_in_contact``, planted feet then stay planted);
        ``physical`` (2, 3): the physical ankle frames (world, m), which ``glide_gap`` needs; ``new_frame``:
        ``False`` for a solve again within a data frame (``glide_step`` then keeps the frame's decision);
        ``caught``: the harness holds a robot it has caught (with ``plant_caught``, glides are then planted at once);
        ``near``: a sub-goal's gap at the end of the last frame is within ``hold_near`` (the caller decides it,
        :meth:`near`), and ``person`` (2,) the person's horizontal position (world, m): with ``hold_in_contact``,
        planted feet whose targets step away from the person then stay planted (:meth:`backing`); ``land``: a
        sub-goal's gap at the end of the last frame is within ``land_gap`` (:meth:`landing`): in a new frame, a foot
        not planted is then put down at its target's point; ``still``: a sub-goal's gap at the end of the last frame
        is within ``hold_step_gap`` (:meth:`stepless`): a planted foot's step then plants it at once at its target's
        horizontal point (no foot is lifted, no glide steps); ``far``: no sub-goal's gap at the end of the last frame
        is within ``glide_far`` (:meth:`walking_up`; the caller passes ``False`` without ``glide_gap_far`` and
        ``glide_gap_caught``): ``glide_gap_far`` then replaces ``glide_gap``, and otherwise while ``caught``
        ``glide_gap_caught`` does; ``flight``: the frame lies in a thrown object's flight (:meth:`in_flight`): as
        ``still``."""
        if self.needs_physical and physical is None:
            raise SimulationError("FootLock.apply: glide_gap and restep_gap need the physical ankle frames")
        out = np.array(ankles, dtype=np.float64)
        c = self.config
        held = touching and c.hold_in_contact
        still = still or flight  # (hold_step_flight: the plan steps, the foot stays)
        back = (self.backing(out, person) if near and person is not None and c.hold_in_contact and not held
                else (False, False))
        self._touched = self._touched or bool(touching)
        if self._glide is not None and new_frame and self._glide_left > 0:  # a longer step: still lifted
            self._glide_left -= 1
            s, lifted = self._glide
            if out[s][2] - self.home_height[s] <= c.lift:  # toward the glide's latest point
                lifted = np.array([out[s][0], out[s][1], lifted[2]])
                self._glide = (s, lifted)
            new_frame = False
        if not new_frame and self._glide is not None:  # solved again within the frame: the foot still steps
            s, lifted = self._glide
            out[s] = lifted
            if self.planted[1 - s] is not None:
                out[1 - s] = self.planted[1 - s]
            return out
        self._glide = None
        if held and all(p is not None for p in self.planted):
            return np.array([np.array(p) for p in self.planted])
        hold = c.lift if c.hold_lift is None else c.hold_lift
        glide, wait = None, [False, False]
        if c.glide_step is not None:  # within a frame the frame's decision stands
            if held or still or (c.glide_until_contact and self._touched) or (c.plant_caught and caught):
                self._last, self._wait = None, wait
            elif new_frame:
                gap = c.glide_gap
                if far and c.glide_gap_far is not None:
                    gap = c.glide_gap_far
                elif not far and caught and c.glide_gap_caught is not None:
                    gap = c.glide_gap_caught
                glide, wait = self._gliding(out, hold, physical, gap)
                self._wait = wait
            else:
                wait = self._wait
        for s in (0, 1):
            t = out[s]
            rise = t[2] - self.home_height[s]
            p = self.planted[s]
            if p is not None and (back[s] or glide != s and (rise <= hold and np.linalg.norm(t[:2] - p[:2]) <= c.radius
                                                            or wait[s])):
                out[s] = p  # stands (and does not lift while the other foot glide-steps)
            elif glide == s:
                self.planted[s] = None
                out[s] = np.array([t[0], t[1], self.home_height[s] + c.glide_step])
                self._glide = (s, out[s].copy())
                self._glide_left = c.glide_step_frames - 1
                self.glide_steps += 1
                self.steps += 1
            elif rise <= c.lift or (land and new_frame and p is None) or (still and p is not None):
                # (land: lifted in an earlier frame; still: a step of a planted foot planted at once where it goes)
                self.planted[s] = np.array([t[0], t[1], self.home_height[s]])
                out[s] = self.planted[s]
            else:
                self.steps += p is not None
                self.planted[s] = None
        return out

    def _gliding(self, ankles: np.ndarray, hold: float, physical: np.ndarray | None, gap: float | None
                 ) -> tuple[int | None, list[bool]]:
        """For targets ``ankles`` (2, 3): the foot (0 left, 1 right) that glide-steps this frame (else ``None``)
        and which planted feet are held where they stand instead of being planted again at their gliding target.
        A foot glides when it is planted and its target left ``radius`` at most ``lift`` above home height. It may
        step while the other foot is planted and its target keeps it planted or glides too; of two such feet the
        one whose target is farther from where it stands steps, and the other is held; so is a gliding foot the
        frame after the other foot's glide step (it lands). With ``glide_gap`` a foot glides only while its physical
        ankle frame (``physical`` (2, 3), world, m) stands farther than d_g from its target; with ``restep_gap`` a
        planted foot also glides (its distance the larger of the two) while its physical ankle frame stands farther
        than d_r from where it is planted, and such a foot does not count as standing for the other's step.
        ``hold``: the planted feet's height bound; ``gap``: d_g (or ``glide_gap_far``/``glide_gap_caught`` in its
        place, :meth:`apply`)."""
        c = self.config
        last, self._last = self._last, None
        planted = [p is not None for p in self.planted]
        rise = ankles[:, 2] - self.home_height
        off = np.array([np.linalg.norm(ankles[s, :2] - p[:2]) if p is not None else 0.0
                        for s, p in enumerate(self.planted)])
        glides = np.array(planted) & (off > c.radius) & (rise <= c.lift)
        if gap is not None:  # a creep the standing foot stays within d_g of is planted at once
            glides &= np.linalg.norm(ankles[:, :2] - np.asarray(physical)[:, :2], axis=1) > gap
        stays = np.array(planted) & (off <= c.radius) & (rise <= hold)
        if c.restep_gap is not None:  # a foot that landed short of where it is planted steps again
            short = np.array([np.linalg.norm(np.asarray(physical)[s, :2] - p[:2]) if p is not None else 0.0
                              for s, p in enumerate(self.planted)])
            glides |= (short > c.restep_gap) & (rise <= c.lift)
            stays &= short <= c.restep_gap
            off = np.maximum(off, short)
        ok = [s for s in (0, 1) if glides[s] and planted[1 - s] and (stays[1 - s] or glides[1 - s])]
        step = max(ok, key=lambda s: off[s]) if ok else None
        self._last = step
        held = [bool(glides[s] and s != step and (step is not None or last == 1 - s)) for s in (0, 1)]
        return step, held
