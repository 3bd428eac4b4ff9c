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

Resource caps: a pickle states an array's shape before its data, so a short stream could make
NumPy allocate gigabytes. Every array the stream creates is checked before it is allocated:
at most :data:`MAX_ARRAY_BYTES` each, :data:`MAX_TOTAL_BYTES` in all, and at most
:data:`MAX_BYTES_PER_STREAM_BYTE` times the stream's length plus 1 MiB (a real array's data, or
for an object array one memo reference per element, is in the stream). Memo indices are checked
against the stream's opcode count before anything runs (the C unpickler sizes its memo by the
largest index). Exceeding a cap raises :class:`~socialaff_sim.errors.DataError`.
"""

from __future__ import annotations

import io
import pickle
import pickletools
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
    "MAX_ARRAY_BYTES",
    "MAX_TOTAL_BYTES",
    "MAX_BYTES_PER_STREAM_BYTE",
]

MAX_ARRAY_BYTES = 512 << 20
"""Largest array one pickle may create, bytes (512 MiB)."""
MAX_TOTAL_BYTES = 1 << 30
"""Largest total of the arrays one pickle may create, bytes (1 GiB)."""
MAX_BYTES_PER_STREAM_BYTE = 64
"""Largest ratio of the arrays' bytes to the stream's length (plus 1 MiB of slack)."""


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


class _Budget:
    """Bytes of arrays a single load may still allocate."""

    def __init__(self, stream_bytes: int, source: str | Path) -> None:
        self.left = min(MAX_TOTAL_BYTES, MAX_BYTES_PER_STREAM_BYTE * stream_bytes + (1 << 20))
        self.source = source

    def take(self, shape: object, dtype: object) -> None:
        try:
            dims = tuple(int(n) for n in shape)  # type: ignore[attr-defined]
            itemsize = np.dtype(dtype).itemsize  # type: ignore[call-overload]
        except (TypeError, ValueError, OverflowError):
            raise DataError(f"malformed array shape {shape!r} or dtype {dtype!r}", path=self.source,
                            field="pickle") from None
        if any(n < 0 for n in dims):
            raise DataError(f"malformed array shape {dims}", path=self.source, field="pickle")
        nbytes = itemsize
        for n in dims:
            nbytes *= n
        if nbytes > MAX_ARRAY_BYTES or nbytes > self.left:
            raise DataError(
                f"an array of shape {dims} and {nbytes} bytes exceeds the limit ({min(MAX_ARRAY_BYTES, self.left)} "
                f"bytes left for this stream; caps: {MAX_ARRAY_BYTES} per array, {MAX_TOTAL_BYTES} in all, "
                f"{MAX_BYTES_PER_STREAM_BYTE} per byte of the stream)", path=self.source, field="pickle")
        self.left -= nbytes


class _GuardedArray(np.ndarray):
    """The array class a pickle's ``_reconstruct`` builds: checks the state's size before NumPy allocates."""

    _budget: _Budget | None = None

    def __setstate__(self, state: Any) -> None:
        if not isinstance(state, tuple) or len(state) not in (4, 5):
            raise DataError(f"malformed array state of type {type(state).__name__}", field="pickle")
        shape, dtype = state[-4], state[-3]
        if self._budget is not None:
            self._budget.take(shape, dtype)
        super().__setstate__(state)


def _plain(obj: Any) -> Any:
    """``obj`` with every guarded array replaced by a plain ndarray view (dicts and object arrays walked)."""
    if isinstance(obj, dict):
        return {k: _plain(v) for k, v in obj.items()}
    if isinstance(obj, np.ndarray):
        arr = obj.view(np.ndarray)
        if arr.dtype.hasobject:
            for idx, item in np.ndenumerate(arr):
                if isinstance(item, (np.ndarray, dict)):
                    arr[idx] = _plain(item)
        return arr
    return obj


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
        self._budget = _Budget(MAX_TOTAL_BYTES, source)
        multiarray = _numpy_multiarray()
        budget = self._budget
        guarded = type("_GuardedArray", (_GuardedArray,), {"_budget": budget})

        def reconstruct(subtype: Any, shape: Any, dtype: Any) -> np.ndarray:
            if subtype is not np.ndarray:
                raise UnsafePickleError(f"forbidden array subtype {subtype!r}", path=source, field="pickle")
            budget.take(shape, dtype)
            return multiarray._reconstruct(guarded, shape, dtype)

        for key, value in self._allowed.items():
            if value is multiarray._reconstruct:
                self._allowed[key] = reconstruct

    def limit_to_stream(self, stream_bytes: int) -> None:
        """Tighten the byte budget to :data:`MAX_BYTES_PER_STREAM_BYTE` times the stream's length."""
        self._budget.left = _Budget(stream_bytes, self._source).left

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


def _check_memo(data: bytes, source: str | Path) -> None:
    """Refuse memo indices beyond the stream's opcode count (they would size the memo) before running it."""
    n_ops = 0
    try:
        for op, arg, _ in pickletools.genops(data):
            n_ops += 1
            if op.name in ("PUT", "BINPUT", "LONG_BINPUT", "GET", "BINGET", "LONG_BINGET"):
                index = int(arg)
                if index > n_ops:
                    raise DataError(f"memo index {index} beyond the stream's {n_ops} opcodes so far",
                                    path=source, field="pickle")
    except DataError:
        raise
    except (ValueError, TypeError, EOFError, UnicodeDecodeError, OverflowError) as exc:
        raise DataError(f"not a readable pickle ({type(exc).__name__}: {exc})", path=source, field="pickle") from None


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
        _check_memo(data, source)
        unpickler = RestrictedUnpickler(io.BytesIO(data), allowed=allowed, source=source)
        unpickler.limit_to_stream(len(data))
        obj = _plain(unpickler.load())
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
