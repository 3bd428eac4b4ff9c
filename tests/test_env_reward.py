"""The environment's reward and adapters: exact term sums, term semantics, proxy and model scores, the robot→agent map."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy import stats

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.environment import (
    AffordanceScore,
    GroundTruthAdapter,
    ModelAdapter,
    ModelScorer,
    RewardConfig,
    RobotPose,
    SocialAffordanceEnv,
)
from socialaff_sim.environment.bodymap import RobotToAgent
from socialaff_sim.environment.model_adapter import load_models, spatial_upper_bound, weibull_max_logpdf
from socialaff_sim.environment.reward import affordance_term
from socialaff_sim.errors import ConfigError, ModelError
from socialaff_sim.learning.config import LearningConfig
from socialaff_sim.learning import SocialAffordanceModel
from socialaff_sim.retarget.intent import ContactIntent


@pytest.fixture(scope="module")
def data():
    return generate_dataset(seed=0, config=SyntheticConfig(interactions=("shake_hands", "hand_over"), instances_per_interaction=3))


@pytest.fixture(scope="module")
def model(data):
    """A quickly fitted hand-over model (few iterations: only its potentials' form matters here)."""
    learning = LearningConfig(iterations=3, n_clusters=12, init_rounds=2, initial_gibbs_sweeps=5)
    return SocialAffordanceModel(learning=learning).fit(list(data.of_label("hand_over")), rng=np.random.default_rng(0))


def reward_keys(info):
    return [k for k in info if k.startswith("reward_")]


def test_terms_sum_exactly_to_the_reward_over_rollouts(data, rng):
    w = RewardConfig()
    for mode, kw in (("residual", {}), ("targets", {"terminate_on_failure": False, "max_frames": 24})):
        env = SocialAffordanceEnv(data=data, action_mode=mode, **kw)
        env.action_space.seed(int(rng.integers(1 << 30)))
        seen = {"success": 0, "failure": 0}
        for seed in range(3):
            env.reset(seed=seed)
            previous_success, previous_failures, names = {}, {}, None
            while True:
                a = np.zeros((5, 3), np.float32) if mode == "residual" else env.action_space.sample()
                _, r, term, trunc, info = env.step(a)
                keys = reward_keys(info)
                names = names or keys
                assert keys == names  # every term, every step
                assert r == math.fsum(info[k] for k in keys)
                assert 0.0 <= info["reward_affordance"] <= w.affordance_weight
                for sg, ok in info["subgoals"].items():
                    gained = info[f"reward_success_{sg}"]
                    assert gained == (w.success_bonus if ok and not previous_success.get(sg, False) else 0.0)
                    seen["success"] += gained > 0
                for kind, hit in info["failures"].items():
                    lost = info[f"reward_failure_{kind}"]
                    assert lost == (-w.failure_penalty if hit and not previous_failures.get(kind, False) else 0.0)
                    seen["failure"] += lost < 0
                previous_success, previous_failures = info["subgoals"], info["failures"]
                if term or trunc:
                    break
        # the checks above must have met both kinds of event at least once
        assert seen["success" if mode == "residual" else "failure"] > 0, seen


def test_progress_terms_add_up_to_the_weight(data):
    env = SocialAffordanceEnv(data=data, interactions="shake_hands", action_mode="residual")
    env.reset(seed=0, options={"instance": "shake_hands_000"})
    total = 0.0
    while True:
        _, _, term, _, info = env.step(np.zeros((5, 3), np.float32))
        total += info["reward_progress_hands_clasped"]
        if term:
            break
    contact = env.simulator.scorer.subgoals[0].contact_time
    expected = RewardConfig().progress_weight * min(contact / 0.3, 1.0)
    assert total == pytest.approx(expected, abs=1e-9)
    assert info["subgoals"]["hands_clasped"] == (contact >= 0.3 - 1e-9)


def test_failure_terminates_unless_told_otherwise(data, seed):
    # A person who bears 1 N at most: the replayed handshake's grip is a failure (random targets no longer
    # reliably make the robot collide with itself since targets are projected onto what its body can follow).
    for terminate in (True, False):
        env = SocialAffordanceEnv(data=data, interactions="shake_hands", action_mode="residual", terminate_on_failure=terminate)
        task = env.pool.tasks["shake_hands"]
        env.pool.tasks["shake_hands"] = dataclasses.replace(task, failures=tuple(
            dataclasses.replace(f, threshold=1.0) if f.kind == "contact_force" else f for f in task.failures))
        env._sims.clear()
        env.reset(seed=seed)
        failed_at, steps = None, 0
        while True:
            _, reward, term, _, info = env.step(np.zeros((5, 3), np.float32))
            steps += 1
            if info["failed"] and failed_at is None:
                failed_at = steps
                assert info["reward_failure_contact_force"] == -RewardConfig().failure_penalty
            if term:
                break
        assert failed_at is not None, "the replayed handshake is expected to push on the hand with more than 1 N"
        assert (steps == failed_at) == terminate
        assert steps == failed_at or info["frame"] == env.simulator.n_frames - 1


def test_affordance_term_closed_form():
    cfg = RewardConfig(affordance_weight=2.0, affordance_clip=8.0)
    assert affordance_term(AffordanceScore(-12.0, 0.0, 3), cfg) == pytest.approx(2.0 * (1 - 4 / 8), abs=1e-12)
    assert affordance_term(AffordanceScore(5.0, 5.0, 2), cfg) == pytest.approx(2.0, abs=1e-12)
    assert affordance_term(AffordanceScore(-1e6, 0.0, 2), cfg) == 0.0
    assert affordance_term(AffordanceScore(-np.inf, 0.0, 2), cfg) == 0.0
    assert affordance_term(AffordanceScore(0.0, 0.0, 0), cfg) == 0.0
    with pytest.raises(ConfigError, match="affordance_clip"):
        RewardConfig(affordance_clip=0.0)


def test_ground_truth_proxy_is_a_gaussian_log_density(data, rng):
    inter = data.of_label("hand_over")[0]
    ad = GroundTruthAdapter(sigma=0.12)
    ad.reset(inter)
    t = 7
    frame = ad.observe(t)
    np.testing.assert_array_equal(frame.proposal, inter.key_joints()[t, 1])
    assert frame.belief.sum() == 1.0 and frame.subevent_name == inter.subevent_names[inter.subevents[t]]
    ref = rng.normal(size=(5, 3))
    ref[4] = np.nan  # a key frame without a reference is not scored
    keys = ref + rng.normal(scale=0.1, size=(5, 3))
    pose = RobotPose(t, keys, ref, None, lambda: pytest.fail("the proxy must not need the inverse map"))
    score = ad.log_likelihood(frame.subevent, pose)
    gauss = [stats.multivariate_normal(ref[k], 0.12**2 * np.eye(3)) for k in range(4)]
    assert score.log_likelihood == pytest.approx(sum(g.logpdf(keys[k]) for k, g in enumerate(gauss)), abs=1e-9)
    assert score.upper_bound == pytest.approx(sum(g.logpdf(ref[k]) for k, g in enumerate(gauss)), abs=1e-9)
    assert score.n_terms == 4


def test_robot_to_agent_inverts_the_scaler(data):
    """The scaler itself is the reference: mapping the inverse forward again gives the robot's keys back."""
    env = SocialAffordanceEnv(data=data, robot="ours")
    robot_to_agent = RobotToAgent()
    near = frames = exact = 0
    for inter in data:
        env.reset(options={"instance": inter.instance_id})
        robot_to_agent.reset()
        sim = env.simulator
        keys = inter.key_joints()[:, 1]
        for t in range(inter.n_frames):
            target = sim.retarget(keys[t], frame=t)
            back = robot_to_agent(sim, target, t)
            np.testing.assert_allclose(back[[0, 3, 4]], keys[t, [0, 3, 4]], atol=1e-9)  # base and ankles: exact
            frames += 1
            exact += np.abs(sim.retarget(back, frame=t) - target).max() <= 1e-5  # wrists: a preimage
            obj = sim.object_anchors(t)
            if not sim.scaler.contact_weights(keys[t] + sim.offset, sim.pose.joints[t], obj).any():
                np.testing.assert_allclose(back[1:3], keys[t, 1:3], atol=1e-6)  # away from the partner: the recording
            else:
                near += 1
    assert near > 0  # the contact branch was exercised
    assert exact >= 0.97 * frames, f"{frames - exact} of {frames} frames without an exact preimage"


def test_weibull_max_matches_a_grid_search():
    eps = 1e-3
    for k, lam in ((0.7, 0.2), (1.0, 0.5), (1.8, 0.3), (6.0, 0.05), (15.0, 1e-3)):
        x = np.concatenate([[eps], np.geomspace(eps, 20 * lam + eps, 200001)])
        grid = stats.weibull_min(k, scale=lam).logpdf(x).max()
        assert weibull_max_logpdf(np.array([k]), np.array([lam]), eps)[0] == pytest.approx(grid, abs=1e-6)


def test_model_scorer_bound_and_configuration(model, data, rng):
    inter = data.of_label("hand_over")[1]
    scorer = ModelScorer({"hand_over": model})
    scorer.reset(inter)
    track = model.canonical_track(inter)
    recorded = inter.key_joints()[:, 1]
    for t in (0, 10, inter.n_frames - 1):
        np.testing.assert_allclose(scorer.configuration(recorded[t], t, inter.object[t]), track[t], atol=1e-9)
    for s in range(model.n_subevents_):
        bound, n = spatial_upper_bound(model, s)
        assert n == int((model.grouping_[s][model.available_] > 0).sum())
        t = int(rng.integers(inter.n_frames))
        keys = recorded[t] + rng.normal(scale=0.2, size=(200, 5, 3))
        lls = np.array([scorer.log_likelihood(s, k, t, inter.object[t]).log_likelihood for k in keys])
        direct = model.log_spatial(s, np.stack([scorer.configuration(k, t, inter.object[t]) for k in keys]))
        np.testing.assert_allclose(lls, direct, atol=1e-9)
        assert (lls <= bound + 1e-9).all()
    assert scorer.log_likelihood(-1, recorded[0], 0, None) == AffordanceScore(0.0, 0.0, 0)


def test_load_models_checks_labels(model, tmp_path):
    assert load_models(model, ["hand_over"])["hand_over"] is model
    path = model.save(tmp_path / "hand_over.npz")
    assert load_models({"hand_over": path}, ["hand_over"])["hand_over"].label_ == "hand_over"
    with pytest.raises(ConfigError, match="mapping"):
        load_models(model, ["hand_over", "shake_hands"])
    with pytest.raises(ModelError, match="fitted on 'hand_over'"):
        load_models({"shake_hands": model}, ["shake_hands"])


def test_model_adapter_drives_the_synthesizer(model, data):
    """With a model, the proposal is the online synthesis (T0 frames copied from agent 1), the belief
    the synthesizer's, and the affordance term the model's spatial potential."""
    from socialaff_sim.inference.synthesis import OnlineSynthesizer, SynthesisConfig

    inter = data.of_label("hand_over")[2]
    env = SocialAffordanceEnv(data=[inter], model={"hand_over": model}, action_mode="residual", max_frames=16,
                              control_dt=None)  # one step per frame: the synthesizer's steps
    assert isinstance(env.adapter, ModelAdapter)
    assert env.observation_space["subevent_belief"].shape == (model.n_subevents_,)
    obs, info = env.reset(seed=4)
    syn = OnlineSynthesizer(model, None, SynthesisConfig.reactive())  # the adapter's default
    syn.reset(env.pool.instances[0], rng=np.random.default_rng(env._adapter_seed))
    steps = [syn.step() for _ in range(16)]
    t, scored = 0, 0
    while True:
        np.testing.assert_allclose(obs["subevent_belief"], steps[t + 1].belief, atol=1e-6)
        intent = ContactIntent.of(model).at(steps[t + 1].subevent)  # the model's intent, as the env passes it
        np.testing.assert_allclose(obs["proposal"], env.simulator.retarget(steps[t + 1].key_joints, frame=t + 1,
                                                                           **intent.kwargs()), atol=1e-5)
        obs, r, term, _, info = env.step(np.zeros((5, 3), np.float32))
        t += 1
        assert info["subevent_index"] == steps[t].subevent
        scored += info["subevent_index"] >= 0
        if info["subevent_index"] < 0:  # T0 frames: no sub-event inferred yet, nothing scored
            assert info["reward_affordance"] == 0.0
        if term:
            break
    assert scored > 0
    with pytest.raises(ModelError, match="rng"):
        env.adapter.reset(inter)


@pytest.mark.slow
def test_whole_synthetic_interactions(seed):
    """Every synthetic interaction, whole episodes: exact sums, bounded observations, and the recorded
    agent 1 as proposal far ahead of random targets."""
    data = generate_dataset(seed=seed, config=SyntheticConfig(instances_per_interaction=3))
    success = {}
    for mode in ("residual", "targets"):
        env = SocialAffordanceEnv(data=data, action_mode=mode)
        env.action_space.seed(seed)
        wins = []
        for inter in data:
            obs, _ = env.reset(seed=seed, options={"instance": inter.instance_id})
            while True:
                a = np.zeros((5, 3), np.float32) if mode == "residual" else env.action_space.sample()
                obs, r, term, trunc, info = env.step(a)
                assert obs in env.observation_space
                assert r == math.fsum(v for k, v in info.items() if k.startswith("reward_"))
                if term or trunc:
                    break
            wins.append(info["success"])
        success[mode] = float(np.mean(wins))
    assert success["residual"] >= success["targets"] + 0.4, success
