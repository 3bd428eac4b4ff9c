"""Compiled kernels of the re-planning (``SynthesisConfig.kernel = "numba"``; issue 24, real-time speed, session 27):
the polar row densities, the candidates' scores and the expected-error choice, each one loop over the arrays.

Each kernel evaluates the arithmetic of the NumPy code it replaces (:meth:`~.row_density.RowSet.logpdf`,
:meth:`~.candidate_planner.CandidatePlanner._score` with the type tables, the sign terms and the regression prior,
:func:`~.candidates.expected_error_choice`), in the same order where a choice may depend on it: sums of a row are
NumPy's pairwise summation (:func:`_pairwise`), sums over a non-contiguous axis are sequential, as NumPy's reduction
runs them. The elementwise functions (log, exp, cos, power, hypot, arctan2) are the C library's, not NumPy's SIMD ones,
so values differ from NumPy's in the last bits: accepted under the tolerance declared in docs/design.md §7 (session
27), tested against the NumPy code in tests/test_score_kernel.py. Random draws are not here: they stay NumPy's.

This module needs numba: it is imported by :func:`~.row_density.compiled_kernels` only, which raises the
:class:`~socialaff_sim.errors.ConfigError` naming the extra when numba is missing.
"""

from __future__ import annotations

import math

import numpy as np

from ..model.densities import LOG_2PI
from .compiled import njit

__all__ = ["rows_logpdf", "scores", "choice", "pairwise_sum"]

_PW_BLOCK = 128  # NumPy's PW_BLOCKSIZE


@njit
def pairwise_sum(a: np.ndarray, lo: int, n: int) -> float:
    """Σ a[lo : lo + n] in NumPy's pairwise order (``np.add.reduce`` over a contiguous row: above 128 values split in
    halves, a multiple of 8 on the left, the halves' sums added; eight running sums within a block, then the tail),
    from 0.0 as NumPy's reduction starts. The halves are walked by an explicit stack: numba's on-disk cache does not
    hold recursive functions."""
    if n <= _PW_BLOCK:
        return 0.0 + _block(a, lo, n)
    los = np.empty(64, np.int64)  # depth ≤ log2(n / 128) + 1
    ns = np.empty(64, np.int64)
    stage = np.zeros(64, np.int64)
    vals = np.empty(64)
    top, vtop = 0, 0
    los[0], ns[0] = lo, n
    while top >= 0:
        m, start = ns[top], los[top]
        if m <= _PW_BLOCK:
            vals[vtop] = _block(a, start, m)
            vtop += 1
            top -= 1
            continue
        half = m // 2
        half -= half % 8
        if stage[top] == 0:  # the left half first
            stage[top] = 1
            top += 1
            los[top], ns[top], stage[top] = start, half, 0
        elif stage[top] == 1:  # then the right half
            stage[top] = 2
            top += 1
            los[top], ns[top], stage[top] = start + half, m - half, 0
        else:  # left + right
            vals[vtop - 2] = vals[vtop - 2] + vals[vtop - 1]
            vtop -= 1
            top -= 1
    return 0.0 + vals[0]


@njit
def _block(a: np.ndarray, lo: int, n: int) -> float:
    """NumPy's pairwise sum of at most 128 values: sequential below 8, else eight running sums, combined, then the tail."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[lo + i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    i = 8
    end = n - n % 8
    while i < end:
        r0 += a[lo + i]
        r1 += a[lo + i + 1]
        r2 += a[lo + i + 2]
        r3 += a[lo + i + 3]
        r4 += a[lo + i + 4]
        r5 += a[lo + i + 5]
        r6 += a[lo + i + 6]
        r7 += a[lo + i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


_BIG = float(np.finfo(float).max)


@njit
def _nan_to_num(v: float) -> float:
    """``np.nan_to_num`` of one float: NaN → 0, ±inf → ±the largest float."""
    if math.isnan(v):
        return 0.0
    if math.isinf(v):
        return _BIG if v > 0 else -_BIG
    return v


@njit
def _weibull(x: float, lam: float, k: float, lkl: float, km1: float, k1: float) -> float:
    """``row_density._weibull`` of one element: log(k/λ) − z^k + (k − 1) log z, z = x/λ (0 for the term when k = 1).
    z^k as exp(k log z) from the log made anyway (C's pow is about as dear as log and exp together; the same value
    within |k log z| ulp), by pow itself where z is 0, infinite or NaN or k is not finite (its conventions)."""
    z = x / lam
    if z > 0.0 and z < math.inf and math.isfinite(k):
        logz = math.log(z)
        zk = math.exp(k * logz)
    else:
        logz = -math.inf if z == 0.0 else (math.inf if z == math.inf else math.nan)
        zk = z**k
    core = lkl - zk
    term = 0.0 if k1 != 0.0 else km1 * logz
    return core + term


@njit
def _density(x: float, y: float, zc: float, eps: float, expon: bool, kh: float, lh: float, nlh: float, kv: float,
             lv: float, nlv: float, lkl_h: float, km1_h: float, k1_h: float, lkl_v: float, km1_v: float, k1_v: float,
             mu: float, kap: float, li0e: float, cmu: float, smu: float) -> float:
    """The log-density of one vector (x, y, z) under one row (:meth:`~.row_density.RowSet.logpdf`; the row's terms as
    scalars: a call that passes no array costs no reference counting). cos(θ − μ) with θ = arctan2(y, x) as
    (x cos μ + y sin μ) / r (r = |(x, y)|; cos μ and sin μ NumPy's, from the table): the same value within a few ulp of
    1, without arctan2 and cos; where r is 0, infinite or NaN (arctan2's conventions for the angle), by arctan2 and
    cos."""
    r2 = x * x + y * y
    # sqrt(x² + y²) within an ulp of hypot (a fraction of its cost); hypot itself where the squares could lose range
    r = math.sqrt(r2) if r2 > 1e-280 and r2 < 1e280 else math.hypot(x, y)
    h = eps if r < eps else r  # np.maximum(h, ε): NaN stays NaN
    v = abs(zc)
    if v < eps:
        v = eps
    if r > 0.0 and r < math.inf:
        c = (x * cmu + y * smu) / r
    else:
        c = math.cos(math.atan2(y, x) - mu)
    if expon:
        dist = (nlh - h / lh) + (nlv - v / lv)
    else:
        dist = _weibull(h, lh, kh, lkl_h, km1_h, k1_h) + _weibull(v, lv, kv, lkl_v, km1_v, k1_v)
    return dist + (kap * (c - 1.0) - LOG_2PI - li0e)


@njit
def _same(a: float, b: float) -> bool:
    """a and b the same float (−0.0 and 0.0 differ: arctan2 tells them apart; NaN is never the same)."""
    return a == b and (a != 0.0 or math.copysign(1.0, a) == math.copysign(1.0, b))


@njit
def _fill(vecs: np.ndarray, tab: np.ndarray, eps: float, out: np.ndarray) -> None:
    """``out`` (N, K) ← the row log-densities of vectors (N, K, 3) under the K rows of ``tab``, row by row; a vector
    the same as the previous one's under that row keeps its value (candidates share agent 0's and the object's joints,
    so their rows repeat: a pure function of the same inputs is the same value)."""
    N, K = vecs.shape[0], vecs.shape[1]
    for k in range(K):
        expon = tab[k, 0] != 0.0
        kh, lh, nlh, kv, lv, nlv = tab[k, 1], tab[k, 2], tab[k, 3], tab[k, 4], tab[k, 5], tab[k, 6]
        lkl_h, km1_h, k1_h, lkl_v, km1_v, k1_v = tab[k, 7], tab[k, 8], tab[k, 9], tab[k, 10], tab[k, 11], tab[k, 12]
        mu, kap, li0e, cmu, smu = tab[k, 13], tab[k, 14], tab[k, 15], tab[k, 16], tab[k, 17]
        px, py, pz, val = math.nan, math.nan, math.nan, math.nan
        for n in range(N):
            x, y, zc = vecs[n, k, 0], vecs[n, k, 1], vecs[n, k, 2]
            if not (_same(x, px) and _same(y, py) and _same(zc, pz)):
                val = _density(x, y, zc, eps, expon, kh, lh, nlh, kv, lv, nlv, lkl_h, km1_h, k1_h, lkl_v, km1_v,
                               k1_v, mu, kap, li0e, cmu, smu)
                px, py, pz = x, y, zc
            out[n, k] = val


@njit
def rows_logpdf(vecs: np.ndarray, tab: np.ndarray, eps: float) -> np.ndarray:
    """(N, K) row log-densities of vectors (N, K, 3) under the K rows of ``tab`` (:attr:`~.row_density.RowSet.table`)."""
    out = np.empty((vecs.shape[0], vecs.shape[1]))
    _fill(vecs, tab, eps, out)
    return out


@njit
def scores(cand: np.ndarray, before: np.ndarray, sp_joint: np.ndarray, w: np.ndarray, cols: np.ndarray,
           mo_joint: np.ndarray, tab: np.ndarray, eps: float, sign: int, aff: np.ndarray, sign_w: np.ndarray,
           off_up: np.ndarray, moving: np.ndarray, disp_up: np.ndarray, prior: int, a1: np.ndarray, mean: np.ndarray,
           L: np.ndarray, logdet: float, const: float) -> np.ndarray:
    """(M,) scores of M configurations ``cand`` (M, 11, 3) after ``before`` (11, 3) under one type: its spatial rows
    (the joints ``sp_joint`` (R,) less the reference weights ``w`` (R, C) of the columns ``cols`` (C,)) and motion rows
    (the joints ``mo_joint`` (Q,)), the R + Q rows of ``tab``; with ``sign``, the vertical-sign terms
    (:class:`~.candidates.SignTerms`' arrays); with ``prior``, the regression prior's Gaussian (agent 1's joints
    ``a1`` (5,), its mean (5, 3), factor L (15, 15), log det, and D log 2π); NaN → −inf."""
    M = cand.shape[0]
    R, Q, C = sp_joint.shape[0], mo_joint.shape[0], cols.shape[0]
    A, B, D = aff.shape[0], moving.shape[0], L.shape[0]
    out = np.empty(M)
    vecs = np.empty((M, R + Q, 3))
    for n in range(M):
        for k in range(R):
            j = sp_joint[k]
            rx = 0.0
            ry = 0.0
            rz = 0.0
            for c in range(C):
                rx += w[k, c] * cand[n, cols[c], 0]
                ry += w[k, c] * cand[n, cols[c], 1]
                rz += w[k, c] * cand[n, cols[c], 2]
            vecs[n, k, 0] = cand[n, j, 0] - rx
            vecs[n, k, 1] = cand[n, j, 1] - ry
            vecs[n, k, 2] = cand[n, j, 2] - rz
        for q in range(Q):
            j = mo_joint[q]
            for d in range(3):
                vecs[n, R + q, d] = cand[n, j, d] - before[j, d]
    rows = np.empty((M, R + Q))
    _fill(vecs, tab, eps, rows)
    terms = np.empty(max(A, B, 1))
    res = np.empty(D)
    J = cand.shape[1]
    zn = np.empty(J)
    for n in range(M):
        dens = rows[n]
        mo = pairwise_sum(dens, R, Q)
        if math.isnan(mo):
            mo = -math.inf
        sp = 0.0
        if R:
            sp = pairwise_sum(dens, 0, R)
            if math.isnan(sp):
                sp = -math.inf
        score = sp + mo
        if sign:
            sg = 0.0
            if A:
                for j in range(J):
                    zn[j] = _nan_to_num(cand[n, j, 2])
                for a in range(A):
                    ref = 0.0
                    for j in range(J):
                        ref += sign_w[a, j] * zn[j]
                    terms[a] = off_up[0, a] if cand[n, aff[a], 2] - ref > 0.0 else off_up[1, a]
                sg += pairwise_sum(terms, 0, A)
            if B:
                for b in range(B):
                    j = moving[b]
                    terms[b] = disp_up[0, b] if cand[n, j, 2] - before[j, 2] > 0.0 else disp_up[1, b]
                sg += pairwise_sum(terms, 0, B)
            score = score + sg
        if prior:
            for i in range(D):
                a = cand[n, a1[i // 3], i % 3]
                res[i] = a - mean[i // 3, i % 3] if math.isfinite(a) else 0.0
            ss = 0.0
            for i in range(D):  # L y = res, forward substitution
                acc = res[i]
                for k in range(i):
                    acc -= L[i, k] * res[k]
                res[i] = acc / L[i, i]
                ss += res[i] * res[i]
            score = score + -0.5 * (ss + logdet + const)
        out[n] = -math.inf if math.isnan(score) else score
    return out


@njit
def choice(cand: np.ndarray, a1: np.ndarray, score: np.ndarray, temperature: float) -> int:
    """:func:`~.candidates.expected_error_choice` of the joints ``a1`` of ``cand`` (M, 11, 3): the candidate nearest
    the mean under weights ∝ exp(score / temperature) (−inf scores weigh nothing; all −inf: 0)."""
    M, J = cand.shape[0], a1.shape[0]
    sc = score / temperature
    top = -math.inf
    any_finite = False
    for i in range(M):
        if math.isfinite(sc[i]):
            if not any_finite or sc[i] > top:
                top = sc[i]
            any_finite = True
    if not any_finite:
        return 0
    w = np.empty(M)
    for i in range(M):
        w[i] = math.exp(sc[i] - top) if math.isfinite(sc[i]) else 0.0
    total = pairwise_sum(w, 0, M)
    for i in range(M):
        w[i] /= total
    D = 3 * J
    x = np.empty((M, D))
    for i in range(M):
        for c in range(D):
            x[i, c] = _nan_to_num(cand[i, a1[c // 3], c % 3])
    mean = np.zeros(D)
    for i in range(M):
        for c in range(D):
            mean[c] += w[i] * x[i, c]
    row = np.empty(D)
    best, best_d2 = 0, math.inf
    for i in range(M):
        for c in range(D):
            row[c] = (x[i, c] - mean[c]) ** 2
        d2 = pairwise_sum(row, 0, D) if math.isfinite(sc[i]) else math.inf
        if math.isnan(d2):  # np.argmin: the first NaN
            return i
        if d2 < best_d2:
            best, best_d2 = i, d2
    return best


def _fixed(a: np.ndarray) -> np.ndarray:
    v = a.view()
    v.flags.writeable = False
    return v


def warm() -> None:
    """Load (or compile) every kernel for the argument types the reactor passes (its fixed inputs read-only, the
    candidates and the prior's mean writable), on a tiny input: called once, when the first reactor with
    ``kernel="numba"`` is made, so that the JIT's cost is paid there and not at the stream's first re-planning."""
    tab = _fixed(np.ones((1, 18)))
    ints, rows, up = _fixed(np.zeros(1, np.int64)), _fixed(np.zeros((1, 11))), _fixed(np.full((2, 1), -0.5))
    cand, before = np.zeros((2, 11, 3)), np.zeros((11, 3))
    a1 = _fixed(np.arange(5, 10, dtype=np.int64))
    rows_logpdf(np.zeros((2, 1, 3)), tab, 1e-3)
    scores(cand, before, ints, _fixed(np.ones((1, 1))), ints, ints, _fixed(np.ones((2, 18))), 1e-3, 1, ints, rows, up,
           ints, up, 1, a1, np.zeros((5, 3)), _fixed(np.eye(15)), 0.0, 0.0)
    choice(cand, a1, np.zeros(2), 5.0)
