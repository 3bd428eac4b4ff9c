"""The arms' damped least-squares steps compiled (``BalanceConfig.qp_kernel = "numba"``).

:mod:`~.arm_compensation` maps a wrist's shift onto its arm's hinges, Jᵀ (J Jᵀ + λ² I)⁻¹ e on three rows, and
:mod:`~.hand_yield` a wrist's horizontal offset and its rate, Jᵀ (J Jᵀ + λ² I)⁻¹ on two, with a dozen NumPy and LAPACK
calls per arm and driven physics step. :func:`damped_step` does it in one no-Python loop
(:func:`~socialaff_sim.inference.compiled.njit`, fast-math off), the small system solved by Cholesky's
factorisation (J Jᵀ + λ² I is symmetric positive definite), not LAPACK's LU: its results differ from NumPy's in
their last digits, an alternative evaluation judged with ``qp_kernel="numba"`` by its rule (docs/design.md §5,
session 34). NumPy stays the reference. :func:`yield_update` (the arms' give: the feet's allowance, the
rate and the offsets) and :func:`compensation_share` (the compensation's fade and approach gate) likewise.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..inference.compiled import njit, once

__all__ = ["arm_kernel", "damped_step", "yield_update", "compensation_share"]


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


def _yield_update(force, offset, R, lo, hi, capture, margin, weight, height, at, twist, fraction, damping, back, dt,
                  max_offset):  # pragma: no cover - compiled; tested through HandYield
    """:meth:`~.hand_yield.HandYield.update`'s arithmetic: the new offset (2, 2), the rate (2, 2) and whether the arms
    gave way (``twist`` NaN: no twist bound; ``height``: the forces' height above the floor)."""
    t0, t1 = force[0, 0] + force[1, 0], force[0, 1] + force[1, 1]
    nrm = math.sqrt(t0 * t0 + t1 * t1)
    allow = 0.0
    if nrm > 0:
        u0, u1 = t0 / nrm, t1 / nrm
        l0, l1 = R[0, 0] * u0 + R[0, 1] * u1, R[1, 0] * u0 + R[1, 1] * u1  # the direction along the box's axes
        edge = ((hi[0] if l0 >= 0.0 else lo[0]) * l0 + (hi[1] if l1 >= 0.0 else lo[1]) * l1) - margin
        moment = weight * (edge - (capture[0] * u0 + capture[1] * u1))
        moment += (force[0, 2] + force[1, 2]) * ((at[0] * u0 + at[1] * u1) - edge)
        allow = max(moment / max(height, 1e-3), 0.0)
        if not math.isnan(twist):  # the box's middle, world
            c0, c1 = 0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])
            m0, m1 = c0 * R[0, 0] + c1 * R[1, 0], c0 * R[0, 1] + c1 * R[1, 1]
            lever = abs((at[0] - m0) * u1 - (at[1] - m1) * u0)
            allow = min(allow, twist * weight / lever if lever > 1e-9 else np.inf)
    rate = np.zeros((2, 2))
    excess = nrm - fraction * allow
    gave = False
    if not (excess <= 0.0 or nrm <= 0.0):
        for s in range(2):
            for a in range(2):
                rate[s, a] = excess / damping * force[s, a] / nrm
                gave = gave or rate[s, a] != 0.0
    if not gave:  # the offsets return
        for s in range(2):
            for a in range(2):
                rate[s, a] = -offset[s, a] / back if back > 0 else -offset[s, a] / dt
    out = np.empty((2, 2))
    for s in range(2):
        o0, o1 = offset[s, 0] + dt * rate[s, 0], offset[s, 1] + dt * rate[s, 1]
        k = min(1.0, max_offset / max(math.sqrt(o0 * o0 + o1 * o1), 1e-12))
        out[s, 0], out[s, 1] = o0 * k, o1 * k
    return out, rate, gave


def _share(force, release, fraction, gated, wrists, targets, touched, radius):  # pragma: no cover - compiled; tested through ArmCompensation
    """:mod:`~.arm_compensation`'s share per arm (2,): c (1 − |f| / F_r) clipped to [0, 1]; with ``gated`` times
    :func:`~.arm_compensation.approach_gate` of ``wrists`` (2, 3) to ``targets`` (K, 3) (``touched`` (2,))."""
    out = np.empty(2)
    for s in range(2):
        f = math.sqrt(force[s, 0] * force[s, 0] + force[s, 1] * force[s, 1] + force[s, 2] * force[s, 2])
        out[s] = fraction * min(max(1.0 - f / release, 0.0), 1.0)
        if gated and targets.shape[0] == 0:  # nothing to reach for
            out[s] = 0.0
        elif gated:
            best = np.inf
            for t in range(targets.shape[0]):
                d0, d1, d2 = wrists[s, 0] - targets[t, 0], wrists[s, 1] - targets[t, 1], wrists[s, 2] - targets[t, 2]
                best = min(best, math.sqrt(d0 * d0 + d1 * d1 + d2 * d2))
            out[s] *= 1.0 if best <= radius and not touched[s] else 0.0
    return out


def arm_kernel() -> Any:
    """The compiled :func:`_damped`, :func:`_yield_update` and :func:`_share` (made and warmed up once per process;
    numba missing: a ConfigError)."""
    return once(__name__, lambda: {"damped": njit(_damped), "yield": njit(_yield_update), "share": njit(_share)},
                _warm)


def _warm(fns: Any) -> None:
    """One call of each of the argument types their callers pass."""
    fns["damped"](np.eye(3, 5), np.arange(3, dtype=np.int64), 3, 0.0025, np.ones((1, 3)), np.zeros((1, 3)))
    z2 = np.zeros(2)
    fns["yield"](np.zeros((2, 3)), np.zeros((2, 2)), np.eye(2), z2, z2, z2, 0.01, 1.0, 1.0, z2, 0.02, 0.5, 50.0, 1.0,
                 0.004, 0.3)
    fns["share"](np.zeros((2, 3)), 20.0, 1.0, True, np.zeros((2, 3)), np.zeros((1, 3)), np.zeros(2, dtype=np.bool_),
                 1.0)


def damped_step(jac: np.ndarray, dofs: np.ndarray, lam: float, *rhs: np.ndarray) -> np.ndarray:
    """(len(rhs), k): per right-hand side e (r,) of ``rhs`` the hinge step Jᵀ (J Jᵀ + λ² I)⁻¹ e, J the first r rows of
    ``jac`` (3, nv) (a point's translational Jacobian, world) on the columns ``dofs`` (k,), damped by ``lam`` λ (m)."""
    e = np.array(rhs, dtype=np.float64)
    out = np.empty((len(rhs), len(dofs)))
    arm_kernel()["damped"](jac, dofs, e.shape[1], lam * lam, e, out)
    return out


def yield_update(*args: Any) -> tuple[np.ndarray, np.ndarray, bool]:
    """:func:`_yield_update` compiled (its arguments as :meth:`~.hand_yield.HandYield.update` passes them)."""
    return arm_kernel()["yield"](*args)


def compensation_share(*args: Any) -> np.ndarray:
    """:func:`_share` compiled (its arguments as :meth:`~.arm_compensation.ArmCompensation.offsets` passes them)."""
    return arm_kernel()["share"](*args)
