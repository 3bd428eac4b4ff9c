"""What a folder loader does with a file it cannot use: skip it with a warning, or stop.

``"lenient"`` (the default, :data:`DEFAULT_POLICY`): unknown files (a name the format does not
use, e.g. an unknown NuiSI interaction), empty files and files that fail validation are skipped;
one warning (``logging``) lists every skipped file with its reason, and the dataset's
``notes["skipped_files"]`` keeps the list. ``"strict"``: the first such file raises a
:class:`~socialaff_sim.errors.DataError`. Under both policies a pickle asking for a forbidden
global (:class:`~socialaff_sim.errors.UnsafePickleError`) stops the load: a tampered file is
never just skipped. Hidden files (a leading dot) are ignored.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Literal

from ..errors import DataError, UnsafePickleError, choices

__all__ = ["LoadPolicy", "POLICIES", "DEFAULT_POLICY", "SkippedFiles"]

LoadPolicy = Literal["lenient", "strict"]
POLICIES: tuple[str, ...] = ("lenient", "strict")
DEFAULT_POLICY: LoadPolicy = "lenient"

_log = logging.getLogger("socialaff_sim.data")


class SkippedFiles:
    """Collects the files a loader skipped under ``policy`` (raises at once under ``"strict"``)."""

    def __init__(self, policy: str, root: str | Path) -> None:
        if policy not in POLICIES:
            raise DataError(f"policy: expected {choices(POLICIES)}, found {policy!r}", field="policy")
        self.policy = policy
        self.root = Path(root)
        self.files: list[tuple[Path, str]] = []

    def skip(self, path: str | Path, reason: str) -> None:
        """Record ``path`` as skipped (lenient) or raise (strict)."""
        if self.policy == "strict":
            raise DataError(f"{reason} (strict loading; lenient loading skips such files)", path=path)
        self.files.append((Path(path), reason))

    @contextmanager
    def guard(self, path: str | Path) -> Iterator[None]:
        """Run a file's loading; a :class:`DataError` skips the file (lenient) or propagates (strict)."""
        try:
            yield
        except UnsafePickleError:
            raise
        except DataError as exc:
            if self.policy == "strict":
                raise
            self.files.append((Path(path), f"field {exc.field!r}: {exc.detail}" if exc.field else exc.detail))

    def report(self, notes: dict[str, float | str]) -> None:
        """Log one warning listing the skipped files and keep the list in ``notes["skipped_files"]``."""
        if not self.files:
            return
        listing = "; ".join(f"{p.name}: {reason}" for p, reason in self.files)
        _log.warning("%s: skipped %d file(s) (lenient loading; use strict to stop instead): %s",
                     self.root, len(self.files), listing)
        notes["skipped_files"] = listing

    @staticmethod
    def visible(folder: Path) -> list[Path]:
        """The folder's entries without hidden ones, sorted by name."""
        return sorted(p for p in folder.iterdir() if not p.name.startswith("."))
