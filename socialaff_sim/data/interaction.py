"""The interaction instance: two skeletons over time, an optional object, a label."""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from ..errors import DataError
from .names import stem_problem
from .skeletons import N_KEY, SkeletonLayout, layout_for_joint_names

__all__ = ["Interaction", "MIN_FRAMES", "LABEL_PATTERN", "fill_gaps", "fill_key_joints"]

MIN_FRAMES = 3
"""Fewest frames an instance may have: the model needs at least two displacements."""

LABEL_PATTERN = re.compile(r"^[a-z][a-z0-9_]*$")
"""Interaction and sub-event labels are snake_case identifiers."""


def _real_array(value: object, field: str, err: Callable[[str, str], DataError]) -> np.ndarray:
    """A float64 copy of a real-valued array; strings, complex numbers and objects are an error
    (NumPy would parse numeric strings and drop imaginary parts silently)."""
    arr = np.asarray(value)
    if arr.dtype.kind not in "fiub":
        raise err(field, f"expected real numbers, found dtype {arr.dtype}")
    return np.array(arr, dtype=np.float64, copy=True)


def fill_gaps(joints: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """(T, 2, J, 3) float64, metres: a copy of ``joints`` (T, 2, J, 3) metres with each (agent, joint)'s invalid
    frames (``valid`` (T, 2, J) False) linearly interpolated in time between its valid ones (held before the first
    and after the last); NaN where a joint is never valid."""
    out = np.array(joints, dtype=np.float64, copy=True)
    if valid.all():
        return out
    t = np.arange(out.shape[0])
    for a, j in zip(*np.nonzero(~valid.all(axis=0)), strict=True):
        ok = valid[:, a, j]
        if not ok.any():
            out[:, a, j] = np.nan
            continue
        for d in range(3):
            out[:, a, j, d] = np.interp(t, t[ok], out[ok, a, j, d])
    return out


def fill_key_joints(joints: np.ndarray, valid: np.ndarray, key_indices: tuple[int | None, ...]) -> np.ndarray:
    """(T, 2, 5, 3) float64, metres: the key joints ``key_indices`` (5 joint indices or ``None``) of ``joints``
    (T, 2, J, 3) metres, gaps filled by :func:`fill_gaps` (``valid`` (T, 2, J)), NaN where never valid or absent:
    what :meth:`Interaction.filled_joints` gives for those columns (each joint is filled from its own frames only)."""
    present = np.array([i is not None for i in key_indices])
    cols = [0 if i is None else i for i in key_indices]
    return fill_gaps(joints[:, :, cols], valid[:, :, cols] & present)  # an absent joint: never valid, so NaN


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Interaction:
    """One recorded two-agent interaction.

    Agent 0 is the observed human; agent 1 is the agent the robot will play.
    Arrays are converted to read-only float64/bool/int64 copies on construction
    and validated; a :class:`~socialaff_sim.errors.DataError` names the field.
    """

    label: str
    """Interaction class c, snake_case (e.g. ``"shake_hands"``)."""
    fps: float
    """Frame rate, frames per second (> 0)."""
    joints: np.ndarray
    """(T, 2, J, 3) float64, metres, one world frame, z up."""
    joint_names: tuple[str, ...]
    """J joint names; must match a layout in :data:`~socialaff_sim.data.skeletons.LAYOUTS`."""
    actors: tuple[str, str]
    """Actor ids of agent 0 and agent 1 (for pair- and actor-disjoint folds, :mod:`socialaff_sim.evaluation.splits`)."""
    object: np.ndarray | None = None
    """(T, 3) float64, metres: the object's track, or ``None``."""
    valid: np.ndarray | None = None
    """(T, 2, J) bool: False where a joint was not tracked; ``None`` means all valid."""
    subevents: np.ndarray | None = None
    """(T,) int64 ground-truth sub-event per frame, index into :attr:`subevent_names`; -1 unlabelled."""
    subevent_names: tuple[str, ...] = ()
    """Names of the ground-truth sub-events."""
    source: str = ""
    """Where the instance came from (file path or generator spec)."""
    instance_id: str = ""
    """Identifier unique within its dataset (used as file stem)."""

    def __post_init__(self) -> None:
        self._validate()

    # -- validation -----------------------------------------------------------------
    def _err(self, field: str, message: str) -> DataError:
        return DataError(message, path=self.source or self.instance_id or None, field=field)

    def _validate(self) -> None:
        set_ = object.__setattr__
        if not isinstance(self.label, str) or not LABEL_PATTERN.match(self.label):
            raise self._err("label", f"expected a snake_case name like 'shake_hands', found {self.label!r}")
        try:
            fps = float(self.fps)
        except (TypeError, ValueError):
            raise self._err("fps", f"expected a number > 0, found {self.fps!r}") from None
        if not np.isfinite(fps) or fps <= 0:
            raise self._err("fps", f"expected a finite number > 0, found {fps}")
        set_(self, "fps", fps)

        if self.instance_id:
            problem = stem_problem(self.instance_id)
            if problem is not None:
                raise self._err("instance_id", f"{problem} (ids become file names)")
        names = tuple(str(n) for n in self.joint_names)
        set_(self, "joint_names", names)
        joints = _real_array(self.joints, "joints", self._err)
        if joints.ndim != 4 or joints.shape[1] != 2 or joints.shape[3] != 3:
            raise self._err("joints", f"expected shape (T, 2, J, 3), found {joints.shape}")
        T, _, J, _ = joints.shape
        if T == 0:
            raise self._err("joints", "empty sequence: expected at least one frame, found T = 0")
        if T < MIN_FRAMES:
            raise self._err("joints", f"too short: the method needs at least {MIN_FRAMES} frames, found {T}")
        if J != len(names):
            raise self._err("joint_names", f"expected {J} names (joints has J = {J}), found {len(names)}")
        try:
            layout_for_joint_names(names)
        except DataError as exc:
            raise self._err("joint_names", str(exc)) from None

        if self.valid is None:
            valid = np.ones((T, 2, J), dtype=bool)
        else:
            valid = np.array(self.valid, copy=True)
            if valid.shape != (T, 2, J):
                raise self._err("valid", f"expected shape {(T, 2, J)}, found {valid.shape}")
            if valid.dtype.kind not in "biu" or (valid.dtype.kind != "b" and not np.isin(valid, (0, 1)).all()):
                raise self._err("valid", f"expected booleans (or 0/1), found dtype {valid.dtype}")
            valid = valid.astype(bool)
        bad = ~np.isfinite(joints).all(axis=-1) & valid
        if bad.any():
            t, a, j = np.argwhere(bad)[0]
            raise self._err(
                "joints",
                f"non-finite value at frame {t}, agent {a}, joint {names[j]!r} "
                f"({int(bad.sum())} in all) outside the validity mask; mark them invalid in 'valid'",
            )
        set_(self, "joints", _readonly(joints))
        set_(self, "valid", _readonly(valid))

        if self.object is not None:
            obj = _real_array(self.object, "object", self._err)
            if obj.shape != (T, 3):
                raise self._err("object", f"expected shape {(T, 3)}, found {obj.shape}")
            if not np.isfinite(obj).all():
                raise self._err("object", "expected finite values, found NaN or inf")
            set_(self, "object", _readonly(obj))

        actors = tuple(str(a) for a in self.actors)
        if len(actors) != 2 or not all(actors):
            raise self._err("actors", f"expected two non-empty actor ids, found {self.actors!r}")
        set_(self, "actors", actors)

        sub_names = tuple(str(n) for n in self.subevent_names)
        bad = [n for n in sub_names if not LABEL_PATTERN.match(n)]
        if bad:
            raise self._err("subevent_names", f"expected snake_case names like 'approach', found {bad[0]!r}")
        if len(set(sub_names)) != len(sub_names):
            raise self._err("subevent_names", f"expected distinct names, found {list(sub_names)}")
        set_(self, "subevent_names", sub_names)
        if self.subevents is not None:
            sub = np.asarray(self.subevents)
            if sub.shape != (T,):
                raise self._err("subevents", f"expected shape {(T,)}, found {sub.shape}")
            if sub.size and not np.issubdtype(sub.dtype, np.integer):
                raise self._err("subevents", f"expected integers, found dtype {sub.dtype}")
            sub = sub.astype(np.int64)
            if sub.size and (sub.min() < -1 or sub.max() >= len(sub_names)):
                raise self._err(
                    "subevents",
                    f"expected values in [-1, {len(sub_names) - 1}] (indices into subevent_names), "
                    f"found [{sub.min()}, {sub.max()}]",
                )
            set_(self, "subevents", _readonly(sub.copy()))

    # -- derived views --------------------------------------------------------------------
    @property
    def _valid_mask(self) -> np.ndarray:
        # __post_init__ always replaces None by an all-True mask.
        return cast(np.ndarray, self.valid)

    @property
    def layout(self) -> SkeletonLayout:
        """The skeleton layout of :attr:`joint_names`."""
        return layout_for_joint_names(self.joint_names)

    @property
    def n_frames(self) -> int:
        """Number of frames T."""
        return int(self.joints.shape[0])

    @property
    def duration(self) -> float:
        """Length in seconds."""
        return self.n_frames / self.fps

    @property
    def has_object(self) -> bool:
        """Whether an object track is present."""
        return self.object is not None

    def filled_joints(self) -> np.ndarray:
        """(T, 2, J, 3) float64, metres: joints with invalid entries linearly interpolated in time.

        A joint never valid in the whole instance stays NaN.
        """
        return fill_gaps(self.joints, self._valid_mask)

    def key_joints(self) -> np.ndarray:
        """(T, 2, 5, 3) float64, metres: the five key joints per agent (filled); NaN where the layout lacks one.

        The key columns of :meth:`filled_joints`, filled alone (each joint is interpolated from its own frames
        only, so this is bitwise those columns, without filling the other joints)."""
        return fill_key_joints(self.joints, self._valid_mask, self.layout.key_indices)

    def key_available(self) -> np.ndarray:
        """(5,) bool: which of :data:`KEY_JOINTS` this instance's layout provides."""
        return self.layout.key_available

    def key_valid(self) -> np.ndarray:
        """(T, 2, 5) bool: key joints actually tracked in each frame (before filling)."""
        out = np.zeros((self.n_frames, 2, N_KEY), dtype=bool)
        for k, idx in enumerate(self.layout.key_indices):
            if idx is not None:
                out[:, :, k] = self._valid_mask[:, :, idx]
        return out

    def slice(self, start: int, stop: int) -> Interaction:
        """Frames ``start:stop`` as a new instance."""
        sl = slice(start, stop)
        return self.replace(
            joints=self.joints[sl],
            valid=None if self.valid is None else self.valid[sl],
            object=None if self.object is None else self.object[sl],
            subevents=None if self.subevents is None else self.subevents[sl],
        )

    def hide_agent_after(self, agent: int, n: int) -> Interaction:
        """A copy with ``agent``'s frames from ``n`` on unknown (NaN, invalid); :meth:`filled_joints`
        then holds its frame n − 1."""
        joints = self.joints.copy()
        valid = np.array(self._valid_mask, copy=True)
        joints[n:, agent] = np.nan
        valid[n:, agent] = False
        return self.replace(joints=joints, valid=valid)

    def extend_held(self, n_frames: int) -> Interaction:
        """A copy lengthened to ``n_frames`` frames whose new frames carry no information: both agents'
        joints unknown (NaN, invalid, so :meth:`filled_joints` holds each joint's last valid frame), the
        object held at its last frame, sub-events unlabelled. ``n_frames`` ≤ T returns the instance itself.

        The evaluation uses it to ask a method for frames beyond what it may see (see
        :mod:`socialaff_sim.evaluation.protocol`)."""
        T = self.n_frames
        extra = int(n_frames) - T
        if extra <= 0:
            return self
        J = self.joints.shape[2]
        joints = np.concatenate([self.joints, np.full((extra, 2, J, 3), np.nan)])
        valid = np.concatenate([self._valid_mask, np.zeros((extra, 2, J), dtype=bool)])
        obj = None if self.object is None else np.concatenate([self.object, np.repeat(self.object[-1:], extra, axis=0)])
        sub = None if self.subevents is None else np.concatenate([self.subevents, np.full(extra, -1, dtype=np.int64)])
        return self.replace(joints=joints, valid=valid, object=obj, subevents=sub)

    def replace(self, **changes: Any) -> Interaction:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def same_as(self, other: Interaction, *, atol: float = 0.0) -> bool:
        """Whether two instances hold the same data (arrays equal within ``atol``)."""

        def arr_eq(a: np.ndarray | None, b: np.ndarray | None) -> bool:
            if a is None or b is None:
                return a is None and b is None
            if a.shape != b.shape:
                return False
            if a.dtype.kind == "f":
                return bool(np.allclose(a, b, atol=atol, rtol=0.0, equal_nan=True))
            return bool(np.array_equal(a, b))

        return (
            self.label == other.label
            and self.fps == other.fps
            and self.joint_names == other.joint_names
            and self.actors == other.actors
            and self.subevent_names == other.subevent_names
            and self.instance_id == other.instance_id
            and all(
                arr_eq(getattr(self, f), getattr(other, f))
                for f in ("joints", "valid", "object", "subevents")
            )
        )

    def __repr__(self) -> str:
        obj = ", object" if self.has_object else ""
        return (
            f"Interaction({self.instance_id or '?'}: {self.label!r}, T={self.n_frames}, "
            f"{self.fps:g} fps, {self.layout.name}, actors={self.actors}{obj})"
        )

