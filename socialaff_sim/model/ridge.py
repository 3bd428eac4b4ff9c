"""Ridge regression with a Gaussian residual, its penalty chosen by held-out error.

The shared estimator of the model's two regressions of agent 1's configuration
(:mod:`~socialaff_sim.model.end_regression`, :mod:`~socialaff_sim.model.frame_regression`).
The context is standardized; λ is chosen over a fixed grid by leave-one-group-out error (a group
per training instance, or per sample); the residual covariance is the held-out residuals'
covariance shrunk halfway to its diagonal, plus σ_min² on the diagonal.

A regression may carry *offset columns*: context columns that hold a baseline guess of the target
(agent 1's last observed pose). With offset weight α = 1 the ridge models the target minus that
baseline, so the penalty shrinks toward "as last observed" instead of toward the training mean;
α ∈ {0, 1} is chosen with λ by the same held-out error.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["RIDGE_GRID", "RidgeRegression", "fit_ridge", "ridge_solve"]

RIDGE_GRID = (0.1, 0.3, 1.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1e3, 1e4, 1e6)
"""λ values tried (on standardized context)."""


@dataclass(frozen=True)
class RidgeRegression:
    """A fitted linear-Gaussian map from a context (C,) to a target (D,)."""

    context_mean: np.ndarray
    """(C,) mean of the training context."""
    context_scale: np.ndarray
    """(C,) standard deviation of the training context (1 where constant)."""
    target_mean: np.ndarray
    """(D,) mean target."""
    coef: np.ndarray
    """(C, D): coefficients on the standardized context."""
    cov: np.ndarray
    """(D, D): residual covariance."""
    ridge: float
    """λ, the penalty chosen by held-out error."""
    offset_columns: np.ndarray | None = None
    """(D,) int64: the context column holding each target's baseline guess, or ``None``."""
    offset_weight: float = 0.0
    """α ∈ {0, 1}: weight of the offset columns added to the prediction, chosen by held-out error."""

    def predict(self, context: np.ndarray) -> np.ndarray:
        """(M, D) mean target of contexts (M, C)."""
        context = np.asarray(context, float)
        z = (context - self.context_mean) / self.context_scale
        out = z @ self.coef + self.target_mean
        if self.offset_columns is not None and self.offset_weight:
            out = out + self.offset_weight * context[:, self.offset_columns]
        return out

    def log_density(self, residual: np.ndarray) -> np.ndarray:
        """(M,) Gaussian log-density of residuals (M, D) under ``cov``."""
        L = np.linalg.cholesky(self.cov)
        y = np.linalg.solve(L, np.asarray(residual, float).T)
        logdet = 2.0 * np.log(np.diag(L)).sum()
        return -0.5 * ((y**2).sum(axis=0) + logdet + self.cov.shape[0] * np.log(2.0 * np.pi))


def ridge_solve(context: np.ndarray, target: np.ndarray, lam: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(context mean, context scale, target mean, coefficients) of ridge with penalty λ on the standardized context."""
    mean = context.mean(axis=0)
    scale = context.std(axis=0)
    scale = np.where(scale > 1e-9, scale, 1.0)
    z = (context - mean) / scale
    y_mean = target.mean(axis=0)
    coef = np.linalg.solve(z.T @ z + lam * np.eye(z.shape[1]), z.T @ (target - y_mean))
    return mean, scale, y_mean, coef


def fit_ridge(
    context: np.ndarray,
    target: np.ndarray,
    groups: np.ndarray,
    *,
    sigma_min: float,
    grid: tuple[float, ...] = RIDGE_GRID,
    offset_columns: np.ndarray | None = None,
) -> RidgeRegression:
    """Fit contexts (M, C) to targets (M, D); λ (and, given ``offset_columns`` (D,), the offset weight
    α ∈ {0, 1}) by leave-one-group-out error over ``groups`` (M,) (at least 2 groups)."""
    X = np.asarray(context, float)
    Y = np.asarray(target, float)
    groups = np.asarray(groups)
    cols = None if offset_columns is None else np.asarray(offset_columns, np.int64)
    alphas = (0.0,) if cols is None else (0.0, 1.0)
    residuals = _held_out_grid(X, [_shifted(X, Y, cols, alpha) for alpha in alphas], groups, grid)
    best: tuple[float, float, float, np.ndarray] | None = None
    for a, alpha in enumerate(alphas):
        for r, lam in enumerate(grid):
            res = residuals[a][r]
            err = float(np.mean(res**2))
            if best is None or err < best[0]:  # ties keep α = 0 and the smaller λ
                best = (err, alpha, lam, res)
    assert best is not None  # grid is non-empty
    _, alpha, lam, res = best
    mean, scale, y_mean, coef = ridge_solve(X, _shifted(X, Y, cols, alpha), lam)
    S = res.T @ res / X.shape[0]
    cov = 0.5 * S + 0.5 * np.diag(np.diag(S)) + sigma_min**2 * np.eye(Y.shape[1])
    return RidgeRegression(mean, scale, y_mean, coef, cov, float(lam), cols, float(alpha))


def _shifted(X: np.ndarray, Y: np.ndarray, cols: np.ndarray | None, alpha: float) -> np.ndarray:
    """The targets minus α times their offset columns."""
    return Y - alpha * X[:, cols] if alpha and cols is not None else Y


def _held_out_residuals(X: np.ndarray, Y: np.ndarray, groups: np.ndarray, lam: float) -> np.ndarray:
    """(M, D) residuals of each group's targets under the ridge fitted without that group (:func:`ridge_solve`
    per group: the reference of :func:`_held_out_grid`)."""
    res = np.empty_like(Y)
    for g in np.unique(groups):  # one small solve of size C per held-out group
        out = groups == g
        mean, scale, y_mean, coef = ridge_solve(X[~out], Y[~out], lam)
        res[out] = Y[out] - (((X[out] - mean) / scale) @ coef + y_mean)
    return res


def _held_out_grid(X: np.ndarray, targets: list[np.ndarray], groups: np.ndarray, grid: tuple[float, ...]) -> list[list[np.ndarray]]:
    """``out[t][r]``: :func:`_held_out_residuals` of ``targets[t]`` at penalty ``grid[r]``, bitwise, with what
    does not depend on the target or λ (the held-in context's standardization and Gram matrix) computed once
    per held-out group and what does not depend on λ once per target, by :func:`ridge_solve`'s very operations."""
    res = [[np.empty_like(Y) for _ in grid] for Y in targets]
    for g in np.unique(groups):
        out = groups == g
        held_in = X[~out]
        mean = held_in.mean(axis=0)
        scale = held_in.std(axis=0)
        scale = np.where(scale > 1e-9, scale, 1.0)
        z = (held_in - mean) / scale
        gram = z.T @ z
        eye = np.eye(z.shape[1])
        z_out = (X[out] - mean) / scale
        for t, Y in enumerate(targets):
            target = Y[~out]
            y_mean = target.mean(axis=0)
            cross = z.T @ (target - y_mean)
            for r, lam in enumerate(grid):
                coef = np.linalg.solve(gram + lam * eye, cross)
                res[t][r][out] = Y[out] - (z_out @ coef + y_mean)
    return res
