"""Log-space forward–backward and forward filtering for a discrete-state HMM.

Everything works on log probabilities, so impossible states (``-inf``) are exact
and long sequences never underflow. The recursion over time is sequential; each
step is vectorized over the N states.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError

__all__ = ["ForwardBackward", "forward_backward", "forward_filter", "logsumexp", "safe_log"]


def safe_log(p: np.ndarray) -> np.ndarray:
    """``log(p)`` with ``log(0) = -inf`` and no warning."""
    with np.errstate(divide="ignore"):
        return np.log(p)


def logsumexp(a: np.ndarray, axis: int | tuple[int, ...]) -> np.ndarray:
    """``log(sum(exp(a)))`` along ``axis``; all ``-inf`` gives ``-inf`` (no warning)."""
    m = np.max(a, axis=axis, keepdims=True)
    m = np.where(np.isfinite(m), m, 0.0)
    s = np.sum(np.exp(a - m), axis=axis, keepdims=True)
    return np.squeeze(safe_log(s) + m, axis=axis)


@dataclass(frozen=True)
class ForwardBackward:
    """Result of :func:`forward_backward` for one sequence of T frames over N states."""

    log_likelihood: float
    """log p(x_0..x_{T-1}) (natural log)."""
    gamma: np.ndarray
    """(T, N) float64: posterior p(z_t = i | x)."""
    xi: np.ndarray
    """(N, N) float64: expected transition counts sum_t p(z_{t-1} = i, z_t = j | x)."""


def _check(log_start: np.ndarray, log_trans: np.ndarray, log_emit: np.ndarray) -> None:
    n = log_start.shape[0]
    if log_trans.shape != (n, n) or log_emit.ndim != 2 or log_emit.shape[1] != n or log_emit.shape[0] == 0:
        raise ModelError(
            f"HMM: expected start (N,), transitions (N, N) and emissions (T >= 1, N); found "
            f"{log_start.shape}, {log_trans.shape}, {log_emit.shape}"
        )


def _active(log_emit: np.ndarray) -> list[np.ndarray | slice]:
    """Per frame, the states whose emission is possible (a slice when all are)."""
    out: list[np.ndarray | slice] = []
    for row in np.isfinite(log_emit):
        out.append(slice(None) if row.all() else np.flatnonzero(row))
    return out


def _block(log_trans: np.ndarray, rows: np.ndarray | slice, cols: np.ndarray | slice) -> np.ndarray:
    if isinstance(rows, slice) and isinstance(cols, slice):
        return log_trans
    r = np.arange(log_trans.shape[0]) if isinstance(rows, slice) else rows
    c = np.arange(log_trans.shape[1]) if isinstance(cols, slice) else cols
    return log_trans[np.ix_(r, c)]


def _forward(log_start: np.ndarray, log_trans: np.ndarray, log_emit: np.ndarray, active: list) -> np.ndarray:
    """log alpha (T, N); only states with a possible emission are visited (the rest stay -inf)."""
    T, n = log_emit.shape
    alpha = np.full((T, n), -np.inf)
    alpha[0] = log_start + log_emit[0]
    for t in range(1, T):
        a, b = active[t - 1], active[t]
        alpha[t, b] = log_emit[t, b] + logsumexp(alpha[t - 1, a][:, None] + _block(log_trans, a, b), axis=0)
    return alpha


def forward_backward(log_start: np.ndarray, log_trans: np.ndarray, log_emit: np.ndarray) -> ForwardBackward:
    """Posteriors of an HMM given log start (N,), log transitions (N, N) and log emissions (T, N).

    ``log_trans[i, j] = log p(z_t = j | z_{t-1} = i)``; ``log_emit[t, j] = log p(x_t | z_t = j)``.
    States with an impossible emission (``-inf``) are skipped, which makes partly
    observed product states cheap. Raises :class:`~socialaff_sim.errors.ModelError`
    if the sequence has probability zero.
    """
    _check(log_start, log_trans, log_emit)
    T, n = log_emit.shape
    active = _active(log_emit)
    alpha = _forward(log_start, log_trans, log_emit, active)
    loglik = float(logsumexp(alpha[-1], axis=0))
    if not np.isfinite(loglik):
        raise ModelError("HMM: the observation sequence has probability zero under the model")
    beta = np.zeros((T, n))
    xi = np.zeros((n, n))
    for t in range(T - 1, 0, -1):
        a, b = active[t - 1], active[t]
        block = _block(log_trans, a, b)
        nxt = (log_emit[t, b] + beta[t, b])[None, :]
        beta[t - 1, a] = logsumexp(block + nxt, axis=1)
        pair = np.exp(alpha[t - 1, a][:, None] + block + nxt - loglik)
        if isinstance(a, slice) and isinstance(b, slice):
            xi += pair
        else:
            rows = np.arange(n) if isinstance(a, slice) else a
            cols = np.arange(n) if isinstance(b, slice) else b
            xi[np.ix_(rows, cols)] += pair
    gamma = np.exp(alpha + beta - loglik)
    return ForwardBackward(log_likelihood=loglik, gamma=gamma, xi=xi)


def forward_filter(log_start: np.ndarray, log_trans: np.ndarray, log_emit: np.ndarray) -> tuple[np.ndarray, float]:
    """Online (causal) posteriors p(z_t | x_0..x_t), (T, N), and log p(x_0..x_{T-1})."""
    _check(log_start, log_trans, log_emit)
    alpha = _forward(log_start, log_trans, log_emit, _active(log_emit))
    norm = logsumexp(alpha, axis=1)
    if not np.isfinite(norm).all():
        raise ModelError("HMM: the observation sequence has probability zero under the model")
    return np.exp(alpha - norm[:, None]), float(norm[-1])
