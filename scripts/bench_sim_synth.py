"""Sub-goal success of synthesized motion against the ground-truth replay, in physics (issue 5).

The whole loop, per synthetic interaction: the instances are split into pair-disjoint
folds (``socialaff_sim.data.dataset.actor_disjoint_folds``, the fold generator of
``socialaff-sim evaluate``); on each fold an affordance model is fitted on the training
instances (Algorithm 1), saved to a temporary file and wired in as the simulator's
key-joint source exactly as ``socialaff-sim simulate --source model`` does
(``socialaff_sim.retarget.model_source.model_source``). Every test instance is then run
through ``socialaff_sim.sim.episode.run_episode`` twice, with the same simulator:

* ``gt``: agent 1's recorded key joints (``GroundTruthSource``), the reference;
* ``synth``: the synthesis of agent 1's five key joints from the observed human
  (agent 1's first T0 frames are the recording, the rest is synthesized causally, or with
  ``--synthesis offline`` after reading the human's whole recording, as the evaluation does).

Each run goes observed human → key joints → human-to-robot scaling → mink IK → MuJoCo
physics → sub-goal scoring. Per instance: success (every sub-goal met and no failure
condition triggered), each sub-goal, the failure conditions triggered, the key-frame IK
error on targets judged reachable, and for ``synth`` the distance of the synthesized key
joints from the recorded ones (frames ≥ T0). Reported per interaction and overall: both
success rates, their ratio synthesized / ground truth (target ≥ 0.90), per-sub-goal rates
and the commonest failures.

Run with OMP_NUM_THREADS=1 (set here unless given). Examples::

    OMP_NUM_THREADS=1 python scripts/bench_sim_synth.py --json out.json                   # 4 folds, 100 iterations
    OMP_NUM_THREADS=1 python scripts/bench_sim_synth.py --iterations 30 --quick           # first fold only
    OMP_NUM_THREADS=1 python scripts/bench_sim_synth.py --interactions shake_hands --max-train 3 \\
        --max-test 1 --iterations 1 --quick --json tiny.json                              # a smoke run
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
import zlib
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")
if not os.environ.get("DISPLAY"):
    os.environ.setdefault("MUJOCO_GL", "egl")  # no rendering here, but dm_control picks a backend on import

import numpy as np  # noqa: E402

from socialaff_sim._atomic import atomic_write_text  # noqa: E402
from socialaff_sim.data.dataset import actor_disjoint_folds  # noqa: E402
from socialaff_sim.data.interaction import Interaction  # noqa: E402
from socialaff_sim.data.synthetic import generate_dataset  # noqa: E402
from socialaff_sim.evaluation.crossval import fold_rng  # noqa: E402
from socialaff_sim.inference import SynthesisConfig  # noqa: E402
from socialaff_sim.learning.config import LearningConfig  # noqa: E402
from socialaff_sim.learning import SocialAffordanceModel  # noqa: E402
from socialaff_sim.retarget.model_source import model_source  # noqa: E402
from socialaff_sim.retarget.sources import GroundTruthSource, KeyJointSource, SourceFrame  # noqa: E402
from socialaff_sim.sim.episode import ERROR_OK, run_episode  # noqa: E402
from socialaff_sim.sim.simulator import SimConfig, Simulator  # noqa: E402

TARGET_RATIO = 0.90
"""Issue 5: synthesized sub-goal success ≥ 90 % of the ground-truth replay's."""
SOURCES = ("gt", "synth")


class RecordingSource:
    """Passes another source's frames through and keeps the key joints it proposed, (T, 5, 3) data frame."""

    def __init__(self, inner: KeyJointSource) -> None:
        self.inner = inner
        self.keys: list[np.ndarray] = []

    @property
    def placement_frames(self) -> int | None:
        """The inner source's (see ``Simulator.reset``): a causal source places the robot from T0 frames."""
        return getattr(self.inner, "placement_frames", None)

    def reset(self, interaction: Interaction) -> None:
        self.inner.reset(interaction)
        self.keys = []

    def targets(self, t: int) -> SourceFrame:
        frame = self.inner.targets(t)
        if t != len(self.keys):
            raise RuntimeError(f"frames requested out of order: {t} after {len(self.keys)}")
        self.keys.append(np.asarray(frame.keys, dtype=np.float64).copy())
        return frame


def episode(sim: Simulator, source: KeyJointSource, inter: Interaction) -> tuple[dict[str, Any], np.ndarray]:
    """Run one instance; returns its record and the key-frame IK errors (m) on reachable targets."""
    rec = RecordingSource(source)
    tic = time.perf_counter()
    metrics = run_episode(sim, rec, inter)
    wall = time.perf_counter() - tic
    err = np.array([r.ik_error for r in sim.results]).reshape(-1, 5)
    reach = np.array([r.reachable for r in sim.results], dtype=bool).reshape(-1, 5)
    avail = np.broadcast_to(inter.key_available(), err.shape)
    ok = err[reach & avail]
    row = {
        "success": bool(metrics["success"]),
        "subgoals": {s["name"]: bool(s["success"]) for s in metrics["subgoals"]},
        "subgoal_time_s": {s["name"]: s["time"] for s in metrics["subgoals"]},
        "contact_seconds": {s["name"]: float(s["contact_seconds"]) for s in metrics["subgoals"]},
        "failures": [f["kind"] for f in metrics["failures"] if f["triggered"]],
        "ik_reachable_targets": int(ok.size),
        "ik_reachable_hits_2cm": int((ok <= ERROR_OK).sum()),
        "ik_reachable_fraction": float((reach & avail).sum() / max(int(avail.sum()), 1)),
        "ik_error_reachable_p95_m": float(np.percentile(ok, 95)) if ok.size else None,
        "max_force_on_human_n": float(metrics["contact_force_on_human_n"]["max"]),
        "wall_seconds": wall,
    }
    return row, (ok, np.stack(rec.keys))


def synth_key_error(keys: np.ndarray, inter: Interaction, n_observed: int) -> float | None:
    """Mean distance (m) of proposed key joints (T, 5, 3) from agent 1's recorded ones, frames ≥ T0."""
    truth = inter.key_joints()[:, 1]
    d = np.linalg.norm(keys[n_observed:] - truth[n_observed:], axis=-1)
    d = d[np.isfinite(d)]
    return float(d.mean()) if d.size else None


def run_fold(label: str, fold: int, train: list[Interaction], test: list[Interaction], opts: dict[str, Any]) -> dict:
    """Fit on ``train``, then run every test instance with both sources; returns the fold's rows."""
    rng = np.random.default_rng([opts["seed"], zlib.crc32(label.encode()), fold])
    tic_wall, tic_cpu = time.perf_counter(), time.process_time()
    model = SocialAffordanceModel(learning=LearningConfig(iterations=opts["iterations"])).fit(train, rng=rng)
    fit_wall, fit_cpu = time.perf_counter() - tic_wall, time.process_time() - tic_cpu
    n_obs = SynthesisConfig().n_observed  # what model_source's synthesizer uses
    sim = Simulator(opts["robot"], label, SimConfig.harness())
    rows, errors = [], {s: [] for s in SOURCES}
    with tempfile.TemporaryDirectory(prefix="bench_sim_synth_") as tmp:
        path = model.save(Path(tmp) / f"{label}_fold{fold}.npz")
        if opts["save_models"]:
            model.save(Path(opts["save_models"]) / f"{label}_fold{fold}.npz")
        sources = {"gt": GroundTruthSource(), "synth": model_source(path, offline=opts["synthesis"] == "offline")}
        tic = time.perf_counter()
        for inter in test:
            row: dict[str, Any] = {"instance": inter.instance_id, "interaction": label, "fold": fold,
                                   "actors": list(inter.actors), "frames": inter.n_frames}
            for name, src in sources.items():
                row[name], (ok, keys) = episode(sim, src, inter)
                errors[name].append(ok)
                if name == "synth":
                    row[name]["key_joint_error_m"] = synth_key_error(keys, inter, n_obs)
            rows.append(row)
        sim_wall = time.perf_counter() - tic
    info = {"interaction": label, "fold": fold, "train": len(train), "test": len(test),
            "train_actor_pairs": sorted({"+".join(sorted(i.actors)) for i in train}),
            "test_actor_pairs": sorted({"+".join(sorted(i.actors)) for i in test}),
            "fit_wall_seconds": fit_wall, "fit_cpu_seconds": fit_cpu, "simulate_wall_seconds": sim_wall,
            "subevents": int(model.n_subevents_)}
    print(f"  {label} fold {fold}: fit on {len(train)} in {fit_wall:.1f} s, simulated {len(test)} × 2 in {sim_wall:.1f} s; "
          f"success gt {sum(r['gt']['success'] for r in rows)}/{len(rows)}, "
          f"synth {sum(r['synth']['success'] for r in rows)}/{len(rows)}", flush=True)
    return {"info": info, "rows": rows, "errors": {k: np.concatenate(v) if v else np.zeros(0) for k, v in errors.items()}}


def _rate(xs: list[bool]) -> float | None:
    return float(np.mean(xs)) if xs else None


def summarize(rows: list[dict], errors: dict[str, list[np.ndarray]], prefix_subgoals: bool = False) -> dict:
    """Success rates, their ratio, per-sub-goal rates, failure counts and IK error of a set of rows."""
    def key(row: dict, name: str) -> str:
        return f"{row['interaction']}/{name}" if prefix_subgoals else name

    out: dict[str, Any] = {"instances": len(rows)}
    for s in SOURCES:
        ok = [r[s]["success"] for r in rows]
        sub: dict[str, list[bool]] = {}
        for r in rows:
            for name, met in r[s]["subgoals"].items():
                sub.setdefault(key(r, name), []).append(met)
        fails = Counter(k for r in rows for k in set(r[s]["failures"]))
        unmet = Counter(f"unmet:{key(r, n)}" for r in rows for n, met in r[s]["subgoals"].items() if not met)
        err = np.concatenate(errors[s]) if errors[s] else np.zeros(0)
        out[s] = {
            "successes": int(sum(ok)),
            "success_rate": _rate(ok),
            "subgoal_rates": {k: _rate(v) for k, v in sorted(sub.items())},
            "failures": dict(sorted(fails.items(), key=lambda kv: (-kv[1], kv[0]))),
            "unmet_subgoals": dict(sorted(unmet.items(), key=lambda kv: (-kv[1], kv[0]))),
            "commonest_failures": [k for k, _ in (fails + unmet).most_common(3)],
            "ik_reachable_targets": int(err.size),
            "ik_reachable_within_2cm": float((err <= ERROR_OK).mean()) if err.size else None,
            "ik_error_reachable_p95_m": float(np.percentile(err, 95)) if err.size else None,
        }
    ke = [r["synth"]["key_joint_error_m"] for r in rows if r["synth"]["key_joint_error_m"] is not None]
    out["synth"]["key_joint_error_m"] = float(np.mean(ke)) if ke else None
    gt, syn = out["gt"]["success_rate"], out["synth"]["success_rate"]
    out["ratio"] = None if not gt else syn / gt
    out["target_ratio"] = TARGET_RATIO
    out["target_met"] = None if out["ratio"] is None else bool(out["ratio"] >= TARGET_RATIO)
    out["both_succeeded"] = int(sum(r["gt"]["success"] and r["synth"]["success"] for r in rows))
    out["only_gt_succeeded"] = int(sum(r["gt"]["success"] and not r["synth"]["success"] for r in rows))
    out["only_synth_succeeded"] = int(sum(r["synth"]["success"] and not r["gt"]["success"] for r in rows))
    return out


def _pct(x: float | None) -> str:
    return "n/a" if x is None else f"{100 * x:.0f}%"


def print_table(summary: dict[str, dict]) -> None:
    print("\n| interaction | n | GT success | synth success | ratio synth/GT (≥ 0.90) | sub-goals GT → synth "
          "| IK ≤ 2 cm GT / synth | synth key err m | commonest synth failures |")
    print("|---|---|---|---|---|---|---|---|---|")
    for key, s in summary.items():
        gt, sy = s["gt"], s["synth"]
        ratio = "n/a" if s["ratio"] is None else f"{s['ratio']:.2f} ({'met' if s['target_met'] else 'missed'})"
        subs = "; ".join(f"{n} {_pct(gt['subgoal_rates'][n])} → {_pct(sy['subgoal_rates'].get(n))}"
                         for n in gt["subgoal_rates"])
        ke = sy["key_joint_error_m"]
        fails = ", ".join(f"{k} ×{(sy['failures'] | sy['unmet_subgoals'])[k]}" for k in sy["commonest_failures"]) or "—"
        print(f"| {key} | {s['instances']} | {_pct(gt['success_rate'])} ({gt['successes']}) "
              f"| {_pct(sy['success_rate'])} ({sy['successes']}) | {ratio} | {subs} "
              f"| {_pct(gt['ik_reachable_within_2cm'])} / {_pct(sy['ik_reachable_within_2cm'])} "
              f"| {'n/a' if ke is None else f'{ke:.3f}'} | {fails} |")


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--interactions", nargs="+", default=None, help="interaction labels (default: all five)")
    ap.add_argument("--folds", type=int, default=4, help="pair-disjoint folds per interaction (default 4)")
    ap.add_argument("--run-folds", type=int, default=None, metavar="K",
                    help="run only the first K of those folds (default: all)")
    ap.add_argument("--quick", action="store_true", help="run only the first fold (same as --run-folds 1)")
    ap.add_argument("--iterations", type=int, default=100, help="outer MCMC iterations of Algorithm 1 (default 100)")
    ap.add_argument("--synthesis", choices=("online", "offline"), default="online",
                    help="online (default): causal synthesis; offline: reads the human's whole recording first")
    ap.add_argument("--robot", default="ours", help="robot: ours or cmu (default ours)")
    ap.add_argument("--seed", type=int, default=0, help="dataset, split and fitting seed (default 0)")
    ap.add_argument("--max-train", type=int, default=None, help="at most this many training instances per fold")
    ap.add_argument("--max-test", type=int, default=None, help="at most this many test instances per fold")
    ap.add_argument("--workers", type=int, default=1, help="processes over (interaction, fold) pairs (default 1)")
    ap.add_argument("--save-models", default=None, metavar="DIR", help="also keep the fitted models here")
    ap.add_argument("--json", default=None, help="also write the results here (atomically)")
    return ap.parse_args(argv)


def main(argv: list[str] | None = None) -> dict:
    args = parse_args(argv)
    if args.folds < 2:
        sys.exit(f"--folds: expected at least 2 (use --quick or --run-folds 1 to run one fold), found {args.folds}")
    run_folds = 1 if args.quick else (args.run_folds or args.folds)
    if not 1 <= run_folds <= args.folds:
        sys.exit(f"--run-folds: expected 1..{args.folds}, found {run_folds}")
    if args.save_models:
        Path(args.save_models).mkdir(parents=True, exist_ok=True)
    start_wall, start_cpu = time.perf_counter(), time.process_time()
    data = generate_dataset(args.seed)
    labels = args.interactions or list(data.labels)
    unknown = [lb for lb in labels if lb not in data.labels]
    if unknown:
        sys.exit(f"--interactions: unknown {unknown}; valid: {list(data.labels)}")
    n_obs = SynthesisConfig().n_observed
    opts = {"seed": args.seed, "iterations": args.iterations, "robot": args.robot, "save_models": args.save_models,
            "synthesis": args.synthesis}
    tasks, excluded = [], {}
    for label in labels:
        insts = data.of_label(label).interactions
        folds = actor_disjoint_folds(insts, args.folds, rng=fold_rng(args.seed, label))
        excluded[label] = [insts[i].instance_id for f in folds[:run_folds] for i in f[1] if insts[i].n_frames <= n_obs + 1]
        for f, (train, test) in enumerate(folds[:run_folds]):
            tr = [insts[i] for i in train][: args.max_train]
            te = [insts[i] for i in test if insts[i].n_frames > n_obs + 1][: args.max_test]
            if te:
                tasks.append((label, f, tr, te, opts))
    print(f"{len(tasks)} (interaction, fold) runs: {args.folds}-fold pair-disjoint split, {run_folds} fold(s) run, "
          f"{args.iterations} MCMC iterations, robot {args.robot}, seed {args.seed}", flush=True)
    if args.workers > 1:
        with ProcessPoolExecutor(max_workers=args.workers) as pool:
            results = list(pool.map(run_fold, *zip(*tasks)))
    else:
        results = [run_fold(*t) for t in tasks]

    summary: dict[str, dict] = {}
    every: list[dict] = []
    every_err: dict[str, list[np.ndarray]] = {s: [] for s in SOURCES}
    for label in labels:
        mine = [r for r in results if r["info"]["interaction"] == label]
        rows = [row for r in mine for row in r["rows"]]
        if not rows:
            continue
        err = {s: [r["errors"][s] for r in mine] for s in SOURCES}
        summary[label] = summarize(rows, err)
        every += rows
        for s in SOURCES:
            every_err[s] += err[s]
    summary["all"] = summarize(every, every_err, prefix_subgoals=True)
    wall, cpu = time.perf_counter() - start_wall, time.process_time() - start_cpu
    print_table(summary)
    print(f"\n{len(every)} test instances; {wall:.0f} s wall, {cpu:.0f} s CPU in the main process "
          f"({args.workers} worker(s))", flush=True)
    result = {
        "settings": {"seed": args.seed, "folds": args.folds, "folds_run": run_folds, "iterations": args.iterations,
                     "robot": args.robot, "synthesis": args.synthesis, "interactions": labels, "max_train": args.max_train, "max_test": args.max_test,
                     "n_observed": n_obs, "workers": args.workers, "target_ratio": TARGET_RATIO,
                     "omp_num_threads": os.environ.get("OMP_NUM_THREADS")},
        "summary": summary,
        "folds": [r["info"] for r in results],
        "excluded_too_short": excluded,
        "instances": every,
        "wall_seconds": wall,
    }
    if args.json:
        atomic_write_text(args.json, json.dumps(result, indent=2) + "\n")
    return result


if __name__ == "__main__":
    main()
