"""scripts/bench_sim_synth.py: the synthesized-vs-ground-truth sub-goal benchmark, on a tiny setting.

One interaction, 3 training instances, 1 MCMC iteration, 1 test instance of the first
pair-disjoint fold. The figures are not judged (the model is barely fitted); what is
checked is that the JSON carries what the loop did: each source's episode is replayed
independently with the library (``run_episode`` with the recorded track, and with the
saved model through ``key_joint_source``) and must give the same sub-goals and failures,
and the aggregation is checked against counts worked out by hand.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import load_script

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "scripts" / "bench_sim_synth.py"


@pytest.fixture(scope="module")
def bench():  # noqa: ANN201
    return load_script("bench_sim_synth")


def _row(label: str, gt: tuple[bool, list[str]], synth: tuple[bool, list[str]]) -> dict:
    """A hand-made instance row: (sub-goal met, failures) per source, one sub-goal 'g'."""

    def src(met: bool, fails: list[str]) -> dict:
        return {"success": met and not fails, "subgoals": {"g": met}, "failures": fails, "key_joint_error_m": 0.1}

    return {"interaction": label, "gt": src(*gt), "synth": src(*synth)}


def test_summary_counts_by_hand(bench) -> None:  # noqa: ANN001
    rows = [
        _row("a", (True, []), (True, [])),
        _row("a", (True, []), (False, [])),
        _row("a", (True, []), (True, ["contact_force"])),
        _row("a", (False, []), (True, [])),
    ]
    errs = {"gt": [np.array([0.0, 0.01, 0.03])], "synth": [np.array([0.05])]}
    s = bench.summarize(rows, errs)
    assert s["instances"] == 4
    assert s["gt"]["successes"] == 3 and s["synth"]["successes"] == 2
    np.testing.assert_allclose(s["ratio"], (2 / 4) / (3 / 4), atol=1e-12)
    assert s["target_met"] is False
    np.testing.assert_allclose(s["synth"]["subgoal_rates"]["g"], 3 / 4, atol=1e-12)
    assert s["synth"]["failures"] == {"contact_force": 1}
    assert s["synth"]["unmet_subgoals"] == {"unmet:g": 1}
    assert s["gt"]["unmet_subgoals"] == {"unmet:g": 1}
    assert (s["both_succeeded"], s["only_gt_succeeded"], s["only_synth_succeeded"]) == (1, 2, 1)
    np.testing.assert_allclose(s["gt"]["ik_reachable_within_2cm"], 2 / 3, atol=1e-12)
    assert s["gt"]["ik_reachable_targets"] == 3
    everything = bench.summarize(rows, errs, prefix_subgoals=True)
    assert set(everything["gt"]["subgoal_rates"]) == {"a/g"}
    none_gt = bench.summarize(rows[3:], {"gt": [], "synth": []})
    assert none_gt["ratio"] is None and none_gt["target_met"] is None


def test_tiny_run_matches_an_independent_replay(bench, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:  # noqa: ANN001
    from socialaff_sim.data.synthetic import generate_dataset
    from socialaff_sim.retarget.model_source import key_joint_source
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode
    from socialaff_sim.sim.simulator import SimConfig, Simulator

    out, models = tmp_path / "out.json", tmp_path / "models"
    seed = 0
    bench.main(["--interactions", "shake_hands", "--max-train", "3", "--max-test", "1", "--iterations", "1",
                "--quick", "--seed", str(seed), "--save-models", str(models), "--json", str(out)])
    printed = capsys.readouterr().out
    result = json.loads(out.read_text())

    settings = result["settings"]
    assert settings["folds"] == 4 and settings["folds_run"] == 1 and settings["iterations"] == 1
    assert settings["interactions"] == ["shake_hands"] and settings["robot"] == "ours"
    (fold,) = result["folds"]
    assert fold["train"] == 3 and fold["test"] == 1
    assert not set(fold["train_actor_pairs"]) & set(fold["test_actor_pairs"])  # pair-disjoint
    (row,) = result["instances"]
    assert "+".join(sorted(row["actors"])) in fold["test_actor_pairs"]

    # each source's record is what an independent replay of that instance gives
    inter = generate_dataset(seed).by_id(row["instance"])
    sim = Simulator("ours", "shake_hands", SimConfig.harness())
    for name, source in (("gt", GroundTruthSource()), ("synth", key_joint_source(models / "shake_hands_fold0.npz"))):
        ref = run_episode(sim, source, inter)
        rec = row[name]
        assert rec["success"] == ref["success"]
        assert rec["subgoals"] == {s["name"]: s["success"] for s in ref["subgoals"]}
        assert rec["failures"] == [f["kind"] for f in ref["failures"] if f["triggered"]]
        assert rec["success"] == (all(rec["subgoals"].values()) and not rec["failures"])
        assert 0 < rec["ik_reachable_hits_2cm"] <= rec["ik_reachable_targets"]
    assert np.isfinite(row["synth"]["key_joint_error_m"]) and row["synth"]["key_joint_error_m"] > 0

    # the summaries aggregate that one row
    for key in ("shake_hands", "all"):
        s = result["summary"][key]
        assert s["instances"] == 1
        for name in ("gt", "synth"):
            assert s[name]["successes"] == int(row[name]["success"])
            assert s[name]["success_rate"] == float(row[name]["success"])
        if row["gt"]["success"]:
            np.testing.assert_allclose(s["ratio"], float(row["synth"]["success"]), atol=1e-12)
            assert s["target_met"] == row["synth"]["success"]
        else:
            assert s["ratio"] is None
    assert set(result["summary"]["all"]["gt"]["subgoal_rates"]) == {"shake_hands/hands_clasped"}
    assert "| shake_hands | 1 |" in printed and "| all | 1 |" in printed
