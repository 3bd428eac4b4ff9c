"""Path noise: the frames inside a sub-event scored against the straight path between its ends.

Our addition to the paper's model (``AffordanceConfig.path_noise``). The paper's potentials see
two configurations per sub-event — the last frame before it and its last frame — so the frames
in between are not modelled at all, and parses that differ only in where the in-between motion
goes (a reach-and-return lumped into one interval, a still moment cut into a tiny one) are scored
alike. The path term generates those frames: joint j at interior frame t of an interval anchored
at frame a (the last frame before the interval, or frame 0 for the first interval) and ending at
frame e is

    x_t[j] ~ N(x_a[j] + u((t − a) / (e − a)) (x_e[j] − x_a[j]), σ_sj² I₃),

a straight path between the ends covered with the time profile u (``AffordanceConfig.path_profile``:
minimum jerk by default, the profile of a point-to-point human movement; or constant speed), with
isotropic Gaussian noise of standard deviation σ_sj (metres) per sub-event type s and joint j,
fitted by maximum likelihood (σ² = mean squared residual per coordinate, floored at
``path_sigma_min``). Interior frames are a < t < e; the anchor and end frames are the potentials'
business. The term is scored at its maximum-likelihood σ under either ``likelihood`` setting.

Residual sums of all candidate intervals of a track come from prefix sums in O(T + M).
"""

from __future__ import annotations

import numpy as np

__all__ = ["PATH_PROFILES", "PROFILE_POLYNOMIALS", "profile", "path_residuals", "fit_path_noise", "path_loglik"]

_LOG_2PI = float(np.log(2.0 * np.pi))
_CHUNK = 1 << 16  # most (interval, frame) pairs gathered at once


PATH_PROFILES = ("minjerk", "linear")
"""Valid time profiles u(v) of the path between a sub-event's ends (v = elapsed fraction)."""


PROFILE_POLYNOMIALS: dict[str, tuple[tuple[int, float], ...]] = {
    "minjerk": ((3, 10.0), (4, -15.0), (5, 6.0)),
    "linear": ((1, 1.0),),
}
"""Each profile u(v) of :func:`profile` as its monomials (power p, coefficient c_p): u(v) = Σ c_p v^p. What the
forward belief's running path sums (:mod:`~socialaff_sim.inference.path_sums`) expand the path in."""


def profile(v: np.ndarray, kind: str) -> np.ndarray:
    """Fraction u ∈ [0, 1] of the way covered at elapsed fraction v ∈ [0, 1]: ``"minjerk"``
    10v³ − 15v⁴ + 6v⁵ (a minimum-jerk point-to-point movement, Flash & Hogan 1985) or ``"linear"`` v."""
    if kind == "linear":
        return v
    return v**3 * (10.0 - 15.0 * v + 6.0 * v * v)


def path_residuals(
    x: np.ndarray, starts: np.ndarray, stops: np.ndarray, kind: str = "minjerk"
) -> tuple[np.ndarray, np.ndarray]:
    """Squared residuals from the path of intervals ``[starts[m], stops[m])`` of a track.

    ``x``: (T, J, 3) float64, metres; ``kind``: the time profile (:data:`PATH_PROFILES`). Returns
    ``sq`` (M, J) float64, m², the sum over the interval's interior frames of each joint's squared
    distance from its path (NaN for a joint with NaN coordinates), and ``n`` (M,) int64, the number
    of interior frames.
    """
    x = np.asarray(x, float)
    starts = np.asarray(starts, np.int64).reshape(-1)
    stops = np.asarray(stops, np.int64).reshape(-1)
    a = np.maximum(starts - 1, 0)
    e = stops - 1
    n = np.maximum(e - a - 1, 0)
    M, J = starts.shape[0], x.shape[1]
    width = int(n.max()) if M else 0
    if width == 0:
        sq = np.where(np.isnan(x[e]).any(axis=-1), np.nan, 0.0) if M else np.zeros((0, J))
        return sq, n
    if M * width > _CHUNK:  # bound the (M, W, J, 3) temporaries on long recordings
        step = max(1, _CHUNK // width)
        parts = [path_residuals(x, starts[i : i + step], stops[i : i + step], kind)[0] for i in range(0, M, step)]
        return np.concatenate(parts), n
    k = np.arange(1, width + 1)
    mask = k[None, :] <= n[:, None]  # (M, W): interior frame a + k exists
    t = np.where(mask, a[:, None] + k[None, :], a[:, None])
    v = k[None, :] / np.maximum(e - a, 1)[:, None]
    u = profile(np.minimum(v, 1.0), kind)
    xa, xe = x[a], x[e]  # (M, J, 3)
    pred = xa[:, None] + u[:, :, None, None] * (xe - xa)[:, None]
    r = x[t] - pred  # (M, W, J, 3)
    sq = np.einsum("mwjd,mwjd,mw->mj", r, r, mask.astype(float))
    return sq, n


def fit_path_noise(
    sq: np.ndarray, n: np.ndarray, sigma_min: float, available: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Maximum-likelihood σ (J,) metres of N intervals' residual sums ``sq`` (N, J), interior counts
    ``n`` (N,), with the log-likelihood (J,) of their residuals at that σ; σ is floored at
    ``sigma_min``. Joints with NaN sums, or outside ``available`` (J,) bool when given, get
    σ = NaN and log-likelihood 0."""
    sq = np.asarray(sq, float)
    if available is not None:
        sq = np.where(np.asarray(available, bool), sq, np.nan)
    frames = float(np.sum(n))
    total = sq.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        var = total / (3.0 * frames) if frames > 0 else np.zeros_like(total)
    sigma = np.sqrt(np.maximum(var, sigma_min**2))
    sigma = np.where(np.isnan(total), np.nan, sigma)
    ll = path_loglik(sq, n, sigma).sum(axis=0) if sq.shape[0] else np.zeros(sq.shape[1])
    return sigma, ll


def path_loglik(sq: np.ndarray, n: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """(M, J) log-likelihood of M intervals' interior frames per joint under noise σ (J,) metres
    (0 where σ is NaN, i.e. for joints the model does not use)."""
    sq = np.asarray(sq, float)
    nf = np.asarray(n, float)[:, None]
    use = np.isfinite(sigma)
    s2 = np.where(use, sigma, 1.0) ** 2
    out = -1.5 * nf * (_LOG_2PI + np.log(s2)) - sq / (2.0 * s2)
    return np.where(use, out, 0.0)
