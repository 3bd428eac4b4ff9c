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

__all__ = ["PrefixParse", "parse_prefix", "closed_scores", "parse_segments", "log_duration_survival"]


@dataclass(frozen=True)
class PrefixParse:
    """The best parse of frames ``[0, t)`` with an open last interval."""

    intervals: np.ndarray
    """(K, 3) int64 rows (start frame, stop frame, label); the last row is the open sub-event (stop = t)."""
    belief: np.ndarray
    """(S,) float64: posterior weight of each label being the current sub-event (max-product, normalized)."""
    score: float
    """Log score of the best parse."""
    tables: tuple[np.ndarray, np.ndarray] | None = None
    """The DP tables ``(best, back)`` (:func:`~socialaff_sim.model.segment_dp.segmentation_tables`), for reuse."""

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


def closed_scores(model: AffordanceParameters, track: np.ndarray, fps: float, starts: np.ndarray, stops: np.ndarray) -> np.ndarray:
    """(M, S) log scores of M closed intervals ``[starts, stops)`` (frames of ``track``) under every type:
    spatial + motion potentials at their end, log-normal duration (and path noise); −inf for an
    interval shorter than ``config.min_subevent_seconds``. An interval's score reads only frames
    ``starts − 1`` to ``stops − 1`` of ``track``."""
    starts = np.asarray(starts, dtype=np.int64)
    stops = np.asarray(stops, dtype=np.int64)
    S = model.n_subevents_
    out = np.full((starts.shape[0], S), -np.inf)
    if starts.size:
        feats = model.interval_features(track, starts, stops, fps)
        short = (stops - starts) < model.config.min_subevent_seconds * fps
        for s in range(S):
            out[:, s] = np.where(short, -np.inf, model.interval_log_score(feats, s))
    return out


def parse_prefix(
    model: AffordanceParameters,
    track: np.ndarray,
    fps: float,
    bounds: np.ndarray,
    open_interval: str = "survival",
) -> PrefixParse:
    """Best parse of the canonical ``track`` (t, 11, 3) over the cut points ``bounds`` (B + 1,), ending at t.

    ``bounds`` starts at 0 and ends at t = len(track); intervals run between consecutive or
    non-consecutive cut points. ``open_interval``: ``"survival"`` scores the last interval by its
    duration's survival function, ``"closed"`` like the others
    (:attr:`~socialaff_sim.inference.synthesis_config.SynthesisConfig.open_interval`).
    """
    bounds = np.asarray(bounds, dtype=np.int64)
    B = bounds.shape[0] - 1
    a, b = np.triu_indices(B + 1, k=1)
    if open_interval == "survival":
        a, b = a[b < B], b[b < B]
    seg = np.full((B + 1, B + 1, model.n_subevents_), -np.inf)
    seg[a, b] = closed_scores(model, track, fps, bounds[a], bounds[b])
    return parse_segments(model, seg, bounds, fps, open_interval=open_interval)


def parse_segments(
    model: AffordanceParameters,
    seg: np.ndarray,
    bounds: np.ndarray,
    fps: float,
    *,
    log_start: np.ndarray | None = None,
    rows: tuple[np.ndarray, np.ndarray] | None = None,
    open_interval: str = "survival",
) -> PrefixParse:
    """:func:`parse_prefix` from the closed intervals' scores ``seg`` (B + 1, B + 1, S) (entry [a, b] for
    cuts a < b < B; the open column b = B is filled here, in place). ``log_start``: (S,) log prior of
    the first interval's label (default: the model's start probabilities). ``rows``: DP rows reused
    from an earlier parse (:func:`~socialaff_sim.model.segment_dp.segmentation_tables`); the result's
    ``tables`` can be passed on the same way. ``open_interval="closed"``: the open column is the caller's
    (the last interval scored like the closed ones, as in the paper's DP) and is left as given."""
    bounds = np.asarray(bounds, dtype=np.int64)
    B = bounds.shape[0] - 1
    S = model.n_subevents_
    if open_interval == "survival":
        oa = np.arange(B)
        elapsed = (bounds[B] - bounds[oa]) / fps
        for s in range(S):
            seg[oa, B, s] = log_duration_survival(model, s, elapsed)
    cfg = model.config
    best, back = segmentation_tables(
        seg,
        model.log_start_probs_ if log_start is None else log_start,
        model.log_transitions_,
        distinct=cfg.distinct_neighbours and S > 1,
        unique=cfg.unique_labels,
        rows=rows,
    )
    final = best[B]  # (M, S)
    per_label = final.max(axis=0)
    if not np.isfinite(per_label).any():
        # Nothing is allowed (e.g. every type unseen): one open interval of the most frequent start label.
        s0 = int(np.argmax(model.log_start_probs_))
        belief = np.zeros(S)
        belief[s0] = 1.0
        return PrefixParse(np.array([[0, int(bounds[B]), s0]], dtype=np.int64), belief, -np.inf, (best, back))
    belief = np.exp(per_label - logsumexp(per_label))
    m, s = divmod(int(np.argmax(final.reshape(-1))), S)
    out = [(int(bounds[p]), int(bounds[q]), k) for p, q, k in backtrace(back, B, m, s)]
    return PrefixParse(np.array(out, dtype=np.int64), belief, float(final[m, s]), (best, back))
