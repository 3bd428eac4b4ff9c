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

import numpy as np

from ..errors import SimulationError
from .footlock_config import FootLockConfig

__all__ = ["FootLock", "FootLockConfig", "within"]


def within(distance: float | None, gaps: Iterable[float | None]) -> bool:
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
        return within(self.config.hold_near, gaps)

    def stepless(self, gaps: Iterable[float | None], before: Iterable[float | None] | None = None) -> bool:
        """Whether any of the sub-goals' ``gaps`` (m; ``None``: not measured) is within ``hold_step_gap``, or with
        ``hold_step_ahead`` k and the same sub-goals' gaps a frame ``before`` (``None``: no such frame; paired by
        position) one gap's extrapolation g₁ − k·(g₀ − g₁) is (an opening gap's is never nearer than g₁ itself);
        ``False`` without ``hold_step_gap``."""
        g = list(gaps)
        c = self.config
        if within(c.hold_step_gap, g):
            return True
        if c.hold_step_ahead is None or before is None:
            return False
        ahead = [g1 - c.hold_step_ahead * (g0 - g1) for g0, g1 in zip(before, g) if g0 is not None and g1 is not None]
        return within(c.hold_step_gap, ahead)

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
        return within(self.config.land_gap, gaps)

    def walking_up(self, gaps: Iterable[float | None]) -> bool:
        """Whether no sub-goal's gap in ``gaps`` (m; ``None``: not measured) is within ``glide_far`` (``glide_gap_far``
        then decides a glide; ``glide_gap_caught`` does not); ``False`` without either option."""
        c = self.config
        return (c.glide_gap_far is not None or c.glide_gap_caught is not None) and not within(c.glide_far, gaps)

    def gap_flags(self, gaps: Iterable[float | None] | None,
                  before: Iterable[float | None] | None = None) -> dict[str, bool]:
        """:meth:`apply`'s keywords ``near``, ``land``, ``still``, ``far`` and ``still_caught`` (``hold_step_caught``) from the last frame's sub-goal ``gaps``
        (m; ``None`` in a gap: not measured; ``None`` for all: no frame yet), by :meth:`near`, :meth:`landing`,
        :meth:`stepless` (with the frame ``before``'s gaps of the same sub-goals, ``hold_step_ahead``) and
        :meth:`walking_up`."""
        if gaps is None:
            return {"near": False, "land": False, "still": False, "far": self.walking_up(()), "still_caught": False}
        g = list(gaps)
        return {"near": self.near(g), "land": self.landing(g), "still": self.stepless(g, before), "far": self.walking_up(g),
                "still_caught": within(self.config.hold_step_caught, g)}

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
              far: bool = False, flight: bool = False, still_caught: bool = False) -> np.ndarray:
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
        ``still``; ``still_caught``: a sub-goal's gap at the end of the last frame is within ``hold_step_caught``: while
        ``caught``, as ``still``."""
        if self.needs_physical and physical is None:
            raise SimulationError("FootLock.apply: glide_gap and restep_gap need the physical ankle frames")
        out = np.array(ankles, dtype=np.float64)
        c = self.config
        held = touching and c.hold_in_contact
        still = still or flight or (still_caught and caught)  # (hold_step_flight, _caught: the foot stays)
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
