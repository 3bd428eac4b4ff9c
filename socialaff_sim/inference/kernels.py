"""Compiled kernels for the reactor's densities: a probe of issue 24's real-time target, an option
(``SynthesisConfig.kernel = "numba"``), off by default; the NumPy path is the reference.

:func:`polar_rows` fuses what :meth:`~.type_tables.TypeTables._density` does with about thirty NumPy calls — the
polar split of the vectors (:func:`~socialaff_sim.model.features.polar`) and the row log-densities
(:func:`~socialaff_sim.model.potentials.polar_rows_logpdf`: Weibull or exponential of h and |dz|, von Mises of θ) —
into one loop over the (configuration, row) pairs, compiled by numba (the optional extra ``[fast]``). It reads the
same parameter columns and kept terms (log i0e(κ), the Weibull terms) and the same densities, written for a scalar
loop: cos(θ − μ) as (x cos μ + y sin μ) / |(x, y)| instead of cos(atan2(y, x) − μ), (h/λ)^k as exp(k log(h/λ)) with
the logarithm taken once, |(x, y)| as a square root, with the C library's exp, log and sqrt instead of NumPy's loops:
equal in exact arithmetic, not bitwise; values differ in the last bits, and a candidate choice or an arg-max that is a
near-tie may flip (docs/design.md §7, docs/benchmarks.md). numba is imported only when the option is chosen.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable

import numpy as np

from ..errors import ConfigError

__all__ = ["KERNELS", "available", "polar_rows"]

KERNELS = ("numpy", "numba")
"""The values of ``SynthesisConfig.kernel``: ``"numpy"`` (the reference) and ``"numba"`` (compiled)."""

_LOG_2PI = float(np.log(2.0 * np.pi))
_compiled: Callable[..., np.ndarray] | None = None


def available() -> bool:
    """Whether numba can be imported (the ``[fast]`` extra)."""
    return importlib.util.find_spec("numba") is not None


def _compile() -> Callable[..., np.ndarray]:
    """The compiled kernel (numba imported and the kernel compiled at the first call; ``cache=True`` keeps the
    machine code on disk beside this module for later processes)."""
    global _compiled
    if _compiled is not None:
        return _compiled
    if not available():
        raise ConfigError("kernel='numba': numba is not installed (pip install 'socialaff-sim[fast]'); use kernel='numpy'")
    import math

    import numba

    @numba.njit(cache=True, fastmath=False, nogil=True)
    def kernel(vecs, params, expon, log_i0e, lkl_h, km1_h, k1_h, lkl_v, km1_v, k1_v, cos_mu, sin_mu, eps):  # noqa: ANN001, ANN202
        N, R = vecs.shape[0], vecs.shape[1]
        out = np.empty((N, R))
        for i in range(N):
            for r in range(R):
                x, y, zz = vecs[i, r, 0], vecs[i, r, 1], vecs[i, r, 2]
                h0 = math.sqrt(x * x + y * y)
                h = h0
                if h < eps:  # np.maximum(h, eps): NaN stays NaN
                    h = eps
                v = abs(zz)
                if v < eps:
                    v = eps
                # cos(θ − μ) with θ = atan2(y, x): (x cos μ + y sin μ) / |(x, y)|; cos μ at θ = atan2(0, 0) = 0
                c = (x * cos_mu[r] + y * sin_mu[r]) / h0 if h0 > 0.0 else cos_mu[r]
                kh, lh, kv, lv, kap = params[r, 0], params[r, 1], params[r, 2], params[r, 3], params[r, 5]
                if expon[r]:
                    dist = (-math.log(lh) - h / lh) + (-math.log(lv) - v / lv)
                else:  # z^k as exp(k log z), log z once
                    lz = math.log(h / lh)
                    a = lkl_h[r] - math.exp(kh * lz)
                    a = a + (0.0 if k1_h[r] else km1_h[r] * lz)
                    lz = math.log(v / lv)
                    b = lkl_v[r] - math.exp(kv * lz)
                    b = b + (0.0 if k1_v[r] else km1_v[r] * lz)
                    dist = a + b
                out[i, r] = dist + (kap * (c - 1.0) - _LOG_2PI - log_i0e[r])
        return out

    _compiled = kernel
    return kernel


def polar_rows(vecs: np.ndarray, rows: tuple, eps: float, columns: dict[int, tuple] | None = None) -> np.ndarray:
    """(N, R) row log-densities of vectors ``vecs`` (N, R, 3) under a :class:`~.type_tables.TypeTables` row set
    ``rows`` (parameters (R, 6), exponential flags (R,), log i0e(κ) (R,), the Weibull terms of h and |dz|): the values
    of ``polar_rows_logpdf(*polar(vecs, eps), ...)`` up to the compiled functions' last bits (module docstring).
    ``columns``: the caller's dict that keeps each row set's contiguous columns (by the row set's id; the tables keep
    their row sets for their lifetime), else made at each call."""
    kernel = _compile()
    return kernel(np.ascontiguousarray(vecs, dtype=np.float64), *_columns(rows, columns), float(eps))


def _columns(rows: tuple, cache: dict[int, tuple] | None) -> tuple[np.ndarray, ...]:
    """The kernel's contiguous parameter columns of a row set, with cos μ and sin μ."""
    hit = None if cache is None else cache.get(id(rows))
    if hit is not None and hit[0] is rows:
        return hit[1]
    params, expon, log_i0e, ((lkl_h, km1_h, k1_h), (lkl_v, km1_v, k1_v)) = rows
    cols = tuple(np.ascontiguousarray(a) for a in (params, expon, log_i0e, lkl_h, km1_h, k1_h, lkl_v, km1_v, k1_v,
                                                   np.cos(params[:, 4]), np.sin(params[:, 4])))
    if cache is not None:
        cache[id(rows)] = (rows, cols)
    return cols
