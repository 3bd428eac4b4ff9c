"""Euclidean norms with :func:`numpy.linalg.norm`'s own arithmetic, without its argument handling.

The physics step, the IK and the streaming inference take norms of a few 3-vectors many thousand times a second;
``np.linalg.norm``'s set-up costs more than the arithmetic there. These give the same values bit for bit:
:func:`norms` is its ``axis`` form (the square root of ``np.add.reduce`` of the squares), :func:`norm` its
one-vector form (the square root of the vector's dot product with itself).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["norm", "norms"]


def norms(a: np.ndarray, axis: int = -1, keepdims: bool = False) -> np.ndarray:
    """Euclidean norms of ``a`` (float array, any unit) along ``axis``: ``np.linalg.norm(a, axis=axis,
    keepdims=keepdims)``, the same values."""
    return np.sqrt(np.add.reduce(a * a, axis=axis, keepdims=keepdims))


def norm(v: np.ndarray) -> float:
    """The Euclidean norm of the vector ``v`` (1-D float array, any unit): ``float(np.linalg.norm(v))``, the same
    value."""
    return math.sqrt(v.dot(v))
