"""Spatial and motion potentials of one sub-event type, given its joint grouping Z^s.

Grouping vector ``z`` (11,) int: ``-1`` absent joint, ``0`` Null, ``h >= 1`` functional group h.

* Spatial potential (affordable joints, at a sub-event's last frame): the offset of the
  joint from its reference point — the mass centre (mean) of the *other* members of its
  group, or for a lone joint :data:`~socialaff_sim.model.joints.LONE_REFERENCE` (the other
  agent's base; the object: the midpoint of the two bases) — scored by a Weibull on the
  horizontal distance, a Weibull on the vertical distance |dz| and a von Mises on the
  horizontal angle in the canonical frame.
* Motion potential (the displacement over the sub-event): Weibull / Weibull / von Mises for
  affordable joints; exponential / exponential / von Mises for Null joints.

Parameter rows are ``(k_h, λ_h, k_v, λ_v, μ, κ)``: Weibull shape and scale (metres) of the
horizontal and vertical distance, and the von Mises mean (radians) and concentration. An
exponential with mean m is stored as the Weibull (k = 1, λ = m), which it is. Unused rows are NaN.

The fits return the maximum-likelihood parameters and a log-likelihood of the samples: the
maximized one (``AffordanceConfig.likelihood == "profile"``, the paper's) or the held-out one
(``"held_out"``, each sample under the parameters fitted without it; see
:mod:`~socialaff_sim.model.densities`). With ``AffordanceConfig.vector_density == "cartesian"``
every term also carries the Jacobian 1 / (2h) of :func:`cartesian_correction`, making it a density
of the offset or displacement vector rather than of its polar coordinates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .config import AffordanceConfig
from .densities import (
    expon_logpdf,
    fit_expon,
    fit_vonmises,
    fit_weibull,
    heldout_expon,
    heldout_vonmises,
    heldout_weibull,
    vonmises_logpdf,
    weibull_logpdf,
)
from .features import polar
from .joints import N_JOINTS, reference_row

__all__ = [
    "N_PARAMS",
    "TypePotentials",
    "reference_weights",
    "cartesian_correction",
    "fit_offsets",
    "fit_null_motion",
    "fit_type_potentials",
    "log_spatial",
    "log_motion",
    "polar_rows_logpdf",
    "score_polar",
    "spatial_offsets",
]

N_PARAMS = 6


def reference_weights(z: np.ndarray, *, other_side: bool, include_self: bool = False) -> np.ndarray:
    """(11, 11) float64: row j holds the weights of joint j's spatial reference point (zero unless affordable)."""
    z = np.asarray(z)
    W = np.zeros((N_JOINTS, N_JOINTS))
    for j in np.flatnonzero(z > 0):
        others = np.flatnonzero(z == z[j])
        W[j] = reference_row(int(j), others[others != j], other_side, include_self)
    return W


def _references(weights: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Reference points (N, K, 3) of K weight rows (K, 11) over configurations (N, 11, 3).

    Only joints with a non-zero weight are read, so absent (NaN) joints elsewhere do not leak in.
    """
    cols = np.flatnonzero(weights.any(axis=0))
    return np.einsum("kj,njd->nkd", weights[:, cols], end[:, cols])


def _fit_rows(vecs: np.ndarray, cfg: AffordanceConfig, with_params: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Weibull/Weibull/von Mises fits of K rows of N vectors ``(K, N, 3)`` → params (K, 6) (empty (K, 0)
    without ``with_params``), log-lik (K,)."""
    K = vecs.shape[0]
    h, v, th = polar(vecs, cfg.eps)
    hv = np.concatenate([h, v])
    w = fit_weibull(hv, eps=cfg.eps, shape_min=cfg.shape_min, shape_max=cfg.shape_max)
    vm = fit_vonmises(th, kappa_max=cfg.kappa_max)
    if with_params:
        params = np.stack([w.shape[:K], w.scale[:K], w.shape[K:], w.scale[K:], vm.mu, vm.kappa], axis=1)
    else:
        params = np.zeros((K, 0))
    if cfg.likelihood == "held_out":
        lw = heldout_weibull(hv, eps=cfg.eps, shape_min=cfg.shape_min, shape_max=cfg.shape_max, full=w)
        return params, lw[:K] + lw[K:] + heldout_vonmises(th, kappa_max=cfg.kappa_max, full=vm)
    return params, w.loglik[:K] + w.loglik[K:] + vm.loglik


def cartesian_correction(vecs: np.ndarray, eps: float) -> np.ndarray:
    """log |∂(h, |dz|, θ) / ∂(dx, dy, dz)| = −log h − log 2 of vectors ``(..., 3)`` (h floored at ``eps``).

    Added to the polar log-density f_h(h) f_v(|dz|) f_θ(θ), it gives the density of the offset vector
    itself (metres⁻³): the polar map has Jacobian h, and |dz| folds ±dz onto one value.
    """
    h = np.maximum(np.hypot(vecs[..., 0], vecs[..., 1]), eps)
    return -np.log(h) - np.log(2.0)


def fit_offsets(
    end: np.ndarray, joints: np.ndarray, weights: np.ndarray, cfg: AffordanceConfig, with_params: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """Fit the spatial potential of K (joint, reference) pairs at once.

    ``end`` (N, 11, 3) metres; ``joints`` (K,) int; ``weights`` (K, 11) reference weights.
    Returns params (K, 6) (empty (K, 0) without ``with_params``: the learner's scoring reads the
    log-likelihoods only) and the log-likelihood of each pair summed over the N samples (K,)
    (with :func:`cartesian_correction` when ``cfg.vector_density == "cartesian"``).
    """
    offsets = (end[:, joints] - _references(weights, end)).transpose(1, 0, 2)
    params, ll = _fit_rows(offsets, cfg, with_params)
    if cfg.vector_density == "cartesian":
        ll = ll + cartesian_correction(offsets, cfg.eps).sum(axis=1)
    return params, ll


def fit_null_motion(disp: np.ndarray, cfg: AffordanceConfig) -> tuple[np.ndarray, np.ndarray]:
    """Exponential/exponential/von Mises motion fits of every joint ``disp`` (N, J, 3) → params (J, 6), log-lik (J,)."""
    vecs = disp.transpose(1, 0, 2)
    J = vecs.shape[0]
    h, v, th = polar(vecs, cfg.eps)
    hv = np.concatenate([h, v])
    e = fit_expon(hv, eps=cfg.eps)
    vm = fit_vonmises(th, kappa_max=cfg.kappa_max)
    ones = np.ones(J)
    params = np.stack([ones, e.mean[:J], ones, e.mean[J:], vm.mu, vm.kappa], axis=1)
    if cfg.likelihood == "held_out":
        le = heldout_expon(hv, eps=cfg.eps)
        ll = le[:J] + le[J:] + heldout_vonmises(th, kappa_max=cfg.kappa_max, full=vm)
    else:
        ll = e.loglik[:J] + e.loglik[J:] + vm.loglik
    if cfg.vector_density == "cartesian":
        ll = ll + cartesian_correction(vecs, cfg.eps).sum(axis=1)
    return params, ll


def fit_affordable_motion(disp: np.ndarray, cfg: AffordanceConfig) -> tuple[np.ndarray, np.ndarray]:
    """Weibull/Weibull/von Mises motion fits of every joint ``disp`` (N, J, 3) → params (J, 6), log-lik (J,)."""
    vecs = disp.transpose(1, 0, 2)
    params, ll = _fit_rows(vecs, cfg)
    if cfg.vector_density == "cartesian":
        ll = ll + cartesian_correction(vecs, cfg.eps).sum(axis=1)
    return params, ll


@dataclass(frozen=True)
class TypePotentials:
    """Fitted potentials of one sub-event type."""

    spatial: np.ndarray
    """(11, 6) float64: spatial parameter rows (NaN unless affordable)."""
    motion: np.ndarray
    """(11, 6) float64: motion parameter rows (exponential as k = 1 for Null; NaN if absent)."""
    loglik: float
    """Log-likelihood of the training samples: maximized or held-out (``AffordanceConfig.likelihood``)."""


def fit_type_potentials(end: np.ndarray, disp: np.ndarray, z: np.ndarray, cfg: AffordanceConfig) -> TypePotentials:
    """Maximum-likelihood potentials of one type from its N samples (``end``, ``disp``: (N, 11, 3))."""
    z = np.asarray(z)
    spatial = np.full((N_JOINTS, N_PARAMS), np.nan)
    motion = np.full((N_JOINTS, N_PARAMS), np.nan)
    ll = 0.0
    aff = np.flatnonzero(z > 0)
    null = np.flatnonzero(z == 0)
    if end.shape[0] == 0:
        return TypePotentials(spatial, motion, 0.0)
    if aff.size:
        W = reference_weights(z, other_side=cfg.other_side_reference, include_self=cfg.reference_self)
        p, l_sp = fit_offsets(end, aff, W[aff], cfg)
        spatial[aff] = p
        pm, l_mo = fit_affordable_motion(disp[:, aff], cfg)
        motion[aff] = pm
        ll += float(l_sp.sum() + l_mo.sum())
    if null.size:
        pn, l_n = fit_null_motion(disp[:, null], cfg)
        motion[null] = pn
        ll += float(l_n.sum())
    return TypePotentials(spatial, motion, ll)


def _score_rows(vecs: np.ndarray, params: np.ndarray, eps: float, expon: np.ndarray) -> np.ndarray:
    """Log-density of vectors (N, K, 3) under K parameter rows (K, 6) → (N,) summed over K."""
    return score_polar(*polar(vecs, eps), params, expon)


def polar_rows_logpdf(
    h: np.ndarray, v: np.ndarray, th: np.ndarray, params: np.ndarray, expon: np.ndarray, *, log_i0e: np.ndarray | None = None,
    weibull: tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]] | None = None,
) -> np.ndarray:
    """Log-density (N, K) of vectors given in polar form (:func:`~socialaff_sim.model.features.polar`: h, |dz|, θ,
    each (N, K)) under K parameter rows (K, 6), one column per row: Weibull (``expon`` (K,): exponential) of h and
    |dz| plus von Mises of θ. Only the kind the rows use is evaluated when they are all of one kind (``np.where``
    would pick the same values). ``log_i0e``: log i0e(κ) of the rows, when the caller keeps it; ``weibull``:
    :func:`~.densities.weibull_terms` of (k_h, λ_h) and of (k_v, λ_v), when the caller keeps them (read when every row
    is a Weibull row)."""
    kh, lh, kv, lv, mu, kap = params.T
    if expon.all():
        dist = expon_logpdf(h, lh) + expon_logpdf(v, lv)
    elif not expon.any():
        th_, tv_ = (None, None) if weibull is None else weibull
        dist = weibull_logpdf(h, kh, lh, terms=th_) + weibull_logpdf(v, kv, lv, terms=tv_)
    else:  # each kind on its own columns (was: both on every column, then np.where; the same values per element)
        w = ~expon
        dist = np.empty(np.broadcast_shapes(h.shape, v.shape))
        dist[..., expon] = expon_logpdf(h[..., expon], lh[expon]) + expon_logpdf(v[..., expon], lv[expon])
        dist[..., w] = weibull_logpdf(h[..., w], kh[w], lh[w]) + weibull_logpdf(v[..., w], kv[w], lv[w])
    return dist + vonmises_logpdf(th, mu, kap, log_i0e=log_i0e)


def score_polar(h: np.ndarray, v: np.ndarray, th: np.ndarray, params: np.ndarray, expon: np.ndarray) -> np.ndarray:
    """Log-density of vectors given in polar form (:func:`~socialaff_sim.model.features.polar`: h, |dz|, θ, each
    (N, K)) under K parameter rows (K, 6) → (N,) summed over K (``expon`` (K,): exponential rows)."""
    return polar_rows_logpdf(h, v, th, params, expon).sum(axis=-1)


def log_spatial(
    pot: TypePotentials, z: np.ndarray, end: np.ndarray, eps: float, *, other_side: bool, cartesian: bool = False,
    include_self: bool = False,
) -> np.ndarray:
    """Spatial log-potential of N configurations ``end`` (N, 11, 3) canonical metres → (N,).

    ``cartesian``: add :func:`cartesian_correction` of every offset (``vector_density == "cartesian"``)."""
    z = np.asarray(z)
    end = np.asarray(end, float)
    aff = np.flatnonzero(z > 0)
    if aff.size == 0:
        return np.zeros(end.shape[0])
    offsets = spatial_offsets(z, end, other_side=other_side, include_self=include_self)
    out = _score_rows(offsets, pot.spatial[aff], eps, np.zeros(aff.size, bool))
    if cartesian:
        out = out + cartesian_correction(offsets, eps).sum(axis=-1)
    return out


def spatial_offsets(z: np.ndarray, end: np.ndarray, *, other_side: bool, include_self: bool = False) -> np.ndarray:
    """(N, K, 3) offsets of the K affordable joints of grouping ``z`` (in joint order) from their reference points
    in N configurations ``end`` (N, 11, 3), as :func:`log_spatial` scores them."""
    aff = np.flatnonzero(np.asarray(z) > 0)
    W = reference_weights(z, other_side=other_side, include_self=include_self)[aff]
    return end[:, aff] - _references(W, end)


def log_motion(pot: TypePotentials, z: np.ndarray, disp: np.ndarray, eps: float, *, cartesian: bool = False) -> np.ndarray:
    """Motion log-potential of N displacement sets ``disp`` (N, 11, 3) metres → (N,).

    ``cartesian``: add :func:`cartesian_correction` of every displacement (``vector_density == "cartesian"``)."""
    z = np.asarray(z)
    used = np.flatnonzero(z >= 0)
    disp = np.asarray(disp, float)
    if used.size == 0:
        return np.zeros(disp.shape[0])
    out = _score_rows(disp[:, used], pot.motion[used], eps, z[used] == 0)
    if cartesian:
        out = out + cartesian_correction(disp[:, used], eps).sum(axis=-1)
    return out
