"""A mix-in giving frozen dataclass configs a JSON round trip."""

from __future__ import annotations

from dataclasses import fields
from typing import Any, TypeVar

from .errors import ConfigError

__all__ = ["DictConfig"]

C = TypeVar("C", bound="DictConfig")


class DictConfig:
    """``to_dict`` / ``from_dict`` for a dataclass config (used in model files' JSON metadata)."""

    def to_dict(self) -> dict[str, Any]:
        """The settings as a JSON-compatible dict."""
        return {f.name: getattr(self, f.name) for f in fields(self)}  # type: ignore[arg-type]

    @classmethod
    def from_dict(cls: type[C], data: dict[str, Any]) -> C:
        """Inverse of :meth:`to_dict`; unknown keys are a :class:`~socialaff_sim.errors.ConfigError`."""
        known = {f.name for f in fields(cls)}  # type: ignore[arg-type]
        unknown = sorted(set(data) - known)
        if unknown:
            raise ConfigError(f"{cls.__name__}: unknown fields {unknown}; valid fields: {sorted(known)}")
        return cls(**data)
