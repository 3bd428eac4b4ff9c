"""Inner loop of Algorithm 1: Gibbs sampling of the joint grouping Z^s of one sub-event type.

Each site z^s_ai is drawn from p(z_ai | Z_−ai, G) ∝ p(z_ai | Z_−ai) · p(G | Z), the CRP/Bernoulli
conditional (:func:`~socialaff_sim.model.grouping.conditional_log_prior`) times the maximized
likelihood of the potentials it affects. Only the affected terms are re-evaluated: the joint's
own term, the spatial terms of the members of the group it leaves and of the group it joins.
Sites are visited in joint order. The loop keeps the best joint log-probability
log p(Z) + log p(G | Z) seen; it stops when a full sweep changes nothing, or when the best has
not improved for ``patience`` sweeps, or after ``max_sweeps``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from math import lgamma, log

import numpy as np

from ..model.grouping import canonical_ids, log_prior
from .likelihood import TypeLikelihood

__all__ = ["GibbsResult", "GibbsChain", "gibbs_conditional", "gibbs_optimize", "joint_log_prob"]


@dataclass(frozen=True)
class GibbsResult:
    """The best grouping found and its joint log-probability."""

    z: np.ndarray
    """(11,) int64 best grouping vector."""
    log_joint: float
    """log p(Z) + log p(G | Z) of ``z``."""
    sweeps: int
    """Sweeps run."""


@lru_cache(maxsize=None)
def _members(mask: int) -> tuple[int, ...]:
    """The joints of a group (bitmask), in increasing order."""
    out = []
    j = 0
    while mask:
        if mask & 1:
            out.append(j)
        mask >>= 1
        j += 1
    return tuple(out)


def _group_terms(lik: TypeLikelihood, mask: int) -> float:
    """Σ of the spatial terms of every member of a group (bitmask), in member order; a likelihood's terms
    never change once fitted, so each group's sum is kept in it (the same sum, summed once)."""
    sums = lik.group_sums
    v = sums.get(mask)
    if v is None:
        memo = lik.memo
        v = sums[mask] = sum(memo[k] if k in memo else lik.term(k) for k in _group_keys(mask))
    return v


def _draw(rng: np.random.Generator, p: np.ndarray) -> int:
    """``rng.choice(len(p), p=p)`` for normalised probabilities ``p``: numpy's own steps (the cumulative sum
    normalised by its last value, one uniform draw, the first cut above it) without its argument checks; the
    same index and the same single draw from the stream. Non-finite ``p`` goes to numpy, which refuses it."""
    if not np.isfinite(p).all():
        return int(rng.choice(len(p), p=p))
    cdf = p.cumsum()
    cdf /= cdf[-1]
    return int(cdf.searchsorted(rng.random(), side="right"))


@lru_cache(maxsize=None)
def _group_keys(mask: int) -> tuple[int, ...]:
    """Memo keys of the spatial terms of every member of a group (bitmask), in member order."""
    return tuple(TypeLikelihood.key(m, mask & ~(1 << m)) for m in _members(mask))


def _site_keys(z: list[int], masks: dict[int, int], j: int) -> list[int]:
    """Memo keys of every spatial term a move of site ``j`` can touch."""
    bj = 1 << j
    g = z[j]
    need = [TypeLikelihood.key(j, 0)]
    if g > 0:
        need += _group_keys(masks[g])
        need += _group_keys(masks[g] & ~bj)
    for h, m in masks.items():
        if h != g:
            need += _group_keys(m)
            need += _group_keys(m | bj)
    return need


def _site_values(
    lik: TypeLikelihood, z: list[int], masks: dict[int, int], total: float, j: int, beta: float, gamma: float
) -> tuple[list[int], np.ndarray, np.ndarray]:
    """Options of site ``j`` (0, existing ids, new id), their log prior weights and log-likelihoods."""
    bj = 1 << j
    g = z[j]
    lik.ensure(_site_keys(z, masks, j))
    # Total with j removed from the grouping.
    if g > 0:
        rest = masks[g] & ~bj
        without = total - lik.aff_motion_ll[j] - _group_terms(lik, masks[g]) + _group_terms(lik, rest)
    else:
        without = total - lik.null_ll[j]
    ids = [h for h in sorted(masks) if h != g or masks[h] & ~bj]
    sizes = [bin(masks[h] & ~bj).count("1") for h in ids]
    m_rest = sum(sizes)
    new_id = max(list(masks) + [0]) + 1
    options = [0, *ids, new_id]
    denom = log(m_rest + gamma)
    logw = [log(1.0 - beta)] + [log(beta) + log(n) - denom for n in sizes] + [log(beta) + log(gamma) - denom]
    ll = [without + lik.null_ll[j]]
    for h in ids:
        m = masks[h] & ~bj
        ll.append(without + lik.aff_motion_ll[j] + _group_terms(lik, m | bj) - _group_terms(lik, m))
    ll.append(without + lik.aff_motion_ll[j] + lik.spatial_term(j, 0))
    return options, np.asarray(logw), np.asarray(ll)


def _masks_of(z: list[int]) -> dict[int, int]:
    masks: dict[int, int] = {}
    for j, h in enumerate(z):
        if h > 0:
            masks[h] = masks.get(h, 0) | (1 << j)
    return masks


def gibbs_conditional(
    lik: TypeLikelihood, z: np.ndarray, j: int, beta: float, gamma: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Options for site ``j`` (group ids, 0 = Null, last = a new group), their normalized
    conditional probabilities p(z_j | Z_−j, G) and the log-likelihood of each resulting grouping."""
    zl = [int(v) for v in z]
    masks = _masks_of(zl)
    options, logw, ll = _site_values(lik, zl, masks, lik.loglik(zl), j, beta, gamma)
    logp = logw + ll
    p = np.exp(logp - logp.max())
    return np.asarray(options), p / p.sum(), ll


def _fast_log_prior(masks: dict[int, int], present: int, beta: float, gamma: float) -> float:
    sizes = [bin(m).count("1") for m in masks.values()]
    M = sum(sizes)
    crp = len(sizes) * log(gamma) + sum(lgamma(n) for n in sizes) - sum(log(gamma + i) for i in range(M))
    return M * log(beta) + (present - M) * log(1.0 - beta) + crp


class GibbsChain:
    """The state of a Gibbs sampler over one type's grouping (group ids as bitmasks for speed)."""

    def __init__(self, lik: TypeLikelihood, z0: np.ndarray, beta: float, gamma: float) -> None:
        self.lik, self.beta, self.gamma = lik, beta, gamma
        self.z = [int(v) for v in canonical_ids(np.where(lik.available, np.maximum(np.asarray(z0), 0), -1))]
        self.masks = _masks_of(self.z)
        self.present = int(lik.available.sum())
        self.sites = [int(j) for j in np.flatnonzero(lik.available)]
        self.total = lik.loglik(self.z)
        """log p(G | Z) of the current grouping."""

    @property
    def log_joint(self) -> float:
        """log p(Z) + log p(G | Z) of the current grouping."""
        return _fast_log_prior(self.masks, self.present, self.beta, self.gamma) + self.total

    def grouping(self) -> np.ndarray:
        """(11,) int64 current grouping with canonical ids."""
        return canonical_ids(np.asarray(self.z, dtype=np.int64))

    def sweep(self, rng: np.random.Generator) -> tuple[bool, float, list[int]]:
        """One systematic-scan sweep; returns (changed, best log joint in the sweep, its grouping)."""
        lik, z, masks = self.lik, self.z, self.masks
        lik.ensure([k for j in self.sites for k in _site_keys(z, masks, j)])  # one batch for the sweep
        changed = False
        best, best_z = -np.inf, list(z)
        for j in self.sites:
            options, logw, ll = _site_values(lik, z, masks, self.total, j, self.beta, self.gamma)
            logp = logw + ll
            p = np.exp(logp - logp.max())
            c = _draw(rng, p / p.sum())
            o = options[c]
            self.total = float(ll[c])
            if o != z[j]:
                changed = True
                g = z[j]
                if g > 0:
                    masks[g] &= ~(1 << j)
                    if not masks[g]:
                        del masks[g]
                if o > 0:
                    masks[o] = masks.get(o, 0) | (1 << j)
                z[j] = o
                value = self.log_joint
                if value > best:
                    best, best_z = value, list(z)
        return changed, best, best_z


def gibbs_optimize(
    lik: TypeLikelihood,
    z0: np.ndarray,
    *,
    beta: float,
    gamma: float,
    rng: np.random.Generator,
    max_sweeps: int = 10,
    patience: int = 2,
) -> GibbsResult:
    """Run Gibbs sweeps from ``z0`` and return the best grouping visited (``z0`` included)."""
    chain = GibbsChain(lik, z0, beta, gamma)
    best, best_z = chain.log_joint, list(chain.z)
    stale = 0
    sweeps = 0
    for _ in range(max_sweeps):
        sweeps += 1
        changed, value, z = chain.sweep(rng)
        improved = value > best + 1e-9
        if improved:
            best, best_z = value, z
        if not changed:
            break
        stale = 0 if improved else stale + 1
        if stale >= patience:
            break
    return GibbsResult(canonical_ids(np.asarray(best_z, dtype=np.int64)), float(best), sweeps)


def joint_log_prob(lik: TypeLikelihood, z: np.ndarray, beta: float, gamma: float) -> float:
    """log p(Z) + log p(G | Z) of one grouping (reference implementation for checks)."""
    return log_prior(z, beta, gamma) + lik.loglik(z)
