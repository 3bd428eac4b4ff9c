"""Start and transition frequencies of sub-event labels, with add-α smoothing.

p(s_1 = s) = (n_s + α) / (N + α |S|) and p(s_k = s′ | s_{k−1} = s) = (n_ss′ + α) / (n_s + α m),
where m is the number of allowed successors: |S| − 1 when consecutive labels must differ
(the diagonal is then 0), else |S|. With α = 0 an unseen row is uniform over the allowed successors.

:func:`order_ranks`: each type's mean position in the parses (0 for the first interval), the learned order of
the sub-events that ``SynthesisConfig.ordered`` makes the causal plan follow.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["count_transitions", "order_ranks", "smoothed_probs", "transition_loglik"]


def count_transitions(spans: Sequence[Sequence[tuple[int, int, int]]], S: int) -> tuple[np.ndarray, np.ndarray]:
    """Start counts (S,) and transition counts (S, S) of parses given as rows (start, stop, label)."""
    start = np.zeros(S)
    trans = np.zeros((S, S))
    for sp in spans:
        labs = [int(s) for _, _, s in sp]
        if labs:
            start[labs[0]] += 1
        for a, b in zip(labs, labs[1:]):
            trans[a, b] += 1
    return start, trans


def smoothed_probs(
    start: np.ndarray, trans: np.ndarray, alpha: float, distinct: bool, learn_start: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """Smoothed start (S,) and transition (S, S) probabilities from counts; ``learn_start=False``:
    p(s_1) uniform, 1 / |S| (:attr:`~socialaff_sim.model.config.AffordanceConfig.start_prior`)."""
    S = start.shape[0]
    allowed = ~np.eye(S, dtype=bool) if (distinct and S > 1) else np.ones((S, S), dtype=bool)
    num = np.where(allowed, trans + alpha, 0.0)
    rows = num.sum(axis=1, keepdims=True)
    uniform = allowed / allowed.sum(axis=1, keepdims=True)
    p_trans = np.where(rows > 0, num / np.where(rows > 0, rows, 1.0), uniform)
    total = start.sum() + alpha * S
    p_start = (start + alpha) / total if (total > 0 and learn_start) else np.full(S, 1.0 / S)
    return p_start, p_trans


def transition_loglik(
    start: np.ndarray, trans: np.ndarray, alpha: float, distinct: bool, learn_start: bool = True
) -> float:
    """Σ n log p of the counts under their own smoothed frequencies (with ``learn_start=False`` the start
    term is Σ n log(1 / |S|), a constant of the parses)."""
    p_start, p_trans = smoothed_probs(start, trans, alpha, distinct, learn_start)
    ll = (start * np.log(np.where(start > 0, p_start, 1.0))).sum()
    ll += (trans * np.log(np.where(trans > 0, p_trans, 1.0))).sum()
    return float(ll)


def order_ranks(spans: Sequence[Sequence[tuple[int, int, int]]], S: int) -> np.ndarray:
    """(S,) mean position of each type's intervals in parses given as rows (start, stop, label), in time order (0:
    the first interval of its parse); NaN for a type no parse uses."""
    total = np.zeros(S)
    count = np.zeros(S)
    for sp in spans:
        for k, (_, _, s) in enumerate(sorted(sp, key=lambda row: row[0])):
            total[int(s)] += k
            count[int(s)] += 1
    return np.where(count > 0, total / np.where(count > 0, count, 1.0), np.nan)
