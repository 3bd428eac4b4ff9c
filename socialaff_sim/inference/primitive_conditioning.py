"""The fixed part of the interaction primitive's conditioning on a stream, shared by the streams of one fitted
primitive (:class:`~.primitive_stream.PrimitiveStream`, module docstring there).

Agent 1 is seen only in its first T0 frames, so its block Λ_rr = P_rr + B_r of the information matrix is fixed
once a stream starts. Per candidate duration, Λ_rr's Cholesky factor, K = Λ_rr⁻¹ P_ra and the Schur complement
S = P_aa − P_ar K depend on the instance only through B_r, which is the same on every instance whose agent 1 is
tracked alike in its first T0 frames: they are made once per primitive (anew if it is refitted: a new
``precision_``), keyed by the candidate and B_r's bytes, at most :data:`SHARED_SOLVERS` of them, and
:func:`warm_fixed_parts` makes the usual ones before a stream's first frame.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from .interaction_primitive import InteractionPrimitive
from .primitive_sums import outer_sums

__all__ = ["SHARED_SOLVERS", "add_blocks", "fixed_parts", "warm_fixed_parts"]

SHARED_SOLVERS = 32
"""[—]: At most this many candidates' fixed conditioning parts (S, K and Λ_rr's factor, about 0.9 MB each on the
handovers; one per candidate duration and agent-1 tracking pattern) are kept per fitted primitive, shared by its
streams (oldest dropped first)."""

_SHARED: weakref.WeakKeyDictionary[InteractionPrimitive, tuple[np.ndarray, dict[tuple[int, bytes], tuple[np.ndarray, ...]]]]
_SHARED = weakref.WeakKeyDictionary()  # per primitive: its precision_ (a refit replaces it) and the fixed parts
_WARM: weakref.WeakKeyDictionary[InteractionPrimitive, tuple[np.ndarray, set[int]]] = weakref.WeakKeyDictionary()


def add_blocks(lam: np.ndarray, blocks: np.ndarray) -> np.ndarray:
    """``lam`` (M·N, M·N) plus the block-diagonal of ``blocks`` (M, N, N), in place."""
    m, n = blocks.shape[:2]
    view = lam.reshape(m, n, m, n)
    diag = np.arange(m)
    view[diag, :, diag, :] += blocks
    return lam


def fixed_parts(primitive: InteractionPrimitive, a: int, duration: int,
                blocks: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Λ_rr's lower Cholesky factor (r, r), K (r, a) and S (a, a) of the candidate ``duration`` (frames) given
    agent 1's information blocks B_r ``blocks`` (r-DoFs, N, N); ``a`` the size of the agent-0 (and object) block.
    Shared between the streams of ``primitive`` (module docstring)."""
    entry = _SHARED.get(primitive)
    if entry is None or entry[0] is not primitive.precision_:
        entry = _SHARED[primitive] = (primitive.precision_, {})
    shared = entry[1]
    key = (int(duration), blocks.tobytes())
    if key not in shared:
        prec = primitive.precision_
        lam_rr = add_blocks(prec[a:, a:].copy(), blocks)
        factor = cho_factor(0.5 * (lam_rr + lam_rr.T), lower=True, check_finite=False)
        k = cho_solve(factor, prec[a:, :a], check_finite=False)
        s = prec[:a, :a] - prec[:a, a:] @ k
        if len(shared) >= SHARED_SOLVERS:
            shared.pop(next(iter(shared)))  # the oldest
        shared[key] = (factor[0], k, 0.5 * (s + s.T))
    return shared[key]


def warm_fixed_parts(primitive: InteractionPrimitive, n_observed: int, a: int, durations: np.ndarray,
                     inv_var_r: np.ndarray, rbf: Callable[[np.ndarray], np.ndarray]) -> None:
    """Make every candidate's fixed part (:func:`fixed_parts`) for an agent 1 tracked in all of its first T0 =
    ``n_observed`` frames (the usual recording) before the first frame, once per primitive and T0 (the reactor's
    constructor calls it through :meth:`~.primitive_stream.PrimitiveStream.warm`): on the first recording after a
    load they were made at the frames where the chosen duration first changed to each candidate (a factorisation
    each, 1.5–3 ms). B_r is what a stream's first call adds, the view's T0 + 1 frames at once
    (:meth:`~.primitive_sums.PrimitiveSums._add_rows`, agent 1 seen before T0): the same products and sums, so the
    same bytes, the same key; a recording tracked otherwise misses and makes its own. ``durations`` (C,) the
    candidates (frames), ``inv_var_r`` (r-DoFs,) agent 1's 1/σ², ``rbf`` the basis (G,) phases → (G, N)."""
    entry = _WARM.get(primitive)
    if entry is None or entry[0] is not primitive.precision_:
        entry = _WARM[primitive] = (primitive.precision_, set())
    if n_observed in entry[1]:
        return
    frames = np.arange(n_observed + 1)
    span = np.maximum(durations - 1, 1)  # every candidate is active at frame 0
    phi = rbf(np.minimum(frames[:, None] / span[None], 1.0).ravel()).reshape(len(frames), len(durations), -1)
    w = np.where(frames[:, None] < n_observed, inv_var_r[None], 0.0)  # seen × 1/σ², as _add_rows
    blocks = 0.0 + 1.0 * outer_sums(phi, w)  # the sums start at zero; sign 1.0
    for c, duration in enumerate(durations):
        fixed_parts(primitive, a, int(duration), np.ascontiguousarray(blocks[c]))
    entry[1].add(n_observed)
