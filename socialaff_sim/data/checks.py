"""Plausibility checks applied when recordings are loaded from files.

:class:`~socialaff_sim.data.interaction.Interaction` checks types, shapes and finiteness; this module
checks that the numbers mean what the format says: metres, and two real people. A file in
millimetres read as metres, coordinates scaled by 1e300, an agent that is all zeros or never tracked
load without complaint otherwise and give silently wrong models.

The size of an agent is the median over frames of its largest extent along x, y or z (metres) over
the joints valid in that frame, frames with at least two valid joints. On the real recordings it lies
between 0.61 m (NuiSI: no legs are tracked) and 1.76 m; :data:`BODY_SIZE_RANGE_M` is the accepted
range, "a person 0.5-2.5 m tall".
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import DataError, choices
from .interaction import MIN_FRAMES, Interaction

__all__ = ["BODY_SIZE_RANGE_M", "UNITS", "body_sizes", "check_plausible", "to_metres"]

BODY_SIZE_RANGE_M = (0.5, 2.5)
"""Accepted median largest extent of one agent's skeleton, metres."""

UNITS: dict[str, float] = {"m": 1.0, "cm": 0.01, "mm": 0.001}
"""Length units a file may be declared in, and their size in metres."""


def _unit_scale(units: str) -> float:
    if units not in UNITS:
        raise DataError(f"units: expected {choices(UNITS)}, found {units!r}", field="units")
    return UNITS[units]


def to_metres(inter: Interaction, units: str) -> Interaction:
    """``inter`` with joints and object converted from ``units`` to metres (itself for ``"m"``)."""
    scale = _unit_scale(units)
    if scale == 1.0:
        return inter
    obj = None if inter.object is None else inter.object * scale
    return inter.replace(joints=inter.joints * scale, object=obj)


def body_sizes(inter: Interaction) -> tuple[np.ndarray, np.ndarray]:
    """Per agent: (median largest extent in metres, NaN if never two valid joints; frames with two valid joints)."""
    valid = np.asarray(inter.valid)
    mask = np.broadcast_to(valid[..., None], inter.joints.shape)
    hi = np.max(inter.joints, axis=2, initial=-np.inf, where=mask)  # valid entries are finite (Interaction)
    lo = np.min(inter.joints, axis=2, initial=np.inf, where=mask)
    counted = valid.sum(axis=2) >= 2  # (T, 2)
    extent = np.where(counted, (hi - lo).max(axis=-1, initial=0.0, where=np.isfinite(hi - lo)), 0.0)
    sizes = np.array([np.median(extent[counted[:, a], a]) if counted[:, a].any() else np.nan for a in range(2)])
    return sizes, counted.sum(axis=0)


def check_plausible(inter: Interaction, *, path: str | Path | None = None, units: str = "m") -> None:
    """Raise a :class:`DataError` if an agent is never tracked, collapsed to a point or not person-sized.

    ``units`` is what the file was declared in (after conversion the sizes are in metres); the error
    suggests another unit when the sizes would be plausible in it.
    """
    where = path if path is not None else (inter.source or inter.instance_id or None)
    sizes, frames = body_sizes(inter)
    lo, hi = BODY_SIZE_RANGE_M
    for a in range(2):
        if frames[a] < MIN_FRAMES:
            raise DataError(f"agent {a} has two or more valid joints in {frames[a]} frames, expected at least "
                            f"{MIN_FRAMES} (all NaN, zero or invalid?)", path=where, field="joints")
        size = float(sizes[a])
        if size == 0.0:
            raise DataError(f"agent {a}'s joints all sit at one point (all zeros?): expected a person-sized skeleton",
                            path=where, field="joints")
        if lo <= size <= hi:
            continue
        raw = size / _unit_scale(units)  # in the file's own numbers
        hint = ""
        for name, scale in UNITS.items():
            if name != units and lo <= raw * scale <= hi:
                hint = f"; it would be {raw * scale:.2f} m if the file were in {name} (units={name!r}, --units {name})"
                break
        raise DataError(
            f"agent {a} is {size:.4g} m across (median largest extent) reading the file in {units}, expected a "
            f"person {lo}-{hi} m{hint}", path=where, field="joints")
