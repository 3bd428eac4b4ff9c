"""scripts/_residual_reach.py: the base-and-reach residual of the fourth declared RL run.

The offsets are checked against hand-built observations (directions and lengths worked out by hand), the
wrapper against the plain residual environment fed the same offsets (bit-for-bit the same episode), and the
script's flag against the environment it builds.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import load_script

from socialaff_sim.environment import SocialAffordanceEnv
from socialaff_sim.errors import ConfigError, SimulationError

reach = load_script("_residual_reach")


def _obs(cup: np.ndarray | None, human_wrists: np.ndarray | None = None, mask: tuple[float, float] = (1.0, 1.0)
         ) -> dict[str, np.ndarray]:
    proposal = np.array([[0.0, 0.0, 0.6], [0.3, 0.2, 1.0], [0.3, -0.2, 1.0], [0.0, 0.1, 0.0], [0.0, -0.1, 0.0]])
    human = np.zeros((4, 5, 3))
    if human_wrists is not None:
        human[-1, 1:3] = human_wrists
    return {"proposal": proposal.astype(np.float32),
            "object": np.tile(np.zeros(3) if cup is None else cup, (4, 1)).astype(np.float32),
            "object_present": np.array([0.0 if cup is None else 1.0], np.float32),
            "human_keys": human.astype(np.float32),
            "human_mask": np.array([1.0, mask[0], mask[1], 1.0, 1.0], np.float32)}


def test_reach_moves_each_wrist_along_the_line_to_the_cup() -> None:
    cup = np.array([0.7, 0.2, 1.3])  # left wrist → cup: (0.4, 0, 0.3), length 0.5; the right one is farther
    obs = _obs(cup)
    off = reach.reach_offsets(obs, np.array([0.5, -1.0, 0.0, 0.4, -0.5]), base_scale=0.1, reach_scale=0.2)
    np.testing.assert_allclose(off[0], [0.05, -0.1, 0.0], atol=1e-12)
    np.testing.assert_allclose(off[1], 0.2 * 0.4 * np.array([0.4, 0.0, 0.3]) / 0.5, atol=1e-6)
    right = cup - obs["proposal"][2].astype(np.float64)
    np.testing.assert_allclose(off[2], 0.2 * -0.5 * right / np.linalg.norm(right), atol=1e-6)
    np.testing.assert_array_equal(off[3:], 0.0)
    # A positive reach shortens the wrist's distance to the cup by exactly its length, a negative one lengthens it.
    p = obs["proposal"].astype(np.float64)
    assert np.linalg.norm(cup - (p[1] + off[1])) == pytest.approx(0.5 - 0.08, abs=1e-6)
    assert np.linalg.norm(cup - (p[2] + off[2])) == pytest.approx(np.linalg.norm(right) + 0.1, abs=1e-6)


def test_first_reach_is_the_nearer_hands_whichever_side() -> None:
    # The cup on the right: now the right wrist is the nearer one and takes a[3].
    cup = np.array([0.6, -0.3, 1.0])
    obs = _obs(cup)
    off = reach.reach_offsets(obs, np.array([0, 0, 0, 1.0, 0.0]), 0.1, 0.2)
    np.testing.assert_array_equal(off[1], 0.0)
    np.testing.assert_allclose(off[2], 0.2 * np.array([0.3, -0.1, 0.0]) / np.linalg.norm([0.3, -0.1, 0.0]), atol=1e-6)
    mirrored = reach.reach_offsets(_obs(np.array([0.6, 0.3, 1.0])), np.array([0, 0, 0, 1.0, 0.0]), 0.1, 0.2)
    np.testing.assert_array_equal(mirrored[2], 0.0)
    np.testing.assert_allclose(mirrored[1], off[2] * [1, -1, 1], atol=1e-6)


def test_action_is_clipped_and_zero_gives_zero() -> None:
    obs = _obs(np.array([0.7, 0.2, 1.3]))
    np.testing.assert_array_equal(reach.reach_offsets(obs, np.zeros(5), 0.1, 0.2), 0.0)
    big = reach.reach_offsets(obs, np.array([3.0, 0.0, 0.0, 5.0, 0.0]), 0.1, 0.2)
    assert big[0, 0] == pytest.approx(0.1) and np.linalg.norm(big[1]) == pytest.approx(0.2)


def test_without_an_object_each_hand_reaches_for_the_persons_nearer_wrist() -> None:
    # The person's left wrist (row 1) is near the robot's right wrist and the person's right one near its left.
    wrists = np.array([[0.8, -0.25, 1.0], [0.9, 0.3, 1.1]])  # the right hand's target is the nearer (0.50 m vs 0.62 m)
    off = reach.reach_offsets(_obs(None, wrists), np.array([0, 0, 0, 1.0, 1.0]), 0.1, 0.1)
    first = reach.reach_offsets(_obs(None, wrists), np.array([0, 0, 0, 1.0, 0.0]), 0.1, 0.1)
    np.testing.assert_array_equal(first[1], 0.0) and np.testing.assert_allclose(first[2], off[2])
    to_left = np.array([0.6, 0.1, 0.1]) / np.linalg.norm([0.6, 0.1, 0.1])
    to_right = np.array([0.5, -0.05, 0.0]) / np.linalg.norm([0.5, -0.05, 0.0])
    np.testing.assert_allclose(off[1], 0.1 * to_left, atol=1e-6)
    np.testing.assert_allclose(off[2], 0.1 * to_right, atol=1e-6)
    # A wrist the layout lacks is no target: both hands then reach for the one that is there.
    only = reach.reach_offsets(_obs(None, wrists, mask=(0.0, 1.0)), np.array([0, 0, 0, 1.0, 1.0]), 0.1, 0.1)
    np.testing.assert_allclose(only[1], 0.1 * to_left, atol=1e-6)
    np.testing.assert_allclose(only[2], 0.1 * np.array([0.6, 0.5, 0.1]) / np.linalg.norm([0.6, 0.5, 0.1]), atol=1e-6)
    # Neither wrist: only the base moves.
    none = reach.reach_offsets(_obs(None, wrists, mask=(0.0, 0.0)), np.array([1.0, 0, 0, 1.0, 1.0]), 0.1, 0.1)
    np.testing.assert_allclose(none[0], [0.1, 0, 0]) and np.testing.assert_array_equal(none[1:], 0.0)


@pytest.fixture(scope="module")
def env_pair():  # noqa: ANN201
    kw = {"interactions": ["hand_over"], "action_mode": "residual", "max_frames": 12, "residual_tau": 0.3}
    return SocialAffordanceEnv(**kw), SocialAffordanceEnv(**kw)


def test_wrapper_plays_the_same_episode_as_the_offsets_it_sends(env_pair) -> None:  # noqa: ANN001
    plain, inner = env_pair
    wrapped = reach.ReachResidual(inner, base_scale=0.1, reach_scale=0.15)
    assert wrapped.action_space.shape == (5,)
    rng = np.random.default_rng(0)
    obs_w, _ = wrapped.reset(seed=4)
    obs_p, _ = plain.reset(seed=4)
    moved = 0.0
    for _ in range(40):
        a = rng.uniform(-1, 1, 5)
        off = reach.reach_offsets(obs_p, a, 0.1, 0.15).astype(np.float32)
        moved = max(moved, float(np.abs(off[1:3]).max()))
        obs_w, rw, tw, uw, _ = wrapped.step(a)
        obs_p, rp, tp, up, _ = plain.step(off)
        for k in obs_p:
            np.testing.assert_array_equal(obs_w[k], obs_p[k], err_msg=k)
        assert (rw, tw, uw) == (rp, tp, up)
        if tp or up:
            break
    assert moved > 0.01  # the hand rows were really moved (the episode has a cup)


def test_wrapper_needs_reset_and_the_plain_action(env_pair) -> None:  # noqa: ANN001
    with pytest.raises(SimulationError, match="reset"):
        reach.ReachResidual(SocialAffordanceEnv(interactions=["hand_over"], action_mode="residual", max_frames=12),
                            0.1, 0.1).step(np.zeros(5))
    grouped = SocialAffordanceEnv(interactions=["hand_over"], action_mode="residual", max_frames=12,
                                  residual_groups=[["base"], ["left_wrist", "right_wrist"]])
    with pytest.raises(ConfigError, match="--reach-scale"):
        reach.ReachResidual(grouped, 0.1, 0.1)
    with pytest.raises(ConfigError, match="--reach-scale"):
        reach.ReachResidual(env_pair[0], 0.1, 0.5)  # beyond the environment's 0.3 m bound


def test_script_flag_builds_the_reach_environment() -> None:
    script = load_script("train_residual")
    s = script.Settings(train_instances=1, eval_instances=1, fit_iterations=1, max_frames=12, reach_scale=0.15,
                        residual_tau=0.3)
    train, _ = script.build_data(s)
    env = script.make_env(s, train, script.fit_models(s, train), training=True)
    assert env.action_space.shape == (5,) and env.action_space.low.min() == -1.0
    assert type(env.env).__name__ == "ReachResidual" and env.env.reach_scale == 0.15
    with pytest.raises(ConfigError, match="--reach-scale"):
        script.make_env(dataclasses.replace(s, residual_groups=("base",)), train, {}, training=True)


def test_constant_action_is_evaluated_on_the_same_pairs(tmp_path) -> None:  # noqa: ANN001
    pytest.importorskip("stable_baselines3")
    script = load_script("train_residual")
    report = load_script("_residual_report")
    s = script.Settings(train_instances=1, eval_instances=2, fit_iterations=1, timesteps=64, n_envs=1, n_steps=64,
                        batch_size=32, n_epochs=1, hidden=16, seed=5, max_frames=12, reach_scale=0.2,
                        action_scale=0.05, use_sde=True, sde_sample_freq=8, log_std_init=-3.0,
                        eval_constant=(0.0, 0.0, 0.0, 1.0, 0.0))
    with pytest.raises(ConfigError, match="--eval-constant"):  # a wrong length fails before any training
        script.run(dataclasses.replace(s, eval_constant=(1.0,)), tmp_path / "bad", log=lambda m: None)
    assert not (tmp_path / "bad" / "residual_ppo.zip").exists()
    r = script.run(s, tmp_path / "ok", log=lambda m: None)
    zero, const = r["episodes"]["zero_residual"], r["episodes_constant"]
    assert [(x["instance"], x["seed"]) for x in const] == [(x["instance"], x["seed"]) for x in zero]
    assert all(x["mean_abs_action"] == pytest.approx(0.2) for x in const)  # |a| averaged over the 5 numbers
    assert r["summary_constant"]["residual"]["successes"] == sum(x["success"] for x in const)
    # The constant rows are what the reach environment gives for that action, replayed from scratch.
    train, held = script.build_data(s)
    models = {lbl: script.SocialAffordanceModel.load(tmp_path / "ok" / "models" / f"{lbl}.npz") for lbl in s.labels}
    env = script.make_env(s, held, models)
    again = script.run_episodes(env, [(x["instance"], x["seed"]) for x in const], lambda obs: np.array(s.eval_constant, np.float32))
    assert [x["return"] for x in again] == [x["return"] for x in const]
    lines = report.result_lines(r)
    assert any(line.startswith("all") and "paired constant - zero" in line for line in lines)
    assert any("paired residual - zero" in line for line in lines) and lines[-1].startswith("target met")
