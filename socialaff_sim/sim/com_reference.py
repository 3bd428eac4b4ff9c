"""The balance controller's centre-of-mass reference c* (``BalanceConfig.com_reference``, ``com_shift``).

Per data frame the IK's plan gives the middle of its feet p̄_plan and its centre of mass's offset from it
(:meth:`ComReference.begin_frame`). Per physics step c* is, by ``com_reference``, that offset carried onto the
physical feet, p̄ + (c_plan − p̄_plan) (``plan``), or the middle of the support box (``middle``); with ``com_shift``
it is moved forward by the feet's shortfall behind the plan's, which also weights the centre of mass's rows
(:mod:`~.com_shift`); with ``ReachLeanConfig.lead`` (:attr:`ComReference.lead`), in a leaned reach's grip, moved
forward by d_g once an arm has touched. The controller then leans it against the measured external forces
(:func:`~.external_force.lean_offset`) and clips it into the support box
(:class:`~socialaff_sim.sim.balance_control.BalanceController`).
"""

from __future__ import annotations

import mujoco
import numpy as np

from .arm_compensation import ArmCompensation
from .balance_config import BalanceConfig
from .com_shift import forward_shortfall, shift_weight
from .support_box import SupportBox

__all__ = ["ComReference"]


class ComReference:
    """c* of one robot: ``feet`` (F,) its foot bodies' ids, ``root`` its root body's id, ``compensation`` the arms'
    compensation whose touch latch ends ``shift_until_touch`` (``None`` without ``arm_compensation``)."""

    def __init__(self, config: BalanceConfig, feet: np.ndarray, root: int,
                 compensation: ArmCompensation | None) -> None:
        self.config = config
        self._feet, self._root, self._compensation = feet, root, compensation
        self.lead: float | None = None
        """d_g [m]: ``ReachLeanConfig.lead`` where it acts in this episode (set by the simulator at each episode's start),
        else ``None``: :meth:`goal` moves c* d_g forward along the box's heading once an arm has touched."""
        self.reset()

    def reset(self) -> None:
        """A new episode: no plan yet."""
        self._offset = np.zeros(2)
        self._plan_feet = np.zeros(2)

    def begin_frame(self, plan: mujoco.MjData) -> None:
        """The IK's plan for the frame: ``plan`` posed at its end, after ``mj_kinematics`` and ``mj_comPos``."""
        feet = self._plan_feet = self._middle(plan)
        self._offset = plan.subtree_com[self._root, :2] - feet

    def goal(self, d: mujoco.MjData, box: SupportBox) -> tuple[np.ndarray, float]:
        """A physics step's (2,) c* (world, m) before the lean and the box's clip, :meth:`reference` plus
        :meth:`shift`'s shift (and :attr:`lead` along the box's heading after an arm's first touch), and the centre of
        mass's rows' weight; the feet of ``d`` read once for both."""
        feet = self._middle(d)
        s, w = self._shift(feet, box)
        goal = self._reference(feet, box) + s
        if self.lead is not None and self._compensation is not None and self._compensation.touched.any():
            goal = goal + self.lead * box.R[0]  # (ReachLeanConfig.lead: the grip's reference toward the toes)
        return goal, w

    def reference(self, d: mujoco.MjData, box: SupportBox) -> np.ndarray:
        """(2,) c* (world, m) before the shift, the lean and the box's clip, by ``com_reference``: the plan's offset
        from its feet on the feet of ``d``, or the middle of ``box``."""
        return self._reference(self._middle(d), box)

    def shift(self, d: mujoco.MjData, box: SupportBox) -> tuple[np.ndarray, float]:
        """``com_shift``: the reference's forward shift (2,) (world, m) by the feet's shortfall behind the plan's
        along ``box``'s heading, and the centre of mass's rows' weight (:mod:`~.com_shift`); else (and with
        ``shift_until_touch`` after an arm's first touch) none and ``w_com``."""
        return self._shift(self._middle(d), box)

    def _middle(self, d: mujoco.MjData) -> np.ndarray:
        """(2,) the middle of the feet of ``d`` (world, m)."""
        xy = d.xpos[self._feet, :2]
        return np.add.reduce(xy, axis=0) / len(xy)  # (the mean's own sum and division, without its wrapper)

    def _reference(self, feet: np.ndarray, box: SupportBox) -> np.ndarray:
        """:meth:`reference` with the feet's middle ``feet`` (2,)."""
        if self.config.com_reference == "plan":
            return feet + self._offset
        return box.middle()

    def _shift(self, feet: np.ndarray, box: SupportBox) -> tuple[np.ndarray, float]:
        """:meth:`shift` with the feet's middle ``feet`` (2,)."""
        c = self.config
        if c.com_shift is None or (c.shift_until_touch and self._compensation.touched.any()):  # type: ignore[union-attr]
            return np.zeros(2), c.w_com
        s, share = forward_shortfall(self._plan_feet, feet, box.R[0], c.com_shift)
        return s, shift_weight(c.w_com, c.shift_weight, share)
