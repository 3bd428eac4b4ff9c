"""Rotations and the analytic two-link inverse kinematics used for arms and legs.

Every function is vectorised over leading axes (usually frames T).
"""

from __future__ import annotations

import numpy as np

__all__ = ["unit", "rot_z", "rot_y", "apply", "two_link_ik"]

_EPS = 1e-12


def unit(v: np.ndarray) -> np.ndarray:
    """``v`` divided by its norm along the last axis (zero vectors stay zero)."""
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.maximum(n, _EPS)


def rot_z(angle: np.ndarray | float) -> np.ndarray:
    """(..., 3, 3) rotations by ``angle`` (radians) about the vertical z axis."""
    a = np.asarray(angle, dtype=np.float64)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def rot_y(angle: np.ndarray | float) -> np.ndarray:
    """(..., 3, 3) rotations by ``angle`` (radians) about y; a positive angle tips +z toward +x."""
    a = np.asarray(angle, dtype=np.float64)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2)


def apply(rot: np.ndarray, vec: np.ndarray) -> np.ndarray:
    """Rotate vectors: ``rot`` (T, 3, 3) times ``vec`` (3,) or (T, 3) → (T, 3)."""
    return np.einsum("...ij,...j->...i", rot, vec)


def _perpendicular(d: np.ndarray) -> np.ndarray:
    """A unit vector perpendicular to each unit vector in ``d`` (T, 3)."""
    helper = np.where(np.abs(d[..., 2:3]) < 0.9, np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]))
    return unit(np.cross(d, helper))


def two_link_ik(
    root: np.ndarray,
    target: np.ndarray,
    upper: float,
    lower: float,
    pole: np.ndarray,
    *,
    max_extension: float = 0.999,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Place the middle joint of a two-bone chain so that its end reaches ``target``.

    The chain root (shoulder or hip) is fixed; the middle joint (elbow or knee)
    is put in the plane spanned by the root→target direction and the ``pole``
    vector, on the pole's side, which gives a natural bend direction. A target
    farther than ``max_extension·(upper + lower)`` (or nearer than
    ``|upper − lower|``) is moved along the root→target line to the nearest
    reachable distance, so bones keep their lengths exactly.

    Args:
        root: (T, 3) chain root, metres.
        target: (T, 3) desired end point, metres.
        upper: root→middle bone length, metres.
        lower: middle→end bone length, metres.
        pole: (T, 3) or (3,) bend direction hint (need not be unit or perpendicular).
        max_extension: fraction of the full length the chain may straighten to.

    Returns:
        ``(middle, end, bend)``: (T, 3) middle joint and reached end point, metres,
        and the (T, 3) unit bend direction (perpendicular to root→end, toward the middle joint).
    """
    d = target - root
    dist = np.linalg.norm(d, axis=-1, keepdims=True)
    dhat = np.where(dist > _EPS, d / np.maximum(dist, _EPS), np.array([0.0, 0.0, -1.0]))
    lo = abs(upper - lower) + 1e-6
    hi = max_extension * (upper + lower)
    reach = np.clip(dist, lo, hi)
    cos_a = np.clip((upper**2 + reach**2 - lower**2) / (2.0 * upper * reach), -1.0, 1.0)
    sin_a = np.sqrt(1.0 - cos_a**2)
    pole = np.broadcast_to(np.asarray(pole, dtype=np.float64), d.shape)
    perp = pole - np.sum(pole * dhat, axis=-1, keepdims=True) * dhat
    norm = np.linalg.norm(perp, axis=-1, keepdims=True)
    bend = np.where(norm > 1e-6, perp / np.maximum(norm, _EPS), _perpendicular(dhat))
    middle = root + upper * (cos_a * dhat + sin_a * bend)
    end = middle + lower * unit(root + reach * dhat - middle)
    return middle, end, bend
