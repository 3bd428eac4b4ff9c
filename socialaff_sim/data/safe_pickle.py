"""A restricted unpickler for the pickled parts of the real recordings.

Pickles can run arbitrary code: unpickling calls whatever global the stream
names. The handover recordings are pickled dicts of NumPy arrays, and NuiSI
stores its ROS time stamps as a pickled object array, so both must be read,
but only through :class:`RestrictedUnpickler`, whose ``find_class`` resolves a
global only when it is on an explicit allow-list and raises
:class:`~socialaff_sim.errors.UnsafePickleError` (naming the file and the
forbidden global) before anything is called otherwise. Every callable a pickle
can reach comes from ``find_class`` (``GLOBAL``, ``STACK_GLOBAL``, ``INST``,
``OBJ`` and the copyreg extension codes all go through it), so the allow-list
bounds what can run.

Two allow-lists are provided:

* :data:`NUMPY_ARRAY_GLOBALS`: ``builtins.dict`` and NumPy's array, dtype and
  scalar reconstruction (``_reconstruct``, ``ndarray``, ``dtype``, ``scalar``)
  under both the NumPy 1.x module name ``numpy.core.multiarray`` and the NumPy
  2.x ``numpy._core.multiarray``. The names are resolved to the installed
  NumPy's own objects without importing the deprecated ``numpy.core`` alias.
  Pickle protocol 5's ``_frombuffer`` is deliberately absent: these files do
  not use it.
* :data:`ROS_TIME_GLOBALS`: the array machinery plus ``rospy.rostime.Time`` and
  ``genpy.rostime.Time``, both mapped to :class:`RosTime`, a plain holder of
  ``secs`` and ``nsecs``; ROS is never imported.
"""

from __future__ import annotations

import io
import pickle
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import DataError, UnsafePickleError, choices

__all__ = [
    "RosTime",
    "RestrictedUnpickler",
    "NUMPY_ARRAY_GLOBALS",
    "ROS_TIME_GLOBALS",
    "restricted_loads",
    "restricted_load",
]


def _numpy_multiarray() -> Any:
    """The installed NumPy's ``multiarray`` module (NumPy 2.x name first, then 1.x)."""
    try:
        from numpy._core import multiarray  # NumPy >= 2
    except ImportError:  # pragma: no cover - NumPy 1.x
        from numpy.core import multiarray  # type: ignore[no-redef]
    return multiarray


class RosTime:
    """A ROS time stamp (``rospy.rostime.Time`` / ``genpy.Time``) as plain data.

    Built by the restricted unpickler in place of the ROS class: the pickle
    creates an empty instance and hands it its state ``[secs, nsecs]``.
    """

    __slots__ = ("secs", "nsecs")

    def __init__(self, secs: int = 0, nsecs: int = 0) -> None:
        self.__setstate__((secs, nsecs))

    def __setstate__(self, state: object) -> None:
        if not isinstance(state, (list, tuple)) or len(state) != 2:
            raise DataError(f"ROS time state: expected [secs, nsecs], found {state!r}")
        secs, nsecs = state
        for name, value in (("secs", secs), ("nsecs", nsecs)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise DataError(f"ROS time state: expected an integer {name}, found {value!r}")
        if not 0 <= int(nsecs) < 1_000_000_000:
            raise DataError(f"ROS time state: expected 0 <= nsecs < 1e9, found {nsecs}")
        self.secs = int(secs)
        self.nsecs = int(nsecs)

    def __reduce__(self) -> tuple[Any, ...]:
        return (RosTime, (self.secs, self.nsecs))

    def to_sec(self) -> float:
        """Seconds as a float (loses sub-microsecond precision for epoch times)."""
        return self.secs + self.nsecs * 1e-9

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, RosTime):
            return NotImplemented
        return (self.secs, self.nsecs) == (other.secs, other.nsecs)

    def __hash__(self) -> int:
        return hash((self.secs, self.nsecs))

    def __repr__(self) -> str:
        return f"RosTime(secs={self.secs}, nsecs={self.nsecs})"


def _array_globals() -> dict[tuple[str, str], Any]:
    multiarray = _numpy_multiarray()
    table: dict[tuple[str, str], Any] = {
        ("builtins", "dict"): dict,
        ("numpy", "ndarray"): np.ndarray,
        ("numpy", "dtype"): np.dtype,
    }
    for mod in ("numpy.core.multiarray", "numpy._core.multiarray"):
        table[(mod, "_reconstruct")] = multiarray._reconstruct
        table[(mod, "scalar")] = multiarray.scalar
    return table


NUMPY_ARRAY_GLOBALS: Mapping[tuple[str, str], Any] = _array_globals()
"""Allow-list for pickled dicts of NumPy arrays: (module, name) -> object."""

ROS_TIME_GLOBALS: Mapping[tuple[str, str], Any] = {
    **NUMPY_ARRAY_GLOBALS,
    ("rospy.rostime", "Time"): RosTime,
    ("genpy.rostime", "Time"): RosTime,
}
"""Allow-list for NumPy object arrays of ROS time stamps."""


class RestrictedUnpickler(pickle.Unpickler):
    """An unpickler that resolves only the globals of an allow-list.

    ``allowed`` maps ``(module, name)`` as written in the stream to the object
    to use; ``source`` (the file) is named in every error.
    """

    def __init__(
        self,
        file: io.BufferedIOBase | io.BytesIO,
        *,
        allowed: Mapping[tuple[str, str], Any],
        source: str | Path,
        encoding: str = "latin1",
    ) -> None:
        # latin1 maps Python 2 byte strings 1:1 (what NumPy uses for py2 arrays).
        super().__init__(file, encoding=encoding, fix_imports=False)
        self._allowed = dict(allowed)
        self._source = source

    def find_class(self, module: str, name: str) -> Any:
        key = (module, name)
        if key in self._allowed:
            return self._allowed[key]
        allowed = sorted(f"{m}.{n}" for m, n in self._allowed)
        raise UnsafePickleError(
            f"forbidden global {module}.{name}: this loader only unpickles {choices(allowed)}",
            path=self._source,
            field="pickle",
        )

    def persistent_load(self, pid: Any) -> Any:
        raise UnsafePickleError(
            f"forbidden persistent id {pid!r}: persistent references are not allowed",
            path=self._source,
            field="pickle",
        )


def restricted_loads(
    data: bytes,
    *,
    allowed: Mapping[tuple[str, str], Any],
    expect: type | tuple[type, ...],
    source: str | Path = "<bytes>",
) -> Any:
    """Unpickle ``data`` through the allow-list and check the top-level type.

    Raises :class:`UnsafePickleError` for a forbidden global and
    :class:`DataError` for a corrupt stream or a top-level object that is not an
    instance of ``expect``.
    """
    try:
        obj = RestrictedUnpickler(io.BytesIO(data), allowed=allowed, source=source).load()
    except DataError as exc:
        if exc.path is None:  # e.g. a malformed ROS time state: name the file
            raise type(exc)(exc.detail, path=source, field=exc.field or "pickle") from None
        raise
    except (pickle.UnpicklingError, EOFError, ValueError, TypeError, AttributeError, IndexError, KeyError,
            MemoryError, OverflowError, UnicodeDecodeError) as exc:
        raise DataError(
            f"not a readable pickle ({type(exc).__name__}: {exc})", path=source, field="pickle"
        ) from None
    if not isinstance(obj, expect):
        names = [t.__name__ for t in (expect if isinstance(expect, tuple) else (expect,))]
        raise DataError(
            f"expected a pickled {' or '.join(names)} at top level, found {type(obj).__name__}",
            path=source,
            field="pickle",
        )
    return obj


def restricted_load(
    path: str | Path,
    *,
    allowed: Mapping[tuple[str, str], Any],
    expect: type | tuple[type, ...],
) -> Any:
    """Read ``path`` and unpickle it with :func:`restricted_loads`."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise DataError(f"cannot read file ({exc.strerror or exc})", path=path) from None
    return restricted_loads(data, allowed=allowed, expect=expect, source=path)
