"""Array comparisons on the environment's per-step path (the control clock's and the action decoder's)."""

from __future__ import annotations

import numpy as np

__all__ = ["same_array"]


def same_array(a: np.ndarray, b: np.ndarray) -> bool:
    """``np.array_equal(a, b)`` of two arrays (same shape, every entry ``==``; NaN never equal), without its
    argument handling (it runs every control step)."""
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and bool(np.logical_and.reduce(a == b, axis=None))
