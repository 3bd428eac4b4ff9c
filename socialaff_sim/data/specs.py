"""Dataset specs as used on the command line: ``kind:PATH`` or ``synthetic[:SEED]``."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from ..errors import DataError, choices
from .dataset import Dataset
from .npz_format import load_npz_dataset
from .policy import DEFAULT_POLICY, POLICIES

__all__ = ["DATASET_KINDS", "load_dataset"]


def _sbu(path: Path, policy: str) -> Dataset:
    from .sbu import load_sbu

    return load_sbu(path, policy=policy)


def _handover(path: Path, policy: str) -> Dataset:
    from .handover import load_handover

    return load_handover(path, policy=policy)


def _nuisi(path: Path, policy: str) -> Dataset:
    from .nuisi import load_nuisi

    return load_nuisi(path, policy=policy)


def _hhoi(path: Path, policy: str) -> Dataset:
    from .hhoi import load_hhoi

    return load_hhoi(path, policy=policy)


DATASET_KINDS: dict[str, Callable[[Path, str], Dataset]] = {
    "sbu": _sbu,
    "handover": _handover,
    "nuisi": _nuisi,
    "hhoi": _hhoi,
    "npz": lambda path, policy: load_npz_dataset(path, policy=policy),
}
"""Loaders by spec prefix, called with (path, policy); ``synthetic`` is handled separately (it takes a seed)."""


def load_dataset(spec: str, *, policy: str = DEFAULT_POLICY, units: str = "m") -> Dataset:
    """Load a dataset from a spec such as ``sbu:PATH``, ``npz:DIR`` or ``synthetic`` / ``synthetic:SEED``.

    ``policy``: ``"lenient"`` (default) skips unknown, empty or invalid files of a folder with one
    warning listing them, ``"strict"`` stops at the first (:mod:`~socialaff_sim.data.policy`).
    ``units``: the length unit of ``npz:`` files (``"m"``, ``"cm"``, ``"mm"``); the other formats
    have a documented unit of their own.
    """
    if policy not in POLICIES:
        raise DataError(f"policy: expected {choices(POLICIES)}, found {policy!r}", field="policy")
    kind, _, rest = spec.partition(":")
    if units != "m" and kind != "npz":
        raise DataError(f"units: only npz: folders take a unit, {kind or spec!r} has its own; found units={units!r}",
                        field="units")
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
    if kind == "npz":
        return load_npz_dataset(path, policy=policy, units=units)
    return DATASET_KINDS[kind](path, policy)
