"""``np.nan_to_num`` of float arrays with fewer NumPy calls when nothing is infinite (the common case).

The reactor fills NaN (untracked joints, absent parameters) several times per frame and at every re-planning;
``np.nan_to_num`` makes about ten calls each time. These give the same arrays, bitwise (±0.0 kept, ±inf to ±the
largest float by falling back to ``np.nan_to_num`` itself).
"""

from __future__ import annotations

import numpy as np

__all__ = ["nan_to_value", "nan_to_zero"]


def nan_to_value(x: np.ndarray, nan: float) -> np.ndarray:
    """``np.nan_to_num(x, nan=nan)`` of a float64 array ``x`` (a new array)."""
    out = np.where(np.isnan(x), nan, x)
    if not np.isfinite(out).all():
        return np.nan_to_num(x, nan=nan)
    return out


def nan_to_zero(x: np.ndarray) -> np.ndarray:
    """``np.nan_to_num(x)`` of a float64 array ``x`` (a new array, NaN → 0, ±inf → ±the largest float)."""
    return nan_to_value(x, 0.0)
