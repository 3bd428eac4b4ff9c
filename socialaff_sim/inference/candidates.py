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

__all__ = [
    "AGENT1", "vector_rows", "draw_from", "draw_vectors", "expected_error_choice", "SignTerms", "sign_loglik",
    "gaussian_factor", "RegressionPrior",
]

AGENT1 = np.arange(N_KEY, 2 * N_KEY)
"""Indices of agent 1's key joints among the 11 model joints."""


def vector_rows(params: np.ndarray) -> tuple[np.ndarray, ...]:
    """The columns (k_h, λ_h, k_v, λ_v, μ, max(κ, 10⁻⁹)), each (K,), that :func:`draw_from` draws with, of K
    parameter rows (K, 6) (NaN read as 1): made once per type by a caller that draws from the same rows again."""
    kh, lh, kv, lv, mu, kap = nan_to_value(np.asarray(params, dtype=float), 1.0).T
    return kh, lh, kv, lv, mu, np.maximum(kap, 1e-9)


def draw_from(rows: tuple[np.ndarray, ...], up: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, K, 3) vectors from the parameter columns ``rows`` (:func:`vector_rows`) and P(dz > 0) ``up`` (K,)."""
    kh, lh, kv, lv, mu, kap = rows
    K = kh.shape[0]
    if n == 0:
        return np.zeros((0, K, 3))
    h = lh * rng.weibull(kh, size=(n, K))
    v = lv * rng.weibull(kv, size=(n, K))
    sign = np.where(rng.random((n, K)) < up, 1.0, -1.0)
    th = rng.vonmises(mu, kap, size=(n, K))
    out = np.empty((n, K, 3))  # np.stack's result, each product written in place (the same values)
    np.multiply(h, np.cos(th), out=out[..., 0])
    np.multiply(h, np.sin(th), out=out[..., 1])
    np.multiply(sign, v, out=out[..., 2])
    return out


def draw_vectors(params: np.ndarray, up: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, K, 3) vectors from K parameter rows (k_h, λ_h, k_v, λ_v, μ, κ) and P(dz > 0) (K,)."""
    return draw_from(vector_rows(params), up, n, rng)


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
    mean = np.dot(w.reshape(1, -1), x.reshape(x.shape[0], -1)).reshape(x.shape[1:])  # np.tensordot(w, x, axes=(0, 0)), its own call
    d2 = ((x - mean[None]) ** 2).sum(axis=(1, 2))
    return int(np.argmin(np.where(finite, d2, np.inf)))


@dataclass(frozen=True)
class SignTerms:
    """What :func:`sign_loglik` reads of one type and grouping: agent 1's affordable joints, their reference weights
    and the log-frequencies of up and down, made once (a re-planning scores the same type again)."""

    aff: np.ndarray
    """(A,) agent 1's affordable joints."""
    weights: np.ndarray
    """(A, 11) their reference weights."""
    offset_up: np.ndarray
    """(2, A) log P(dz > 0), log P(dz < 0) of their spatial offsets."""
    moving: np.ndarray
    """(B,) agent 1's joints that move (not absent)."""
    disp_up: np.ndarray
    """(2, B) log P(dz > 0), log P(dz < 0) of their displacements."""

    @classmethod
    def of(cls, model: AffordanceParameters, s: int, z: np.ndarray, weights: np.ndarray | None = None) -> SignTerms:
        """The terms of type ``s`` under grouping ``z`` (11,); ``weights``: its (11, 11) reference weights if the
        caller has them (else computed)."""
        up = np.clip(model.vertical_up_[s], 1e-3, 1 - 1e-3)
        aff = AGENT1[z[AGENT1] > 0]
        if aff.size and weights is None:
            weights = reference_weights(z, other_side=model.config.other_side_reference, include_self=model.config.reference_self)
        W = weights[aff] if aff.size else np.zeros((0, z.shape[0]))  # type: ignore[index]
        moving = AGENT1[z[AGENT1] >= 0]
        return cls(aff, W, np.stack([np.log(up[0, aff]), np.log1p(-up[0, aff])]), moving,
                   np.stack([np.log(up[1, moving]), np.log1p(-up[1, moving])]))

    def loglik(self, cand: np.ndarray, disp: np.ndarray) -> np.ndarray:
        """(N,) :func:`sign_loglik` of configurations ``cand`` (N, 11, 3) with displacements ``disp`` (N, 11, 3)."""
        out = np.zeros(cand.shape[0])
        if self.aff.size:
            off_z = cand[:, self.aff, 2] - np.einsum("kj,nj->nk", self.weights, nan_to_zero(cand[:, :, 2]))
            out += np.where(off_z > 0, self.offset_up[0], self.offset_up[1]).sum(axis=1)
        if self.moving.size:
            out += np.where(disp[:, self.moving, 2] > 0, self.disp_up[0], self.disp_up[1]).sum(axis=1)
        return out


def sign_loglik(
    model: AffordanceParameters, s: int, z: np.ndarray, cand: np.ndarray, disp: np.ndarray, weights: np.ndarray | None = None
) -> np.ndarray:
    """(N,) log-probability of the vertical signs of agent 1's offsets and displacements.

    The potentials score |dz| only; the learned frequencies of dz > 0 resolve up from down. ``weights``:
    the (11, 11) reference weights of ``z`` if the caller has them (else computed).
    """
    return SignTerms.of(model, s, z, weights).loglik(cand, disp)


def gaussian_factor(regression: RidgeRegression) -> tuple[np.ndarray, float]:
    """The Cholesky factor L of a regression's residual covariance and log det, as
    :meth:`~socialaff_sim.model.ridge.RidgeRegression.log_density` makes them at every call: made once per type."""
    L = np.linalg.cholesky(regression.cov)
    return L, float(2.0 * np.log(np.diag(L)).sum())


@dataclass(frozen=True)
class RegressionPrior:
    """The end-configuration regression of one re-planning: its prediction and Gaussian."""

    regression: RidgeRegression
    mean: np.ndarray
    """(5, 3) canonical metres: predicted agent 1 key joints at the end."""
    factor: tuple[np.ndarray, float] | None = None
    """The covariance's Cholesky factor and log det (:func:`gaussian_factor`), or None: made at each use."""

    @classmethod
    def at(
        cls, regression: RidgeRegression, config: np.ndarray, before: np.ndarray, reference: np.ndarray, available: np.ndarray,
        factor: tuple[np.ndarray, float] | None = None,
    ) -> RegressionPrior:
        """The prior for the end configuration ``config`` (11, 3) (agent 0 and the object as
        expected at the end) after the previous-frame configuration ``before`` (11, 3), in an
        instance whose reference frame (T0 − 1, the last observed) was ``reference`` (11, 3).
        ``factor``: the regression's :func:`gaussian_factor` if the caller keeps it."""
        ctx = end_context(config[None], before[None], reference[None], available)
        mean = regression.predict(ctx)[0].reshape(N_KEY, 3) + config[0]
        return cls(regression, mean, factor)

    def draw(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """(n, 5, 3) agent 1 key-joint configurations: the mean, then n − 1 draws from the Gaussian."""
        L = np.linalg.cholesky(self.regression.cov) if self.factor is None else self.factor[0]
        eps = rng.standard_normal((n, L.shape[0])) @ L.T
        eps[:1] = 0.0  # the mode itself is always a candidate
        return self.mean[None] + eps.reshape(n, N_KEY, 3)

    def log_density(self, configs: np.ndarray) -> np.ndarray:
        """(N,) log-density of configurations (N, 11, 3) (agent 1's absent joints read as the mean)."""
        a1 = np.asarray(configs, float)[:, AGENT1]
        res = np.where(np.isfinite(a1), a1 - self.mean[None], 0.0).reshape(a1.shape[0], -1)
        if self.factor is None:
            return self.regression.log_density(res)
        # RidgeRegression.log_density's arithmetic, its factor made once: the same values
        L, logdet = self.factor
        y = np.linalg.solve(L, res.T)
        return -0.5 * ((y**2).sum(axis=0) + logdet + self.regression.cov.shape[0] * np.log(2.0 * np.pi))
