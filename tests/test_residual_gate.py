"""scripts/_residual_gate.py and the flags that use it: where the residual acts, and the bias it starts from.

The gate is checked against a plain environment fed the actions worked out by hand (zeros on a label the
residual does not act on, clip(b + a) on one it does: bit-for-bit the same episode), its training resets against
the instances of the acting labels, and the script's held-out arms against replays from scratch.
"""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest
from conftest import load_script

from socialaff_sim.environment import SocialAffordanceEnv
from socialaff_sim.errors import ConfigError, SimulationError

gate = load_script("_residual_gate")
LABELS = ["hand_over", "shake_hands"]


def _box(env: gym.Env) -> gym.Env:
    """The plain residual as the policy sees it: a flat [−1, 1] box, ×0.1 m."""
    shape = env.action_space.shape
    flat = gym.spaces.Box(-1.0, 1.0, shape=(int(np.prod(shape)),), dtype=np.float32)
    return gym.wrappers.TransformAction(env, lambda a: (0.1 * np.asarray(a, np.float32)).reshape(shape), flat)


def _env() -> gym.Env:
    return _box(SocialAffordanceEnv(interactions=LABELS, action_mode="residual", max_frames=10))


def _same_episode(gated: gym.Env, plain: gym.Env, instance: str, actions: np.ndarray, sent: np.ndarray) -> int:
    """Play ``actions`` on ``gated`` and ``sent`` on ``plain`` from the same reset; assert every step equal."""
    og, ig = gated.reset(seed=7, options={"instance": instance})
    op, _ = plain.reset(seed=7, options={"instance": instance})
    assert ig["interaction"] in LABELS
    for k, (a, b) in enumerate(zip(actions, sent)):
        og, rg, tg, ug, _ = gated.step(a)
        op, rp, tp, up, _ = plain.step(b)
        for key in op:
            np.testing.assert_array_equal(og[key], op[key], err_msg=key)
        assert (rg, tg, ug) == (rp, tp, up)
        if tp or up:
            return k + 1
    return len(actions)


@pytest.fixture(scope="module")
def envs():  # noqa: ANN201
    return _env(), _env()


def _instance(env: gym.Env, label: str) -> str:
    return next(x.instance_id for x in env.unwrapped.pool.instances if x.label == label)


def test_other_labels_get_zeros_whatever_the_policy_does(envs) -> None:  # noqa: ANN001
    inner, plain = envs
    g = gate.GatedResidual(inner, ["hand_over"], bias=[0.5] * 15)
    rng = np.random.default_rng(1)
    actions = rng.uniform(-1, 1, (30, 15)).astype(np.float32)
    steps = _same_episode(g, plain, _instance(plain, "shake_hands"), actions, np.zeros_like(actions))
    assert steps >= 5


def test_acting_label_gets_the_clipped_biased_action(envs) -> None:  # noqa: ANN001
    inner, plain = envs
    bias = np.linspace(-0.8, 0.8, 15).astype(np.float32)
    g = gate.GatedResidual(inner, ["hand_over"], bias=bias)
    rng = np.random.default_rng(2)
    actions = rng.uniform(-1, 1, (30, 15)).astype(np.float32)
    sent = np.minimum(np.maximum(actions + bias, -1.0), 1.0)  # by hand: clip(b + a, -1, 1)
    assert (np.abs(actions + bias) > 1.0).any()  # the clip is exercised
    _same_episode(g, plain, _instance(plain, "hand_over"), actions, sent)
    # Without a bias the acting label's action passes unchanged.
    g0 = gate.GatedResidual(inner, ["hand_over"])
    _same_episode(g0, plain, _instance(plain, "hand_over"), actions, actions)


def test_gate_decision_follows_the_episode_label(envs) -> None:  # noqa: ANN001
    inner, _ = envs
    g = gate.GatedResidual(inner, ["shake_hands"], bias=[0.25] * 15)
    a = np.full(15, 0.5, np.float32)
    g.reset(seed=1, options={"instance": _instance(inner, "shake_hands")})
    np.testing.assert_array_equal(g.action(a), np.full(15, 0.75, np.float32))
    g.reset(seed=1, options={"instance": _instance(inner, "hand_over")})
    np.testing.assert_array_equal(g.action(a), np.zeros(15, np.float32))


def test_training_resets_draw_acting_labels_only_and_named_instances_pass(envs) -> None:  # noqa: ANN001
    inner, _ = envs
    g = gate.GatedResidual(inner, ["hand_over"], train_only=True)
    labels = [g.reset(seed=3 if k == 0 else None)[1]["interaction"] for k in range(12)]
    assert set(labels) == {"hand_over"}
    ids = [g.reset(seed=None)[1]["instance"] for _ in range(30)]
    assert len(set(ids)) > 1  # it draws, it does not repeat one instance
    _, info = g.reset(seed=3, options={"instance": _instance(inner, "shake_hands")})
    assert info["interaction"] == "shake_hands"
    # The same seed draws the same instances.
    first = [g.reset(seed=11)[1]["instance"]] + [g.reset()[1]["instance"] for _ in range(5)]
    again = [g.reset(seed=11)[1]["instance"]] + [g.reset()[1]["instance"] for _ in range(5)]
    assert first == again
    # Without train_only the environment's own draw is used: both labels come up.
    free = gate.GatedResidual(inner, ["hand_over"])
    assert {free.reset(seed=s)[1]["interaction"] for s in range(20)} == set(LABELS)


def test_bad_gate_settings_name_their_flag(envs) -> None:  # noqa: ANN001
    inner, _ = envs
    with pytest.raises(ConfigError, match="--residual-labels"):
        gate.GatedResidual(inner, ["high_five"])
    with pytest.raises(ConfigError, match="--action-bias"):
        gate.GatedResidual(inner, ["hand_over"], bias=[0.5])
    with pytest.raises(ConfigError, match="--action-bias"):
        gate.GatedResidual(inner, ["hand_over"], bias=[1.5] * 15)
    with pytest.raises(ConfigError, match="--residual-labels"):
        gate.GatedResidual(inner.env, ["hand_over"])  # metres, not the policy's box
    with pytest.raises(SimulationError, match="reset"):
        gate.GatedResidual(_env(), ["hand_over"]).step(np.zeros(15))


def test_gated_run_plays_start_and_trained_on_the_same_pairs(tmp_path) -> None:  # noqa: ANN001
    pytest.importorskip("stable_baselines3")
    script = load_script("train_residual")
    s = script.Settings(train_instances=1, eval_instances=2, fit_iterations=1, timesteps=64, n_envs=1, n_steps=64,
                        batch_size=32, n_epochs=1, hidden=16, seed=5, max_frames=12, reach_scale=0.2,
                        action_scale=0.05, residual_labels=("hand_over",), action_bias=(0.0, 0.0, 0.0, 0.5, 0.0))
    with pytest.raises(ConfigError, match="--residual-labels"):  # a bad label fails before any training
        script.run(dataclasses.replace(s, residual_labels=("wave",)), tmp_path / "bad", log=lambda m: None)
    assert not (tmp_path / "bad" / "residual_ppo.zip").exists()
    ref = script.run(s, tmp_path / "ref", reference_only=True, log=lambda m: None)
    assert set(ref["train_reference_start"]) == set(s.labels)
    r = script.run(s, tmp_path / "ok", models_dir=tmp_path / "ref" / "models", reference_file=tmp_path / "ref" / "reference.json",
                   log=lambda m: None)
    assert r["train_reference_start"] == ref["train_reference_start"]
    zero, start, res = r["episodes"]["zero_residual"], r["episodes_start"], r["episodes"]["residual"]
    pairs = [(x["instance"], x["seed"]) for x in zero]
    assert [(x["instance"], x["seed"]) for x in start] == pairs == [(x["instance"], x["seed"]) for x in res]
    for z, st, tr in zip(zero, start, res):
        if z["interaction"] == "shake_hands":  # no authority: every arm is the affordance model alone, bitwise
            assert z["return"] == st["return"] == tr["return"] and z["success"] == st["success"] == tr["success"]
    # The start rows are the bias through the reach environment, replayed from scratch (the zero action's own
    # rows differ on the hand-overs: the bias moved a hand).
    _, held = script.build_data(s)
    models = {lbl: script.SocialAffordanceModel.load(tmp_path / "ref" / "models" / f"{lbl}.npz") for lbl in s.labels}
    env = script.make_env(s, held, models)
    label = {i.instance_id: i.label for i in held}
    bias, none = np.array(s.action_bias, np.float32), np.zeros(5, np.float32)
    again = [script.run_episodes(env, [p], lambda obs, b=(bias if label[p[0]] == "hand_over" else none): b.copy())[0]
             for p in pairs]
    assert [x["return"] for x in again] == [x["return"] for x in start]
    # ... and on a hand-over the start is not the zero residual (the bias moved a hand; the tiny episodes' returns
    # are all 0, so the observations are compared).
    gated = script.make_env(s, held, models, gate=True)
    pair = next(p for p in pairs if label[p[0]] == "hand_over")
    og, _ = gated.reset(seed=pair[1], options={"instance": pair[0]})
    op, _ = env.reset(seed=pair[1], options={"instance": pair[0]})
    for _ in range(10):
        og, op = gated.step(none)[0], env.step(none)[0]
    assert np.abs(og - op).max() > 1e-3
    # The summaries: trained − zero (declared), start − zero, trained − start.
    assert r["summary"]["residual"]["successes"] == sum(x["success"] for x in res)
    assert r["summary_start"]["residual"]["successes"] == sum(x["success"] for x in start)
    assert r["summary_learned"]["zero_residual"]["successes"] == sum(x["success"] for x in start)
    d = r["summary"]["per_interaction"]["shake_hands"]["paired_success_difference"]
    assert d["mean"] == 0.0 and tuple(d["ci95"]) == (0.0, 0.0)


@pytest.mark.parametrize(("flags", "word"), [(["--residual-labels", "wave"], "--residual-labels"),
                                             (["--action-bias", "0.5"], "--action-bias"),
                                             (["--reach-scale", "0.2", "--action-bias", "0", "0", "0", "2", "0"], "--action-bias")])
def test_bad_gate_flag_is_one_line_and_exit_2(flags: list[str], word: str, tmp_path, monkeypatch: pytest.MonkeyPatch,  # noqa: ANN001
                                              capsys: pytest.CaptureFixture[str]) -> None:
    """Before any data is made or model fitted: exit 2, one line naming the flag, nothing written."""
    mod = load_script("train_residual")
    out = tmp_path / "rl"
    monkeypatch.setattr("sys.argv", ["train_residual.py", "--out", str(out), *flags])
    with pytest.raises(SystemExit) as exc:
        mod.main()
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and word in err[0]
    assert not out.exists()
