"""Benchmark the baselines (multi-level HMM, Interaction ProMP) under the paper's Experiment 1.

Runs the evaluation (4 pair-disjoint folds, T0 = 10) on

* the embedded synthetic dataset (all five interactions),
* the real SBU Kinect Interaction handshakes (``shaking_hands``),
* the real human-to-human handover recordings (``hand_over``),

with the methods ``hmm`` and ``promp`` plus a trivial reference, ``hold_last``
(agent 1 keeps its last observed pose), which shows how much of the error any
method removes. Real recordings are read from ../shared/data (or
$SOCIALAFF_SHARED_DATA) and skipped with a note when absent. Each dataset's
results (results.json / .md / .png) go to OUT/<dataset>/, and a summary of the
averages is printed together with the equivalent CLI commands.

Usage::

    python scripts/bench_baselines.py [--out bench_out/baselines] [--workers 2] [--seed 0]
        [--datasets synthetic sbu handover] [--json PATH]

``--json PATH`` also writes the summary (averages per dataset and method, wall
seconds, the equivalent CLI command, skipped datasets) to PATH, atomically.

A dataset whose recordings are not found (the real ones live beside the project,
in ../shared/data, or under $SOCIALAFF_SHARED_DATA) is skipped with a message.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from socialaff_sim._atomic import atomic_write_text
from socialaff_sim.data import Interaction, load_dataset
from socialaff_sim.evaluation import EvaluationConfig, Prediction, evaluate, prediction_from_joints, register_method, write_results

ROOT = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("SOCIALAFF_SHARED_DATA", ROOT.parent / "shared" / "data"))

DATASETS = {
    # name: (spec, interactions or None for all)
    "synthetic": ("synthetic:0", None),
    "sbu": (f"sbu:{SHARED / 'sbu_kinect_interaction'}", ["shaking_hands"]),
    "handover": (f"handover:{SHARED / 'handover_h2h'}", ["hand_over"]),
}


class HoldLast:
    """Reference: agent 1 keeps its last observed pose."""

    name = "hold_last"

    def fit(self, interactions: list[Interaction], *, rng: np.random.Generator) -> HoldLast:
        return self

    def predict(self, interaction: Interaction, *, n_observed: int, rng: np.random.Generator) -> Prediction:
        joints = interaction.filled_joints()[:, 1].copy()
        joints[n_observed:] = joints[n_observed - 1]
        return prediction_from_joints(interaction, joints, n_observed=n_observed)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="bench_out/baselines", help="output folder")
    parser.add_argument("--workers", type=int, default=2, help="process-pool workers")
    parser.add_argument("--seed", type=int, default=0, help="run seed")
    parser.add_argument("--datasets", nargs="+", choices=list(DATASETS), default=list(DATASETS))
    parser.add_argument("--json", default=None, help="also write the summary here (atomically)")
    args = parser.parse_args()

    register_method("hold_last", HoldLast)
    methods = ["hmm", "promp", "hold_last"]
    summary = []
    skipped: dict[str, str] = {}
    for name in args.datasets:
        spec, interactions = DATASETS[name]
        if not spec.startswith("synthetic") and not Path(spec.partition(":")[2]).exists():
            print(f"[{name}] skipped: recordings not found at {spec.partition(':')[2]}")
            skipped[name] = f"recordings not found at {spec.partition(':')[2]}"
            continue
        start = time.perf_counter()
        data = load_dataset(spec)
        config = EvaluationConfig(n_folds=4, seed=args.seed, executor="process", workers=args.workers)
        results = evaluate(data, methods, interactions=interactions, config=config,
                           progress=lambda msg, n=name: print(f"[{n}] {msg}", flush=True))
        out = Path(args.out) / name
        paths = write_results(results, out)
        wall = time.perf_counter() - start
        print(paths["markdown"].read_text())
        inter = " ".join(interactions) if interactions else ""
        cli = (f"socialaff-sim evaluate --data {spec}" + (f" --interactions {inter}" if inter else "")
               + f" --methods hmm,promp --folds 4 --seed {args.seed} --workers {args.workers} --out {out}")
        summary.append((name, results, wall, cli))

    print("\n# Summary: average key-joint / full-skeleton error (m), 4 pair-disjoint folds, T0 = 10\n")
    print("| dataset | " + " | ".join(methods) + " | wall s |")
    print("|---|" + "---:|" * (len(methods) + 1))
    for name, results, wall, _ in summary:
        cells = [
            f"{results['average'][m]['key_joint_error_m']:.3f} / {results['average'][m]['joint_error_m']:.3f}"
            for m in methods
        ]
        print(f"| {name} | " + " | ".join(cells) + f" | {wall:.0f} |")
    print("\nEquivalent CLI commands (without the hold_last reference):")
    for _, _, _, cli in summary:
        print("  " + cli)
    print(f"\nrun: {sys.executable} scripts/bench_baselines.py --out {args.out} --workers {args.workers} --seed {args.seed}")
    if args.json:
        result = {
            "seed": args.seed, "workers": args.workers, "n_folds": 4, "methods": methods, "skipped": skipped,
            "datasets": {
                name: {"spec": DATASETS[name][0], "interactions": DATASETS[name][1], "wall_s": wall, "cli": cli,
                       "average": {m: {k: results["average"][m][k] for k in ("key_joint_error_m", "joint_error_m")}
                                   for m in methods}}
                for name, results, wall, cli in summary
            },
        }
        atomic_write_text(args.json, json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
