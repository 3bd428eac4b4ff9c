"""Log-densities and maximum-likelihood fits of the model's distributions, vectorized.

The densities (all natural-log, broadcasting over their arguments):

* Weibull ``f(x; k, λ) = (k/λ) (x/λ)^(k−1) exp(−(x/λ)^k)``, x ≥ 0 (``scipy.stats.weibull_min(k, scale=λ)``);
* von Mises ``f(θ; μ, κ) = exp(κ cos(θ − μ)) / (2π I0(κ))`` on the circle (``scipy.stats.vonmises(κ, loc=μ)``);
* exponential ``f(x; m) = exp(−x/m) / m``, x ≥ 0, with mean m (``scipy.stats.expon(scale=m)``);
* log-normal ``f(x; μ, σ) = exp(−(log x − μ)² / 2σ²) / (x σ √(2π))`` (``scipy.stats.lognorm(σ, scale=e^μ)``).

The fits take a batch of rows ``(B, N)`` (B independent samples of size N, the
same N for every row) and return per-row parameters and the log-likelihood at
the fitted parameters. They use closed forms where they exist (exponential,
log-normal, the Weibull scale given its shape, the von Mises mean) and a few
safeguarded Newton steps otherwise (the Weibull shape on its profile likelihood,
the von Mises concentration on A(κ) = I1(κ)/I0(κ) = R̄). Degenerate samples are
guarded by the documented floors of :class:`~socialaff_sim.model.config.AffordanceConfig`:
values below ``eps`` are raised to ``eps``; the Weibull shape is clamped to
``[shape_min, shape_max]``; κ is capped at ``kappa_max``; σ is floored at
``sigma_min``. With N = 0 a row has NaN parameters and log-likelihood 0.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.special import i0e, i1e

__all__ = [
    "weibull_logpdf",
    "weibull_terms",
    "vonmises_logpdf",
    "expon_logpdf",
    "lognorm_logpdf",
    "WeibullFit",
    "VonMisesFit",
    "ExponFit",
    "LogNormFit",
    "fit_weibull",
    "fit_vonmises",
    "fit_expon",
    "fit_lognorm",
    "vonmises_mean_resultant",
    "leave_one_out_rows",
    "heldout_weibull",
    "heldout_vonmises",
    "heldout_expon",
    "heldout_lognorm",
]

LOG_2PI = float(np.log(2.0 * np.pi))


# -- log-densities ----------------------------------------------------------------------
def weibull_terms(k: np.ndarray | float, lam: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """log(k / λ), k − 1 and k == 1 of Weibull parameter rows: what :func:`weibull_logpdf` computes of the parameters
    alone, for a caller that scores the same rows again (the reactor's tables, every frame)."""
    k, lam = np.asarray(k, float), np.asarray(lam, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.log(k / lam), k - 1.0, k == 1.0


def weibull_logpdf(
    x: np.ndarray, k: np.ndarray | float, lam: np.ndarray | float,
    *, terms: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """log f(x; k, λ) of the two-parameter Weibull; −inf for x < 0 (x = 0 follows the limit). ``terms``:
    :func:`weibull_terms` of (k, λ) when the caller keeps them (the same values as computed here)."""
    x, k, lam = np.asarray(x, float), np.asarray(k, float), np.asarray(lam, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = x / lam
        logz = np.log(z)
        # The parameters' terms on their own shape (K parameter rows, not N × K): the same values, broadcast.
        log_k_lam, k_minus_1, k_is_1 = weibull_terms(k, lam) if terms is None else terms
        core = log_k_lam - z**k
        # (k - 1) * log z with the convention 0 * log 0 = 0 (k = 1 at x = 0).
        term = np.where(k_is_1, 0.0, k_minus_1 * logz)
        out = core + term
    return np.where(x < 0, -np.inf, out)


def vonmises_logpdf(
    theta: np.ndarray, mu: np.ndarray | float, kappa: np.ndarray | float, *, log_i0e: np.ndarray | None = None
) -> np.ndarray:
    """log f(θ; μ, κ) of the von Mises distribution (periodic in θ, radians). ``log_i0e``: log i0e(κ) when the caller
    already has it (a table scoring the same rows every frame), the same values as computed here."""
    theta = np.asarray(theta, float)
    kappa = np.asarray(kappa, float)
    return kappa * (np.cos(theta - mu) - 1.0) - LOG_2PI - (np.log(i0e(kappa)) if log_i0e is None else log_i0e)


def expon_logpdf(x: np.ndarray, mean: np.ndarray | float) -> np.ndarray:
    """log f(x; m) of the exponential with mean m; −inf for x < 0."""
    x = np.asarray(x, float)
    mean = np.asarray(mean, float)
    return np.where(x < 0, -np.inf, -np.log(mean) - x / mean)


def lognorm_logpdf(x: np.ndarray, mu: np.ndarray | float, sigma: np.ndarray | float) -> np.ndarray:
    """log f(x; μ, σ) of the log-normal (μ, σ of log x); −inf for x ≤ 0."""
    x = np.asarray(x, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        lx = np.log(x)
        out = -lx - np.log(sigma) - 0.5 * LOG_2PI - 0.5 * ((lx - mu) / sigma) ** 2
    return np.where(x > 0, out, -np.inf)


# -- fits ----------------------------------------------------------------------------------
class WeibullFit(NamedTuple):
    """Per-row Weibull fit: ``shape`` k, ``scale`` λ (metres), ``loglik`` (all (B,))."""

    shape: np.ndarray
    scale: np.ndarray
    loglik: np.ndarray


class VonMisesFit(NamedTuple):
    """Per-row von Mises fit: ``mu`` (radians), ``kappa``, ``loglik`` (all (B,))."""

    mu: np.ndarray
    kappa: np.ndarray
    loglik: np.ndarray


class ExponFit(NamedTuple):
    """Per-row exponential fit: ``mean`` m, ``loglik`` (both (B,))."""

    mean: np.ndarray
    loglik: np.ndarray


class LogNormFit(NamedTuple):
    """Per-row log-normal fit: ``mu``, ``sigma`` (of log x), ``loglik`` (all (B,))."""

    mu: np.ndarray
    sigma: np.ndarray
    loglik: np.ndarray


def _rows(x: np.ndarray) -> np.ndarray:
    x = np.asarray(x, float)
    return x[None, :] if x.ndim == 1 else x


def row_mean(x: np.ndarray) -> np.ndarray:
    """(B,) the mean of each row of ``x`` (B, N): ``x.mean(axis=1)``'s very sum and division, without its
    Python overhead (the fits below run on small arrays many thousand times per learning run)."""
    return np.add.reduce(x, axis=1) / x.shape[1]


def row_std(x: np.ndarray) -> np.ndarray:
    """(B,) the standard deviation of each row of ``x`` (B, N): ``x.std(axis=1)``'s very operations."""
    d = x - np.add.reduce(x, axis=1, keepdims=True) / x.shape[1]
    return np.sqrt(np.add.reduce(np.square(d), axis=1) / x.shape[1])


def fit_weibull(
    x: np.ndarray,
    *,
    eps: float = 1e-3,
    shape_min: float = 0.3,
    shape_max: float = 20.0,
    tol: float = 1e-10,
    max_steps: int = 30,
    k0: np.ndarray | None = None,
) -> WeibullFit:
    """Maximum-likelihood Weibull per row of ``x`` (B, N) (a 1-D x is one row).

    Values are floored at ``eps``. The shape k solves the profile-likelihood
    equation g(k) = Σ x^k log x / Σ x^k − 1/k − mean(log x) = 0, which is
    increasing in k with g'(k) = Var_w(log x) + 1/k² (weights ∝ x^k); Newton
    steps are taken in log k from the moment estimate k₀ = π / (√6 · sd(log x))
    (or from ``k0`` (B,), a warm start, when given) until the step is below ``tol``, and the result is clamped to
    ``[shape_min, shape_max]`` (all-equal values or N = 1 give ``shape_max``).
    The scale is then closed-form, λ = (mean x^k)^(1/k), and the log-likelihood
    N log k − N k log λ + (k − 1) Σ log x − N.
    """
    x = np.maximum(_rows(x), eps)
    B, N = x.shape
    if N == 0:
        nan = np.full(B, np.nan)
        return WeibullFit(nan, nan.copy(), np.zeros(B))
    L = np.log(x)
    Lbar = row_mean(L)
    Lmax = np.maximum.reduce(L, axis=1)
    u = L - Lmax[:, None]  # shift: x^k / max^k = exp(k u) <= 1
    sd = row_std(L)
    k = np.where(sd > 0, np.pi / (np.sqrt(6.0) * np.where(sd > 0, sd, 1.0)), shape_max)
    if k0 is not None:
        k = np.where(sd > 0, np.asarray(k0, float), shape_max)
    k = np.minimum(np.maximum(k, shape_min), shape_max)
    active = sd > 1e-12
    Lc = L - Lbar[:, None]  # centring keeps the weighted moments well conditioned
    # A finished row keeps its k, so only the others need stepping. Stepping a subset of the rows is
    # bitwise the same for C-ordered rows (each row's sums are its own); the other layouts step them all.
    subset = bool(x.flags.c_contiguous)
    for _ in range(max_steps):
        n_active = int(np.count_nonzero(active))
        if not n_active:
            break
        if subset and 2 * n_active <= B:  # gathering pays when at most half the rows are left
            rows = np.flatnonzero(active)
            kr, ur, Lr = k[rows], u[rows], Lc[rows]
        else:
            rows = slice(None)
            kr, ur, Lr = k, u, Lc
        e = np.exp(kr[:, None] * ur)
        eL = e * Lr
        s0 = np.add.reduce(e, axis=1)
        m1 = np.add.reduce(eL, axis=1) / s0
        m2 = np.add.reduce(eL * Lr, axis=1) / s0
        g = m1 - 1.0 / kr
        dg = (m2 - m1 * m1) + 1.0 / (kr * kr)
        step = np.where(active[rows], np.minimum(np.maximum(g / (kr * dg), -2.0), 2.0), 0.0)  # Newton in log k
        k_new = np.minimum(np.maximum(kr * np.exp(-step), shape_min), shape_max)
        # A row is done when its step is below tol or it is stuck at a clamp.
        active[rows] &= (np.abs(step) > tol) & (k_new != kr)
        k[rows] = k_new
    e = np.exp(k[:, None] * u)
    log_mean_xk = np.log(row_mean(e)) + k * Lmax
    log_lam = log_mean_xk / k
    lam = np.exp(log_lam)
    ll = N * np.log(k) - N * k * log_lam + (k - 1.0) * np.add.reduce(L, axis=1) - N
    return WeibullFit(k, lam, ll)


def vonmises_mean_resultant(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean direction μ and mean resultant length R̄ per row of ``theta`` (B, N)."""
    theta = _rows(theta)
    c = row_mean(np.cos(theta))
    s = row_mean(np.sin(theta))
    return np.arctan2(s, c), np.hypot(c, s)


def _a_ratio(kappa: np.ndarray) -> np.ndarray:
    return i1e(kappa) / i0e(kappa)


def fit_vonmises(
    theta: np.ndarray, *, kappa_max: float = 200.0, tol: float = 1e-12, max_steps: int = 20, kappa0: np.ndarray | None = None
) -> VonMisesFit:
    """Maximum-likelihood von Mises per row of ``theta`` (B, N).

    μ = atan2(mean sin, mean cos); κ solves A(κ) = I1(κ)/I0(κ) = R̄, started at
    R̄(2 − R̄²)/(1 − R̄²) (or at ``kappa0`` (B,), a warm start, when given) and refined by Newton with A'(κ) = 1 − A/κ − A²,
    capped at ``kappa_max`` (R̄ = 1, e.g. N = 1, gives ``kappa_max``).
    Log-likelihood: N (κ R̄ − κ − log 2π − log i0e(κ)).
    """
    theta = _rows(theta)
    B, N = theta.shape
    if N == 0:
        nan = np.full(B, np.nan)
        return VonMisesFit(nan, nan.copy(), np.zeros(B))
    mu, R = vonmises_mean_resultant(theta)
    R = np.minimum(R, 1.0)
    a_max = float(_a_ratio(np.array(kappa_max)))
    capped = R >= a_max
    Rs = np.where(capped, 0.5, R)
    kappa = Rs * (2.0 - Rs * Rs) / (1.0 - Rs * Rs)
    if kappa0 is not None:
        kappa = np.where(np.isfinite(kappa0) & (kappa0 > 0), np.minimum(kappa0, kappa_max), kappa)
    for _ in range(max_steps):
        A = _a_ratio(kappa)
        dA = 1.0 - A / np.maximum(kappa, 1e-300) - A * A
        dA = np.where(kappa > 1e-8, dA, 0.5)
        step = (A - Rs) / dA
        kappa = np.maximum(kappa - step, 0.5 * kappa)  # never jump below zero
        if np.logical_and.reduce(np.abs(step) <= tol * np.maximum(kappa, 1.0)):  # np.all without its wrapper
            break
    kappa = np.where(capped, kappa_max, np.minimum(kappa, kappa_max))
    ll = N * (kappa * R - kappa - LOG_2PI - np.log(i0e(kappa)))
    return VonMisesFit(mu, kappa, ll)


def fit_expon(x: np.ndarray, *, eps: float = 1e-3) -> ExponFit:
    """Maximum-likelihood exponential per row of ``x`` (B, N): m = mean(max(x, eps)); log-lik −N log m − N."""
    x = np.maximum(_rows(x), eps)
    B, N = x.shape
    if N == 0:
        return ExponFit(np.full(B, np.nan), np.zeros(B))
    m = x.mean(axis=1)
    return ExponFit(m, -N * np.log(m) - N)


def fit_lognorm(x: np.ndarray, *, sigma_min: float = 0.05) -> LogNormFit:
    """Maximum-likelihood log-normal per row of ``x`` (B, N) of positive values.

    μ = mean(log x), σ = max(sd(log x), sigma_min) (the ML σ when above the floor);
    the log-likelihood is evaluated at these parameters.
    """
    x = _rows(x)
    B, N = x.shape
    if N == 0:
        nan = np.full(B, np.nan)
        return LogNormFit(nan, nan.copy(), np.zeros(B))
    L = np.log(x)
    mu = L.mean(axis=1)
    var = ((L - mu[:, None]) ** 2).mean(axis=1)
    sigma = np.maximum(np.sqrt(var), sigma_min)
    ll = -L.sum(axis=1) - N * np.log(sigma) - 0.5 * N * LOG_2PI - 0.5 * N * var / sigma**2
    return LogNormFit(mu, sigma, ll)


# -- held-out (leave-one-out) log-likelihoods -------------------------------------------------
# Σ_n log f(x_n; θ̂_−n): every sample is scored under the parameters fitted to the other N − 1
# samples of its row. Unlike the maximized log-likelihood Σ_n log f(x_n; θ̂), it does not
# reward a fit to few or near-identical samples (a Weibull shape or a κ pushed to its cap by
# a tight sample costs dearly when one held-out sample falls outside). A row with N < 2 has no
# held-out fit and keeps its maximized log-likelihood (documented fallback); N = 0 gives 0.


def leave_one_out_rows(x: np.ndarray) -> np.ndarray:
    """(B, N, N − 1): row b, slice n holds the samples of row b of ``x`` (B, N) without sample n."""
    x = _rows(x)
    N = x.shape[1]
    idx = np.arange(N)
    keep = np.broadcast_to(idx, (N, N))[~np.eye(N, dtype=bool)].reshape(N, N - 1)
    return x[:, keep]


def heldout_weibull(
    x: np.ndarray, *, eps: float = 1e-3, shape_min: float = 0.3, shape_max: float = 20.0, full: WeibullFit | None = None
) -> np.ndarray:
    """(B,) held-out Weibull log-likelihood per row of ``x`` (B, N), values floored at ``eps``.

    ``full``: the rows' full-sample fit when already known (its shapes warm-start the held-out fits)."""
    x = np.maximum(_rows(x), eps)
    B, N = x.shape
    if full is None:
        full = fit_weibull(x, eps=eps, shape_min=shape_min, shape_max=shape_max)
    if N < 2:
        return full.loglik
    f = fit_weibull(
        leave_one_out_rows(x).reshape(B * N, N - 1), eps=eps, shape_min=shape_min, shape_max=shape_max,
        k0=np.repeat(full.shape, N),  # warm start: the held-out shapes are near the full-sample one
    )
    return weibull_logpdf(x.reshape(-1), f.shape, f.scale).reshape(B, N).sum(axis=1)


def heldout_vonmises(theta: np.ndarray, *, kappa_max: float = 200.0, full: VonMisesFit | None = None) -> np.ndarray:
    """(B,) held-out von Mises log-likelihood per row of ``theta`` (B, N).

    ``full``: the rows' full-sample fit when already known (its κ warm-start the held-out fits)."""
    theta = _rows(theta)
    B, N = theta.shape
    if full is None:
        full = fit_vonmises(theta, kappa_max=kappa_max)
    if N < 2:
        return full.loglik
    f = fit_vonmises(leave_one_out_rows(theta).reshape(B * N, N - 1), kappa_max=kappa_max, kappa0=np.repeat(full.kappa, N))
    return vonmises_logpdf(theta.reshape(-1), f.mu, f.kappa).reshape(B, N).sum(axis=1)


def heldout_expon(x: np.ndarray, *, eps: float = 1e-3) -> np.ndarray:
    """(B,) held-out exponential log-likelihood per row of ``x`` (B, N); the held-out mean is
    closed-form, m_−n = (Σ x − x_n) / (N − 1)."""
    x = np.maximum(_rows(x), eps)
    B, N = x.shape
    if N < 2:
        return fit_expon(x, eps=eps).loglik
    m = (x.sum(axis=1, keepdims=True) - x) / (N - 1)
    return expon_logpdf(x, m).sum(axis=1)


def heldout_lognorm(x: np.ndarray, *, sigma_min: float = 0.05) -> np.ndarray:
    """(B,) held-out log-normal log-likelihood per row of ``x`` (B, N) of positive values."""
    x = _rows(x)
    B, N = x.shape
    if N < 2:
        return fit_lognorm(x, sigma_min=sigma_min).loglik
    f = fit_lognorm(leave_one_out_rows(x).reshape(B * N, N - 1), sigma_min=sigma_min)
    return lognorm_logpdf(x.reshape(-1), f.mu, f.sigma).reshape(B, N).sum(axis=1)
