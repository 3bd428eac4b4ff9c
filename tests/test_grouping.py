"""Joint selection and grouping: the CRP/Bernoulli prior, the Gibbs conditional, the sampler."""

from __future__ import annotations

from itertools import product
from math import factorial, lgamma, log

import numpy as np
import pytest

from socialaff_sim.learning.gibbs import GibbsChain, gibbs_conditional, gibbs_optimize, joint_log_prob
from socialaff_sim.learning.likelihood import TypeLikelihood
from socialaff_sim.model.config import AffordanceConfig
from socialaff_sim.model.grouping import canonical_ids, conditional_log_prior, log_prior
from socialaff_sim.model.joints import N_JOINTS
from socialaff_sim.model.potentials import fit_type_potentials


def _partitions(items: list[int]):
    """All set partitions of ``items`` as lists of blocks."""
    if not items:
        yield []
        return
    first, rest = items[0], items[1:]
    for part in _partitions(rest):
        for i in range(len(part)):
            yield part[:i] + [[first, *part[i]]] + part[i + 1 :]
        yield [[first], *part]


def all_groupings(sites: list[int]) -> list[np.ndarray]:
    """Every grouping vector (canonical ids) over the given present joints; the rest absent."""
    out = []
    for sel in product([False, True], repeat=len(sites)):
        chosen = [j for j, s in zip(sites, sel, strict=True) if s]
        for part in _partitions(chosen):
            z = np.full(N_JOINTS, -1, dtype=np.int64)
            z[sites] = 0
            for h, block in enumerate(part, start=1):
                z[block] = h
            out.append(canonical_ids(z))
    return out


def test_enumeration_counts() -> None:
    # Σ_m C(n, m) Bell(m): 1, 2, 5, 15, 52 for n = 0..4.
    assert [len(all_groupings(list(range(n)))) for n in range(5)] == [1, 2, 5, 15, 52]


@pytest.mark.parametrize("gamma", [1.0, 0.5, 2.5])
def test_log_prior_formula(gamma: float) -> None:
    beta = 0.3
    z = np.array([1, 1, 0, 2, -1, 3, 3, 3, 0, 0, -1])
    sizes = [2, 1, 3]
    M = sum(sizes)
    present = 9
    crp = len(sizes) * log(gamma) + sum(lgamma(m) for m in sizes) - sum(log(gamma + i) for i in range(M))
    expected = M * log(beta) + (present - M) * log(1 - beta) + crp
    assert log_prior(z, beta, gamma) == pytest.approx(expected, abs=1e-12)
    if gamma == 1.0:  # the paper's form ∏ (M_h − 1)! / M!
        paper = np.prod([factorial(m - 1) for m in sizes]) / factorial(M)
        assert log_prior(z, beta, gamma) == pytest.approx(log(paper) + M * log(beta) + 3 * log(1 - beta), abs=1e-12)


def test_prior_is_normalized() -> None:
    zs = all_groupings([0, 2, 5, 7])
    total = sum(np.exp(log_prior(z, 0.3, 1.7)) for z in zs)
    assert total == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("gamma", [1.0, 0.7])
def test_conditional_prior_agrees_with_joint_prior(gamma: float) -> None:
    beta = 0.3
    z = np.array([1, 2, 0, 2, 1, 0, 3, -1, 0, 2, 1])
    for j in np.flatnonzero(z >= 0):
        options, logw = conditional_log_prior(z, int(j), beta, gamma)
        joint = []
        for o in options:
            zz = z.copy()
            zz[j] = o
            joint.append(log_prior(zz, beta, gamma))
        cond = np.exp(logw - np.logaddexp.reduce(logw))
        ref = np.exp(np.array(joint) - np.logaddexp.reduce(joint))
        np.testing.assert_allclose(cond, ref, atol=1e-12)
        # The unnormalized weights are the textbook ones.
        others = np.delete(z, j)
        m_rest = int((others > 0).sum())
        assert logw[0] == pytest.approx(log(1 - beta))
        assert logw[-1] == pytest.approx(log(beta * gamma / (m_rest + gamma)))
        for o, w in zip(options[1:-1], logw[1:-1], strict=True):
            assert w == pytest.approx(log(beta * (others == o).sum() / (m_rest + gamma)))


def _data(rng: np.random.Generator, n: int = 6) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    end = rng.normal(0, 0.3, (n, N_JOINTS, 3)) + rng.normal(0, 1, (1, N_JOINTS, 3))
    disp = rng.normal(0, 0.2, (n, N_JOINTS, 3))
    available = np.ones(N_JOINTS, dtype=bool)
    available[10] = False
    end[:, 10] = np.nan
    disp[:, 10] = np.nan
    return end, disp, available


@pytest.mark.parametrize("likelihood", ["profile", "held_out"])
def test_memoized_likelihood_matches_direct_fit(rng: np.random.Generator, likelihood: str) -> None:
    end, disp, available = _data(rng)
    cfg = AffordanceConfig(likelihood=likelihood)
    lik = TypeLikelihood(end, disp, available, cfg)
    for z in ([0] * 10 + [-1], [1, 1, 0, 2, 2, 2, 0, 3, 0, 4, -1], list(range(1, 11)) + [-1]):
        direct = fit_type_potentials(end, disp, np.array(z), cfg).loglik
        assert lik.loglik(z) == pytest.approx(direct, abs=1e-8)


def test_gibbs_conditional_matches_brute_force(rng: np.random.Generator) -> None:
    end, disp, available = _data(rng)
    lik = TypeLikelihood(end, disp, available, AffordanceConfig())
    z = np.array([1, 1, 0, 2, 2, 0, 0, 3, 1, 0, -1])
    for j in range(10):
        options, p, ll = gibbs_conditional(lik, z, j, 0.3, 1.0)
        joint = []
        for o, l_o in zip(options, ll, strict=True):
            zz = z.copy()
            zz[j] = o
            assert l_o == pytest.approx(lik.loglik(zz), abs=1e-8)
            joint.append(joint_log_prob(lik, zz, 0.3, 1.0))
        joint = np.array(joint)
        np.testing.assert_allclose(p, np.exp(joint - np.logaddexp.reduce(joint)), atol=1e-10)


class _TableLikelihood(TypeLikelihood):
    """A likelihood with arbitrary moderate values per term, to give a spread-out posterior."""

    def __init__(self, available: np.ndarray, seed: int) -> None:
        super().__init__(np.zeros((0, N_JOINTS, 3)), np.zeros((0, N_JOINTS, 3)), available, AffordanceConfig())
        self._rng = np.random.default_rng(seed)
        self.null_ll = self._rng.normal(0, 1, N_JOINTS)
        self.aff_motion_ll = self._rng.normal(0, 1, N_JOINTS)
        self._table: dict[int, float] = {}

    def _compute(self, keys: list[int]) -> None:
        for k in keys:
            if k not in self._memo:
                self._memo[k] = float(np.random.default_rng([k, 7]).normal(0, 1.2))


def _sampler_tv(rng: np.random.Generator, n_sweeps: int) -> float:
    sites = [1, 2, 6, 7, 10]
    available = np.zeros(N_JOINTS, dtype=bool)
    available[sites] = True
    lik = _TableLikelihood(available, seed=3)
    lik.aff_motion_ll += 1.0  # favour selection, so that groups of several joints matter
    zs = all_groupings(sites)
    logp = np.array([joint_log_prob(lik, z, 0.3, 1.0) for z in zs])
    exact = np.exp(logp - np.logaddexp.reduce(logp))
    index = {tuple(z): i for i, z in enumerate(zs)}
    chain = GibbsChain(lik, np.where(available, 0, -1), 0.3, 1.0)
    counts = np.zeros(len(zs))
    for _ in range(200):  # burn-in
        chain.sweep(rng)
    for _ in range(n_sweeps):
        chain.sweep(rng)
        counts[index[tuple(chain.grouping())]] += 1
    return float(0.5 * np.abs(counts / n_sweeps - exact).sum())


def test_gibbs_sampler_matches_exact_enumeration(rng: np.random.Generator) -> None:
    """Visit frequencies of the Gibbs chain vs the exact posterior over all 203 groupings of 5 joints.

    Tolerance: total variation ≤ 0.08 after 8 000 sweeps (seeded; typical 0.035-0.04). A sampler
    whose CRP weights lack the M_h factor scores about 0.23, one with β and 1 − β swapped far more.
    """
    tv = _sampler_tv(rng, 8000)
    assert tv <= 0.08, f"total variation {tv:.4f}"


@pytest.mark.slow
def test_gibbs_sampler_matches_exact_enumeration_long(rng: np.random.Generator) -> None:
    """The same with 60 000 sweeps and a total-variation bound of 0.03."""
    tv = _sampler_tv(rng, 60000)
    assert tv <= 0.03, f"total variation {tv:.4f}"


def test_gibbs_optimize_finds_the_best_grouping_of_a_tiny_problem(rng: np.random.Generator) -> None:
    sites = [0, 3, 5, 8]
    available = np.zeros(N_JOINTS, dtype=bool)
    available[sites] = True
    lik = _TableLikelihood(available, seed=11)
    zs = all_groupings(sites)
    logp = np.array([joint_log_prob(lik, z, 0.3, 1.0) for z in zs])
    res = gibbs_optimize(lik, np.where(available, 0, -1), beta=0.3, gamma=1.0, rng=rng, max_sweeps=50, patience=10)
    assert res.log_joint == pytest.approx(logp.max(), abs=1e-9)
    assert res.log_joint == pytest.approx(joint_log_prob(lik, res.z, 0.3, 1.0), abs=1e-9)


def test_contacting_joints_group_together(rng: np.random.Generator) -> None:
    """Two wrists that always meet (and an object between them) are put in one group."""
    n = 20
    end = rng.normal(0, 0.25, (n, N_JOINTS, 3)) + np.array([0, 0, 1.0])
    end[:, 5:10, 0] += 1.2
    meet = rng.normal([0.6, 0.0, 1.1], 0.08, (n, 3))
    end[:, 2] = meet + rng.normal(0, 0.01, (n, 3))
    end[:, 7] = meet + rng.normal(0, 0.01, (n, 3))
    end[:, 10] = meet + rng.normal(0, 0.01, (n, 3))
    disp = rng.normal(0, 0.2, (n, N_JOINTS, 3))
    lik = TypeLikelihood(end, disp, np.ones(N_JOINTS, bool), AffordanceConfig())
    res = gibbs_optimize(lik, np.zeros(N_JOINTS, np.int64), beta=0.3, gamma=1.0, rng=rng, max_sweeps=30)
    assert res.z[2] > 0 and res.z[2] == res.z[7] == res.z[10]
