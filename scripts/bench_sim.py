"""Benchmark the simulation loop: IK time, key-frame error, real-time factor and sub-goal success.

Replays the ground-truth agent-1 track of synthetic instances (no rendering) and
reports, per robot and interaction:

* IK CPU time per data frame (mean, p95), IK iterations per frame;
* key-frame IK error where the scaled target is reachable (fraction ≤ 2 cm, p95);
* loop real-time factor (simulated seconds / CPU seconds of the whole loop);
* sub-goal success rate and failure rate.

Times are CPU times (the IK's: of the calling thread, as reported by
:attr:`StepResult.ik_seconds`; the loop's: of this process), which is what "one
core" means on a machine shared with other jobs. Run with OMP_NUM_THREADS=1.
Example::

    python scripts/bench_sim.py --robots ours cmu --per-label 4
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim.episode import ERROR_OK
from socialaff_sim.sim.simulator import Simulator


def run(sim: Simulator, inter) -> dict:
    src = GroundTruthSource()
    src.reset(inter)
    cpu = time.process_time()
    sim.reset(inter)
    sim.settle(sim.retarget(src.targets(0).keys, frame=0))
    ik_cpu = []
    while not sim.done:
        f = src.targets(sim.frame + 1)
        res = sim.step(sim.retarget(f.keys, frame=sim.frame + 1), subevent=f.subevent)
        ik_cpu.append(res.ik_seconds)
    loop_cpu = time.process_time() - cpu
    err = np.array([r.ik_error for r in sim.results])
    reach = np.array([r.reachable for r in sim.results]) & inter.key_available()[None]
    sc = sim.scorer
    return {
        "ik_ms": np.array(ik_cpu) * 1e3,
        "iters": np.array([r.ik_iterations for r in sim.results]),
        "err_reach": err[reach],
        "rtf": sim.time / loop_cpu,
        "success": all(s.success for s in sc.subgoals),
        "subgoals": {s.name: s.success for s in sc.subgoals},
        "failed": sc.failed,
        "failures": [f.kind for f in sc.failures if f.triggered],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robots", nargs="+", default=["ours", "cmu"])
    ap.add_argument("--labels", nargs="+", default=None, help="interactions (default: all five)")
    ap.add_argument("--per-label", type=int, default=3, help="instances per interaction")
    ap.add_argument("--seed", type=int, default=0, help="synthetic dataset seed")
    ap.add_argument("--json", default=None, help="also write the summary here")
    args = ap.parse_args()
    ds = generate_dataset(seed=args.seed)
    labels = args.labels or list(ds.labels)
    summary = {}
    for robot in args.robots:
        for label in labels:
            sim = Simulator(robot, label)
            rows = [run(sim, inter) for inter in ds.of_label(label).interactions[: args.per_label]]
            ik = np.concatenate([r["ik_ms"] for r in rows])
            err = np.concatenate([r["err_reach"] for r in rows])
            key = f"{robot}/{label}"
            summary[key] = {
                "instances": len(rows),
                "ik_ms_mean": float(ik.mean()),
                "ik_ms_p95": float(np.percentile(ik, 95)),
                "ik_iterations_mean": float(np.concatenate([r["iters"] for r in rows]).mean()),
                "err_reachable_within_2cm": float((err <= ERROR_OK).mean()),
                "err_reachable_p95_m": float(np.percentile(err, 95)),
                "real_time_factor_min": float(min(r["rtf"] for r in rows)),
                "real_time_factor_mean": float(np.mean([r["rtf"] for r in rows])),
                "success_rate": float(np.mean([r["success"] for r in rows])),
                "failure_rate": float(np.mean([r["failed"] for r in rows])),
                "failures": sorted({f for r in rows for f in r["failures"]}),
            }
            s = summary[key]
            print(f"{key:24s} IK {s['ik_ms_mean']:.2f} ms (p95 {s['ik_ms_p95']:.2f}, {s['ik_iterations_mean']:.2f} it)  "
                  f"err≤2cm {100 * s['err_reachable_within_2cm']:.1f}% (p95 {100 * s['err_reachable_p95_m']:.1f} cm)  "
                  f"RTF {s['real_time_factor_mean']:.1f}x (min {s['real_time_factor_min']:.1f})  "
                  f"success {100 * s['success_rate']:.0f}%  failed {100 * s['failure_rate']:.0f}% {s['failures']}",
                  flush=True)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(summary, fh, indent=2)


if __name__ == "__main__":
    main()
