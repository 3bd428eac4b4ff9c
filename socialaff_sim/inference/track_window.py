"""A per-frame array addressed by absolute frame, of which only a trailing window is held.

The causal reactor's tracks (the synthesizer's working track, the canonical stream's world and canonical copies and
agent 0's wrist paths) are read by absolute frame, but on a stream each reader reads only the last few seconds
(docs/design.md §7, "The reactor's memory: a bounded window"). :class:`TrackWindow` keeps frames ``[floor, n)`` of
such an array in a buffer that is compacted (the frames before ``floor`` dropped, the rest moved to its front) when
it is full and at least half of it is forgettable, and else reallocated at twice the frames held: amortized O(1) work
per frame, and a buffer of at most twice the most frames held at once (or the initial capacity). :meth:`TrackWindow.forget` raises the floor; a frame below it is no longer readable
nor writable (a :class:`~socialaff_sim.errors.ModelError` naming the frame and the floor, never a stale value), except
the frames pinned with :meth:`TrackWindow.pin`, whose rows are kept apart when the floor passes them (the planner's
hold frame T0 − 1).

Indexing follows NumPy's on the first axis, in absolute frames: an integer frame (no negative ones), a slice (no
step; a missing start means frame 0, a stop past ``n`` is clipped to ``n``), an integer array, or a tuple whose first
item is one of those (the rest indexes a row as NumPy does). A slice or an array reads the buffer (a view for a
slice); a pinned frame below the floor is read by an integer only.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..errors import ModelError

__all__ = ["TrackWindow"]

_MIN_CAPACITY = 64


class TrackWindow:
    """Frames ``[floor, n)`` of a ``(n, *row_shape)`` float64 array, by absolute frame (module docstring)."""

    def __init__(self, row_shape: tuple[int, ...], fill: float = np.nan, capacity: int = _MIN_CAPACITY, name: str = "track") -> None:
        self.name = name
        self._fill = fill
        self._buf = np.full((max(int(capacity), 1),) + tuple(row_shape), fill)
        self._base = 0  # absolute frame of buffer row 0
        self._n = 0
        self._floor = 0
        self._pins: dict[int, np.ndarray | None] = {}  # frame → its row once the floor passed it (None before)

    @classmethod
    def of(cls, rows: np.ndarray, name: str = "track", fill: float = np.nan) -> TrackWindow:
        """A window holding a copy of ``rows`` (n, …) as frames ``[0, n)``."""
        rows = np.asarray(rows, dtype=np.float64)
        out = cls(rows.shape[1:], fill, max(rows.shape[0], _MIN_CAPACITY), name)
        out._buf[: rows.shape[0]] = rows
        out._n = rows.shape[0]
        return out

    # -- extent ----------------------------------------------------------------------------------
    @property
    def n(self) -> int:
        """Frames of the array (the held ones and those forgotten before them)."""
        return self._n

    @property
    def floor(self) -> int:
        """The first frame held: frames before it (but the pinned ones) are forgotten."""
        return self._floor

    @property
    def shape(self) -> tuple[int, ...]:
        """(n, *row_shape): the array's shape, as if every frame were held."""
        return (self._n,) + self._buf.shape[1:]

    @property
    def capacity(self) -> int:
        """Rows of the buffer."""
        return self._buf.shape[0]

    @property
    def rows(self) -> np.ndarray:
        """(n − floor, *row_shape): the frames held, a view of the buffer (valid until the next :meth:`extend`)."""
        return self._buf[self._floor - self._base : self._n - self._base]

    def __len__(self) -> int:
        return self._n

    def __array__(self, dtype: object = None, copy: object = None) -> np.ndarray:
        if self._floor > 0:
            raise ModelError(f"{self.name}: frames before {self._floor} are forgotten: read the frames held (.rows)")
        return self.rows if dtype is None else self.rows.astype(dtype)

    def copy(self) -> np.ndarray:
        """A copy of the whole array (only while nothing is forgotten)."""
        return np.array(self.__array__())

    def extend(self, n: int) -> None:
        """Make frames ``[0, n)`` addressable (new frames hold the fill value); ``n`` below the current length is a no-op."""
        n = int(n)
        if n <= self._n:
            return
        need = n - self._base
        cap = self._buf.shape[0]
        if need > cap:
            live = self._buf[self._floor - self._base : self._n - self._base]
            size = n - self._floor
            if size <= cap // 2:  # compact in place: the frames held to the front
                self._buf[: live.shape[0]] = live.copy()
                self._buf[live.shape[0] :] = self._fill
            else:  # grow to twice the frames held: the next compaction or growth comes after as many new frames
                buf = np.full((max(2 * size, 8),) + self._buf.shape[1:], self._fill)
                buf[: live.shape[0]] = live
                self._buf = buf
            self._base = self._floor
        self._n = n

    def forget(self, before: int) -> None:
        """Frames before ``before`` are no longer read (the floor never goes down; pinned frames are kept apart)."""
        before = min(int(before), self._n)
        if before <= self._floor:
            return
        for k, row in self._pins.items():
            if row is None and k < before:
                self._pins[k] = self._buf[k - self._base].copy()
        self._floor = before

    def pin(self, frame: int) -> None:
        """Keep frame ``frame`` readable (by an integer index) after the floor passes it."""
        frame = int(frame)
        if frame < self._floor:
            raise ModelError(f"{self.name}: frame {frame} is already forgotten (frames from {self._floor} are held)")
        self._pins.setdefault(frame, None)

    @property
    def pinned(self) -> list[int]:
        """The pinned frames."""
        return sorted(self._pins)

    def map(self, fn: Callable[[np.ndarray], np.ndarray]) -> None:
        """Replace every frame held and every pinned row ``r`` by ``fn(r)`` (row-wise: ``fn`` maps (F, …) to (F, …))."""
        rows = self.rows
        rows[:] = fn(rows)
        for k, row in self._pins.items():
            if row is not None:
                self._pins[k] = fn(row[None])[0]

    # -- indexing --------------------------------------------------------------------------------
    def _first(self, key: object) -> tuple[object, np.ndarray | None]:
        """The first-axis key in buffer rows, or (None, the pinned row) for a pinned frame below the floor."""
        kind = type(key)
        if kind is slice:  # the usual read of a stream: first, without an isinstance chain or min/max calls
            if key.step is not None and key.step != 1:
                raise ModelError(f"{self.name}: slices with a step are not supported")
            a = 0 if key.start is None else int(key.start)
            b = self._n if key.stop is None or key.stop > self._n else int(key.stop)
            if a >= self._floor and b >= 0:
                return slice(a - self._base, (b if b > a else a) - self._base), None
            if a < 0 or b < 0:
                raise ModelError(f"{self.name}: negative frames are not supported (found {a}:{b})")
            if b > a:
                raise ModelError(f"{self.name}: frames {a}:{b} reach before the window (frames from {self._floor} are held)")
            return slice(self._floor - self._base, self._floor - self._base), None
        if kind is int or isinstance(key, (int, np.integer)):
            k = int(key)
            if k < 0 or k >= self._n:
                raise IndexError(f"{self.name}: frame {k} out of range [0, {self._n})")
            if k < self._floor:
                row = self._pins.get(k)
                if row is None:
                    raise ModelError(f"{self.name}: frame {k} is older than the window (frames from {self._floor} are held)")
                return None, row
            return k - self._base, None
        idx = np.asarray(key)
        if idx.dtype.kind not in "iu":
            raise ModelError(f"{self.name}: expected integer frames, found {idx.dtype}")
        if idx.size:
            lo, hi = int(idx.min()), int(idx.max())
            if hi >= self._n or lo < 0:
                raise IndexError(f"{self.name}: frames {lo}…{hi} out of range [0, {self._n})")
            if lo < self._floor:
                raise ModelError(f"{self.name}: frame {lo} is older than the window (frames from {self._floor} are held)")
        return idx - self._base, None

    def _held(self, key: object) -> tuple[object, ...] | None:
        """The buffer key of the usual read or write of a stream, frames [a, b) held with a ≤ b given as ints
        (alone or first in a tuple); None for any other key (:meth:`_first` judges it). The same buffer rows as
        :meth:`_first` gives, without its checks' calls."""
        first = key[0] if type(key) is tuple else key
        if type(first) is not slice or first.step is not None:
            return None
        a, b = first.start, first.stop
        if type(a) is not int or type(b) is not int or not self._floor <= a <= b <= self._n:
            return None
        rows = slice(a - self._base, b - self._base)
        return (rows,) + key[1:] if type(key) is tuple else (rows,)

    def __getitem__(self, key: object) -> np.ndarray:
        fast = self._held(key)
        if fast is not None:
            return self._buf[fast]
        first, rest = (key[0], key[1:]) if isinstance(key, tuple) else (key, ())
        k, row = self._first(first)
        if k is None:
            return row[rest] if rest else row  # type: ignore[index]
        return self._buf[(k,) + rest]

    def __setitem__(self, key: object, value: object) -> None:
        fast = self._held(key)
        if fast is not None:
            self._buf[fast] = value
            return
        first, rest = (key[0], key[1:]) if isinstance(key, tuple) else (key, ())
        k, row = self._first(first)
        if k is None:
            if rest:
                row[rest] = value  # type: ignore[index]
            else:
                row[...] = value  # type: ignore[index]
            return
        self._buf[(k,) + rest] = value
