"""Parse an observed prefix whose last sub-event is still running (DP over sub-event and end time).

Completed intervals are scored as in learning (spatial + motion potentials at their end,
log-normal duration). The last, open interval has not reached its end, so it is scored only
by the probability that its duration exceeds the time elapsed so far (the log-normal survival
function). Maximizing over parses with :func:`~socialaff_sim.model.segment_dp.segmentation_tables`
gives, for every label s, the best parse whose open interval is labelled s; normalizing those
gives the belief over the current sub-event.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import log_ndtr, logsumexp

from ..model.affordance import AffordanceParameters
from ..model.segment_dp import backtrace, segmentation_tables

__all__ = ["PrefixParse", "parse_prefix", "log_duration_survival"]


@dataclass(frozen=True)
class PrefixParse:
    """The best parse of frames ``[0, t)`` with an open last interval."""

    intervals: np.ndarray
    """(K, 3) int64 rows (start frame, stop frame, label); the last row is the open sub-event (stop = t)."""
    belief: np.ndarray
    """(S,) float64: posterior weight of each label being the current sub-event (max-product, normalized)."""
    score: float
    """Log score of the best parse."""

    @property
    def current(self) -> int:
        """Label of the running sub-event."""
        return int(self.intervals[-1, 2])

    @property
    def start(self) -> int:
        """First frame of the running sub-event."""
        return int(self.intervals[-1, 0])


def log_duration_survival(model: AffordanceParameters, s: int, seconds: np.ndarray) -> np.ndarray:
    """log P(D > seconds) under type ``s``'s log-normal duration; −inf for a type never seen."""
    mu, sigma = model.duration_params_[s]
    secs = np.maximum(np.asarray(seconds, dtype=float), 1e-9)
    if not (np.isfinite(mu) and np.isfinite(sigma)):
        return np.full(secs.shape, -np.inf)
    return log_ndtr(-(np.log(secs) - mu) / sigma)


def parse_prefix(model: AffordanceParameters, track: np.ndarray, fps: float, bounds: np.ndarray) -> PrefixParse:
    """Best parse of the canonical ``track`` (t, 11, 3) over the cut points ``bounds`` (B + 1,), ending at t.

    ``bounds`` starts at 0 and ends at t = len(track); intervals run between consecutive or
    non-consecutive cut points.
    """
    bounds = np.asarray(bounds, dtype=np.int64)
    B = bounds.shape[0] - 1
    S = model.n_subevents_
    a, b = np.triu_indices(B + 1, k=1)
    closed = b < B
    seg = np.full((B + 1, B + 1, S), -np.inf)
    ca, cb = a[closed], b[closed]
    if ca.size:
        feats = model.interval_features(track, bounds[ca], bounds[cb], fps)
        short = (bounds[cb] - bounds[ca]) < model.config.min_subevent_seconds * fps
        for s in range(S):
            seg[ca, cb, s] = np.where(short, -np.inf, model.interval_log_score(feats, s))
    oa = a[~closed]
    elapsed = (bounds[B] - bounds[oa]) / fps
    for s in range(S):
        seg[oa, B, s] = log_duration_survival(model, s, elapsed)
    cfg = model.config
    best, back = segmentation_tables(
        seg,
        model.log_start_probs_,
        model.log_transitions_,
        distinct=cfg.distinct_neighbours and S > 1,
        unique=cfg.unique_labels,
    )
    final = best[B]  # (M, S)
    per_label = final.max(axis=0)
    if not np.isfinite(per_label).any():
        # Nothing is allowed (e.g. every type unseen): one open interval of the most frequent start label.
        s0 = int(np.argmax(model.log_start_probs_))
        belief = np.zeros(S)
        belief[s0] = 1.0
        return PrefixParse(np.array([[0, int(bounds[B]), s0]], dtype=np.int64), belief, -np.inf)
    belief = np.exp(per_label - logsumexp(per_label))
    m, s = divmod(int(np.argmax(final.reshape(-1))), S)
    rows = [(int(bounds[p]), int(bounds[q]), k) for p, q, k in backtrace(back, B, m, s)]
    return PrefixParse(np.array(rows, dtype=np.int64), belief, float(final[m, s]))
