"""Candidate end configurations of agent 1 for Algorithm 2: drawing and the extra score terms.

The spatial and motion potentials score |dz| and a horizontal angle; :func:`draw_vectors` draws
offsets from them and :func:`sign_loglik` adds the learned up/down frequencies. The optional
end-configuration regression (:mod:`~socialaff_sim.model.end_regression`) contributes draws
around its prediction and a joint Gaussian term (:class:`RegressionPrior`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..data.skeletons import N_KEY
from ..model.affordance import AffordanceParameters
from ..model.end_regression import end_context
from ..model.nan_fill import nan_to_value, nan_to_zero
from ..model.potentials import reference_weights
from ..model.ridge import RidgeRegression

__all__ = ["AGENT1", "draw_vectors", "expected_error_choice", "sign_loglik", "RegressionPrior"]

AGENT1 = np.arange(N_KEY, 2 * N_KEY)
"""Indices of agent 1's key joints among the 11 model joints."""


def draw_vectors(params: np.ndarray, up: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, K, 3) vectors from K parameter rows (k_h, λ_h, k_v, λ_v, μ, κ) and P(dz > 0) (K,)."""
    K = params.shape[0]
    if n == 0:
        return np.zeros((0, K, 3))
    kh, lh, kv, lv, mu, kap = nan_to_value(np.asarray(params, dtype=float), 1.0).T
    h = lh * rng.weibull(kh, size=(n, K))
    v = lv * rng.weibull(kv, size=(n, K))
    sign = np.where(rng.random((n, K)) < up, 1.0, -1.0)
    th = rng.vonmises(mu, np.maximum(kap, 1e-9), size=(n, K))
    return np.stack([h * np.cos(th), h * np.sin(th), sign * v], axis=-1)


def expected_error_choice(cand: np.ndarray, score: np.ndarray, temperature: float = 1.0) -> int:
    """Index of the candidate of least expected squared error when the truth is one of the candidates
    ``cand`` (N, J, 3) with probabilities ∝ exp(``score`` / ``temperature``) (N,):
    Σ_j p_j ‖c_i − c_j‖² = ‖c_i − c̄‖² + const, so the candidate nearest the weighted mean c̄ (joints NaN in
    every candidate ignored). Scores of −inf weigh nothing; if every score is −inf, candidate 0."""
    score = np.asarray(score, dtype=float) / float(temperature)
    finite = np.isfinite(score)
    if not finite.any():
        return 0
    w = np.where(finite, np.exp(score - score[finite].max()), 0.0)
    w /= w.sum()
    x = nan_to_zero(np.asarray(cand, dtype=float))
    mean = np.tensordot(w, x, axes=(0, 0))
    d2 = ((x - mean[None]) ** 2).sum(axis=(1, 2))
    return int(np.argmin(np.where(finite, d2, np.inf)))


def sign_loglik(
    model: AffordanceParameters, s: int, z: np.ndarray, cand: np.ndarray, disp: np.ndarray, weights: np.ndarray | None = None
) -> np.ndarray:
    """(N,) log-probability of the vertical signs of agent 1's offsets and displacements.

    The potentials score |dz| only; the learned frequencies of dz > 0 resolve up from down. ``weights``:
    the (11, 11) reference weights of ``z`` if the caller has them (else computed).
    """
    up = np.clip(model.vertical_up_[s], 1e-3, 1 - 1e-3)
    aff = AGENT1[z[AGENT1] > 0]
    out = np.zeros(cand.shape[0])
    if aff.size:
        if weights is None:
            weights = reference_weights(z, other_side=model.config.other_side_reference, include_self=model.config.reference_self)
        W = weights[aff]
        off_z = cand[:, aff, 2] - np.einsum("kj,nj->nk", W, nan_to_zero(cand[:, :, 2]))
        out += np.where(off_z > 0, np.log(up[0, aff]), np.log1p(-up[0, aff])).sum(axis=1)
    moving = AGENT1[z[AGENT1] >= 0]
    if moving.size:
        out += np.where(disp[:, moving, 2] > 0, np.log(up[1, moving]), np.log1p(-up[1, moving])).sum(axis=1)
    return out


@dataclass(frozen=True)
class RegressionPrior:
    """The end-configuration regression of one re-planning: its prediction and Gaussian."""

    regression: RidgeRegression
    mean: np.ndarray
    """(5, 3) canonical metres: predicted agent 1 key joints at the end."""

    @classmethod
    def at(
        cls, regression: RidgeRegression, config: np.ndarray, before: np.ndarray, reference: np.ndarray, available: np.ndarray
    ) -> RegressionPrior:
        """The prior for the end configuration ``config`` (11, 3) (agent 0 and the object as
        expected at the end) after the previous-frame configuration ``before`` (11, 3), in an
        instance whose reference frame (T0 − 1, the last observed) was ``reference`` (11, 3)."""
        ctx = end_context(config[None], before[None], reference[None], available)
        mean = regression.predict(ctx)[0].reshape(N_KEY, 3) + config[0]
        return cls(regression, mean)

    def draw(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """(n, 5, 3) agent 1 key-joint configurations: the mean, then n − 1 draws from the Gaussian."""
        L = np.linalg.cholesky(self.regression.cov)
        eps = rng.standard_normal((n, L.shape[0])) @ L.T
        eps[:1] = 0.0  # the mode itself is always a candidate
        return self.mean[None] + eps.reshape(n, N_KEY, 3)

    def log_density(self, configs: np.ndarray) -> np.ndarray:
        """(N,) log-density of configurations (N, 11, 3) (agent 1's absent joints read as the mean)."""
        a1 = np.asarray(configs, float)[:, AGENT1]
        res = np.where(np.isfinite(a1), a1 - self.mean[None], 0.0).reshape(a1.shape[0], -1)
        return self.regression.log_density(res)
