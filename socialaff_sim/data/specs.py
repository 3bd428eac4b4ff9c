"""Dataset specs as used on the command line: ``kind:PATH`` or ``synthetic[:SEED]``."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from ..errors import DataError, choices
from .dataset import Dataset

__all__ = ["DATASET_KINDS", "load_dataset"]


def _sbu(path: Path) -> Dataset:
    from .sbu import load_sbu

    return load_sbu(path)


def _handover(path: Path) -> Dataset:
    from .handover import load_handover

    return load_handover(path)


def _nuisi(path: Path) -> Dataset:
    from .nuisi import load_nuisi

    return load_nuisi(path)


def _hhoi(path: Path) -> Dataset:
    from .hhoi import load_hhoi

    return load_hhoi(path)


def _npz(path: Path) -> Dataset:
    from .npz_format import load_npz_dataset

    return load_npz_dataset(path)


DATASET_KINDS: dict[str, Callable[[Path], Dataset]] = {
    "sbu": _sbu,
    "handover": _handover,
    "nuisi": _nuisi,
    "hhoi": _hhoi,
    "npz": _npz,
}
"""Loaders by spec prefix; ``synthetic`` is handled separately (it takes a seed, not a path)."""


def load_dataset(spec: str) -> Dataset:
    """Load a dataset from a spec such as ``sbu:PATH``, ``npz:DIR`` or ``synthetic`` / ``synthetic:SEED``."""
    kind, _, rest = spec.partition(":")
    if kind == "synthetic":
        from .synthetic import generate_dataset

        if rest and not rest.isdigit():
            raise DataError(f"dataset spec {spec!r}: expected 'synthetic' or 'synthetic:SEED' with an integer seed")
        return generate_dataset(seed=int(rest) if rest else 0)
    if kind not in DATASET_KINDS or not rest:
        kinds = [f"{k}:PATH" for k in DATASET_KINDS] + ["synthetic[:SEED]"]
        raise DataError(f"dataset spec {spec!r}: expected one of {choices(kinds)}")
    path = Path(rest).expanduser()
    if not path.exists():
        raise DataError(f"dataset spec {spec!r}: no such file or folder", path=path)
    return DATASET_KINDS[kind](path)
