"""The package's exceptions: one root, :class:`SocialAffError`, and a few subclasses.

Every error raised on bad user input derives from :class:`SocialAffError`, so a
caller can catch them all with one ``except`` clause. Messages name the file,
the field and what was expected, and list the valid choices where there are any.
"""

from __future__ import annotations

from collections.abc import Iterable

__all__ = [
    "SocialAffError",
    "DataError",
    "UnsafePickleError",
    "ModelError",
    "NotFittedError",
    "ModelFileError",
    "ConfigError",
    "OutputError",
    "SimulationError",
    "RenderingUnavailableError",
    "choices",
]


def choices(options: Iterable[object]) -> str:
    """Format valid choices for an error message, e.g. ``'a', 'b' or 'c'``."""
    items = [repr(o) for o in options]
    if not items:
        return "(none)"
    if len(items) == 1:
        return items[0]
    return ", ".join(items[:-1]) + " or " + items[-1]


class SocialAffError(Exception):
    """Root of every error this package raises on purpose."""


class DataError(SocialAffError, ValueError):
    """A recording or dataset file is missing, malformed or inconsistent.

    ``path`` and ``field`` are kept as attributes so that tools can point at them.
    """

    def __init__(self, message: str, *, path: object = None, field: str | None = None) -> None:
        parts = []
        if path is not None:
            parts.append(str(path))
        if field is not None:
            parts.append(f"field {field!r}")
        prefix = ": ".join(parts)
        super().__init__(f"{prefix}: {message}" if prefix else message)
        self.path = path
        self.field = field
        self.detail = message


class UnsafePickleError(DataError):
    """A pickle asked for something outside the allow-list of the restricted unpickler."""


class ConfigError(SocialAffError, ValueError):
    """A configuration value or task file is invalid."""


class OutputError(SocialAffError, OSError):
    """An output path cannot be written: a file where a folder is expected, no permission,
    or another run holding the folder's lock."""


class ModelError(SocialAffError):
    """The affordance model cannot do what was asked (e.g. too few instances)."""


class NotFittedError(ModelError, AttributeError):
    """A model was used before ``fit`` was called."""


class ModelFileError(ModelError, ValueError):
    """A saved model file is truncated, of another format version, or malformed."""


class SimulationError(SocialAffError, RuntimeError):
    """The MuJoCo scene, retargeting or physics loop cannot proceed."""


class RenderingUnavailableError(SimulationError):
    """Offscreen rendering is not available (EGL/OSMesa libraries missing)."""
