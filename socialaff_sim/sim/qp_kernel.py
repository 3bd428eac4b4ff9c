"""The balance QP's arrays assembled in one compiled loop (``BalanceConfig.qp_kernel = "numba"``, the extra ``[fast]``).

:func:`~.contact_qp.solve_contact_qp` builds its cost (H, f), the generalised forces of the cone edges G and its
constraint rows (the equation of motion's rows in their order, the inequality, hard task, foot load and centre of
pressure rows) with a few dozen NumPy calls per solve, and scales the rows to unit norm for DAQP. :func:`assemble`
does the same arithmetic in one no-Python loop (:func:`~socialaff_sim.inference.compiled.njit`, fast-math off). It
is not bit for bit the NumPy path (BLAS and einsum sum in their own order; the rows' weights multiply each product
here, the sums there): an alternative evaluation, declared equivalent for the standing mode by its rule on fresh
instances (docs/design.md §5, session 33). NumPy stays the reference and the default (``qp_kernel = "numpy"``).
"""

from __future__ import annotations

from typing import Any

import daqp
import numpy as np

from ..inference.compiled import njit, once

__all__ = ["CompiledLimits", "assemble", "compiled_rows", "kernels"]

_INF = 1e30  # (contact_qp's "no bound")


def _assemble(M, h, order, nu, point_jac, edges, TA, Tb, Tw, da, db, dw, w_force, w_reg, mass, lim, IA, Ilo, EA,
              Eb, loaded, foot, min_load, cop):  # pragma: no cover - compiled; tested through compiled_rows
    n = M.shape[0]
    P = point_jac.shape[0]
    K = 4 * P
    N = K + n
    G = np.zeros((n, K))
    for p in range(P):
        for j in range(n):
            for k in range(4):
                s = 0.0
                for i in range(3):
                    s += point_jac[p, i, j] * edges[p, i, k]
                G[j, 4 * p + k] = s
    H = np.zeros((N, N))
    f = np.zeros(N)
    for i in range(K):
        H[i, i] = w_force
    for j in range(n):
        H[K + j, K + j] = w_reg
    for r in range(TA.shape[0]):  # the full tasks' rows: w aᵀa and w aᵀb, row by row
        w = Tw[r]
        for a in range(n):
            x = TA[r, a]
            if x == 0.0:
                continue
            wx = w * x
            f[K + a] -= wx * Tb[r]
            for b in range(n):
                H[K + a, K + b] += wx * TA[r, b]
    for j in range(n):  # the diagonal task
        H[K + j, K + j] += dw * (da[j] * da[j])
        f[K + j] -= dw * (da[j] * db[j])
    n_in, n_eq, n_ld, n_cop = IA.shape[0], EA.shape[0], loaded.shape[0], cop.shape[0]
    R = n + n_in + n_eq + n_ld + n_cop
    A = np.zeros((R, N))
    up = np.empty(R)
    lo = np.empty(R)
    sn = np.zeros(R, dtype=np.int32)
    for r in range(n):
        o = order[r]
        for c in range(K):
            A[r, c] = -G[o, c]
        for c in range(n):
            A[r, K + c] = M[o, c] / mass
        hm = h[o] / mass
        if r < nu:
            up[r] = -hm
            lo[r] = -hm
            sn[r] = 5
        else:
            hi_, lo_ = lim[o, 1], lim[o, 0]
            up[r] = hi_ / mass - hm if np.isfinite(hi_) else _INF
            lo[r] = lo_ / mass - hm if np.isfinite(lo_) else -_INF
    r = n
    for i in range(n_in):
        for c in range(n):
            A[r, K + c] = IA[i, c]
        up[r], lo[r] = _INF, Ilo[i]
        r += 1
    for i in range(n_eq):
        for c in range(n):
            A[r, K + c] = EA[i, c]
        up[r], lo[r] = Eb[i], Eb[i]
        sn[r] = 5
        r += 1
    for i in range(n_ld):
        for p in range(P):
            if foot[p] == loaded[i]:
                for k in range(4):
                    A[r, 4 * p + k] = edges[p, 2, k]
        up[r], lo[r] = _INF, min_load / mass
        r += 1
    for i in range(n_cop):
        for c in range(K):
            A[r, c] = cop[i, c]
        up[r], lo[r] = _INF, 0.0
        r += 1
    # the rows scaled to unit norm for DAQP, the simple bounds 0 ≤ β' first (an empty row: not scaled, ok False)
    As = np.empty((R, N))
    bu = np.empty(K + R)
    bl = np.zeros(K + R)
    s5 = np.zeros(K + R, dtype=np.int32)
    ok = True
    for i in range(K):
        bu[i] = _INF
    for r in range(R):
        q = 0.0
        for c in range(N):
            q += A[r, c] * A[r, c]
        nrm = np.sqrt(q)
        if not nrm > 1e-9:
            ok = False
            nrm = 1.0
        k_ = 1.0 / nrm
        for c in range(N):
            As[r, c] = A[r, c] * k_
        bu[K + r] = up[r] * k_ if up[r] < _INF else _INF
        bl[K + r] = lo[r] * k_ if lo[r] > -_INF else -_INF
        s5[K + r] = sn[r]
    return H, f, G, A, up, lo, sn, As, bu, bl, s5, ok


def _limits(q, v, gain, ctrlrange, b0, b1, b2, cl, clip_on, clip_lo, clip_hi, rows, n, fraction):  # pragma: no cover - compiled; tested through CompiledLimits
    """(n, 2) the QP's torque bounds: ±inf, and on the actuators' ``rows`` ``fraction`` times
    :class:`~.contact_qp.ActuatorLimits` at ``q``, ``v`` (A,): the servo's force at its control range's ends (where
    control-limited, in order), then clipped by each of ``clip_on`` (C, A) with ``clip_lo``, ``clip_hi`` (C, A)."""
    out = np.empty((n, 2))
    for r in range(n):
        out[r, 0], out[r, 1] = -np.inf, np.inf
    for a in range(q.shape[0]):
        lo, hi = -np.inf, np.inf
        if cl[a]:
            bias = b0[a] + b1[a] * q[a] + b2[a] * v[a]
            e0, e1 = gain[a] * ctrlrange[a, 0] + bias, gain[a] * ctrlrange[a, 1] + bias
            lo, hi = min(e0, e1), max(e0, e1)
        for c in range(clip_on.shape[0]):
            if clip_on[c, a]:
                lo = min(max(lo, clip_lo[c, a]), clip_hi[c, a])
                hi = min(max(hi, clip_lo[c, a]), clip_hi[c, a])
        out[rows[a], 0], out[rows[a], 1] = fraction * lo, fraction * hi
    return out


class CompiledLimits:
    """:class:`~.contact_qp.ActuatorLimits` of ``limits`` times ``fraction`` on the robot's ``rows`` (A,) of ``n``,
    ±inf elsewhere, compiled (:func:`_limits`; the same operations, bit for bit)."""

    def __init__(self, limits: Any, rows: np.ndarray, n: int, fraction: float) -> None:
        self._fn = kernels()["limits"]
        L = limits
        A = L._n
        on, lo, hi = np.zeros((len(L._clips), A), dtype=np.bool_), np.zeros((len(L._clips), A)), np.zeros((len(L._clips), A))
        for c, (mask, lo_c, hi_c) in enumerate(L._clips):
            on[c], lo[c, mask], hi[c, mask] = mask, lo_c[:, 0], hi_c[:, 0]
        self._args = (np.ascontiguousarray(L._gain[:, 0]), np.ascontiguousarray(L._ctrlrange, dtype=np.float64),
                      L._b0, L._b1, L._b2, np.asarray(L._cl, dtype=np.bool_), on, lo, hi,
                      np.asarray(rows, dtype=np.int64), int(n), float(fraction))

    def __call__(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """(n, 2) the bounds at the actuators' joint positions ``q`` and velocities ``v`` (A,)."""
        return self._fn(q, v, *self._args)


def kernels() -> Any:
    """The compiled :func:`_assemble` and :func:`_limits` (made and warmed up once per process; numba missing: a
    ConfigError)."""
    return once(__name__, lambda: {"assemble": njit(_assemble), "limits": njit(_limits)}, _warm)


def _warm(fns: Any) -> None:
    """One call of each of the argument types the controller passes (its row order and cone edges are read-only
    arrays)."""
    fn = fns["assemble"]
    n, P = 7, 2
    z = np.zeros
    order, edges = np.arange(n), np.ones((P, 3, 4))
    order.flags.writeable = edges.flags.writeable = False
    fn(np.eye(n), z(n), order, 1, z((P, 3, n)), edges, z((1, n)), z(1), z(1), z(n), z(n), 1.0,
       1e-3, 1e-6, 1.0, np.ones((n, 2)), z((0, n)), z(0), z((0, n)), z(0), np.arange(1), np.zeros(P, dtype=np.int64),
       0.0, z((0, 4 * P)))
    o = np.ones(2)
    fns["limits"](o, o, o, np.ones((2, 2)), o, o, o, np.ones(2, dtype=np.bool_), np.ones((1, 2), dtype=np.bool_),
                  np.ones((1, 2)), np.ones((1, 2)), np.arange(2, dtype=np.int64), 3, 0.9)


def compiled_rows(M: np.ndarray, h: np.ndarray, order: np.ndarray, nu: int, point_jac: np.ndarray, edges: np.ndarray,
                  tasks: list[tuple[np.ndarray, np.ndarray, float]], w_force: float, w_reg: float, mass: float,
                  lim: np.ndarray, inequalities: tuple[np.ndarray, np.ndarray] | None,
                  equalities: tuple[np.ndarray, np.ndarray] | None, loaded: np.ndarray, foot: np.ndarray | None,
                  min_load: float, cop: np.ndarray | None, force_cost: np.ndarray | None = None) -> tuple[Any, ...]:
    """:func:`~.contact_qp.solve_contact_qp`'s H, f, G and unscaled rows A, up, lo, senses (as its NumPy assembly
    returns them), and DAQP's ``(x, flag)`` on the rows scaled here (``None`` when a row is empty: the caller
    scales and drops it as with NumPy); ``force_cost`` (4P, 4P) added to H's force block, as the NumPy path adds it."""
    n = M.shape[0]
    full = [(A, b, w) for A, b, w in tasks if A.ndim == 2]
    diag = [(A, b, w) for A, b, w in tasks if A.ndim == 1]
    if len(diag) > 1:
        raise ValueError("qp_kernel='numba': at most one diagonal task")
    TA = np.vstack([A for A, _, _ in full]) if full else np.zeros((0, n))
    Tb = np.concatenate([b for _, b, _ in full]) if full else np.zeros(0)
    Tw = np.concatenate([np.full(len(b), float(w)) for _, b, w in full]) if full else np.zeros(0)
    da, db, dw = diag[0] if diag else (np.zeros(n), np.zeros(n), 0.0)
    P = point_jac.shape[0]
    empty = np.zeros((0, n))
    IA, Ilo = inequalities if inequalities is not None else (empty, np.zeros(0))
    EA, Eb = equalities if equalities is not None else (empty, np.zeros(0))
    H, f, G, A, up, lo, sn, As, bu, bl, s5, ok = assemble(
        M, h, order, nu, np.ascontiguousarray(point_jac), edges, TA, Tb, Tw, da, db, float(dw), float(w_force),
        float(w_reg), float(mass), lim, np.ascontiguousarray(IA, dtype=np.float64), np.asarray(Ilo, dtype=np.float64),
        np.ascontiguousarray(EA, dtype=np.float64), np.asarray(Eb, dtype=np.float64), loaded,
        np.zeros(P, dtype=np.int64) if foot is None else np.asarray(foot, dtype=np.int64), float(min_load),
        np.zeros((0, 4 * P)) if cop is None else np.ascontiguousarray(cop, dtype=np.float64))
    if force_cost is not None:
        H[:4 * P, :4 * P] += force_cost
    first = None
    if ok:
        x, _, flag, _ = daqp.solve(H, f, As, bu, bl, s5)
        first = (np.asarray(x), int(flag))
    return H, f, G, A, up, lo, sn.astype(np.intc), first


def assemble(*args: Any) -> tuple:
    """:func:`_assemble` compiled (the arguments as :func:`compiled_rows` prepares them)."""
    return kernels()["assemble"](*args)
