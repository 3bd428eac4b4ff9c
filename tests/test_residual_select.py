"""scripts/_residual_select.py and the flags that use it (``--select-every``, ``--target-kl``,
``--held-out-seed-base``): model selection on the training side.

The choice rule is checked against a brute-force reference on random score lists and on the cases that tell it
apart from its inversions (the worst checkpoint, a tie going to the checkpoint, the latest of equal maxima). The
wiring is checked on tiny runs: the selection episodes are the reference run's episodes of the acting labels, the
start's score is a replay of the zero output through the gate, evaluating checkpoints leaves the training
bit-for-bit unchanged, and whichever way the choice goes (forced both ways) the saved policy and the held-out
"residual" arm are the chosen one.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import load_script, parsed_settings

pytest.importorskip("stable_baselines3")  # the [rl] extra

import torch  # noqa: E402
from stable_baselines3 import PPO  # noqa: E402
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize  # noqa: E402


_SCRIPT = load_script("train_residual")  # puts scripts/ on sys.path, where _residual_select imports its siblings
sel = load_script("_residual_select")


def _brute(start: int, scores: list[int]) -> int | None:
    best = max(scores, default=None)
    if best is None or best <= start:
        return None
    return min(k for k, v in enumerate(scores) if v == best)


def test_select_picks_the_best_checkpoint_and_falls_back_to_the_start() -> None:
    assert sel.select(10, [9, 12, 11]) == 1  # the best, not the last or the worst
    assert sel.select(10, [12, 9, 8]) == 0
    assert sel.select(10, [9, 10, 10]) is None  # equal to the start: the start is kept
    assert sel.select(10, [3, 4]) is None  # all worse: the start
    assert sel.select(10, [11, 12, 12]) == 1  # equal maxima: the earliest
    assert sel.select(10, []) is None
    rng = np.random.default_rng(0)
    for _ in range(500):
        scores = [int(x) for x in rng.integers(0, 8, size=int(rng.integers(0, 6)))]
        start = int(rng.integers(0, 8))
        assert sel.select(start, scores) == _brute(start, scores), (start, scores)


def test_score_counts_successes_and_means() -> None:
    rows = [{"success": True, "return": 2.0, "mean_abs_action": 0.1}, {"success": False, "return": -1.0, "mean_abs_action": 0.3},
            {"success": True, "return": 5.0, "mean_abs_action": 0.2}]
    got = sel.score(rows)
    assert got["successes"] == 2 and got["episodes"] == 3
    assert got["mean_return"] == pytest.approx(2.0) and got["mean_abs_action"] == pytest.approx(0.2)


@pytest.fixture(scope="module")
def script():  # noqa: ANN201
    return _SCRIPT


@pytest.fixture(scope="module")
def tiny(script, tmp_path_factory):  # noqa: ANN001, ANN201
    """A gated tiny run's settings, its training set and models (fitted once by a --reference-only run)."""
    s = script.Settings(train_instances=2, eval_instances=2, fit_iterations=1, timesteps=128, n_envs=1, n_steps=64,
                        batch_size=32, n_epochs=2, hidden=16, seed=5, max_frames=12, reach_scale=0.2,
                        action_scale=0.05, residual_labels=("hand_over",), action_bias=(0.0, 0.0, 0.0, 0.5, 0.0),
                        select_every=1, target_kl=0.01, held_out_seed_base=20_000)
    out = tmp_path_factory.mktemp("sel")
    ref = script.run(s, out / "ref", reference_only=True, log=lambda m: None)
    train, _ = script.build_data(s)
    models = {lbl: script.SocialAffordanceModel.load(out / "ref" / "models" / f"{lbl}.npz") for lbl in s.labels}
    return s, out, ref, train, models


def test_selection_episodes_and_start_are_the_reference_runs(script, tiny) -> None:  # noqa: ANN001
    s, _, ref, train, models = tiny
    eps = script.selection_episodes(s, train)
    hand_overs = [i.instance_id for i in train if i.label == "hand_over"]
    assert sorted(i for i, _ in eps) == sorted(hand_overs) and len(eps) == 2
    start_rows = {(r["instance"], r["seed"]): r for r in ref["episodes_start"]}
    assert all(p in start_rows for p in eps)  # the --reference-only run's (instance, seed) pairs
    agent, norm, recorder, selector = script.train(s, train, models)
    assert selector.start["successes"] == sum(start_rows[p]["success"] for p in eps)
    assert selector.start["mean_return"] == pytest.approx(np.mean([start_rows[p]["return"] for p in eps]), abs=1e-9)
    assert agent.target_kl == 0.01
    # 2 updates of 64 steps, a checkpoint after each (the second one by finish(), after the last update)
    assert [c["updates"] for c in selector.checkpoints] == [1, 2]
    assert [c["timesteps"] for c in selector.checkpoints] == [64, 128]
    assert selector.chosen == sel.select(selector.start["successes"], [c["successes"] for c in selector.checkpoints])


def test_checkpoint_evaluations_leave_training_unchanged(script, tiny) -> None:  # noqa: ANN001
    s, _, _, train, models = tiny
    plain_agent, plain_norm, plain_rec, none = script.train(dataclasses.replace(s, select_every=0), train, models)
    assert none is None
    agent, norm, rec, selector = script.train(s, train, models)
    assert rec.rows == plain_rec.rows
    last_weights, last_rms = selector._snapshots[-1]
    for key, value in plain_agent.policy.state_dict().items():
        assert torch.equal(value, last_weights[key]), key
    np.testing.assert_array_equal(plain_norm.obs_rms.mean, last_rms.mean)
    np.testing.assert_array_equal(plain_norm.obs_rms.var, last_rms.var)
    # the last checkpoint's score is the unselected policy's, replayed from scratch
    env = script.make_env(s, train, models, training=True, gate=True)
    rows = script.run_episodes(env, script.selection_episodes(s, train), script.trained_policy(plain_agent, plain_norm))
    assert selector.checkpoints[-1]["successes"] == sum(r["success"] for r in rows)
    assert selector.checkpoints[-1]["mean_return"] == pytest.approx(np.mean([r["return"] for r in rows]), abs=1e-9)


@pytest.mark.parametrize("forced", [0, None])
def test_the_run_keeps_what_was_chosen(script, tiny, forced, monkeypatch: pytest.MonkeyPatch) -> None:  # noqa: ANN001
    """Forced to the first checkpoint, the saved policy is that checkpoint (not the last policy) and the held-out
    residual arm plays it; forced to the start, the held-out residual arm is the start's rows."""
    s, out, _, train, models = tiny
    monkeypatch.setitem(script.CheckpointSelector.finish.__globals__, "select", lambda start, scores: forced)
    r = script.run(s, out / f"run_{forced}", models_dir=out / "ref" / "models", reference_file=out / "ref" / "reference.json",
                   log=lambda m: None)
    selection = r["selection"]
    assert selection["chosen"] == forced and len(selection["checkpoints"]) == 2
    res, start = r["episodes"]["residual"], r["episodes_start"]
    _, held = script.build_data(s)
    assert [x["seed"] for x in res] == [20_000 + 1_000 * s.seed + k for k in range(len(held))]  # fresh reset seeds
    assert [x["seed"] for x in r["episodes"]["zero_residual"]] == [x["seed"] for x in res]
    if forced is None:
        assert res == start
        assert r["summary_learned"]["paired_success_difference"]["mean"] == 0.0
        return
    agent = PPO.load(out / f"run_{forced}" / "residual_ppo.zip", device="cpu")
    norm = VecNormalize.load(str(out / f"run_{forced}" / "vecnormalize.pkl"),
                             DummyVecEnv([lambda: script.make_env(s, train, models, gate=True)]))
    norm.training = False
    env = script.make_env(s, train, models, training=True, gate=True)
    rows = script.run_episodes(env, script.selection_episodes(s, train), script.trained_policy(agent, norm))
    first = selection["checkpoints"][0]
    assert sum(x["success"] for x in rows) == first["successes"]
    assert np.mean([x["return"] for x in rows]) == pytest.approx(first["mean_return"], abs=1e-9)
    assert np.mean([x["mean_abs_action"] for x in rows]) == pytest.approx(first["mean_abs_action"], abs=1e-9)
    assert first["mean_abs_action"] != selection["checkpoints"][1]["mean_abs_action"]  # not the last policy
    held_gated = script.make_env(s, held, models, gate=True)
    again = script.run_episodes(held_gated, [(x["instance"], x["seed"]) for x in res], script.trained_policy(agent, norm))
    assert [x["return"] for x in again] == [x["return"] for x in res]


def test_held_out_seed_base() -> None:
    eps = load_script("_residual_episodes")
    assert eps.held_out_episodes(["a", "b"], 2) == [("a", 12_000), ("b", 12_001)]  # the first five runs' seeds
    assert eps.held_out_episodes(["a", "b"], 0, 20_000) == [("a", 20_000), ("b", 20_001)]


def test_flags_parse_and_bad_select_every_is_exit_2(script, tmp_path, monkeypatch: pytest.MonkeyPatch,  # noqa: ANN001
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    s = parsed_settings(script, monkeypatch, ["--out", str(tmp_path / "x"), "--select-every", "8", "--target-kl", "0.02",
                                              "--held-out-seed-base", "20000", "--learning-rate", "1e-4"])
    assert (s.select_every, s.target_kl, s.held_out_seed_base, s.learning_rate) == (8, 0.02, 20_000, 1e-4)
    assert script.Settings().target_kl is None and script.Settings().select_every == 0  # defaults unchanged
    capsys.readouterr()
    monkeypatch.setattr("sys.argv", ["train_residual.py", "--out", str(tmp_path / "y"), "--select-every", "-1"])
    with pytest.raises(SystemExit) as exc:
        script.main()
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--select-every" in err[0]
    assert not (tmp_path / "y").exists()
