"""The ``gru`` baseline (skipped without torch; tests/test_ridge_baseline.py checks the registry without it)."""

from __future__ import annotations

import numpy as np
import pytest
from test_ridge_baseline import T0, make_instance, make_set

import socialaff_sim.baselines.gru as gru_module
from socialaff_sim.errors import NotFittedError
from socialaff_sim.evaluation import get_method, key_joint_error
from socialaff_sim.evaluation.streaming import run_protocol


torch = pytest.importorskip("torch")
SMALL = gru_module.GRUConfig(hidden_sizes=(8,), max_epochs=150, patience=20, learning_rate=2e-2)


@pytest.fixture(scope="module")
def fitted() -> gru_module.GRUReaction:
    rng = np.random.default_rng(7)
    return gru_module.GRUReaction(SMALL).fit(make_set(rng, "follow", 16), rng=rng)


def test_gru_learns_a_reaction_and_beats_hold(fitted: gru_module.GRUReaction) -> None:
    assert fitted.hidden_size_ == 8 and fitted.validation_error_ < 0.5 * fitted.validation_hold_error_
    rng = np.random.default_rng(1)
    hold = get_method("hold")().fit(make_set(rng, "follow", 2), rng=rng)
    test = make_set(rng, "follow", 4)
    e_g = np.mean([key_joint_error(run_protocol(fitted, i, protocol="causal", n_observed=T0, rng=rng), i) for i in test])
    e_h = np.mean([key_joint_error(run_protocol(hold, i, protocol="causal", n_observed=T0, rng=rng), i) for i in test])
    assert e_g < 0.5 * e_h


def test_gru_is_causal(fitted: gru_module.GRUReaction) -> None:
    rng = np.random.default_rng(2)
    inst = make_instance(rng, "follow", T=30)
    base = run_protocol(fitted, inst, protocol="causal", n_observed=T0, rng=rng).joints
    t = 17
    joints = np.array(inst.joints)
    joints[t + 1:, 0] -= 0.3  # agent 0's future
    later = run_protocol(fitted, inst.replace(joints=joints), protocol="causal", n_observed=T0, rng=rng).joints
    np.testing.assert_array_equal(later[: t + 1], base[: t + 1])
    assert not np.allclose(later[t + 1:], base[t + 1:])


def test_gru_state_advances_on_seen_frames_only(fitted: gru_module.GRUReaction) -> None:
    """Under the paper protocol frames t+1 … t+4 are forecast from a copy of the state; at the next block
    start the state has consumed agent 0's real frames, so block starts equal the causal frames, and the
    offline protocol (everything seen) equals the causal one."""
    rng = np.random.default_rng(3)
    inst = make_instance(rng, "follow", T=32)
    causal = run_protocol(fitted, inst, protocol="causal", n_observed=T0, rng=rng).joints
    paper = run_protocol(fitted, inst, protocol="paper", n_observed=T0, rng=rng).joints
    offline = run_protocol(fitted, inst, protocol="offline", n_observed=T0, rng=rng).joints
    np.testing.assert_allclose(paper[T0::5], causal[T0::5], atol=1e-5)
    assert not np.allclose(paper[T0 + 1::5], causal[T0 + 1::5], atol=1e-5)
    np.testing.assert_allclose(offline, causal, atol=1e-5)


def test_gru_is_seeded() -> None:
    preds = []
    for _ in range(2):
        rng = np.random.default_rng(11)
        m = gru_module.GRUReaction(SMALL).fit(make_set(rng, "follow", 8), rng=rng)
        preds.append(m.predict(make_instance(np.random.default_rng(5), "follow"), n_observed=T0, rng=rng).joints)
    np.testing.assert_array_equal(preds[0], preds[1])


def test_gru_falls_back_to_hold_when_it_does_not_beat_it() -> None:
    """Agent 1 never moves: the zero read-out (hold) is never improved on, so hold is kept."""
    rng = np.random.default_rng(4)
    m = gru_module.GRUReaction(SMALL).fit(make_set(rng, "still", 8), rng=rng)
    assert m.hidden_size_ == 0 and m.net_ is None
    inst = make_instance(rng, "follow")
    p = m.predict(inst, n_observed=T0, rng=rng)
    np.testing.assert_allclose(p.joints[T0:], np.repeat(inst.joints[T0 - 1, 1][None], inst.n_frames - T0, 0), atol=1e-12)
    with pytest.raises(NotFittedError, match="gru"):
        gru_module.GRUReaction(SMALL).start(n_observed=T0, offline=False, rng=rng)
