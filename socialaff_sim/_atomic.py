"""Write files and folders so that a reader never sees half of them.

* :func:`atomic_path` / :func:`atomic_write_bytes` / :func:`atomic_write_text`: one file, written to a
  temporary file in the same folder and renamed onto its name.
* :func:`output_folder`: a multi-file output. The folder is locked (a second writer gets an
  :class:`~socialaff_sim.errors.OutputError` naming the holder's process id), the files are written into a
  hidden staging folder beside it, and only when the work finishes are they moved in, one rename each.
  An interrupted run leaves the target as it was.

Temporary names carry the writer's process id (``.<name>.<pid>.<random>.tmp``, ``.<name>.<pid>.staging``,
lock ``.<name>.lock``); leftovers of a process that no longer runs (killed with SIGKILL, power loss)
are removed by the next writer to the same place.
"""

from __future__ import annotations

import errno
import logging
import os
import re
import shutil
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO

from .errors import OutputError

__all__ = [
    "atomic_path", "atomic_write_bytes", "atomic_write_text", "output_folder", "clean_stale",
    "check_output_folder", "check_output_file",
]

_log = logging.getLogger(__name__)

_LEFTOVER = re.compile(r"^\.(?P<name>.+)\.(?P<pid>\d+)\.(?:[^.]+\.tmp|staging)$")
"""Temporary files and staging folders: ``.<name>.<pid>.<random>.tmp`` and ``.<name>.<pid>.staging``."""


def _alive(pid: int) -> bool:
    """Whether a process with this id exists (on this machine)."""
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    except OSError:
        return False
    return True


def clean_stale(folder: str | os.PathLike[str], name: str | None = None) -> list[Path]:
    """Remove temporary files and staging folders in ``folder`` left by processes no longer running.

    With ``name``, only the leftovers of that target name. Returns what was removed.
    """
    folder = Path(folder)
    removed: list[Path] = []
    if not folder.is_dir():
        return removed
    for entry in folder.iterdir():
        m = _LEFTOVER.match(entry.name)
        if not m or (name is not None and m.group("name") != name) or _alive(int(m.group("pid"))):
            continue
        try:
            if entry.is_dir() and not entry.is_symlink():
                shutil.rmtree(entry)
            else:
                entry.unlink()
        except OSError:
            continue
        removed.append(entry)
    if removed:
        _log.warning("removed %d leftover(s) of interrupted runs in %s: %s", len(removed), folder,
                     ", ".join(p.name for p in removed))
    return removed


def _parent_dir(target: Path) -> Path:
    """Create ``target``'s parent folder; errors name the path and what was expected."""
    parent = target.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise OutputError(f"{parent}: expected a folder to write {target.name} into, found a file") from None
    except OSError as exc:
        raise OutputError(f"{parent}: cannot create the folder ({exc.strerror or exc})") from None
    return parent


@contextmanager
def atomic_path(path: str | os.PathLike[str], suffix: str = "") -> Iterator[Path]:
    """Yield a temporary path next to ``path``; rename it onto ``path`` on success.

    On an exception (including KeyboardInterrupt) the temporary file is removed and ``path``
    is left as it was, so a reader never sees a half-written file.
    """
    target = Path(path)
    if target.is_dir():
        raise OutputError(f"{target}: expected a file name, found a folder")
    parent = _parent_dir(target)
    clean_stale(parent, target.name)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.{os.getpid()}.", suffix=suffix or ".tmp", dir=parent)
    except OSError as exc:
        raise OutputError(f"{parent}: cannot write here ({exc.strerror or exc})") from None
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        # mkstemp creates the file 0600; give it the permissions a plain open() would.
        os.chmod(tmp_path, 0o666 & ~_umask())
        os.replace(tmp_path, target)
    except BaseException:
        tmp_path.unlink(missing_ok=True)
        raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _write(path: str | os.PathLike[str], mode: str, fill: Callable[[IO], None]) -> None:
    with atomic_path(path) as tmp, open(tmp, mode) as fh:
        fill(fh)


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes) -> None:
    """Write ``data`` to ``path`` atomically."""
    _write(path, "wb", lambda fh: fh.write(data))


def atomic_write_text(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    data = text.encode("utf-8")
    _write(path, "wb", lambda fh: fh.write(data))


def _lock(lock: Path, folder: Path) -> None:
    """Create the lock file holding our pid; take over a lock whose process is gone."""
    for _ in range(2):
        try:
            fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            try:
                pid = int(lock.read_text().strip() or "-1")
            except (OSError, ValueError):
                pid = -1
            if pid > 0 and _alive(pid):
                raise OutputError(
                    f"{folder}: another socialaff-sim run (process {pid}) is writing to this folder; "
                    f"wait for it or choose another --out (lock file {lock})"
                ) from None
            _log.warning("removing the stale lock %s (process %s is not running)", lock, pid)
            lock.unlink(missing_ok=True)
            continue
        except OSError as exc:
            raise OutputError(f"{folder.parent}: cannot write here ({exc.strerror or exc})") from None
        with os.fdopen(fd, "w") as fh:
            fh.write(f"{os.getpid()}\n")
        return
    raise OutputError(f"{folder}: cannot take the lock {lock}")  # pragma: no cover - lost two races


def _move_in(staging: Path, folder: Path) -> None:
    """Move every staged file into ``folder`` (one ``os.replace`` each), creating sub-folders."""
    folder.mkdir(parents=True, exist_ok=True)
    for src in sorted(staging.rglob("*")):
        dst = folder / src.relative_to(staging)
        if src.is_dir():
            if dst.exists() and not dst.is_dir():
                raise OutputError(f"{dst}: expected a folder, found a file")
            dst.mkdir(exist_ok=True)
        else:
            if dst.is_dir():
                raise OutputError(f"{dst}: expected a file name, found a folder")
            os.replace(src, dst)


def _probe_writable(start: Path, target: Path) -> None:
    """The nearest existing ancestor of ``start`` must be a folder we can create files in."""
    probe = start
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir():
        raise OutputError(f"{probe}: expected a folder to create {target} in, found a file")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".probe.{os.getpid()}.", suffix=".tmp", dir=probe)
    except OSError as exc:
        reason = exc.strerror or errno.errorcode.get(exc.errno or 0, str(exc))
        raise OutputError(f"{probe}: cannot write here ({reason})") from None
    os.close(fd)
    os.unlink(tmp)


def check_output_folder(folder: str | os.PathLike[str]) -> Path:
    """Check, before any work, that ``folder`` can be an output folder: not a file, creatable, writable."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"{folder}: expected a folder (or a new name), found a file")
    _probe_writable(folder, folder)
    return folder


def check_output_file(path: str | os.PathLike[str]) -> Path:
    """Check, before any work, that ``path`` can be written: not a folder, its folder creatable, writable."""
    path = Path(path)
    if path.is_dir():
        raise OutputError(f"{path}: expected a file name, found a folder")
    if not path.name or path.name in (".", ".."):
        raise OutputError(f"{path}: expected a file name")
    _probe_writable(path.parent, path)
    return path


@contextmanager
def output_folder(folder: str | os.PathLike[str]) -> Iterator[Path]:
    """Lock ``folder`` and yield a staging folder to write into; move its files in on success.

    A second writer to the same folder gets an :class:`OutputError` while the first holds the lock.
    On any exception the staged files are discarded and ``folder`` keeps what it held before.
    Files already in ``folder`` that the run does not write are kept.
    """
    folder = Path(os.path.abspath(folder))
    check_output_folder(folder)
    parent = _parent_dir(folder)
    lock = parent / f".{folder.name}.lock"
    _lock(lock, folder)
    staging = parent / f".{folder.name}.{os.getpid()}.staging"
    try:
        clean_stale(parent, folder.name)
        clean_stale(folder)
        if staging.exists():
            shutil.rmtree(staging)
        staging.mkdir()
        yield staging
        _move_in(staging, folder)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
        lock.unlink(missing_ok=True)
