"""The online synthesizer's working track, held in a bounded window (issue 24; docs/design.md §7).

The working track is the canonical track the synthesizer plans on: agent 0's key joints and the object as recorded
(:class:`~socialaff_sim.inference.canonical_stream.CanonicalStream`), relabelled by the active-hand flags, and agent
1's key joints, observed for the first T0 frames and planned after. Under a causal configuration only its last
:func:`reader_window` frames before the next frame are held (:class:`~socialaff_sim.inference.track_window.TrackWindow`),
and the hold frame T0 − 1 is pinned apart.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..data.skeletons import N_KEY
from ..model.handedness import relabel
from .track_window import TrackWindow

if TYPE_CHECKING:
    from .canonical_stream import CanonicalStream
    from .forward_belief import ForwardBelief
    from .stream_parse import StreamParser
    from .synthesis_config import SynthesisConfig

__all__ = ["OTHERS", "WorkingTrack", "reader_window"]

OTHERS = np.r_[np.arange(N_KEY), 2 * N_KEY]
"""Agent 0's key joints and the object among the 11 model joints: what the recording gives."""


def reader_window(config: SynthesisConfig, belief: ForwardBelief | None, parser: StreamParser | None) -> int | None:
    """L: the frames before frame t that any reader may still read at t, or None (every frame: with ``lookahead``,
    the observed parse, or an unbounded online parse, which read agent 0's whole track).

    The forward belief's cuts read their intervals back to a horizon H and a stride s before t, and the frame before
    each start; after a history change it replays from frame 0 while t <= 2 H, else from H + s back at most: L =
    2 H + 2 s + 2. The windowed parse (W frames, hops of W / 2) reads from its start w0 − 1 >= t − W − hop: L = W +
    2 hop + 2. The planner reads its running sub-event's start − 1 (a start of the same belief or parse) and t − 1."""
    if config.lookahead or config.parse != "online":
        return None
    if belief is not None:
        return 2 * belief.horizon + 2 * belief.stride + 2
    if parser is not None and parser.window is not None:
        return parser.window + 2 * parser.hop + 2
    return None


def _relabelled_others(hands: np.ndarray) -> np.ndarray:
    """(6,) the model joints that ``relabel(x, hands)[..., OTHERS, :]`` reads of x, in its order: made once per flags."""
    key = (bool(hands[0]), bool(hands[1]))
    cols = _OTHERS_BY_HANDS.get(key)
    if cols is None:
        order = relabel(np.arange(2 * N_KEY + 1)[:, None], np.array(key))[:, 0]  # where relabel takes each joint from
        cols = _OTHERS_BY_HANDS[key] = order[OTHERS]
    return cols


_OTHERS_BY_HANDS: dict[tuple[bool, bool], np.ndarray] = {}


class WorkingTrack(TrackWindow):
    """(T, 11, 3) float64, metres, canonical: the synthesizer's working track by absolute frame (module docstring)."""

    def take(self, stream: CanonicalStream, changed: int, n: int, hands: np.ndarray, emitted: int) -> bool:
        """Lengthen to ``n`` frames and copy agent 0's and the object's frames from ``changed`` (the stream's first
        changed frame) to ``n`` out of ``stream``, relabelled by ``hands``: the frames held, and the pinned ones among
        those before the window (the others are read no more). Returns whether a frame before ``emitted`` changed
        (the parse's and the belief's history), judged on those frames."""
        old = self.n
        lo = max(changed, self.floor)
        cols = _relabelled_others(hands)  # relabel(x, hands)[..., OTHERS, :] as one gather (the same values)
        new = stream.track[lo:n][:, cols]
        pins = [(p, stream.track[p][cols]) for p in self.pinned if changed <= p < lo]
        seen = min(emitted, old, n)
        history = lo < seen and not np.array_equal(self[lo:seen, OTHERS], new[: seen - lo], equal_nan=True)
        history = history or any(p < seen and not np.array_equal(self[p, OTHERS], row, equal_nan=True) for p, row in pins)
        self.extend(max(n, old))
        self[lo:n, OTHERS] = new
        for p, row in pins:
            self[p, OTHERS] = row
        return history
