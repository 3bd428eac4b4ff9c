"""How physical a robot's motion is: the support it gets from anything but its feet, and its effort.

:class:`SupportMeter` reads the physics state after every step and keeps, per
data frame:

* **outside support**: the force of the harness (the weld that holds the
  robot's root to its mocap anchor, or to the spring-mounted carriage of a
  compliant harness, as the generalised force ``Jᵀλ`` of the weld's constraint
  rows on the root's translational coordinates) plus the weight carried by
  gravity compensation (``Σ gravcomp·m·g`` over the robot's bodies), as a
  fraction of the robot's weight ``m·g``: the mean over the frame's physics steps
  and its peak;
* **foot sliding**: the horizontal distance a foot (the subtree of an ankle key
  frame's body) moves while it touches the floor on two consecutive steps, m (the
  path: a foot rocking or shaking in place adds to it as one dragged along does),
  and the box of the foot's horizontal positions while it touches the floor (its
  diagonal over a phase bounds how far the foot got from where it stood);
* **sole slip** (:mod:`~socialaff_sim.sim.sole_slip`, a different figure from the sliding path): how far the
  feet's floor contacts slip along the floor, each contact carried with its sole while it persists (a sole
  rocking on an edge that stays put adds ≈ 0), the feet's **steps** (a foot leaving the floor, rising above
  a clearance and landing again: their number and summed length, not slip) and **skims** (a foot off the floor
  that stays within the clearance: neither slip nor step);
* **penetration**: the deepest robot–floor contact, m;
* **effort**: the largest ratio of an actuator's force to its force limit, and
  whether any servo is saturated (≥ :data:`SATURATED` of its limit) or any robot
  joint is at the end of its range (within :data:`AT_LIMIT` rad).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from .._norms import norm
from ..retarget.kinematic_tree import shared_ancestor, subtree_mask
from .external_force import weld_force
from .scene import Scene
from .sole_slip import SoleSlip

__all__ = ["SupportMeter", "FrameSupport", "SATURATED", "AT_LIMIT"]

SATURATED = 0.99
"""An actuator force at this fraction of its limit or more counts as saturated."""
AT_LIMIT = 1e-3
"""A joint this close (rad or m) to an end of its range counts as at its limit."""


@dataclass(frozen=True)
class FrameSupport:
    """Support and effort figures of one data frame (see the module docstring)."""

    outside_mean: float
    """Mean outside support over the frame's physics steps, fraction of the robot's weight."""
    outside_peak: float
    """Its largest value in the frame."""
    slide: float
    """Horizontal foot sliding in the frame (largest of the feet), m."""
    penetration: float
    """Deepest robot–floor penetration in the frame, m."""
    torque_ratio: float
    """Largest |actuator force| / force limit in the frame (0 without limited actuators)."""
    saturated: float
    """Fraction of the frame's physics steps with a saturated servo."""
    at_limit: float
    """Fraction of the frame's physics steps with a robot joint at the end of its range."""
    tilt_deg: float = 0.0
    """Largest angle in the frame between the torso's up axis and the vertical, degrees (the torso: the
    body both shoulders hang from)."""
    feet_lo: tuple[float, float, float, float] = (math.inf,) * 4
    """Lowest horizontal coordinates (m, world; left x, left y, right x, right y) of each foot's body at the
    frame's physics steps in which it touches the floor (inf: it did not)."""
    feet_hi: tuple[float, float, float, float] = (-math.inf,) * 4
    """... and the highest (−inf: it did not touch)."""
    slip: float = 0.0
    """How far the soles' floor contacts slipped along the floor in the frame (largest of the feet), m: not the
    sliding path (:attr:`slide`, the ankle body's), see :mod:`~socialaff_sim.sim.sole_slip`."""
    steps: int = 0
    """Steps that landed in the frame (a foot that left the floor touching it again), both feet."""
    step_length: float = 0.0
    """Their summed horizontal length (the ankle body's origin from its last touch to its new one), m."""
    skims: int = 0
    """Skims that ended in the frame (a foot off the floor within the clearance touching it again), both feet."""
    skim_length: float = 0.0
    """Their summed length (the foot's last contacts carried with it, their mean horizontal move), m."""


class SupportMeter:
    """Accumulates :class:`FrameSupport` figures; :meth:`reset` before an episode, :meth:`update` after every
    physics step, :meth:`end_frame` after the last step of a data frame."""

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        m = scene.model
        robot_bodies = subtree_mask(m, scene.root_body)
        mass = m.body_mass[robot_bodies]
        self.mass = float(mass.sum())
        """Robot mass, kg."""
        self.weight = self.mass * float(np.linalg.norm(m.opt.gravity))
        """Robot weight, N."""
        self.gravcomp_fraction = float((m.body_gravcomp[robot_bodies] * mass).sum() / self.mass) if self.mass else 0.0
        """Share of the robot's weight carried by gravity compensation (0: real weight)."""
        self._weld = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, "robot_anchor")
        self._eq_type = int(mujoco.mjtConstraint.mjCNSTR_EQUALITY)
        # Constraint rows of each equality before the harness weld when active (weld 6, connect 3, others 1).
        rows = {int(mujoco.mjtEq.mjEQ_WELD): 6, int(mujoco.mjtEq.mjEQ_CONNECT): 3}
        self._eq_rows_before = np.array([rows.get(int(t), 1) for t in m.eq_type[: max(self._weld, 0)]], dtype=np.int64)
        self._weld_row: dict[bytes, int] = {}  # the weld's first row per pattern of active equalities before it
        self._root_lin = scene.robot_vadr[:3]
        self._feet = []
        for k in (3, 4):
            body = scene.frame_body(k)
            inside = subtree_mask(m, body)
            self._feet.append((body, inside[m.geom_bodyid] & scene.robot_geom))
        self._robot_geom = scene.robot_geom
        self._foot_bodies = np.array([b for b, _ in self._feet], dtype=np.int64)
        self._sole_slip = SoleSlip(m, scene.floor_geom, [g for _, g in self._feet], self._foot_bodies)
        # Geom classes for the contact pass (see _flush): robot 1, left foot +2, right foot +4, floor 8.
        code = np.where(scene.robot_geom, 1, 0) + 2 * self._feet[0][1] + 4 * self._feet[1][1]
        if scene.floor_geom >= 0:
            code[scene.floor_geom] = 8
        self._code = code.astype(np.int64)
        self._torso = shared_ancestor(m, int(scene.limb_body_ids[0]), int(scene.limb_body_ids[1]), scene.root_body)
        # The torso's own axis that points up at home (models differ in how their bodies' frames sit).
        self._torso_up = scene.home_data().xmat[self._torso].reshape(3, 3).T @ np.array([0.0, 0.0, 1.0])
        lim = np.where(m.actuator_forcelimited[scene.act_ids].astype(bool),
                       np.abs(m.actuator_forcerange[scene.act_ids]).max(axis=1), np.inf)
        self._act_limit = lim
        joints = scene.robot_joint_ids[1:]
        limited = m.jnt_limited[joints].astype(bool)
        self._lim_qadr = m.jnt_qposadr[joints[limited]]
        self._lim_range = m.jnt_range[joints[limited]]
        self._res = np.zeros(m.nv)
        self.frames: list[FrameSupport] = []
        self.reset()

    def reset(self) -> None:
        """Forget everything (a new episode)."""
        self.frames = []
        self._foot_prev: list[np.ndarray | None] = [None, None]
        self._feet_down = (True, True)
        self._sole_slip.reset()
        self._clear_frame()

    @property
    def feet_down(self) -> tuple[bool, bool]:
        """Whether each foot (left, right) touched the floor at the last physics step."""
        self._flush()
        return self._feet_down

    def _clear_frame(self) -> None:
        self._n = 0
        self._out_sum = self._out_peak = self._slide_max = self._pen = self._ratio = 0.0
        self._slide = [0.0, 0.0]
        self._sat = self._lim = 0
        self._tilt = 0.0
        self._lo = np.full(4, math.inf)
        self._hi = np.full(4, -math.inf)
        self._clear_pending()

    def _clear_pending(self) -> None:
        # Raw readings of the physics steps not yet accounted for (see update and _flush).
        self._p_outside: list[float] = []
        self._p_codes: list[np.ndarray | None] = []
        self._p_dist: list[np.ndarray | None] = []
        self._p_feet: list[np.ndarray] = []
        self._p_force: list[np.ndarray] = []
        self._p_q: list[np.ndarray] = []
        self._p_up: list[np.ndarray] = []

    def harness_force(self, data: mujoco.MjData) -> np.ndarray:
        """(3,) force (N, world frame) the harness weld exerts on the robot's root at the current state."""
        if self._weld < 0:
            return np.zeros(3)
        return weld_force(self.scene.model, data, self._weld, self._root_lin, self._res)

    def _harness_norm(self, data: mujoco.MjData) -> float:
        """‖:meth:`harness_force`‖ (N), read straight off the weld's constraint rows.

        The weld's first three rows are its translational ones, and their Jacobian on the root's free-joint
        translation is ±I (that joint moves the root in world coordinates), so ``Jᵀλ`` there is ±λ of those
        rows. MuJoCo lays the equality rows out first, in equality order, active ones only; when the rows
        are not where that puts them, the general path is taken."""
        nefc = data.nefc
        if self._weld < 0 or nefc == 0:
            return 0.0
        off = 0
        if self._weld:  # the same few patterns recur (grips on or off): looked up, not summed, every physics step
            active = data.eq_active[: self._weld]
            key = active.tobytes()
            off = self._weld_row.get(key, -1)
            if off < 0:
                off = self._weld_row[key] = int(self._eq_rows_before @ active)
        if off + 3 <= nefc and data.efc_id[off] == self._weld and data.efc_type[off] == self._eq_type:
            x, y, z = data.efc_force[off: off + 3].tolist()
            return math.sqrt(x * x + y * y + z * z)
        return norm(self.harness_force(data))

    def update(self, data: mujoco.MjData) -> None:
        """Account for the physics step just taken.

        Only copies what the figures need (the harness force, the contacts' geom classes and distances,
        the feet's positions, the actuator forces, the limited joints' angles, the torso's attitude); the
        figures are worked out for all pending steps at once, vectorised, when read (:meth:`end_frame`,
        :attr:`feet_down`): this runs after every physics step, and per-step NumPy calls cost about as much
        as the step itself."""
        self._p_outside.append(self._harness_norm(data) / self.weight + self.gravcomp_fraction)
        n = data.ncon
        if n:
            con = data.contact
            self._p_codes.append(self._code[con.geom[:n]])
            self._p_dist.append(con.dist[:n].copy())
        else:
            self._p_codes.append(None)
            self._p_dist.append(None)
        self._p_feet.append(data.xpos[self._foot_bodies, :2])
        if len(self._act_limit):
            self._p_force.append(data.actuator_force[self.scene.act_ids])
        if len(self._lim_qadr):
            self._p_q.append(data.qpos[self._lim_qadr])
        self._p_up.append(data.xmat[self._torso, 6:9].copy())
        self._sole_slip.record(data)
        self._n += 1

    def _flush(self) -> None:
        """Fold the pending steps' readings into the frame's figures, in step order."""
        k = len(self._p_outside)
        if not k:
            return
        for v in self._p_outside:
            self._out_sum += v
            self._out_peak = max(self._out_peak, v)
        # Contacts of all pending steps at once: a code per geom (1 robot, +2 / +4 left / right foot, 8 floor),
        # so that a robot–floor contact has both bits 1 and 8 of the pair's OR, and a foot's its own bit too.
        lengths = [0 if d is None else len(d) for d in self._p_dist]
        touching = np.zeros((2, k), dtype=bool)
        if sum(lengths):
            codes = np.concatenate([c for c in self._p_codes if c is not None])
            dist = np.concatenate([d for d in self._p_dist if d is not None])
            step = np.repeat(np.arange(k), lengths)
            pair = codes[:, 0] | codes[:, 1]
            robot_floor = (pair & 9) == 9
            if robot_floor.any():
                self._pen = max(self._pen, float(-dist[robot_floor].min()))
            down = robot_floor & (dist <= 0)
            for s, bit in enumerate((2, 4)):
                touching[s, step[down & ((pair & bit) != 0)]] = True
        pos = np.array(self._p_feet)  # (k, 2 feet, 2)
        for s in range(2):
            prev = self._foot_prev[s]
            if touching[s].any() or prev is not None:
                # A step slides a foot by its move since the previous step when it touches the floor at both.
                seq = np.concatenate([pos[:1, s] if prev is None else prev[None], pos[:, s]])
                d = seq[1:] - seq[:-1]
                moved = np.sqrt(np.sum(d * d, axis=1))
                both = touching[s] & np.concatenate([[prev is not None], touching[s, :-1]])
                for v in moved[both].tolist():
                    self._slide[s] += v
            self._foot_prev[s] = pos[-1, s].copy() if touching[s, -1] else None
            if touching[s].any():
                on = pos[touching[s], s]
                self._lo[2 * s: 2 * s + 2] = np.minimum(self._lo[2 * s: 2 * s + 2], on.min(axis=0))
                self._hi[2 * s: 2 * s + 2] = np.maximum(self._hi[2 * s: 2 * s + 2], on.max(axis=0))
        self._feet_down = (self._foot_prev[0] is not None, self._foot_prev[1] is not None)
        if self._p_force:
            top = (np.abs(np.array(self._p_force)) / self._act_limit).max(axis=1)
            self._ratio = max(self._ratio, float(top.max()))
            self._sat += int(np.count_nonzero(top >= SATURATED))
        if self._p_q:
            q = np.array(self._p_q)
            lo, hi = self._lim_range[:, 0], self._lim_range[:, 1]
            self._lim += int(np.count_nonzero(((q - lo <= AT_LIMIT) | (hi - q <= AT_LIMIT)).any(axis=1)))
        up_z = np.array(self._p_up) @ self._torso_up  # the z row of the torso's rotation, times its up axis
        self._tilt = max(self._tilt, float(np.degrees(np.arccos(np.clip(up_z, -1.0, 1.0))).max()))
        self._clear_pending()

    def end_frame(self) -> FrameSupport:
        """Close the data frame: its figures (also appended to :attr:`frames`)."""
        self._flush()
        n = max(self._n, 1)
        soles = self._sole_slip.end_frame()
        fs = FrameSupport(outside_mean=self._out_sum / n, outside_peak=self._out_peak, slide=max(self._slide),
                          penetration=self._pen, torque_ratio=self._ratio, saturated=self._sat / n, at_limit=self._lim / n,
                          tilt_deg=self._tilt, feet_lo=tuple(self._lo.tolist()),  # type: ignore[arg-type]
                          feet_hi=tuple(self._hi.tolist()),  # type: ignore[arg-type]
                          slip=max(soles.slip), steps=soles.steps, step_length=soles.step_length, skims=soles.skims,
                          skim_length=soles.skim_length)
        self.frames.append(fs)
        self._clear_frame()
        return fs
