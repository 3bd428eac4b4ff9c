"""Frame helpers shared by the loaders: levelling a camera frame and placing the floor."""

from __future__ import annotations

import numpy as np

from ..errors import DataError

__all__ = ["level_rotation", "floor_offset"]

_FLOOR_PERCENTILE = 5.0


def level_rotation(up_vectors: np.ndarray) -> np.ndarray:
    """(3, 3) rotation taking the median of ``up_vectors`` onto +z (the smallest such rotation).

    ``up_vectors``: (N, 3) directions that should be vertical on average (e.g.
    mid-feet → neck); non-finite rows are ignored. Returns the identity when
    fewer than one finite row is given or the median is already +z.
    """
    v = np.asarray(up_vectors, dtype=np.float64).reshape(-1, 3)
    v = v[np.isfinite(v).all(axis=1)]
    norms = np.linalg.norm(v, axis=1)
    v = v[norms > 1e-9] / norms[norms > 1e-9, None]
    if len(v) == 0:
        return np.eye(3)
    u = np.median(v, axis=0)
    u /= np.linalg.norm(u)
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(u, z)
    s, c = np.linalg.norm(axis), float(u @ z)
    if s < 1e-12:
        if c > 0:
            return np.eye(3)
        return np.diag([1.0, -1.0, -1.0])  # upside down: half turn about x
    k = axis / s
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def floor_offset(feet_z: np.ndarray, percentile: float = _FLOOR_PERCENTILE) -> float:
    """Height of the floor: a low percentile of the foot joints' heights (finite values only), metres."""
    z = np.asarray(feet_z, dtype=np.float64).ravel()
    z = z[np.isfinite(z)]
    if len(z) == 0:
        raise DataError("no valid foot position to place the floor", field="joints")
    return float(np.percentile(z, percentile))
