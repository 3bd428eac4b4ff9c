"""CPU time of the interaction primitive's per-frame solve within T_max against recursive alternatives (issue 24).

Within the longest training duration the primitive stream factors its a-block M = S + B_a (n×n; n = 216 on the
handovers) at every frame; the next frame adds a rank-m term U D Uᵀ (U = I ⊗ φ, m = 18 DoFs, N = 12 basis
functions per DoF). Times, on a random SPD matrix of that size and one thread: the direct solve (copy, LAPACK
``dpotrf`` and ``dpotrs``); a rank-m update of the Cholesky factor by LAPACK's triangular-pentagonal QR
(``dtpqrt``); the Woodbury solve from an anchor factor (A⁻¹U: ``dpotrs`` with m right-hand sides); the
covariance-form update of M⁻¹ (information filter: P − PU (D⁻¹ + UᵀPU)⁻¹ UᵀP, PU by the Kronecker structure) and
its renewal (``dpotri`` and the symmetrisation). Each check's result is compared with ``numpy.linalg`` so the timed
code is the working code.

    OMP_NUM_THREADS=1 python scripts/bench_primitive_solve.py [--n-dof 18 --n-basis 12 --repeats 300]
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from scipy.linalg.lapack import dpotrf, dpotri, dpotrs, dtpqrt  # noqa: E402


def _ms(f: Callable[[], object], repeats: int) -> float:
    f()
    c0 = time.thread_time()
    for _ in range(repeats):
        f()
    return (time.thread_time() - c0) / repeats * 1e3


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n-dof", type=int, default=18)
    p.add_argument("--n-basis", type=int, default=12)
    p.add_argument("--repeats", type=int, default=300)
    args = p.parse_args()
    m, nb = args.n_dof, args.n_basis
    n = m * nb
    rng = np.random.default_rng(0)
    x = rng.normal(size=(n, n))
    a = x @ x.T + n * np.eye(n)
    phi = rng.random(nb)
    phi /= phi.sum()
    w = np.full(m, 100.0)  # 1/σ_h², σ_h = 0.1 m
    u = np.kron(np.eye(m), phi[:, None])  # (n, m)
    new = a + (u * w) @ u.T
    b = rng.normal(size=n)
    ref = np.linalg.solve(new, b)
    chol, _ = dpotrf(a.copy(order="F"), lower=1, clean=1)

    def direct() -> np.ndarray:
        c, _ = dpotrf(new.copy(order="F"), lower=1, clean=0, overwrite_a=1)
        return dpotrs(c, b, lower=1)[0]

    def qr_update() -> np.ndarray:
        r = dtpqrt(0, m, np.triu(chol.T).copy(order="F"), np.asfortranarray((u * np.sqrt(w)).T))[0]
        return dpotrs(np.triu(r).T.copy(order="F"), b, lower=1)[0]

    def woodbury() -> np.ndarray:
        au = dpotrs(chol, u, lower=1)[0]
        y = dpotrs(chol, b, lower=1)[0]
        z = np.linalg.solve(np.eye(m) + w[:, None] * (u.T @ au), w * (u.T @ y))
        return y - au @ z

    inv_a = np.linalg.inv(a)

    def cov_update() -> np.ndarray:
        pu = inv_a.reshape(n, m, nb) @ phi  # (n, m) P U
        c = (pu.reshape(m, nb, m).transpose(0, 2, 1) @ phi).T  # (m, m) Uᵀ P U
        g = np.linalg.solve(np.eye(m) + w[:, None] * c, np.diag(w))
        return (inv_a - pu @ g @ pu.T) @ b

    def renewal() -> np.ndarray:
        inv, _ = dpotri(chol, lower=1)
        inv = np.tril(inv)
        inv += np.tril(inv, -1).T
        return inv

    for name, f in (("direct: copy, dpotrf, dpotrs", direct), ("rank-m factor update (dtpqrt) and dpotrs", qr_update),
                    ("Woodbury from the anchor factor", woodbury), ("covariance form: update of M⁻¹ and M⁻¹b", cov_update)):
        err = float(np.abs(f() - ref).max() / np.abs(ref).max())
        print(f"{name:45s} {_ms(f, args.repeats):7.3f} ms   (relative error {err:.1e})")
    err = float(np.abs(renewal() - inv_a).max() / np.abs(inv_a).max())
    print(f"{'covariance form: renewal (dpotri, symmetrise)':45s} {_ms(renewal, args.repeats):7.3f} ms   "
          f"(relative error {err:.1e})")
    print(f"n = {n}, m = {m}; load {os.getloadavg()}")


if __name__ == "__main__":
    main()
