"""The forward belief's cuts and posterior as compiled loops (``SynthesisConfig.kernel = "numba"``, issue 24).

:class:`~.forward_belief.ForwardBelief` does a cut with about a hundred small NumPy calls: the kept starts' path sums
(:class:`~.path_sums.PathSums`), the closed intervals' scores (the type tables' spatial and motion row densities, the
duration table, the path terms, the shortness mask), the log-sum-exps of the semi-Markov recursion, the used-label
masks, the long bucket and the renormalisation. :func:`cuts` does every cut due at a frame in one compiled call (at
10 Hz a recording's first call has about five back to back), reading the same per-model arrays and the same state
(start rows, F, the long bucket, the path sums), and :func:`posterior` the per-frame posterior. The arithmetic is the
NumPy path's, written as scalar loops: the same operations on the same values, but the sums are sequential (NumPy's
are pairwise over contiguous axes) and exp, log, pow, hypot, atan2 and cos are the C library's, not NumPy's. So it
is not bitwise; it is accepted under the tolerance declared in docs/design.md §7 (session 27) and tested against the
NumPy cut (tests/test_belief_kernel.py). NaN and −inf follow NumPy's rules: maxima propagate NaN, a log-sum-exp of
−inf terms is −inf, ``np.logaddexp``'s branches.

The closed intervals' scores are :mod:`~.belief_scores`'. The functions are plain Python until :func:`load` compiles them (:func:`~.compiled.njit`, numba's cache on
disk); :func:`load` raises the :class:`~socialaff_sim.errors.ConfigError` naming the ``[fast]`` extra without numba.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from . import belief_scores, compiled
from .belief_scores import BELOW_FLOOR, NO_ERROR, NO_REPRESENTATIVE, NOT_HELD, _frame_ok, closed_scores, row_terms

__all__ = ["BELOW_FLOOR", "NOT_HELD", "NO_ERROR", "NO_REPRESENTATIVE", "Constants", "constants", "cuts", "load", "posterior"]

_LOG2 = math.log(2.0)


class Constants(tuple):
    """The kernel's per-model arrays (read-only, shared): a copy of a belief (the evaluation forks reactors by
    ``copy.deepcopy``) shares them instead of copying them, so every call passes read-only arrays (one compiled
    specialisation, not a second one for writable copies)."""

    def __copy__(self) -> Constants:
        return self

    def __deepcopy__(self, memo: dict) -> Constants:
        return self


SURV = 12
"""The index of log P(D_s > d / fps) (H + 1, S) in :class:`Constants` (what :func:`posterior` reads)."""


def constants(tables: object, sums: object, base: tuple, horizon: int, stride: int, log_start: np.ndarray) -> Constants:
    """The kernel's per-model arrays, from the type tables (``tables``: :class:`~.type_tables.TypeTables`), a
    :class:`~.path_sums.PathSums` (its profile and Σ u(k/L)² table), the belief's own constants ``base`` (those of
    ``forward_belief._constants``) and the start log-probabilities (S,)."""
    trans, bits, surv, _, path_use, path_c, path_2s2, into, from_, dur, short = base
    sp_f, sp_b = row_terms(tables.sp_params, np.zeros(tables.sp_params.shape[0], bool))
    mo_f, mo_b = row_terms(tables.mo_params, tables.mo_expon)
    read = np.asarray(tables._read, bool)  # noqa: SLF001 (the columns each spatial row's type reads)
    powers, coefs, u2 = sums.profile_terms(horizon + stride + 2)
    c = np.ascontiguousarray
    return Constants((c(sp_f), c(sp_b), c(tables.sp_w, float), c(read), c(tables.sp_joint), c(tables.sp_type),
                      c(mo_f), c(mo_b), c(tables.mo_joint), c(tables.mo_type),
                      c(trans, float), c(bits, np.int64), c(surv, float), c(dur, float), c(short, bool),
                      c(path_use, bool), c(path_c, float), c(path_2s2, float), c(into, np.int64), c(from_, np.int64),
                      c(powers), c(coefs), c(u2), c(log_start, float), float(tables.eps)))


# --- scalar helpers (NumPy's rules for NaN and −inf) -------------------------------------------------------------

def _nanmax(a: float, b: float) -> float:
    """``np.maximum(a, b)``: NaN if either is NaN (the first)."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a >= b else b


def _logaddexp(x: float, y: float) -> float:
    """``np.logaddexp(x, y)`` by its branches (x == y, including both −inf: x + log 2)."""
    if x == y:
        return x + _LOG2
    tmp = x - y
    if tmp > 0:
        return x + math.log1p(math.exp(-tmp))
    if tmp <= 0:
        return y + math.log1p(math.exp(tmp))
    return tmp


def _exp_term(v: float, safe: float) -> float:
    """exp(v − safe), a log-sum-exp's term: 0 for v = −inf without calling exp (exp(−inf − safe) is exactly 0; most
    of F's entries are −inf, the masks that do not hold their label); NaN stays NaN."""
    if v == -math.inf:
        return 0.0
    return math.exp(v - safe)


def _finish_lse(top: float, total: float) -> float:
    """The last step of ``forward_belief._lse``: log Σ exp(x − safe) + safe, safe = top if finite else 0."""
    safe = top if math.isfinite(top) else 0.0
    return math.log(total) + safe


def cuts(rows, floor, b0, n_cuts, stride, origin, horizon, starts, F, long, has_long, long_read,  # noqa: ANN001, ANN201
         a, upto, ps, sp_f, sp_b, sp_w, read, sp_joint, sp_type, mo_f, mo_b, mo_joint, mo_type, trans, bits, surv,
         dur, short, path_use, path_c, path_2s2, into, from_, powers, coefs, u2, log_start, eps):
    """``n_cuts`` cuts b0, b0 + stride, … of ``ForwardBelief._cut`` on the frames ``rows`` (frames from ``floor`` on,
    J, 3) and the belief's state (starts (K,), F (K, M, S), the long bucket (M, S), whether it holds mass, its
    posterior term (S,), and the path sums' anchors, summed-up-to frames and packed rows). Returns the new state,
    G (K, S), G_long (S,), the cuts done, an error code and the frame it names."""
    M, S = long.shape[0], long.shape[1]
    J3 = sp_w.shape[1] * 3
    G = np.empty((0, S))
    G_long = np.full(S, -np.inf)
    long = long.copy()  # the caller's bucket is not changed in place (renormalised below)
    for done in range(n_cuts):
        b = b0 + done * stride
        K = starts.shape[0]
        Fn = np.full((M, S), -np.inf)
        if b == origin:
            for s in range(S):
                prior = log_start[s] if b == 0 else -math.log(S)
                Fn[bits[s] if M > 1 else 0, s] = prior
        else:
            C = np.full((M, S), -np.inf)
            if K or has_long:
                seg, code, frame = closed_scores(rows, floor, b, starts, K, has_long, horizon, a, upto, ps,
                                                 sp_f, sp_b, sp_w, read, sp_joint, sp_type, mo_f, mo_b, mo_joint,
                                                 mo_type, dur, short, path_use, path_c, path_2s2, powers, coefs, u2,
                                                 eps, S)
                if code != NO_ERROR:
                    return starts, F, long, has_long, long_read, a, upto, ps, G, G_long, done, code, frame
                for m in range(M):
                    for s in range(S):
                        top = -np.inf
                        for k in range(K):
                            top = _nanmax(top, F[k, m, s] + seg[k, s])
                        safe = top if math.isfinite(top) else 0.0
                        tot = 0.0
                        for k in range(K):
                            tot += _exp_term(F[k, m, s] + seg[k, s], safe)
                        c = _finish_lse(top, tot)
                        if has_long:
                            c = _logaddexp(c, long[m, s] + seg[K, s])
                        C[m, s] = c
            V = np.empty((M, S))
            for m in range(M):
                for s in range(S):
                    top = -np.inf
                    for q in range(S):
                        top = _nanmax(top, C[m, q] + trans[q, s])
                    safe = top if math.isfinite(top) else 0.0
                    tot = 0.0
                    for q in range(S):
                        tot += _exp_term(C[m, q] + trans[q, s], safe)
                    V[m, s] = _finish_lse(top, tot)
            Vf, Ff = V.reshape(-1), Fn.reshape(-1)
            for i in range(into.shape[0]):
                Ff[into[i]] = Vf[from_[i]]
        # The new row, and the path sums' row of its interval (PathSums.add).
        anchor = max(b - 1, 0)
        code = _frame_ok(anchor, floor, rows.shape[0])
        if code != NO_ERROR:
            return starts, F, long, has_long, long_read, a, upto, ps, G, G_long, done, code, anchor
        old = 0
        for k in range(K):
            if starts[k] <= b - horizon:
                old += 1
        if b <= b - horizon:
            old += 1
        keep = K + 1 - old
        starts2 = np.empty(keep, np.int64)
        F2 = np.empty((keep, M, S))
        a2 = np.empty(keep, np.int64)
        upto2 = np.empty(keep, np.int64)
        ps2 = np.empty((keep, ps.shape[1]))
        o = np.empty((old, M, S))
        i2, io = 0, 0
        for k in range(K + 1):
            st = starts[k] if k < K else b
            if st <= b - horizon:
                o[io] = F[k] if k < K else Fn
                io += 1
                continue
            starts2[i2] = st
            if k < K:
                F2[i2] = F[k]
                a2[i2], upto2[i2] = a[k], upto[k]
                ps2[i2] = ps[k]
            else:
                F2[i2] = Fn
                a2[i2], upto2[i2] = anchor, anchor + 1
                ps2[i2] = 0.0
                x = rows[anchor - floor]
                for q in range(J3):
                    ps2[i2, q] = x[q // 3, q % 3]
            i2 += 1
        if old:  # the rows too old for the next cut join the long bucket
            oldF = np.empty((M, S))
            for m in range(M):
                for s in range(S):
                    top = -np.inf
                    for k in range(old):
                        top = _nanmax(top, o[k, m, s])
                    safe = top if math.isfinite(top) else 0.0
                    tot = 0.0
                    for k in range(old):
                        tot += _exp_term(o[k, m, s], safe)
                    oldF[m, s] = _finish_lse(top, tot)
            for m in range(M):
                for s in range(S):
                    long[m, s] = _logaddexp(long[m, s], oldF[m, s])
            if M > 1:  # the long bucket forgets the labels used before it
                merged = np.empty(S)
                for s in range(S):
                    merged[s] = _lse_col(long, s, M)
                long = np.full((M, S), -np.inf)
                for s in range(S):
                    long[bits[s], s] = merged[s]
        starts, F, a, upto, ps = starts2, F2, a2, upto2, ps2
        # Renormalise: Python's max of the two NumPy maxima (the first unless the second is greater).
        tf = -np.inf
        first = True
        for v in F.reshape(-1):
            tf = v if first else _nanmax(tf, v)
            first = False
        tl = -np.inf
        first = True
        for v in long.reshape(-1):
            tl = v if first else _nanmax(tl, v)
            first = False
        top = tl if tl > tf else tf
        if math.isfinite(top):
            F -= top
            long -= top
        K2 = starts.shape[0]
        G = np.empty((K2, S))
        for k in range(K2):
            for s in range(S):
                G[k, s] = _lse_col(F[k], s, M)
        G_long = np.empty(S)
        for s in range(S):
            G_long[s] = _lse_col(long, s, M)
        has_long = False
        for v in long.reshape(-1):
            if math.isfinite(v):
                has_long = True
        if has_long:
            long_read = G_long + surv[horizon]
    return starts, F, long, has_long, long_read, a, upto, ps, G, G_long, n_cuts, NO_ERROR, 0


def _lse_col(X: np.ndarray, s: int, M: int) -> float:
    """log Σ_m exp X[m, s] (``forward_belief._lse`` over the masks)."""
    top = -np.inf
    for m in range(M):
        top = _nanmax(top, X[m, s])
    safe = top if math.isfinite(top) else 0.0
    tot = 0.0
    for m in range(M):
        tot += _exp_term(X[m, s], safe)
    return _finish_lse(top, tot)


def posterior(t, starts, G, surv, horizon, has_long, long_read):  # noqa: ANN001, ANN201
    """``ForwardBelief._posterior_at``'s starts (K',) and P (K', S) at frame ``t``, and whether anything is possible
    (False: the caller returns the uniform fallback at the origin)."""
    K, S = G.shape[0], G.shape[1]
    n = K + (1 if has_long else 0)
    out_starts = np.empty(n, np.int64)
    logp = np.empty((n, S))
    for k in range(K):
        out_starts[k] = starts[k]
        d = min(t - starts[k], horizon)
        for s in range(S):
            logp[k, s] = G[k, s] + surv[d, s]
    if has_long:
        out_starts[K] = t - horizon
        for s in range(S):
            logp[K, s] = long_read[s]
    top = -np.inf
    first = True
    for v in logp.reshape(-1):
        top = v if first else _nanmax(top, v)
        first = False
    if not math.isfinite(top):
        return out_starts, logp, False
    p = np.exp(logp - top)
    tot = 0.0
    for v in p.reshape(-1):
        tot += v
    return out_starts, p / tot, True


_COMPILED = ("_nanmax", "_logaddexp", "_exp_term", "_finish_lse", "_lse_col", "cuts", "posterior")


def _compile() -> dict[str, Any]:
    """The compiled functions by name, put in place of the Python ones: every function, or none (numba missing). A
    compiled function resolves the functions it calls among its module's globals when it is first called, so each
    module's names are replaced by the compiled ones before any call: the scores' (also imported here by name), then
    this module's. (``py_func``: the Python function again, should a compiled one be there already.)"""
    scores, mine = vars(belief_scores), globals()
    jitted = {name: compiled.njit(getattr(scores[name], "py_func", scores[name]))
              for name in belief_scores._COMPILED}  # noqa: SLF001
    own = {name: compiled.njit(getattr(mine[name], "py_func", mine[name])) for name in _COMPILED}
    scores.update(jitted)
    mine.update({name: f for name, f in jitted.items() if name in mine})
    mine.update(own)
    return {**jitted, **own}


def load() -> None:
    """Compile the kernels (once per process, :func:`~.compiled.once`; numba's on-disk cache makes later processes load
    them). Raises the :class:`~socialaff_sim.errors.ConfigError` of :func:`~.compiled.require` without numba."""
    compiled.once(__name__, _compile)
