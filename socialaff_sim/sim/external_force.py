"""The forces the world other than the floor exerts on the robot, as its contacts report them.

A robot shaking hands, catching a ball or pulling a person up from a chair is pushed and pulled at its hands
(100–170 N in a pull-up). :class:`ExternalForces` reads, after a physics step, every contact between a robot
geom and anything but the floor (the person, the object, the chair), and returns their generalised force on
the robot's coordinates (``Σ J_pᵀ f_p``, J_p the contact point's translational Jacobian) and their resultant
force and moment about a point. The balance controller takes them as known loads for the next step (a
wrist force sensor's reading, one step old), low-pass filtered.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import mujoco
import numpy as np

from .scene import Scene

__all__ = ["Contacts", "ExternalForces", "FilteredExternal", "lean_offset", "weld_force"]


class Contacts(NamedTuple):
    """The robot's contacts with anything but the floor after one physics step (:meth:`ExternalForces.contacts`),
    read once per step and handed to every part of the balance controller that folds them in."""

    points: np.ndarray
    """(K, 3) contact points, world frame, m."""
    forces: np.ndarray
    """(K, 3) their forces on the robot, world frame, N."""
    geoms: np.ndarray
    """(K,) the robot geom each acts on."""
    others: np.ndarray
    """(K,) the geom that pushes it."""


class ExternalForces:
    """Contact forces on the robot from anything but the floor (see the module docstring)."""

    def __init__(self, scene: Scene, exclude_floor: bool = True) -> None:
        """``exclude_floor``: leave out the floor's contacts (``False`` counts them too, as a check: with no other
        constraint acting, the sum is then MuJoCo's own ``qfrc_constraint``)."""
        m = scene.model
        self.scene = scene
        self.vadr = np.asarray(scene.robot_vadr)
        self._robot = np.asarray(scene.robot_geom, dtype=bool)
        self._floor = int(scene.floor_geom) if exclude_floor else -2
        self._jp = np.zeros((3, m.nv))
        self._f6 = np.zeros(6)

    def measure(self, m: mujoco.MjModel, d: mujoco.MjData,
                contacts: Contacts | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """At ``d``'s state after a step (contacts and constraint forces of that step): the generalised force
        (nv_r,) on the robot's coordinates (N, N·m), the contact points (K, 3) and their forces on the robot
        (K, 3), world frame. ``contacts``: this step's :meth:`contacts`, when already read (``None``: read here)."""
        gen = np.zeros(len(self.vadr))
        pts, forces, geoms, _ = self.contacts(m, d) if contacts is None else contacts
        for p, f, g in zip(pts, forces, geoms, strict=True):
            mujoco.mj_jac(m, d, self._jp, None, p, int(m.geom_bodyid[g]))
            gen += self._jp[:, self.vadr].T @ f
        return gen, pts, forces

    def contacts(self, m: mujoco.MjModel, d: mujoco.MjData) -> Contacts:
        """The contacts of :meth:`measure`: points (K, 3), forces on the robot (K, 3), world frame, the robot geom
        (K,) each acts on and the geom (K,) that pushes it."""
        none = np.zeros(0, dtype=np.int64)
        nc = d.ncon
        if not nc:
            return Contacts(np.zeros((0, 3)), np.zeros((0, 3)), none, none)
        con = d.contact  # (each read of MjData.contact and of its fields makes new views: read once)
        g = con.geom[:nc]
        r0, r1 = self._robot[g[:, 0]], self._robot[g[:, 1]]
        floor = (g[:, 0] == self._floor) | (g[:, 1] == self._floor)
        rows = np.flatnonzero((r0 ^ r1) & ~floor & (con.efc_address[:nc] >= 0))
        pts, forces, geoms, others = [], [], [], []
        if len(rows):
            frames, where = con.frame, con.pos
        for i in rows.tolist():
            mujoco.mj_contactForce(m, d, i, self._f6)
            frame = frames[i].reshape(3, 3)
            f = frame.T @ self._f6[:3]  # on geom 1, world frame
            robot_geom, other = int(g[i, 1]), int(g[i, 0])
            if r0[i]:
                f, robot_geom, other = -f, int(g[i, 0]), int(g[i, 1])
            pts.append(where[i].copy())
            forces.append(f)
            geoms.append(robot_geom)
            others.append(other)
        if not pts:
            return Contacts(np.zeros((0, 3)), np.zeros((0, 3)), none, none)
        return Contacts(np.array(pts), np.array(forces), np.array(geoms, dtype=np.int64),
                        np.array(others, dtype=np.int64))


class FilteredExternal:
    """The external contacts' low-pass filtered estimate the balance controller leans against
    (``BalanceConfig.external_forces``): :attr:`gen` (nv_r,) their generalised force on the robot's coordinates (N,
    N·m), :attr:`force` (3,) their resultant (N) and :attr:`moment` (3,) their moment about the world origin (N·m),
    each an exponential average with time constant τ = ``time_constant`` (s; 0: the last step's alone)."""

    def __init__(self, forces: ExternalForces, time_constant: float) -> None:
        self.forces, self.time_constant = forces, float(time_constant)
        self.gen, self.force, self.moment = np.zeros(len(forces.vadr)), np.zeros(3), np.zeros(3)

    def clear(self) -> None:
        """No external force (a new episode, or a step the robot does not stand)."""
        self.gen[:], self.force[:], self.moment[:] = 0.0, 0.0, 0.0

    def measure(self, m: mujoco.MjModel, d: mujoco.MjData, contacts: Contacts) -> None:
        """Fold the external contacts ``contacts`` (:meth:`ExternalForces.contacts`) of the step just taken into the
        estimate."""
        gen, pts, forces = self.forces.measure(m, d, contacts)
        a = math.exp(-m.opt.timestep / self.time_constant) if self.time_constant > 0 else 0.0
        self.gen = a * self.gen + (1.0 - a) * gen
        self.force = a * self.force + (1.0 - a) * forces.sum(axis=0)
        self.moment = a * self.moment + (1.0 - a) * np.cross(pts, forces).sum(axis=0)


def lean_offset(moment: np.ndarray, force: np.ndarray, point: np.ndarray, weight: float) -> np.ndarray:
    """(2,) horizontal shift (m) of the centre of mass that keeps the centre of pressure at ``point`` (3,) on the
    floor under external forces of resultant ``force`` (3,) N and moment ``moment`` (3,) N·m about the world
    origin, for a robot of ``weight`` N: with M their moment about the point, M_y + W (c_x − p_x) = 0 and
    M_x − W (c_y − p_y) = 0 (a forward pull above the floor leans the robot back)."""
    mom = np.asarray(moment, dtype=np.float64) - np.cross(point, force)
    return np.array([-mom[1], mom[0]]) / weight


def weld_force(m: mujoco.MjModel, d: mujoco.MjData, eq: int, dofs: np.ndarray, out: np.ndarray) -> np.ndarray:
    """(3,) the force (N, world) the active equality ``eq`` exerts on the robot at ``d``'s last step: ``Jᵀλ`` of its
    constraint rows on the robot's root translation ``dofs`` (3,) (a free joint's: the resultant of every force on
    the robot; an equality between a robot body and the object has no other share in it). Zeros when inactive.
    ``out`` (nv,) is scratch."""
    rows = (d.efc_type[: d.nefc] == int(mujoco.mjtConstraint.mjCNSTR_EQUALITY)) & (d.efc_id[: d.nefc] == eq)
    if not rows.any():
        return np.zeros(3)
    lam = np.where(rows, d.efc_force[: d.nefc], 0.0)
    mujoco.mj_mulJacTVec(m, d, out, lam)
    return out[dofs].copy()
