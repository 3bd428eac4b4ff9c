"""The arms' damped least-squares steps compiled (``BalanceConfig.qp_kernel = "numba"``).

:mod:`~.arm_compensation` maps a wrist's shift onto its arm's hinges, Jᵀ (J Jᵀ + λ² I)⁻¹ e on three rows, and
:mod:`~.hand_yield` a wrist's horizontal offset and its rate, Jᵀ (J Jᵀ + λ² I)⁻¹ on two, with a dozen NumPy and LAPACK
calls per arm and driven physics step. :func:`damped_step` does it in one no-Python loop
(:func:`~socialaff_sim.inference.compiled.njit`, fast-math off), the small system solved by Cholesky's
factorisation (J Jᵀ + λ² I is symmetric positive definite), not LAPACK's LU: its results differ from NumPy's in
their last digits, an alternative evaluation judged with ``qp_kernel="numba"`` by its rule (docs/design.md §5,
session 34). NumPy stays the reference.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..inference.compiled import njit, once

__all__ = ["arm_kernel", "damped_step"]


def _damped(jac, dofs, rows, lam2, e, out):  # pragma: no cover - compiled; tested through damped_step
    """out[:, c] = Jᵀ (J Jᵀ + λ² I)⁻¹ e[c] for J the first ``rows`` rows of ``jac`` (3, nv) on the columns
    ``dofs`` (k,), for each right-hand side e (m, rows)."""
    k = dofs.shape[0]
    A = np.zeros((rows, rows))
    for i in range(rows):
        for j in range(i + 1):
            s = 0.0
            for c in range(k):
                s += jac[i, dofs[c]] * jac[j, dofs[c]]
            A[i, j] = s
        A[i, i] += lam2
    L = np.zeros((rows, rows))  # Cholesky: A = L Lᵀ
    for i in range(rows):
        for j in range(i + 1):
            s = A[i, j]
            for t in range(j):
                s -= L[i, t] * L[j, t]
            L[i, j] = math.sqrt(s) if i == j else s / L[j, j]
    y = np.empty(rows)
    for m in range(e.shape[0]):
        for i in range(rows):  # L y = e, then Lᵀ x = y (x in y)
            s = e[m, i]
            for t in range(i):
                s -= L[i, t] * y[t]
            y[i] = s / L[i, i]
        for i in range(rows - 1, -1, -1):
            s = y[i]
            for t in range(i + 1, rows):
                s -= L[t, i] * y[t]
            y[i] = s / L[i, i]
        for c in range(k):
            s = 0.0
            for i in range(rows):
                s += jac[i, dofs[c]] * y[i]
            out[m, c] = s


def arm_kernel() -> Any:
    """The compiled :func:`_damped` (made and warmed up once per process; numba missing: a ConfigError)."""
    return once(__name__, lambda: njit(_damped), _warm)


def _warm(fn: Any) -> None:
    """One call of the argument types :func:`damped_step` passes."""
    fn(np.eye(3, 5), np.arange(3, dtype=np.int64), 3, 0.0025, np.ones((1, 3)), np.zeros((1, 3)))


def damped_step(jac: np.ndarray, dofs: np.ndarray, lam: float, *rhs: np.ndarray) -> np.ndarray:
    """(len(rhs), k): per right-hand side e (r,) of ``rhs`` the hinge step Jᵀ (J Jᵀ + λ² I)⁻¹ e, J the first r rows of
    ``jac`` (3, nv) (a point's translational Jacobian, world) on the columns ``dofs`` (k,), damped by ``lam`` λ (m)."""
    e = np.array(rhs, dtype=np.float64)
    out = np.empty((len(rhs), len(dofs)))
    arm_kernel()(jac, dofs, e.shape[1], lam * lam, e, out)
    return out
