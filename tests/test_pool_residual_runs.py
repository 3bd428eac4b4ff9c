"""scripts/pool_residual_runs.py: the replication summary of several residual-RL runs, against a brute-force
computation written out here, and its one-line errors."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import load_script

_SCRIPT = load_script("pool_residual_runs")


def _results(path, outcomes):
    """A results.json with rows {instance: (task, final success, zero success)}."""
    rows = {"residual": [], "zero_residual": []}
    for name, (task, final, zero) in outcomes.items():
        rows["residual"].append({"instance": name, "task": task, "success": final})
        rows["zero_residual"].append({"instance": name, "task": task, "success": zero})
    path.write_text(json.dumps({"episodes": rows}))
    return path


def _brute_force(runs, n_resamples, seed):
    """Per-instance mean over runs, stratified by task; the bootstrap resampling instances within each task with
    one (n_resamples, n_task) draw per task in sorted task order (paired_difference's order of draws)."""
    names = sorted(runs[0])
    d = {i: np.mean([r[i][1] - r[i][2] for r in runs]) for i in names}
    tasks = sorted({runs[0][i][0] for i in names})
    groups = [np.array([d[i] for i in names if runs[0][i][0] == t]) for t in tasks]
    point = np.mean([g.mean() for g in groups])
    rng = np.random.default_rng(seed)
    boot = sum(g[rng.integers(0, g.size, size=(n_resamples, g.size))].mean(axis=1) for g in groups) / len(groups)
    return point, *np.percentile(boot, [2.5, 97.5])


def test_pooled_figure_equals_brute_force(tmp_path):
    rng = np.random.default_rng(3)
    instances = {f"i{k}": ("hand_over" if k % 3 else "shake_hands") for k in range(30)}
    runs = [{i: (t, bool(rng.random() < 0.8), bool(rng.random() < 0.7)) for i, t in instances.items()}
            for _ in range(2)]
    paths = [_results(tmp_path / f"r{k}.json", run) for k, run in enumerate(runs)]
    got = _SCRIPT.pool([_SCRIPT.instance_differences(p) for p in paths], [str(p) for p in paths], seed=5)
    np.testing.assert_allclose(got, _brute_force(runs, 10_000, 5), rtol=0, atol=1e-12)
    # one run alone is that run's own statistic: the strata's means of final − zero
    one = _SCRIPT.pool([_SCRIPT.instance_differences(paths[0])], [str(paths[0])], seed=5)
    np.testing.assert_allclose(one, _brute_force(runs[:1], 10_000, 5), rtol=0, atol=1e-12)


def test_strata_weighted_equally_not_by_size(tmp_path):
    # 1 shake-hands instance gained, 9 hand-overs unchanged: equal strata give 0.5, pooling instances would give 0.1
    outcomes = {f"h{k}": ("hand_over", True, True) for k in range(9)} | {"s0": ("shake_hands", True, False)}
    path = _results(tmp_path / "r.json", outcomes)
    mean, _, _ = _SCRIPT.pool([_SCRIPT.instance_differences(path)], [str(path)])
    assert mean == pytest.approx(0.5)


def test_runs_averaged_per_instance(tmp_path):
    a = _results(tmp_path / "a.json", {"x": ("t", True, False), "y": ("t", False, False)})
    b = _results(tmp_path / "b.json", {"x": ("t", False, False), "y": ("t", False, True)})
    runs = [_SCRIPT.instance_differences(p) for p in (a, b)]
    mean, low, high = _SCRIPT.pool(runs, ["a", "b"])
    assert mean == pytest.approx(0.0)  # x: (1 + 0)/2, y: (0 − 1)/2
    assert low == pytest.approx(-0.5) and high == pytest.approx(0.5)


@pytest.mark.parametrize("case, expected", [
    ("missing", "expected a train_residual.py results.json"),
    ("no_episodes", "expected episodes.residual and episodes.zero_residual"),
    ("other_instances", "expected the same held-out instances and tasks as"),
    ("arms_differ", "expected the residual and zero-residual arms on the same instances"),
])
def test_bad_input_exit_2_one_line(tmp_path, capsys, case, expected):
    a = _results(tmp_path / "a.json", {"x": ("t", True, False)})
    if case == "missing":
        b = tmp_path / "absent.json"
    elif case == "no_episodes":
        b = tmp_path / "b.json"
        b.write_text(json.dumps({"summary": {}}))
    elif case == "other_instances":
        b = _results(tmp_path / "b.json", {"z": ("t", True, False)})
    else:
        b = tmp_path / "b.json"
        b.write_text(json.dumps({"episodes": {"residual": [{"instance": "x", "task": "t", "success": True}],
                                               "zero_residual": []}}))
    out = tmp_path / "out.json"
    assert _SCRIPT.main([str(a), str(b), "--json", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and expected in err and str(b if case != "other_instances" else b) in err
    assert not out.exists()


def test_writes_json(tmp_path, capsys):
    a = _results(tmp_path / "a.json", {"x": ("t", True, False), "y": ("t", True, True)})
    out = tmp_path / "out.json"
    assert _SCRIPT.main([str(a), "--json", str(out)]) == 0
    rows = json.loads(out.read_text())
    assert [r["run"] for r in rows] == [str(a), "pooled"]
    assert rows[1]["mean"] == pytest.approx(0.5)
