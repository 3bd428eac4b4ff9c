"""How far the soles' contacts slip along the floor, and the feet's steps: the support meter's second foot figure.

The support meter's *slide* (:mod:`~socialaff_sim.sim.support`) is the horizontal path of each ankle body's
origin while its foot touches the floor. A sole that rocks onto an edge or a corner without moving on the floor
swings that origin (Stubby's ankle sits 8 cm above its sole) and adds to the slide; so does a foot that rolls off
its toe for a step while the toe still touches. :class:`SoleSlip` measures the slip of the contact itself:

* **slip**: per foot and physics step, every contact between one of the foot's geoms and the floor at the step
  before (distance ≤ 0, the meter's *touching*) whose geom still touches the floor at this step is carried
  with its geom's body, as a point fixed in that body, from the body's pose at the step before to its pose
  now: ``p' = x₁ + R₁ R₀ᵀ (p − x₀)``; the horizontal length of ``p' − p`` is how far that contact slipped along
  the floor in the step (the sole's velocity at the contact point in the floor plane, integrated over the step).
  The foot's slip in the step is the mean of that over its persisting contacts (a sole twisted about its middle
  slips by the mean arc of its corners), nothing when none persists. A sole rolling on an edge that stays put
  slips ≈ 0 (its contact points lie on the axis it turns about), one dragged along slips its drag;
* **a foot off the floor** (no contact at distance ≤ 0) carries its last contacts with their bodies until it
  touches again, and is then counted as one of two things, neither of them slip (a contact that does not persist
  is not slip). If the lowest of its carried contacts rose more than ``clearance`` (:data:`CLEARANCE`, 5 mm) above
  where it touched, the foot **stepped**: a step, its length the horizontal distance of the foot's (ankle) body
  origin from its last touch to the new one. Otherwise it **skimmed** the floor: a skim, its length the carried
  contacts' mean horizontal move from the last touch to the new one (measured as slip is). Skims are MuJoCo's
  contacts coming and going for a physics step or a few under a lightly loaded or rocking sole, and a foot moved
  along the floor within the clearance without touching it throughout (the foot lock's glides); whoever defines
  "slide" may add them to the slip or not. A foot's first touch after :meth:`reset` is neither.

Readings are copied per physics step (:meth:`record`) and worked out per data frame (:meth:`end_frame`), in
step order; the state between frames (the last step's contacts and poses, the feet off the floor) carries over.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from ..errors import SimulationError

__all__ = ["SoleSlip", "FrameSlip", "CLEARANCE"]

CLEARANCE = 0.005
"""How high (m) the lowest of a lifted foot's last contacts must rise above where it touched for the foot to have
stepped (below it the foot skimmed the floor)."""


@dataclass
class _Gap:
    """A foot off the floor: its contacts at its last touch (geoms, points; the bodies' poses then), its step
    body's horizontal position then, and how high the lowest contact has risen since (m)."""

    geoms: np.ndarray
    points: np.ndarray
    x: np.ndarray
    rot: np.ndarray
    xy: np.ndarray
    rise: float = 0.0


@dataclass(frozen=True)
class FrameSlip:
    """One data frame's slip and steps (see the module docstring)."""

    slip: tuple[float, float]
    """Each foot's (left, right) summed slip over the frame's physics steps, m."""
    steps: int
    """Steps that landed in the frame, both feet."""
    step_length: float
    """Their summed horizontal length, m."""
    skims: int = 0
    """Skims that ended in the frame (the foot touching again), both feet."""
    skim_length: float = 0.0
    """Their summed length (the carried contacts' mean horizontal move), m."""


class SoleSlip:
    """Per-foot contact slip and steps of feet on a floor (the module docstring).

    ``feet``: per foot, a boolean mask over the model's geoms (the foot's geoms); ``step_bodies``: per foot, the
    body whose origin measures a step's length (the support meter's ankle body); ``floor``: the floor's geom;
    ``clearance``: :data:`CLEARANCE`."""

    def __init__(self, model: mujoco.MjModel, floor: int, feet: Sequence[np.ndarray], step_bodies: Sequence[int],
                 clearance: float = CLEARANCE) -> None:
        if len(feet) != len(step_bodies):
            raise SimulationError(f"SoleSlip: {len(feet)} feet but {len(step_bodies)} step bodies (one per foot)")
        self._floor = int(floor)
        self._nfeet = len(feet)
        self.clearance = float(clearance)
        masks = np.array([np.asarray(f, dtype=bool) for f in feet]).reshape(len(feet), model.ngeom)
        self._foot_geoms = np.flatnonzero(masks.any(axis=0))
        # Per geom: its foot (-1: none), its column among the feet's geoms, its body's row among the bodies kept.
        self._foot_of = np.full(model.ngeom + 1, -1, dtype=np.int64)  # + 1: index -1 (no other geom) lands here
        for s in range(len(feet)):
            self._foot_of[:-1][masks[s]] = s
        self._col = np.full(model.ngeom, -1, dtype=np.int64)
        self._col[self._foot_geoms] = np.arange(len(self._foot_geoms))
        self._col_foot = self._foot_of[self._foot_geoms]
        self._bodies = np.unique(model.geom_bodyid[self._foot_geoms]).astype(np.int64)
        row = {int(b): i for i, b in enumerate(self._bodies)}
        self._row = np.full(model.ngeom, -1, dtype=np.int64)
        self._row[self._foot_geoms] = [row[int(b)] for b in model.geom_bodyid[self._foot_geoms]]
        self._step_bodies = np.asarray(step_bodies, dtype=np.int64)
        self.reset()

    def reset(self) -> None:
        """Forget everything (a new episode): no contact carried, no foot lifted."""
        nb = len(self._bodies)
        # The last step's touching contacts (geoms, points), bodies' poses, geoms touching, feet down, step bodies.
        self._geoms = np.zeros(0, dtype=np.int64)
        self._points = np.zeros((0, 3))
        self._x = np.zeros((nb, 3))
        self._rot = np.zeros((nb, 3, 3))
        self._touch = np.zeros(len(self._foot_geoms), dtype=bool)
        self._down = np.zeros(self._nfeet, dtype=bool)
        self._xy = np.full((self._nfeet, 2), np.nan)
        self._gaps: list[_Gap | None] = [None] * self._nfeet  # feet off the floor since a touch
        self._p_pair: list[np.ndarray] = []
        self._p_dist: list[np.ndarray] = []
        self._p_pos: list[np.ndarray] = []
        self._p_x: list[np.ndarray] = []
        self._p_rot: list[np.ndarray] = []
        self._p_xy: list[np.ndarray] = []

    def record(self, data: mujoco.MjData) -> None:
        """Copy what the physics step just taken shows: its contacts (geoms, distances, points), the poses of the
        bodies that carry the feet's geoms, the step bodies' horizontal positions (worked out in :meth:`end_frame`)."""
        n = data.ncon
        con = data.contact
        self._p_pair.append(con.geom[:n].copy())
        self._p_dist.append(con.dist[:n].copy())
        self._p_pos.append(con.pos[:n].copy())
        self._p_x.append(data.xpos[self._bodies])
        self._p_rot.append(data.xmat[self._bodies])
        self._p_xy.append(data.xpos[self._step_bodies, :2])

    def _carried(self, gap: _Gap, x: np.ndarray, rot: np.ndarray) -> np.ndarray:
        """(rows, contacts, 3) world points of ``gap``'s contacts carried with their bodies to the poses ``x``
        (rows, bodies, 3), ``rot`` (rows, bodies, 3, 3)."""
        b = self._row[gap.geoms]
        local = np.einsum("nji,nj->ni", gap.rot[b], gap.points - gap.x[b])  # R₀ᵀ (p − x₀)
        return x[:, b] + np.einsum("rnij,nj->rni", rot[:, b], local)

    def _rise(self, gap: _Gap, x: np.ndarray, rot: np.ndarray) -> None:
        """Raise ``gap.rise`` to the lowest carried contact's rise at the poses ``x``, ``rot`` (rows off the floor)."""
        if len(x) and len(gap.geoms):
            z = self._carried(gap, x, rot)[:, :, 2] - gap.points[:, 2]
            gap.rise = max(gap.rise, float(z.min(axis=1).max()))

    def end_frame(self) -> FrameSlip:
        """The pending steps' slip and steps, in step order (the carried state updated); all steps at once."""
        k = len(self._p_x)
        nf, ng = self._nfeet, len(self._foot_geoms)
        if not k:
            return FrameSlip(slip=(0.0,) * nf, steps=0, step_length=0.0)  # type: ignore[arg-type]
        # Row 0: the last step of the frame before (carried); rows 1..k: this frame's steps.
        lengths = np.array([len(d) for d in self._p_dist])
        pair = np.concatenate(self._p_pair).reshape(-1, 2).astype(np.int64)
        dist = np.concatenate(self._p_dist)
        pos = np.concatenate(self._p_pos).reshape(-1, 3)
        row = np.repeat(np.arange(1, k + 1), lengths)
        other = np.where(pair[:, 0] == self._floor, pair[:, 1], np.where(pair[:, 1] == self._floor, pair[:, 0], -1))
        keep = (self._foot_of[other] >= 0) & (dist <= 0.0)
        geoms = np.concatenate([self._geoms, other[keep]])
        points = np.concatenate([self._points, pos[keep]])
        rows = np.concatenate([np.zeros(len(self._geoms), dtype=np.int64), row[keep]])
        touch = np.zeros((k + 1, ng), dtype=bool)
        touch[0] = self._touch
        touch[rows, self._col[geoms]] = True
        x = np.concatenate([self._x[None], np.array(self._p_x)])
        rot = np.concatenate([self._rot[None], np.array(self._p_rot).reshape(k, -1, 3, 3)])
        xy = np.concatenate([self._xy[None], np.array(self._p_xy)])
        # Slip: each contact of row r carried to row r + 1 with its body, if its geom touches the floor there too.
        on = rows < k
        on[on] = touch[rows[on] + 1, self._col[geoms[on]]]
        slip = np.zeros(nf)
        if on.any():
            r, g, b = rows[on], geoms[on], self._row[geoms[on]]
            local = np.einsum("nji,nj->ni", rot[r, b], points[on] - x[r, b])  # R₀ᵀ (p − x₀)
            moved = x[r + 1, b] + np.einsum("nij,nj->ni", rot[r + 1, b], local) - points[on]
            d = np.hypot(moved[:, 0], moved[:, 1])
            key = r * nf + self._foot_of[g]
            count = np.bincount(key, minlength=(k + 1) * nf)
            total = np.bincount(key, d, minlength=(k + 1) * nf)
            slip = (total / np.maximum(count, 1)).reshape(k + 1, nf).sum(axis=0)
        # Feet off the floor: stepped or skimmed, decided when they touch again.
        down = np.zeros((k + 1, nf), dtype=bool)
        down[0] = self._down
        for s in range(nf):
            down[1:, s] = touch[1:, self._col_foot == s].any(axis=1)
        steps, length, skims, skimmed = 0, 0.0, 0, 0.0
        for s in range(nf):
            since = 1  # the first row of the current time off the floor not yet looked at
            for r in (np.flatnonzero(down[1:, s] != down[:-1, s]) + 1).tolist():
                gap = self._gaps[s]
                if not down[r, s]:  # left the floor at row r: its contacts at row r - 1 carried from there
                    mine = (rows == r - 1) & (self._foot_of[geoms] == s)
                    self._gaps[s] = _Gap(geoms[mine], points[mine], x[r - 1], rot[r - 1], xy[r - 1, s])
                    since = r
                    continue
                if gap is not None:  # back on the floor at row r (None: a first touch)
                    self._rise(gap, x[since:r], rot[since:r])
                    if gap.rise > self.clearance:
                        steps += 1
                        length += float(np.hypot(*(xy[r, s] - gap.xy)))
                    else:
                        moved = self._carried(gap, x[r:r + 1], rot[r:r + 1])[0] - gap.points
                        skims += 1
                        skimmed += float(np.hypot(moved[:, 0], moved[:, 1]).mean())
                self._gaps[s] = None
            gap = self._gaps[s]
            if gap is not None:  # still off the floor at the frame's end
                self._rise(gap, x[since:], rot[since:])
        last = rows == k
        self._geoms, self._points = geoms[last], points[last]
        self._x, self._rot, self._touch, self._down, self._xy = x[-1], rot[-1], touch[-1], down[-1], xy[-1]
        self._p_pair, self._p_dist, self._p_pos, self._p_x, self._p_rot, self._p_xy = [], [], [], [], [], []
        return FrameSlip(slip=tuple(slip.tolist()), steps=steps, step_length=length,  # type: ignore[arg-type]
                         skims=skims, skim_length=skimmed)
