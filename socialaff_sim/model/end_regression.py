"""End-configuration regression: agent 1's key joints at a sub-event's end given its context.

The paper's potentials score each of agent 1's joints against its own reference independently,
so the most likely candidate scatters the wrists and ankles around the body (docs/design.md).
This term models agent 1's five key joints *jointly*: per sub-event type, a ridge regression
from the interval's context to agent 1's end configuration, with a Gaussian residual.

Context (all relative to the anchor, agent 0's base at the interval's end, canonical metres):
agent 0's other four key joints at the end, the object at the end (when the model uses one),
agent 1's five key joints on the frame before the interval and on the instance's reference frame
(T0 − 1, the last frame observed before synthesis: it keeps the errors of earlier sub-events from
compounding), and the anchor itself.
Target: agent 1's five key joints at the end relative to the anchor, flattened to 15 values.

The ridge penalty λ is chosen per type by leave-one-out error (:func:`~socialaff_sim.model.ridge.fit_ridge`),
and with it whether the ridge shrinks toward the training mean or toward agent 1's pose at the
reference frame (the offset columns, :func:`offset_columns`).
"""

from __future__ import annotations

import numpy as np

from ..data.skeletons import N_KEY
from .joints import OBJECT
from .ridge import RidgeRegression, fit_ridge

__all__ = ["end_context", "fit_end_regression", "interval_samples", "n_context", "offset_columns"]


def n_context(available: np.ndarray) -> int:
    """Length of the context vector for a model using the joints ``available`` (11,)."""
    return 3 * ((N_KEY - 1) + 2 * N_KEY + 1 + int(bool(available[OBJECT])))


def offset_columns(available: np.ndarray) -> np.ndarray:
    """(15,) int64: the context columns of agent 1's key joints at the reference frame, in target order."""
    start = 3 * ((N_KEY - 1) + int(bool(available[OBJECT])) + N_KEY)
    return np.arange(start, start + 3 * N_KEY)


def interval_samples(
    tracks: list[np.ndarray], spans: list[list[tuple[int, int, int]]], s: int, reference: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """End, previous-frame and reference-frame configurations (M, 11, 3) of every interval labelled
    ``s`` in the parses ``spans`` (rows start, stop exclusive, label) of canonical ``tracks`` (T_i, 11, 3);
    the reference frame is ``reference`` (T0 − 1), or an instance's last frame if it is shorter."""
    rows = [
        (x[b - 1], x[max(a - 1, 0)], x[min(reference, len(x) - 1)])
        for x, sp in zip(tracks, spans, strict=True)
        for a, b, lab in sp
        if lab == s
    ]
    if not rows:
        empty = np.zeros((0, tracks[0].shape[1] if tracks else 11, 3))
        return empty, empty.copy(), empty.copy()
    end, before, ref = (np.stack(c) for c in zip(*rows))
    return end, before, ref


def end_context(end: np.ndarray, before: np.ndarray, reference: np.ndarray, available: np.ndarray) -> np.ndarray:
    """(M, C) context of M intervals from their end, previous-frame and reference-frame
    configurations (each (M, 11, 3), canonical metres); absent joints read as 0 (they are absent in
    every sample)."""
    end = np.asarray(end, float)
    anchor = end[:, 0:1]
    parts = [end[:, 1:N_KEY] - anchor]
    if available[OBJECT]:
        parts.append(end[:, OBJECT : OBJECT + 1] - anchor)
    for cfg in (before, reference):
        parts.append(np.asarray(cfg, float)[:, N_KEY : 2 * N_KEY] - anchor)
    parts.append(anchor)
    # Explicit widths: with no interval (M = 0, a type no parse uses) reshape cannot infer them.
    return np.nan_to_num(np.concatenate([p.reshape(end.shape[0], int(np.prod(p.shape[1:]))) for p in parts], axis=1))


def _target(end: np.ndarray) -> np.ndarray:
    """(M, 15) agent 1's key joints at the end relative to agent 0's base."""
    end = np.asarray(end, float)
    return np.nan_to_num((end[:, N_KEY : 2 * N_KEY] - end[:, 0:1]).reshape(end.shape[0], 3 * N_KEY))


def fit_end_regression(
    end: np.ndarray, before: np.ndarray, reference: np.ndarray, available: np.ndarray, *, sigma_min: float
) -> RidgeRegression | None:
    """Fit one type's regression from M ≥ 3 intervals' end, previous-frame and reference-frame
    configurations (M, 11, 3) canonical metres; ``None`` with fewer intervals."""
    X = end_context(end, before, reference, available)
    Y = _target(end)
    M = X.shape[0]
    if M < 3:
        return None
    return fit_ridge(X, Y, np.arange(M), sigma_min=sigma_min, offset_columns=offset_columns(available))
