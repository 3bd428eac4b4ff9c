"""The online parse of a stream, with per-frame work and memory bounded independently of its length.

Re-parsing every frame since the start at each re-planning (:func:`~socialaff_sim.inference.online_parse.parse_prefix`
over the whole prefix) costs O(B²) interval scores over B cut points, each reading its interval's
frames, plus an O(B²) dynamic programme: the cost of a re-planning grows with the time elapsed, and
a robot that has reacted for a minute can no longer keep up. :class:`StreamParser` bounds it two ways:

- **A bounded window.** Only the last W to 1.5 W frames are cut into atoms and parsed
  (W = ``SynthesisConfig.parse_window``; the window's start moves in hops of W / 2, so that between
  hops the parse grows at its end only). A window that starts at frame 0 is exactly the unbounded parse;
  one that starts later gives its first interval a uniform label prior (what came before has
  left the window) instead of the model's start probabilities, and its first interval is scored as
  it would be in the whole track (its displacement and path are read from the frame before the
  window).
- **Incremental scores.** A closed interval's score depends only on the frames it spans (and the
  one before), which never change once emitted, so it is computed once, when one of its cut
  points first appears, and kept while its start is inside the window; only the open, last interval
  (its survival term grows with the time elapsed) is scored afresh. Likewise the DP rows of the cut
  points the previous parse already had (same window start, same cuts) are reused: a re-planning
  computes the rows of the last few cuts only.

With a window covering the whole stream the parse equals the unbounded one; :attr:`StreamParser.work`
counts the interval scores computed and the DP cells of the latest parse (what a test can bound).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigError, ModelError
from ..learning.atomic import cut_atoms
from ..model.affordance import AffordanceParameters
from .online_parse import PrefixParse, closed_scores, parse_segments

__all__ = ["ParseWork", "StreamParser"]


@dataclass
class ParseWork:
    """What the latest :meth:`StreamParser.parse` did (counts, not time)."""

    frames: int = 0
    """Frames cut into atoms (the window's length)."""
    cuts: int = 0
    """B + 1: cut points of the window."""
    scored: int = 0
    """Closed intervals newly scored (the rest came from the cache)."""
    cached: int = 0
    """Closed interval scores held after the parse (the cache's size)."""
    dp_rows: int = 0
    """DP rows computed (B minus the rows reused from the previous parse)."""
    dp_cells: int = 0
    """dp_rows · B · M · |S|²: candidate (previous cut, mask, previous label, label) cells evaluated."""
    totals: dict[str, int] = field(default_factory=dict)
    """Running totals of ``frames``, ``scored``, ``dp_rows``, ``dp_cells`` and ``parses`` since :meth:`StreamParser.reset`."""


class StreamParser:
    """Online parses of a growing canonical track, over a bounded window, with cached interval scores."""

    def __init__(
        self, model: AffordanceParameters, fps: float, window: int | None, *, min_frames: int, max_seconds: float, tau: float,
        open_interval: str = "survival",
    ) -> None:
        """``window``: frames parsed at most (None: every frame since the start, as the paper);
        ``min_frames``, ``max_seconds``, ``tau``: the atom settings the model learnt with
        (:func:`~socialaff_sim.learning.atomic.cut_atoms`); ``open_interval``: how the running, last
        interval is scored (:attr:`~socialaff_sim.inference.synthesis_config.SynthesisConfig.open_interval`;
        ``"closed"`` scores it afresh at every parse, since its end moves)."""
        if window is not None and window < 2:
            raise ConfigError(f"parse_window: expected at least 2 frames or None, found {window}")
        self.model = model
        self._min_frames, self._max_seconds, self._tau = int(min_frames), float(max_seconds), float(tau)
        self.fps = float(fps)
        self.window = window
        self.open_interval = open_interval
        self.hop = max(window // 2, 1) if window is not None else 1
        """Frames the window's start moves by."""
        self._scores: dict[tuple[int, int], np.ndarray] = {}
        # The previous parse's window start, cuts and DP tables.
        self._w0 = 0
        self._bounds: np.ndarray | None = None
        self._tables: tuple[np.ndarray, np.ndarray] | None = None
        self.work = ParseWork()
        S = model.n_subevents_
        self._uniform = np.full(S, -np.log(S))

    def reset(self) -> None:
        """Forget every cached score (a new stream, or its history relabelled)."""
        self._scores.clear()
        self._w0, self._bounds, self._tables = 0, None, None
        self.work = ParseWork()

    def parse(self, track: np.ndarray, t: int, available: np.ndarray, *, offset: int = 0) -> tuple[PrefixParse, int]:
        """The parse of frames ``[w0, t)`` of the canonical ``track`` (≥ t frames, 11, 3) and w0.

        Frames before ``t`` must not change between calls (else :meth:`reset`). The parse's rows are
        in absolute frames. ``offset``: the absolute frame of ``track``'s first row (a window of a longer
        track, :class:`~socialaff_sim.inference.track_window.TrackWindow`); the parse reads frames from
        w0 − 1 on (w0 > 0), an error if the window starts later.
        """
        model = self.model
        W = self.window
        # The window's start moves in hops of W / 2, so that between hops its cut points, and the DP rows
        # over them, stay those of the previous parse except near its end.
        w0 = 0 if W is None or t < W + self.hop else ((t - W) // self.hop) * self.hop
        if offset and (w0 == 0 or w0 - 1 < offset):
            raise ModelError(f"StreamParser.parse: frames from {max(w0 - 1, 0)} are read, but the track holds frames "
                             f"from {offset} on")
        track = track[: t - offset]
        x = track[w0 - offset :]
        bounds = cut_atoms(
            x, self.fps, available, model.centroids_, min_frames=self._min_frames, max_seconds=self._max_seconds, tau=self._tau
        )
        B = bounds.shape[0] - 1
        keep = self._reusable_rows(w0, bounds)
        # Closed intervals ending at cuts keep + 1 … B − 1 (the rows before are reused).
        b = np.repeat(np.arange(keep + 1, B), np.arange(keep + 1, B))
        a = np.concatenate([np.arange(k) for k in range(keep + 1, B)]) if B > keep + 1 else np.zeros(0, np.int64)
        starts, stops = bounds[a] + w0, bounds[b] + w0
        keys = list(zip(starts.tolist(), stops.tolist()))
        missing = [k for k, key in enumerate(keys) if key not in self._scores]
        if missing:
            idx = np.asarray(missing, dtype=np.int64)
            new = closed_scores(model, track, self.fps, starts[idx] - offset, stops[idx] - offset)
            for k, row in zip(missing, new):
                self._scores[keys[k]] = row
        S = model.n_subevents_
        seg = np.full((B + 1, B + 1, S), -np.inf)
        if keys:
            seg[a, b] = np.array([self._scores[key] for key in keys])
        if self.open_interval == "closed":  # the running interval scored as if it ended at t (not cached: t moves)
            oa = np.arange(B)
            seg[oa, B] = closed_scores(model, track, self.fps, bounds[oa] + w0 - offset, np.full(B, t - offset))
        if w0 > self._w0:  # what began before the window has left it: evict, keep memory bounded
            for key in [key for key in self._scores if key[0] < w0]:
                del self._scores[key]
        rows = None
        if keep > 0 and self._tables is not None:
            rows = (self._tables[0][: keep + 1], self._tables[1][: keep + 1])
        parse = parse_segments(
            model, seg, bounds, self.fps, log_start=None if w0 == 0 else self._uniform, rows=rows,
            open_interval=self.open_interval,
        )
        self._w0, self._bounds, self._tables = w0, bounds, parse.tables
        w = self.work
        M = parse.tables[1].shape[1] if parse.tables is not None else 1
        w.frames, w.cuts, w.scored, w.cached = t - w0, B + 1, len(missing), len(self._scores)
        w.dp_rows, w.dp_cells = B - keep, (B - keep) * B * M * S * S
        for name in ("frames", "scored", "dp_rows", "dp_cells"):
            w.totals[name] = w.totals.get(name, 0) + getattr(w, name)
        w.totals["parses"] = w.totals.get("parses", 0) + 1
        if w0:
            out = parse.intervals.copy()
            out[:, :2] += w0
            parse = PrefixParse(out, parse.belief, parse.score)
        return parse, w0

    def _reusable_rows(self, w0: int, bounds: np.ndarray) -> int:
        """k: the DP rows 0 … k of the previous parse that hold for ``bounds`` (0: none)."""
        prev = self._bounds
        if prev is None or w0 != self._w0:
            return 0
        n = min(prev.shape[0], bounds.shape[0])
        same = int(np.argmin(prev[:n] == bounds[:n])) if not np.array_equal(prev[:n], bounds[:n]) else n
        # Row b is reusable if cuts 0 … b agree and b was a closed cut before (the old last row held the open interval).
        return max(min(same - 1, prev.shape[0] - 2, bounds.shape[0] - 2), 0)
