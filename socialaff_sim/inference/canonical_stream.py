"""The canonical model joints of a growing view, updated with its new frames only.

Online synthesis reads an instance in the model's canonical frame (:func:`~socialaff_sim.model.joints.canonical_joints`):
the 11 model joints, gaps of each joint filled in time as :meth:`~socialaff_sim.data.interaction.Interaction.filled_joints`
does (linear between two tracked frames, held after the last one and before the first, NaN if never tracked), and
lengthened by held frames as :meth:`~socialaff_sim.data.interaction.Interaction.extend_held` does. Recomputing that
from the whole view at every frame costs O(t) at frame t. :class:`CanonicalStream` gives the same arrays, bitwise,
from the frames new since the last call:

- a tracked frame fills, per joint, the frames since that joint's previous tracked frame (the open gap, held
  until now) by the same linear interpolation, or, for a joint tracked for the first time, every frame before it;
- a joint that is not tracked holds its last tracked position, the object its last position (the held frames);
- agent 0's cumulative wrist paths (:func:`~socialaff_sim.model.handedness.wrist_paths`, what the causal
  active-hand flag reads) are extended from the first changed frame by the same running sum.

The frames that change at a call are the new ones, the held ones and an open gap that closes: bounded work per
frame on average, each gap frame refilled once (a joint first tracked late refills every frame before it, once).

Memory: the world and canonical copies (11 × 3 floats per frame each) and the paths are
:class:`~socialaff_sim.inference.track_window.TrackWindow` s: with ``keep_from`` (:meth:`CanonicalStream.update`) the
frames before it are forgotten, so that a stream of any length holds a bounded window (docs/design.md §7). What the
stream still needs of the frames before the window is kept apart: each joint's last tracked position (the held
frames and the interpolation of a gap that closes start from it) and the pinned frames (:meth:`CanonicalStream.pin`).
A gap of an agent-0 wrist that began before the window and closes refills the frames held (and the pinned ones) only;
the wrist's running sum is carried across the frames before the window by the same interpolation, recomputed in
chunks and not stored, so the paths stay those of the whole track (bitwise).
"""

from __future__ import annotations

import numpy as np

from .._norms import norms
from ..data.interaction import Interaction
from ..data.skeletons import N_KEY
from ..errors import ModelError
from ..model.frame import CanonicalFrame
from ..model.handedness import wrist_paths
from ..model.joints import N_JOINTS, OBJECT
from ..model.nan_fill import nan_to_zero
from .track_window import TrackWindow

__all__ = ["CanonicalStream"]

_WRISTS = (1, 2)  # agent 0's left and right wrists among the model joints (the paths' columns 0 and 1)
_CHUNK = 4096  # frames per step of a running sum carried across the frames before the window


_COLUMNS: dict[tuple[int | None, ...], tuple[np.ndarray, np.ndarray, np.ndarray]] = {}


def _key_columns(key_indices: tuple[int | None, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For a layout's key joints: the model columns a * N_KEY + k (D,), agents a (D,) and the layout's joint indices
    (D,) of the key joints it has, agent by agent in the order of a joint-by-joint copy; made once per layout."""
    cols = _COLUMNS.get(key_indices)
    if cols is None:
        have = [(k, idx) for k, idx in enumerate(key_indices) if idx is not None]
        cols = _COLUMNS[key_indices] = (
            np.array([a * N_KEY + k for k, _ in have for a in range(2)], np.int64),
            np.array([a for _ in have for a in range(2)], np.int64),
            np.array([idx for _, idx in have for _a in range(2)], np.int64),
        )
    return cols


class CanonicalStream:
    """:func:`~socialaff_sim.model.joints.canonical_joints` of ``view.extend_held(n_frames)`` for a view that grows
    call by call (module docstring), in the canonical ``frame`` fixed at the start.

    Calls come in order: each view holds the previous one's frames unchanged (more may follow), and ``n_frames``
    does not decrease (a view whose last frame seen before changed is an error: e.g. a view lengthened by held frames,
    whose held frames later become real).
    """

    def __init__(self, frame: CanonicalFrame) -> None:
        self.frame = frame
        # Filled model joints of the view's frames, metres, world; their canonical values, then the held frames'.
        self._world = TrackWindow((N_JOINTS, 3), name="canonical stream (world)")
        self._canon = TrackWindow((N_JOINTS, 3), name="canonical stream")
        self._paths = TrackWindow((2,), 0.0, name="wrist paths")
        self._last = np.full(N_JOINTS, -1, dtype=np.int64)  # each joint's last tracked frame (−1: none yet)
        self._last_pos = np.full((N_JOINTS, 3), np.nan)  # its world position there (what held frames and gaps start from)
        self._seen = 0  # frames of the views consumed
        self._n = 0  # frames of the track (the view's and the held ones)
        self._carry: dict[int, tuple[int, np.ndarray, np.ndarray]] = {}  # this call's wrist gaps refilled from before the window

    @property
    def n_frames(self) -> int:
        """T: frames of the track (the latest view's, then held ones)."""
        return self._n

    @property
    def seen(self) -> int:
        """Frames of the views consumed so far (the latest view's length)."""
        return self._seen

    @property
    def floor(self) -> int:
        """The first frame held (0 unless ``keep_from`` was given)."""
        return self._canon.floor

    @property
    def track(self) -> TrackWindow:
        """(T, 11, 3) float64, metres, canonical frame: the model joints as recorded, by absolute frame (frames from
        :attr:`floor` held; valid until the next :meth:`update`)."""
        return self._canon

    @property
    def paths(self) -> TrackWindow:
        """(T, 2) float64, metres: agent 0's cumulative left and right wrist paths over :attr:`track`
        (:func:`~socialaff_sim.model.handedness.wrist_paths` of the whole track), by absolute frame."""
        return self._paths

    def pin(self, frame: int) -> None:
        """Keep frame ``frame`` of :attr:`track` (refilled when a gap over it closes) after the window passes it."""
        self._world.pin(frame)
        self._canon.pin(frame)

    def update(self, view: Interaction, n_frames: int | None = None, *, keep_from: int = 0) -> int:
        """Consume the new frames of ``view`` and lengthen the track to ``n_frames`` (default the view's length)
        frames; returns the first frame whose value may have changed (earlier frames are bitwise unchanged; it may
        precede :attr:`floor`). ``keep_from``: frames before it (and before the frames seen) are no longer read."""
        V = view.n_frames
        n = V if n_frames is None else max(int(n_frames), V)
        if V < self._seen or n < self._n:
            raise ModelError(f"canonical stream: the view has {V} frames and asks for {n}, but {self._seen} frames were "
                             f"seen and {self._n} made: views must grow")
        if self._seen and not self._same_tail(view):
            raise ModelError(f"canonical stream: frame {self._seen - 1} of the view differs from the one seen before: views "
                             "must grow (pass the frames known, and the held length as n_frames, not a lengthened view)")
        keep = min(int(keep_from), self._seen)
        for w in (self._world, self._canon, self._paths):
            w.forget(keep)
        self._world.extend(V)
        self._canon.extend(n)
        self._paths.extend(n)
        self._carry = {}
        # From the previous view's end on (its held frames change too), or from the first gap frame refilled.
        changed = self._consume(view, self._seen, V) if V > self._seen else self._seen
        floor = self._canon.floor
        lo = max(changed, floor)
        self._canon[lo:V] = self.frame.to_canonical(self._world[lo:V])
        for p in self._canon.pinned:  # a pinned frame before the window, refilled by a gap that closed
            if changed <= p < floor:
                self._canon[p] = self.frame.to_canonical(self._world[p][None])[0]
        if n > V:  # held frames: each joint at its last tracked position (NaN if never tracked), the object at its last
            # One frame's conversion, broadcast to the held frames: the same values as converting each copy (the
            # rotation is applied frame by frame, each the same (11, 3) @ (3, 3) product; tests/test_reactor_frames.py).
            self._canon[V:n] = self.frame.to_canonical(self._last_pos[None])
        self._seen, self._n = V, n
        self._tail = (view.joints[V - 1].copy(), np.array(view.valid[V - 1]))
        self._update_paths(changed, n)
        return changed

    def _same_tail(self, view: Interaction) -> bool:
        """Whether the last frame consumed is unchanged in ``view`` (a cheap check that views grow)."""
        joints, valid = self._tail
        k = self._seen - 1
        vj, vv = view.joints[k], view.valid[k]
        # The same bytes are equal arrays (NaN to NaN included): the usual case, without array_equal's set-up.
        if vj.tobytes() == joints.tobytes() and np.asarray(vv).tobytes() == valid.tobytes():
            return True
        return bool(np.array_equal(vv, valid) and np.array_equal(vj, joints, equal_nan=True))

    def _consume(self, view: Interaction, start: int, stop: int) -> int:
        """Fill the view's frames [start, stop) and the gaps they close; the first frame changed."""
        dst, agent, src = _key_columns(view.layout.key_indices)
        x = np.full((stop - start, N_JOINTS, 3), np.nan)
        ok = np.zeros((stop - start, N_JOINTS), dtype=bool)
        valid = np.asarray(view.valid)
        if dst.size:  # the key joints of both agents, one gather each (the same values as joint by joint)
            x[:, dst] = view.joints[start:stop][:, agent, src]
            ok[:, dst] = valid[start:stop][:, agent, src]
        if view.object is not None:
            x[:, OBJECT] = view.object[start:stop]
            ok[:, OBJECT] = True
        world = self._world
        floor = world.floor
        if stop - start == 1:  # the stream's usual call: one new frame (the same values, fewer calls)
            seen = ok[0]
            simple = seen & (self._last == start - 1)
            # The frame's row: the simple joints as recorded, every other joint at its last tracked position (the
            # held ones stay so; the gaps that close are interpolated over it below).
            row = np.where(simple[:, None], x[0], self._last_pos)
            world[start:stop] = row[None]
            self._last[simple] = start
            np.copyto(self._last_pos, row)
            closing = seen & ~simple
        else:
            # Tracked in every new frame right after its last tracked one: the values as recorded (np.interp returns
            # a tracked frame's own value).
            simple = ok.all(axis=0) & (self._last == start - 1)
            world[start:stop, simple] = x[:, simple]
            self._last[simple] = stop - 1
            self._last_pos[simple] = world[stop - 1, simple]
            rest = ~simple
            held = rest & ~ok.any(axis=0)  # not tracked in any new frame: held at its last tracked position (NaN if never)
            if held.any():
                world[start:stop, held] = self._last_pos[held]
            closing = rest & ~held
        first = start
        for j in closing.nonzero()[0]:
            tracked = ok[:, j].nonzero()[0]
            last = int(self._last[j])
            lo = last + 1 if last >= 0 else 0  # from the open gap's first frame (or the stream's first)
            xp = np.r_[[last] if last >= 0 else [], start + tracked].astype(np.float64)
            fp = np.concatenate([self._last_pos[j][None] if last >= 0 else np.zeros((0, 3)), x[tracked, j]])
            a = max(lo, floor)  # the frames held of the gap (those before the window are not read again)
            at = np.arange(a, stop)
            for d in range(3):  # as filled_joints: np.interp on the tracked frames bracketing each frame
                world[a:stop, j, d] = np.interp(at, xp, fp[:, d])
            for p in world.pinned:  # a pinned frame before the window, in the gap
                if lo <= p < floor:
                    for d in range(3):
                        world[p, j, d] = np.interp(float(p), xp, fp[:, d])
            if j in _WRISTS and lo <= floor and floor > 0:  # its running sum is carried across frames not held
                self._carry[j] = (last, xp, fp)
            self._last[j] = start + int(tracked[-1])
            self._last_pos[j] = world[int(self._last[j]), j]
            first = min(first, lo)
        return first

    def _update_paths(self, changed: int, n: int) -> None:
        """Agent 0's cumulative wrist paths from frame ``changed`` on (the same running sum as
        :func:`~socialaff_sim.model.handedness.wrist_paths`)."""
        paths, track = self._paths, self._canon
        floor = track.floor
        if changed <= 0 and floor == 0:
            paths[:n] = wrist_paths(track[:n], 0)
            return
        if changed - 1 < floor:  # frames before the window changed: the sums at the window's first frame
            for j, (last, xp, fp) in self._carry.items():
                paths[floor, j - 1] = self._carried(j, last, xp, fp, floor, float(paths[floor, j - 1]))
            changed = floor + 1
        seg = track[changed - 1 : n, 1:3]
        steps = nan_to_zero(norms(seg[1:] - seg[:-1]))  # np.diff's subtraction and np.linalg.norm's values, fewer calls
        paths[changed - 1 : n] = np.cumsum(np.concatenate([paths[changed - 1 : changed], steps]), axis=0)

    def _carried(self, j: int, last: int, xp: np.ndarray, fp: np.ndarray, stop: int, total: float) -> float:
        """Wrist ``j``'s cumulative path at frame ``stop``: ``total`` (its value at frame ``last``, the gap's last
        tracked frame, held since) plus the steps over frames ``last`` … ``stop`` of the gap's interpolation, in the
        canonical frame, summed in order as the whole track's running sum does (work O(gap), memory O(chunk))."""
        prev = None
        k = max(last, 0)
        while k <= stop:
            hi = min(k + _CHUNK, stop + 1)
            at = np.arange(k, hi)
            x = np.zeros((hi - k, N_JOINTS, 3))
            for d in range(3):
                x[:, j, d] = np.interp(at, xp, fp[:, d])
            c = self.frame.to_canonical(x)[:, 1:3]
            if prev is not None:
                c = np.concatenate([prev[None], c])
            steps = np.nan_to_num(np.linalg.norm(np.diff(c, axis=0), axis=-1), nan=0.0)[:, j - 1]
            if steps.size:
                total = float(np.cumsum(np.concatenate([[total], steps]))[-1])
            prev, k = c[-1], hi
        return total
