"""Physics scoring on the real recordings: the ground truth and the synthesized agent 1, per robot (issue 25).

For each data set of ../shared (SBU: shaking_hands, exchanging_object, pushing; the handovers: hand_over; NuiSI:
handshake, high_five, fist_bump) the instances of a class are split into k folds exactly as ``socialaff-sim
evaluate`` splits them (:func:`socialaff_sim.evaluation.splits.make_folds` with ``fold_rng(seed, label)``; the
split ``evaluate``'s commands use for that data set, :data:`DATASETS`): SBU and the handovers ``pair``
(pair-disjoint; every handover recording is its own pair, so there it is also recording-disjoint), NuiSI
``block`` (each class is one recording of one pair: contiguous blocks of it, the same people in training and
test; optimistic). On each fold the affordance model is fitted on the training instances only, as ``socialaff-sim
fit`` does (the default preset's model and learner), with the generator of ``task_seed(seed, label, fold,
"full")``; it is cached in ``--models`` (one file per data set, class, fold and seed) so that a second robot or a
restarted run reuses it. Every test instance longer than T0 + 1 frames (``evaluate``'s rule) is then run through
:func:`socialaff_sim.sim.episode.run_episode` twice, with the same simulator:

* ``gt``: agent 1's recorded key joints (``GroundTruthSource``): the ceiling;
* ``synth``: the model's causal synthesis (``model_source(path, offline=False)``, as ``socialaff-sim simulate
  --source model`` runs it: agent 1's first T0 frames are the recording, the rest is synthesized; seed 0).

Physics: ``--physics harness`` (``SimConfig()``, the default) or ``standing`` (``SimConfig.standing()``).
One JSON row per episode (robot, physics, data set, label, instance, fold, source, success, outcome code and
time, sub-goals, failures, support figures, CPU and wall seconds). The JSON is rewritten after every instance
and a rerun with the same ``--json`` skips the episodes it holds (restartable); ``--datasets``, ``--labels``,
``--robots``, ``--offset``, ``--limit`` and ``--every`` cut a run into chunks; ``--completion FIELD=VALUE``
sets fields of the contact completion (``ContactCompletionConfig``) and ``--sim FIELD=VALUE`` the simulator's own
(``SimConfig``) for a development or rule run. ``--table A.json [B.json ...]``
prints the per data set × label × robot table (scripts/_realdata_table.py); ``--fit-only`` fits and caches the
models without running an episode (so that runs on two robots in parallel share them). Examples::

    OMP_NUM_THREADS=1 python scripts/bench_realdata.py --robots ours --json rd_ours.json
    OMP_NUM_THREADS=1 python scripts/bench_realdata.py --robots unitree_h1 \\
        --mjcf unitree_h1=../shared/robots/unitree_h1/h1.xml --datasets nuisi --json rd_h1.json
    python scripts/bench_realdata.py --table rd_ours.json rd_h1.json

The library never imports this script.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MUJOCO_GL", "egl")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _config_flags import field_settings  # noqa: E402
from _realdata_table import format_tables, table_rows  # noqa: E402

from socialaff_sim._atomic import atomic_write_text  # noqa: E402
from socialaff_sim.data.interaction import Interaction  # noqa: E402
from socialaff_sim.data.specs import load_dataset  # noqa: E402
from socialaff_sim.evaluation.crossval import fold_rng, task_seed  # noqa: E402
from socialaff_sim.evaluation.splits import make_folds, recording_of  # noqa: E402
from socialaff_sim.inference.presets import preset  # noqa: E402
from socialaff_sim.inference.protocol import DEFAULT_N_OBSERVED  # noqa: E402
from socialaff_sim.learning.estimator import SocialAffordanceModel  # noqa: E402
from socialaff_sim.retarget.contact_completion import ContactCompletionConfig  # noqa: E402
from socialaff_sim.retarget.model_source import model_source  # noqa: E402
from socialaff_sim.retarget.robot import load_robot  # noqa: E402
from socialaff_sim.retarget.sources import GroundTruthSource  # noqa: E402
from socialaff_sim.sim.episode import run_episode  # noqa: E402
from socialaff_sim.sim.simulator import SimConfig, Simulator  # noqa: E402
from socialaff_sim.sim.tasks import task_for_label  # noqa: E402

SHARED = Path(__file__).resolve().parents[1].parent / "shared"
DATASETS: dict[str, tuple[str, tuple[str, ...], str]] = {
    "sbu": ("sbu_kinect_interaction", ("shaking_hands", "exchanging_object", "pushing"), "pair"),
    "handover": ("handover_h2h", ("hand_over",), "pair"),
    "nuisi": ("nuisi_v1", ("handshake", "high_five", "fist_bump"), "block"),
}
"""Data set → (folder under ../shared/data, labels, the split ``evaluate``'s commands in docs/benchmarks.md use)."""
N_FOLDS = 4
"""k: folds per class, as ``evaluate``'s default."""
SOURCES = ("gt", "synth")
METHOD_STREAM = "full"
"""The method name in the fit's ``task_seed``: the stream ``evaluate`` gives its ``full`` method on that fold."""


def split_name(split: str, insts: list[Interaction]) -> str:
    """What the split holds apart, in words: ``pair-disjoint`` (plus ``= recording-disjoint`` when every
    recording has its own actor pair), ``actor-disjoint``, ``recording-disjoint`` or ``block (optimistic)``."""
    if split == "pair":
        pairs: dict[tuple[str, ...], set[str]] = {}
        for i in insts:
            pairs.setdefault(tuple(sorted(i.actors)), set()).add(recording_of(i))
        own = len(pairs) == len({recording_of(i) for i in insts}) and all(len(r) == 1 for r in pairs.values())
        return "pair-disjoint (= recording-disjoint: one recording per pair)" if own else "pair-disjoint"
    return {"actor": "actor-disjoint", "recording": "recording-disjoint",
            "block": "block (within one recording: optimistic)"}[split]


def fold_plan(insts: list[Interaction], split: str, label: str, seed: int,
              n_observed: int = DEFAULT_N_OBSERVED) -> list[tuple[int, list[int], list[int]]]:
    """(fold, training indices, test indices) of ``insts`` as ``evaluate`` builds them (``make_tasks``): the folds
    of ``make_folds(insts, N_FOLDS, split, rng=fold_rng(seed, label))``, test instances of at most T0 + 1 frames
    left out (they train)."""
    folds = make_folds(insts, N_FOLDS, split, rng=fold_rng(seed, label))
    return [(f, [int(i) for i in train], [int(i) for i in test if insts[i].n_frames > n_observed + 1])
            for f, (train, test) in enumerate(folds)]


def fitted_model(dataset: str, label: str, fold: int, train: list[Interaction], seed: int, cache: Path) -> tuple[Path, float | None]:
    """The model of one fold (cached): fitted as ``socialaff-sim fit`` does with the default preset; returns its
    path and the fit's CPU seconds (``None``: read from the cache)."""
    path = cache / f"{dataset}_{label}_fold{fold}_seed{seed}.npz"
    if path.exists():
        return path, None
    chosen = preset("default")
    tic = time.process_time()
    model = SocialAffordanceModel(chosen.affordance, chosen.learning).fit(
        train, rng=np.random.default_rng(task_seed(seed, label, fold, METHOD_STREAM)))
    cpu = time.process_time() - tic
    model.save(path)  # atomic
    return path, cpu


def episode_row(metrics: dict[str, Any]) -> dict[str, Any]:
    """The JSON fields of one episode's metrics (``summarize``)."""
    sup = metrics["support"]
    ep, cp = sup["episode"], sup["contact_phase"]
    return {
        "success": bool(metrics["success"]),
        "outcome": metrics.get("outcome"),
        "outcome_time": metrics.get("outcome_time"),
        "fell_at": metrics.get("fell_at"),
        "subgoals": {s["name"]: bool(s["achieved"]) for s in metrics["subgoals"]},
        "subgoal_time_s": {s["name"]: s["time"] for s in metrics["subgoals"]},
        "failures": [f["kind"] for f in metrics["failures"] if f["triggered"]],
        "max_force_on_human_n": float(metrics["contact_force_on_human_n"]["max"]),
        "support": {"mode": sup["mode"], "outside_support_mean": ep["outside_support_mean"],
                    "contact_outside_support_mean": cp["outside_support_mean"], "contact_frames": cp["frames"],
                    "foot_slide_cm": ep["foot_slide_cm"], "foot_slip_cm": ep["foot_slip_cm"],
                    "torso_tilt_deg_max": ep["torso_tilt_deg_max"]},
        "frames": int(metrics["frames"]),
        "simulated_seconds": float(metrics["simulated_seconds"]),
    }


def _key(row: dict[str, Any]) -> tuple:
    return (row["robot"], row["physics"], row["dataset"], row["label"], row["instance"], row["source"])


def _write(path: Path, doc: dict[str, Any]) -> None:
    atomic_write_text(path, json.dumps(doc, indent=1, sort_keys=False) + "\n")


def run(args: argparse.Namespace) -> int:
    out = Path(args.json)
    doc: dict[str, Any] = json.loads(out.read_text()) if out.exists() else {"rows": [], "folds": [], "runs": []}
    done = {_key(r): r for r in doc["rows"]}  # every episode row by its key (those in the file are skipped)
    cache = Path(args.models)
    cache.mkdir(parents=True, exist_ok=True)
    mjcf = dict(item.split("=", 1) for item in args.mjcf)
    config = SimConfig.mode(args.physics)
    if args.completion_fields and config.contact_completion is not None:
        config = dataclasses.replace(config, contact_completion=dataclasses.replace(
            config.contact_completion, **args.completion_fields))
    if args.sim_fields:
        config = dataclasses.replace(config, **args.sim_fields)
    run_info = {"argv": sys.argv[1:], "seed": args.seed, "physics": args.physics, "n_folds": N_FOLDS,
                "n_observed": DEFAULT_N_OBSERVED, "started": time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime())}
    tic_wall, tic_cpu = time.perf_counter(), time.process_time()
    for robot_name in args.robots:
        robot = load_robot(robot_name, mjcf=mjcf.get(robot_name))
        for dataset in args.datasets:
            folder, labels, split = DATASETS[dataset]
            data = load_dataset(f"{dataset}:{SHARED / 'data' / folder}")
            for label in labels:
                if args.labels and label not in args.labels:
                    continue
                insts = list(data.of_label(label).interactions)
                plan = fold_plan(insts, split, label, args.seed)
                named = split_name(split, insts)  # (the same for every episode of the class)
                order = [(f, i) for f, _, test in plan for i in test][args.offset::args.every]
                order = order[: args.limit] if args.limit is not None else order
                if args.fit_only:
                    order = [(f, test[0]) for f, _, test in plan if test]
                sim = Simulator(robot, task_for_label(label), config)
                models: dict[int, Path] = {}
                for f, i in order:
                    inter = insts[i]
                    keys = {s: (robot_name, args.physics, dataset, label, inter.instance_id, s) for s in SOURCES}
                    if all(k in done for k in keys.values()):
                        continue
                    if f not in models:
                        train = [insts[j] for j in plan[f][1]]
                        models[f], fit_cpu = fitted_model(dataset, label, f, train, args.seed, cache)
                        if fit_cpu is not None:
                            doc["folds"].append({"dataset": dataset, "label": label, "fold": f, "seed": args.seed,
                                                 "split": split, "train": len(train), "test": len(plan[f][2]),
                                                 "fit_cpu_seconds": fit_cpu, "model": str(models[f])})
                    if args.fit_only:
                        _write(out, doc)
                        continue
                    sources = {"gt": GroundTruthSource(), "synth": model_source(models[f], offline=False)}
                    for s, src in sources.items():
                        if keys[s] in done:
                            continue
                        w, c = time.perf_counter(), time.process_time()
                        metrics = run_episode(sim, src, inter)
                        row = {"robot": robot_name, "physics": args.physics, "dataset": dataset, "label": label,
                               "task": sim.task.interaction, "instance": inter.instance_id, "fold": f,
                               "split": named, "source": s, **episode_row(metrics),
                               "cpu_seconds": time.process_time() - c, "wall_seconds": time.perf_counter() - w}
                        doc["rows"].append(row)
                        done[keys[s]] = row
                    _write(out, doc)
                    if not args.quiet:
                        gt, sy = (done[keys[s]] for s in SOURCES)
                        print(f"{robot_name} {dataset}/{label} fold {f} {inter.instance_id}: gt {gt['outcome'] or gt['success']}"
                              f", synth {sy['outcome'] or sy['success']}", flush=True)
    run_info.update(wall_seconds=time.perf_counter() - tic_wall, cpu_seconds=time.process_time() - tic_cpu)
    doc["runs"].append(run_info)
    _write(out, doc)
    print(f"wrote {out}: {len(doc['rows'])} episode rows")
    return 0


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--robots", nargs="+", default=["ours"], help="robot mappings (default: ours)")
    p.add_argument("--mjcf", nargs="*", default=[], help="NAME=PATH: the MJCF of a robot the project does not ship")
    p.add_argument("--datasets", nargs="+", choices=tuple(DATASETS), default=list(DATASETS))
    p.add_argument("--labels", nargs="*", default=[], help="only these labels (default: each data set's)")
    p.add_argument("--physics", choices=("harness", "standing"), default="harness")
    p.add_argument("--seed", type=int, default=0, help="the run seed: folds and fits (default 0, as evaluate)")
    p.add_argument("--offset", type=int, default=0, help="skip the first K test instances of each class (fold order)")
    p.add_argument("--every", type=int, default=1, help="then take every k-th test instance (default 1: all)")
    p.add_argument("--limit", type=int, default=None, help="at most N test instances per class")
    p.add_argument("--models", default="/tmp/bench_realdata_models", help="folder of the fitted models (cache)")
    p.add_argument("--json", help="episode rows (read back: episodes already in it are skipped)")
    p.add_argument("--table", nargs="+", metavar="JSON", help="print the table of these JSONs instead of running")
    p.add_argument("--interval-seed", type=int, default=0, help="seed of the paired bootstrap (default 0)")
    p.add_argument("--fit-only", action="store_true", help="fit (and cache) every fold's model, run no episode")
    p.add_argument("--completion", nargs="*", default=[], metavar="FIELD=VALUE",
                   help="ContactCompletionConfig fields (Python literals), e.g. reach_carried=True")
    p.add_argument("--sim", nargs="*", default=[], metavar="FIELD=VALUE",
                   help="SimConfig's own fields (Python literals), e.g. trunk_vertices=True")
    p.add_argument("--quiet", action="store_true")
    args = p.parse_args(argv)
    args.completion_fields = field_settings(p, "--completion", ContactCompletionConfig, args.completion)
    args.sim_fields = field_settings(p, "--sim", SimConfig, args.sim)
    if args.table:
        rows = [r for path in args.table for r in json.loads(Path(path).read_text())["rows"]]
        print(format_tables(table_rows(rows, seed=args.interval_seed, pooled=True)))
        return 0
    if not args.json:
        p.error("--json is required to run episodes")
    if args.every < 1 or args.offset < 0 or (args.limit is not None and args.limit < 1):
        p.error("--every ≥ 1, --offset ≥ 0, --limit ≥ 1")
    return run(args)


if __name__ == "__main__":
    raise SystemExit(main())
