"""Online synthesis (Algorithm 2): prefix DP against brute force, duration sampling, causality, methods."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import labelled_partitions
from scipy import stats

from socialaff_sim.data.dataset import Dataset
from socialaff_sim.errors import ConfigError, ModelError, NotFittedError
from socialaff_sim.evaluation import get_method
from socialaff_sim.inference.protocol import observed_part
from socialaff_sim.inference import (
    AffordanceMethod,
    BodyFitter,
    OnlineSynthesizer,
    SynthesisConfig,
    parse_prefix,
    synthesize,
)
from socialaff_sim.inference.methods import REGISTERED_CHAINS
from socialaff_sim.inference.online_parse import log_duration_survival
from socialaff_sim.inference.synthesis import sample_remaining_seconds
from socialaff_sim.retarget.model_source import ModelSource, key_joint_source
from socialaff_sim.learning.config import LearningConfig
from socialaff_sim.learning import SocialAffordanceModel

FAST = LearningConfig(iterations=3)


@pytest.fixture(scope="module")
def shake(shake8: Dataset) -> Dataset:
    return shake8


@pytest.fixture(scope="module")
def model(shake8_model: SocialAffordanceModel) -> SocialAffordanceModel:
    return shake8_model


@pytest.fixture(scope="module")
def body(shake: Dataset) -> BodyFitter:
    return BodyFitter().fit_interactions(list(shake)[:6], agent=1, rng=np.random.default_rng(0))


def _brute_force(model: SocialAffordanceModel, track: np.ndarray, fps: float, bounds: np.ndarray) -> np.ndarray:
    """Best score per label of the open last interval, by enumerating every labelled partition."""
    S = model.n_subevents_
    B = len(bounds) - 1
    cfg = model.config
    best = np.full(S, -np.inf)
    for pts, labels in labelled_partitions(B, S, distinct=cfg.distinct_neighbours, unique=cfg.unique_labels):
        score = model.log_start_probs_[labels[0]]
        score += sum(model.log_transitions_[a, b] for a, b in zip(labels, labels[1:]))
        for (p, q), s in zip(zip(pts, pts[1:]), labels):
            a, b = bounds[p], bounds[q]
            if q < B:
                f = model.interval_features(track, np.array([a]), np.array([b]), fps)
                score += model.interval_log_score(f, s)[0]
            else:
                score += log_duration_survival(model, s, np.array([(b - a) / fps]))[0]
        best[labels[-1]] = max(best[labels[-1]], score)
    return best


def test_prefix_dp_matches_brute_force(model: SocialAffordanceModel, shake: Dataset) -> None:
    inter = shake[6]
    track = model.canonical_track(inter)[:30]
    for bounds in (np.array([0, 6, 13, 21, 30]), np.array([0, 10, 30]), np.array([0, 4, 9, 15, 22, 30])):
        parse = parse_prefix(model, track, inter.fps, bounds)
        brute = _brute_force(model, track, inter.fps, bounds)
        assert np.isclose(parse.score, brute.max(), rtol=0, atol=1e-9)
        finite = np.isfinite(brute)
        expected = np.exp(brute[finite] - np.logaddexp.reduce(brute[finite]))
        np.testing.assert_allclose(parse.belief[finite], expected, rtol=1e-9, atol=1e-12)
        assert parse.current == int(np.argmax(brute))
        rows = parse.intervals
        assert rows[0, 0] == 0 and rows[-1, 1] == 30 and np.all(rows[1:, 0] == rows[:-1, 1])
        assert set(rows[:, :2].ravel()) <= set(bounds.tolist())


def test_remaining_duration_is_the_conditional_lognormal(rng: np.random.Generator) -> None:
    mu, sigma, elapsed = 0.2, 0.4, 1.5
    draws = np.array([sample_remaining_seconds(mu, sigma, elapsed, rng) for _ in range(3000)])
    assert draws.min() > elapsed
    dist = stats.lognorm(sigma, scale=np.exp(mu))
    lo = dist.cdf(elapsed)

    def cond_cdf(x: np.ndarray) -> np.ndarray:
        return (dist.cdf(x) - lo) / (1.0 - lo)

    assert stats.kstest(draws, cond_cdf).pvalue > 1e-3
    med = sample_remaining_seconds(mu, sigma, elapsed, rng, median=True)
    assert np.isclose(cond_cdf(np.array([med]))[0], 0.5, atol=1e-9)


def test_log_survival_matches_scipy(model: SocialAffordanceModel) -> None:
    secs = np.array([0.1, 0.5, 1.0, 3.0])
    for s in range(model.n_subevents_):
        mu, sigma = model.duration_params_[s]
        expected = stats.lognorm(sigma, scale=np.exp(mu)).logsf(secs)
        np.testing.assert_allclose(log_duration_survival(model, s, secs), expected, rtol=1e-10)


def test_synthesizer_outputs_and_determinism(model: SocialAffordanceModel, body: BodyFitter, shake: Dataset) -> None:
    inter = observed_part(shake[7], 10)
    keys, skel, subs, beliefs = synthesize(model, inter, rng=np.random.default_rng(5), body=body)
    keys2, skel2, subs2, _ = synthesize(model, inter, rng=np.random.default_rng(5), body=body)
    np.testing.assert_array_equal(keys, keys2)
    np.testing.assert_array_equal(skel, skel2)
    np.testing.assert_array_equal(subs, subs2)
    T = inter.n_frames
    assert keys.shape == (T, 5, 3) and skel.shape == (T, 25, 3) and beliefs.shape == (T, model.n_subevents_)
    np.testing.assert_allclose(keys[:10], shake[7].key_joints()[:10, 1], atol=1e-12)
    assert np.all(subs[:10] == -1) and np.all(subs[10:] >= 0)
    np.testing.assert_allclose(beliefs.sum(axis=1), 1.0, atol=1e-9)
    assert np.isfinite(keys).all() and np.isfinite(skel).all()
    # The fitted skeleton's wrists reach the synthesized key joints where reachable: within a few cm.
    lay = inter.layout
    wrists = skel[10:, [lay.index("left_wrist"), lay.index("right_wrist")]]
    assert np.median(np.linalg.norm(wrists - keys[10:, 1:3], axis=-1)) < 0.05
    other = synthesize(model, inter, rng=np.random.default_rng(6), body=body)[0]
    assert not np.array_equal(other, keys)


def test_synthesis_is_causal(model: SocialAffordanceModel, shake: Dataset) -> None:
    inter = observed_part(shake[7], 10)
    keys = synthesize(model, inter, rng=np.random.default_rng(1))[0]
    cut = 25
    joints = inter.joints.copy()
    joints[cut:, 0] += np.array([0.5, -0.3, 0.2])  # agent 0 moves differently after `cut`
    changed = inter.replace(joints=joints)
    keys_changed = synthesize(model, changed, rng=np.random.default_rng(1))[0]
    np.testing.assert_array_equal(keys[:cut + 1], keys_changed[:cut + 1])
    assert not np.allclose(keys[cut + 6 :], keys_changed[cut + 6 :])


def test_synthesizer_errors(model: SocialAffordanceModel, shake: Dataset) -> None:
    syn = OnlineSynthesizer(model)
    with pytest.raises(ModelError, match="before reset"):
        syn.step()
    short = shake[0].slice(0, 8)
    with pytest.raises(ModelError, match="more than T0 = 10"):
        syn.reset(short, rng=np.random.default_rng(0))
    with pytest.raises(ConfigError, match="delta_t"):
        SynthesisConfig(delta_t=0)
    with pytest.raises(ConfigError, match="'sample' or 'median'"):
        SynthesisConfig(duration="mode")
    syn.reset(shake[7], rng=np.random.default_rng(0))
    for _ in range(shake[7].n_frames):
        syn.step()
    assert syn.done
    with pytest.raises(ModelError, match="finished"):
        syn.step()


def test_methods_are_registered_and_follow_the_protocol(shake: Dataset) -> None:
    for name in ("full", "v1", "v2"):
        method = get_method(name)()
        assert isinstance(method, AffordanceMethod) and method.name == name and method.chains == REGISTERED_CHAINS
    assert get_method("full_online")().chains == 1  # the simulator's single model
    method = AffordanceMethod("v2", learning=FAST)
    with pytest.raises(NotFittedError):
        method.predict(shake[7], n_observed=10, rng=np.random.default_rng(0))
    method.fit(list(shake)[:6], rng=np.random.default_rng(0))
    pred = method.predict(observed_part(shake[7], 10), n_observed=10, rng=np.random.default_rng(0))
    assert pred.joints.shape == shake[7].joints[:, 1].shape and pred.n_observed == 10
    assert method.model_.n_subevents_ == 1
    with pytest.raises(ConfigError, match="'full', 'v1' or 'v2'"):
        AffordanceMethod("v3")


def test_chains_average_independent_fits(shake: Dataset) -> None:
    seed = 7
    print(f"seed = {seed}")
    train, test = list(shake)[:6], observed_part(shake[7], 10)
    method = AffordanceMethod("full", learning=FAST, chains=2).fit(train, rng=np.random.default_rng(seed))
    pred = method.predict(test, n_observed=10, rng=np.random.default_rng(seed + 1))
    # Reference: two models learnt from the spawned generators, synthesized one by one.
    models = [SocialAffordanceModel(method.model_config, FAST).fit(train, rng=r) for r in np.random.default_rng(seed).spawn(2)]
    assert [m.parses_[0].tolist() for m in models] == [m.parses_[0].tolist() for m in method.models_]
    cfg = SynthesisConfig.offline(n_observed=10)  # what the method synthesizes with
    runs = [synthesize(m, test, rng=r, config=cfg)[0] for m, r in zip(models, np.random.default_rng(seed + 1).spawn(2), strict=True)]
    np.testing.assert_allclose(pred.key_joints, np.mean(runs, axis=0), rtol=0, atol=1e-12)
    assert not np.allclose(runs[0][10:], runs[1][10:], atol=1e-3)  # the chains differ, so the mean is neither
    np.testing.assert_array_equal(pred.joints[:10], test.filled_joints()[:10, 1])
    assert pred.joints.shape == test.joints[:, 1].shape and np.isfinite(pred.joints[10:]).all()
    # One chain is the plain method: the caller's generator is used as it is.
    one = AffordanceMethod("full", learning=FAST).fit(train, rng=np.random.default_rng(seed))
    keys = synthesize(one.model_, test, rng=np.random.default_rng(seed + 1), config=cfg)[0]
    np.testing.assert_array_equal(one.predict(test, n_observed=10, rng=np.random.default_rng(seed + 1)).key_joints, keys)
    for bad in (0, 1.5, True):
        with pytest.raises(ConfigError, match="chains: expected an integer >= 1"):
            AffordanceMethod("full", chains=bad)  # type: ignore[arg-type]


def test_model_source_replays_the_synthesizer(model: SocialAffordanceModel, shake: Dataset, tmp_path) -> None:  # noqa: ANN001

    path = model.save(tmp_path / "m.npz")
    source = key_joint_source(path, seed=3)
    assert isinstance(source, ModelSource)
    inter = shake[7]
    source.reset(inter)
    frames = [source.targets(t) for t in range(inter.n_frames)]
    keys = synthesize(model, inter, rng=np.random.default_rng(3), config=SynthesisConfig.reactive())[0]
    np.testing.assert_allclose(np.stack([f.keys for f in frames]), keys, atol=1e-12)
    assert frames[0].subevent is None and frames[-1].subevent in model.subevent_names_
    np.testing.assert_allclose(source.belief.sum(), 1.0, atol=1e-9)
