"""The online parse of a stream, with per-frame work and memory bounded independently of its length.

Re-parsing every frame since the start at each re-planning (:func:`~socialaff_sim.inference.online_parse.parse_prefix`
over the whole prefix) costs O(B²) interval scores over B cut points, each reading its interval's
frames, plus an O(B²) dynamic programme: the cost of a re-planning grows with the time elapsed, and
a robot that has reacted for a minute can no longer keep up. :class:`StreamParser` bounds it two ways:

- **A bounded window.** Only the last ``window`` frames are cut into atoms and parsed
  (``SynthesisConfig.parse_window``). A window that starts at frame 0 is exactly today's parse;
  one that starts later gives its first interval a uniform label prior (what came before has
  left the window) instead of the model's start probabilities, and its first interval is scored as
  it would be in the whole track (its displacement and path are read from the frame before the
  window).
- **Incremental scores.** A closed interval's score depends only on the frames it spans (and the
  one before), which never change once emitted, so it is computed once, when one of its cut
  points first appears, and kept while its start is inside the window; only the open, last interval
  (its survival term grows with the time elapsed) is scored afresh.

With a window covering the whole stream the parse equals the unbounded one; :attr:`StreamParser.work`
counts the interval scores computed and the DP cells of the latest parse (what a test can bound).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigError
from ..learning.atomic import cut_atoms
from ..model.affordance import AffordanceParameters
from .online_parse import PrefixParse, closed_scores, parse_prefix

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
    dp_cells: int = 0
    """(B + 1)² · |S|: cells of the DP's score table."""
    totals: dict[str, int] = field(default_factory=dict)
    """Running totals of ``frames``, ``scored`` and ``dp_cells`` since :meth:`StreamParser.reset`."""


class StreamParser:
    """Online parses of a growing canonical track, over a bounded window, with cached interval scores."""

    def __init__(
        self, model: AffordanceParameters, fps: float, window: int | None, *, min_frames: int, max_seconds: float, tau: float
    ) -> None:
        """``window``: frames parsed at most (None: every frame since the start, as the paper);
        ``min_frames``, ``max_seconds``, ``tau``: the atom settings the model learnt with
        (:func:`~socialaff_sim.learning.atomic.cut_atoms`)."""
        if window is not None and window < 2:
            raise ConfigError(f"parse_window: expected at least 2 frames or None, found {window}")
        self.model = model
        self._min_frames, self._max_seconds, self._tau = int(min_frames), float(max_seconds), float(tau)
        self.fps = float(fps)
        self.window = window
        self._scores: dict[tuple[int, int], np.ndarray] = {}
        self.work = ParseWork()
        S = model.n_subevents_
        self._uniform = np.full(S, -np.log(S))

    def reset(self) -> None:
        """Forget every cached score (a new stream, or its history relabelled)."""
        self._scores.clear()
        self.work = ParseWork()

    def parse(self, track: np.ndarray, t: int, available: np.ndarray) -> tuple[PrefixParse, int]:
        """The parse of frames ``[w0, t)`` of the canonical ``track`` (≥ t frames, 11, 3) and w0.

        Frames before ``t`` must not change between calls (else :meth:`reset`). The parse's rows are
        in absolute frames.
        """
        model = self.model
        w0 = 0 if self.window is None or t <= self.window else t - self.window
        x = track[w0:t]
        bounds = cut_atoms(
            x, self.fps, available, model.centroids_, min_frames=self._min_frames, max_seconds=self._max_seconds, tau=self._tau
        )
        B = bounds.shape[0] - 1
        a, b = np.triu_indices(B + 1, k=1)
        closed = b < B
        starts, stops = bounds[a[closed]] + w0, bounds[b[closed]] + w0
        keys = list(zip(starts.tolist(), stops.tolist()))
        missing = [k for k, key in enumerate(keys) if key not in self._scores]
        if missing:
            idx = np.asarray(missing, dtype=np.int64)
            new = closed_scores(model, track[:t], self.fps, starts[idx], stops[idx])
            for k, row in zip(missing, new):
                self._scores[keys[k]] = row
        S = model.n_subevents_
        table = np.array([self._scores[key] for key in keys]).reshape(len(keys), S)
        if w0 > 0:  # what began before the window has left it: evict, keep memory bounded
            for key in [key for key in self._scores if key[0] < w0]:
                del self._scores[key]
        parse = parse_prefix(model, x, self.fps, bounds, closed=table, log_start=None if w0 == 0 else self._uniform)
        w = self.work
        w.frames, w.cuts, w.scored, w.cached, w.dp_cells = t - w0, B + 1, len(missing), len(self._scores), (B + 1) ** 2 * S
        for name, v in (("frames", w.frames), ("scored", w.scored), ("dp_cells", w.dp_cells), ("parses", 1)):
            w.totals[name] = w.totals.get(name, 0) + v
        if w0:
            rows = parse.intervals.copy()
            rows[:, :2] += w0
            parse = PrefixParse(rows, parse.belief, parse.score)
        return parse, w0
