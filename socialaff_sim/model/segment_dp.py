"""Best parse of an instance over candidate cut points by dynamic programming (semi-Markov Viterbi).

Given the log score of every candidate interval ``seg[a, b, s]`` (cut points a < b, label s),
log start probabilities and log transition probabilities, find the labelled partition of
``[0, B]`` into intervals between cut points that maximizes

    log p(s_1) + Σ_k log p(s_k | s_{k−1}) + Σ_k seg[a_k, b_k, s_k],

optionally with consecutive labels different (``distinct``) and each label used at most once
(``unique``; the state then carries the set of labels used, 2^|S| of them).
"""

from __future__ import annotations

import numpy as np

__all__ = ["best_segmentation", "segmentation_tables", "backtrace"]


def segmentation_tables(
    seg: np.ndarray,
    log_start: np.ndarray,
    log_trans: np.ndarray,
    *,
    distinct: bool = True,
    unique: bool = False,
    rows: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The DP tables: ``best`` (B + 1, M, S) — the best score of a parse of ``[0, b)`` whose last
    interval is labelled s with used-label set m (M = 2^S if ``unique`` else 1) — and the
    back-pointers ``back`` (B + 1, M, S, 3) holding (previous cut, previous mask, previous label).

    ``rows``: the first k + 1 rows of both tables from an earlier call whose cut points and interval
    scores agree up to cut k (row b reads only ``seg[:b, b]`` and the rows before it); only rows
    k + 1 … B are computed, and only the columns ``seg[:, k + 1:]`` are read."""
    seg = np.where(np.isnan(seg), -np.inf, seg)
    B = seg.shape[0] - 1
    S = log_start.shape[0]
    M = 1 << S if unique else 1
    trans = np.array(log_trans, dtype=float)
    if distinct:
        np.fill_diagonal(trans, -np.inf)
    best = np.full((B + 1, M, S), -np.inf)
    back = np.full((B + 1, M, S, 3), -1, dtype=np.int64)  # (a, mask, s) of the previous interval
    masks = np.arange(M)
    bits = 1 << np.arange(S)
    # Every (used-label set m, label s) an interval can extend: s not in m when labels are unique (the state
    # becomes m | s), every s from the one set otherwise; the targets (m', s) are all distinct.
    if unique:
        src_m, src_s = np.nonzero((masks[:, None] & bits[None, :]) == 0)
        tgt = src_m | bits[src_s]
    else:
        src_s = np.arange(S)
        src_m = tgt = np.zeros(S, np.int64)
    first_mask = bits if unique else np.zeros(S, np.int64)
    labels = np.arange(S)
    trans_sp = trans[None, :, :]  # (1, s', s)
    trans_rows = trans.T[src_s]  # (P, s'): trans[s', s] of each extendable pair's label
    # reach[a, p] = max over s' of (best[a, m, s'] + trans[s', s]) for the extendable pair p = (m, s) = (src_m[p],
    # src_s[p]): what an interval of label s starting at cut a can extend, fixed once row a is (seg is added after).
    pairs = np.arange(len(src_s))
    reach = np.full((B + 1, len(src_s)), -np.inf)
    first = 1
    if rows is not None:
        k = rows[0].shape[0] - 1
        best[: k + 1], back[: k + 1] = rows[0], rows[1]
        reach[1 : k + 1] = (best[1 : k + 1, :, :, None] + trans_sp[:, None]).max(axis=2)[:, src_m, src_s]
        first = k + 1
    seg_p = seg[:, first:, src_s]  # (B + 1, B + 1 − first, P): seg[a, b, s] of each pair's label
    for b in range(first, B + 1):
        # A first interval [0, b).
        best[b, first_mask, labels] = log_start + seg[0, b]
        if b > 1:
            # The candidates are best[a, m, s'] + trans[s', s] + seg[a, b, s] (summed in that order) over the previous
            # cut a in 1..b-1 and label s', read in the order a·S + s' (the first maximum wins). Rounding is monotone,
            # so each a's largest candidate is reach[a, m, s] + seg[a, b, s] exactly; the first a reaching the
            # overall maximum is the chosen one, and its first s' is found among that a's S candidates, recomputed.
            per_a = reach[1:b] + seg_p[1:b, b - first]  # (b − 1, P)
            a_idx = np.argmax(per_a, axis=0)  # (P,)
            v = per_a[a_idx, pairs]
            better = v > best[b, tgt, src_s]
            if better.any():
                a_idx, m, s, t = a_idx[better], src_m[better], src_s[better], tgt[better]
                cand = best[a_idx + 1, m] + trans_rows[better] + seg[a_idx + 1, b, s][:, None]  # (P', s')
                best[b, t, s] = v[better]
                back[b, t, s, 0] = a_idx + 1
                back[b, t, s, 1] = m
                back[b, t, s, 2] = np.argmax(cand, axis=1)
        reach[b] = (best[b, :, :, None] + trans_sp).max(axis=1)[src_m, src_s]
    return best, back


def backtrace(back: np.ndarray, b: int, m: int, s: int) -> list[tuple[int, int, int]]:
    """The intervals ``[(a, b, s), ...]`` of the parse ending at cut ``b`` in state (``m``, ``s``)."""
    out = []
    while True:
        a, pm, ps = back[b, m, s]
        out.append((int(max(a, 0)), b, int(s)))
        if a < 0:
            break
        b, m, s = int(a), int(pm), int(ps)
    return out[::-1]


def best_segmentation(
    seg: np.ndarray,
    log_start: np.ndarray,
    log_trans: np.ndarray,
    *,
    distinct: bool = True,
    unique: bool = False,
) -> tuple[float, list[tuple[int, int, int]]]:
    """Maximize over parses; returns (best log score, [(a, b, s), ...]) or (-inf, []) if none is allowed.

    ``seg``: (B + 1, B + 1, S) float64 (only a < b is read; −inf or NaN forbids an interval).
    """
    best, back = segmentation_tables(seg, log_start, log_trans, distinct=distinct, unique=unique)
    B = best.shape[0] - 1
    S = best.shape[2]
    flat_best = best[B].reshape(-1)
    idx = int(np.argmax(flat_best))
    m, s = divmod(idx, S)
    total = float(flat_best[idx])
    if not np.isfinite(total):
        return -np.inf, []
    return total, backtrace(back, B, m, s)

