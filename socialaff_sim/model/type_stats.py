"""Summaries of the learned sub-event types that synthesis and reports use besides the potentials."""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..data.interaction import Interaction
from .potentials import reference_weights

__all__ = ["name_subevents", "vertical_up_frequencies"]


def vertical_up_frequencies(
    end: np.ndarray, disp: np.ndarray, z: np.ndarray, other_side: bool, include_self: bool = False
) -> np.ndarray:
    """(2, 11) add-one smoothed frequency of dz > 0 of spatial offsets and of displacements."""
    W = reference_weights(z, other_side=other_side, include_self=include_self)
    off_z = end[:, :, 2] - np.nan_to_num(end[:, :, 2]) @ W.T
    n = end.shape[0]
    return np.stack([((off_z > 0).sum(axis=0) + 1.0) / (n + 2.0), ((disp[:, :, 2] > 0).sum(axis=0) + 1.0) / (n + 2.0)])


def name_subevents(inters: list[Interaction], spans: list[list[tuple[int, int, int]]], S: int) -> tuple[str, ...]:
    """Name learned types after the ground-truth sub-events they overlap most (optimal one-to-one
    matching over frames) when every instance has them with the same names; else s0, s1, …"""
    names = [f"s{s}" for s in range(S)]
    gt_names = {i.subevent_names for i in inters}
    if len(gt_names) != 1 or any(i.subevents is None for i in inters) or not next(iter(gt_names)):
        return tuple(names)
    gt = next(iter(gt_names))
    overlap = np.zeros((S, len(gt)))
    for inter, sp in zip(inters, spans, strict=True):
        for f0, f1, s in sp:
            g = inter.subevents[f0:f1]  # type: ignore[index]
            g = g[g >= 0]
            overlap[s] += np.bincount(g, minlength=len(gt))
    rows, cols = linear_sum_assignment(-overlap)
    for r, c in zip(rows, cols, strict=True):
        if overlap[r, c] > 0:
            names[r] = gt[c]
    return tuple(names)
