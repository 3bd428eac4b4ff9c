"""scripts/train_residual.py: a few hundred PPO steps through the script's own code path.

The tiny run (2 training and 2 held-out instances per interaction cut to 15 frames, so that episodes of
about 6 control steps a frame end within the rollouts, a one-iteration model fit, 256 PPO steps) proves the
example works end to end; its figures are not judged. What is checked: the files it
writes (policy, normalizer, models, learning curve, results), that the evaluation rows are what the
environment gives — the zero-residual rows are replayed with a plain ``SocialAffordanceEnv`` and the
trained policy is reloaded from disk and replayed — and the summary statistics against hand counts and
the closed-form Wilson interval. Skipped without the ``[rl]`` extra (stable-baselines3, torch).
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from conftest import load_script, parsed_settings

pytest.importorskip("stable_baselines3")  # the [rl] extra

from stable_baselines3 import PPO  # noqa: E402
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize  # noqa: E402

from socialaff_sim.data.dataset import Dataset  # noqa: E402
from socialaff_sim.data.npz_format import save_dataset  # noqa: E402
from socialaff_sim.data.synthetic import generate_dataset  # noqa: E402
from socialaff_sim.data.synthetic.config import SyntheticConfig  # noqa: E402
from socialaff_sim.environment import SocialAffordanceEnv  # noqa: E402
from socialaff_sim.environment.episode_end import TERMINATION_REASONS  # noqa: E402
from socialaff_sim.errors import ConfigError  # noqa: E402
from socialaff_sim.learning import SocialAffordanceModel  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "scripts" / "train_residual.py"
STATS = load_script("_residual_stats")  # the summaries (train_residual calls them through _residual_eval)


@pytest.fixture(scope="module")
def script():  # noqa: ANN201
    return load_script("train_residual")


@pytest.fixture(scope="module")
def tiny(script, tmp_path_factory):  # noqa: ANN001, ANN201
    settings = script.Settings(train_instances=2, eval_instances=2, fit_iterations=1, timesteps=256, n_envs=2,
                               n_steps=64, batch_size=64, n_epochs=2, hidden=32, seed=3, max_frames=15)
    out = tmp_path_factory.mktemp("rl")
    logged: list[str] = []
    results = script.run(settings, out, log=logged.append)
    return settings, out, results, logged


def test_writes_policy_curve_and_results(tiny) -> None:  # noqa: ANN001
    settings, out, results, logged = tiny
    for name in ("residual_ppo.zip", "vecnormalize.pkl", "models/shake_hands.npz", "models/hand_over.npz"):
        assert (out / name).stat().st_size > 0, name
    png = (out / "learning_curve.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
    assert json.loads((out / "results.json").read_text()) == json.loads(json.dumps(results))
    assert results["timesteps_trained"] >= settings.timesteps
    curve = json.loads((out / "curve.json").read_text())
    assert len(curve) == results["training_episodes"] > 0
    steps = [r["timesteps"] for r in curve]
    assert steps == sorted(steps) and steps[-1] <= results["timesteps_trained"]
    assert {r["interaction"] for r in curve} <= {"shake_hands", "hand_over"}
    # 2 held-out instances per interaction, one episode each per policy, on the same (instance, seed) pairs.
    rows = results["episodes"]
    assert len(rows["residual"]) == len(rows["zero_residual"]) == 4
    assert [(r["instance"], r["seed"]) for r in rows["residual"]] == [(r["instance"], r["seed"]) for r in rows["zero_residual"]]
    summary = results["summary"]
    assert set(summary["per_interaction"]) == {"shake_hands", "hand_over"}
    for pol in ("residual", "zero_residual"):
        s = summary[pol]
        assert s["episodes"] == 4 and s["successes"] == sum(r["success"] for r in rows[pol])
        np.testing.assert_allclose(s["mean_return"], np.mean([r["return"] for r in rows[pol]]), rtol=1e-12, atol=1e-12)
    assert any("models ready" in m for m in logged)


def test_rows_carry_reward_terms_and_termination_reasons(script, tiny) -> None:  # noqa: ANN001
    settings, _, results, _ = tiny
    frames = {i.instance_id: min(i.n_frames, settings.max_frames) for i in script.build_data(settings)[1]}
    reasons = set(TERMINATION_REASONS)
    for pol in ("residual", "zero_residual"):
        for row in results["episodes"][pol]:
            assert math.fsum(row["reward_terms"].values()) == pytest.approx(row["return"], abs=1e-9)
            assert "affordance" in row["reward_terms"] and row["termination_reason"] in reasons
            if row["termination_reason"] in ("task_complete", "instance_end"):  # several control steps a frame
                assert row["steps"] >= 4 * (frames[row["instance"]] - 1)
    assert all(row["mean_abs_action"] == 0.0 for row in results["episodes"]["zero_residual"])


def test_action_scale_maps_the_unit_box_to_metres(script, tiny) -> None:  # noqa: ANN001
    settings, out, _, _ = tiny
    train, _ = script.build_data(settings)
    models = {lbl: SocialAffordanceModel.load(out / "models" / f"{lbl}.npz") for lbl in settings.labels}
    env = script.make_env(dataclasses.replace(settings, action_scale=0.05), train, models)
    assert env.action_space.shape == (15,) and float(env.action_space.high.max()) == 1.0
    unit = np.linspace(-1.0, 1.0, 15, dtype=np.float32)
    np.testing.assert_allclose(env.action(unit), 0.05 * unit.reshape(5, 3), rtol=0, atol=1e-8)
    assert env.unwrapped.config.control_dt == settings.control_dt == 0.015  # the environment's default rate
    with pytest.raises(ConfigError, match="action-scale"):
        script.make_env(dataclasses.replace(settings, action_scale=0.31), train, models)
    assert env.unwrapped.robot.name == "ours"
    assert script.make_env(dataclasses.replace(settings, robot="cmu"), train, models).unwrapped.robot.name == "cmu"


def test_held_out_instances_are_not_training_instances(script, tiny) -> None:  # noqa: ANN001
    settings = tiny[0]
    train, held = script.build_data(settings)
    assert len(train) == 4 and len(held) == 4
    train_tracks = [i.joints for i in train]
    for h in held:  # another dataset seed: no held-out track equals a training track
        assert not any(t.shape == h.joints.shape and np.allclose(t, h.joints, equal_nan=True) for t in train_tracks)


def test_zero_residual_rows_match_a_plain_environment(script, tiny) -> None:  # noqa: ANN001
    settings, out, results, _ = tiny
    _, held = script.build_data(settings)
    models = {lbl: SocialAffordanceModel.load(out / "models" / f"{lbl}.npz") for lbl in settings.labels}
    env = SocialAffordanceEnv(interactions=list(settings.labels), data=held, action_mode="residual", model=models,
                              physics=settings.physics, control_dt=settings.control_dt, max_frames=settings.max_frames)
    for row in results["episodes"]["zero_residual"]:
        env.reset(seed=row["seed"], options={"instance": row["instance"]})
        total, done, info = 0.0, False, {}
        while not done:
            _, reward, term, trunc, info = env.step(np.zeros((5, 3), np.float32))
            total, done = total + reward, term or trunc
        assert total == pytest.approx(row["return"], abs=1e-9)
        assert info["success"] == row["success"] and info["subgoals"] == row["subgoals"]


def test_saved_policy_replays_its_evaluation(script, tiny) -> None:  # noqa: ANN001
    settings, out, results, _ = tiny
    train, held = script.build_data(settings)
    models = {lbl: SocialAffordanceModel.load(out / "models" / f"{lbl}.npz") for lbl in settings.labels}
    agent = PPO.load(out / "residual_ppo.zip", device="cpu")
    norm = VecNormalize.load(str(out / "vecnormalize.pkl"), DummyVecEnv([lambda: script.make_env(settings, train, models)]))
    norm.training = False
    env = script.make_env(settings, held, models)
    rows = script.run_episodes(env, [(r["instance"], r["seed"]) for r in results["episodes"]["residual"]],
                               script.trained_policy(agent, norm))
    assert [r["return"] for r in rows] == pytest.approx([r["return"] for r in results["episodes"]["residual"]], abs=1e-9)
    assert [r["success"] for r in rows] == [r["success"] for r in results["episodes"]["residual"]]


def _row(label: str, k: int, success: bool, ret: float) -> dict:
    return {"instance": f"{label}_{k}", "seed": k, "interaction": label, "return": ret, "success": success,
            "failed": False, "subgoals": {"g": success}, "subgoals_met": float(success)}


def _wilson(k: int, n: int, z: float = 1.959963984540054) -> tuple[float, float]:
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return centre - half, centre + half


def test_summary_by_hand(script) -> None:  # noqa: ANN001
    # a: residual succeeds on 0, 1, 2; zero on 0, 3 -> +1, +1 -1 ... b: both succeed on 0 only.
    res = [_row("a", 0, True, 5.0), _row("a", 1, True, 4.0), _row("a", 2, True, 3.0), _row("a", 3, False, 0.0),
           _row("b", 0, True, 2.0), _row("b", 1, False, 1.0)]
    zero = [_row("a", 0, True, 4.0), _row("a", 1, False, 1.0), _row("a", 2, False, 1.0), _row("a", 3, True, 2.0),
            _row("b", 0, True, 2.0), _row("b", 1, False, 3.0)]
    s = STATS.summarize(res, zero[::-1], seed=0)  # pairing is by (instance, seed), not by order
    assert s["residual_only_successes"] == 2 and s["zero_only_successes"] == 1
    assert s["residual"]["successes"] == 4 and s["zero_residual"]["successes"] == 3
    np.testing.assert_allclose(s["residual"]["success_ci95"], _wilson(4, 6), atol=1e-9)
    # overall differences weigh the two interactions equally: mean of (a: (0+1+1-1)/4, b: 0)
    np.testing.assert_allclose(s["paired_success_difference"]["mean"], (0.25 + 0.0) / 2, atol=1e-12)
    np.testing.assert_allclose(s["paired_return_difference"]["mean"], ((1 + 3 + 2 - 2) / 4 + (0 - 2) / 2) / 2, atol=1e-12)
    a = s["per_interaction"]["a"]
    assert a["residual"]["success_rate"] == 0.75 and a["zero_residual"]["success_rate"] == 0.5
    assert s["target_met"] is False  # one zero-only success: the interval reaches below 0


def test_target_decision(script) -> None:  # noqa: ANN001
    n = 20
    better = [_row("a", k, True, 1.0) for k in range(n)]
    worse = [_row("a", k, k < 2, 0.0) for k in range(n)]
    assert STATS.summarize(better, worse, seed=0)["target_met"] is True
    assert STATS.summarize(worse, better, seed=0)["target_met"] is False
    assert STATS.summarize(better, better, seed=0)["target_met"] is False


def test_summary_rejects_unpaired_episodes(script) -> None:  # noqa: ANN001
    with pytest.raises(ConfigError, match="same"):
        STATS.summarize([_row("a", 0, True, 1.0)], [_row("a", 1, True, 1.0)], seed=0)


def test_wall_clock_budget_stops_after_a_whole_rollout(script, tiny) -> None:  # noqa: ANN001
    settings, out, results, _ = tiny
    assert results["stopped_by_budget"] is False and results["timesteps_trained"] == settings.timesteps
    train, _ = script.build_data(settings)
    models = {lbl: SocialAffordanceModel.load(out / "models" / f"{lbl}.npz") for lbl in settings.labels}
    long = dataclasses.replace(settings, timesteps=100_000)
    agent, norm, recorder, selector = script.train(long, train, models, budget_s=0.0)
    assert selector is None  # select_every 0: no model selection
    rollout = settings.n_steps * settings.n_envs
    assert recorder.stopped and recorder.updated_timesteps == rollout
    assert agent.num_timesteps == rollout + settings.n_envs  # one step of the next rollout, then the stop
    assert all(r["timesteps"] <= rollout for r in recorder.rows)


def test_summary_strata_are_tasks_not_labels(script) -> None:  # noqa: ANN001
    # Two labels of one task (SBU's shaking_hands, NuiSI's handshake) are one stratum; a third task is another.
    def row(label: str, task: str, k: int, success: bool) -> dict:
        return {**_row(label, k, success, float(success)), "task": task}

    res = [row("shaking_hands", "shake_hands", 0, True), row("handshake", "shake_hands", 1, True),
           row("handshake", "shake_hands", 2, True), row("hand_over", "hand_over", 3, False)]
    zero = [row("shaking_hands", "shake_hands", 0, False), row("handshake", "shake_hands", 1, True),
            row("handshake", "shake_hands", 2, True), row("hand_over", "hand_over", 3, False)]
    s = STATS.summarize(res, zero, seed=0)
    assert set(s["per_interaction"]) == {"shake_hands", "hand_over"}
    assert set(s["per_label"]) == {"shaking_hands", "handshake", "hand_over"}
    # by task: (1/3 + 0) / 2; weighting the three labels equally would give (1 + 0 + 0) / 3
    np.testing.assert_allclose(s["paired_success_difference"]["mean"], (1 / 3) / 2, atol=1e-12)
    assert s["per_label"]["shaking_hands"]["paired_success_difference"]["mean"] == 1.0
    assert "per_label" not in STATS.summarize(res[3:], zero[3:], seed=0)


def test_reference_only_plays_the_training_recordings_and_nothing_else(script, tmp_path) -> None:  # noqa: ANN001
    insts = list(generate_dataset(7, SyntheticConfig(interactions=("shake_hands",), instances_per_interaction=4)))
    recorded = [inst.replace(label="handshake", actors=(f"a{k}", f"b{k}"), instance_id=f"rec_{k}")
                for k, inst in enumerate(insts)]
    save_dataset(Dataset("rec", recorded), tmp_path / "rec")
    settings = script.Settings(labels=("handshake",), data=(f"npz:{tmp_path / 'rec'}",), split=("pair",), folds=2,
                               fit_iterations=1, max_frames=15, seed=2)
    ref = script.run(settings, tmp_path / "out", log=lambda m: None, reference_only=True)
    split = ref["split"]
    train_ids, held_ids = split["train_ids"]["handshake"], split["held_out_ids"]["handshake"]
    assert len(train_ids) == len(held_ids) == 2 and not set(train_ids) & set(held_ids)
    assert sorted(r["instance"] for r in ref["episodes"]) == sorted(train_ids)  # no held-out instance is played
    assert {r["task"] for r in ref["episodes"]} == {"shake_hands"} and {r["interaction"] for r in ref["episodes"]} == {"handshake"}
    assert ref["train_reference_zero_residual"]["handshake"]["success"] == np.mean([r["success"] for r in ref["episodes"]])
    assert (tmp_path / "out" / "reference.json").is_file() and (tmp_path / "out" / "models" / "handshake.npz").is_file()
    assert not (tmp_path / "out" / "residual_ppo.zip").exists()
    again = script.build_data(settings)  # the split is a function of the settings
    assert [i.instance_id for i in again[0]] == train_ids and [i.instance_id for i in again[1]] == held_ids


def test_saved_reference_must_come_from_the_same_training_set(script, tmp_path) -> None:  # noqa: ANN001
    settings = script.Settings(data=("npz:/x",), labels=("handshake",), seed=4)
    ref = {"handshake": {"success": 0.5, "return": 3.0}}
    path = tmp_path / "reference.json"
    path.write_text(json.dumps({"settings": dataclasses.asdict(settings), "train_reference_zero_residual": ref}))
    assert script.load_reference(path, settings) == ref
    assert script.load_reference(path, dataclasses.replace(settings, timesteps=5)) == ref  # training budget: free
    older = {k: v for k, v in dataclasses.asdict(settings).items() if k != "train_fall_penalty"}  # before the option
    path.write_text(json.dumps({"settings": older, "train_reference_zero_residual": ref}))
    assert script.load_reference(path, settings) == ref
    with pytest.raises(ConfigError, match="train_fall_penalty"):
        script.load_reference(path, dataclasses.replace(settings, train_fall_penalty=5.0))
    path.write_text(json.dumps({"settings": dataclasses.asdict(settings), "train_reference_zero_residual": ref}))
    for change in ({"seed": 5}, {"held_out_fold": 1}, {"split": ("block",)}, {"data": ("npz:/y",)},
                   {"train_fall_penalty": 5.0}):
        with pytest.raises(ConfigError, match=f"--reference .*{next(iter(change))}"):
            script.load_reference(path, dataclasses.replace(settings, **change))


def test_bad_flag_is_one_line_and_exit_2(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """A bad ``--split`` ends the script with exit 2 and one line naming the flag, before anything is written."""
    mod = load_script("train_residual")
    out = tmp_path / "rl"
    monkeypatch.setattr("sys.argv", ["train_residual.py", "--out", str(out), "--split", "bogus"])
    with pytest.raises(SystemExit) as exc:
        mod.main()
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--split" in err[0] and "bogus" in err[0]
    assert not out.exists()


class _Scripted(gym.Env):
    """Ends its episode at step ``len(reasons)`` with the last reason; reward 1 per step."""

    observation_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
    action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)

    def __init__(self, reasons: list[str | None]) -> None:
        self.reasons, self.k = reasons, 0

    def reset(self, *, seed: int | None = None, options: dict | None = None):  # noqa: ANN206
        self.k = 0
        return np.zeros(1, np.float32), {"termination_reason": None}

    def step(self, action):  # noqa: ANN001, ANN201
        reason = self.reasons[self.k]
        self.k += 1
        return np.zeros(1, np.float32), 1.0, reason is not None, False, {"termination_reason": reason, "reward_x": 1.0}


@pytest.mark.parametrize("last", ["fell", "self_collision", "task_complete"])
def test_fall_penalty_only_on_the_step_that_ends_in_a_fall(last: str) -> None:
    reward_mod = load_script("_residual_reward")
    env = reward_mod.FallPenalty(_Scripted([None, None, last]), 7.5)
    env.reset(seed=0)
    got = [env.step(np.zeros(1, np.float32)) for _ in range(3)]
    expected_last = 1.0 - 7.5 if last == "fell" else 1.0
    assert [g[1] for g in got] == [1.0, 1.0, expected_last]
    for _, reward, _, _, info in got:  # the reward_<term> entries still sum to the reward
        assert info["reward_x"] + info["reward_failure_fell"] == reward
    with pytest.raises(ConfigError, match="--train-fall-penalty"):
        reward_mod.FallPenalty(_Scripted([None]), -1.0)


def test_fall_penalty_wraps_training_environments_only(script, tiny) -> None:  # noqa: ANN001
    settings = tiny[0]
    train, held = script.build_data(settings)
    models = {lbl: SocialAffordanceModel.load(tiny[1] / "models" / f"{lbl}.npz") for lbl in settings.labels}

    def wrapped(s, training: bool) -> bool:  # noqa: ANN001
        env = script.make_env(s, train if training else held, models, training=training)
        while not isinstance(env, SocialAffordanceEnv):
            if type(env).__name__ == "FallPenalty":
                return True
            env = env.env
        return False

    penal = dataclasses.replace(settings, train_fall_penalty=20.0)
    assert wrapped(penal, training=True)
    assert not wrapped(penal, training=False)  # the held-out evaluation keeps the environment's reward
    assert not wrapped(settings, training=True)  # default 0: the environment's reward unchanged


def test_residual_shape_flags_reach_the_environment(script, tiny, monkeypatch: pytest.MonkeyPatch) -> None:  # noqa: ANN001
    """``--residual-groups base left_wrist+right_wrist --residual-tau 0.5``: a (2, 3) residual (6 policy numbers,
    scaled like the plain one), filtered, and the zero policy of that shape."""
    settings, out, _, _ = tiny
    train, _ = script.build_data(settings)
    models = {lbl: SocialAffordanceModel.load(out / "models" / f"{lbl}.npz") for lbl in settings.labels}
    s = dataclasses.replace(settings, residual_groups=("base", "left_wrist+right_wrist"), residual_tau=0.5)
    env = script.make_env(s, train, models)
    assert env.action_space.shape == (6,)
    assert env.unwrapped.config.residual_groups == (("base",), ("left_wrist", "right_wrist"))
    assert env.unwrapped.config.residual_tau == 0.5
    unit = np.linspace(-1.0, 1.0, 6, dtype=np.float32)
    np.testing.assert_allclose(env.action(unit), 0.1 * unit.reshape(2, 3), rtol=0, atol=1e-8)
    episodes_mod = load_script("_residual_episodes")
    assert episodes_mod.zero_policy(env)(None).shape == (6,)
    # The command line parses into the same settings (stopped at the first thing the run checks).
    parsed = parsed_settings(script, monkeypatch, ["--out", str(out / "x"), "--residual-groups", "base",
                                                   "left_wrist+right_wrist", "--residual-tau", "0.5"])
    assert parsed.residual_groups == s.residual_groups and parsed.residual_tau == 0.5


def test_policy_seed_seeds_the_training_only(script, tiny) -> None:  # noqa: ANN001
    # --policy-seed replicates a run's training: PPO and the training resets follow it, while the split, the
    # selection and held-out episodes and the reference check keep --seed.
    settings, out, _, _ = tiny
    train, held = script.build_data(settings)
    models = {lbl: SocialAffordanceModel.load(out / "models" / f"{lbl}.npz") for lbl in settings.labels}
    one = dataclasses.replace(settings, timesteps=settings.n_steps * settings.n_envs)

    def weights(s) -> list[np.ndarray]:  # noqa: ANN001
        agent = script.train(s, train, models)[0]
        return [p.detach().numpy().copy() for p in agent.policy.parameters()]

    default = weights(one)
    same = weights(dataclasses.replace(one, policy_seed=settings.seed))
    other = weights(dataclasses.replace(one, policy_seed=settings.seed + 1))
    assert all(np.array_equal(a, b) for a, b in zip(default, same, strict=True))  # None means --seed
    assert any(not np.array_equal(a, b) for a, b in zip(default, other, strict=True))
    moved = dataclasses.replace(settings, policy_seed=settings.seed + 1)
    train2, held2 = script.build_data(moved)
    assert [i.instance_id for i in train2] == [i.instance_id for i in train]
    assert [i.instance_id for i in held2] == [i.instance_id for i in held]
    assert script.selection_episodes(moved, train) == script.selection_episodes(settings, train)
    ref = out / "reference_policy_seed.json"
    ref.write_text(json.dumps({"settings": dataclasses.asdict(settings),
                               "train_reference_zero_residual": {"x": {"success": 1.0, "return": 0.0}}}))
    assert script.load_reference(ref, moved) == {"x": {"success": 1.0, "return": 0.0}}


def test_policy_seed_flag(script) -> None:  # noqa: ANN001
    ap = script.parser(script.Settings, None)
    given = script.settings_from_args(script.Settings, ap.parse_args(["--out", "x", "--policy-seed", "1"]))
    assert (given.seed, given.policy_seed) == (0, 1)
    assert script.settings_from_args(script.Settings, ap.parse_args(["--out", "x"])).policy_seed is None
