"""The ankles' roll torque bounded by what the floor can hold: the balance QP's torque limits for
``BalanceConfig.roll_bound``.

A foot pressed on the floor with normal load F_z stays flat on its sole while the moment its ankle puts on it
about the foot's long axis is at most the sole's half-width b times F_z (the floor's centre of pressure then stays
under the sole; beyond it the foot rolls onto its edge). The balance QP models each planted foot flat on its four
corners and keeps the planned centre of pressure ``cop_margin`` inside the sole, so its planned roll torque obeys
the bound for the forces it plans; the forces the floor actually gives a foot differ (the other foot carries more
than planned, the sole sinks unevenly into the soft floor), and traced step by step (docs/design.md §5, "The standing mode's feet tipping onto their
edges …") most of the remaining slide falls while a foot stands rolled on one or two corners. With ``roll_bound``
the ankle's roll joint of each foot gets the torque limits −M ± (b − m_r) · F_z: F_z the foot's vertical load and
M the moment about the joint's axis of the floor's whole force on the foot moved to the sole's middle (the sole's
sideways friction, 8 cm below Stubby's ankle, included), both measured from MuJoCo's contacts with the floor at
the last physics step (:meth:`AnkleRollBound.measure`); a static foot has τ = −M_floor, so these are the torques
that keep the floor's centre of pressure within b − m_r of the sole's middle across it. Within the actuator's own
limits, and never excluding 0 (:meth:`AnkleRollBound.clip`).

The roll joint of a foot is the hinge of the foot's body whose axis lies along the foot's forward axis at home
(|cos| ≥ 0.9); a foot without one (the H1's five-joint legs) is not bounded.
"""

from __future__ import annotations

import mujoco
import numpy as np

from .feet_on_floor import FeetOnFloor

__all__ = ["AnkleRollBound", "roll_joint_rows"]


def roll_joint_rows(m: mujoco.MjModel, feet: FeetOnFloor, vadr: np.ndarray) -> list[int | None]:
    """Each foot's ankle roll joint as a row of the robot's coordinates ``vadr`` (n,): the hinge of the foot's body
    whose axis (body frame) has |cos| ≥ 0.9 with the foot's forward axis at home (the best such), or ``None``."""
    where = {int(v): i for i, v in enumerate(vadr)}
    out: list[int | None] = []
    for s, body in enumerate(feet.bodies):
        best, row = 0.9, None
        for j in range(m.njnt):
            if m.jnt_bodyid[j] != body or m.jnt_type[j] != mujoco.mjtJoint.mjJNT_HINGE:
                continue
            c = abs(float(m.jnt_axis[j] @ feet.forward[s]) / float(np.linalg.norm(m.jnt_axis[j])))
            if c >= best and int(m.jnt_dofadr[j]) in where:
                best, row = c, where[int(m.jnt_dofadr[j])]
        out.append(row)
    return out


class AnkleRollBound:
    """The feet's ankle roll torques bounded to what the floor can hold with each foot flat (module docstring).
    ``margin`` (m): the half-width's reduction (``roll_bound``, m_r)."""

    def __init__(self, m: mujoco.MjModel, feet: FeetOnFloor, vadr: np.ndarray, margin: float) -> None:
        self.rows = roll_joint_rows(m, feet, vadr)
        """Each foot's roll joint's row of the robot's coordinates (``None``: none, not bounded)."""
        dof_jnt = {int(m.jnt_dofadr[j]): j for j in range(m.njnt)}
        self._joints = [None if r is None else dof_jnt[int(vadr[r])] for r in self.rows]
        arms = []
        for s, corners in enumerate(feet.corners):
            if corners is None:
                arms.append(0.0)
                continue
            up = feet.home_rot[s].T @ np.array([0.0, 0.0, 1.0])  # the world's vertical in the foot's frame at home
            side = np.cross(up, feet.forward[s])
            across = corners @ (side / np.linalg.norm(side))
            arms.append(max(0.5 * float(np.ptp(across)) - margin, 0.0))
        self.arms = np.array(arms)
        """(2,) each foot's lever b − margin (m): half its sole's width across its forward axis, less the margin."""
        self._middle = [None if c is None else c.mean(axis=0) for c in feet.corners]  # the soles' middles, body frame
        self._bodies = list(feet.bodies)
        self.loads = np.zeros(len(self._bodies))
        """(2,) each foot's normal (vertical) load from the floor at the last :meth:`measure` (N)."""
        self.moments = np.zeros(len(self._bodies))
        """(2,) the moment (N·m) about each foot's roll axis of the floor's force on it at the last :meth:`measure`,
        the force moved to its sole's middle."""
        self._feet_on_floor = feet

    @classmethod
    def of(cls, m: mujoco.MjModel, feet: FeetOnFloor, vadr: np.ndarray, margin: float | None) -> AnkleRollBound | None:
        """The bound with m_r = ``margin`` (``BalanceConfig.roll_bound``), or ``None`` where that is ``None``."""
        return None if margin is None else cls(m, feet, vadr, margin)

    def measure(self, m: mujoco.MjModel, d: mujoco.MjData) -> None:
        """Each foot's :attr:`loads` and :attr:`moments` from its contacts with the floor after ``mj_step2`` (MuJoCo's
        contact frame: the normal, then two tangents; the force on the foot, whichever geom comes first)."""
        force = self._feet_on_floor.forces(m, d)
        self.loads = force[:, 2].copy()
        for s, j in enumerate(self._joints):
            if j is None or self._middle[s] is None:
                self.moments[s] = 0.0
                continue
            b = self._bodies[s]
            c = d.xpos[b] + d.xmat[b].reshape(3, 3) @ self._middle[s]
            self.moments[s] = float(d.xaxis[j] @ np.cross(c - d.xanchor[j], force[s]))

    def clip(self, limits: np.ndarray) -> np.ndarray:
        """``limits`` (n, 2) (the QP's torque limits, rows of the robot's coordinates) with each roll joint's row
        narrowed to −M ± (b − margin) · F_z, M the floor's moment about the axis with its force at the sole's
        middle (:attr:`moments`): the torques that put the floor's centre of pressure within b − margin of the
        middle across the sole (a static foot: τ = −M_floor); the narrower of that and the row's own limits, and
        never excluding 0 (the QP's free fall stays feasible). In place, returned."""
        for s, row in enumerate(self.rows):
            if row is None:
                continue
            cap = self.arms[s] * max(float(self.loads[s]), 0.0)
            lo, hi = -self.moments[s] - cap, -self.moments[s] + cap
            limits[row, 0] = min(max(limits[row, 0], lo), 0.0)
            limits[row, 1] = max(min(limits[row, 1], hi), 0.0)
        return limits
