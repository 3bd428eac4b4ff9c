"""The interaction primitive stream's running sums (:mod:`.primitive_stream`): adding frames to them.

Per candidate duration T̂ (index c) and degree of freedom d: the information HᵀR⁻¹H (``_hth``, (C, D, N, N)),
HᵀR⁻¹y (``_hty``, (C, D, N)) and the duration match's squared error (``_err``, (C,)). A frame s is at phase
min(s / (T̂ − 1), 1) for each candidate. :meth:`PrimitiveSums._add_frame` is the per-frame call (the stream's usual
one): the same sums, bitwise, as the gathers of :meth:`PrimitiveSums._add_rows`, from a table of the basis rows and
with the active candidates and the seen DoFs as slices.
"""

from __future__ import annotations

import numpy as np

from ..errors import ModelError
from .low_rank_solve import LowRankUpdatedSolver
from .primitive_kernel import UpdatedFactor

__all__ = ["PrimitiveSums", "diagonal_blocks", "outer_sums"]


class PrimitiveSums:
    """The running sums' updates, a base of :class:`~.primitive_stream.PrimitiveStream`, which sets the attributes
    read here: ``n_observed`` (T0), ``t_max``, ``_cands`` (C,) sorted durations, ``_d0`` (agent 0's and the object's
    DoFs), ``_n`` (N), ``_inv_var`` (D,), ``_mean`` (D, N), ``_table`` (T_max + 1, C, N) the basis rows,
    ``_first`` (d0,) and ``_mu0`` (d0,), the sums, ``_col_runs`` and the past-T_max solver ``_phase_one``."""

    n_observed: int
    t_max: int
    _cands: np.ndarray
    _d0: int
    _n: int
    _inv_var: np.ndarray
    _mean: np.ndarray
    _table: np.ndarray
    _first: np.ndarray
    _mu0: np.ndarray
    _hth: np.ndarray
    _hty: np.ndarray
    _err: np.ndarray
    _col_runs: dict[bytes, _Seen]
    _phase_one: LowRankUpdatedSolver | None
    _phase_one_frames: int
    _log: list[tuple[int, np.ndarray, _Seen]]
    _log_base: int
    _done: list[int]
    _active: int
    _factor: UpdatedFactor | None

    def _rbf(self, phase: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def _add(self, frames: np.ndarray, y: np.ndarray, sign: float = 1.0, information: bool = True) -> None:
        """Add (``sign`` −1: remove) frames (G,) with canonical DoF values y (G, D) (NaN: not seen) to the sums;
        ``information`` False leaves HᵀR⁻¹H alone (the values change, not which are seen).

        Only the candidates still to be chosen are updated: T̂ ≥ the frames seen (the calls' ``stop`` grows), and
        T_max (the bounded rule); the others' sums are left as they were (never read again)."""
        if len(frames) == 1 and sign == 1.0 and information:
            self._add_frame(int(frames[0]), y[0])
        else:
            self._add_rows(frames, y, sign, information)

    def _add_rows(self, frames: np.ndarray, y: np.ndarray, sign: float = 1.0, information: bool = True) -> None:
        """:meth:`_add` by gathers over the active candidates and seen DoFs (any frames, any sign); the frames
        deferred before it are added first (:meth:`flush`), so every candidate's sums gain their terms in order."""
        self._flush_active()
        if information and self._factor is not None:  # the compiled path's factor: made anew at the next read
            self._factor.forget()
        seen = np.isfinite(y)
        seen[frames >= self.n_observed, self._d0 :] = False  # agent 1 after the prefix is never used
        act = np.flatnonzero((self._cands > frames[0]) | (self._cands == self.t_max))
        cols = np.flatnonzero(seen.any(axis=0))
        yz = np.where(seen[:, cols], y[:, cols], 0.0) * self._inv_var[cols]  # (G, K)
        # The basis rows at phases min(s / (T̂ − 1), 1), read from the table (rbf_rows's value at each row's own phase;
        # frames past T_max are at phase 1 for every candidate, the table's last row), not evaluated again.
        phi = self._table[np.minimum(frames, self.t_max)][:, act]
        sub = _block(act, cols)
        if len(frames) == 1:  # the per-frame path
            p0 = phi[0]
            hty = p0[:, None, :] * yz[0][None, :, None]
            if sign != 1.0:  # 1.0 × a is a: the usual (adding) call skips the product
                hty *= sign
            self._hty[sub] += hty
            if information:
                w = seen[0, cols] * self._inv_var[cols]
                outer = p0[:, :, None] * p0[:, None, :]  # (A, N, N)
                if w.size and (w == w[0]).all():  # one weight for every DoF (the usual frame): the same products, broadcast
                    hth = (outer * w[0])[:, None]
                else:
                    hth = outer[:, None] * w[None, :, None, None]
                if sign != 1.0:
                    hth *= sign
                self._hth[sub] += hth
                if self._phase_one is not None:  # past T_max: the frame's phase is 1 (anchored at ≥ T_max frames)
                    a_cols = cols < self._d0
                    self._phase_one.weights[cols[a_cols]] += sign * w[a_cols]
                    self._phase_one_frames += 1
        else:
            self._hty[sub] += sign * np.einsum("gcn,gd->cdn", phi, yz)
            if information:
                w = seen[:, cols] * self._inv_var[cols]
                self._hth[sub] += sign * outer_sums(phi, w)
        # The duration match: frames s < T̂ of each candidate, agent 0's (and the object's) DoFs.
        eligible = frames[:, None] < self._cands[act][None]
        if not eligible.any():  # past every candidate (a long stream): the sums would gain zeros
            return
        obs = y[:, : self._d0] - self._first[None]
        ok = np.isfinite(obs)
        mu = phi @ self._mean[: self._d0].T - self._mu0  # (G, A, d0)
        sq = np.where(ok[:, None], obs[:, None] - mu, 0.0) ** 2
        self._err[act] += sign * np.where(eligible, sq.sum(axis=2), 0.0).sum(axis=0)

    def _reset_log(self) -> None:
        """No frame deferred (the sums start anew)."""
        self._log: list[tuple[int, np.ndarray, _Seen]] = []
        self._log_base = 0  # the log's first entry's index among every frame deferred
        self._done = [0] * len(self._cands)  # per candidate: the frames deferred up to this index are in its sums
        self._active = 0  # the first active candidate at the last frame added
        if self._factor is not None:
            self._factor.forget()

    def _add_terms(self, lo: int, p0: np.ndarray, yz: np.ndarray, pattern: _Seen) -> None:
        """A frame's information terms for candidates [lo, lo + A) with basis rows ``p0`` (A, N) and weighted values
        ``yz`` (K,) of the seen DoFs ``pattern``: HᵀR⁻¹y += φ (y/σ²), HᵀR⁻¹H += φφᵀ/σ² per seen DoF."""
        hi = lo + len(p0)
        outer = p0[:, :, None] * p0[:, None, :]  # (A, N, N)
        equal = pattern.w0 is not None
        hth = (outer * pattern.w0)[:, None] if equal else outer[:, None] * pattern.w[None, :, None, None]  # equal: broadcast
        # The seen DoFs as runs of consecutive columns (e.g. agent 0's never-tracked ankles between its arms and
        # the object): a slice per run instead of a gather and a scatter of the same entries (the same sums).
        for a, b, ka, kb in pattern.runs:
            self._hty[lo:hi, a:b] += p0[:, None, :] * yz[None, ka:kb, None]
            self._hth[lo:hi, a:b] += hth if equal else hth[:, ka:kb]

    def flush(self, c: int) -> None:
        """Add to candidate ``c``'s sums the frames deferred since it was last read, in order, each term as
        :meth:`_add_terms` makes it and the sums gaining them one after another (``np.add.accumulate`` from the
        current sum: the same additions, bitwise, as adding each frame when it came; tests/test_reactor_frames.py).
        A candidate is read only while still to be chosen, so it was active at every deferred frame."""
        k = self._done[c] - self._log_base
        if k >= len(self._log):
            return
        pending = self._log[k:]
        if len(pending) == 1:  # one frame (the chosen candidate, frame after frame): added as it would have been
            s, yz, pattern = pending[0]
            self._add_terms(c, self._table[min(s, self.t_max), c : c + 1], yz, pattern)
            pending = []
        i = 0
        while i < len(pending):  # runs of frames with the same seen DoFs (usually one run)
            pattern = pending[i][2]
            j = i + 1
            while j < len(pending) and pending[j][2] is pattern:
                j += 1
            frames = np.array([f for f, _, _ in pending[i:j]], dtype=np.int64)
            yz = np.array([v for _, v, _ in pending[i:j]])  # (G, K)
            p = self._table[np.minimum(frames, self.t_max), c]  # (G, N)
            outer = p[:, :, None] * p[:, None, :]  # (G, N, N)
            for a, b, ka, kb in pattern.runs:
                terms = p[:, None, :] * yz[:, ka:kb, None]  # (G, b − a, N)
                self._hty[c, a:b] = np.add.accumulate(np.concatenate([self._hty[c, a:b][None], terms]), axis=0)[-1]
                if pattern.w0 is not None:
                    h = np.broadcast_to((outer * pattern.w0)[:, None], (j - i, b - a) + outer.shape[1:])
                else:
                    h = outer[:, None] * pattern.w[None, ka:kb, None, None]
                self._hth[c, a:b] = np.add.accumulate(np.concatenate([self._hth[c, a:b][None], h]), axis=0)[-1]
            i = j
        self._done[c] = self._log_base + len(self._log)
        # Entries every active candidate has are dropped (the log holds at most T_max frames).
        first = min(self._done[self._active :]) - self._log_base
        if first > 0:
            del self._log[:first]
            self._log_base += first

    def _flush_active(self) -> None:
        """:meth:`flush` every candidate still active (before terms added otherwise, which must come after)."""
        for c in range(self._active, len(self._cands)):
            self.flush(c)

    def _add_frame(self, s: int, y: np.ndarray) -> None:
        """:meth:`_add` of one frame s with DoF values y (D,) (the per-frame call): the same sums, bitwise, from the
        basis table, with the active candidates (a contiguous run: the durations are sorted) and usually the seen
        DoFs as slices, and the duration match without its no-op selections. What depends on the seen DoFs alone
        (their weights, whether they are equal, their runs) is made once per pattern (:class:`_Seen`)."""
        seen = np.isfinite(y)
        if s >= self.n_observed:
            seen[self._d0 :] = False  # agent 1 after the prefix is never used
        n_c = len(self._cands)
        lo = min(int(self._cands.searchsorted(s, side="right")), n_c - 1)  # candidates > s, and T_max
        cols = seen.nonzero()[0]  # np.flatnonzero of the 1-d mask, without its wrappers
        key = cols.tobytes()
        pattern = self._col_runs.get(key)
        if pattern is None:
            pattern = self._col_runs[key] = _Seen(cols, self._inv_var, self._d0)
        p0 = self._table[min(s, self.t_max), lo:]  # (A, N)
        w = pattern.w
        yz = y[cols] * w
        self._active = lo
        if lo < n_c - 1:  # several candidates still to be chosen: their information terms wait until one is read
            self._log.append((s, yz, pattern))
        else:  # T_max alone (past the other candidates): its pending terms first, then this frame's
            self.flush(lo)
            self._add_terms(lo, p0, yz, pattern)
            self._log_base += len(self._log)
            self._log.clear()
            self._done[lo] = self._log_base
        if self._phase_one is not None:  # past T_max: the frame's phase is 1 (anchored at ≥ T_max frames)
            self._phase_one.weights[pattern.cols_a] += pattern.w_a
            self._phase_one_frames += 1
        if self._factor is not None:  # the compiled path: the a-block's terms of this frame, for its factor's update
            self._factor.record(s, pattern.cols_a, pattern.w_a)
        if s >= self.t_max:  # past every candidate (a long stream): the duration match's sums would gain zeros
            return
        obs = y[: self._d0] - self._first
        mu = p0 @ self._mean[: self._d0].T - self._mu0  # (A, d0)
        diff = obs[None] - mu
        if not np.isfinite(obs).all():
            diff = np.where(np.isfinite(obs)[None], diff, 0.0)
        self._err[lo:] += (diff**2).sum(axis=1)


class _Seen:
    """What :meth:`PrimitiveSums._add_frame` reads of a pattern of seen DoFs ``cols`` (K,), sorted, made once per
    pattern: their weights ``w`` = 1/σ² (K,), the common weight ``w0`` (``w[0]``, a NumPy scalar) when all are equal
    (else None), their runs of consecutive columns, and the agent-0 (and object) ones ``cols_a`` with weights ``w_a``
    (the past-T_max low-rank weights)."""

    __slots__ = ("cols_a", "runs", "w", "w0", "w_a")

    def __init__(self, cols: np.ndarray, inv_var: np.ndarray, d0: int) -> None:
        self.w = inv_var[cols]
        self.w0 = self.w[0] if self.w.size and bool((self.w == self.w[0]).all()) else None
        self.runs = _runs(cols)
        a_cols = cols < d0
        self.cols_a, self.w_a = cols[a_cols], self.w[a_cols]


def outer_sums(phi: np.ndarray, w: np.ndarray) -> np.ndarray:
    """(C, D, N, N) Σ_g φ[g, c, n] φ[g, c, m] w[g, d] of basis rows ``phi`` (G, C, N) and weights ``w`` (G, D):
    ``np.einsum("gcn,gcm,gd->cdnm", phi, phi, w)``'s values, bitwise — its products (φ_n φ_m) w and its sum over g from
    0 in order (tests/test_reactor_setup.py) — computed once per distinct column of ``w`` (the DoFs seen in the same
    frames with the same weight, two or three on a recording's first frames, share one) instead of once per DoF: the
    stream's first call adds T0 + 1 frames at once (about ten times cheaper on the handovers).
    The result is a pure function of ``phi`` and ``w``: the last :data:`OUTER_SUMS_KEPT` results of at most 64 frames
    are kept by their bytes and returned again, read-only (a recording's first frames, tracked in full as usual, give every recording of
    a fitted primitive the same ``phi`` and ``w``: made once, not once per recording)."""
    G, C, N = phi.shape
    key = (phi.shape, w.shape, phi.dtype.str, w.dtype.str, phi.tobytes(), w.tobytes()) if G <= _OUTER_FRAMES else None
    out = _OUTER.get(key) if key is not None else None
    if out is not None:
        return out
    distinct, inverse = np.unique(w, axis=1, return_inverse=True)  # (G, U), (D,)
    acc = np.zeros((distinct.shape[1], C, N, N))
    for g in range(G):  # one frame's outer products at a time: memory O(C N²), not O(G C N²)
        p = phi[g]
        acc += (p[:, :, None] * p[:, None, :])[None] * distinct[g][:, None, None, None]
    out = acc[inverse.ravel()].transpose(1, 0, 2, 3)
    out.setflags(write=False)
    if key is None:
        return out
    if len(_OUTER) >= OUTER_SUMS_KEPT:
        _OUTER.pop(next(iter(_OUTER)))  # the oldest
    _OUTER[key] = out
    return out


OUTER_SUMS_KEPT = 8
"""[—]: results of :func:`outer_sums` kept (about 0.6 MB each on the handovers; oldest dropped first)."""
_OUTER: dict[tuple[object, ...], np.ndarray] = {}
_OUTER_FRAMES = 64  # results of at most this many frames are kept (a first call's T0 + 1; a rebuild of a long view is not)


def diagonal_blocks(lam: np.ndarray, m: int, n: int) -> np.ndarray:
    """(m, n, n) a writable strided view of the m diagonal n×n blocks of ``lam`` (m·n, m·n), Fortran-ordered: element
    [i, p, q] is ``lam[i·n + p, i·n + q]`` (what ``lam.reshape((n, m, n, m), order="F")[:, i, :, i]`` reads and
    writes, without a gather and a scatter)."""
    if lam.shape != (m * n, m * n) or not lam.flags.f_contiguous:
        raise ModelError(f"diagonal_blocks: expected a Fortran-ordered ({m * n}, {m * n}) array, found {lam.shape}")
    it, size = lam.itemsize, m * n
    return np.ndarray((m, n, n), lam.dtype, lam, 0, ((n + n * size) * it, it, size * it))  # its base is ``lam``


def _runs(cols: np.ndarray) -> list[tuple[int, int, int, int]]:
    """The runs of consecutive indices of the sorted ``cols`` (K,): (first, end, start in cols, end in cols) each."""
    if not cols.size:
        return []
    cuts = np.flatnonzero(np.diff(cols) != 1) + 1
    starts, ends = np.r_[0, cuts], np.r_[cuts, cols.size]
    return [(int(cols[i]), int(cols[j - 1]) + 1, int(i), int(j)) for i, j in zip(starts, ends, strict=True)]


def _block(rows: np.ndarray, cols: np.ndarray) -> tuple[slice, slice] | tuple[np.ndarray, np.ndarray]:
    """The index of the (rows, cols) sub-array: slices when both runs are contiguous (the usual case: an in-place
    add on a view instead of a gather and a scatter; the same sums), else ``np.ix_``."""
    if rows.size and cols.size and rows[-1] - rows[0] + 1 == rows.size and cols[-1] - cols[0] + 1 == cols.size:
        return slice(int(rows[0]), int(rows[-1]) + 1), slice(int(cols[0]), int(cols[-1]) + 1)
    return np.ix_(rows, cols)
