"""The self-clearance barrier rows compiled (``BalanceConfig.qp_kernel = "numba"``, with ``self_clearance``).

:meth:`~.self_clearance.SelfClearance.rows` screens every watched pair by its bounding spheres, asks MuJoCo for the
near pairs' distances and Jacobians, and writes one row per pair closer than the detection distance, with some
fifteen NumPy calls per such pair. :class:`CompiledClearance` keeps MuJoCo's calls
(:func:`mujoco.mj_geomDistance`, :func:`mujoco.mj_jac`, :func:`mujoco.mj_jacDot`) and does the screening and the rows
in two no-Python loops (:func:`~socialaff_sim.inference.compiled.njit`, fast-math off); the sums of products are
written out (BLAS fuses them), so the rows differ from NumPy's in their last digits: an alternative evaluation, judged
with ``qp_kernel="numba"`` by its rule (docs/design.md §5, session 34). NumPy stays the reference.
"""

from __future__ import annotations

import math
from typing import Any

import mujoco
import numpy as np

from ..inference.compiled import njit, once
from .self_clearance import SelfClearance

__all__ = ["CompiledClearance", "clearance_kernels"]


def _near(xpos, first, second, reach):  # pragma: no cover - compiled; tested through CompiledClearance
    """The pairs whose geoms' centres are closer than their bounding spheres' reach, in order."""
    out = np.empty(first.shape[0], dtype=np.int64)
    k = 0
    for i in range(first.shape[0]):
        a, b = first[i], second[i]
        d0, d1, d2 = xpos[a, 0] - xpos[b, 0], xpos[a, 1] - xpos[b, 1], xpos[a, 2] - xpos[b, 2]
        if math.sqrt(d0 * d0 + d1 * d1 + d2 * d2) < reach[i]:
            out[k] = i
            k += 1
    return out[:k]


def _rows(fromto, dist, jac, jdot, qvel, vadr, w, clearance):  # pragma: no cover - compiled; tested through CompiledClearance
    """Rows A (k, n) and bounds lo (k,) of the k pairs with their segment ``fromto`` (k, 6), distance ``dist`` (k,)
    and the Jacobians and their derivatives at both ends (k, 2, 3, nv); ``keep`` (k,): a row was made (the segment
    has a direction)."""
    K = dist.shape[0]
    n = vadr.shape[0]
    nv = qvel.shape[0]
    A = np.empty((K, n))
    lo = np.empty(K)
    keep = np.zeros(K, dtype=np.bool_)
    row = np.empty(nv)
    for i in range(K):
        g0, g1, g2 = fromto[i, 3] - fromto[i, 0], fromto[i, 4] - fromto[i, 1], fromto[i, 5] - fromto[i, 2]
        length = math.sqrt(g0 * g0 + g1 * g1 + g2 * g2)
        if length < 1e-9:
            continue  # touching at a point: no direction to push along
        sgn = 1.0 if dist[i] >= 0 else -1.0
        n0, n1, n2 = g0 / length * sgn, g1 / length * sgn, g2 / length * sgn
        rate = 0.0
        drift = 0.0
        for c in range(nv):
            row[c] = (n0 * (jac[i, 1, 0, c] - jac[i, 0, 0, c]) + n1 * (jac[i, 1, 1, c] - jac[i, 0, 1, c])
                      + n2 * (jac[i, 1, 2, c] - jac[i, 0, 2, c]))
            rate += row[c] * qvel[c]
            drift += (n0 * (jdot[i, 1, 0, c] - jdot[i, 0, 0, c]) + n1 * (jdot[i, 1, 1, c] - jdot[i, 0, 1, c])
                      + n2 * (jdot[i, 1, 2, c] - jdot[i, 0, 2, c])) * qvel[c]
        for c in range(n):
            A[i, c] = row[vadr[c]]
        lo[i] = -2.0 * w * rate - w * w * (dist[i] - clearance) - drift
        keep[i] = True
    return A, lo, keep


def clearance_kernels() -> Any:
    """The compiled :func:`_near` and :func:`_rows` (made and warmed up once per process; numba missing: a
    ConfigError)."""
    return once(__name__, lambda: {"near": njit(_near), "rows": njit(_rows)}, _warm)


def _warm(fns: Any) -> None:
    """One call of each of the argument types :class:`CompiledClearance` passes."""
    i = np.zeros(1, dtype=np.int64)
    fns["near"](np.zeros((2, 3)), i, i + 1, np.ones(1))
    fns["rows"](np.ones((1, 6)), np.ones(1), np.zeros((1, 2, 3, 4)), np.zeros((1, 2, 3, 4)), np.zeros(4),
                np.arange(2, dtype=np.int64), 30.0, 0.01)


class CompiledClearance:
    """:meth:`~.self_clearance.SelfClearance.rows` of ``clearance``, compiled (the module docstring); its
    ``last_distance`` is kept on ``clearance``."""

    def __init__(self, m: mujoco.MjModel, clearance: SelfClearance) -> None:
        self._fns = clearance_kernels()
        self.of = clearance
        c = clearance
        self._first = np.ascontiguousarray(c.pairs[:, 0], dtype=np.int64)
        self._second = np.ascontiguousarray(c.pairs[:, 1], dtype=np.int64)
        self._reach = np.ascontiguousarray(c._reach, dtype=np.float64)
        self._vadr = np.asarray(c.vadr, dtype=np.int64)
        P = len(c.pairs)
        self._fromto = np.zeros((P, 6))
        self._dist = np.zeros(P)
        self._jac, self._jdot = np.zeros((P, 2, 3, m.nv)), np.zeros((P, 2, 3, m.nv))

    def rows(self, m: mujoco.MjModel, d: mujoco.MjData) -> tuple[np.ndarray, np.ndarray] | None:
        """As :meth:`~.self_clearance.SelfClearance.rows`."""
        c = self.of
        if not len(c.pairs):
            return None
        near = self._fns["near"](d.geom_xpos, self._first, self._second, self._reach).tolist()
        k = 0
        det, body_of, pairs = c.detection, c._body_of, c._pair_list
        fromto, jac, jdot = self._fromto, self._jac, self._jdot
        for i in near:
            g1, g2 = pairs[i]
            dd = mujoco.mj_geomDistance(m, d, g1, g2, det, fromto[k])
            if dd >= det:
                continue
            self._dist[k] = dd
            for e, (g, p) in enumerate(((g1, fromto[k, :3]), (g2, fromto[k, 3:]))):
                mujoco.mj_jac(m, d, jac[k, e], None, p, body_of[g])
                mujoco.mj_jacDot(m, d, jdot[k, e], None, p, body_of[g])
            k += 1
        if not k:
            c.last_distance = np.zeros(0)
            return None
        A, lo, keep = self._fns["rows"](fromto[:k], self._dist[:k], jac[:k], jdot[:k], d.qvel, self._vadr,
                                        c.bandwidth, c.clearance)
        c.last_distance = self._dist[:k][keep]
        if not keep.any():
            return None
        return (A, lo) if keep.all() else (A[keep], lo[keep])
