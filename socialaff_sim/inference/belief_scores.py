"""The closed intervals' scores of the forward belief's cut as a compiled loop (part of :mod:`~.belief_kernel`,
``SynthesisConfig.kernel = "numba"``, issue 24).

:func:`closed_scores` is ``ForwardBelief._closing`` (with ``_features`` and :meth:`~.path_sums.PathSums.residuals`)
for the kept starts and the long bucket's row: the path sums advanced by the new frames, the spatial row densities of
the common end frame, the motion row densities of each interval's displacement, the duration table, the path terms and
the shortness mask, written as scalar loops over the same arrays (:func:`row_terms`: the terms
:class:`~.row_density.RowSet` keeps). Not bitwise (sequential sums, the C library's functions, and two scalar forms:
the von Mises cosine from μ's cosine and sine, the Weibull power from the logarithm it also needs): within the
tolerance of docs/design.md §7 (session 27). Plain Python until :func:`~.belief_kernel.load` compiles it.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import i0e

from ..model.densities import weibull_terms

__all__ = ["BELOW_FLOOR", "NOT_HELD", "NO_ERROR", "NO_REPRESENTATIVE", "closed_scores", "row_terms"]

_LOG_2PI = float(np.log(2.0 * np.pi))
NO_ERROR, BELOW_FLOOR, NOT_HELD, NO_REPRESENTATIVE = 0, 1, 2, 3
"""Error codes of :func:`closed_scores` and :func:`~.belief_kernel.cuts` (the cuts before the failing one are applied;
the caller raises)."""


def row_terms(params: np.ndarray, expon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Polar parameter rows (R, 6) and their exponential flags (R,) as the kernel reads them: floats (R, 15) k_h, λ_h,
    k_v, λ_v, μ, κ, log i0e(κ), log(k_h/λ_h), k_h − 1, log(k_v/λ_v), k_v − 1, −log λ_h, −log λ_v, cos μ, sin μ, and
    flags (R, 3) exponential, k_h == 1, k_v == 1 (the terms :class:`~.row_density.RowSet` keeps, by the same
    functions, and μ's cosine and sine)."""
    p = np.asarray(params, float).reshape(-1, 6)
    kh, lh, kv, lv, mu, kap = p.T
    with np.errstate(divide="ignore", invalid="ignore"):
        (lkl_h, km1_h, k1_h), (lkl_v, km1_v, k1_v) = weibull_terms(kh, lh), weibull_terms(kv, lv)
        floats = np.column_stack([p, np.log(i0e(kap)), lkl_h, km1_h, lkl_v, km1_v, -np.log(lh), -np.log(lv),
                                  np.cos(mu), np.sin(mu)])
    flags = np.column_stack([np.asarray(expon, bool), k1_h, k1_v])
    return np.ascontiguousarray(floats), np.ascontiguousarray(flags)


def _power(z: float, lz: float, k: float) -> float:
    """z^k from lz = log z: exp(k log z) (one exp instead of a pow; equal in exact arithmetic), pow where k = 0
    (pow(NaN or ∞, 0) = 1)."""
    return math.exp(k * lz) if k != 0.0 else z**k


def _polar_row(x: float, y: float, z: float, f: np.ndarray, g: np.ndarray, r: int, eps: float) -> float:
    """One row's polar log-density of the vector (x, y, z): :meth:`~.row_density.RowSet.logpdf`'s terms, with
    cos(atan2(y, x) − μ) as (x cos μ + y sin μ) / |(x, y)| (where 0 < |(x, y)| < ∞; else as NumPy writes it) and the
    Weibull z^k as exp(k log z) with log z taken once: equal in exact arithmetic, not bitwise."""
    h0 = math.hypot(x, y)
    h = h0
    if h == h and h < eps:
        h = eps
    v = abs(z)
    if v == v and v < eps:
        v = eps
    if 0.0 < h0 < math.inf:
        c = (x * f[r, 13] + y * f[r, 14]) / h0
    else:
        c = math.cos(math.atan2(y, x) - f[r, 4])
    if g[r, 0]:
        dist = (f[r, 11] - h / f[r, 1]) + (f[r, 12] - v / f[r, 3])
    else:
        zh = h / f[r, 1]
        lz = math.log(zh)
        a = f[r, 7] - _power(zh, lz, f[r, 0])
        a = a + (0.0 if g[r, 1] else f[r, 8] * lz)
        zv = v / f[r, 3]
        lz = math.log(zv)
        b = f[r, 9] - _power(zv, lz, f[r, 2])
        b = b + (0.0 if g[r, 2] else f[r, 10] * lz)
        dist = a + b
    return dist + (f[r, 5] * (c - 1.0) - _LOG_2PI - f[r, 6])


def _frame_ok(f: int, floor: int, n: int) -> int:
    if f < floor:
        return BELOW_FLOOR
    if f >= floor + n:
        return NOT_HELD
    return NO_ERROR


def closed_scores(rows, floor, b, starts, K, has_long, horizon, a, upto, ps,  # noqa: ANN001, ANN201
                  sp_f, sp_b, sp_w, read, sp_joint, sp_type, mo_f, mo_b, mo_joint, mo_type,
                  dur, short, path_use, path_c, path_2s2, powers, coefs, u2, eps, S):
    """(K + has_long, S) closed-interval scores [starts, b) (``ForwardBelief._closing``), the kept rows' path sums
    advanced to the end frame b − 1 first (``PathSums.residuals``). Returns (seg, error code, frame)."""
    J = sp_w.shape[1]
    J3 = J * 3
    P = powers.shape[0]
    e = b - 1
    n_rows = rows.shape[0]
    code = _frame_ok(e, floor, n_rows)
    if code != NO_ERROR:
        return np.empty((0, S)), code, e
    for k in range(K):
        lo = upto[k]
        if lo < floor and lo < e:
            return np.empty((0, S)), BELOW_FLOOR, lo
        anchor = max(starts[k] - 1, 0)
        if anchor < floor:
            return np.empty((0, S)), BELOW_FLOOR, anchor
    # The path sums: each kept row gains its interior frames [upto, e) (PathSums._advance).
    kp = np.empty(P)
    for k in range(K):
        for fr in range(upto[k], e):
            kf = float(fr - a[k])
            for p in range(P):
                kp[p] = kf ** powers[p]
            x = rows[fr - floor]
            for q in range(J3):
                y = x[q // 3, q % 3] - ps[k, q]
                ps[k, J3 + q] += y * y
                for p in range(P):
                    ps[k, (2 + p) * J3 + q] += kp[p] * y
        if upto[k] < e:
            upto[k] = e
    end = rows[e - floor]
    n_seg = K + (1 if has_long else 0)
    seg = np.empty((n_seg, S))
    # Spatial: one configuration (the common end frame), every type's rows.
    sp = np.zeros(S)
    for r in range(sp_f.shape[0]):
        j = sp_joint[r]
        ox, oy, oz = 0.0, 0.0, 0.0
        for jj in range(J):
            if read[r, jj]:
                w = sp_w[r, jj]
                ox += w * end[jj, 0]
                oy += w * end[jj, 1]
                oz += w * end[jj, 2]
        sp[sp_type[r]] += _polar_row(end[j, 0] - ox, end[j, 1] - oy, end[j, 2] - oz, sp_f, sp_b, r, eps)
    for s in range(S):
        if sp[s] != sp[s]:
            sp[s] = -np.inf
    mo = np.zeros(S)
    sq = np.empty(J)
    wp = np.empty(P)
    rep_row = -1
    if has_long:  # the long bucket's representative start b − horizon: a kept row's (forward_belief._features)
        for k in range(K):
            if starts[k] == b - horizon:
                rep_row = k
        if rep_row < 0:
            return np.empty((0, S)), NO_REPRESENTATIVE, b - horizon
    for i in range(n_seg):
        k = i if i < K else rep_row  # the long bucket's row: that kept row's start, anchor and path sums
        st = starts[k]
        xa = rows[max(st - 1, 0) - floor]
        d = b - st
        # Motion: the displacement end − x[anchor], every type's rows.
        for s in range(S):
            mo[s] = 0.0
        for r in range(mo_f.shape[0]):
            j = mo_joint[r]
            mo[mo_type[r]] += _polar_row(end[j, 0] - xa[j, 0], end[j, 1] - xa[j, 1], end[j, 2] - xa[j, 2],
                                         mo_f, mo_b, r, eps)
        # Path residuals of row k's interval [start_k, b) from its sums (PathSums.residuals).
        L = max(e - a[k], 0)
        nf = float(max(L - 1, 0))
        Lf = float(max(L, 1))
        for p in range(P):
            wp[p] = coefs[p] / Lf ** powers[p]
        for jj in range(J):
            tot = 0.0
            for c in range(3):
                q = jj * 3 + c
                cross = 0.0
                for p in range(P):
                    cross += wp[p] * ps[k, (2 + p) * J3 + q]
                D = end[jj, c] - ps[k, q]
                val = (ps[k, J3 + q] - 2.0 * D * cross) + D * D * u2[L]
                tot = val if c == 0 else tot + val
            sq[jj] = tot if (tot != tot or tot > 0.0) else 0.0
        for s in range(S):
            m = mo[s]
            if m != m:
                m = -np.inf
            pth = 0.0
            for jj in range(J):
                if path_use[s, jj]:
                    pth += -1.5 * nf * path_c[s, jj] - sq[jj] / path_2s2[s, jj]
            seg[i, s] = -np.inf if short[d] else ((sp[s] + m) + dur[d, s]) + pth
    return seg, NO_ERROR, 0


_COMPILED = ("_power", "_polar_row", "_frame_ok", "closed_scores")
"""What :func:`~.belief_kernel.load` compiles here, helpers first."""
