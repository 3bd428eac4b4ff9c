"""The switching regression's blend, compiled (``SynthesisConfig.kernel = "numba"``): the displacement of one row
(:meth:`~.switching.SwitchingRegression.displacement` of the reactor's per-frame call) in one compiled call.

Per member m of the blend: its prior (the ``from_plan`` or ``from_primitive`` offset, or zero) plus its columns of the
row, divided by their scales and clipped to the training range (``clip_features``), times its ridge weights; the
members summed with their weights α_m. The same arithmetic as NumPy's, but the row-times-weights product is summed in
column order where NumPy's matrix product may use BLAS (fused multiply-adds, another order): equal to rounding, not
bitwise (docs/design.md §7, "Compiled kernels under a declared tolerance"; tests/test_blend_kernel.py holds it within
1e-12 relative). Rows of several frames (forecasts, the offline call) stay NumPy's.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..errors import ModelError
from . import compiled
from .switching import SwitchingRegression

__all__ = ["Blend", "blend_row_python"]

_PRIORS = {None: 0, "from_plan": 1, "from_primitive": 2}


def blend_row_python(out: np.ndarray, row: np.ndarray, offset: np.ndarray, prim_offset: np.ndarray, cols: np.ndarray,
                     starts: np.ndarray, scale: np.ndarray, lower: np.ndarray, upper: np.ndarray, coef: np.ndarray,
                     weight: np.ndarray, prior: np.ndarray, clip: bool) -> None:
    """``out`` (O,) = Σ_m weight[m] (prior_m + Σ_q x_q coef[q]) over member m's entries q in [starts[m], starts[m + 1]),
    x_q = row[cols[q]] / scale[q], clipped to [lower[q], upper[q]] when ``clip``; prior_m is ``offset`` (O,) when
    prior[m] is 1, ``prim_offset`` (O,) when 2, zero when 0."""
    n_out = out.shape[0]
    part = np.empty(n_out)
    for o in range(n_out):
        out[o] = 0.0
    for m in range(weight.shape[0]):
        for o in range(n_out):
            part[o] = offset[o] if prior[m] == 1 else (prim_offset[o] if prior[m] == 2 else 0.0)
        for q in range(starts[m], starts[m + 1]):
            x = row[cols[q]] / scale[q]
            if clip:  # np.clip: the bounds, NaN kept
                if x < lower[q]:
                    x = lower[q]
                elif x > upper[q]:
                    x = upper[q]
            for o in range(n_out):
                part[o] += x * coef[q, o]
        for o in range(n_out):
            out[o] += weight[m] * part[o]


def _build_blend() -> Callable[..., None]:
    return compiled.njit(blend_row_python)


def _warm_blend(row: Callable[..., None]) -> None:
    """Compiled now for the types :class:`Blend` passes, on a one-member blend of one column."""
    one, i = np.ones(1), np.zeros(2, np.int64)
    row(np.zeros(1), one, one, one, np.zeros(1, np.int64), i, one, one, one, np.ones((1, 1)), one, np.zeros(1, np.int64),
        True)


def _kernel() -> Callable[..., None]:
    """The compiled kernel (compiled on the first call in a process for the types :class:`Blend` passes:
    :func:`~.compiled.once`)."""
    return compiled.once(__name__, _build_blend, _warm_blend)


class Blend:
    """A fitted :class:`~.switching.SwitchingRegression`'s members packed for the compiled kernel (made again if the
    regression is refitted). A missing numba is a ConfigError at construction."""

    def __init__(self, regression: SwitchingRegression) -> None:
        self._kernel = _kernel()
        self.regression = regression
        self._members: object = None

    def _pack(self) -> None:
        reg = self.regression
        members = reg.members_
        cols = [m.columns for m in members]
        self._cols = np.ascontiguousarray(np.concatenate(cols) if cols else np.zeros(0), dtype=np.int64)
        self._starts = np.concatenate([[0], np.cumsum([len(c) for c in cols])]).astype(np.int64)
        self._scale = np.array(reg.scale_[self._cols], dtype=np.float64)
        self._lower = np.array(reg.lower_[self._cols], dtype=np.float64)
        self._upper = np.array(reg.upper_[self._cols], dtype=np.float64)
        n_out = reg.n_outputs_
        coefs = [np.asarray(m.coefficients, dtype=np.float64).reshape(len(m.columns), n_out) for m in members]
        self._coef = np.array(np.concatenate(coefs) if coefs else np.zeros((0, n_out)), dtype=np.float64, order="C")
        self._weight = np.array([m.weight for m in members], dtype=np.float64)
        self._prior = np.array([_PRIORS[m.prior] for m in members], dtype=np.int64)
        self._members = members

    def displacement(self, row: np.ndarray, offset: np.ndarray | None, prim_offset: np.ndarray | None) -> np.ndarray:
        """(1, J·3) :meth:`~.switching.SwitchingRegression.displacement` of one row (1, ·) with the priors (1, J·3) or
        ``None`` (each read only by members whose prior it is)."""
        reg = self.regression
        if not hasattr(reg, "members_"):
            raise ModelError("switching regression: call fit(...) before displacement")
        if self._members is not reg.members_:
            self._pack()
        empty = np.zeros(0)
        for code, given, name in ((1, offset, "from_plan"), (2, prim_offset, "from_primitive")):
            if given is None and (self._prior == code).any():
                raise ModelError(f"switching regression: a member's prior is {name!r}: pass its offset")
        out = np.empty((1, reg.n_outputs_))
        self._kernel(out[0], np.ascontiguousarray(row[0], dtype=np.float64),
                     empty if offset is None else np.ascontiguousarray(offset[0], dtype=np.float64),
                     empty if prim_offset is None else np.ascontiguousarray(prim_offset[0], dtype=np.float64),
                     self._cols, self._starts, self._scale, self._lower, self._upper, self._coef, self._weight,
                     self._prior, bool(reg.config.clip_features))
        return out
