"""Framing the side camera: the look-at height and distance that keep every body in the picture below the caption.

MuJoCo's free camera looks from ``lookat - distance * forward`` along ``forward`` (azimuth, elevation in
degrees) with the vertical field of view ``fovy``; :func:`project` maps world points to normalized device
coordinates (x right, y up, both -1..1 at the image's edges) the way it renders them. :func:`fit_camera` chooses
the look-at height and the smallest distance (not below a floor) at which spheres around every body fit inside
the image with the caption band's share of its top left free.
"""

from __future__ import annotations

import numpy as np

__all__ = ["camera_axes", "project", "fit_camera", "MARGIN"]

MARGIN = 0.04
"""Normalized-device-coordinate margin kept free inside the image's edges and below the caption band."""


def camera_axes(azimuth: float, elevation: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(forward, up, right) unit vectors (3,) of MuJoCo's free camera at ``azimuth``/``elevation`` (degrees)."""
    a, e = np.radians(azimuth), np.radians(elevation)
    forward = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    up = np.array([-np.sin(e) * np.cos(a), -np.sin(e) * np.sin(a), np.cos(e)])
    return forward, up, np.cross(forward, up)


def project(points: np.ndarray, lookat: np.ndarray, distance: float, azimuth: float, elevation: float,
            fovy: float, aspect: float) -> np.ndarray:
    """(N, 2) normalized device coordinates (x right, y up) of world ``points`` (N, 3) m seen by the free camera;
    ``fovy`` degrees (vertical), ``aspect`` width / height. Points behind the camera get NaN."""
    forward, up, right = camera_axes(azimuth, elevation)
    v = np.asarray(points, dtype=np.float64) - (np.asarray(lookat, dtype=np.float64) - distance * forward)
    depth = v @ forward
    t = np.tan(np.radians(fovy) / 2.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        ndc = np.stack([(v @ right) / (depth * t * aspect), (v @ up) / (depth * t)], axis=-1)
    ndc[depth <= 0] = np.nan
    return ndc


def fit_camera(centres: np.ndarray, radii: np.ndarray, xy: np.ndarray, azimuth: float, elevation: float,
               fovy: float, aspect: float, band: float, min_distance: float) -> tuple[np.ndarray, float]:
    """Look-at point (3,) m and distance (m) at which spheres ``centres`` (N, 3) m of ``radii`` (N,) m all show
    inside the image below a caption band covering the top ``band`` fraction of its height.

    The look-at point stays above ``xy`` (2,) m; its height centres the spheres' vertical extent in the free part
    of the image, and the distance is the smallest of a geometric sequence from ``min_distance`` (growing by 4 %)
    at which they fit (``min_distance`` itself when they already do)."""
    centres = np.asarray(centres, dtype=np.float64).reshape(-1, 3)
    radii = np.asarray(radii, dtype=np.float64).reshape(-1)
    _, up, right = camera_axes(azimuth, elevation)
    # Each sphere's top, bottom, left and right edge as seen from the camera.
    offsets = np.stack([up, -up, right, -right])
    pts = (centres[:, None, :] + radii[:, None, None] * offsets[None]).reshape(-1, 3)
    top, bottom = 1.0 - 2.0 * band - MARGIN, -1.0 + MARGIN
    t = np.tan(np.radians(fovy) / 2.0)
    z = 0.5 * (centres[:, 2].min() + centres[:, 2].max()) if len(centres) else 1.0
    distance = float(min_distance)
    for _ in range(200):  # 1.04 ** 200: a distance 2,500 times the floor, far beyond any scene
        for _ in range(3):  # centre the vertical extent in the free part (ndc is close to linear in the height)
            y = project(pts, np.array([xy[0], xy[1], z]), distance, azimuth, elevation, fovy, aspect)[:, 1]
            if len(y) == 0 or not np.isfinite(y).all():
                break
            z += 0.5 * (y.max() + y.min() - top - bottom) * distance * t
        ndc = project(pts, np.array([xy[0], xy[1], z]), distance, azimuth, elevation, fovy, aspect)
        if len(ndc) == 0 or (np.isfinite(ndc).all() and ndc[:, 1].max() <= top and ndc[:, 1].min() >= bottom
                             and np.abs(ndc[:, 0]).max() <= 1.0 - MARGIN):
            break
        distance *= 1.04
    return np.array([xy[0], xy[1], z]), distance
