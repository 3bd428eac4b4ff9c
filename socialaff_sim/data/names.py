"""Names read from files that end up in file names: instance ids, labels, stems.

A name taken from a file's contents (an npz file's ``instance_id``, a model's ``label``) must
never choose where the package writes. :func:`check_file_stem` accepts a name only if it is one
plain path component: no separators, no NUL or control characters, not ``.``/``..``, not hidden
(a leading dot would also collide with the package's temporary files), not option-like, and at most
:data:`MAX_NAME_LENGTH` characters.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import DataError

__all__ = ["MAX_NAME_LENGTH", "check_file_stem", "stem_problem"]

MAX_NAME_LENGTH = 128
"""Longest name accepted, characters (file systems allow 255 bytes per component, suffixes included)."""

_FORBIDDEN = frozenset("/\\:*?\"<>|")
"""Separators (POSIX and Windows), the drive mark and the characters Windows forbids in names."""


def stem_problem(name: object) -> str | None:
    """Why ``name`` cannot be a file stem, or ``None`` if it can."""
    if not isinstance(name, str):
        return f"expected a string, found {type(name).__name__}"
    if not name:
        return "expected a non-empty name"
    if len(name) > MAX_NAME_LENGTH:
        return f"expected at most {MAX_NAME_LENGTH} characters, found {len(name)}"
    bad = sorted({c for c in name if c in _FORBIDDEN or ord(c) < 32 or ord(c) == 127})
    if bad:
        return f"expected a plain name without path separators or control characters, found {''.join(bad)!r} in {name!r}"
    if name in (".", "..") or name.startswith(("." , "-", " ")) or name.endswith((" ", ".")):
        return f"expected a plain name not starting with '.', '-' or a space nor ending with '.' or a space, found {name!r}"
    return None


def check_file_stem(name: object, *, field: str, path: str | Path | None = None) -> str:
    """Return ``name`` if it is safe as one path component; else a :class:`DataError` naming ``field``."""
    problem = stem_problem(name)
    if problem is not None:
        raise DataError(problem, path=path, field=field)
    return str(name)
