"""The standing robot's support at a physics step in one compiled loop (``BalanceConfig.qp_kernel = "numba"``).

At every physics step both planted feet touch the floor, :class:`~.balance_control.BalanceController` reads the
feet's heading (:meth:`~.feet_on_floor.FeetOnFloor.heading`), their soles in the world
(:meth:`~.feet_on_floor.FeetOnFloor.soles_at`), the footprint of the feet on the floor
(:meth:`~.feet_on_floor.FeetOnFloor.footprint`) and the box of that footprint along the heading
(:class:`~.support_box.SupportBox`): some thirty NumPy calls. :class:`CompiledSupport` does the same arithmetic in
one no-Python loop (:func:`~socialaff_sim.inference.compiled.njit`, fast-math off), and the feet's contacts with the
floor (:meth:`~.feet_on_floor.FeetOnFloor.contacts`, bit for bit: a selection and sign flips). The rotations and
projections are sums of products written out here, not BLAS's (which fuses them), so the soles, the heading and the
box differ from NumPy's in their last digits: an alternative evaluation, judged with ``qp_kernel="numba"`` by its rule
(docs/design.md §5, session 34). NumPy stays the reference.
"""

from __future__ import annotations

import math
from typing import Any

import mujoco
import numpy as np

from ..inference.compiled import njit, once
from .feet_on_floor import FeetOnFloor
from .support_box import SupportBox

__all__ = ["CompiledSupport", "support_kernel"]


def _support(xpos, xmat, bodies, soles, has_sole, fwd, pts, which, sole_gap):  # pragma: no cover - compiled; tested through CompiledSupport
    F = bodies.shape[0]
    S = soles.shape[1]
    P = pts.shape[0]
    # the heading: Σ_feet (R_f a_f) on the floor, unit (the sum from 0, foot by foot, as Python's sum)
    f0, f1 = 0.0, 0.0
    for s in range(F):
        b = bodies[s]
        f0 += xmat[b, 0] * fwd[s, 0] + xmat[b, 1] * fwd[s, 1] + xmat[b, 2] * fwd[s, 2]
        f1 += xmat[b, 3] * fwd[s, 0] + xmat[b, 4] * fwd[s, 1] + xmat[b, 5] * fwd[s, 2]
    nrm = math.sqrt(f0 * f0 + f1 * f1)
    if nrm > 1e-9:
        f0, f1 = f0 / nrm, f1 / nrm
    else:
        f0, f1 = 1.0, 0.0
    # the soles in the world: p + R s
    world = np.zeros((F, S, 3))
    for s in range(F):
        if not has_sole[s]:
            continue
        b = bodies[s]
        for i in range(S):
            for k in range(3):
                world[s, i, k] = xpos[b, k] + (soles[s, i, 0] * xmat[b, 3 * k] + soles[s, i, 1] * xmat[b, 3 * k + 1]
                                               + soles[s, i, 2] * xmat[b, 3 * k + 2])
    # the footprint: a foot's sole when it touches (or its sole is within the gap), its live points without a sole
    floor = np.inf
    for p in range(P):
        floor = min(floor, pts[p, 2])
    lo = np.array([np.inf, np.inf])
    hi = np.array([-np.inf, -np.inf])
    for s in range(F):
        touches = False
        for p in range(P):
            if which[p] == s:
                touches = True
                break
        if not touches:
            if not has_sole[s] or sole_gap <= 0.0:
                continue
            low = np.inf
            for i in range(S):
                low = min(low, world[s, i, 2])
            if low > floor + sole_gap + 0.002:
                continue
        if has_sole[s]:
            for i in range(S):
                x, y = world[s, i, 0], world[s, i, 1]
                a, c = x * f0 + y * f1, x * -f1 + y * f0
                lo[0], hi[0] = min(lo[0], a), max(hi[0], a)
                lo[1], hi[1] = min(lo[1], c), max(hi[1], c)
        else:
            for p in range(P):
                if which[p] == s:
                    x, y = pts[p, 0], pts[p, 1]
                    a, c = x * f0 + y * f1, x * -f1 + y * f0
                    lo[0], hi[0] = min(lo[0], a), max(hi[0], a)
                    lo[1], hi[1] = min(lo[1], c), max(hi[1], c)
    R = np.array([[f0, f1], [-f1, f0]])
    return world, R, lo, hi


def _contacts(geom, frame, pos, foot_geom, floor):  # pragma: no cover - compiled; tested through CompiledSupport
    """:meth:`~.feet_on_floor.FeetOnFloor.contacts` of the ``ncon`` contacts' ``geom`` (ncon, 2), ``frame`` (ncon, 9)
    and ``pos`` (ncon, 3): the feet's contacts with the floor, their frames (normal from the floor into the foot)
    and feet."""
    nc = geom.shape[0]
    keep = np.empty(nc, dtype=np.int64)
    k = 0
    for i in range(nc):
        f0, f1 = geom[i, 0] == floor, geom[i, 1] == floor
        side = foot_geom[geom[i, 1] if f0 else geom[i, 0]]
        if (f0 or f1) and side >= 0:
            keep[k] = i
            k += 1
    pts = np.empty((k, 3))
    frames = np.empty((k, 3, 3))
    which = np.empty(k, dtype=np.int64)
    for j in range(k):
        i = keep[j]
        f0 = geom[i, 0] == floor
        which[j] = foot_geom[geom[i, 1] if f0 else geom[i, 0]]
        sign = 1.0 if f0 else -1.0  # MuJoCo's normal points from geom 0 to geom 1
        for a in range(3):
            pts[j, a] = pos[i, a]
            for b in range(3):
                frames[j, a, b] = frame[i, 3 * a + b] * sign
    return pts, frames, which


def support_kernel() -> Any:
    """The compiled :func:`_support` and :func:`_contacts` (made and warmed up once per process; numba missing: a
    ConfigError)."""
    return once(__name__, lambda: {"support": njit(_support), "contacts": njit(_contacts)}, _warm)


def _warm(fns: Any) -> None:
    """One call of each of the argument types :class:`CompiledSupport` passes."""
    xmat = np.tile(np.eye(3).ravel(), (3, 1))
    fns["support"](np.zeros((3, 3)), xmat, np.array([1, 2], dtype=np.int64), np.zeros((2, 8, 3)),
                   np.ones(2, dtype=np.bool_), np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]), np.zeros((2, 3)),
                   np.zeros(2, dtype=np.int64), 0.01)
    rows = np.zeros((2, 16))  # MjData.contact's fields: strided views of its records (two: not flagged contiguous)
    for k in (1, 2):  # (one contact's views are flagged contiguous)
        fns["contacts"](np.zeros((2, 8), dtype=np.int32)[:k, :2], rows[:k, :9], rows[:k, 9:12],
                        np.zeros(2, dtype=np.int64), 0)


class CompiledSupport:
    """:class:`~.feet_on_floor.FeetOnFloor`'s soles in the world, footprint and heading and the support box, compiled
    (the module docstring), for the feet ``feet``."""

    def __init__(self, feet: FeetOnFloor) -> None:
        fns = support_kernel()
        self._kernel, self._contacts = fns["support"], fns["contacts"]
        self._foot_geom, self._floor = np.asarray(feet._foot_geom, dtype=np.int64), int(feet._floor)
        F = len(feet.bodies)
        S = max((len(s) for s in feet.soles if s is not None), default=1)
        if any(s is not None and len(s) != S for s in feet.soles):
            raise ValueError("CompiledSupport: soles of different point counts")
        self._bodies = np.asarray(feet.bodies, dtype=np.int64)
        self._soles = np.zeros((F, S, 3))
        self._has = np.zeros(F, dtype=np.bool_)
        for s, sole in enumerate(feet.soles):
            if sole is not None:
                self._soles[s], self._has[s] = sole, True
        self._fwd = np.ascontiguousarray(feet.forward, dtype=np.float64)
        self._gap = float(feet.sole_gap)

    def support(self, d: mujoco.MjData, pts: np.ndarray, which: np.ndarray) -> tuple[list[np.ndarray | None],
                                                                                      SupportBox]:
        """The soles in the world at ``d`` (per foot (S, 3), ``None``: unknown) and the support box of the feet's
        contacts ``pts`` (P, 3) with the floor, foot ``which`` (P,) of each (P ≥ 1)."""
        world, R, lo, hi = self._kernel(d.xpos, d.xmat, self._bodies, self._soles, self._has, self._fwd, pts,
                                        which, self._gap)
        return [world[s] if self._has[s] else None for s in range(len(self._has))], SupportBox.of(R, lo, hi)

    def contacts(self, d: mujoco.MjData) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`~.feet_on_floor.FeetOnFloor.contacts` of ``d``: points (P, 3), frames (P, 3, 3), feet (P,)."""
        nc = d.ncon
        if not nc:
            return np.zeros((0, 3)), np.zeros((0, 3, 3)), np.zeros(0, dtype=np.int64)
        con = d.contact  # (each read of MjData.contact makes new views: read once)
        return self._contacts(con.geom[:nc], con.frame[:nc], con.pos[:nc], self._foot_geom, self._floor)
