"""Benchmark the simulation loop: IK time, key-frame error, real-time factor and sub-goal success.

Replays the ground-truth agent-1 track of synthetic instances (no rendering),
whole sequences, and reports per robot and interaction:

* IK CPU time per data frame (mean, p95) and QP steps per frame;
* key-frame IK error where the target is reachable (the criterion of
  ``socialaff_sim.sim.reach``): fraction within 2 cm, p95 and max; the fraction of
  targets judged reachable; the p95 error over all targets for comparison;
* loop real-time factor: simulated seconds / CPU seconds of reset, settle and all
  steps of an instance (the scene of a skeleton layout is compiled once per
  simulator, before the first instance, and not counted);
* sub-goal success (every sub-goal met and no failure condition triggered), and
  the failure conditions seen.

Times are CPU times (the IK's: of the calling thread, as reported by
``StepResult.ik_seconds``; the loop's: of this process), which is what "one core"
means on a machine shared with other jobs. Run with OMP_NUM_THREADS=1. Example::

    OMP_NUM_THREADS=1 python scripts/bench_sim.py --robots ours cmu            # all 24 instances per interaction
    OMP_NUM_THREADS=1 python scripts/bench_sim.py --robots ours --per-label 4 --json out.json
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from socialaff_sim._atomic import atomic_write_text
from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim.episode import ERROR_OK
from socialaff_sim.sim.simulator import SimConfig, Simulator


def run(sim: Simulator, inter) -> dict:
    src = GroundTruthSource()
    src.reset(inter)
    cpu = time.process_time()
    sim.reset(inter)
    sim.settle(sim.retarget(src.targets(0).keys, frame=0))
    while not sim.done:
        f = src.targets(sim.frame + 1)
        sim.step(sim.retarget(f.keys, frame=sim.frame + 1), subevent=f.subevent)
    loop_cpu = time.process_time() - cpu
    err = np.array([r.ik_error for r in sim.results])
    avail = np.broadcast_to(inter.key_available(), err.shape)
    reach = np.array([r.reachable for r in sim.results]) & avail
    sc = sim.scorer
    return {
        "ik_ms": np.array([r.ik_seconds for r in sim.results]) * 1e3,
        "iters": np.array([r.ik_iterations for r in sim.results]),
        "err_reach": err[reach],
        "err_all": err[avail],
        "reach_fraction": float(reach.sum() / max(avail.sum(), 1)),
        "rtf": sim.time / loop_cpu,
        "success": all(s.success for s in sc.subgoals) and not sc.failed,
        "failures": [f.kind for f in sc.failures if f.triggered],
        "unmet": [s.name for s in sc.subgoals if not s.success],
    }


def summarize(rows: list[dict]) -> dict:
    ik = np.concatenate([r["ik_ms"] for r in rows])
    err = np.concatenate([r["err_reach"] for r in rows])
    err_all = np.concatenate([r["err_all"] for r in rows])
    return {
        "instances": len(rows),
        "frames": int(ik.size),
        "ik_ms_mean": float(ik.mean()),
        "ik_ms_p95": float(np.percentile(ik, 95)),
        "ik_iterations_mean": float(np.concatenate([r["iters"] for r in rows]).mean()),
        "reachable_fraction": float(np.mean([r["reach_fraction"] for r in rows])),
        "reachable_targets": int(err.size),
        "reachable_misses": int((err > ERROR_OK).sum()),
        "err_reachable_within_2cm": float((err <= ERROR_OK).mean()),
        "err_reachable_p95_m": float(np.percentile(err, 95)),
        "err_reachable_max_m": float(err.max()),
        "err_all_p95_m": float(np.percentile(err_all, 95)),
        "real_time_factor_mean": float(np.mean([r["rtf"] for r in rows])),
        "real_time_factor_min": float(min(r["rtf"] for r in rows)),
        "success_rate": float(np.mean([r["success"] for r in rows])),
        "successes": int(sum(r["success"] for r in rows)),
        "failures": {k: int(sum(k in r["failures"] for r in rows)) for k in sorted({f for r in rows for f in r["failures"]})},
        "unmet_subgoals": int(sum(bool(r["unmet"]) for r in rows)),
    }


def line(key: str, s: dict) -> str:
    return (f"{key:24s} IK {s['ik_ms_mean']:.2f} ms (p95 {s['ik_ms_p95']:.2f}, {s['ik_iterations_mean']:.2f} it)  "
            f"reachable {100 * s['reachable_fraction']:.0f}%: ≤2cm {100 * s['err_reachable_within_2cm']:.2f}% "
            f"({s['reachable_misses']} of {s['reachable_targets']} off; p95 {100 * s['err_reachable_p95_m']:.1f} cm, "
            f"max {100 * s['err_reachable_max_m']:.1f} cm; all p95 {100 * s['err_all_p95_m']:.1f} cm)  "
            f"RTF {s['real_time_factor_mean']:.1f}x (min {s['real_time_factor_min']:.1f})  "
            f"success {100 * s['success_rate']:.0f}% ({s['successes']}/{s['instances']})  "
            f"unmet {s['unmet_subgoals']} failures {s['failures']}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robots", nargs="+", default=["ours", "cmu"])
    ap.add_argument("--labels", nargs="+", default=None, help="interactions (default: all five)")
    ap.add_argument("--per-label", type=int, default=None, help="instances per interaction (default: all)")
    ap.add_argument("--seed", type=int, default=0, help="synthetic dataset seed")
    ap.add_argument("--json", default=None, help="also write the summary here")
    args = ap.parse_args()
    ds = generate_dataset(seed=args.seed)
    labels = args.labels or list(ds.labels)
    summary: dict[str, dict] = {}
    for robot in args.robots:
        every: list[dict] = []
        for label in labels:
            instances = ds.of_label(label).interactions[: args.per_label]
            sim = Simulator(robot, label, SimConfig.harness())
            sim.reset(instances[0])  # compiles the scene of this layout: set-up, not part of the loop
            rows = [run(sim, inter) for inter in instances]
            every += rows
            summary[f"{robot}/{label}"] = s = summarize(rows)
            print(line(f"{robot}/{label}", s), flush=True)
        summary[f"{robot}/all"] = s = summarize(every)
        print(line(f"{robot}/all", s), flush=True)
    if args.json:
        atomic_write_text(args.json, json.dumps(summary, indent=2))


if __name__ == "__main__":
    main()
