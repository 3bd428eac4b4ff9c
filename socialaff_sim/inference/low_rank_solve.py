"""Linear solves with a matrix that grows by a fixed low-rank term: (A + U diag(d) Uᵀ) x = b for a fixed U and
weights d ≥ 0 that change between solves, from one Cholesky factor of A (the Woodbury identity).

The interaction primitive's stream uses it past the longest training duration T_max (:mod:`.primitive_stream`):
there every new frame is an observation at phase 1, so the agent-0 block of its information matrix changes by
w·φ(1)φ(1)ᵀ in each observed DoF's block — a fixed U = I ⊗ φ(1) with one weight per DoF — and a frame's solve
costs two triangular solves and an m×m system (m = U's columns) instead of a Cholesky factorisation of the
whole block. The result equals the direct solve in exact arithmetic, not bitwise (docs/design.md §8 declares
the tolerance).

With D = diag(d) (possibly singular), (A + U D Uᵀ)⁻¹ = A⁻¹ − A⁻¹U (I + D C)⁻¹ D UᵀA⁻¹, C = UᵀA⁻¹U: I + D C is
non-singular for A positive definite and d ≥ 0 (its eigenvalues are those of I + D^½ C D^½).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg.lapack import dpotrf, dpotrs

from ..errors import ModelError

__all__ = ["LowRankUpdatedSolver"]


class LowRankUpdatedSolver:
    """Solves (A + U diag(:attr:`weights`) Uᵀ) x = b.

    ``a``: (n, n) symmetric positive definite, lower triangle read; it is overwritten by its factor (the caller
    passes a matrix it no longer needs). ``u``: (n, m). :attr:`weights` starts at zero (the solve is then A's own,
    the same LAPACK calls as a direct Cholesky solve) and is raised by the caller, in place.
    """

    def __init__(self, a: np.ndarray, u: np.ndarray) -> None:
        u = np.asarray(u, dtype=np.float64)
        if a.ndim != 2 or a.shape[0] != a.shape[1] or u.ndim != 2 or u.shape[0] != a.shape[0]:
            raise ModelError(f"LowRankUpdatedSolver: expected A (n, n) and U (n, m), found {a.shape} and {u.shape}")
        chol, info = dpotrf(a, lower=1, clean=0, overwrite_a=1)
        if info != 0:
            raise ModelError(f"LowRankUpdatedSolver: A is not positive definite (potrf {info})")
        self._chol = chol
        self._u = u
        self._au, _ = dpotrs(chol, u, lower=1)  # (n, m) A⁻¹U
        self._c = u.T @ self._au  # (m, m) UᵀA⁻¹U
        self._eye = np.eye(u.shape[1])
        self.weights = np.zeros(u.shape[1])
        """(m,) d ≥ 0: the weight of each column of U added to A since the factorisation (the caller's units)."""

    @property
    def size(self) -> int:
        """Floats held (the factor, A⁻¹U, UᵀA⁻¹U, U and the weights)."""
        return int(self._chol.size + self._au.size + self._c.size + self._u.size + self.weights.size)

    def solve(self, b: np.ndarray) -> np.ndarray:
        """(n,) x with (A + U diag(d) Uᵀ) x = b, for b (n,)."""
        y, info = dpotrs(self._chol, b, lower=1)
        if info != 0:
            raise ModelError(f"LowRankUpdatedSolver: potrs argument {-info} is invalid")
        d = self.weights
        if not d.any():
            return y
        z = np.linalg.solve(self._eye + d[:, None] * self._c, d * (self._u.T @ y))
        return y - self._au @ z
