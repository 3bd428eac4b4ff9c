"""Hedging the synthesis against wrong futures: which sub-events to plan for, and how far to trust the plan.

A causal predictor can always fall back to holding still; one that commits to a single sub-event,
end and configuration pays for every wrong commitment. From the forward belief
(:class:`~socialaff_sim.inference.forward_belief.ForwardBelief`) :func:`branch_plans` picks the
sub-events worth planning for and their weights, and :func:`shrink_factor` how much of the plan's
displacement from ``hold`` to keep when the belief is uncertain.
"""

from __future__ import annotations

import numpy as np

__all__ = ["BRANCH_FLOOR", "branch_plans", "shrink_factor"]

BRANCH_FLOOR = 0.1
"""Least belief of a sub-event planned for besides the most probable one (fixed a priori)."""


def branch_plans(
    starts: np.ndarray, posterior: np.ndarray, branches: int, allowed: np.ndarray | None = None
) -> list[tuple[float, int, int]]:
    """(weight, sub-event, start frame) of the at most ``branches`` most probable sub-events of the joint
    posterior ``posterior`` (K, S) over the running interval's start ``starts`` (K,) and its label; each
    sub-event's start is its most probable one. The most probable sub-event is always planned, the others
    when their belief is at least :data:`BRANCH_FLOOR`; the weights are their beliefs, renormalised.
    ``allowed`` (S,) bool: only those sub-events, the posterior restricted to them and renormalised (the
    floor then applies to the restricted belief); an empty list when none of them has any mass."""
    if allowed is not None:
        posterior = np.where(np.asarray(allowed, bool)[None], posterior, 0.0)
        mass = float(posterior.sum())
        if not mass > 0:
            return []
        posterior = posterior / mass
    belief = posterior.sum(axis=0)
    order = np.argsort(-belief, kind="stable")[: max(int(branches), 1)]
    keep = [int(s) for k, s in enumerate(order) if k == 0 or belief[s] >= BRANCH_FLOOR]
    w = belief[keep] / belief[keep].sum()
    return [(float(wk), s, int(starts[int(np.argmax(posterior[:, s]))])) for wk, s in zip(w, keep, strict=True)]


def shrink_factor(belief: np.ndarray, shrink: float) -> float:
    """α = 1 − shrink · H(belief) / log |S| ∈ [0, 1]: 1 for a certain belief, 1 − shrink for a uniform one."""
    p = np.asarray(belief, dtype=float)
    S = p.shape[0]
    if S < 2:
        return 1.0
    nz = p[p > 0]
    entropy = float(-(nz * np.log(nz)).sum())
    return float(np.clip(1.0 - shrink * entropy / np.log(S), 0.0, 1.0))
