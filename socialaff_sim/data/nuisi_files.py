"""Reading one NuiSI v1 agent file: joints ``arr_0`` and ROS time stamps ``arr_1``.

The stamps are a pickled object array; they are read only through the
restricted unpickler (never ``np.load(allow_pickle=True)``). See
:mod:`socialaff_sim.data.nuisi` for the dataset and its processing.
"""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
from numpy.lib import format as npy_format

from ..errors import DataError
from .interaction import MIN_FRAMES
from .npz_reader import _READ_ERRORS, read_npz
from .safe_pickle import ROS_TIME_GLOBALS, RosTime, restricted_loads
from .skeletons import get_layout

__all__ = ["read_nuisi_agent"]

_J = get_layout("nuitrack10").n_joints


def _read_stamps(path: Path, zf: zipfile.ZipFile) -> np.ndarray:
    """(N,) int64 nanoseconds since the epoch from ``arr_1`` (restricted unpickling of ROS stamps)."""
    try:
        with zf.open("arr_1.npy") as fh:
            version = npy_format.read_magic(fh)
            read_header = npy_format.read_array_header_1_0 if version == (1, 0) else npy_format.read_array_header_2_0
            shape, _, dtype = read_header(fh)
            payload = fh.read()
    except KeyError:
        raise DataError("expected an array 'arr_1' (time stamps), found none", path=path, field="arr_1") from None
    except ValueError as exc:
        raise DataError(f"not a readable .npy array ({exc})", path=path, field="arr_1") from None
    if len(shape) != 1:
        raise DataError(f"expected shape (N,), found {shape}", path=path, field="arr_1")
    if dtype.kind in "fiu":  # plain numeric seconds: no pickle involved
        if len(payload) < shape[0] * dtype.itemsize:
            raise DataError(f"truncated: expected {shape[0]} stamps, found {len(payload) // dtype.itemsize}",
                            path=path, field="arr_1")
        seconds = np.frombuffer(payload, dtype=dtype, count=shape[0]).astype(np.float64)
        return np.round(seconds * 1e9).astype(np.int64)
    if dtype != np.dtype(object):
        raise DataError(f"expected ROS time stamps (object dtype) or seconds, found dtype {dtype}", path=path,
                        field="arr_1")
    arr = restricted_loads(payload, allowed=ROS_TIME_GLOBALS, expect=np.ndarray, source=f"{path}:arr_1")
    if arr.shape != tuple(shape) or not all(isinstance(s, RosTime) for s in arr.ravel()):
        kinds = sorted({type(s).__name__ for s in arr.ravel()})
        raise DataError(f"expected {shape[0]} ROS time stamps, found shape {arr.shape} of {kinds}", path=path,
                        field="arr_1")
    return np.array([s.secs * 1_000_000_000 + s.nsecs for s in arr], dtype=np.int64)


def read_nuisi_agent(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read one agent file: ``stamps`` (N,) int64 ns since the epoch, ``frames`` (N, 10, 7) float64.

    ``frames[..., :3]`` are metres in the agent's camera frame. Errors name the
    file, the array and the expected vs found shape; stamps must increase.
    """
    path = Path(path)
    frames = read_npz(path, keys=("arr_0",)).get("arr_0")
    if frames is None:
        raise DataError("expected an array 'arr_0' (joints), found none", path=path, field="arr_0")
    try:
        with zipfile.ZipFile(path) as zf:
            stamps = _read_stamps(path, zf)
    except DataError:
        raise
    except _READ_ERRORS as exc:
        raise DataError(f"not a readable .npz file ({type(exc).__name__}: {exc})", path=path, field="arr_1") from None
    if frames.ndim != 3 or frames.shape[1:] != (_J, 7) or frames.dtype.kind != "f":
        raise DataError(f"expected float array (N, {_J}, 7), found {frames.dtype} {frames.shape}", path=path,
                        field="arr_0")
    if len(frames) < MIN_FRAMES:
        raise DataError(f"expected at least {MIN_FRAMES} frames, found {len(frames)}", path=path, field="arr_0")
    if len(stamps) != len(frames):
        raise DataError(f"expected one stamp per frame ({len(frames)}), found {len(stamps)}", path=path, field="arr_1")
    steps = np.diff(stamps)
    if (steps <= 0).any():
        i = int(np.argmax(steps <= 0))
        raise DataError(f"expected strictly increasing time stamps, found stamp {i + 1} <= stamp {i}", path=path,
                        field="arr_1")
    return stamps, frames.astype(np.float64)
