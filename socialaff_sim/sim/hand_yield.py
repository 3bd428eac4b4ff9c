"""Hands that give way to a push or pull beyond what the feet can carry (``BalanceConfig.hand_yield``).

A robot standing on its feet resists a horizontal force at its hands only by moving its centre of pressure
toward the edge of its soles. Quasi-statically, with the robot's weight W at the centre of mass c, the contacts'
resultant on both arms (horizontal part f, N, u = f / |f|; vertical part f_z, N, up positive) applied at x
(horizontal, m) h above the floor, the moments about the centre of pressure p along u balance:
W (p − c)·u − f_z (p − x)·u = |f| h. The centre of pressure stays ``cop_margin`` m inside the support box,
p·u ≤ e − m, e the box's farthest extent along u. With the capture point ξ in place of c (a robot already moving
toward that edge has less to spare), the horizontal force the feet carry is

    F_feet = (W (e − m − ξ·u) + f_z (x·u − (e − m))) / h      (≤ 0: none);

a person leaning on the hands (f_z < 0) in front of the robot (x·u < e) helps it.

Stubby's pull-ups: the rising person's hand, replayed, presses the robot's hand back and down (a median 46 N
horizontally at 1.05 m, up to 216 N); its 16 cm soles carry about 30 N there with the centre of mass over the
middle of the feet, so the robot tips over its heels (torso 10–15°) until the harness catches it
(docs/benchmarks.md, "The pull-ups' outside support …", issue 25).

:class:`HandYield` is the force-limited arm a real robot has: while |f| > κ F_feet (κ ``hand_yield``) each arm's
wrist reference gives way along the horizontal force on that arm, as a damper of ``yield_damping`` b:
ȯ_s = (|f| − κ F_feet) / b · f_s / |f|; otherwise the offset returns over ``yield_return`` τ: ȯ_s = −o_s / τ.
Only the person's contacts count: an object a grip weld holds presses on the hand it is welded to (forces
internal to robot and object; counted, they set the hand overs' arms giving way for seconds). With ``carried``
(``BalanceConfig.yield_carried``) the object counts as the person's while the person still carries it (before its
release the recorded track moves it and nothing moves back): its contacts and its grip welds' forces on the
robot then count too (:func:`~socialaff_sim.sim.external_force.weld_force`), the weld's at its hand body's origin. The offset (world,
horizontal, m, at most :data:`MAX_OFFSET`) moves the arm's hinge references by the damped least-squares
Δq = Jᵀ (J Jᵀ + λ² I)⁻¹ o over the arm's hinges (J the wrist's horizontal translational Jacobian there), and
their reference velocities by the same map of ȯ. The forces are the contacts' of the last step
(:class:`~.external_force.ExternalForces`, read once per step by the controller), low-pass filtered over ``external_filter``.
"""

from __future__ import annotations

import mujoco
import numpy as np

from .._norms import norm, norms
from .arm_kernel import arm_kernel, damped_step, yield_update
from .arm_contacts import arm_hinges, filtered_arm_force, person_geoms
from .external_force import Contacts, weld_force
from .scene import Scene
from .support_box import SupportBox

__all__ = ["HandYield", "feet_allowance", "twist_allowance", "yield_rate", "MAX_OFFSET", "DAMPING_LAMBDA"]

MAX_OFFSET = 0.3
"""[m]: the longest a wrist reference gives way."""
DAMPING_LAMBDA = 0.05
"""λ [m]: damping of the least-squares map of a wrist offset onto the arm's hinges."""
_DAMPING = DAMPING_LAMBDA ** 2 * np.eye(2)  # λ² I, made once


def feet_allowance(box: SupportBox, direction: np.ndarray, point: np.ndarray, margin: float, weight: float,
                   height: float, lift: float = 0.0, at: np.ndarray | None = None) -> float:
    """F_feet (N, ≥ 0): the horizontal force along ``direction`` (2,) (unit, world) at ``height`` (m) above the floor
    that the feet carry with the centre of pressure kept ``margin`` (m) inside ``box`` and the weight ``weight``
    (N) acting at ``point`` (2,) (world, m; the capture point), while the same contacts also push up with ``lift``
    (N; negative: down) at ``at`` (2,) (world, m)."""
    u = np.asarray(direction, dtype=np.float64)
    local = box.R @ u  # the direction along the box's axes: its farthest corner is where each axis' sign points
    corner = np.where(local >= 0.0, box.hi, box.lo)
    edge = float(corner @ local) - margin
    moment = weight * (edge - float(np.asarray(point, dtype=np.float64) @ u))
    if at is not None:
        moment += lift * (float(np.asarray(at, dtype=np.float64) @ u) - edge)
    return max(moment / max(height, 1e-3), 0.0)


def twist_allowance(middle: np.ndarray, direction: np.ndarray, at: np.ndarray, weight: float, twist: float) -> float:
    """F_twist (N, > 0; inf on a line through ``middle``): the horizontal force along ``direction`` (2,) (unit, world)
    at ``at`` (2,) (world, m) whose moment about the vertical through ``middle`` (2,) (the feet's support box's middle)
    is ``twist`` (σ, m) times ``weight`` (N): F_twist = σ W / |((a − m) × u)_z|."""
    rel = np.asarray(at, dtype=np.float64) - np.asarray(middle, dtype=np.float64)
    u = np.asarray(direction, dtype=np.float64)
    lever = abs(float(rel[0] * u[1] - rel[1] * u[0]))
    return twist * weight / lever if lever > 1e-9 else float("inf")


def yield_rate(forces: np.ndarray, allowance: float, fraction: float, damping: float) -> np.ndarray:
    """(2, 2) ȯ (m/s, world, horizontal) of each arm's wrist offset while the horizontal forces ``forces`` (2, 2)
    (N, on the left and right arm) exceed ``fraction`` × ``allowance``; zeros otherwise (the offsets then return,
    :meth:`HandYield.update`)."""
    f = np.asarray(forces, dtype=np.float64)
    total = norm(f.sum(axis=0))
    excess = total - fraction * allowance
    if excess <= 0.0 or total <= 0.0:
        return np.zeros((2, 2))
    return excess / damping * f / total


class HandYield:
    """The arms' give of one physics scene (see the module docstring); :meth:`reset` per episode, :meth:`measure`
    after each physics step the robot stands, :meth:`references` (:meth:`update`, :meth:`offsets`) before each solve
    of the balance controller."""

    def __init__(self, scene: Scene, fraction: float, damping: float, back: float, filter_time: float,
                 twist: float | None = None, carried: bool = False, kernel: str = "numpy") -> None:
        m = scene.model
        self.scene = scene
        self.twist = twist
        """σ (m): the allowance is also at most :func:`twist_allowance` (``BalanceConfig.yield_twist``); ``None``: not."""
        self.carried = bool(carried) and scene.object_geom >= 0
        """Whether the object's forces count as the person's while the person carries it (``yield_carried``)."""
        self._grip = [(int(e), int(b), int(np.flatnonzero(scene.arm_geom[s])[0]))  # weld, its hand body, an arm geom
                      for s, (e, b) in enumerate(zip(scene.grip_eq, scene.grip_body, strict=True)) if e >= 0]
        self._root_lin = np.asarray(scene.robot_vadr[:3])
        self._gen = np.zeros(m.nv)
        self.fraction, self.damping, self.back, self.filter_time = fraction, damping, back, filter_time
        self.vadr = np.asarray(scene.robot_vadr)
        self._arm_geom = np.asarray(scene.arm_geom, dtype=bool)
        self._person = person_geoms(scene)
        self._wrist, self._cols = arm_hinges(scene)
        self._arm_v = [self.vadr[c] for c in self._cols]  # each arm's dofs, made once
        self._compiled = kernel == "numba" and arm_kernel() is not None  # (``qp_kernel``: the step compiled, made now)
        self._arm_v64 = [np.asarray(v, dtype=np.int64) for v in self._arm_v]
        self._jp = np.zeros((3, m.nv))
        self.reset()

    def reset(self) -> None:
        """No offsets, no forces measured."""
        self.offset = np.zeros((2, 2))
        """(2, 2) each arm's wrist reference offset (world, horizontal, m)."""
        self.rate = np.zeros((2, 2))
        """(2, 2) its rate of change at the last update (m/s)."""
        self.force = np.zeros((2, 3))
        """(2, 3) the filtered contact force on each arm (world, N)."""
        self._height = 1.0
        self._at = np.zeros(2)
        self.yield_steps = 0
        """Updates in which the arms gave way."""

    def measure(self, m: mujoco.MjModel, contacts: Contacts, d: mujoco.MjData | None = None,
                carried: bool = False) -> None:
        """Fold the person's contact forces on each arm of the step just taken (``contacts``, the robot's contacts
        of that step) into their filtered estimate; with :attr:`carried` and ``carried`` (the person carries the
        object at this step) the object's contacts and its active grip welds' forces at ``d`` too."""
        pts, forces, geoms, others = contacts
        mine = self._person[others]  # an object held by a grip weld presses on the hand it is welded to
        held = self.carried and carried and d is not None
        if held:  # ... but the person's track holds the object: it is the person's hand
            mine = mine | (others == self.scene.object_geom)
        pts, forces, geoms = pts[mine], forces[mine], geoms[mine]
        if held:
            welds = [(weld_force(m, d, e, self._root_lin, self._gen), d.xpos[b], g)
                     for e, b, g in self._grip if d.eq_active[e]]
            if welds:
                pts = np.vstack([pts] + [p[None] for _, p, _ in welds])
                forces = np.vstack([forces] + [f[None] for f, _, _ in welds])
                geoms = np.concatenate([geoms, np.array([g for _, _, g in welds], dtype=np.int64)])
        self.force = filtered_arm_force(self.force, forces, geoms, self._arm_geom, m, self.filter_time)
        on = self._arm_geom[:, geoms].any(axis=0) if len(geoms) else np.zeros(0, dtype=bool)
        if on.any():  # where the forces act: their points' mean, weighted by the force
            w = norms(forces[on], axis=1) + 1e-9
            self._height = float(pts[on, 2] @ w / w.sum())
            self._at = (w @ pts[on, :2]) / w.sum()

    def update(self, dt: float, box: SupportBox, capture: np.ndarray, floor: float, margin: float,
               weight: float) -> None:
        """Advance the offsets by ``dt`` (s): give way while the arms' horizontal force exceeds the feet's allowance
        (:func:`feet_allowance` at ``capture`` (2,), the floor's height ``floor`` m; with ``twist`` also at most
        :func:`twist_allowance`), return otherwise."""
        if self._compiled:  # (:mod:`~.arm_kernel`)
            self.offset, self.rate, gave = yield_update(
                self.force, self.offset, box.R, box.lo, box.hi, np.asarray(capture, dtype=np.float64), margin, weight,
                self._height - floor, self._at, np.nan if self.twist is None else self.twist, self.fraction,
                self.damping, self.back, dt, MAX_OFFSET)
            self.yield_steps += int(gave)
            return
        f = self.force[:, :2]
        total = f.sum(axis=0)
        nrm = norm(total)
        allow = feet_allowance(box, total / nrm, capture, margin, weight, self._height - floor,
                               float(self.force[:, 2].sum()), self._at) if nrm > 0 else 0.0
        if self.twist is not None and nrm > 0:  # nor more twist about the vertical than the feet hold unturned
            allow = min(allow, twist_allowance(box.middle(), total / nrm, self._at, weight, self.twist))
        rate = yield_rate(f, allow, self.fraction, self.damping)
        if rate.any():
            self.yield_steps += 1
        else:
            rate = -self.offset / self.back if self.back > 0 else -self.offset / dt
        self.offset = self.offset + dt * rate
        n = norms(self.offset, axis=1, keepdims=True)
        self.offset *= np.minimum(1.0, MAX_OFFSET / np.maximum(n, 1e-12))
        self.rate = rate

    def references(self, m: mujoco.MjModel, d: mujoco.MjData, box: SupportBox, capture: np.ndarray, floor: float,
                   margin: float, weight: float) -> tuple[np.ndarray, np.ndarray]:
        """One physics step of ``d`` (:meth:`update` over its time step, then :meth:`offsets`)."""
        self.update(m.opt.timestep, box, capture, floor, margin, weight)
        return self.offsets(m, d)

    def offsets(self, m: mujoco.MjModel, d: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """(n − 6,) hinge reference offsets (rad) and (n − 6,) reference velocity offsets (rad/s) that move each
        wrist by its offset (:attr:`offset`, :attr:`rate`) at the state ``d``."""
        dq = np.zeros(len(self.vadr))
        dv = np.zeros(len(self.vadr))
        for s in (0, 1):
            if not (self.offset[s].any() or self.rate[s].any()):
                continue
            mujoco.mj_jacBody(m, d, self._jp, None, self._wrist[s])
            if self._compiled:  # (:mod:`~.arm_kernel`: the horizontal rows, offset and rate at once)
                step = damped_step(self._jp, self._arm_v64[s], DAMPING_LAMBDA, self.offset[s], self.rate[s])
                dq[self._cols[s]] += step[0]
                dv[self._cols[s]] += step[1]
                continue
            J = self._jp[:2][:, self._arm_v[s]]
            inv = J.T @ np.linalg.inv(J @ J.T + _DAMPING)
            dq[self._cols[s]] += inv @ self.offset[s]
            dv[self._cols[s]] += inv @ self.rate[s]
        return dq[6:], dv[6:]
