"""A foot lock's step taken by the balance controller on the stance foot, without the harness.

Without it the controller stands only while both feet are planted: when the foot lock unplants a foot (a recorded
step) the controller stops, the position servos track the IK's joints, and the harness catches the robot (reason
"step") and holds it until a release delay after the landing (docs/design.md §5, issue 25, session 34). With
``BalanceConfig.single_support`` a step that begins while the harness is off is taken in two phases:

- ``shift``: the swing foot still stands (its rows and contacts as before, whatever its IK target); the centre of
  mass's reference is clipped into the stance foot's sole, and the step waits for the capture point ξ to come inside
  that sole by ``release_margin``;
- ``swing``: the swing foot's contacts, rows and sole leave the controller's problem (the support box, the centres of
  pressure, the friction cones and the centre of mass's reference are the stance foot's alone); the swing leg follows
  the IK's joint targets (the recorded lift and placement) through the joints' task.

The harness stays off through both while the torso stays within ``catch_tilt`` and ξ within the support box (the
stance sole in ``swing``) by ``catch_margin``, and is not let go during either. A step that begins with the harness on,
and a phase the harness ends by a catch, are today's (``off``). Once both feet are planted again the phase is
``stand`` and the controller re-reads where the feet stand.
"""

from __future__ import annotations

import mujoco
import numpy as np

from .feet_on_floor import FeetOnFloor
from .support_box import SupportBox

__all__ = ["PHASES", "SingleSupport", "next_phase", "stance_box"]

PHASES = ("stand", "shift", "swing", "off")
"""The step's phases (module docstring)."""


def next_phase(phase: str, planted: tuple[bool, bool], released: bool) -> str:
    """The phase of a physics step given the last step's ``phase``, the foot lock's ``planted`` feet (left, right)
    and whether the harness is off (``released``, as of the last step). ``shift`` → ``swing`` is not decided here
    (:meth:`SingleSupport.lift`)."""
    if planted[0] and planted[1]:
        return "stand"
    if planted[0] == planted[1]:  # no foot planted
        return "off"
    if phase == "stand":
        return "shift" if released else "off"
    if phase in ("shift", "swing"):
        return phase if released else "off"
    return "off"


class SingleSupport:
    """The step phase of one balance controller (module docstring); :meth:`reset` per episode, :meth:`advance` per
    physics step before the harness's decision."""

    def __init__(self, lift: bool = True) -> None:
        self.lift_allowed = lift
        """``True`` (``"swing"``): a shift ends in a swing once the capture point is over the stance sole;
        ``False`` (``"stand"``): the step is stood through in ``shift``."""
        self.reset()

    def reset(self) -> None:
        """A new episode: standing (nothing planted yet means ``off`` at the first step)."""
        self.phase = "stand"
        """This physics step's phase (:data:`PHASES`)."""
        self.stance = -1
        """The stance foot (0 left, 1 right) in ``shift`` and ``swing``, else −1."""
        self.shift_steps = self.swing_steps = self.lifts = 0
        """Physics steps in ``shift`` and in ``swing``; ``shift`` → ``swing`` transitions (steps taken released)."""

    def advance(self, planted: tuple[bool, bool], released: bool) -> bool:
        """The step's phase from the foot lock's ``planted`` feet and the harness's ``released`` (as of the last
        step); returns whether the controller must re-read where the feet stand (a step phase just ended)."""
        was = self.phase
        self.phase = next_phase(was, planted, released)
        self.stance = (0 if planted[0] else 1) if self.phase in ("shift", "swing") else -1
        self.shift_steps += int(self.phase == "shift")
        self.swing_steps += int(self.phase == "swing")
        return was in ("shift", "swing") and self.phase not in ("shift", "swing")

    def lift(self) -> None:
        """``shift`` → ``swing`` (the capture point came inside the stance sole)."""
        if self.lift_allowed and self.phase == "shift":
            self.phase = "swing"
            self.lifts += 1

    @property
    def lifting(self) -> bool:
        """Whether this step shifts the weight onto the stance foot to lift the other (``"swing"``, in ``shift``)."""
        return self.lift_allowed and self.phase == "shift"

    @property
    def stepping(self) -> bool:
        """Whether a step is being taken on the stance foot (``shift`` or ``swing``)."""
        return self.phase in ("shift", "swing")


def stance_box(feet: FeetOnFloor, d: mujoco.MjData, pts: np.ndarray, which: np.ndarray, stance: int,
               soles: list[np.ndarray | None]) -> SupportBox | None:
    """The :class:`~.support_box.SupportBox` of the ``stance`` foot's sole alone (along the feet's heading), from
    the feet's contacts ``pts`` (P, 3), ``which`` (P,) and their ``soles`` (:meth:`FeetOnFloor.soles_at`); ``None``
    while the stance foot has no contact with the floor."""
    mine = which == stance
    if not mine.any():
        return None
    only = [sole if s == stance else None for s, sole in enumerate(soles)]
    return SupportBox(feet.footprint(d, pts[mine], which[mine], only), feet.heading(d))
