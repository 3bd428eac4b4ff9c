"""Timing helpers of Algorithm 2: the remaining duration of the running sub-event and the share
of the remaining way covered at each frame."""

from __future__ import annotations

import numpy as np
from scipy.special import ndtr, ndtri

from ..model.path import profile

__all__ = ["sample_remaining_seconds", "remaining_fraction"]


def sample_remaining_seconds(
    mu: float, sigma: float, elapsed: float, rng: np.random.Generator, *, median: bool = False
) -> float:
    """A total duration D > ``elapsed`` (seconds) from LogNormal(μ, σ) conditioned on D > elapsed.

    Inverse-CDF sampling on the truncated part: u ~ U(F(elapsed), 1), D = F⁻¹(u);
    ``median`` takes u halfway instead.
    """
    if not (np.isfinite(mu) and np.isfinite(sigma)):
        return elapsed
    lo = float(ndtr((np.log(max(elapsed, 1e-9)) - mu) / sigma))
    u = lo + (1.0 - lo) * (0.5 if median else float(rng.random()))
    u = min(max(u, lo), 1.0 - 1e-12)
    return max(float(np.exp(mu + sigma * ndtri(u))), elapsed)


def remaining_fraction(frames: np.ndarray, prev: int, anchor: int, last: int) -> np.ndarray:
    """(F,) share w ∈ [0, 1] of the remaining way, from frame ``prev`` to the end frame ``last``, covered
    at ``frames`` under the minimum-jerk profile u of a movement from frame ``anchor`` to ``last``:
    w = (u(v_f) − u(v_prev)) / (1 − u(v_prev)), v = (f − anchor) / (last − anchor), clipped to [0, 1];
    w = 1 from ``last`` on."""
    span = max(last - anchor, 1)
    v = ((np.asarray(frames, float) - anchor) / span).clip(0.0, 1.0)
    u0 = float(profile(np.array(min(max((prev - anchor) / span, 0.0), 1.0)), "minjerk"))
    if u0 >= 1.0:
        return np.ones(v.shape)
    return ((profile(v, "minjerk") - u0) / (1.0 - u0)).clip(0.0, 1.0)
