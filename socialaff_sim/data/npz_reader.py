"""Read a NumPy ``.npz`` archive defensively: bounded sizes, no pickles, one error type.

``np.load`` trusts an archive's headers: a member whose header claims shape (10**10,) makes it
allocate that much before noticing the data is missing, and a corrupt archive raises any of a
dozen exception types. :func:`read_npz` checks every member's declared size against
:data:`MAX_MEMBER_BYTES` / :data:`MAX_TOTAL_BYTES` and against the bytes actually stored, refuses
object arrays, and turns every failure into a :class:`~socialaff_sim.errors.DataError` naming
the file and the member.
"""

from __future__ import annotations

import io
import struct
import zipfile
import zlib
from collections.abc import Collection
from pathlib import Path

import numpy as np
from numpy.lib import format as npy_format

from ..errors import DataError

__all__ = ["MAX_MEMBER_BYTES", "MAX_TOTAL_BYTES", "read_npz"]

MAX_MEMBER_BYTES = 1 << 30
"""Largest array one member may hold, bytes (1 GiB; a 10 000-frame 34-joint recording is 16 MB)."""
MAX_TOTAL_BYTES = 2 << 30
"""Largest total of all members' arrays, bytes (2 GiB)."""

_READ_ERRORS = (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError, struct.error, KeyError,
                NotImplementedError, UnicodeDecodeError, OverflowError, TypeError, IndexError, SyntaxError,
                RuntimeError, MemoryError)
"""What zipfile and numpy.lib.format raise on corrupt input (the header is parsed with ast.literal_eval)."""


def _header(fh: io.BufferedIOBase) -> tuple[tuple[int, ...], bool, np.dtype]:
    version = npy_format.read_magic(fh)
    if version == (1, 0):
        return npy_format.read_array_header_1_0(fh)
    if version in ((2, 0), (3, 0)):
        return npy_format.read_array_header_2_0(fh)
    raise ValueError(f"unsupported .npy version {version}")


def _read_member(zf: zipfile.ZipFile, info: zipfile.ZipInfo, source: str, key: str) -> np.ndarray:
    with zf.open(info) as fh:
        shape, fortran, dtype = _header(fh)  # type: ignore[arg-type]
        if dtype.hasobject:
            raise DataError(f"expected a plain numeric or string array, found dtype {dtype} (object arrays "
                            "need pickle, which this reader refuses)", path=source, field=key)
        if any(not isinstance(n, int) or n < 0 for n in shape):
            raise DataError(f"malformed shape {shape}", path=source, field=key)
        nbytes = int(np.prod(shape, dtype=object)) * dtype.itemsize
        if nbytes > min(info.file_size, MAX_MEMBER_BYTES):
            raise DataError(f"header declares {nbytes} bytes, the archive holds {info.file_size} "
                            f"(limit {MAX_MEMBER_BYTES})", path=source, field=key)
        data = fh.read(nbytes)
    if len(data) != nbytes:
        raise DataError(f"truncated: expected {nbytes} bytes of data, found {len(data)}", path=source, field=key)
    arr = np.frombuffer(data, dtype=dtype).copy() if nbytes else np.zeros(0, dtype=dtype)
    return arr.reshape(shape, order="F" if fortran else "C")


def read_npz(source: str | Path | bytes, *, keys: Collection[str] | None = None,
             name: str | Path | None = None) -> dict[str, np.ndarray]:
    """The arrays of an ``.npz`` archive (a path or its bytes) by key; only ``keys`` if given.

    Raises :class:`DataError` (naming ``name`` or the path, and the member) for anything that is
    not a well-formed archive of plain arrays within the size limits.
    """
    label = str(name if name is not None else (source if not isinstance(source, bytes) else "<bytes>"))
    try:
        raw = source if isinstance(source, bytes) else Path(source).read_bytes()
    except OSError as exc:
        raise DataError(f"cannot read file ({exc.strerror or exc})", path=label) from None
    if not raw:
        raise DataError("empty file: expected an .npz archive", path=label)
    out: dict[str, np.ndarray] = {}
    try:
        with zipfile.ZipFile(io.BytesIO(raw)) as zf:
            infos = [i for i in zf.infolist() if i.filename.endswith(".npy")]
            total = sum(i.file_size for i in infos)
            if total > MAX_TOTAL_BYTES:
                raise DataError(f"archive declares {total} bytes uncompressed, the limit is {MAX_TOTAL_BYTES}",
                                path=label)
            for info in infos:
                key = info.filename[: -len(".npy")]
                if keys is None or key in keys:
                    out[key] = _read_member(zf, info, label, key)
    except DataError:
        raise
    except _READ_ERRORS as exc:
        raise DataError(f"not a readable .npz archive ({type(exc).__name__}: {exc})", path=label) from None
    return out
