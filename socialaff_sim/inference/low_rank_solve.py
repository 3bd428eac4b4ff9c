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

A⁻¹ is kept explicitly (made once from A's Cholesky factor), so a solve is matrix–vector products. When the
non-zero weights are all equal, δ on a set S of columns (the stream's usual frame: every DoF seen is seen at every
frame), the capacitance system is diagonal in the eigenvectors Q of C_SS = Q diag(λ) Qᵀ (made once per S): with
G = A⁻¹U_S Q, x = A⁻¹b − G (δ / (1 + δλ) ⊙ Gᵀb) (rows of I + D C outside S are the identity's, and their
right-hand side is zero).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg.lapack import dpotrf, dpotri

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
        inv, info = dpotri(chol, lower=1)  # A⁻¹'s lower triangle
        if info != 0:
            raise ModelError(f"LowRankUpdatedSolver: A is singular (potri {info})")
        inv = np.tril(inv)
        inv += np.tril(inv, -1).T
        self._inv = np.ascontiguousarray(inv)  # (n, n) A⁻¹
        self._u = u
        self._au = self._inv @ u  # (n, m) A⁻¹U
        self._c = u.T @ self._au  # (m, m) UᵀA⁻¹U
        self._eye = np.eye(u.shape[1])
        self._eig: tuple[bytes, np.ndarray, np.ndarray] | None = None  # (S, λ, G) of the last equal-weight solve
        self.weights = np.zeros(u.shape[1])
        """(m,) d ≥ 0: the weight of each column of U added to A since the factorisation (the caller's units)."""

    @property
    def size(self) -> int:
        """Floats held (A⁻¹, A⁻¹U, UᵀA⁻¹U, U, the weights and the eigenvectors of the last equal-weight solve)."""
        eig = self._eig[1].size + self._eig[2].size if self._eig is not None else 0
        return int(self._inv.size + self._au.size + self._c.size + self._u.size + self.weights.size + eig)

    def solve(self, b: np.ndarray) -> np.ndarray:
        """(n,) x with (A + U diag(d) Uᵀ) x = b, for b (n,)."""
        y = self._inv @ b
        d = self.weights
        on = d != 0.0
        if not on.any():
            return y
        delta = d[on][0]
        if (d[on] == delta).all():  # one weight δ on the columns S (module docstring)
            key = on.tobytes()
            if self._eig is None or self._eig[0] != key:
                lam, q = np.linalg.eigh(self._c[np.ix_(on, on)])
                self._eig = (key, lam, self._au[:, on] @ q)
            _, lam, g = self._eig
            return y - g @ (delta / (1.0 + delta * lam) * (g.T @ b))
        z = np.linalg.solve(self._eye + d[:, None] * self._c, d * (self._u.T @ y))
        return y - self._au @ z
