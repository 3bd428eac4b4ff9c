"""The interaction primitive stream's compiled kernel (``SynthesisConfig.kernel = "numba"``): a rank-k update of the
a-block's Cholesky factor instead of a factorisation per frame.

Within the longest training duration T_max the stream factors its a-block M(t) = S_c + B_a(c, t) (216×216 on the
handovers) at every frame (:mod:`.primitive_stream`). While the chosen candidate c stays the same, a new frame s
only adds w_d φ_c(s) φ_c(s)ᵀ to each observed agent-0 (and object) DoF d's diagonal N×N block: a rank-one term
x xᵀ per DoF with x = √w_d φ_c(s) in block d and zero elsewhere. :func:`cholesky_update` updates the lower factor
L (L Lᵀ = M) by these terms, one column at a time (the classic rotation-based update, LINPACK's ``dchud`` in
spirit: for each column k and each vector whose block starts at or before k, r = √(L_kk² + x_k²), c = r / L_kk,
s = x_k / L_kk, L_kk = r, L_ik ← (L_ik + s x_i) / c, x_i ← c x_i − s L_ik for i > k). A vector is zero before its
block, so the work is Σ_d (n − d N)² · 2 flops per frame (about a sixth of a factorisation's n³/3 on the
handovers). The update is exact in arithmetic, not bitwise: docs/design.md §7 ("Compiled kernels under a declared
tolerance") declares what the compiled path must meet, and tests/test_primitive_kernel.py holds the kernel against
``numpy.linalg.cholesky`` of the updated matrix.

The kernel is compiled on first use (:func:`kernels`; a :class:`~socialaff_sim.errors.ConfigError` naming the
``[fast]`` extra when numba is missing); :func:`cholesky_update_python` is the same loop uncompiled (the tests'
reading of what the compiled code does).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from scipy.linalg.lapack import dpotrs

from ..errors import ModelError
from . import compiled

__all__ = ["FACTOR_RENEWAL", "UpdatedFactor", "cholesky_update", "cholesky_update_python", "kernels"]

FACTOR_RENEWAL = 64
"""[frames]: with the compiled kernel, the a-block is factored anew (as the NumPy path does at every frame) when the
factor has been updated over this many frames, besides whenever the chosen candidate changes or the sums change
otherwise (a rebuild): the rounding of successive updates does not accumulate past this many frames."""


def cholesky_update_python(lower_t: np.ndarray, phi: np.ndarray, frame: np.ndarray, dof: np.ndarray,
                           root_w: np.ndarray, n_basis: int) -> None:
    """Lᵀ ``lower_t`` (n, n), C-ordered (the transpose of a Fortran-ordered factor: row k of it is column k of L),
    L lower triangular with L Lᵀ = M, updated in place to the factor of M + Σ_v x_v x_vᵀ, x_v = ``root_w[v]`` ·
    ``phi[frame[v]]`` in entries [dof[v]·N, dof[v]·N + N) (N = ``n_basis``) and zero elsewhere. ``phi`` (F, N) basis
    rows, ``frame``, ``dof`` (V,) int64, ``root_w`` (V,) √weights. Only L's lower triangle (Lᵀ's upper) is read and
    written. At column k the vectors whose block starts at or before k and whose entry k is not zero (a zero leaves
    the column as it is: c = 1, s = 0) are applied in order, two at a time in one pass over the column."""
    n = lower_t.shape[0]
    n_v = len(dof)
    x = np.zeros((n_v, n))
    start = np.empty(n_v, np.int64)
    first = n
    for v in range(n_v):
        a = dof[v] * n_basis
        start[v] = a
        first = min(first, a)
        for j in range(n_basis):
            x[v, a + j] = root_w[v] * phi[frame[v], j]
    act = np.empty(n_v, np.int64)
    for k in range(first, n):
        col = lower_t[k]  # column k of L, contiguous
        m = 0
        for v in range(n_v):
            if start[v] <= k and x[v, k] != 0.0:
                act[m] = v
                m += 1
        q = 0
        while q < m:
            xa = x[act[q]]
            lkk, xk = col[k], xa[k]
            r = math.sqrt(lkk * lkk + xk * xk)
            ca, sa, ia = r / lkk, xk / lkk, lkk / r
            if q + 1 < m:  # two rotations in one pass: the second reads the column the first made
                xb = x[act[q + 1]]
                lkk, xk = r, xb[k]
                r = math.sqrt(lkk * lkk + xk * xk)
                cb, sb, ib = r / lkk, xk / lkk, lkk / r
                col[k] = r
                # Views from k + 1 and an index from 0: the compiler then drops negative-index wraparound and
                # vectorizes the loop (with range(k + 1, n) on the whole rows it stays scalar, 1.8× slower).
                cv, av, bv = col[k + 1 :], xa[k + 1 :], xb[k + 1 :]
                for i in range(cv.shape[0]):
                    lik = (cv[i] + sa * av[i]) * ia
                    av[i] = ca * av[i] - sa * lik
                    lik = (lik + sb * bv[i]) * ib
                    bv[i] = cb * bv[i] - sb * lik
                    cv[i] = lik
                q += 2
            else:
                col[k] = r
                cv, av = col[k + 1 :], xa[k + 1 :]
                for i in range(cv.shape[0]):
                    lik = (cv[i] + sa * av[i]) * ia
                    av[i] = ca * av[i] - sa * lik
                    cv[i] = lik
                q += 1


def _build_update() -> dict[str, Callable[..., None]]:
    return {"cholesky_update": compiled.njit(cholesky_update_python)}


def _warm_update(built: dict[str, Callable[..., None]]) -> None:
    # Compiled now for the argument types the stream passes (a factor's transpose, C-ordered; int64 indices; an
    # int), on a 2×2 factor: the first frame then costs what the others do (or numba's cache loads it).
    one = np.ones(1)
    built["cholesky_update"](np.eye(2), one[None], np.zeros(1, np.int64), np.zeros(1, np.int64), one, 1)


def kernels() -> dict[str, Callable[..., None]]:
    """The compiled kernels by name (``"cholesky_update"``), compiled on the first call in a process (or loaded from
    numba's on-disk cache: :func:`~.compiled.once`); a ConfigError naming the ``[fast]`` extra when numba is missing."""
    return compiled.once(__name__, _build_update, _warm_update)


def cholesky_update(lower_t: np.ndarray, phi: np.ndarray, frame: np.ndarray, dof: np.ndarray, root_w: np.ndarray,
                    n_basis: int) -> None:
    """:func:`cholesky_update_python`, compiled (:func:`kernels`)."""
    kernels()["cholesky_update"](lower_t, phi, frame, dof, root_w, n_basis)


class UpdatedFactor:
    """The compiled path's a-block factor across frames (:class:`~.primitive_stream.PrimitiveStream` with
    ``kernel="numba"``): which candidate it factors, how many frames it was updated over since it was factored, and
    the frames added to the sums since it was last brought up to date (each: its frame index s, its seen agent-0 DoFs
    and their weights 1/σ²). The stream records every frame it adds one at a time (:meth:`record`), forgets the
    factor when its sums change otherwise (:meth:`forget`: a rebuild, frames added by gathers) and, reading candidate
    c, either updates the factor (:meth:`update`, when :meth:`usable`) or factors anew and says so (:meth:`factored`)."""

    __slots__ = ("age", "candidate", "frames")

    def __init__(self) -> None:
        self.candidate = -1  # none
        self.age = 0
        self.frames: list[tuple[int, np.ndarray, np.ndarray]] = []

    def record(self, s: int, cols: np.ndarray, w: np.ndarray) -> None:
        """Frame ``s`` added to the sums with seen agent-0 DoFs ``cols`` (K,) of weights ``w`` (K,)."""
        if self.candidate >= 0:
            self.frames.append((s, cols, w))

    def forget(self) -> None:
        """The sums changed otherwise than by recorded frames: the next read factors anew."""
        self.candidate = -1
        self.frames.clear()

    def usable(self, c: int) -> bool:
        """Whether candidate ``c``'s a-block is the factored one plus the recorded frames, within the renewal."""
        return self.candidate == c and self.age + len(self.frames) <= FACTOR_RENEWAL

    @classmethod
    def for_kernel(cls, kernel: str) -> UpdatedFactor | None:
        """A factor for ``kernel`` "numba" (the kernel compiled now: a missing numba is a ConfigError here, not at the
        first frame); ``None`` for "numpy" (the stream factors every frame)."""
        if kernel != "numba":
            return None
        kernels()
        return cls()

    def factored(self, c: int, chol: np.ndarray, buffer: np.ndarray) -> None:
        """The a-block of candidate ``c`` was just factored from its sums, into ``chol``; kept in ``buffer`` (n, n),
        Fortran-ordered, where it is updated (potrf factors such a buffer in place: usually ``chol`` is it)."""
        if chol is not buffer:
            np.copyto(buffer, chol)
        self.candidate, self.age = c, 0
        self.frames.clear()

    def solve(self, lower: np.ndarray, rows: np.ndarray, t_max: int, rhs: np.ndarray) -> np.ndarray:
        """(n,) M⁻¹ ``rhs`` with the factor ``lower`` (n, n), Fortran-ordered, first updated by the recorded frames'
        terms (:meth:`update`); ``rows`` (T_max + 1, N) the chosen candidate's basis rows by frame."""
        self.update(lower, rows, t_max)
        x, info = dpotrs(lower, rhs, lower=1)
        if info != 0:
            raise ModelError(f"primitive kernel: potrs failed ({info})")
        return x

    def update(self, lower: np.ndarray, rows: np.ndarray, t_max: int) -> None:
        """``lower`` (n, n) Fortran-ordered, the factor, updated by the recorded frames' terms (frame s's basis row is
        ``rows[min(s, T_max)]``)."""
        n_basis = rows.shape[1]
        if len(self.frames) == 1:  # the usual frame
            s, dof, w = self.frames[0]
            cholesky_update(lower.T, rows[min(s, t_max)][None], np.zeros(len(dof), np.int64), dof.astype(np.int64),
                            np.sqrt(w), n_basis)
        elif self.frames:
            phi = np.ascontiguousarray(rows[np.minimum([s for s, _, _ in self.frames], t_max)])  # (F, N)
            frame = np.concatenate([np.full(len(cols), i, np.int64) for i, (_, cols, _) in enumerate(self.frames)])
            dof = np.concatenate([cols for _, cols, _ in self.frames]).astype(np.int64)
            root_w = np.sqrt(np.concatenate([w for _, _, w in self.frames]))
            cholesky_update(lower.T, phi, frame, dof, root_w, n_basis)
        self.age += len(self.frames)
        self.frames.clear()
