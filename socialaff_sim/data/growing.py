"""An instance that grows frame by frame, whose views cost no copy: what a live stream or a causal evaluation hands
to a reactor at every frame.

Building a new :class:`~socialaff_sim.data.interaction.Interaction` of frames ``[0, t]`` at every frame copies and
validates all t frames (O(t) at frame t; 70 ms at 18,000 frames). :class:`GrowingInteraction` keeps the frames in
buffers that double when full, validates each frame once when it is appended, and gives out views of the frames so
far: :class:`Interaction` objects whose arrays are read-only NumPy views of the buffers (no copy, no re-validation:
a prefix of frames that were each valid is valid). A frame is written before the first view that holds it is made
and never changes after, so a view's content is fixed; the buffers hold nothing beyond the frames appended.
"""

from __future__ import annotations

import copy

import numpy as np

from ..errors import DataError
from .interaction import MIN_FRAMES, Interaction

__all__ = ["GrowingInteraction", "grown"]


def grown(buffer: np.ndarray, n: int, fill: object = np.nan) -> np.ndarray:
    """``buffer`` (C, …) itself if C ≥ ``n``, else a new buffer of capacity max(n, 2C) holding its rows first and
    ``fill`` after (amortized O(1) work per appended row)."""
    if buffer.shape[0] >= n:
        return buffer
    out = np.full((max(n, 2 * buffer.shape[0]),) + buffer.shape[1:], fill, dtype=buffer.dtype)
    out[: buffer.shape[0]] = buffer
    return out


def _readonly_view(a: np.ndarray, n: int) -> np.ndarray:
    v = a[:n]
    v.setflags(write=False)
    return v


class GrowingInteraction:
    """Frames of one instance appended as they arrive (module docstring).

    ``template``: an instance whose label, frame rate, joint names, actors, sub-event names, source and id the
    stream takes (its frames are not); it has an object track if and only if the template has one. Views carry no
    sub-events.
    """

    def __init__(self, template: Interaction, capacity: int = 64) -> None:
        J = template.joints.shape[2]
        cap = max(int(capacity), MIN_FRAMES)
        self.template = template.slice(0, MIN_FRAMES).replace(subevents=None)
        self._joints = np.full((cap, 2, J, 3), np.nan)
        self._valid = np.zeros((cap, 2, J), dtype=bool)
        self._object = np.full((cap, 3), np.nan) if template.object is not None else None
        self._n = 0

    @property
    def n_frames(self) -> int:
        """Frames appended so far."""
        return self._n

    def append(self, joints: np.ndarray, valid: np.ndarray | None = None, object: np.ndarray | None = None) -> None:  # noqa: A002
        """Append frames: ``joints`` (F, 2, J, 3) metres, world; ``valid`` (F, 2, J) bool (``None``: all valid);
        ``object`` (F, 3) metres (required if and only if the template has an object). Checked as
        :class:`Interaction` checks them; a :class:`~socialaff_sim.errors.DataError` names the field."""
        x = np.asarray(joints, dtype=np.float64)
        shape = (x.shape[0],) + self._joints.shape[1:]
        if x.ndim != 4 or x.shape != shape:
            raise DataError(f"expected shape (F, {', '.join(map(str, shape[1:]))}), found {x.shape}", field="joints")
        ok = np.ones(shape[:3], dtype=bool) if valid is None else np.asarray(valid)
        if ok.shape != shape[:3] or ok.dtype != bool:
            raise DataError(f"expected booleans of shape {shape[:3]}, found {ok.dtype} {ok.shape}", field="valid")
        if (~np.isfinite(x).all(axis=-1) & ok).any():
            raise DataError("non-finite value outside the validity mask; mark it invalid in 'valid'", field="joints")
        obj = None
        if (object is None) != (self._object is None):
            raise DataError(f"expected {'an object track' if self._object is not None else 'no object'}", field="object")
        if object is not None:
            obj = np.asarray(object, dtype=np.float64)
            if obj.shape != (x.shape[0], 3) or not np.isfinite(obj).all():
                raise DataError(f"expected finite values of shape {(x.shape[0], 3)}, found {obj.shape}", field="object")
        self._write(x, ok, obj)

    def append_from(self, source: Interaction, stop: int) -> None:
        """Append frames [n_frames, ``stop``) of ``source`` (a validated instance of the same layout: no check
        again)."""
        sl = slice(self._n, int(stop))
        self._write(source.joints[sl], np.asarray(source.valid)[sl], None if source.object is None else source.object[sl])

    def _write(self, joints: np.ndarray, valid: np.ndarray, obj: np.ndarray | None) -> None:
        n = self._n + joints.shape[0]
        self._joints = grown(self._joints, n, np.nan)
        self._valid = grown(self._valid, n, False)
        self._joints[self._n : n] = joints
        self._valid[self._n : n] = valid
        if self._object is not None:
            self._object = grown(self._object, n, np.nan)
            self._object[self._n : n] = obj
        self._n = n

    def view(self) -> Interaction:
        """The frames appended so far as an :class:`Interaction` of read-only views of the buffers (no copy)."""
        if self._n < MIN_FRAMES:
            raise DataError(f"too short: a view needs at least {MIN_FRAMES} frames, found {self._n}", field="joints")
        out = copy.copy(self.template)  # its fields were validated; the arrays below are valid frame by frame
        object.__setattr__(out, "joints", _readonly_view(self._joints, self._n))
        object.__setattr__(out, "valid", _readonly_view(self._valid, self._n))
        object.__setattr__(out, "object", None if self._object is None else _readonly_view(self._object, self._n))
        return out
