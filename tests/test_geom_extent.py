"""sim/geom_extent.py: a primitive geom's half-extent along a direction, against the largest projection of points
sampled densely on its surface (brute force), for each primitive type; any other type takes the value given."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from socialaff_sim.sim.geom_extent import primitive_extent

T = mujoco.mjtGeom


def _sphere_points() -> np.ndarray:
    """(N, 3) points on the unit sphere on a grid of polar angle and azimuth (spacing about 0.6°)."""
    t, p = np.meshgrid(np.linspace(0.0, np.pi, 301), np.linspace(0.0, 2.0 * np.pi, 600, endpoint=False))
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1).reshape(-1, 3)


def _surface(kind: int, size: np.ndarray) -> np.ndarray:
    """(N, 3) points on the surface of a geom of ``kind`` and ``geom_size`` ``size`` (3,), in its own frame."""
    s = _sphere_points()
    if kind == T.mjGEOM_SPHERE:
        return size[0] * s
    if kind == T.mjGEOM_CAPSULE:  # the segment ±h along z, swept by the radius
        return np.vstack([size[0] * s + [0.0, 0.0, size[1]], size[0] * s - [0.0, 0.0, size[1]]])
    if kind == T.mjGEOM_BOX:
        return np.array(np.meshgrid(*[[-a, a] for a in size])).reshape(3, -1).T
    if kind == T.mjGEOM_ELLIPSOID:
        return size * s
    phi = np.linspace(0.0, 2.0 * np.pi, 20000, endpoint=False)  # the cylinder's two rims
    rim = np.stack([size[0] * np.cos(phi), size[0] * np.sin(phi), np.zeros_like(phi)], axis=1)
    return np.vstack([rim + [0.0, 0.0, size[1]], rim - [0.0, 0.0, size[1]]])


KINDS = [T.mjGEOM_SPHERE, T.mjGEOM_CAPSULE, T.mjGEOM_BOX, T.mjGEOM_ELLIPSOID, T.mjGEOM_CYLINDER]


@pytest.mark.parametrize("kind", KINDS)
def test_each_primitive_reaches_as_far_as_its_surface(kind: int) -> None:
    rng = np.random.default_rng(int(kind))
    size = rng.uniform(0.02, 0.2, (40, 3))
    cu = rng.normal(size=(40, 3))
    cu[:5] = np.eye(3)[[0, 1, 2, 2, 0]] * [[1], [1], [1], [-1], [-1]]  # along the axes too
    cu /= np.linalg.norm(cu, axis=1, keepdims=True)
    got = primitive_extent(np.full(40, int(kind)), size, cu, np.full(40, np.nan))
    want = np.array([(_surface(kind, s) @ u).max() for s, u in zip(size, cu, strict=True)])
    assert np.all(got >= want - 1e-12)  # no surface point beyond it
    assert np.allclose(got, want, atol=2e-4)  # and it is reached (to the sampling's fineness)


def test_other_types_take_the_value_given() -> None:
    kind = np.array([int(T.mjGEOM_MESH), int(T.mjGEOM_PLANE), int(T.mjGEOM_SPHERE)])
    size = np.full((3, 3), 0.1)
    cu = np.tile([0.0, 0.0, 1.0], (3, 1))
    got = primitive_extent(kind, size, cu, np.array([0.7, 0.8, 0.9]))
    assert got.tolist() == [0.7, 0.8, 0.1]
