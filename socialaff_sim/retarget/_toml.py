"""Validated reading of the small TOML files (robot mappings, task files).

Every error names the file, the dotted key, what was expected and what was found,
and lists the valid choices where there are any.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from ..errors import ConfigError, choices

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - exercised on Python 3.10 only
    import tomli as tomllib

__all__ = ["read_toml", "Table", "MISSING"]

MISSING: Any = object()
"""Sentinel: the key is required."""


def read_toml(path: str | Path) -> dict[str, Any]:
    """Parse a TOML file; syntax errors become :class:`ConfigError` naming the file."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such file") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML: {exc}") from None


def _kind(value: object) -> str:
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, (int, float)):
        return f"the number {value!r}"
    if isinstance(value, str):
        return f"the string {value!r}"
    if isinstance(value, list):
        return f"a list of {len(value)} items"
    if isinstance(value, dict):
        return "a table"
    return type(value).__name__


class Table:
    """A TOML table with typed, checked accessors.

    ``where`` is the dotted key of this table inside ``path`` (empty at top level).
    """

    def __init__(self, data: Mapping[str, Any], path: str | Path, where: str = "") -> None:
        self.data = dict(data)
        self.path = Path(path)
        self.where = where

    def key(self, name: str) -> str:
        """Dotted name of ``name`` in this table."""
        return f"{self.where}.{name}" if self.where else name

    def error(self, name: str, expected: str, found: object = MISSING, valid: Iterable[object] | None = None) -> ConfigError:
        """A :class:`ConfigError` for key ``name``."""
        got = "nothing (the key is missing)" if found is MISSING else _kind(found)
        msg = f"{self.path}: key {self.key(name)!r}: expected {expected}, found {got}"
        if valid is not None:
            msg += f"; valid choices: {choices(valid)}"
        return ConfigError(msg)

    def __contains__(self, name: str) -> bool:
        return name in self.data

    def check_keys(self, allowed: Iterable[str]) -> None:
        """Reject keys not in ``allowed`` (usually a typo)."""
        allowed = list(allowed)
        for name in self.data:
            if name not in allowed:
                raise ConfigError(
                    f"{self.path}: unknown key {self.key(name)!r}; valid keys here: {choices(allowed)}"
                )

    def _get(self, name: str, default: Any) -> Any:
        if name in self.data:
            return self.data[name]
        if default is MISSING:
            raise self.error(name, "a value")
        return default

    def get_str(self, name: str, default: Any = MISSING, *, valid: Iterable[str] | None = None) -> Any:
        """A string (one of ``valid`` when given)."""
        value = self._get(name, default)
        if value is default and name not in self.data:
            return value
        options = None if valid is None else list(valid)
        if not isinstance(value, str):
            raise self.error(name, "a string", value, options)
        if options is not None and value not in options:
            raise self.error(name, "one of the valid choices", value, options)
        return value

    def get_bool(self, name: str, default: Any = MISSING) -> Any:
        """A boolean (``true`` / ``false``)."""
        value = self._get(name, default)
        if value is default and name not in self.data:
            return value
        if not isinstance(value, bool):
            raise self.error(name, "true or false", value)
        return value

    def get_float(self, name: str, default: Any = MISSING, *, lo: float = -math.inf, hi: float = math.inf) -> Any:
        """A finite number in ``[lo, hi]``."""
        value = self._get(name, default)
        if value is default and name not in self.data:
            return value
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise self.error(name, f"a finite number in [{lo}, {hi}]", value)
        if not lo <= value <= hi:
            raise self.error(name, f"a number in [{lo}, {hi}]", value)
        return float(value)

    def get_str_list(self, name: str, default: Any = MISSING, *, valid: Iterable[str] | None = None) -> Any:
        """A list of strings (a single string is accepted as a list of one)."""
        value = self._get(name, default)
        if value is default and name not in self.data:
            return value
        if isinstance(value, str):
            value = [value]
        options = None if valid is None else list(valid)
        if not isinstance(value, list) or not value or not all(isinstance(v, str) for v in value):
            raise self.error(name, "a non-empty list of strings", value, options)
        if options is not None:
            for v in value:
                if v not in options:
                    raise self.error(name, "names from the valid choices", v, options)
        return list(value)

    def get_float_list(self, name: str, length: int, default: Any = MISSING) -> Any:
        """A list of ``length`` finite numbers."""
        value = self._get(name, default)
        if value is default and name not in self.data:
            return value
        ok = (
            isinstance(value, list)
            and len(value) == length
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
        )
        if not ok:
            raise self.error(name, f"a list of {length} finite numbers", value)
        return [float(v) for v in value]

    def get_table(self, name: str, default: Any = MISSING) -> Any:
        """A sub-table."""
        value = self._get(name, default)
        if value is default and name not in self.data:
            return value
        if not isinstance(value, dict):
            raise self.error(name, "a table", value)
        return Table(value, self.path, self.key(name))

    def get_tables(self, name: str) -> list[Table]:
        """An array of tables (``[[name]]``); empty when absent."""
        value = self.data.get(name, [])
        if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
            raise self.error(name, "an array of tables ([[...]])", value)
        return [Table(v, self.path, f"{self.key(name)}[{i}]") for i, v in enumerate(value)]
