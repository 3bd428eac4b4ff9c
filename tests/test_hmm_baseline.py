"""The HMM baseline: log-space forward–backward against brute force, EM monotonicity, the method itself."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from socialaff_sim.baselines.hmm import HMMConfig, MultiLevelHMM
from socialaff_sim.baselines.hmm_core import forward_backward, forward_filter, safe_log
from socialaff_sim.baselines.two_level_hmm import TwoLevelHMM
from socialaff_sim.errors import ModelError, NotFittedError
from socialaff_sim.evaluation import Prediction, key_joint_error, observed_part


def _random_hmm(rng: np.random.Generator, n: int, T: int, zeros: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    start = rng.dirichlet(np.ones(n))
    trans = rng.dirichlet(np.ones(n), size=n)
    emit = rng.uniform(0.05, 1.0, size=(T, n))
    if zeros:  # impossible transitions and emissions exercise the -inf paths
        trans[0, 1] = 0.0
        trans /= trans.sum(axis=1, keepdims=True)
        emit[1, 2] = 0.0
        emit[3, 0] = 0.0
    return safe_log(start), safe_log(trans), safe_log(emit)


def _brute_force(log_start: np.ndarray, log_trans: np.ndarray, log_emit: np.ndarray):
    T, n = log_emit.shape
    start, trans, emit = np.exp(log_start), np.exp(log_trans), np.exp(log_emit)
    total = 0.0
    gamma = np.zeros((T, n))
    xi = np.zeros((n, n))
    filt = np.zeros((T, n))
    for path in itertools.product(range(n), repeat=T):
        p = start[path[0]] * emit[0, path[0]]
        prefix = [p]
        for t in range(1, T):
            p *= trans[path[t - 1], path[t]] * emit[t, path[t]]
            prefix.append(p)
        total += p
        for t in range(T):
            gamma[t, path[t]] += p
        for t in range(1, T):
            xi[path[t - 1], path[t]] += p
    # Filtering: p(z_t | x_0..t) from paths of length t + 1.
    for t in range(T):
        for path in itertools.product(range(n), repeat=t + 1):
            p = start[path[0]] * emit[0, path[0]]
            for s in range(1, t + 1):
                p *= trans[path[s - 1], path[s]] * emit[s, path[s]]
            filt[t, path[t]] += p
    filt /= filt.sum(axis=1, keepdims=True)
    return np.log(total), gamma / total, xi / total, filt


@pytest.mark.parametrize("zeros", [False, True])
def test_forward_backward_matches_brute_force_enumeration(rng: np.random.Generator, zeros: bool) -> None:
    log_start, log_trans, log_emit = _random_hmm(rng, n=3, T=6, zeros=zeros)
    loglik, gamma, xi, filt = _brute_force(log_start, log_trans, log_emit)
    fb = forward_backward(log_start, log_trans, log_emit)
    np.testing.assert_allclose(fb.log_likelihood, loglik, atol=1e-10, rtol=0)
    np.testing.assert_allclose(fb.gamma, gamma, atol=1e-10, rtol=0)
    np.testing.assert_allclose(fb.xi, xi, atol=1e-10, rtol=0)
    post, ll = forward_filter(log_start, log_trans, log_emit)
    np.testing.assert_allclose(post, filt, atol=1e-10, rtol=0)
    np.testing.assert_allclose(ll, loglik, atol=1e-10, rtol=0)


def test_impossible_sequence_is_an_error() -> None:
    log_start = safe_log(np.array([1.0, 0.0]))
    log_trans = safe_log(np.eye(2))
    log_emit = safe_log(np.array([[0.0, 1.0], [1.0, 1.0]]))
    with pytest.raises(ModelError, match="probability zero"):
        forward_backward(log_start, log_trans, log_emit)


def _sample_two_level(
    rng: np.random.Generator, n_seq: int, sizes: tuple[int, ...], agent_size: int = 2
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Sequences from a random two-level model (S = 2 phases, K = 3 agent clusters); last channel agent-level."""
    S, K = 2, 3
    trans_z = np.array([[0.85, 0.15], [0.1, 0.9]])
    trans_r = rng.dirichlet(np.ones(K) * 0.5, size=(S, K))
    emit = [rng.dirichlet(np.ones(k) * 0.5, size=S) for k in sizes]
    agent_emit = rng.dirichlet(np.ones(agent_size) * 0.5, size=K)
    seqs = []
    for _ in range(n_seq):
        T = int(rng.integers(8, 15))
        z, r = 0, int(rng.integers(K))
        xs, rs = [], []
        for _t in range(T):
            xs.append([int(rng.choice(k, p=e[z])) for k, e in zip(sizes, emit, strict=True)] + [int(rng.choice(agent_size, p=agent_emit[r]))])
            rs.append(r)
            z = int(rng.choice(S, p=trans_z[z]))
            r = int(rng.choice(K, p=trans_r[z, r]))
        x = np.array(xs)
        x[rng.random(x.shape) < 0.1] = -1  # some missing symbols
        seqs.append((x, np.array(rs)))
    return seqs


def test_two_level_likelihood_matches_enumeration_over_product_paths(rng: np.random.Generator) -> None:
    sizes = (3, 2)
    seqs = _sample_two_level(rng, 6, sizes)
    hmm = TwoLevelHMM(2, 3, sizes, (2,), max_iter=2).fit(seqs, rng=rng)
    x = seqs[0][0][:4]
    r = np.array([1, -1, 2, -1])  # partly hidden agent clusters
    total = 0.0
    for zs in itertools.product(range(2), repeat=4):
        for rs in itertools.product(range(3), repeat=4):
            if any(ro >= 0 and ro != rr for ro, rr in zip(r, rs, strict=True)):
                continue
            p = hmm.start_phase_[zs[0]] * hmm.start_agent_[zs[0], rs[0]]
            for t in range(1, 4):
                p *= hmm.trans_phase_[zs[t - 1], zs[t]] * hmm.trans_agent_[zs[t], rs[t - 1], rs[t]]
            for t in range(4):
                for c, table in enumerate(hmm.emit_):
                    if x[t, c] >= 0:
                        p *= table[zs[t], x[t, c]]
                if x[t, -1] >= 0:
                    p *= hmm.agent_emit_[0][rs[t], x[t, -1]]
            total += p
    np.testing.assert_allclose(hmm.log_likelihood([(x, r)]), np.log(total), atol=1e-10, rtol=0)


@pytest.mark.parametrize("pseudo_count", [0.0, 0.5])
def test_em_never_decreases_its_objective(rng: np.random.Generator, pseudo_count: float) -> None:
    sizes = (4, 3)
    seqs = _sample_two_level(rng, 12, sizes)
    hmm = TwoLevelHMM(2, 3, sizes, (2,), pseudo_count=pseudo_count, max_iter=25, tol=0.0).fit(seqs, rng=rng)
    history = np.array(hmm.objective_history_)
    assert len(history) == 25
    assert np.all(np.diff(history) >= -1e-8), np.diff(history)
    assert history[-1] > history[0] + 1.0  # EM actually improved on its start
    if pseudo_count == 0.0:
        np.testing.assert_allclose(hmm.log_likelihood_history_, history, atol=0)
    np.testing.assert_allclose(hmm.trans_agent_.sum(axis=-1), 1.0, atol=1e-12)
    np.testing.assert_allclose(hmm.log_likelihood(seqs) + hmm.log_prior() >= history[-1], True)


def test_hmm_method_predicts_from_the_observed_part_only(rng: np.random.Generator) -> None:
    from test_evaluation import toy_dataset

    data = toy_dataset(seed=3, n_pairs=3, per_pair=4)
    train, test = data.interactions[:9], data.interactions[9:]
    method = MultiLevelHMM(HMMConfig(n_phases=3, n_agent_clusters=5, n_human_clusters=5, max_iter=10))
    with pytest.raises(NotFittedError):
        method.predict(observed_part(test[0], 10), n_observed=10, rng=rng)
    method.fit(train, rng=rng)
    inst = test[0]
    pred = method.predict(observed_part(inst, 10), n_observed=10, rng=rng)
    assert isinstance(pred, Prediction)
    assert pred.joints.shape == inst.joints[:, 1].shape and pred.subevents is not None
    np.testing.assert_allclose(pred.joints[:10], inst.joints[:10, 1], atol=1e-12)
    # Changing agent 1's hidden frames cannot change the prediction.
    altered = inst.replace(joints=inst.joints + np.where(np.arange(inst.n_frames)[:, None, None, None] >= 10, 0.3, 0.0)
                           * np.array([0, 1])[None, :, None, None])
    again = method.predict(observed_part(altered, 10), n_observed=10, rng=rng)
    np.testing.assert_allclose(again.joints, pred.joints, atol=0)
    # A sanity bound: the toy arms move by ~0.6 m; placing agent 1 anywhere near the human would be worse.
    errs = [key_joint_error(method.predict(observed_part(i, 10), n_observed=10, rng=rng), i) for i in test]
    print(f"hmm key-joint error {np.mean(errs):.3f} m")
    assert np.mean(errs) < 0.15
