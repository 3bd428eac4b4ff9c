"""Reusing methods' results from an earlier evaluation (``evaluate --reuse``, evaluation/merge.py)."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest
from test_evaluation import toy_dataset

from socialaff_sim.cli.main import main
from socialaff_sim.data import save_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.evaluation import EvaluationConfig, evaluate, format_tables, write_results
from socialaff_sim.evaluation.merge import check_reusable, reuse_results

METHODS = ["ridge", "hold", "constvel"]


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, dict, dict]:
    """(three methods in one run, saved and loaded; the same run's hold alone; the data and config)."""
    data = toy_dataset(seed=5, labels=("shake_hands", "hand_over"), n_pairs=4, per_pair=2)
    config = EvaluationConfig(n_folds=2, seed=3, executor="serial")
    folder = tmp_path_factory.mktemp("reuse")
    write_results(evaluate(data, METHODS, config=config), folder)
    whole = json.loads((folder / "results.json").read_text())
    part = evaluate(data, ["hold"], config=config)
    return whole, part, {"folder": folder, "data": data, "config": config}


def test_rerunning_some_methods_reproduces_the_whole_run(runs: tuple[dict, dict, dict]) -> None:
    whole, part, _ = runs
    merged = reuse_results(part, whole, "earlier/results.json")
    assert merged["reused"] == {"from": "earlier/results.json", "methods": ["ridge", "constvel"]}
    assert list(merged["average"]) == METHODS and merged["settings"]["methods"] == METHODS
    # the saved file writes NaN as null; compare as saved
    folder = Path(runs[2]["folder"]) / "merged"
    write_results(merged, folder)
    again = json.loads((folder / "results.json").read_text())
    for key in ("per_interaction", "average", "per_instance", "paired", "parse_accuracy"):
        assert again[key] == whole[key], key
    assert "Not run again: ridge, constvel, taken from `earlier/results.json`" in format_tables(merged)
    assert "Not run again" not in format_tables(whole)


def test_a_method_in_both_runs_is_taken_from_the_new_one(runs: tuple[dict, dict, dict]) -> None:
    whole, part, _ = runs
    stale = copy.deepcopy(whole)
    for label in stale["per_instance"]:
        for row in stale["per_instance"][label]["hold"]:
            row["key_joint_error_m"] += 1.0
    merged = reuse_results(part, stale, "stale.json")
    assert merged["reused"]["methods"] == ["ridge", "constvel"]
    for label in part["per_instance"]:
        assert merged["per_instance"][label]["hold"] == part["per_instance"][label]["hold"]
    # and the paired comparisons use the new hold: ridge − hold as in the whole run, not shifted by 1 m
    d_new = merged["paired"]["hold"]["differences"]["key_joint_error_m"]["ridge"]["mean_m"]
    assert d_new == pytest.approx(whole["paired"]["hold"]["differences"]["key_joint_error_m"]["ridge"]["mean_m"], abs=1e-12)


@pytest.mark.parametrize(("field", "value", "message"), [
    ("seed", 4, "settings.seed is 4"),
    ("n_folds", 3, "settings.n_folds is 3"),
    ("protocol", "offline", "settings.protocol is 'offline'"),
    ("max_test", 1, "settings.max_test is 1"),
])
def test_other_settings_are_refused(runs: tuple[dict, dict, dict], field: str, value: object, message: str) -> None:
    whole, part, ctx = runs
    other = copy.deepcopy(whole)
    other["settings"][field] = value
    with pytest.raises(ConfigError, match=message):
        reuse_results(part, other, "x.json")
    with pytest.raises(ConfigError, match=message):
        check_reusable(other, ctx["data"].name, ctx["config"], list(ctx["data"].labels), "x.json")
    check_reusable(whole, ctx["data"].name, ctx["config"], list(ctx["data"].labels), "x.json")  # the same: no error


def test_other_instances_or_data_are_refused(runs: tuple[dict, dict, dict]) -> None:
    whole, part, _ = runs
    other = copy.deepcopy(whole)
    other["per_instance"]["hand_over"]["ridge"][0]["fold"] = 1 - other["per_instance"]["hand_over"]["ridge"][0]["fold"]
    with pytest.raises(ConfigError, match=r"per_instance\.hand_over\.ridge tests other \(instance, fold\) pairs"):
        reuse_results(part, other, "x.json")
    other = copy.deepcopy(whole)
    other["dataset"] = "sbu"
    with pytest.raises(ConfigError, match="x.json: dataset is 'sbu'"):
        reuse_results(part, other, "x.json")
    with pytest.raises(ConfigError, match="no method to reuse"):
        reuse_results(whole, whole, "x.json")


def test_cli_reuse_and_its_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    save_dataset(toy_dataset(seed=4, per_pair=2), tmp_path / "data")
    spec = f"npz:{tmp_path / 'data'}"
    base = ["evaluate", "--data", spec, "--folds", "2", "--executor", "serial", "--quiet"]
    assert main([*base, "--methods", "ridge,hold", "--out", str(tmp_path / "a")]) == 0
    capsys.readouterr()
    earlier = tmp_path / "a" / "results.json"
    assert main([*base, "--methods", "hold", "--reuse", str(earlier), "--out", str(tmp_path / "b")]) == 0
    merged = json.loads((tmp_path / "b" / "results.json").read_text())
    assert merged["reused"]["methods"] == ["ridge"]
    assert merged["paired"] == json.loads(earlier.read_text())["paired"]
    capsys.readouterr()
    # a run with another seed is refused before anything is fitted or written
    assert main([*base, "--seed", "1", "--methods", "hold", "--reuse", str(earlier), "--out", str(tmp_path / "c")]) == 2
    err = capsys.readouterr().err.strip()
    assert "settings.seed is 0, this run's is 1" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "c").exists()
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    assert main([*base, "--methods", "hold", "--reuse", str(bad), "--out", str(tmp_path / "d")]) == 2
    assert "--reuse" in capsys.readouterr().err and not (tmp_path / "d").exists()
    assert main([*base, "--methods", "hold", "--reuse", str(tmp_path / "none.json"), "--out", str(tmp_path / "e")]) == 2
    assert "cannot read it" in capsys.readouterr().err


def test_reusing_a_merged_file_keeps_where_its_rows_came_from(runs: tuple[dict, dict, dict]) -> None:
    whole, part, _ = runs
    merged = reuse_results(part, whole, "first.json")  # hold new; ridge, constvel from first.json
    ridge_only = {**merged, "average": {"ridge": merged["average"]["ridge"]}}
    again = reuse_results(ridge_only, merged, "second.json")
    assert again["reused"]["methods"] == ["hold", "constvel"]
    assert again["reused"]["earlier"] == {"from": "first.json", "methods": ["ridge", "constvel"]}
    assert "That file took ridge, constvel from `first.json`." in format_tables(again)
    assert "earlier" not in merged["reused"]

