"""The project's own on-disk format: one ``.npz`` per interaction (see docs/data_format.md)."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from .._atomic import atomic_write_bytes
from ..errors import DataError
from .checks import check_plausible, to_metres
from .dataset import Dataset
from .interaction import Interaction
from .names import check_file_stem
from .npz_reader import read_npz
from .policy import DEFAULT_POLICY, SkippedFiles

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


def _scalar_str(data: dict[str, np.ndarray], key: str, path: Path) -> str:
    arr = data[key]
    if arr.shape != () or arr.dtype.kind != "U":
        raise DataError(f"expected a string scalar, found dtype {arr.dtype} shape {arr.shape}", path=path, field=key)
    return str(arr)


def _numeric(data: dict[str, np.ndarray], key: str, path: Path, kinds: str = "fiu") -> np.ndarray:
    arr = data[key]
    if arr.dtype.kind not in kinds:
        raise DataError(f"expected numbers, found dtype {arr.dtype}", path=path, field=key)
    return arr


def load_interaction(path: str | Path, *, units: str = "m") -> Interaction:
    """Read and validate one interaction file; errors name the file and the field.

    ``units``: the length unit of the file's coordinates (``"m"``, ``"cm"`` or ``"mm"``); they are
    converted to metres and each agent must then be person-sized (:func:`~socialaff_sim.data.checks.check_plausible`).
    """
    path = Path(path)
    if not path.is_file():
        raise DataError("no such file", path=path)
    data = read_npz(path, keys=(*_REQUIRED, *_OPTIONAL))
    missing = [k for k in _REQUIRED if k not in data]
    if missing:
        raise DataError(
            f"missing required keys {missing}; a file holds {list(_REQUIRED)} and optionally {list(_OPTIONAL)}",
            path=path,
            field=missing[0],
        )
    version = data["format_version"]
    if version.shape != () or version.dtype.kind not in "iu" or int(version) != FORMAT_VERSION:
        raise DataError(f"expected format_version {FORMAT_VERSION}, found {version.tolist()!r}", path=path,
                        field="format_version")
    names = data["joint_names"]
    if names.ndim != 1 or names.dtype.kind != "U":
        raise DataError(f"expected a 1-D string array, found {names.dtype} {names.shape}", path=path, field="joint_names")
    actors = data["actors"]
    if actors.shape != (2,) or actors.dtype.kind != "U":
        raise DataError(f"expected 2 strings, found {actors.dtype} {actors.shape}", path=path, field="actors")
    fps = _numeric(data, "fps", path)
    if fps.shape != ():
        raise DataError(f"expected a number, found shape {fps.shape}", path=path, field="fps")
    sub_names: tuple[str, ...] = ()
    if "subevent_names" in data:
        sn = data["subevent_names"]
        if sn.ndim != 1 or (sn.size and sn.dtype.kind != "U"):
            raise DataError(f"expected a 1-D string array, found {sn.dtype} {sn.shape}", path=path, field="subevent_names")
        sub_names = tuple(str(x) for x in sn)
    kwargs = dict(
        label=_scalar_str(data, "label", path),
        fps=float(fps),
        joints=_numeric(data, "joints", path),
        joint_names=tuple(str(n) for n in names),
        actors=(str(actors[0]), str(actors[1])),
        object=_numeric(data, "object", path) if "object" in data else None,
        valid=_numeric(data, "valid", path, "biu") if "valid" in data else None,
        subevents=_numeric(data, "subevents", path, "iu") if "subevents" in data else None,
        subevent_names=sub_names,
        source=_scalar_str(data, "source", path) if "source" in data else str(path),
        instance_id=_scalar_str(data, "instance_id", path) if "instance_id" in data else path.stem,
    )
    try:
        inter = to_metres(Interaction(**kwargs), units)  # type: ignore[arg-type]
    except DataError as exc:
        raise DataError(exc.detail, path=path, field=exc.field) from None
    check_plausible(inter, path=path, units=units)
    return inter


def save_dataset(dataset: Dataset, folder: str | Path) -> list[Path]:
    """Write every interaction as ``<folder>/<instance_id>.npz``; returns the paths.

    Ids become file names, so each must be one plain path component
    (:func:`~socialaff_sim.data.names.check_file_stem`); all are checked before anything is written.
    """
    folder = Path(folder)
    stems = []
    for k, inter in enumerate(dataset):
        stems.append(check_file_stem(inter.instance_id, field="instance_id", path=inter.source or None)
                     if inter.instance_id else f"instance_{k:05d}")
    dup = sorted({s for s in stems if stems.count(s) > 1})
    if dup:
        raise DataError(f"two instances would be written to the same file {dup[0]}.npz", field="instance_id")
    folder.mkdir(parents=True, exist_ok=True)
    return [save_interaction(inter, folder / f"{stem}.npz") for stem, inter in zip(stems, dataset, strict=True)]


def load_npz_dataset(folder: str | Path, *, name: str = "npz", policy: str = DEFAULT_POLICY,
                     units: str = "m") -> Dataset:
    """Read a folder of interaction files (sorted by name).

    ``policy`` (:mod:`~socialaff_sim.data.policy`): ``"lenient"`` skips files that are not ``.npz``,
    empty or invalid with one warning listing them; ``"strict"`` raises on the first. ``units``: see
    :func:`load_interaction`.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise DataError("expected a folder of .npz interaction files", path=folder)
    skipped = SkippedFiles(policy, folder)
    items = []
    for f in SkippedFiles.visible(folder):
        if f.suffix != ".npz" or not f.is_file():
            skipped.skip(f, "unknown file: expected <instance_id>.npz")
            continue
        with skipped.guard(f):
            items.append(load_interaction(f, units=units))
    if not items:
        raise DataError(f"expected at least one readable .npz interaction file, found none "
                        f"({len(skipped.files)} skipped: {'; '.join(f'{p.name}: {r}' for p, r in skipped.files[:3])})"
                        if skipped.files else "expected at least one .npz interaction file, found none", path=folder)
    notes: dict[str, float | str] = {}
    skipped.report(notes)
    return Dataset(name, tuple(items), notes)
