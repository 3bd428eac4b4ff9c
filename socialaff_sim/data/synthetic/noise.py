"""Kinect-like corruption of clean joints: correlated jitter, louder occluded hands, dropouts.

The jitter of every coordinate is a stationary AR(1) process in time with
standard deviation σ_j (σ_o for hand joints occluded in a contact) and lag-one
autocorrelation ρ, like the smoothed noise of a depth-camera tracker. Each
joint in each frame is independently untracked with probability p_d (p_o when
occluded); untracked joints get NaN coordinates and ``valid`` False. The
random numbers are drawn in a fixed order and amount whatever the settings, so
changing one level does not reshuffle the others.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from .config import SyntheticConfig

__all__ = ["ar1_noise", "corrupt_joints", "corrupt_object"]


def ar1_noise(rng: np.random.Generator, shape: tuple[int, ...], rho: float) -> np.ndarray:
    """Unit-variance stationary AR(1) noise along axis 0: x_t = ρ·x_{t−1} + √(1−ρ²)·e_t.

    Args:
        rng: the caller's generator.
        shape: (T, ...) output shape; the process runs along the first axis.
        rho: lag-one autocorrelation in [0, 1).

    Returns:
        ``shape`` float64 with marginal N(0, 1) entries.
    """
    draws = rng.standard_normal((shape[0] + 1, *shape[1:]))
    previous, innovations = draws[:1], draws[1:]  # x_{-1} from the stationary law
    return lfilter([np.sqrt(1.0 - rho**2)], [1.0, -rho], innovations, axis=0, zi=rho * previous)[0]


def corrupt_joints(
    joints: np.ndarray, occluded: np.ndarray, rng: np.random.Generator, config: SyntheticConfig
) -> tuple[np.ndarray, np.ndarray]:
    """Add jitter and dropouts.

    Args:
        joints: (T, 2, J, 3) clean joints, metres.
        occluded: (T, 2, J) bool, joints hidden in a contact.
        rng: the caller's generator.
        config: noise levels σ_j, σ_o, ρ, p_d, p_o.

    Returns:
        ``(noisy, valid)``: (T, 2, J, 3) float64 with NaN where untracked, and (T, 2, J) bool.
    """
    jitter = ar1_noise(rng, joints.shape, config.jitter_correlation)
    sd = np.where(occluded, config.occluded_jitter_sd, config.jitter_sd)
    noisy = joints + sd[..., None] * jitter
    drop = rng.random(occluded.shape) < np.where(occluded, config.occluded_dropout, config.dropout)
    noisy[drop] = np.nan
    return noisy, ~drop


def corrupt_object(track: np.ndarray, rng: np.random.Generator, config: SyntheticConfig) -> np.ndarray:
    """(T, 3) object track plus white jitter of σ_b metres per axis (never dropped)."""
    return track + config.object_jitter_sd * rng.standard_normal(track.shape)
