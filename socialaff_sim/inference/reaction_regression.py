"""Ridge regressions of agent 1's displacement chosen by an inner cross-validation on the training instances.

Shared by the full model's switching regression (:mod:`.switching`) and the ``ridge`` baseline
(:mod:`socialaff_sim.baselines.ridge`). A *candidate* is a named set of feature columns and a penalty λ;
``hold`` (no columns, λ = ∞, zero displacement) is always one more. Rows are weighted so that every
training instance weighs one in total (as the evaluation's metric weighs instances), the features are
scaled to unit weighted RMS without centring (zero features mean ``hold``), and there is no intercept, so
λ‖W‖² pulls every prediction toward ``hold``. The inner folds are pair-disjoint where the training set holds
at least two actor pairs, else instance-disjoint; the score is the evaluation's (mean key-joint distance per
instance, averaged over instances), and ``hold`` wins ties.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Collection, Mapping, Sequence

import numpy as np

from ..data.dataset import deal_groups
from ..data.interaction import Interaction
from ..errors import ModelError

__all__ = [
    "HOLD", "blend_weights", "cv_errors", "fold_predictions", "inner_folds", "key_columns", "key_error", "ridge_solve",
    "scale_of", "select", "simplex_grid", "stack_instances",
]

HOLD: tuple[str, ...] = ()
"""The candidate without features: ``hold`` (λ = ∞)."""

Candidate = tuple[tuple[str, ...], float]


def stack_instances(
    interactions: Sequence[Interaction], n_observed: int, rows: Callable[[int, Interaction], tuple[np.ndarray, ...]],
    who: str,
) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """The training rows of every instance longer than T0 = ``n_observed`` frames, stacked: ``rows(i, inst)``
    gives arrays of N_i rows each; returns their concatenations (in the order ``rows`` gives them), row weights
    (N,) summing to one per instance, and each row's instance index (N,) into ``interactions``.
    Raises :class:`~socialaff_sim.errors.ModelError` naming ``who`` when no instance is long enough."""
    parts: list[tuple[np.ndarray, ...]] = []
    ws, ids = [], []
    for i, inst in enumerate(interactions):
        if inst.n_frames <= n_observed:
            continue
        arrays = rows(i, inst)
        parts.append(arrays)
        ws.append(np.full(len(arrays[0]), 1.0 / len(arrays[0])))
        ids.append(np.full(len(arrays[0]), i))
    if not parts:
        raise ModelError(f"{who}: expected a training instance longer than T0 = {n_observed} frames, found none")
    return [np.concatenate(col) for col in zip(*parts, strict=True)], np.concatenate(ws), np.concatenate(ids)


def ridge_solve(gram: np.ndarray, cross: np.ndarray, penalty: float) -> np.ndarray:
    """W (F, D) minimising ‖X W − Y‖²_w + λ‖W‖², from gram = XᵀWX (F, F) and cross = XᵀWY (F, D)."""
    F = gram.shape[0]
    return np.linalg.solve(gram + penalty * np.eye(F), cross)


def select(cv: Mapping[Candidate, float]) -> Candidate:
    """The (groups, λ) with the lowest inner-CV error; ``hold`` ``((), inf)`` wins ties, so a regression is
    chosen only where it beat ``hold`` on held-out training instances; among tied regressions, the larger λ,
    then the fewer groups."""
    return min(cv, key=lambda key: (cv[key], key != (HOLD, math.inf), -key[1], len(key[0])))


def key_columns(interaction: Interaction) -> np.ndarray:
    """Target columns (int64, 3 per key joint the layout has) of agent 1's key joints in a (·, J·3) displacement."""
    idx = [i for i in interaction.layout.key_indices if i is not None]
    return (3 * np.asarray(idx, dtype=np.int64)[:, None] + np.arange(3)).reshape(-1)


def key_error(pred: np.ndarray, truth: np.ndarray, ids: np.ndarray) -> float:
    """Mean over instances of the mean key-joint distance, metres (pred/truth (N, 3·k) key columns, ids (N,))."""
    d = np.linalg.norm((pred - truth).reshape(len(pred), -1, 3), axis=-1).mean(axis=1)
    # One run per instance, in np.unique's order, each with its rows in their original order (a stable sort; a
    # no-op for rows stacked by instance): the same means as d[ids == i].mean(), bitwise.
    order = np.argsort(ids, kind="stable")
    sorted_ids = ids[order]
    cuts = np.flatnonzero(sorted_ids[1:] != sorted_ids[:-1]) + 1
    return float(np.mean([run.mean() for run in np.split(d[order], cuts)]))


def scale_of(X: np.ndarray, w: np.ndarray) -> np.ndarray:
    """(F,) weighted RMS of each column of X (N, F) under row weights w (N,); 1 where a column is zero."""
    rms = np.sqrt((w[:, None] * X**2).sum(0) / w.sum())
    return np.where(rms > 1e-12, rms, 1.0)


def inner_folds(
    interactions: Sequence[Interaction], usable: np.ndarray, k: int, rng: np.random.Generator, *, contiguous: bool = False
) -> list[list[int]]:
    """At most ``k`` non-empty folds of the instance indices ``usable``: actor-pair-disjoint with two pairs or
    more, else instance-disjoint — dealt at random, or, with ``contiguous``, as consecutive runs of ``usable`` in
    the order given (for one pair's recording given in time order: held-out blocks of the session, as a block
    split holds them out; neighbouring repetitions of one session resemble each other more than later ones)."""
    pairs: dict[tuple[str, ...], list[int]] = {}
    for i in usable:
        pairs.setdefault(tuple(sorted(interactions[i].actors)), []).append(int(i))
    if contiguous and len(pairs) < 2:
        return [[int(i) for i in run] for run in np.array_split(np.asarray(usable), min(k, len(usable))) if len(run)]
    groups = pairs if len(pairs) >= 2 else {(str(i),): [int(i)] for i in usable}
    return [f for f in deal_groups(groups, min(k, len(groups)), rng) if f]


def cv_errors(
    Xs: np.ndarray,
    Yk: np.ndarray,
    w: np.ndarray,
    ids: np.ndarray,
    folds: Sequence[Sequence[int]],
    candidates: Mapping[tuple[str, ...], np.ndarray],
    penalties: Sequence[float],
    *,
    offset: np.ndarray | None = None,
    from_offset: Collection[tuple[str, ...]] = (),
) -> dict[Candidate, float]:
    """{(name, λ): mean over the folds of the held-out key error} for every candidate column set (name →
    columns of the scaled features Xs (N, F)) and penalty, and ``hold`` under ``((), inf)``. Yk (N, 3·k):
    key-joint targets; w (N,): row weights; ids (N,): each row's instance. A candidate named in
    ``from_offset`` predicts ``offset`` (N, 3·k) plus a ridge fit of the residual Yk − offset (it shrinks
    toward ``offset`` instead of ``hold``); without columns it is ``offset`` itself, reported under λ = ∞."""
    errors: dict[Candidate, list[float]] = {}
    zero = np.zeros_like(Yk)
    for held in folds:
        ho = np.isin(ids, held)
        tr = ~ho
        wt = w[tr] / w[tr].sum()
        x_tr, x_ho, ids_ho = Xs[tr], Xs[ho], ids[ho]  # once per fold (the same arrays every candidate indexed)
        gram = (x_tr * wt[:, None]).T @ x_tr
        truth = Yk[ho]
        errors.setdefault((HOLD, math.inf), []).append(key_error(np.zeros_like(truth), truth, ids_ho))
        crosses: dict[bool, np.ndarray] = {}
        bases: dict[bool, np.ndarray] = {}
        for name, cols in candidates.items():
            shifted = name in from_offset
            base = (offset if shifted and offset is not None else zero)
            if shifted not in bases:
                bases[shifted] = base[ho]
            if len(cols) == 0:
                errors.setdefault((name, math.inf), []).append(key_error(bases[shifted], truth, ids_ho))
                continue
            if shifted not in crosses:
                crosses[shifted] = (x_tr * wt[:, None]).T @ (Yk[tr] - base[tr])
            # One eigendecomposition of the Gram matrix serves every λ: W(λ) = V (Vᵀ cross) / (e + λ).
            evals, V = np.linalg.eigh(gram[np.ix_(cols, cols)])
            vc, xv = V.T @ crosses[shifted][cols], x_ho[:, cols] @ V
            for lam in penalties:
                pred = bases[shifted] + xv @ (vc / (evals + lam)[:, None])
                errors.setdefault((name, float(lam)), []).append(key_error(pred, truth, ids_ho))
    return {key: float(np.mean(v)) for key, v in errors.items()}


def fold_predictions(
    Xs: np.ndarray,
    Yk: np.ndarray,
    w: np.ndarray,
    ids: np.ndarray,
    folds: Sequence[Sequence[int]],
    cols: np.ndarray,
    penalty: float,
    base: np.ndarray,
) -> np.ndarray:
    """(N, 3·k) held-out predictions of one candidate: for each fold, ``base`` plus the ridge fit (columns
    ``cols``, λ = ``penalty``; none when ``cols`` is empty or λ infinite) of Yk − base on the other folds."""
    out = np.array(base, dtype=np.float64, copy=True)
    if len(cols) == 0 or not math.isfinite(penalty):
        return out
    for held in folds:
        ho = np.isin(ids, held)
        tr = ~ho
        wt = w[tr] / w[tr].sum()
        Xt = Xs[tr][:, cols]
        W = ridge_solve((Xt * wt[:, None]).T @ Xt, (Xt * wt[:, None]).T @ (Yk[tr] - base[tr]), penalty)
        out[ho] = base[ho] + Xs[ho][:, cols] @ W
    return out


def simplex_grid(m: int, steps: int) -> np.ndarray:
    """(C, m) every weight vector with entries in {0, 1/steps, …, 1} and sum ≤ 1, the all-zero one first."""
    combos = [c for c in itertools.product(range(steps + 1), repeat=m) if sum(c) <= steps]
    combos.sort(key=lambda c: (sum(c), c))
    return np.asarray(combos, dtype=np.float64) / steps


def blend_weights(preds: np.ndarray, truth: np.ndarray, ids: np.ndarray, steps: int = 10) -> tuple[np.ndarray, float]:
    """The weights α (M,) ≥ 0, Σα ≤ 1 on the grid of :func:`simplex_grid` minimising the key error of
    Σ_m α_m preds[m] (the rest of the weight on ``hold``, zero displacement) against ``truth`` (N, 3·k), with
    ``preds`` (M, N, 3·k) held-out predictions; and that error. Ties go to the smaller total weight (more
    ``hold``), then to the earlier grid entry."""
    grid = simplex_grid(preds.shape[0], steps)
    _, inv = np.unique(ids, return_inverse=True)
    count = np.bincount(inv)
    errors = np.empty(len(grid))
    for lo in range(0, len(grid), 64):
        blend = np.einsum("cm,mnk->cnk", grid[lo:lo + 64], preds)
        d = np.linalg.norm((blend - truth[None]).reshape(blend.shape[0], blend.shape[1], -1, 3), axis=-1).mean(axis=2)
        per = np.stack([np.bincount(inv, weights=row) / count for row in d])
        errors[lo:lo + 64] = per.mean(axis=1)
    best = int(np.argmin(errors))  # first minimum: the grid is ordered by total weight
    return grid[best], float(errors[best])
