"""The motion features' compiled kernel (``SynthesisConfig.kernel = "numba"``): the causal reactor's one feature row
per frame (:meth:`~.reaction_features.FeatureStream.rows` of the frame just seen) in one compiled call instead of
about thirty small NumPy calls.

The row is :meth:`~.reaction_features.Anchor.features` of agent 0's newest held key joints and their window slope
(:func:`~.reaction_features.velocity_estimate` over the last K frames), the same arithmetic in loops: the 3×3
rotations and the slope's weighted sum are summed in index order, where NumPy's matrix products may use BLAS (fused
multiply-adds, another order), and ``expm1`` is the C library's; so the row equals NumPy's to rounding, not bitwise
(docs/design.md §7, "Compiled kernels under a declared tolerance"; tests/test_feature_kernel.py holds it within
1e-12 relative). NaN becomes 0 and ±inf ±the largest float, as ``np.nan_to_num``.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from . import compiled

__all__ = ["feature_row", "feature_row_python", "kernels"]

_BIG = float(np.finfo(np.float64).max)
COLUMNS = (15, 18, 19, 34, 49)
"""Where the kernel writes the groups: agent0 [0, 15), gap [15, 18) and its ramp 18, own_velocity [19, 34),
agent0_velocity [34, 49) (five key joints; tests/test_feature_kernel.py checks them against the feature layout)."""


def feature_row_python(out: np.ndarray, win: np.ndarray, fps: float, rot: np.ndarray, keys0: np.ndarray,
                       base1: np.ndarray, velocity1: np.ndarray, s: float, tau: float, agent0: bool, own: bool,
                       velocity0: bool) -> None:
    """Fill ``out`` (N_FEATURES,) with the features of one frame: ``win`` (K, 5, 3) agent 0's last K held key joints
    (world, metres; the newest last), ``fps`` frames/s, ``rot`` (3, 3) the anchor frame's rotation, ``keys0`` (5, 3)
    and ``base1`` (3,) the anchor's agent-0 key joints and agent-1 base (world), ``velocity1`` (15,) agent 1's
    observed velocity (anchor frame, m/s), ``s`` seconds since the anchor, ``tau`` τ (s); the groups ``agent0``,
    ``own`` (own_velocity) and ``velocity0`` (agent0_velocity) computed or left zero (``gap`` always)."""
    for i in range(out.shape[0]):
        out[i] = 0.0
    k = win.shape[0]
    last = k - 1
    ramp = -math.expm1(-s / tau)
    if agent0:
        for j in range(5):
            for c in range(3):
                acc = 0.0
                for m in range(3):
                    acc += (win[last, j, m] - keys0[j, m]) * rot[m, c]
                out[3 * j + c] = acc
    for c in range(3):
        acc = 0.0
        for m in range(3):
            acc += (win[last, 0, m] - base1[m]) * rot[m, c]
        out[15 + c] = acc
    out[18] = ramp
    if own:
        for i in range(15):
            out[19 + i] = (tau * ramp) * velocity1[i]
    if velocity0 and k >= 2:
        half = (k - 1) / 2.0
        tt = 0.0
        for q in range(k):
            tt += (q - half) * (q - half)
        for j in range(5):
            vel = np.zeros(3)
            for m in range(3):
                acc = 0.0
                for q in range(k):
                    acc += (q - half) * win[q, j, m]
                vel[m] = acc / tt * fps
            for c in range(3):
                acc = 0.0
                for m in range(3):
                    acc += vel[m] * rot[m, c]
                out[34 + 3 * j + c] = acc
    for i in range(out.shape[0]):  # np.nan_to_num of agent0, gap (before its ramp) and agent0_velocity
        if 18 <= i < 34:
            continue
        v = out[i]
        if v != v:
            out[i] = 0.0
        elif v > _BIG:
            out[i] = _BIG
        elif v < -_BIG:
            out[i] = -_BIG
    for c in range(3):
        out[15 + c] *= ramp


def _build_features() -> dict[str, Callable[..., None]]:
    return {"feature_row": compiled.njit(feature_row_python)}


def _warm_features(built: dict[str, Callable[..., None]]) -> None:
    """Compiled now for the argument types the stream passes, on a two-frame window."""
    win = np.zeros((2, 5, 3))
    built["feature_row"](np.zeros(49), win, 1.0, np.eye(3), np.zeros((5, 3)), np.zeros(3), np.zeros(15), 1.0, 1.0, True,
                         True, True)


def kernels() -> dict[str, Callable[..., None]]:
    """The compiled kernels by name (``"feature_row"``), compiled on the first call in a process (or loaded from
    numba's on-disk cache) for the argument types the stream passes (:func:`~.compiled.once`); a ConfigError naming the
    ``[fast]`` extra when numba is missing."""
    return compiled.once(__name__, _build_features, _warm_features)


def feature_row(out: np.ndarray, win: np.ndarray, fps: float, rot: np.ndarray, keys0: np.ndarray, base1: np.ndarray,
                velocity1: np.ndarray, s: float, tau: float, agent0: bool, own: bool, velocity0: bool) -> None:
    """:func:`feature_row_python`, compiled (:func:`kernels`)."""
    kernels()["feature_row"](out, win, fps, rot, keys0, base1, velocity1, s, tau, agent0, own, velocity0)
