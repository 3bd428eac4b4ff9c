"""Contact completion: the last few centimetres of a contact the synthesized reaction is already making.

The affordance model proposes where agent 1's wrists go; scaled onto a robot of another build and met by
IK and servos, a hand the model sends to the person's hand can stop a decimetre short of it (the model's
end configuration is a prediction, the person's hand is where it is). Between the scaled key-joint targets
and the IK, this stage blends a wrist target toward the contact itself when three things hold at frame t:

* the task wants that contact (a ``contact`` sub-goal with the person's hands or wrists, or an object
  sub-goal; :mod:`~socialaff_sim.sim.contact_targets` lists the *anchors*, spheres at frame t);
* the model means to touch it: the *intended gap* g_m, the distance between the anchor's surface and the
  robot's hand moved by as much as the model's wrist target differs from the robot's current wrist, is below
  ``capture``, or (``intent``) the model's current sub-event is one it makes a hand contact in (learned:
  :func:`~socialaff_sim.model.contact_keys.contact_types`; the model's intent, not the anchor, decides whether
  to touch: a causal strike lags the person's, its wrist still far when the sub-event already says strike);
* the contact point lies within the robot's reach (``reach`` times the arm's length from its shoulder, the
  gate falling to zero ``reach_band`` beyond).

The completed wrist target moves the robot's hand, as it is now, until its nearest point lies ``press``
inside the anchor's surface (the surfaces meet; the IK's contact limit stops a hand at
``IKConfig.contact_depth``). With weight β the target is (1 − β)·w_model + β·w_contact, where
β = smoothstep((capture − g_m) / (capture − engage)) · smoothstep((ρ·arm + b − |w_contact − shoulder|) / b),
changing by at most Δt / ``ramp`` per frame (it ramps in and out smoothly). Every input is of frame t or
earlier (the person's and the object's poses at t, the robot's own state), so a causal source stays causal.
Of the person's hands one pair at most is completed (the one of smallest intended gap); both hands may
close on an object.

With ``catch_flight`` (on by default), in a catch sub-goal's window (the object free, no hand gripping
it, a ``catch`` sub-goal wanting it) the object's target for the hand its flight passes nearest is not where the
object is at the frame's end but a point of its predicted free flight within the arm's reach, the hand in the
ball's way (:func:`~socialaff_sim.retarget.flight_target.flight_targets`); the window captures it for that hand
whatever the intended gap (as the model's intent captures a free object), and the reach gate and ramp apply as
to any contact, from the frame the ball is within ``flight_lead`` of that point. The other hand is completed as
without the option (two hands sent onto one path struck each other). While the window is open, both hands' targets
are paced (``flight_pace``): each lies at most v_p·Δt from its commanded wrist (a target that jumps is met by
servos that overshoot).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import ConfigError
from .flight_target import FlightState, flight_targets
from .scaling import smoothstep

__all__ = ["ContactCompletionConfig", "CompletionInput", "ContactCompletion", "paced"]

_OUT_OF_REACH = 1e3
"""Metres added to the intended gap of a pair out of reach when ranking pairs captured by intent."""


@dataclass(frozen=True)
class ContactCompletionConfig:
    """Settings of the contact completion stage (:class:`ContactCompletion`).

    Fields by concept
    -----------------
    - When: capture, engage, reach, reach_band, intent, keep, approach, release_met, reach_carried
    - Where: press, catch_flight, catch_approach, flight_horizon, flight_lead, hand_speed, flight_pace
    - How fast: ramp
    """

    capture: float = 0.3
    """g_c [m]: an intended gap (model's hand to the anchor's surface) at or above this leaves the target alone."""
    engage: float = 0.15
    """g_e [m]: at or below this intended gap the target is the contact itself (β = 1 before the reach gate)."""
    press: float = 0.015
    """δ_p [m]: the completed target puts the hand's nearest point this far inside the anchor's surface, so that
    the geoms touch despite the servos' tracking error (the IK stops it at ``IKConfig.contact_depth``)."""
    reach: float = 1.0
    """ρ [—]: the contact counts as within reach while the completed wrist target lies within ρ times the arm's
    length (shoulder to wrist) from its shoulder."""
    reach_band: float = 0.1
    """b [m]: the reach gate falls smoothly from 1 at ρ·arm to 0 at ρ·arm + b (a hand reaches about this far
    past its wrist, so a wrist target a little beyond the arm's length still brings the hand to the contact)."""
    ramp: float = 0.2
    """τ_r [s]: β changes by at most Δt / τ_r per frame (0: at once)."""
    intent: bool = True
    """[—]: Whether the model's intent to touch also captures: in a frame whose sub-event is one the model makes a
    hand contact in (:func:`~socialaff_sim.model.contact_keys.contact_types`), every contact the task allows then
    is captured whatever the intended gap (the reach gate still applies; of the person's hands only the one held
    out, :func:`~socialaff_sim.sim.contact_targets.offered_hand`); otherwise only the intended gap does."""
    keep: bool = False
    """[—]: Whether a person's hand being completed keeps its robot hand while it is still captured, rather than the
    pair of smallest intended gap taking over (a pull-up's grip does not jump between the person's hands). Off by
    default: on the benchmark it shrank the pull-ups' partings (the H1's largest 41.5 → 7.3 cm, Stubby's 10.5 →
    1.2 cm) but lowered the share of the recorded pull in contact (83 → 75 % Stubby, 79 → 75 % H1)."""
    approach: bool = True
    """[—]: Whether, in such a frame or one before it, a person's hand held out beyond the robot's reach moves the
    robot in (:meth:`~socialaff_sim.retarget.scaling.KeyJointScaler.approach`; online placement only)."""
    release_met: bool = False
    """[—]: Whether a person's hand is no longer captured once the task's touches are met (``CompletionInput.met``:
    every contact sub-goal with the person met by a touch, its ``min_duration`` shorter than a data frame, has been
    met: a high five's strike is over): the hand then ramps out (``ramp``) to the model's target, as a hand whose
    anchor is no longer wanted. Objects are captured as without it. Off (``False``): a met touch is chased on, and
    the standing high_five_007's hand, held on the person's palm after the meeting, followed it down onto the
    person's head and upper arm (311–332 N a frame; docs/design.md §5, "The ground-truth high five's press after
    the meeting released")."""

    reach_carried: bool = False
    """[—]: Whether an object the person still carries (not free) that the task wants a robot hand on is captured,
    for the hand of smallest intended gap, whatever that gap (the reach gate and the ramp still apply): the hand
    reaches for a cup held out within its reach. Off: only the intended gap captures it (a carried object is
    met where the model meets it). On the 150 real handovers the causal synthesis' hand stayed a median 0.35 m
    (intended gap) from the cup at the person's release, beyond ``capture``, with the cup within reach in 30 of
    its 34 drops (docs/design.md §5, "Why the synthesized reaction drops the cup on the real handovers")."""

    catch_flight: bool = True
    """[—]: Whether, in a catch sub-goal's window (the object free, in the air and not gripped, a ``catch`` sub-goal
    wanting it), the hand whose shoulder the object's predicted free flight (from its simulated state now) passes
    nearest aims at a point of that flight within the arm's reach, in the ball's way
    (:func:`~socialaff_sim.retarget.flight_target.flight_targets`), captured by the window whatever the intended
    gap, rather than at the object where it will be at the frame's end; the other hand is completed as without it.
    The hand is chosen afresh each frame. On by default since the rule of docs/design.md §5 ("The catch options'
    two failures traced and mended"), passed on fresh instances (docs/benchmarks.md, "The catch options' two
    failures traced …")."""
    catch_approach: bool = True
    """[—]: Whether, with ``catch_flight`` and the window open, a predicted flight that passes beyond the arm's
    reach (``reach``) from both shoulders moves the robot in toward it (:meth:`~socialaff_sim.retarget.scaling.
    KeyJointScaler.approach_nearest` with ``flight=True``: also when the robot was placed from the whole recording,
    and not held back by the recording's trunk bound; at most ``ScalingConfig.approach_speed``). The
    recording's placement stands a broad robot back from where the ball flies (docs/benchmarks.md, "A hand target
    on the ball's predicted flight"); on by default with ``catch_flight`` (the same rule)."""
    flight_horizon: float = 1.0
    """T_f [s]: with ``catch_flight``, how far past the end of the frame being planned the flight is searched (it
    ends earlier where the ball lands)."""
    flight_lead: float = 0.4
    """T_w [s]: with ``catch_flight``, the hand goes onto the flight only once the ball is at most this long from the
    point chosen for it; before, it is completed as without the option (a hand raised to the flight 0.7 s early
    tipped a standing Stubby back: docs/benchmarks.md, "A hand target on the ball's predicted flight")."""
    hand_speed: float = 1.5
    """v_h [m/s]: with ``catch_flight``, how fast a hand is taken to move: the target is the earliest point of the
    flight within reach that the hand, at this speed from its commanded wrist, reaches before the ball."""

    flight_pace: float | None = 3.0
    """v_p [m/s]: with ``catch_flight`` and the window open, each hand's completed wrist target lies at most v_p·Δt
    (Δt the time since the last frame completed) from its commanded wrist, both hands (``None``: no pace). Without
    it a target jumps up to 0.4 m in one frame (the recording's catch swing, the flight's point chosen afresh), the
    servos overshoot, and the H1's forearms struck each other 2.5 cm deep with the plan 12 cm apart
    (throw_catch_044) while a standing Stubby's hand flung up over its head and back down tipped its trunk back 17°
    (throw_catch_045); paced at ``hand_speed`` (1.5 m/s) Stubby's hands, from its hips, came too late for balls
    it caught without the pace (docs/benchmarks.md, "The catch options' two failures traced …")."""

    def __post_init__(self) -> None:
        if self.flight_pace is not None and not self.flight_pace > 0.0:
            raise ConfigError(f"ContactCompletionConfig.flight_pace: expected a speed > 0 m/s or None, found "
                              f"{self.flight_pace}")
        if not self.flight_lead >= 0.0:
            raise ConfigError(f"ContactCompletionConfig.flight_lead: expected seconds ≥ 0, found {self.flight_lead}")
        if not self.hand_speed > 0.0:
            raise ConfigError(f"ContactCompletionConfig.hand_speed: expected a speed > 0 m/s, found {self.hand_speed}")
        if not self.flight_horizon >= 0.0:
            raise ConfigError(f"ContactCompletionConfig.flight_horizon: expected seconds ≥ 0, found {self.flight_horizon}")
        if not self.capture > self.engage >= 0.0:
            raise ConfigError(f"ContactCompletionConfig: expected capture > engage ≥ 0 m, found capture "
                              f"{self.capture}, engage {self.engage}")
        if not self.press >= 0.0:
            raise ConfigError(f"ContactCompletionConfig.press: expected a depth ≥ 0 m, found {self.press}")
        if not self.reach > 0.0 or not self.reach_band > 0.0:
            raise ConfigError(f"ContactCompletionConfig: expected reach > 0 and reach_band > 0, found "
                              f"{self.reach}, {self.reach_band}")
        if not self.ramp >= 0.0:
            raise ConfigError(f"ContactCompletionConfig.ramp: expected seconds ≥ 0, found {self.ramp}")


@dataclass(frozen=True)
class CompletionInput:
    """What the stage reads at one frame, world frame, metres. Hands: 0 left, 1 right; A anchors."""

    wrist_target: np.ndarray
    """(2, 3) the wrists' targets from the model (scaled onto the robot)."""
    wrist_now: np.ndarray
    """(2, 3) the robot's wrists now as last commanded (its latest IK solution; the hands' ``nearest`` points
    are read in physics, and move as the commanded wrists move)."""
    nearest: np.ndarray
    """(2, A, 3) the point of each robot hand's geoms nearest each anchor, now."""
    centre: np.ndarray
    """(A, 3) the anchors' centres at frame t."""
    radius: np.ndarray
    """(A,) the anchors' radii."""
    shared: np.ndarray
    """(A,) bool: whether both hands may close on the anchor (an object) or only one (a person's hand)."""
    allowed: np.ndarray
    """(2, A) bool: which robot hand may touch which anchor (the task's robot and human groups)."""
    shoulder: np.ndarray
    """(2, 3) the robot's physical shoulders now, the reach is measured from (world, m)."""
    arm: float
    """The robot's arm length, shoulder to wrist frame."""
    intent: bool = False
    """Whether the source's model means to touch now (its current sub-event makes a hand contact)."""
    free: bool = False
    """Whether the object moves freely now (thrown or let go; not carried by the person): only then is it
    captured by intent (a cup held out is met where the model meets it)."""
    inside: bool = False
    """Whether the model's contact is a keyframe inside its sub-event (released before the end: a high five's
    strike): only then is a person's hand captured by intent (a contact at a sub-event's end, a handshake, is
    one the model's own end configuration reaches)."""
    catch: bool = False
    """Whether a catch sub-goal's window is open: the object free, no hand gripping it, a ``catch`` sub-goal
    wanting it now (read with ``ContactCompletionConfig.catch_flight``)."""
    flight: FlightState | None = None
    """The free object's state now, for its predicted flight (``None``: unknown)."""
    met: bool = False
    """Whether the task's touches have all been met by now (contact sub-goals with the person met by a touch; read
    with ``ContactCompletionConfig.release_met``; ``False`` in a task with none)."""


class ContactCompletion:
    """The stage for one episode: :meth:`reset` at its start, then :meth:`__call__` once per frame in order."""

    def __init__(self, config: ContactCompletionConfig | None = None) -> None:
        self.config = config or ContactCompletionConfig()
        self.reset()

    def reset(self) -> None:
        """Forget the blend weights (a new episode starts with none)."""
        self._frame: int | None = None
        self._before = (np.zeros(2), np.full(2, -1, dtype=np.int64))  # β and anchors of the frame before
        self.weight = np.zeros(2)
        """(2,) β of the last frame completed, per hand."""
        self.anchor = np.full(2, -1, dtype=np.int64)
        """(2,) anchor index each hand was blended toward at the last frame (-1: none)."""

    def contact_targets(self, x: CompletionInput) -> np.ndarray:
        """(2, A, 3) the wrist target that brings each hand's nearest point ``press`` inside each anchor."""
        toward = x.centre[None] - x.nearest  # (2, A, 3)
        dist = np.linalg.norm(toward, axis=-1, keepdims=True)
        unit = np.divide(toward, dist, out=np.zeros_like(toward), where=dist > 1e-9)
        move = (dist - (x.radius[None, :, None] - self.config.press)) * unit
        return x.wrist_now[:, None, :] + move

    def intended_gaps(self, x: CompletionInput) -> np.ndarray:
        """(2, A) the gap between each anchor's surface and each hand moved as the model moves its wrist."""
        moved = x.nearest + (x.wrist_target - x.wrist_now)[:, None, :]
        return np.linalg.norm(x.centre[None] - moved, axis=-1) - x.radius[None]

    def _assign(self, gaps: np.ndarray, x: CompletionInput, beyond: np.ndarray, flying: np.ndarray) -> np.ndarray:
        """(2,) the anchor each hand goes for (-1: none): its nearest allowed one within ``capture``. Of the
        person's hands (anchors not shared) one pair at most is completed, the one of smallest intended gap (a
        handshake or a high five is one contact: the robot's other hand does not reach for the person's other
        hand); both hands may close on a shared anchor (an object). Captured by intent (a free object; a person's
        hand when the contact is ``inside`` its sub-event), every allowed pair counts whatever its intended gap,
        and of the person's hands a pair whose anchor lies within reach of the hand's shoulder comes before any
        out of it (a short robot meets a tall person's raised hand with whichever hand reaches it); the pair
        being completed stays first while ``beyond`` (2, A), its target's metres past the reach, stays below
        ``reach_band``. ``flying`` (2,) bool: the hand whose object target is on the predicted flight (captured by
        the catch's window), or the hand that reaches for a carried object (``reach_carried``)."""
        c = self.config
        rank = np.where(gaps < c.capture, gaps, np.inf)  # captured by the intended gap
        if c.keep:  # the person's hand being completed stays first while still captured (no swapping hands)
            beta, anchor = self._before
            for side in (0, 1):
                a = int(anchor[side])
                if beta[side] > 0 and 0 <= a < len(x.shared) and not x.shared[a] and np.isfinite(rank[side, a]):
                    rank[side, a] = -1.0
        if self._intent(x):
            person = rank
            if x.inside:
                far = np.linalg.norm(x.centre[None] - x.shoulder[:, None, :], axis=-1) > c.reach * x.arm
                person = np.where(far, gaps + _OUT_OF_REACH, gaps)
                # The pair being completed stays first while it can still be reached (no switching hands mid-reach).
                beta, anchor = self._before
                for side in (0, 1):
                    a = int(anchor[side])
                    if beta[side] > 0 and 0 <= a < len(x.shared) and not x.shared[a] and beyond[side, a] < c.reach_band:
                        person[side, a] = -1.0
            # An object: both hands may close on it, each by its intended gap; captured by intent only while free.
            rank = np.where(x.shared[None, :], gaps if x.free else rank, person)
        # The catch's window captures the object for the hand on the flight whatever the intended gap.
        rank = np.where(x.shared[None, :] & flying[:, None], gaps, rank)
        g = np.where(x.allowed, rank, np.inf)
        person = np.where(~x.shared[None, :], g, np.inf)
        if np.isfinite(person).any():
            side, a = np.unravel_index(int(np.argmin(person)), person.shape)
            g[1 - side] = np.where(x.shared, g[1 - side], np.inf)
            g[side] = np.where(x.shared | (np.arange(len(x.shared)) == a), g[side], np.inf)
        return np.where(np.isfinite(g).any(axis=1), np.argmin(g, axis=1), -1).astype(np.int64)

    def _intent(self, x: CompletionInput) -> bool:
        """Whether this frame's capture is the model's intent (rather than the intended gap)."""
        return self.config.intent and x.intent

    def _reaching(self, x: CompletionInput, gaps: np.ndarray) -> np.ndarray:
        """(2,) bool: with ``reach_carried`` and the object carried (not free), the hand of smallest intended gap
        ``gaps`` (2, A) to each object anchor the task allows it on (captured whatever the gap)."""
        out = np.zeros(2, dtype=bool)
        if not self.config.reach_carried or x.free:
            return out
        for a in np.flatnonzero(x.shared):
            g = np.where(x.allowed[:, a], gaps[:, a], np.inf)
            if np.isfinite(g).any():
                out[int(np.argmin(g))] = True
        return out

    def _window(self, x: CompletionInput) -> bool:
        """Whether the object's target is on its predicted flight this frame (``catch_flight``, the window open)."""
        return self.config.catch_flight and x.catch and x.flight is not None

    def __call__(self, x: CompletionInput, frame: int, dt: float) -> np.ndarray:
        """(2, 3) the completed wrist targets of ``frame`` (data frames of ``dt`` seconds).

        Frames come in order (anchors indexed the same way throughout the episode); asking for the same
        frame again recomputes it from the same previous weights."""
        c = self.config
        if self._frame is not None and frame == self._frame:
            base_beta, base_anchor = self._before
            frames = 1
        elif self._frame is not None and frame > self._frame:
            base_beta, base_anchor = self.weight, self.anchor
            frames = frame - self._frame
        else:
            base_beta, base_anchor = np.zeros(2), np.full(2, -1, dtype=np.int64)
            frames = 1
        self._before = (base_beta.copy(), base_anchor.copy())
        self._frame = frame
        want = np.zeros(2)
        choice = np.full(2, -1, dtype=np.int64)
        targets = np.zeros((2, 0, 3))
        if len(x.centre):
            targets = self.contact_targets(x)
            gaps = self.intended_gaps(x)
            beyond = np.linalg.norm(targets - x.shoulder[:, None, :], axis=-1) - c.reach * x.arm  # (2, A)
            flying = np.zeros(2, dtype=bool)
            if self._window(x):  # one hand, the one whose shoulder the flight passes nearest, goes onto it
                for a in np.flatnonzero(x.shared):
                    ft, fb, when, closest = flight_targets(
                        x.flight, float(x.radius[a]), c.press, x.nearest[:, a], x.wrist_now, x.shoulder,  # type: ignore[arg-type]
                        c.reach * x.arm, c.flight_horizon, c.hand_speed)
                    s = int(np.argmin(closest))
                    if when[s] <= c.flight_lead:  # the ball near its point: the hand goes (earlier, it tips a trunk)
                        targets[s, a], beyond[s, a], flying[s] = ft[s], fb[s], True
            if c.release_met and x.met:  # the touch is over: the person's hands are no longer wanted
                x = replace(x, allowed=x.allowed & x.shared[None, :])
            reaching = self._reaching(x, gaps)
            choice = self._assign(gaps, x, beyond, flying | reaching)
            for s in (0, 1):
                a = choice[s]
                if a < 0:
                    continue
                gate = float(smoothstep((c.reach_band - beyond[s, a]) / c.reach_band))
                if (self._intent(x) and (x.free if x.shared[a] else x.inside)) or ((flying[s] or reaching[s])
                                                                                   and x.shared[a]):
                    # whatever the gap, where reachable
                    want[s] = gate
                else:
                    want[s] = float(smoothstep((c.capture - gaps[s, a]) / (c.capture - c.engage))) * gate
        step = np.inf if c.ramp == 0 else frames * dt / c.ramp
        beta = np.clip(want, base_beta - step, base_beta + step)
        # A hand ramping out after losing its anchor keeps blending toward where that anchor is now.
        anchor = np.where(choice >= 0, choice, base_anchor)
        anchor = np.where((beta > 0) & (anchor < targets.shape[1]), anchor, -1)
        beta = np.where(anchor >= 0, beta, 0.0)
        out = x.wrist_target.copy()
        for s in (0, 1):
            if anchor[s] >= 0:
                out[s] = (1.0 - beta[s]) * out[s] + beta[s] * targets[s, anchor[s]]
        self.weight, self.anchor = beta, anchor.astype(np.int64)
        if c.flight_pace is not None and self._window(x):
            out = paced(out, x.wrist_now, c.flight_pace * frames * dt)
        return out


def paced(target: np.ndarray, now: np.ndarray, step: float) -> np.ndarray:
    """(2, 3) each of ``target`` (2, 3) moved back toward ``now`` (2, 3) until it lies at most ``step`` m from it
    (along the line between them; a target within ``step`` is left as it is)."""
    move = target - now
    dist = np.linalg.norm(move, axis=1, keepdims=True)
    return now + move * np.minimum(1.0, step / np.maximum(dist, 1e-12))
