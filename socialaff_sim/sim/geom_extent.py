"""How far a MuJoCo primitive geom reaches from its centre along a direction: the support function of its shape.

For a unit direction given in each geom's own frame, u (G, 3), the half-extent r(u) = max over the geom's points x of
(x − x_g)·u: a sphere's radius; a capsule's |u_z| h + r; a box's Σ |u_i| s_i; an ellipsoid's √(Σ u_i² s_i²); a
cylinder's |u_z| h + r √(1 − u_z²) (``geom_size``'s half-lengths). The robot's lowest point at home
(:mod:`~.lowest_point`) and the hands' reach (:mod:`~.reach`) read it.
"""

from __future__ import annotations

import mujoco
import numpy as np

__all__ = ["primitive_extent"]


def primitive_extent(kind: np.ndarray, size: np.ndarray, cu: np.ndarray, other: np.ndarray) -> np.ndarray:
    """(G,) each geom's half-extent (m) along the unit direction ``cu`` (G, 3) in its own frame: ``kind`` (G,) the
    geoms' ``geom_type``, ``size`` (G, 3) their ``geom_size`` (m); ``other`` (G,) the value of any other type."""
    T = mujoco.mjtGeom
    return np.where(
        kind == int(T.mjGEOM_SPHERE), size[:, 0],
        np.where(kind == int(T.mjGEOM_CAPSULE), np.abs(cu[:, 2]) * size[:, 1] + size[:, 0],
        np.where(kind == int(T.mjGEOM_BOX), np.einsum("gi,gi->g", np.abs(cu), size),
        np.where(kind == int(T.mjGEOM_ELLIPSOID), np.sqrt(np.einsum("gi,gi->g", cu**2, size**2)),
        np.where(kind == int(T.mjGEOM_CYLINDER),
                 np.abs(cu[:, 2]) * size[:, 1] + size[:, 0] * np.sqrt(np.clip(1 - cu[:, 2] ** 2, 0, 1)),
                 other)))))
