"""Method replicates (``EvaluationConfig.replicate``, ``evaluate --replicate``): the same folds, another
random stream for every method."""

from __future__ import annotations

import json
import math
from collections.abc import Sequence

import numpy as np
import pytest
from conftest import load_script
from test_evaluation import toy_dataset

from socialaff_sim.baselines.simple import HoldPose
from socialaff_sim.cli.main import main
from socialaff_sim.data import Interaction, save_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.evaluation import EvaluationConfig, evaluate, format_tables, write_results
from socialaff_sim.evaluation.crossval import make_tasks, task_seed
from socialaff_sim.evaluation.merge import reuse_results
from socialaff_sim.evaluation.registry import METHODS


class DriftingHold(HoldPose):
    """``hold`` plus a constant drift drawn from the fit's generator: its errors depend on the stream."""

    name = "drift"

    def fit(self, interactions: Sequence[Interaction], *, rng: np.random.Generator) -> DriftingHold:
        self.drift_ = rng.normal(scale=0.01, size=3)
        return super().fit(interactions, rng=rng)

    def _velocity(self, seen: np.ndarray, fps: float) -> tuple[np.ndarray, float]:
        return np.broadcast_to(self.drift_, seen[-1].shape).copy(), math.inf


@pytest.fixture()
def registered(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(METHODS, "drift", DriftingHold)
    monkeypatch.setitem(METHODS, "hold", HoldPose)


def test_replicate_zero_keeps_the_streams_of_earlier_runs_and_others_differ() -> None:
    old = np.random.SeedSequence(4, spawn_key=(1, 0xABC, 2, 0xDEF))  # the formula before replicates existed
    label, method = "shake_hands", "full"
    zero = task_seed(4, label, 2, method)
    assert zero.spawn_key[0] == old.spawn_key[0] == 1 and zero.entropy == 4
    draws = {r: np.random.default_rng(task_seed(4, label, 2, method, r)).integers(1 << 62) for r in range(4)}
    assert np.random.default_rng(task_seed(4, label, 2, method, 0)).integers(1 << 62) == draws[0]
    assert np.random.default_rng(task_seed(4, label, 2, method, 3)).integers(1 << 62) == draws[3]  # deterministic
    assert len(set(draws.values())) == 4


def test_replicates_share_the_folds(registered: None) -> None:
    data = toy_dataset(seed=2, labels=("shake_hands",), n_pairs=4, per_pair=2)
    a, _, _ = make_tasks(data, [("drift", DriftingHold)], ["shake_hands"], EvaluationConfig(seed=1))
    b, _, _ = make_tasks(data, [("drift", DriftingHold)], ["shake_hands"], EvaluationConfig(seed=1, replicate=2))
    assert [t.replicate for t in a] == [0] * len(a) and [t.replicate for t in b] == [2] * len(b)
    for x, y in zip(a, b, strict=True):
        assert [i.instance_id for i in x.train] == [i.instance_id for i in y.train]
        assert [i.instance_id for i in x.test] == [i.instance_id for i in y.test]
    with pytest.raises(ConfigError, match="replicate: expected at least 0"):
        EvaluationConfig(replicate=-1)


def test_a_replicate_changes_a_random_method_only_and_merges_with_its_replicate(registered: None) -> None:
    data = toy_dataset(seed=2, labels=("shake_hands",), n_pairs=4, per_pair=2)
    zero = evaluate(data, ["drift", "hold"], config=EvaluationConfig(executor="serial", seed=1))
    one = evaluate(data, ["drift", "hold"], config=EvaluationConfig(executor="serial", seed=1, replicate=1))
    again = evaluate(data, ["drift"], config=EvaluationConfig(executor="serial", seed=1, replicate=1))
    rows = {name: res["per_instance"]["shake_hands"] for name, res in (("zero", zero), ("one", one), ("again", again))}
    ids = [(r["instance_id"], r["fold"]) for r in rows["zero"]["drift"]]
    assert ids == [(r["instance_id"], r["fold"]) for r in rows["one"]["drift"]]
    err = {k: np.array([r["key_joint_error_m"] for r in v["drift"]]) for k, v in rows.items()}
    assert not np.allclose(err["zero"], err["one"])  # another stream
    np.testing.assert_array_equal(err["one"], err["again"])  # the same replicate: the same numbers
    assert rows["zero"]["hold"] == rows["one"]["hold"]  # a method without randomness does not move
    assert zero["settings"]["replicates"] == {"drift": 0, "hold": 0}
    assert one["settings"]["replicates"] == {"drift": 1, "hold": 1} and "method replicate 1" in one["title"]
    assert "method replicate" not in zero["title"]
    merged = reuse_results(again, zero, "zero.json")  # replicate 1 of drift beside replicate 0 of hold
    assert merged["settings"]["replicates"] == {"drift": 1, "hold": 0}
    assert "Method replicates (the same folds, another random stream for the method): drift 1" in format_tables(merged)
    assert "Method replicates" not in format_tables(zero)


def test_cli_rejects_a_negative_replicate(tmp_path, capsys: pytest.CaptureFixture[str]) -> None:  # noqa: ANN001
    data = toy_dataset(seed=2, labels=("shake_hands",), n_pairs=4, per_pair=2)
    path = tmp_path / "toy.npz"
    save_dataset(data, path)
    code = main(["evaluate", "--data", str(path), "--methods", "hold", "--out", str(tmp_path / "out"), "--replicate", "-1"])
    assert code == 2 and "argument --replicate: expected an integer >= 0, found -1" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_replicate_summary_averages_the_instances_over_replicates(registered: None, tmp_path,  # noqa: ANN001
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    script = load_script("replicate_summary")
    data = toy_dataset(seed=2, labels=("shake_hands", "hand_over"), n_pairs=4, per_pair=2)
    paths, runs = [], []
    for r in (2, 0, 1):
        res = evaluate(data, ["drift", "hold"], config=EvaluationConfig(executor="serial", seed=1, replicate=r))
        paths.append(write_results(res, tmp_path / f"r{r}")["json"])
        runs.append(json.loads(paths[-1].read_text()))
    assert script.main([str(p) for p in paths] + ["--method", "drift", "--references", "hold"]) == 0
    out = capsys.readouterr().out
    # independent reference: the class means of the per-instance differences, averaged over the replicates
    diff = []
    for label in ("shake_hands", "hand_over"):
        hold = {(r["instance_id"], r["fold"]): r["key_joint_error_m"] for r in runs[0]["per_instance"][label]["hold"]}
        per_rep = [{(r["instance_id"], r["fold"]): r["key_joint_error_m"] for r in run["per_instance"][label]["drift"]}
                   for run in runs]
        diff.append(np.mean([np.mean([p[k] for p in per_rep]) - hold[k] for k in hold]))
    mean_row = next(line for line in out.splitlines() if line.startswith("| **mean of 3** |"))
    assert f"| {np.mean(diff):+.4f} [" in mean_row
    averages = [run["average"]["drift"]["key_joint_error_m"] for run in runs]
    assert f"{np.mean(averages):.4f}" in mean_row and f"standard deviation {np.std(averages, ddof=1):.4f} m" in out
    rows = [line.split(" | ")[0] for line in out.splitlines() if line.startswith("| ") and line[2].isdigit()]
    assert rows == ["| 0", "| 1", "| 2"]  # ordered by replicate
    # a reference with randomness is averaged over the files too: hold − mean(drift) is the negated difference
    assert script.main([str(paths[1]), str(paths[2]), str(paths[0]), "--method", "hold", "--references", "drift"]) == 0
    out = capsys.readouterr().out
    assert "References' replicates: `drift` [0, 1, 2]" in out
    mean_row = next(line for line in out.splitlines() if line.startswith("| **mean of 3** |"))
    assert f"| {-np.mean(diff):+.4f} [" in mean_row
    # a replicate given twice, and a reference not evaluated: exit 2 with a line naming it
    assert script.main([str(paths[1]), str(paths[1]), "--method", "drift", "--references", "hold"]) == 2
    assert "each replicate once" in capsys.readouterr().err
    assert script.main([str(paths[0]), "--method", "drift", "--references", "ridge"]) == 2
    assert "method 'ridge' was not evaluated" in capsys.readouterr().err
