"""Experiment 1 machinery: protocol, registry, metrics, cross-validation, reports, CLI."""

from __future__ import annotations

import itertools
import json
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest
from test_body_fit import KINECT, place, standing_skeleton

from socialaff_sim.data import Dataset, Interaction, save_dataset
from socialaff_sim.errors import ConfigError, ModelError
from socialaff_sim.evaluation import (
    METHODS,
    EvaluationConfig,
    Prediction,
    ReactionMethod,
    evaluate,
    get_method,
    joint_error,
    key_joint_error,
    matched_accuracy,
    observed_part,
    parse_confusion,
    prediction_from_joints,
    register_method,
    write_results,
)
from socialaff_sim.evaluation.metrics import mean_joint_distance


# -- a small two-person data set: agent 1 raises its right arm after agent 0, with a lag -------------
def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def toy_interaction(rng: np.random.Generator, label: str, actors: tuple[str, str], idx: int, *, n_frames: int | None = None) -> Interaction:
    """One reach-and-return instance (Kinect v2 layout, 10 fps) with 3 ground-truth sub-events."""
    T = n_frames or int(rng.integers(26, 36))
    t = np.arange(T)
    start, dur, lag, amp = rng.uniform(3, 6), rng.uniform(6, 9), rng.uniform(1, 3), rng.uniform(1.0, 1.4)
    a0 = amp * (_smoothstep((t - start) / dur) - _smoothstep((t - start - dur - 6) / dur))
    a1 = (0.9 * amp + 0.1) * (_smoothstep((t - start - lag) / dur) - _smoothstep((t - start - lag - dur - 6) / dur))
    yaw, off, dist = rng.uniform(-0.3, 0.3), rng.normal(scale=0.3, size=2), rng.uniform(1.0, 1.3)
    p1 = off + dist * np.array([np.cos(yaw), np.sin(yaw)])
    joints = np.stack([place(standing_skeleton(a0), off, yaw), place(standing_skeleton(a1), p1, yaw + np.pi)], axis=1)
    joints = joints + rng.normal(scale=0.005, size=joints.shape)
    sub = np.where(t < start, 0, np.where(t < start + dur + 6, 1, 2)).astype(np.int64)
    obj = None
    if label == "hand_over":
        w = _smoothstep((t - start - dur / 2) / dur)[:, None]
        hand = KINECT.index("right_hand")
        obj = (1 - w) * joints[:, 0, hand] + w * joints[:, 1, hand]
    return Interaction(
        label, 10.0, joints, KINECT.joint_names, actors, object=obj, subevents=sub,
        subevent_names=("approach", "act", "retreat"), instance_id=f"{label}_{idx:03d}",
    )


def toy_dataset(seed: int = 0, labels: Sequence[str] = ("shake_hands",), n_pairs: int = 4, per_pair: int = 3) -> Dataset:
    """``n_pairs`` actor pairs × ``per_pair`` instances per class."""
    rng = np.random.default_rng(seed)
    out = [
        toy_interaction(rng, label, (f"a{p}", f"b{p}"), p * per_pair + k)
        for label in labels for p in range(n_pairs) for k in range(per_pair)
    ]
    return Dataset("toy", tuple(out))


class HoldLastPose:
    """A trivial method: agent 1 keeps its last observed pose (plus rng noise, to test seeding)."""

    name = "hold"

    def fit(self, interactions: Sequence[Interaction], *, rng: np.random.Generator) -> HoldLastPose:
        self.n_train_ = len(interactions)
        return self

    def predict(self, interaction: Interaction, *, n_observed: int, rng: np.random.Generator) -> Prediction:
        joints = interaction.filled_joints()[:, 1].copy()
        joints[n_observed:] = joints[n_observed - 1] + rng.normal(scale=1e-3, size=(1,) + joints.shape[1:])
        return prediction_from_joints(interaction, joints, n_observed=n_observed, subevents=np.zeros(interaction.n_frames, dtype=np.int64))


@pytest.fixture
def hold_registered(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(METHODS, "hold", HoldLastPose)


# -- protocol ---------------------------------------------------------------------------------
def test_observed_part_hides_agent_one_after_the_prefix(rng: np.random.Generator) -> None:
    inst = toy_interaction(rng, "shake_hands", ("a", "b"), 0)
    seen = observed_part(inst, 10)
    assert np.isnan(seen.joints[10:, 1]).all() and not np.asarray(seen.valid)[10:, 1].any()
    np.testing.assert_array_equal(seen.joints[:, 0], inst.joints[:, 0])
    np.testing.assert_array_equal(seen.joints[:10, 1], inst.joints[:10, 1])
    assert seen.subevents is None
    with pytest.raises(ConfigError, match="n_observed"):
        observed_part(inst, inst.n_frames)
    assert isinstance(HoldLastPose(), ReactionMethod)


def test_registry_lists_methods_and_guards_names(hold_registered: None) -> None:
    with pytest.raises(ConfigError, match="available methods: .*'hmm'.*'promp'"):
        get_method("no_such_method")
    with pytest.raises(ConfigError, match="already registered"):
        register_method("hold", lambda: HoldLastPose())
    with pytest.raises(ConfigError, match="identifier"):
        register_method("Bad Name", HoldLastPose)
    register_method("hold", HoldLastPose)  # the same factory again is fine
    assert get_method("hold") is HoldLastPose


def test_prediction_validates_shapes() -> None:
    with pytest.raises(ModelError, match="key_joints"):
        Prediction(np.zeros((5, 25, 3)), np.zeros((4, 5, 3)), None, 2)
    with pytest.raises(ModelError, match="n_observed"):
        Prediction(np.zeros((5, 25, 3)), np.zeros((5, 5, 3)), None, 6)


# -- metrics ------------------------------------------------------------------------------------
def test_joint_errors_against_a_frame_by_frame_loop(rng: np.random.Generator) -> None:
    inst = toy_interaction(rng, "shake_hands", ("a", "b"), 0)
    valid = np.ones((inst.n_frames, 2, 25), dtype=bool)
    valid[12:15, 1, 3] = False
    inst = inst.replace(valid=valid)
    pred_joints = inst.joints[:, 1] + rng.normal(scale=0.05, size=inst.joints[:, 1].shape)
    pred = Prediction(pred_joints, pred_joints[:, list(KINECT.key_indices)], None, 10)
    dists = [np.linalg.norm(pred_joints[t, j] - inst.joints[t, 1, j]) for t in range(10, inst.n_frames) for j in range(25) if valid[t, 1, j]]
    np.testing.assert_allclose(joint_error(pred, inst), np.mean(dists), rtol=1e-12)
    keys = [np.linalg.norm(pred_joints[t, j] - inst.joints[t, 1, j]) for t in range(10, inst.n_frames) for j in KINECT.key_indices]
    np.testing.assert_allclose(key_joint_error(pred, inst), np.mean(keys), rtol=1e-12)
    bad = pred_joints.copy()
    bad[20, 0] = np.nan
    with pytest.raises(ModelError, match="frame 10, joint 0"):
        mean_joint_distance(bad[10:], inst.joints[10:, 1], np.ones((inst.n_frames - 10, 25), dtype=bool))


def test_parse_accuracy_after_optimal_matching_equals_brute_force(rng: np.random.Generator) -> None:
    truth = rng.integers(-1, 3, size=200)
    pred = rng.integers(-1, 4, size=200)
    conf = parse_confusion(pred, truth, 3)
    n_lab = int((truth >= 0).sum())
    best = max(
        sum(np.sum((truth == g) & (pred == p)) for g, p in enumerate(perm) if p is not None)
        for perm in itertools.permutations([0, 1, 2, 3, None], 3)
    )
    np.testing.assert_allclose(matched_accuracy(conf, n_lab), best / n_lab, rtol=1e-12)
    relabelled = np.where(truth >= 0, (truth + 1) % 3 + 5, -1)  # a permutation of other label ids
    np.testing.assert_allclose(matched_accuracy(parse_confusion(relabelled, truth, 3), n_lab), 1.0, rtol=0)


# -- cross-validation runner ----------------------------------------------------------------------
SCHEMA_METRICS = {"key_joint_error_m", "joint_error_m", "n_test", "key_joint_error_0.2s_m", "key_joint_error_0.5s_m",
                  "key_joint_error_1s_m"}


def _leaves(tree: object, prefix: str = "") -> list[tuple[str, float]]:
    """Numeric leaves of nested dicts/lists as (path, value), in order (strings hashed to numbers)."""
    if isinstance(tree, dict):
        return [leaf for k in sorted(tree) for leaf in _leaves(tree[k], f"{prefix}/{k}")]
    if isinstance(tree, list):
        return [leaf for i, v in enumerate(tree) for leaf in _leaves(v, f"{prefix}/{i}")]
    if isinstance(tree, str):
        return [(f"{prefix}={tree}", 0.0)]
    return [(prefix, float(tree))]  # type: ignore[arg-type]


def test_evaluation_schema_exclusion_and_executor_independence(hold_registered: None, tmp_path: Path) -> None:
    data = toy_dataset(seed=1, labels=("shake_hands", "hand_over"), per_pair=2)
    rng = np.random.default_rng(7)
    short = toy_interaction(rng, "hand_over", ("a0", "b0"), 99, n_frames=11)  # T <= T0 + 1: excluded
    data = Dataset("toy", data.interactions + (short,))
    serial = evaluate(data, ["hold", "promp"], config=EvaluationConfig(executor="serial", seed=5))
    pooled = evaluate(data, ["hold"], config=EvaluationConfig(executor="process", workers=2, seed=5))
    # Same numbers whatever the executor, up to the round-off (< 1 nm) of the parent's multi-threaded BLAS
    # (pool workers run single-threaded BLAS).
    for key in ("per_interaction", "average", "parse_accuracy", "per_instance", "excluded"):
        a = [leaf for leaf in _leaves(serial[key]) if "promp" not in leaf[0]]
        b = _leaves(pooled[key])
        assert [k for k, _ in a] == [k for k, _ in b], key
        np.testing.assert_allclose([v for _, v in a], [v for _, v in b], rtol=0, atol=1e-9)
    assert serial["excluded"] == {"hand_over": 1, "shake_hands": 0}
    assert {k for k in serial if k in ("dataset", "per_interaction", "average", "seconds")} == {"dataset", "per_interaction", "average", "seconds"}
    for label, row in serial["per_interaction"].items():
        for m, cell in row.items():
            assert set(cell) == SCHEMA_METRICS and cell["n_test"] == 8, (label, m)
    assert serial["horizons_s"] == [0.2, 0.5, 1.0] and set(serial["latency_ms"]) == {"hold", "promp"}
    lat = serial["latency_ms"]["promp"]
    assert 0 < lat["p50"] <= lat["p99"] <= lat["max"] and lat["n_calls"] == sum(
        i.n_frames - 10 for lab in ("shake_hands", "hand_over") for i in data.of_label(lab).interactions if i.n_frames > 11)
    ids = {d["instance_id"] for d in serial["per_instance"]["hand_over"]["hold"]}
    assert "hand_over_099" not in ids and len(ids) == 8
    for m in ("hold", "promp"):
        expected = np.mean([serial["per_interaction"][lab][m]["key_joint_error_m"] for lab in ("shake_hands", "hand_over")])
        np.testing.assert_allclose(serial["average"][m]["key_joint_error_m"], expected, rtol=1e-12)
    # ProMP uses the human's motion; holding the last pose cannot follow the arm.
    assert serial["average"]["promp"]["key_joint_error_m"] < serial["average"]["hold"]["key_joint_error_m"]
    assert "hold" in serial["parse_accuracy"]["shake_hands"]
    # Paired against hold and against the best baseline (here hold or promp); the difference is that of the averages.
    assert serial["protocol"] == "causal" and serial["split"] == "pair" and serial["preset"] == "default"
    assert serial["settings"]["protocol"] == "causal" and not serial["upper_bound"] and not serial["optimistic"]
    assert "causal protocol" in serial["title"] and "pair-disjoint" in serial["title"]
    best = min(("hold", "promp"), key=lambda m: serial["average"][m]["key_joint_error_m"])
    assert serial["paired"]["best_baseline"]["reference"] == best == "promp"
    paired = serial["paired"]["hold"]
    assert paired["reference"] == "hold" and pooled["paired"] == {}  # one method: nothing to pair
    for metric in ("key_joint_error_m", "joint_error_m"):
        cell = paired["differences"][metric]["promp"]
        np.testing.assert_allclose(cell["mean_m"], serial["average"]["promp"][metric] - serial["average"]["hold"][metric], rtol=1e-9)
        assert cell["low_m"] <= cell["mean_m"] <= cell["high_m"] and cell["n_instances"] == 16
    assert paired["differences"]["key_joint_error_m"]["promp"]["verdict"] == "lower"
    other_seed = evaluate(data, ["hold"], interactions=["shake_hands"], config=EvaluationConfig(executor="serial", seed=6))
    assert other_seed["per_interaction"]["shake_hands"]["hold"] != serial["per_interaction"]["shake_hands"]["hold"]

    paths = write_results(serial, tmp_path / "out")
    loaded = json.loads(paths["json"].read_text())
    assert loaded["per_interaction"] == serial["per_interaction"]
    table = paths["markdown"].read_text()
    assert "| hold |" in table and "| promp |" in table and "hand_over | shake_hands | Average" in table
    assert "## Paired differences to `hold` (`hold`)" in table and "| lower |" in table
    assert "## Paired differences to the best baseline (`promp`)" in table and "causal protocol" in table
    assert paths["chart"].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_errors_name_the_problem(hold_registered: None) -> None:
    data = toy_dataset(seed=2, n_pairs=3)
    with pytest.raises(ConfigError, match="--split pair: 4 pair-disjoint folds need at least 4 actor pairs"):
        evaluate(data, ["hold"], config=EvaluationConfig(executor="serial"))
    with pytest.raises(ConfigError, match="not in dataset"):
        evaluate(data, ["hold"], interactions=["wave"], config=EvaluationConfig(executor="serial", n_folds=3))
    with pytest.raises(ConfigError, match="executor"):
        EvaluationConfig(executor="threads")


def test_ray_missing_gives_install_hint(hold_registered: None, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)  # makes `import ray` fail
    data = toy_dataset(seed=2, n_pairs=2, per_pair=2)
    with pytest.raises(ConfigError, match=r"pip install socialaff-sim\[distributed\]"):
        evaluate(data, ["hold"], config=EvaluationConfig(executor="ray", n_folds=2))


@pytest.mark.slow  # starts a local Ray instance (~10 s)
def test_ray_local_instance_gives_the_same_results() -> None:
    pytest.importorskip("ray", reason="Ray is an optional extra (pip install socialaff-sim[distributed])")
    data = toy_dataset(seed=2, n_pairs=2, per_pair=2)
    serial = evaluate(data, ["promp"], config=EvaluationConfig(n_folds=2, seed=3, executor="serial"))
    ray_run = evaluate(data, ["promp"], config=EvaluationConfig(n_folds=2, seed=3, executor="ray", workers=1))
    a, b = _leaves(serial["per_instance"]), _leaves(ray_run["per_instance"])
    assert [k for k, _ in a] == [k for k, _ in b] and len(a) == 4 * 4
    np.testing.assert_allclose([v for _, v in a], [v for _, v in b], rtol=0, atol=1e-9)


def test_cli_writes_results(hold_registered: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from socialaff_sim.cli.main import main

    save_dataset(toy_dataset(seed=4, per_pair=2), tmp_path / "data")
    out = tmp_path / "eval"
    code = main([
        "evaluate", "--data", f"npz:{tmp_path / 'data'}", "--methods", "hold", "--folds", "2",
        "--out", str(out), "--executor", "serial", "--quiet",
    ])
    assert code == 0
    results = json.loads((out / "results.json").read_text())
    assert set(results["average"]) == {"hold"} and results["dataset"] == "npz"
    assert "| hold |" in capsys.readouterr().out
    assert main(["evaluate", "--data", f"npz:{tmp_path / 'data'}", "--methods", "nope", "--out", str(out)]) == 2
    assert "available methods" in capsys.readouterr().err
