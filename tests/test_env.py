"""The Gymnasium environment: API conformance, determinism, vector envs, pickling, rendering, registration."""

from __future__ import annotations

import os
import pickle
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest
from conftest import check_env_strict

import socialaff_sim.environment as senv
from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.environment import ENV_IDS, MAX_EPISODE_STEPS, SocialAffordanceEnv
from socialaff_sim.errors import ConfigError, RenderingUnavailableError, SimulationError

FRAMES = 10


@pytest.fixture(scope="module")
def data():
    """Two instances each of an interaction without and one with an object (cut to FRAMES in the envs)."""
    return generate_dataset(seed=0, config=SyntheticConfig(interactions=("shake_hands", "hand_over"), instances_per_interaction=2))


def make(data, **kw) -> SocialAffordanceEnv:
    """An env of one step per data frame (these tests check per-frame semantics; the control period's are in
    tests/test_env_control.py) unless ``control_dt`` is given."""
    kw.setdefault("max_frames", FRAMES)
    kw.setdefault("control_dt", None)
    return SocialAffordanceEnv(data=data, **kw)


def rollout(env, actions, seed, options=None):
    """Observations, rewards and infos of one episode driven by ``actions`` (a list, consumed in order)."""
    obs, info = env.reset(seed=seed, options=options)
    out = [(obs, 0.0, info)]
    for a in actions:
        obs, r, term, trunc, info = env.step(a)
        out.append((obs, r, info))
        if term or trunc:
            break
    return out


def test_check_env_warnings_are_errors(data):
    for kw in ({"action_mode": "targets"}, {"action_mode": "residual", "interactions": "hand_over"}):
        env = gym.make("SocialAffordance-v0", data=data, max_frames=FRAMES, **kw)
        try:
            check_env_strict(env)
        finally:
            env.close()


def test_spaces_documented_shapes(data):
    env = make(data, history=3)
    try:
        obs, _ = env.reset(seed=0)
        sp = env.observation_space
        assert sp["human_keys"].shape == (3, 5, 3) and sp["object"].shape == (3, 3)
        assert sp["subevent_belief"].shape == (4,)  # both interactions have 4 recorded sub-events
        assert sp["interaction"].shape == (2,) and sp["subgoal_progress"].shape == (2,)
        assert all(v.dtype == np.float32 for v in obs.values())
        assert env.action_space.shape == (5, 3) and env.action_space.dtype == np.float32
        np.testing.assert_array_equal(env.action_space.low[0], np.float32([-1.0, -1.5, 0.0]))
        res = make(data, action_mode="residual")
        np.testing.assert_allclose(res.action_space.high, 0.3, atol=1e-7)
    finally:
        env.close()


def test_observation_matches_simulator(data):
    # All-zero targets crouch the robot into a ball; with its real weight that self-collides at once
    # (the failure would end the episode): observations are what is checked here.
    env = make(data, history=2, interactions="hand_over", terminate_on_failure=False)
    obs, _ = env.reset(seed=3)
    for _ in range(4):
        sim = env.simulator
        t = sim.frame
        np.testing.assert_allclose(obs["human_keys"][-1], sim.human_key_joints(min(t + 1, sim.n_frames - 1)), atol=1e-5)
        np.testing.assert_allclose(obs["human_keys"][0], sim.human_key_joints(t), atol=1e-5)
        np.testing.assert_allclose(obs["robot_keys"], sim.robot_key_frames(), atol=1e-5)
        np.testing.assert_allclose(obs["object"][-1], sim.object_position(), atol=1e-5)
        assert obs["object_present"][0] == 1.0
        np.testing.assert_array_equal(obs["interaction"], [1.0])  # one interaction
        q, _ = sim.joint_state()
        np.testing.assert_allclose(obs["joint_pos"], np.clip(q, -np.pi, np.pi), atol=1e-6)
        assert obs["progress"][0] == pytest.approx(t / (sim.n_frames - 1))
        obs, *_ = env.step(np.zeros((5, 3), np.float32))


def test_residual_and_target_actions_reach_the_simulator(data):
    env = make(data, action_mode="residual")
    obs, _ = env.reset(seed=1)
    offset = np.full((5, 3), 0.05, np.float32)
    env.step(offset)
    np.testing.assert_allclose(env.simulator.last_targets, obs["proposal"] + offset, atol=1e-5)
    big = np.full((5, 3), 9.0, np.float32)
    big[0] = 0.0  # (a base pushed away would come back at the envelope's speed, not in one frame)
    proposal = env.step(big)[0]["proposal"]
    env.step(np.zeros((5, 3), np.float32))
    np.testing.assert_allclose(env.simulator.last_targets, proposal, atol=1e-5)

    tgt = make(data, action_mode="targets", terminate_on_failure=False)
    tgt.reset(seed=1)
    base = tgt.simulator.last_targets[0]
    a = np.array([base, [0.4, 0.3, 0.9], [9.0, -9.0, 9.0], [0.0, 0.1, 0.1], [0.0, -0.1, 0.1]], np.float32)
    _, _, _, _, info = tgt.step(a)
    # Clipped to the box, then the right wrist pulled to twice the arm's length from its shoulder.
    boxed = np.clip(a, tgt.action_space.low, tgt.action_space.high).astype(np.float64)
    expected = boxed.copy()
    shoulder = expected[0] + tgt.feasible.body.shoulders[1]
    gap = expected[2] - shoulder
    expected[2] = shoulder + gap * 2.0 * tgt.feasible.body.arm / np.linalg.norm(gap)
    np.testing.assert_allclose(tgt.simulator.last_targets, expected, atol=1e-6)
    np.testing.assert_allclose(info["action_adjustment"], np.linalg.norm(expected - boxed, axis=1), atol=1e-6)
    assert info["action_adjustment"][2] > 1.0 and not info["action_adjustment"][[0, 1, 3, 4]].any()
    with pytest.raises(SimulationError, match="shape"):
        tgt.step(np.zeros((4, 3)))
    with pytest.raises(SimulationError, match="finite"):
        tgt.step(np.full((5, 3), np.nan))


def test_same_seed_same_trajectory(data, rng):
    actions = list(rng.uniform(-0.2, 0.2, size=(FRAMES, 5, 3)).astype(np.float32))
    a, b = make(data, action_mode="residual"), make(data, action_mode="residual")
    a.reset(seed=99)  # a previous episode on one of them must not matter
    ra, rb = rollout(a, actions, seed=7), rollout(b, actions, seed=7)
    assert len(ra) == len(rb) > 2
    for (oa, xa, ia), (ob, xb, ib) in zip(ra, rb, strict=True):
        assert xa == xb and ia["instance"] == ib["instance"]
        for k in oa:
            np.testing.assert_array_equal(oa[k], ob[k])


def test_seed_picks_instance_and_options_restrict(data):
    env = make(data)
    picked = {env.reset(seed=s)[1]["instance"] for s in range(12)}
    assert len(picked) > 1 and picked <= {i.instance_id for i in data}
    assert env.reset(seed=0, options={"instance": "hand_over_001"})[1]["instance"] == "hand_over_001"
    assert {env.reset(seed=s, options={"interaction": "shake_hands"})[1]["interaction"] for s in range(5)} == {"shake_hands"}
    with pytest.raises(ConfigError, match="valid keys"):
        env.reset(options={"episode": 3})
    with pytest.raises(ConfigError, match="'hand_over' or 'shake_hands'"):
        env.reset(options={"interaction": "high_five"})


def test_termination_at_track_end_and_truncation(data):
    env = make(data, action_mode="residual", max_frames=6)
    env.reset(seed=0)
    steps = 0
    while True:
        _, _, term, trunc, info = env.step(np.zeros((5, 3), np.float32))
        steps += 1
        assert not trunc
        if term:
            break
    assert steps == 5 and info["frame"] == 5
    with pytest.raises(SimulationError, match="reset"):
        env.step(np.zeros((5, 3), np.float32))

    limited = gym.make("SocialAffordance-ShakeHands-v0", data=data, max_frames=FRAMES, action_mode="residual", max_episode_steps=3)
    limited.reset(seed=0)
    flags = [limited.step(np.zeros((5, 3), np.float32))[2:4] for _ in range(3)]
    assert flags == [(False, False), (False, False), (False, True)]
    limited.close()


def test_vector_envs(data):
    fns = [lambda: make(data, action_mode="residual", max_frames=6) for _ in range(2)]
    for cls in (gym.vector.SyncVectorEnv, gym.vector.AsyncVectorEnv):
        venv = cls(fns)
        try:
            obs, infos = venv.reset(seed=[0, 1])
            assert obs["human_keys"].shape == (2, 4, 5, 3)
            for _ in range(7):  # crosses the end of the track: autoreset
                obs, rew, term, trunc, infos = venv.step(np.zeros((2, 5, 3), np.float32))
                assert rew.shape == (2,) and np.isfinite(rew).all()
                assert venv.single_observation_space.contains({k: v[0] for k, v in obs.items()})
            assert "reward_affordance" in infos
        finally:
            venv.close()


def test_pickle_mid_episode_round_trip(data, rng):
    env = make(data, action_mode="residual", interactions="hand_over")
    env.reset(seed=5)
    for _ in range(3):
        env.step(rng.uniform(-0.1, 0.1, size=(5, 3)).astype(np.float32))
    clone = pickle.loads(pickle.dumps(env))
    a = rng.uniform(-0.1, 0.1, size=(5, 3)).astype(np.float32)
    o1, r1, t1, _, i1 = env.step(a)
    o2, r2, t2, _, i2 = clone.step(a)
    assert (r1, t1, i1["frame"]) == (r2, t2, i2["frame"])
    for k in o1:
        np.testing.assert_array_equal(o1[k], o2[k])
    assert clone.reset(seed=2)[1]["instance"] == env.reset(seed=2)[1]["instance"]
    fresh = pickle.loads(pickle.dumps(make(data)))
    assert fresh.reset(seed=0)[0] in fresh.observation_space


@pytest.mark.render
def test_render_rgb_array(data):
    env = make(data, render_mode="rgb_array", render_width=160, render_height=120)
    try:
        env.reset(seed=0)
        try:
            img = env.render()
        except RenderingUnavailableError as exc:
            pytest.skip(f"offscreen rendering unavailable here: {exc}")
        assert img.shape == (120, 160, 3) and img.dtype == np.uint8 and img.std() > 0
        env.step(env.action_space.sample())
        assert env.render().shape == (120, 160, 3)
    finally:
        env.close()
        env.close()


def test_render_human_without_display_is_a_clear_error(data, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(RenderingUnavailableError, match="rgb_array"):
        make(data, render_mode="human")
    assert make(data).metadata["render_modes"] == ["rgb_array"]
    with pytest.raises(ConfigError, match="render_mode"):
        make(data, render_mode="ansi")


def test_constructor_errors(data):
    with pytest.raises(ConfigError, match="'targets' or 'residual'"):
        make(data, action_mode="joint")
    with pytest.raises(ConfigError, match="no instance of 'pull_up'"):
        make(data, interactions="pull_up")
    with pytest.raises(ConfigError, match="physics"):
        make(data, physics="slow")
    with pytest.raises(ConfigError, match="max_frames"):
        make(data, max_frames=2)


def test_registration():
    assert set(ENV_IDS) <= set(gym.registry)
    for env_id, label in ENV_IDS.items():
        spec = gym.spec(env_id)
        assert spec.max_episode_steps == MAX_EPISODE_STEPS
        assert spec.kwargs.get("interactions") == label
    senv.register_envs()  # idempotent: re-registering must not warn (warnings are errors)


def test_module_prefixed_id_imports_the_package(tmp_path):
    code = (
        "import gymnasium as gym, sys\n"
        "assert 'socialaff_sim.environment' not in sys.modules\n"
        "env = gym.make('socialaff_sim.environment:SocialAffordance-ShakeHands-v0', max_frames=4)\n"
        "obs, info = env.reset(seed=0)\n"
        "print(env.spec.id, info['interaction'])\n"
    )
    env = {**os.environ, "MUJOCO_GL": "egl"}
    out = subprocess.run([sys.executable, "-W", "error", "-c", code], capture_output=True, text=True, env=env, cwd=tmp_path)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split() == ["SocialAffordance-ShakeHands-v0", "shake_hands"]


def test_layout_without_ankles(data):
    """NuiSI-like recordings have no legs: masked in the observation, unscored, proposal rows held."""
    from socialaff_sim.data.skeletons import get_layout

    inter = data.of_label("shake_hands")[0]
    src, dst = get_layout("kinect_v2"), get_layout("nuitrack10")
    names = {"torso": "spine_mid", "waist": "spine_base", "left_hand": "left_wrist", "right_hand": "right_wrist"}
    idx = [src.index(names.get(n, n)) for n in dst.joint_names]
    nuisi = inter.replace(joints=inter.joints[:, :, idx], valid=None if inter.valid is None else inter.valid[:, :, idx],
                          joint_names=dst.joint_names, instance_id="nuisi_like")
    env = make([nuisi], action_mode="residual")
    obs, _ = env.reset(seed=0)
    np.testing.assert_array_equal(obs["human_mask"], [1, 1, 1, 0, 0])
    assert (obs["human_keys"][:, 3:] == 0).all()
    for _ in range(3):
        robot = env.simulator.robot_key_frames()
        proposal = obs["proposal"]
        obs, r, *_ = env.step(np.zeros((5, 3), np.float32))
        np.testing.assert_allclose(proposal[3:], robot[3:], atol=1e-5)  # no ankle proposal: hold the robot's
        assert obs in env.observation_space and np.isfinite(r)
