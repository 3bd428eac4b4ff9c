"""A fixed set of polar-density parameter rows with every term of the parameters alone made once, and the row
log-densities of vectors under it (issue 24, real-time speed, session 26).

:func:`~socialaff_sim.model.potentials.polar_rows_logpdf` (with :func:`~socialaff_sim.model.features.polar`) scores
vectors under K parameter rows: about fifty NumPy calls, a fifth of them its wrappers' conversions and checks
(``np.asarray``, ``expon.all()``, ``np.errstate``, a ``np.where(x < 0, …)`` that polar distances, ≥ 0 or NaN, never
select, and, on rows of both kinds, the Weibull terms of the parameters made again at every call). The reactor scores
the same rows at every cut of the forward belief and every re-planning. :class:`RowSet` keeps what depends on the
rows only (the columns, −log λ of the exponential rows, the Weibull terms, log i0e(κ), which kind the rows are) and
:meth:`RowSet.logpdf` does the same elementwise arithmetic, in the same order, on the vectors: the same values,
bitwise (tests/test_row_density.py, against the code it replaces written out).
"""

from __future__ import annotations

import importlib
from types import ModuleType

import numpy as np
from scipy.special import i0e

from ..model.densities import LOG_2PI, weibull_terms
from . import compiled

__all__ = ["RowSet", "TABLE_COLUMNS", "compiled_kernels"]

_WEIBULL, _EXPON, _MIXED = 0, 1, 2

TABLE_COLUMNS = ("expon", "k_h", "lam_h", "-log lam_h", "k_v", "lam_v", "-log lam_v", "log(k_h/lam_h)", "k_h - 1",
                 "k_h == 1", "log(k_v/lam_v)", "k_v - 1", "k_v == 1", "mu", "kappa", "log i0e(kappa)", "cos mu", "sin mu")
"""The columns of :attr:`RowSet.table`, one row per parameter row: what the compiled densities read."""

_SCORE_KERNEL = f"{__package__}.score_kernel"


def _import_score_kernel() -> ModuleType:
    return importlib.import_module(_SCORE_KERNEL)


def _warm_score_kernel(kernels: ModuleType) -> None:
    kernels.warm()  # the JIT's cost (a compilation, or its cache's load) now, not at a stream's first re-planning


def compiled_kernels() -> ModuleType:
    """The compiled kernels (:mod:`~.score_kernel`), imported and loaded (:func:`~.score_kernel.warm`) at the first call
    (:func:`~.compiled.once`): that module needs numba, an optional extra, so the package imports and runs without it
    (:func:`~.compiled.require`'s error when it is missing)."""
    return compiled.once(_SCORE_KERNEL, _import_score_kernel, _warm_score_kernel)


def _weibull_parts(k: np.ndarray, lam: np.ndarray, terms: tuple | None = None) -> tuple:
    """λ, k and :func:`~socialaff_sim.model.densities.weibull_terms` of Weibull rows (``terms`` if made already),
    and whether any k is 1."""
    log_k_lam, k_minus_1, k_is_1 = weibull_terms(k, lam) if terms is None else terms
    return lam, k, log_k_lam, k_minus_1, k_is_1, bool(k_is_1.any())


def _weibull(x: np.ndarray, parts: tuple) -> np.ndarray:
    """:func:`~socialaff_sim.model.densities.weibull_logpdf` of x ≥ 0 (or NaN) with its terms made: the same values
    (its ``np.where(x < 0, −inf, …)`` selects nothing there; its ``np.where(k == 1, 0, …)`` only where a k is 1)."""
    lam, k, log_k_lam, k_minus_1, k_is_1, any_1 = parts
    z = x / lam
    logz = np.log(z)
    core = log_k_lam - z**k
    term = np.where(k_is_1, 0.0, k_minus_1 * logz) if any_1 else k_minus_1 * logz
    return core + term


class RowSet:
    """K parameter rows (k_h, λ_h, k_v, λ_v, μ, κ) (K, 6) and their exponential flags (K,) (None: none); ``kernel``:
    ``"numba"`` evaluates :meth:`logpdf` by the compiled kernel (:func:`~.score_kernel.rows_logpdf`, within the
    tolerance of docs/design.md §7), ``"numpy"`` (the default) by NumPy."""

    def __init__(self, params: np.ndarray, expon: np.ndarray | None, eps: float, kernel: str = "numpy") -> None:
        p = params
        e = np.zeros(p.shape[0], bool) if expon is None else np.asarray(expon, bool)
        self.params, self.expon, self.eps = p, e, eps
        self.compiled = kernel == "numba"
        if self.compiled:
            compiled_kernels()  # the missing extra's error now, not at the first density
        kh, lh, kv, lv, mu, kap = p.T  # polar_rows_logpdf's columns (the same views)
        self.mu, self.kap = mu, kap
        with np.errstate(divide="ignore", invalid="ignore"):
            self.log_i0e = np.log(i0e(p.T[5]))
            self.weibull = (weibull_terms(kh, lh), weibull_terms(kv, lv))  # what the tables kept before (read by tests)
            if e.all():
                self.kind = _EXPON
                self._e = (lh, -np.log(lh), lv, -np.log(lv))
            elif not e.any():
                self.kind = _WEIBULL
                self._h = _weibull_parts(kh, lh, self.weibull[0])
                self._v = _weibull_parts(kv, lv, self.weibull[1])
            else:  # each kind on its own columns, as polar_rows_logpdf's third branch
                self.kind = _MIXED
                w = ~e
                self._ei, self._wi = np.flatnonzero(e), np.flatnonzero(w)
                self._e = (lh[e], -np.log(lh[e]), lv[e], -np.log(lv[e]))
                self._h = _weibull_parts(kh[w], lh[w])
                self._v = _weibull_parts(kv[w], lv[w])
            # Every term of every row, one row per parameter row (TABLE_COLUMNS): what the compiled kernels read. The
            # terms are NumPy's (elementwise: a term of a row is the same wherever it is made).
            self.table = np.ascontiguousarray(np.column_stack([
                e.astype(float), kh, lh, -np.log(lh), kv, lv, -np.log(lv), *self.weibull[0], *self.weibull[1], mu, kap,
                self.log_i0e, np.cos(mu), np.sin(mu)]).reshape(-1, len(TABLE_COLUMNS)), dtype=float)

    def logpdf(self, vecs: np.ndarray) -> np.ndarray:
        """(N, K) row log-densities of vectors (N, K, 3): ``polar_rows_logpdf(*polar(vecs, eps), params, expon)``."""
        if self.compiled:
            return compiled_kernels().rows_logpdf(np.ascontiguousarray(vecs, dtype=float), self.table, self.eps)
        with np.errstate(divide="ignore", invalid="ignore"):
            x, y = vecs[..., 0], vecs[..., 1]
            h = np.maximum(np.hypot(x, y), self.eps)
            v = np.maximum(np.abs(vecs[..., 2]), self.eps)
            th = np.arctan2(y, x)
            if self.kind == _WEIBULL:
                dist = _weibull(h, self._h) + _weibull(v, self._v)
            elif self.kind == _EXPON:
                lh, nlh, lv, nlv = self._e
                dist = (nlh - h / lh) + (nlv - v / lv)
            else:
                lh, nlh, lv, nlv = self._e
                ei, wi = self._ei, self._wi
                dist = np.empty(h.shape)
                dist[..., ei] = (nlh - h[..., ei] / lh) + (nlv - v[..., ei] / lv)
                dist[..., wi] = _weibull(h[..., wi], self._h) + _weibull(v[..., wi], self._v)
            return dist + (self.kap * (np.cos(th - self.mu) - 1.0) - LOG_2PI - self.log_i0e)
