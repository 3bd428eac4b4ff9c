"""Collision avoidance between geom pairs as one mink limit, built for a per-frame IK budget.

:class:`GeomPairLimit` plays the part of :class:`mink.CollisionAvoidanceLimit`
with three differences that matter here:

* its bound is a displacement, in the same units as mink's other limits on Δq:
  ``−∂d/∂q · Δq ≤ gain · (d − d_min)`` (mink 1.3 divides that bound by dt, which
  is right only for dt = 1 s);
* each pair has its own ``d_min`` and detection distance: the robot keeps clear of
  most of the person but may press ``contact_depth`` into the parts a sub-goal
  wants touched;
* a pair found closer than ``d_min`` because the *person* moved into the robot
  (which the robot cannot prevent) may get a negative bound, down to ``−max_push``:
  the solution then moves the robot back out instead of merely not going deeper.

The distances come from MuJoCo's own collision detection rather than from one
``mj_geomDistance`` call per pair: every geom in a pair gets a contact margin
equal to its largest detection distance, so ``mujoco.mj_collision`` reports
every pair closer than that (broad- and narrow-phase in C), and
``mujoco.mj_makeConstraint`` turns the contacts into Jacobian rows (their
normal directions, ``∂d/∂q``). This needs the model to itself: the limit sets
the margins, makes every contact frictionless (one row each) and turns off the
other constraint types (joint limits, equalities, friction loss), which the IK
handles as limits of its own. The person's capsule sizes may change afterwards
(MuJoCo reads them at each call).

A pair only enters the QP within its detection distance, and one QP step of a
fast limb can move a hand by more than that: :meth:`GeomPairLimit.crossed` finds
the pairs a step carried from outside their limit to inside it, and the caller
solves the step again with them :meth:`~GeomPairLimit.watch`-ed (a row from
their nearest points, ``mj_geomDistance``, and the Jacobians of those points).
"""

from __future__ import annotations

from dataclasses import dataclass

import mink
import mujoco
import numpy as np

__all__ = ["GeomPairLimit", "PairMemory", "collision_pairs"]


def collision_pairs(model: mujoco.MjModel, group_a: np.ndarray, group_b: np.ndarray, *,
                    bits: bool = True) -> np.ndarray:
    """(P, 2) int: pairs (a, b), a from ``group_a`` and b from ``group_b``, of geoms that can collide.

    Left out, as MuJoCo's collision detection does: pairs on the same body (or on
    bodies welded together), pairs whose bodies are parent and child, pairs whose
    contype/conaffinity bits never meet (unless ``bits`` is false: the model's
    structure alone), and body pairs the model excludes. Each unordered pair
    appears once.
    """
    a = np.unique(np.asarray(group_a, dtype=np.int64).ravel())
    b = np.unique(np.asarray(group_b, dtype=np.int64).ravel())
    if a.size == 0 or b.size == 0:
        return np.zeros((0, 2), dtype=np.int64)
    ga, gb = (x.ravel() for x in np.meshgrid(a, b, indexing="ij"))
    weld = model.body_weldid
    wa, wb = weld[model.geom_bodyid[ga]], weld[model.geom_bodyid[gb]]
    pa, pb = weld[model.body_parentid[wa]], weld[model.body_parentid[wb]]
    meet = ((model.geom_contype[ga] & model.geom_conaffinity[gb]) != 0) | (
        (model.geom_contype[gb] & model.geom_conaffinity[ga]) != 0)
    keep = (wa != wb) & (wa != pb) & (wb != pa) & (meet | (not bits))
    if model.nexclude:
        signature = model.exclude_signature
        ba, bb = model.geom_bodyid[ga], model.geom_bodyid[gb]
        sig = (np.minimum(ba, bb).astype(np.int64) << 16) + np.maximum(ba, bb)
        keep &= ~np.isin(sig, signature)
    pairs = np.stack([ga[keep], gb[keep]], axis=1)
    _, first = np.unique(np.sort(pairs, axis=1), axis=0, return_index=True)
    return pairs[np.sort(first)]


@dataclass(frozen=True)
class PairMemory:
    """What a :class:`GeomPairLimit` remembers from one call to the next (:meth:`GeomPairLimit.memory`)."""

    before: np.ndarray
    """(G, G) each pair's smallest distance since it last produced a row, metres (inf: not seen)."""
    last_active: np.ndarray
    """(k, 2) the geom pairs that produced a row at the last call."""
    last_distance: np.ndarray
    """(k,) their distances, metres."""


class GeomPairLimit(mink.Limit):
    """Keep each geom pair at least its ``d_min`` apart, as linear inequalities on Δq.

    ``pairs`` (P, 2) geom ids; ``min_distance`` (P,) metres (negative: may press
    that deep); ``detection`` (P,) metres: a pair farther apart is left out of the
    QP; ``push`` (P,) bool: whether the pair may get a negative bound. ``gain`` is
    the fraction of the remaining gap a pair may close per step, ``max_push`` (m)
    the most a pair is pushed apart per step. ``margins`` (ngeom,), optional: each
    geom's contact margin; MuJoCo reports a pair closer than the *sum* of its two
    margins, which must reach the pair's detection distance (by default each geom
    gets half the largest detection distance of its pairs). Changes ``model`` (see
    the module notes).
    """

    def __init__(self, model: mujoco.MjModel, pairs: np.ndarray, min_distance: np.ndarray, detection: np.ndarray,
                 push: np.ndarray, *, gain: float = 0.85, max_push: float = 0.02, margins: np.ndarray | None = None) -> None:
        self.model = model
        pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
        n = len(pairs)
        self.pairs = pairs
        self.min_distance = np.broadcast_to(np.asarray(min_distance, dtype=np.float64), (n,)).copy()
        self.detection = np.broadcast_to(np.asarray(detection, dtype=np.float64), (n,)).copy()
        self.push = np.broadcast_to(np.asarray(push, dtype=bool), (n,)).copy()
        self.gain = float(gain)
        self.max_push = float(max_push)
        self.allow_push = True
        """Switched off by the caller for a retry when a push made the QP infeasible."""
        G = model.ngeom
        g1, g2 = pairs[:, 0], pairs[:, 1]
        self._dmin = np.zeros((G, G))
        self._detect = np.full((G, G), -np.inf)  # not a pair: never close enough
        self._push = np.zeros((G, G), dtype=bool)
        for a, b in ((g1, g2), (g2, g1)):
            self._dmin[a, b] = self.min_distance
            self._detect[a, b] = self.detection
            self._push[a, b] = self.push
        if margins is None:
            margin = np.zeros(G)
            np.maximum.at(margin, g1, 0.5 * self.detection)
            np.maximum.at(margin, g2, 0.5 * self.detection)
        else:
            margin = np.asarray(margins, dtype=np.float64)
            short = margin[g1] + margin[g2] < self.detection - 1e-12
            if short.any():
                raise ValueError(f"GeomPairLimit: margins sum below the detection distance for {int(short.sum())} pairs")
        model.geom_margin[:] = margin
        model.geom_gap[:] = 0.0
        model.geom_condim[:] = 1
        model.opt.jacobian = int(mujoco.mjtJacobian.mjJAC_DENSE)
        model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_EQUALITY | mujoco.mjtDisableBit.mjDSBL_LIMIT
                                      | mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS)
        model.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
        self.last_active = np.zeros((0, 2), dtype=np.int64)
        """Geom pairs that produced a row at the last call (for tests and diagnostics)."""
        self.last_distance = np.zeros(0)
        """Their distances (m) at that call."""
        self._before = np.full((G, G), np.inf)  # each pair's distance at the last call (inf: not seen)
        self.watched = np.zeros((0, 2), dtype=np.int64)
        """Pairs that get a row whatever their distance (:meth:`watch`)."""
        self._jac = np.zeros((2, 3, model.nv))
        self._fromto = np.zeros(6)

    def memory(self) -> PairMemory:
        """A copy of what the limit remembers between calls (valid between solves: no pair watched)."""
        return PairMemory(self._before.copy(), self.last_active.copy(), self.last_distance.copy())

    def restore(self, memory: PairMemory | None) -> None:
        """Put back a :meth:`memory` (``None``: that of a newly built limit, nothing seen), in place."""
        if memory is None:
            self._before.fill(np.inf)
            self.last_active, self.last_distance = np.zeros((0, 2), dtype=np.int64), np.zeros(0)
        else:
            self._before[...] = memory.before
            self.last_active, self.last_distance = memory.last_active.copy(), memory.last_distance.copy()
        self.unwatch()
        self.allow_push = True

    def watch(self, pairs: np.ndarray) -> bool:
        """Give ``pairs`` (k, 2) a row at the next calls, however far apart; whether any is new."""
        pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
        known = {tuple(sorted(p)) for p in self.watched.tolist()}
        new = []
        for p in pairs.tolist():
            if tuple(sorted(p)) not in known:
                known.add(tuple(sorted(p)))
                new.append(p)
        if new:
            self.watched = np.concatenate([self.watched, np.array(new, dtype=np.int64)])
        return bool(new)

    def unwatch(self) -> None:
        """Back to the rows of the pairs within their detection distance only."""
        self.watched = np.zeros((0, 2), dtype=np.int64)

    def crossed(self, configuration: mink.Configuration, slack: float) -> np.ndarray:
        """(k, 2) pairs that are, at ``configuration`` (a step away from the last
        :meth:`compute_qp_inequalities`), more than ``slack`` (m) inside their ``d_min`` and were
        not then.

        The QP only sees pairs within their detection distance: a long step can carry a hand
        from beyond it straight into the thigh, after which a pair that may not be pushed apart
        is held inside. The caller re-solves the step with these pairs :meth:`watch`-ed.
        """
        model, data = self.model, configuration.data
        mujoco.mj_collision(model, data)
        n = data.ncon
        if not n:
            return np.zeros((0, 2), dtype=np.int64)
        geom = data.contact.geom[:n]
        a, b = geom[:, 0], geom[:, 1]
        d = data.contact.dist[:n]
        dmin = self._dmin[a, b]
        bad = (d < self._detect[a, b]) & (d < dmin - slack) & (self._before[a, b] >= dmin - slack)
        return np.stack([a[bad], b[bad]], axis=1)

    def _forget(self) -> None:
        a, b = self.last_active[:, 0], self.last_active[:, 1]
        self._before[a, b] = np.inf
        self._before[b, a] = np.inf
        self.last_active, self.last_distance = np.zeros((0, 2), dtype=np.int64), np.zeros(0)

    def _watched_rows(self, data: mujoco.MjData, seen: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pairs, distances and separation-rate rows (k, nv) of the watched pairs without a contact row,
        from their nearest points (``mj_geomDistance``) and the Jacobians of those points."""
        m = self.model
        pairs, dist, rows = [], [], []
        for g1, g2 in self.watched.tolist():
            if seen[g1, g2]:
                continue
            d = mujoco.mj_geomDistance(m, data, g1, g2, 1.0, self._fromto)
            if not 0.0 < d < 1.0:
                continue  # touching (then MuJoCo's contact makes the row) or far beyond any step
            p1, p2 = self._fromto[:3], self._fromto[3:]
            normal = (p2 - p1) / d
            mujoco.mj_jac(m, data, self._jac[0], None, p1, int(m.geom_bodyid[g1]))
            mujoco.mj_jac(m, data, self._jac[1], None, p2, int(m.geom_bodyid[g2]))
            pairs.append((g1, g2))
            dist.append(d)
            rows.append(normal @ (self._jac[1] - self._jac[0]))
        if not pairs:
            return np.zeros((0, 2), dtype=np.int64), np.zeros(0), np.zeros((0, m.nv))
        return np.array(pairs, dtype=np.int64), np.array(dist), np.array(rows)

    def compute_qp_inequalities(self, configuration: mink.Configuration, dt: float) -> mink.Constraint:
        model, data = self.model, configuration.data
        mujoco.mj_collision(model, data)
        n = data.ncon
        self._forget()
        con = data.contact
        geom = con.geom[:n]
        g1, g2 = geom[:, 0], geom[:, 1]
        dist = con.dist[:n]
        a, b, d = np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0)
        jac = np.zeros((0, model.nv))
        if n and (dist < self._detect[g1, g2]).any():
            mujoco.mj_makeConstraint(model, data)
            nefc = data.nefc
            # One frictionless row per contact: efc_J · q̇ is the rate at which the pair separates.
            cid = data.efc_id[:nefc]
            rows = np.flatnonzero(dist[cid] < self._detect[g1[cid], g2[cid]])
            cid = cid[rows]
            a, b = g1[cid], g2[cid]
            d = dist[cid]
            jac = data.efc_J[: nefc * model.nv].reshape(nefc, model.nv)[rows]
        if len(self.watched):
            seen = np.zeros((model.ngeom, model.ngeom), dtype=bool)
            seen[a, b] = seen[b, a] = True
            pairs, dw, jw = self._watched_rows(data, seen)
            a, b = np.concatenate([a, pairs[:, 0]]), np.concatenate([b, pairs[:, 1]])
            d, jac = np.concatenate([d, dw]), np.concatenate([jac, jw])
        if not len(d):
            return mink.Constraint()
        self.last_active, self.last_distance = np.stack([a, b], axis=1), d
        np.minimum.at(self._before, (a, b), d)
        np.minimum.at(self._before, (b, a), d)
        bound = self.gain * (d - self._dmin[a, b])
        floor = np.where(self._push[a, b] & self.allow_push, -self.max_push, 0.0)
        return mink.Constraint(G=-jac, h=np.maximum(bound, floor))
