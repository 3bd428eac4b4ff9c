"""``np.nan_to_num`` of float arrays with fewer NumPy calls when nothing is infinite (the common case).

The reactor fills NaN (untracked joints, absent parameters) several times per frame and at every re-planning;
``np.nan_to_num`` makes about ten calls each time. These give the same arrays, bitwise (±0.0 kept, ±inf to ±the
largest float by falling back to ``np.nan_to_num`` itself).
"""

from __future__ import annotations

import numpy as np

__all__ = ["nan_to_value", "nan_to_zero"]

_all = np.logical_and.reduce  # what ndarray.all calls, without its Python wrapper


def nan_to_value(x: np.ndarray, nan: float) -> np.ndarray:
    """``np.nan_to_num(x, nan=nan)`` of a float64 array ``x`` (a new array)."""
    if type(x) is np.ndarray and x.dtype == np.float64 and x.flags.c_contiguous and _all(np.isfinite(x), axis=None):
        return x.copy()  # nothing to replace (the reactor's usual case): a copy (C order, as np.where's), two calls fewer
    out = np.where(np.isnan(x), nan, x)
    if not np.isfinite(out).all():
        return np.nan_to_num(x, nan=nan)
    return out


def nan_to_zero(x: np.ndarray) -> np.ndarray:
    """``np.nan_to_num(x)`` of a float64 array ``x`` (a new array, NaN → 0, ±inf → ±the largest float)."""
    return nan_to_value(x, 0.0)
