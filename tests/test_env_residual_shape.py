"""The residual action's options: key joints grouped under one offset (``residual_groups``) and a low-pass
filtered offset (``residual_tau``): spaces, the env checker, the filter against its closed form, and that
each option sends exactly the offsets it documents (the same physics as the plain residual given them)."""

from __future__ import annotations

import pickle

import gymnasium as gym
import numpy as np
import pytest
from conftest import check_env_strict

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.environment import SocialAffordanceEnv
from socialaff_sim.environment.config import EnvConfig
from socialaff_sim.environment.residual import ResidualMap, group_matrix
from socialaff_sim.errors import ConfigError, SimulationError

FRAMES = 6
WRISTS = (("left_wrist", "right_wrist"),)


@pytest.fixture(scope="module")
def data():
    return generate_dataset(seed=0, config=SyntheticConfig(interactions=("hand_over",), instances_per_interaction=1))


def make(data, **kw) -> SocialAffordanceEnv:
    return SocialAffordanceEnv(data=data, action_mode="residual", max_frames=FRAMES, **kw)


def play(env, actions):
    """Per step: (observation, reward, the (5, 3) targets sent to the simulator)."""
    env.reset(seed=5)
    out = []
    for a in actions:
        obs, r, term, trunc, _ = env.step(a)
        out.append((obs, r, env.simulator.last_targets.copy()))
        if term or trunc:
            break
    return out


def test_env_checker_clean_with_both_options(data) -> None:
    env = gym.make("SocialAffordance-v0", data=data, action_mode="residual", max_frames=FRAMES,
                   residual_groups=[["base"], ["left_wrist", "right_wrist"]], residual_tau=0.2)
    try:
        check_env_strict(env)
        assert env.action_space.shape == (2, 3)
        assert env.observation_space["residual_offset"].shape == (5, 3)
        assert np.all(env.observation_space["residual_offset"].high == np.float32(0.3))
    finally:
        env.close()


def test_spaces_by_option(data) -> None:
    plain, grouped = make(data), make(data, residual_groups=WRISTS)
    assert plain.action_space.shape == (5, 3) and grouped.action_space.shape == (1, 3)
    assert "residual_offset" not in plain.observation_space.spaces
    assert "residual_offset" not in grouped.observation_space.spaces  # no filter state without a filter
    obs, _ = make(data, residual_tau=0.1).reset(seed=0)
    assert np.array_equal(obs["residual_offset"], np.zeros((5, 3), np.float32))
    with pytest.raises(SimulationError, match=r"expected shape \(1, 3\)"):
        grouped.reset(seed=0)
        grouped.step(np.zeros((5, 3), np.float32))


def test_group_matrix() -> None:
    E = group_matrix((("base",), ("left_wrist", "right_wrist")))
    expected = np.zeros((5, 2))
    expected[0, 0] = expected[1, 1] = expected[2, 1] = 1.0
    assert np.array_equal(E, expected)
    assert np.array_equal(group_matrix(None), np.eye(5))
    a = np.array([[0.1, 0.0, -0.2], [0.0, 0.05, 0.0]])
    u = ResidualMap((("base",), ("left_wrist", "right_wrist")), None).step(a, 0.015)
    assert np.array_equal(u, np.array([[0.1, 0, -0.2], [0, 0.05, 0], [0, 0.05, 0], [0, 0, 0], [0, 0, 0]]))


@pytest.mark.parametrize("kw, match", [
    ({"residual_groups": (("base", "neck"),)}, "neck"),
    ({"residual_groups": (("base",), ("base", "left_wrist"))}, "more than one group"),
    ({"residual_groups": ((),)}, "non-empty"),
    ({"residual_groups": ()}, "at least one group"),
    ({"residual_tau": 0.0}, "residual_tau"),
    ({"residual_tau": -1.0}, "residual_tau"),
    ({"residual_tau": 0.1, "action_mode": "targets"}, "unless action_mode"),
    ({"residual_groups": (("base",),), "action_mode": "targets"}, "unless action_mode"),
])
def test_config_errors_name_the_field(kw, match) -> None:
    kw = {"action_mode": "residual", **kw}
    with pytest.raises(ConfigError, match=match):
        EnvConfig(**kw)


def test_filter_follows_the_closed_form_step_response() -> None:
    """From rest, a held action u gives o(t) = u (1 − e^(−t/τ)) whatever the steps' lengths."""
    tau, rng = 0.25, np.random.default_rng(0)
    m = ResidualMap(None, tau)
    u = rng.uniform(-0.3, 0.3, (5, 3))
    t = 0.0
    for dt in rng.choice([0.012, 0.016, 0.008], size=40):
        o = m.step(u, float(dt))
        t += float(dt)
        assert np.allclose(o, u * (1.0 - np.exp(-t / tau)), rtol=0, atol=1e-13)
    m.reset()
    assert np.array_equal(m.offset, np.zeros((5, 3)))
    # Without the filter the offset is the action at once (not a fraction of it).
    assert np.array_equal(ResidualMap(None, None).step(u, 0.015), u)


def test_grouped_action_is_the_plain_residual_with_shared_rows(data) -> None:
    """A (1, 3) wrists action gives bit for bit the physics of the (5, 3) action with that row on both wrists."""
    rng = np.random.default_rng(1)
    group_actions = [rng.uniform(-0.05, 0.05, (1, 3)).astype(np.float32) for _ in range(40)]
    full_actions = [np.vstack([np.zeros((1, 3)), g, g, np.zeros((2, 3))]).astype(np.float32) for g in group_actions]
    grouped = play(make(data, residual_groups=WRISTS), group_actions)
    plain = play(make(data), full_actions)
    assert len(grouped) == len(plain) > 10
    for (og, rg, tg), (op, rp, tp) in zip(grouped, plain, strict=True):
        assert rg == rp and np.array_equal(tg, tp)
        assert all(np.array_equal(og[k], op[k]) for k in op)


def test_filtered_offset_is_what_is_sent(data) -> None:
    """With τ, a held action reaches the simulator as the filter's output: the plain residual env driven by
    those offsets gives the same physics, the observation carries them, and they follow the closed form."""
    tau = 0.1
    env = make(data, residual_tau=tau, residual_groups=WRISTS)
    action = np.array([[0.0, 0.08, 0.0]], np.float32)
    env.reset(seed=5)
    sent, steps = [], []
    for _ in range(30):
        obs, _, term, trunc, _ = env.step(action)
        sent.append(env._decoder.offsets.offset.copy())
        steps.append((obs, env.simulator.last_targets.copy()))
        assert np.array_equal(obs["residual_offset"], sent[-1].astype(np.float32))
        if term or trunc:
            break
    # Closed form at the simulated time of each step (from rest, action held).
    lengths = np.diff((0, *env.clock.bounds)) * env.clock.step_seconds  # the control steps of a frame, s
    assert len(lengths) > 1
    t = np.cumsum(np.tile(lengths, FRAMES))[: len(sent)]
    wrist = np.array([s[1, 1] for s in sent])
    assert np.allclose(wrist, 0.08 * (1.0 - np.exp(-t / tau)), rtol=0, atol=1e-7)
    assert all(s[0].tolist() == [0, 0, 0] and s[3:].tolist() == [[0] * 3] * 2 for s in sent)
    assert wrist[0] < 0.08 * 0.3  # inverted (no filter) it would be the whole 0.08 at once
    plain = play(make(data), [s.astype(np.float64) for s in sent])
    assert len(plain) == len(steps)
    for (_, tg), (_, _, tp) in zip(steps, plain, strict=True):
        assert np.array_equal(tg, tp)


def test_pickle_restores_the_filter_state(data) -> None:
    env = make(data, residual_tau=0.2)
    env.reset(seed=2)
    a = np.full((5, 3), 0.05, np.float32)
    for _ in range(7):
        env.step(a)
    clone = pickle.loads(pickle.dumps(env))
    assert np.array_equal(clone._decoder.offsets.offset, env._decoder.offsets.offset)
    o1, r1, *_ = env.step(a)
    o2, r2, *_ = clone.step(a)
    assert r1 == r2 and all(np.array_equal(o1[k], o2[k]) for k in o1)
