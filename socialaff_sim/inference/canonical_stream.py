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
Memory is the track itself (11 × 3 floats per frame, twice, plus the paths), in buffers that double when full.
"""

from __future__ import annotations

import numpy as np

from ..data.growing import grown
from ..data.interaction import Interaction
from ..data.skeletons import N_KEY
from ..errors import ModelError
from ..model.frame import CanonicalFrame
from ..model.handedness import wrist_paths
from ..model.joints import N_JOINTS, OBJECT

__all__ = ["CanonicalStream"]


class CanonicalStream:
    """:func:`~socialaff_sim.model.joints.canonical_joints` of ``view.extend_held(n_frames)`` for a view that grows
    call by call (module docstring), in the canonical ``frame`` fixed at the start.

    Calls come in order: each view holds the previous one's frames unchanged (more may follow), and ``n_frames``
    does not decrease (a view whose last frame seen before changed is an error: e.g. a view lengthened by held frames,
    whose held frames later become real).
    """

    def __init__(self, frame: CanonicalFrame) -> None:
        self.frame = frame
        self._world = np.full((0, N_JOINTS, 3), np.nan)  # filled model joints of the view's frames, metres, world
        self._canon = np.full((0, N_JOINTS, 3), np.nan)  # their canonical values, then the held frames'
        self._paths = np.zeros((0, 2))
        self._last = np.full(N_JOINTS, -1, dtype=np.int64)  # each joint's last tracked frame (−1: none yet)
        self._seen = 0  # frames of the views consumed
        self._n = 0  # frames of the track (the view's and the held ones)

    @property
    def n_frames(self) -> int:
        """T: frames of the track (the latest view's, then held ones)."""
        return self._n

    @property
    def seen(self) -> int:
        """Frames of the views consumed so far (the latest view's length)."""
        return self._seen

    @property
    def track(self) -> np.ndarray:
        """(T, 11, 3) float64, metres, canonical frame: the model joints as recorded (a view of the buffer: valid
        until the next :meth:`update`)."""
        return self._canon[: self._n]

    @property
    def paths(self) -> np.ndarray:
        """(T, 2) float64, metres: agent 0's cumulative left and right wrist paths over :attr:`track`
        (:func:`~socialaff_sim.model.handedness.wrist_paths`; a view of the buffer)."""
        return self._paths[: self._n]

    def update(self, view: Interaction, n_frames: int | None = None) -> int:
        """Consume the new frames of ``view`` and lengthen the track to ``n_frames`` (default the view's length)
        frames; returns the first frame whose value may have changed (earlier frames are bitwise unchanged)."""
        V = view.n_frames
        n = V if n_frames is None else max(int(n_frames), V)
        if V < self._seen or n < self._n:
            raise ModelError(f"canonical stream: the view has {V} frames and asks for {n}, but {self._seen} frames were "
                             f"seen and {self._n} made: views must grow")
        if self._seen and not self._same_tail(view):
            raise ModelError(f"canonical stream: frame {self._seen - 1} of the view differs from the one seen before: views "
                             "must grow (pass the frames known, and the held length as n_frames, not a lengthened view)")
        self._world = grown(self._world, V)
        self._canon = grown(self._canon, n)
        self._paths = grown(self._paths, n, 0.0)
        # From the previous view's end on (its held frames change too), or from the first gap frame refilled.
        changed = self._consume(view, self._seen, V) if V > self._seen else self._seen
        # Held frames: each joint at its last tracked position (NaN if never tracked), the object at its last.
        held = np.where((self._last >= 0)[:, None], self._world[np.maximum(self._last, 0), np.arange(N_JOINTS)], np.nan)
        self._canon[changed:V] = self.frame.to_canonical(self._world[changed:V])
        if n > V:
            self._canon[V:n] = self.frame.to_canonical(np.broadcast_to(held, (n - V, N_JOINTS, 3)))
        self._seen, self._n = V, n
        self._tail = (view.joints[V - 1].copy(), np.array(view.valid[V - 1]))
        self._update_paths(changed, n)
        return changed

    def _same_tail(self, view: Interaction) -> bool:
        """Whether the last frame consumed is unchanged in ``view`` (a cheap check that views grow)."""
        joints, valid = self._tail
        k = self._seen - 1
        return bool(np.array_equal(view.valid[k], valid) and np.array_equal(view.joints[k], joints, equal_nan=True))

    def _consume(self, view: Interaction, start: int, stop: int) -> int:
        """Fill the view's frames [start, stop) and the gaps they close; the first frame changed."""
        layout = view.layout
        x = np.full((stop - start, N_JOINTS, 3), np.nan)
        ok = np.zeros((stop - start, N_JOINTS), dtype=bool)
        valid = np.asarray(view.valid)
        for k, idx in enumerate(layout.key_indices):
            if idx is not None:
                for a in range(2):
                    x[:, a * N_KEY + k] = view.joints[start:stop, a, idx]
                    ok[:, a * N_KEY + k] = valid[start:stop, a, idx]
        if view.object is not None:
            x[:, OBJECT] = view.object[start:stop]
            ok[:, OBJECT] = True
        # Tracked in every new frame right after its last tracked one: the values as recorded (np.interp returns a
        # tracked frame's own value).
        simple = ok.all(axis=0) & (self._last == start - 1)
        self._world[start:stop, simple] = x[:, simple]
        self._last[simple] = stop - 1
        first = start
        for j in np.flatnonzero(~simple):
            tracked = np.flatnonzero(ok[:, j])
            last = int(self._last[j])
            if not tracked.size:  # held at its last tracked position (NaN if never tracked)
                self._world[start:stop, j] = self._world[last, j] if last >= 0 else np.nan
                continue
            lo = last + 1 if last >= 0 else 0  # from the open gap's first frame (or the stream's first)
            xp = np.r_[[last] if last >= 0 else [], start + tracked].astype(np.float64)
            fp = np.concatenate([self._world[last, j][None] if last >= 0 else np.zeros((0, 3)), x[tracked, j]])
            at = np.arange(lo, stop)
            for d in range(3):  # as filled_joints: np.interp on the tracked frames bracketing each frame
                self._world[lo:stop, j, d] = np.interp(at, xp, fp[:, d])
            self._last[j] = start + int(tracked[-1])
            first = min(first, lo)
        return first

    def _update_paths(self, changed: int, n: int) -> None:
        """Agent 0's cumulative wrist paths from frame ``changed`` on (the same running sum as
        :func:`~socialaff_sim.model.handedness.wrist_paths`)."""
        track = self._canon[:n]
        if changed <= 0:
            self._paths[:n] = wrist_paths(track, 0)
            return
        steps = np.nan_to_num(np.linalg.norm(np.diff(track[changed - 1 :, 1:3], axis=0), axis=-1), nan=0.0)
        self._paths[changed - 1 : n] = np.cumsum(np.concatenate([self._paths[changed - 1 : changed], steps]), axis=0)
