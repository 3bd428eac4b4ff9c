"""scripts/bench_realdata.py (physics scoring on the real recordings), its table (scripts/_realdata_table.py) and
the pushing roles' measure (scripts/pushing_roles.py).

Checked: the script's folds are ``evaluate``'s (same training and test instances, short test instances left out)
and disjoint as named; the table's counts by hand; the paired interval against the exact bootstrap distribution
(multinomial enumeration) and that it is paired; the pusher's decision both ways. The real-data checks skip
without ../shared.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import load_script, shared_path

from socialaff_sim.data.sbu import SBU_CLASSES
from socialaff_sim.data.specs import load_dataset
from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.evaluation.crossval import EvaluationConfig, make_tasks
from socialaff_sim.evaluation.splits import recording_of
from socialaff_sim.sim.tasks import task_for_label


@pytest.fixture(scope="module")
def bench():  # noqa: ANN201
    return load_script("bench_realdata")


@pytest.fixture(scope="module")
def table():  # noqa: ANN201
    return load_script("_realdata_table")


@pytest.fixture(scope="module")
def roles():  # noqa: ANN201
    return load_script("pushing_roles")


def _dummy_method() -> None:  # never called: make_tasks only records the factory
    raise AssertionError


@pytest.mark.parametrize("n_observed", [10, 60])
def test_folds_are_evaluates_and_pair_disjoint(bench, n_observed: int) -> None:  # noqa: ANN001
    data = generate_dataset(0)
    label = data.labels[0]
    insts = list(data.of_label(label).interactions)
    plan = bench.fold_plan(insts, "pair", label, seed=3, n_observed=n_observed)
    config = EvaluationConfig(split="pair", seed=3, n_folds=bench.N_FOLDS, n_observed=n_observed)
    tasks, _, _ = make_tasks(data, [("m", _dummy_method)], [label], config)
    ours = [(f, [insts[i].instance_id for i in tr], [insts[i].instance_id for i in te]) for f, tr, te in plan if te]
    theirs = [(t.fold, [i.instance_id for i in t.train], [i.instance_id for i in t.test]) for t in tasks]
    assert ours == theirs
    if n_observed == 60:  # some instances are too short to synthesize: they train but are not tested
        short = {i.instance_id for i in insts if i.n_frames <= 61}
        assert short and not short & {i for _, _, te in ours for i in te}
    for _, train, test in plan:
        pairs = {tuple(sorted(insts[i].actors)) for i in train}
        assert not pairs & {tuple(sorted(insts[i].actors)) for i in test}
    assert bench.split_name("pair", insts) == "pair-disjoint"  # the synthetic pairs recur across recordings


def test_real_folds_are_disjoint_as_named(bench) -> None:  # noqa: ANN001
    for dataset, (folder, labels, split) in bench.DATASETS.items():
        data = load_dataset(f"{dataset}:{shared_path(folder)}")
        for label in labels:
            insts = list(data.of_label(label).interactions)
            name = bench.split_name(split, insts)
            plan = bench.fold_plan(insts, split, label, seed=0)
            tested = [i for _, _, te in plan for i in te]
            assert len(tested) == len(set(tested))  # each instance is tested once at most
            for _, train, test in plan:
                assert not set(train) & set(test)
                if split == "pair":
                    assert not ({tuple(sorted(insts[i].actors)) for i in train}
                                & {tuple(sorted(insts[i].actors)) for i in test})
                if "recording-disjoint" in name:
                    assert not {recording_of(insts[i]) for i in train} & {recording_of(insts[i]) for i in test}
            expected = {"sbu": "pair-disjoint", "handover": "pair-disjoint (= recording-disjoint: one recording per pair)",
                        "nuisi": "block (within one recording: optimistic)"}[dataset]
            assert name == expected, (dataset, label)


def test_the_sbu_pushing_label_resolves_to_the_pushing_task() -> None:
    assert SBU_CLASSES["04"] == "pushing"
    task = task_for_label(SBU_CLASSES["04"])
    assert task.interaction == "pushing" and task.object is None
    (sg,) = task.subgoals
    assert (sg.kind, sg.robot, sg.human) == ("contact", "body", "body")  # role-free: either may push
    assert {f.kind for f in task.failures} == {"self_collision", "contact_force"}


def _exact_bootstrap_quantile(d: np.ndarray, q: float) -> float:
    """The q-quantile (smallest v with P(mean* ≤ v) ≥ q) of the bootstrap mean of d ∈ {−1, 0, 1}ⁿ, enumerated:
    the resample's counts of −1, 0 and 1 are multinomial with the sample's proportions."""
    n = d.size
    p = [np.mean(d == v) for v in (-1, 0, 1)]
    atoms: dict[float, float] = {}
    for a in range(n + 1):
        for c in range(n + 1 - a):
            b = n - a - c
            prob = math.factorial(n) / (math.factorial(a) * math.factorial(b) * math.factorial(c))
            prob *= p[0] ** a * p[1] ** b * p[2] ** c
            atoms[(c - a) / n] = atoms.get((c - a) / n, 0.0) + prob
    cdf = 0.0
    for v in sorted(atoms):
        cdf += atoms[v]
        if cdf >= q - 1e-12:
            return v
    return max(atoms)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_paired_interval_matches_the_exact_bootstrap(table, seed: int) -> None:  # noqa: ANN001
    rng = np.random.default_rng(100 + seed)
    gt = rng.random(17) < 0.8
    synth = rng.random(17) < 0.55
    gap, lo, hi = table.paired_gap(gt, synth, rng=np.random.default_rng(seed))
    d = synth.astype(float) - gt.astype(float)
    assert gap == pytest.approx(synth.mean() - gt.mean())
    # 10,000 resamples: the percentiles land between the exact quantiles a percent either side
    assert _exact_bootstrap_quantile(d, 0.015) <= lo <= _exact_bootstrap_quantile(d, 0.035)
    assert _exact_bootstrap_quantile(d, 0.965) <= hi <= _exact_bootstrap_quantile(d, 0.985)


def test_the_interval_is_paired(table) -> None:  # noqa: ANN001
    same = np.array([True] * 10 + [False] * 10)
    assert table.paired_gap(same, same, rng=np.random.default_rng(0)) == (0.0, 0.0, 0.0)
    swapped = ~same  # the same rate on other instances: an unpaired interval would not see the difference
    gap, lo, hi = table.paired_gap(same, swapped, rng=np.random.default_rng(0))
    assert gap == 0.0 and lo < -0.3 and hi > 0.3


def _row(inst: str, source: str, success: bool, outcome: str, label: str = "shaking_hands") -> dict:
    return {"robot": "ours", "physics": "harness", "dataset": "sbu", "label": label, "instance": inst, "fold": 0,
            "split": "pair-disjoint", "source": source, "success": success, "outcome": outcome}


def test_table_counts_by_hand(table) -> None:  # noqa: ANN001
    rows = [_row("a", "gt", True, "success"), _row("a", "synth", True, "success"),
            _row("b", "gt", True, "success"), _row("b", "synth", False, "no_contact"),
            _row("c", "gt", False, "contact_force"), _row("c", "synth", True, "success"),
            _row("d", "gt", False, "no_contact"), _row("d", "synth", False, "no_contact"),
            _row("e", "gt", True, "success"),  # no synthesized run: left out
            _row("a", "gt", False, "fell", label="pushing"), _row("a", "synth", False, "fell", label="pushing")]
    cells = table.table_rows(rows, seed=0)
    assert [(c["label"], c["n"], c["unpaired"]) for c in cells] == [("shaking_hands", 4, 1), ("pushing", 1, 0)]
    c = cells[0]
    assert (c["gt"], c["synth"], c["both"], c["lost"], c["gained"]) == (2, 2, 1, 1, 1)
    assert c["gap"] == 0.0
    assert c["gt_outcomes"] == {"success": 2, "contact_force": 1, "no_contact": 1}
    assert c["synth_outcomes"] == {"success": 2, "no_contact": 2}
    pooled = table.table_rows(rows, seed=0, pooled=True)
    assert pooled[:2] == cells
    (everything,) = pooled[2:]
    assert (everything["label"], everything["n"], everything["gt"], everything["synth"], everything["lost"]) == (
        "all", 5, 2, 2, 1)
    assert everything["synth_outcomes"] == {"success": 2, "no_contact": 2, "fell": 1}
    text = table.format_tables(cells)
    assert "| ours | harness | sbu | shaking_hands | pair-disjoint | 4 | 2/4 (50 %) | 2/4 (50 %) |" in text
    assert "contact_force 1, no_contact 1 | no_contact 2 |" in text and "1 instance(s) with only one source" in text


def _pair(hand_to_other: bool) -> object:
    """Two SBU skeletons 1 m apart; agent 0's right hand reaches agent 1's torso (or the other way round)."""
    from socialaff_sim.data.interaction import Interaction  # noqa: PLC0415
    from socialaff_sim.data.skeletons import get_layout  # noqa: PLC0415

    names = get_layout("sbu15").joint_names
    z = {"head": 1.7, "neck": 1.5, "torso": 1.2, "left_shoulder": 1.45, "left_elbow": 1.2, "left_hand": 0.95,
         "right_shoulder": 1.45, "right_elbow": 1.2, "right_hand": 0.95, "left_hip": 0.9, "left_knee": 0.5,
         "left_foot": 0.05, "right_hip": 0.9, "right_knee": 0.5, "right_foot": 0.05}
    body = np.array([[0.0, 0.2 if "left" in n else -0.2 if "right" in n else 0.0, z[n]] for n in names])
    joints = np.repeat(np.stack([body, body + [1.0, 0.0, 0.0]])[None], 12, axis=0)
    a, b = (0, 1) if hand_to_other else (1, 0)
    joints[6, a, names.index("right_hand")] = joints[6, b, names.index("torso")] + [0.03 * (b - a), 0.0, 0.0]
    return Interaction(label="pushing", fps=15.0, joints=joints, joint_names=names, actors=("s01", "s02"),
                       instance_id="s01s02_04_001")


def test_the_pusher_is_the_agent_whose_hand_reaches_the_others_trunk(roles) -> None:  # noqa: ANN001
    assert roles.pusher(_pair(True)) == "agent0"
    assert roles.pusher(_pair(False)) == "agent1"
    assert roles.hand_to_trunk(_pair(True), 0) == pytest.approx(0.03)
    assert roles.pusher(_pair(True), margin=2.0) == "ambiguous"


def test_sbu_pushing_roles_alternate(roles) -> None:  # noqa: ANN001
    insts = list(load_dataset(f"sbu:{shared_path('sbu_kinect_interaction')}").of_label("pushing").interactions)
    counts, sets = roles.roles(insts)
    assert (counts["agent0"], counts["agent1"], counts["ambiguous"]) == (14, 16, 3)  # docs/task_format.md
    two = [v for v in sets.values() if len(v) == 2 and "ambiguous" not in v]
    assert len(two) == 11 and all(v[0] != v[1] for v in two)


def test_an_episode_row_carries_the_metrics(bench) -> None:  # noqa: ANN001
    support = {"outside_support_mean": 0.2, "foot_slide_cm": 3.0, "foot_slip_cm": 1.0, "torso_tilt_deg_max": 7.0}
    metrics = {
        "success": False, "outcome": "contact_force", "outcome_time": 1.25, "fell_at": None, "frames": 30,
        "simulated_seconds": 2.0,
        "subgoals": [{"name": "hands_clasped", "achieved": True, "time": 0.8}],
        "failures": [{"kind": "self_collision", "triggered": False}, {"kind": "contact_force", "triggered": True}],
        "contact_force_on_human_n": {"max": 312.5},
        "support": {"mode": "harness", "episode": support, "contact_phase": {"frames": 4, "outside_support_mean": 0.3}},
    }
    row = bench.episode_row(metrics)
    assert (row["success"], row["outcome"], row["outcome_time"]) == (False, "contact_force", 1.25)
    assert row["failures"] == ["contact_force"]  # only what triggered
    assert row["subgoals"] == {"hands_clasped": True} and row["subgoal_time_s"] == {"hands_clasped": 0.8}
    assert row["support"]["contact_outside_support_mean"] == 0.3 and row["support"]["outside_support_mean"] == 0.2
    assert row["max_force_on_human_n"] == 312.5


def test_sim_flag_names_simconfig_fields_only(bench, capsys: pytest.CaptureFixture[str]) -> None:  # noqa: ANN001
    """``--sim FIELD=VALUE`` sets ``SimConfig``'s own fields: one that is not a field exits 2 naming the flag."""
    with pytest.raises(SystemExit) as err:
        bench.main(["--sim", "no_such_field=True", "--json", "unused.json"])
    assert err.value.code == 2 and "--sim" in capsys.readouterr().err
    with pytest.raises(SystemExit) as err:  # a ContactCompletionConfig field is not a SimConfig one
        bench.main(["--sim", "reach_carried=True", "--json", "unused.json"])
    assert err.value.code == 2
