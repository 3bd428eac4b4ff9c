"""Arm references that make up for the trunk's pose error (``BalanceConfig.arm_compensation``).

The balance QP tracks the IK's joint angles, but a released robot's trunk (root and torso) is not where the plan
puts it: only the feet hold it, and a fast arm swing rolls or pitches it 5–11° off the plan (Stubby's high fives,
docs/benchmarks.md, "Why the standing robot's hand stops short of a high five …"). An arm that meets its joint
references on a trunk so turned puts the hand 10–30 cm from the plan's in the world, and the contact completion,
which moves the commanded wrist by the physical hand's offset, then aims beyond the arm's reach and its gate shuts.

:class:`ArmCompensation` moves each arm's hinge references, at every physics step the controller drives, so that
the wrist on the *physical* trunk goes where the plan's wrist is in the world. With x_p the wrist in the plan's
forward kinematics (the step's reference q_ref, base included) and x̂ the wrist with the robot as it is but the
arm's hinges at their references (both world, m), the arm's references move by

    Δq = c · s · Jᵀ (J Jᵀ + λ² I)⁻¹ (x_p − x̂)

over the arm's hinges (J the wrist's translational Jacobian there at x̂'s configuration, λ :data:`DAMPING_LAMBDA`,
c ``arm_compensation``), s = max(0, 1 − |f| / F_r) fading it out as the person's force f on that arm (filtered
over ``external_filter``) reaches F_r ``compensation_release`` (in a grasp the hand is where the person holds
it, and the hands' give, :mod:`~.hand_yield`, decides). The offset is a reference, not a task: the joints' rows
keep their weight, and nothing is done while the harness holds the robot (the servos then track the plan on a
trunk the harness holds).

With ``compensation_gate`` d_g set, the compensation is confined to the *approach* of a contact: an arm is
compensated only while its plan's wrist x_p is within d_g of the nearest thing it may touch (a geom of the person,
or the interaction's free object, by its centre; :func:`approach_gate`) and until that arm first touches the person
or the object in the episode (a latch, :attr:`ArmCompensation.touched`). A held contact (a pull-up, a handshake, a
carried cup) then gets none, whatever force it carries.
"""

from __future__ import annotations

import mujoco
import numpy as np

from .._norms import norms
from .arm_kernel import arm_kernel, compensation_share, damped_step
from .arm_contacts import arm_hinges, filtered_arm_force, person_geoms, wrist_frames, wrist_positions
from .external_force import Contacts
from .scene import Scene

__all__ = ["ArmCompensation", "DAMPING_LAMBDA", "approach_gate", "fade", "compensation_step"]

DAMPING_LAMBDA = 0.05
_DAMP3 = DAMPING_LAMBDA * DAMPING_LAMBDA * np.eye(3)  # λ² I of a wrist's three rows, made once
_DAMP3.flags.writeable = False
"""λ [m]: damping of the least-squares map of a wrist shift onto the arm's hinges."""


def fade(force: np.ndarray, release: float) -> np.ndarray:
    """(2,) s per arm: 1 − |f| / F_r clipped to [0, 1], ``force`` (2, 3) N per arm, ``release`` F_r (N)."""
    return np.clip(1.0 - norms(np.asarray(force, dtype=np.float64), axis=1) / release, 0.0, 1.0)


def approach_gate(wrists: np.ndarray, targets: np.ndarray, touched: np.ndarray, radius: float) -> np.ndarray:
    """(2,) 1.0 per arm whose wrist ``wrists`` (2, 3) (world, m) is within ``radius`` d_g (m) of one of ``targets``
    (K, 3) (world, m) and that has not ``touched`` (2,) bool, else 0.0 (no targets: 0.0)."""
    w = np.asarray(wrists, dtype=np.float64)
    t = np.asarray(targets, dtype=np.float64).reshape(-1, 3)
    if not len(t):
        return np.zeros(len(w))
    near = norms(w[:, None, :] - t[None, :, :], axis=2).min(axis=1) <= radius
    return (near & ~np.asarray(touched, dtype=bool)).astype(np.float64)


def compensation_step(jac: np.ndarray, shift: np.ndarray, lam: float = DAMPING_LAMBDA) -> np.ndarray:
    """(k,) hinge offsets (rad) Jᵀ (J Jᵀ + λ² I)⁻¹ e moving a point with translational Jacobian ``jac`` (3, k) on k
    hinges by ``shift`` e (3,) (m), damped by ``lam`` λ (m)."""
    J = np.asarray(jac, dtype=np.float64)
    damp = _DAMP3 if lam == DAMPING_LAMBDA and J.shape[0] == 3 else lam * lam * np.eye(J.shape[0])
    return J.T @ np.linalg.solve(J @ J.T + damp, np.asarray(shift, dtype=np.float64))


class ArmCompensation:
    """The arms' trunk compensation of one physics scene (module docstring); :meth:`reset` per episode,
    :meth:`measure` after each physics step the robot stands, :meth:`offsets` before each solve of the controller."""

    def __init__(self, scene: Scene, fraction: float, release: float, filter_time: float,
                 gate: float | None = None, kernel: str = "numpy") -> None:
        m = scene.model
        self.scene, self.fraction, self.release, self.filter_time = scene, fraction, release, filter_time
        self.gate = gate
        """d_g (m): the approach's radius (``compensation_gate``), ``None``: ungated."""
        self.vadr = np.asarray(scene.robot_vadr)
        self.qadr = np.asarray(scene.robot_qadr)
        self._arm_geom = np.asarray(scene.arm_geom, dtype=bool)
        self._person = person_geoms(scene)
        self._target = self._person.copy()  # what a hand may reach for: the person and the free object
        if scene.object_geom >= 0:
            self._target[scene.object_geom] = True
        self._target_ids = np.flatnonzero(self._target)
        self._frames = wrist_frames(scene)
        self._wrist, self._cols = arm_hinges(scene)
        # per arm, made once: its hinges' qpos addresses (robot_qadr[7 + (dof − 6)]), their entries of q_ref and dofs
        self._arm_q = [(self.qadr[c + 1], c + 1, self.vadr[c]) for c in self._cols]
        self._scratch = mujoco.MjData(m)
        self._jp = np.zeros((3, m.nv))
        self._compiled = kernel == "numba" and arm_kernel() is not None  # (``qp_kernel``: the step compiled, made now)
        self._dofs = [np.asarray(v, dtype=np.int64) for _, _, v in self._arm_q]
        self._none3 = np.zeros((0, 3))
        self.reset()

    def reset(self) -> None:
        """No forces measured."""
        self.force = np.zeros((2, 3))
        """(2, 3) the filtered contact force of the person on each arm (world, N)."""
        self.shift = np.zeros((2, 3))
        """(2, 3) x_p − x̂ of the last :meth:`offsets` (world, m)."""
        self.touched = np.zeros(2, dtype=bool)
        """(2,) whether each arm has touched the person or the object this episode (``gate`` only)."""

    def measure(self, m: mujoco.MjModel, contacts: Contacts) -> None:
        """Fold the person's contact forces on each arm of the step just taken (``contacts``, the robot's contacts
        of that step) into their filtered estimate."""
        _, forces, geoms, others = contacts
        if self.gate is not None and len(geoms):  # the approach ends at an arm's first touch
            hit = self._target[others]
            self.touched |= np.array([bool(self._arm_geom[s][geoms[hit]].any()) for s in (0, 1)])
        mine = self._person[others]
        forces, geoms = forces[mine], geoms[mine]
        self.force = filtered_arm_force(self.force, forces, geoms, self._arm_geom, m, self.filter_time)

    def _wrists(self, d: mujoco.MjData) -> np.ndarray:
        return wrist_positions(d, self._frames)

    def offsets(self, m: mujoco.MjModel, d: mujoco.MjData, q_ref: np.ndarray) -> np.ndarray:
        """(n − 6,) hinge reference offsets (rad) that put each wrist, on the trunk of ``d``, where the plan's
        robot coordinates ``q_ref`` (nq_r,) put it (world), scaled by c and the force's fade."""
        dq = np.zeros(len(self.vadr))
        share = self.fraction * fade(self.force, self.release) if not self._compiled else compensation_share(
            self.force, self.release, self.fraction, False, self._none3, self._none3, self.touched, 0.0)
        if self.gate is not None and self.touched.all():  # the touches end compensation
            share = np.zeros(2)
        s_ = self._scratch
        if share.any():
            s_.qpos[:] = d.qpos
            s_.qpos[self.qadr] = q_ref
            mujoco.mj_kinematics(m, s_)
            plan = self._wrists(s_)
            if self.gate is not None:  # only an arm on its way to a touch, near what it may touch
                share = share * approach_gate(plan, d.geom_xpos[self._target_ids], self.touched, self.gate) if (
                    not self._compiled) else compensation_share(self.force, self.release, self.fraction, True, plan,
                                                                d.geom_xpos[self._target_ids], self.touched, self.gate)
        if not share.any():
            self.shift[:] = 0.0
            return dq[6:]
        s_.qpos[self.qadr] = d.qpos[self.qadr]
        for q_idx, ref, _ in self._arm_q:  # the arms' hinges at their references, the rest (trunk, base) as it is
            s_.qpos[q_idx] = q_ref[ref]
        mujoco.mj_kinematics(m, s_)
        mujoco.mj_comPos(m, s_)
        here = self._wrists(s_)
        self.shift = plan - here
        for s in (0, 1):
            if share[s] <= 0.0:
                continue
            mujoco.mj_jac(m, s_, self._jp, None, here[s], self._wrist[s])
            if self._compiled:  # (:mod:`~.arm_kernel`)
                dq[self._cols[s]] += share[s] * damped_step(self._jp, self._dofs[s], DAMPING_LAMBDA, self.shift[s])[0]
                continue
            J = self._jp[:, self._arm_q[s][2]]
            dq[self._cols[s]] += share[s] * compensation_step(J, self.shift[s])
        return dq[6:]
