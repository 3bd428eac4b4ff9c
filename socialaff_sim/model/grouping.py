"""Prior over joint selection and grouping Z^s: Bernoulli(β) selection times a CRP(γ) partition.

A grouping vector ``z`` (J,) int holds ``-1`` for an absent joint, ``0`` for Null and a
group id ``h >= 1`` for an affordable joint. With M selected joints in H groups of sizes
M_h among the J' present joints,

    log p(Z) = M log β + (J' − M) log(1 − β) + H log γ + Σ_h log (M_h − 1)! − Σ_{i<M} log(γ + i),

which for γ = 1 is the paper's ∏(M_h − 1)!/M! times the Bernoulli terms. The Gibbs
conditional of one joint given the others (Z_−ai, with M_−ai selected joints) follows:
Null ∝ 1 − β, existing group h ∝ β M_h / (M_−ai + γ), new group ∝ β γ / (M_−ai + γ).
"""

from __future__ import annotations

import numpy as np
from scipy.special import gammaln

__all__ = ["log_prior", "conditional_log_prior", "canonical_ids", "group_sizes"]


def canonical_ids(z: np.ndarray) -> np.ndarray:
    """Renumber groups 1, 2, … in order of first appearance (Null and absent unchanged)."""
    z = np.asarray(z, dtype=np.int64)
    out = z.copy()
    seen: dict[int, int] = {}
    for j, h in enumerate(z):
        if h > 0:
            out[j] = seen.setdefault(int(h), len(seen) + 1)
    return out


def group_sizes(z: np.ndarray) -> np.ndarray:
    """Sizes M_h of the groups present, in id order (ids need not be contiguous)."""
    z = np.asarray(z)
    sel = z[z > 0]
    if sel.size == 0:
        return np.zeros(0, dtype=np.int64)
    return np.unique(sel, return_counts=True)[1]


def log_prior(z: np.ndarray, beta: float, gamma: float) -> float:
    """log p(Z^s) of one grouping vector (absent joints ignored)."""
    z = np.asarray(z)
    present = int((z >= 0).sum())
    sizes = group_sizes(z)
    M = int(sizes.sum())
    H = sizes.size
    crp = H * np.log(gamma) + float(gammaln(sizes).sum()) - float(np.log(gamma + np.arange(M)).sum())
    return float(M * np.log(beta) + (present - M) * np.log1p(-beta) + crp)


def conditional_log_prior(z: np.ndarray, j: int, beta: float, gamma: float) -> tuple[np.ndarray, np.ndarray]:
    """Options for joint ``j`` given the others and their unnormalized log prior weights.

    Returns ``(options, logw)``: options are group ids (0 = Null, existing ids of the other
    joints, then ``max id + 1`` for a new group) and their log weights
    ``log(1 − β)``, ``log(β M_h / (M_−j + γ))``, ``log(β γ / (M_−j + γ))``.
    """
    z = np.asarray(z)
    others = np.delete(z, j)
    sel = others[others > 0]
    M = sel.size
    ids, counts = (np.unique(sel, return_counts=True) if M else (np.zeros(0, np.int64), np.zeros(0, np.int64)))
    new_id = int(max(z.max(), 0)) + 1
    options = np.concatenate([[0], ids, [new_id]]).astype(np.int64)
    denom = np.log(M + gamma)
    logw = np.concatenate(
        [[np.log1p(-beta)], np.log(beta) + np.log(counts) - denom, [np.log(beta) + np.log(gamma) - denom]]
    )
    return options, logw
