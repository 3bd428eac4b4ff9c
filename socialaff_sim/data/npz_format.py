"""The project's own on-disk format: one ``.npz`` per interaction (see docs/data_format.md)."""

from __future__ import annotations

import io
import zipfile
from pathlib import Path

import numpy as np

from .._atomic import atomic_write_bytes
from ..errors import DataError
from .dataset import Dataset
from .interaction import Interaction

__all__ = ["FORMAT_VERSION", "save_interaction", "load_interaction", "save_dataset", "load_npz_dataset"]

FORMAT_VERSION = 1
"""Version written into every file as ``format_version``; readers reject other versions."""

_REQUIRED = ("format_version", "joints", "joint_names", "fps", "label", "actors")
_OPTIONAL = ("object", "valid", "subevents", "subevent_names", "source", "instance_id")


def _to_bytes(inter: Interaction) -> bytes:
    arrays: dict[str, np.ndarray] = {
        "format_version": np.array(FORMAT_VERSION, dtype=np.int64),
        "joints": inter.joints,
        "joint_names": np.array(inter.joint_names, dtype=str),
        "fps": np.array(inter.fps, dtype=np.float64),
        "label": np.array(inter.label, dtype=str),
        "actors": np.array(inter.actors, dtype=str),
        "source": np.array(inter.source, dtype=str),
        "instance_id": np.array(inter.instance_id, dtype=str),
    }
    if inter.object is not None:
        arrays["object"] = inter.object
    if inter.valid is not None and not inter.valid.all():
        arrays["valid"] = inter.valid
    if inter.subevents is not None:
        arrays["subevents"] = inter.subevents
        arrays["subevent_names"] = np.array(inter.subevent_names, dtype=str)
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)  # type: ignore[arg-type]
    return buf.getvalue()


def save_interaction(inter: Interaction, path: str | Path) -> Path:
    """Write one interaction to ``path`` atomically; returns the path."""
    path = Path(path)
    atomic_write_bytes(path, _to_bytes(inter))
    return path


def _scalar_str(data: np.lib.npyio.NpzFile, key: str, path: Path) -> str:
    arr = data[key]
    if arr.shape != () or arr.dtype.kind != "U":
        raise DataError(f"expected a string scalar, found dtype {arr.dtype} shape {arr.shape}", path=path, field=key)
    return str(arr)


def load_interaction(path: str | Path) -> Interaction:
    """Read and validate one interaction file; errors name the file and the field."""
    path = Path(path)
    if not path.is_file():
        raise DataError("no such file", path=path)
    try:
        # Read the bytes first: np.load leaks its file handle when the archive is corrupt.
        with np.load(io.BytesIO(path.read_bytes()), allow_pickle=False) as data:
            present = set(data.files)
            missing = [k for k in _REQUIRED if k not in present]
            if missing:
                raise DataError(
                    f"missing required keys {missing}; a file holds {list(_REQUIRED)} and optionally {list(_OPTIONAL)}",
                    path=path,
                    field=missing[0],
                )
            version = data["format_version"]
            if version.shape != () or int(version) != FORMAT_VERSION:
                raise DataError(
                    f"expected format_version {FORMAT_VERSION}, found {version.tolist()}",
                    path=path,
                    field="format_version",
                )
            names = data["joint_names"]
            if names.ndim != 1 or names.dtype.kind != "U":
                raise DataError(f"expected a 1-D string array, found {names.dtype} {names.shape}", path=path, field="joint_names")
            actors = data["actors"]
            if actors.shape != (2,) or actors.dtype.kind != "U":
                raise DataError(f"expected 2 strings, found {actors.dtype} {actors.shape}", path=path, field="actors")
            fps = data["fps"]
            if fps.shape != () or fps.dtype.kind not in "fiu":
                raise DataError(f"expected a number, found {fps.dtype} {fps.shape}", path=path, field="fps")
            sub_names = tuple(str(s) for s in data["subevent_names"]) if "subevent_names" in present else ()
            kwargs = dict(
                label=_scalar_str(data, "label", path),
                fps=float(fps),
                joints=data["joints"],
                joint_names=tuple(str(n) for n in names),
                actors=(str(actors[0]), str(actors[1])),
                object=data["object"] if "object" in present else None,
                valid=data["valid"] if "valid" in present else None,
                subevents=data["subevents"] if "subevents" in present else None,
                subevent_names=sub_names,
                source=_scalar_str(data, "source", path) if "source" in present else str(path),
                instance_id=_scalar_str(data, "instance_id", path) if "instance_id" in present else path.stem,
            )
    except (zipfile.BadZipFile, EOFError, OSError, ValueError) as exc:
        if isinstance(exc, DataError):
            raise
        raise DataError(f"not a readable .npz file ({exc})", path=path) from None
    try:
        return Interaction(**kwargs)  # type: ignore[arg-type]
    except DataError as exc:
        raise DataError(exc.detail, path=path, field=exc.field) from None


def save_dataset(dataset: Dataset, folder: str | Path) -> list[Path]:
    """Write every interaction as ``<folder>/<instance_id>.npz``; returns the paths."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for k, inter in enumerate(dataset):
        stem = inter.instance_id or f"instance_{k:05d}"
        out.append(save_interaction(inter, folder / f"{stem}.npz"))
    return out


def load_npz_dataset(folder: str | Path, *, name: str = "npz") -> Dataset:
    """Read a folder of interaction files (sorted by name)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise DataError("expected a folder of .npz interaction files", path=folder)
    files = sorted(folder.glob("*.npz"))
    if not files:
        raise DataError("expected at least one .npz interaction file, found none", path=folder)
    return Dataset(name, tuple(load_interaction(f) for f in files))
