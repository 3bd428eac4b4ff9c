"""Bitwise check of the full model's predictions between two code trees (issues 23 and 24, the speed work).

``run`` fits each method of each case on a subset of fold 1's training instances (the evaluation's own folds,
seed, task generator and protocol driver, :func:`socialaff_sim.evaluation.crossval.run_task`'s steps, horizon
forecasts included) and saves agent 1's predicted skeletons, key joints, sub-events and forecasts to one .npz,
with the CPU seconds of every (case, method). ``compare`` checks two such files with ``np.array_equal``
(NaN equal to NaN) and prints the largest difference where they differ. Usage::

    PYTHONPATH=/path/to/reference python scripts/check_bitwise.py run --out ref.npz [--set quick|extra|full|bench]
    PYTHONPATH=/path/to/candidate python scripts/check_bitwise.py run --out new.npz [--set quick|extra|full|bench]

``quick``: the synthetic handshakes, the SBU handshakes and the handovers under the default preset and the
causal protocol; ``extra``: the paper preset and the paper and offline protocols; ``bench``: ``full`` on 30
training and 3 test handovers of fold 1 (the CPU figure of docs/benchmarks.md).
    python scripts/check_bitwise.py compare ref.npz new.npz

The library never imports this script.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np

from socialaff_sim.data import load_dataset
from socialaff_sim.evaluation.crossval import EvaluationConfig, make_method, make_tasks, task_seed
from socialaff_sim.evaluation.registry import METHODS
from socialaff_sim.evaluation.streaming import PAPER_DELTA_T, run_protocol_measured

_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


@dataclasses.dataclass(frozen=True)
class Case:
    """One dataset class, fold 1, a training subset and a few test instances, under one preset and protocol."""

    name: str
    spec: str
    label: str
    split: str
    n_train: int
    n_test: int
    preset: str
    protocol: str
    methods: tuple[str, ...]


_ALL = ("full", "full_plan", "v1", "v2")


def _cases(which: str) -> list[Case]:
    sbu = f"sbu:{_DATA / 'sbu_kinect_interaction'}"
    ho = f"handover:{_DATA / 'handover_h2h'}"
    quick = [
        Case("syn_shake_default_causal", "synthetic", "shake_hands", "pair", 8, 2, "default", "causal", _ALL),
        Case("sbu_shake_default_causal", sbu, "shaking_hands", "pair", 8, 2, "default", "causal", _ALL),
        Case("ho_default_causal", ho, "hand_over", "pair", 6, 2, "default", "causal", ("full", "full_plan")),
    ]
    extra = [
        Case("syn_high5_paper_causal", "synthetic", "high_five", "pair", 8, 2, "paper", "causal", _ALL),
        Case("syn_shake_default_paper", "synthetic", "shake_hands", "pair", 8, 2, "default", "paper", _ALL),
        Case("syn_shake_default_offline", "synthetic", "shake_hands", "pair", 8, 2, "default", "offline", _ALL),
        Case("sbu_push_paper_paper", sbu, "pushing", "pair", 8, 2, "paper", "paper", _ALL),
        Case("sbu_push_paper_offline", sbu, "pushing", "pair", 8, 2, "paper", "offline", ("full", "v2")),
        Case("ho_default_paper", ho, "hand_over", "pair", 5, 1, "default", "paper", ("full", "v1", "v2")),
        Case("ho_paper_causal", ho, "hand_over", "pair", 5, 1, "paper", "causal", ("full",)),
    ]
    bench = [Case("ho_bench", ho, "hand_over", "pair", 30, 3, "default", "causal", ("full",))]
    return {"quick": quick, "extra": extra, "full": quick + extra, "bench": bench}[which]


def _cpu() -> float:
    return time.process_time()


def run_case(case: Case, arrays: dict[str, np.ndarray], seconds: dict[str, float]) -> None:
    data = load_dataset(case.spec)
    config = EvaluationConfig(protocol=case.protocol, split=case.split, preset=case.preset, max_folds=1,
                              max_test=case.n_test, seed=0)
    methods = [(m, METHODS[m]) for m in case.methods]
    tasks, _, _ = make_tasks(data, methods, [case.label], config)
    for task in tasks:
        train = task.train[: case.n_train]
        rng = np.random.default_rng(task_seed(task.seed, task.label, task.fold, task.method))
        tic = _cpu()
        method = make_method(task.factory, task.preset)
        method.fit(train, rng=rng)
        fit_s = _cpu() - tic
        key = f"{case.name}/{task.method}"
        for k, inst in enumerate(task.test):
            steps = [max(1, round(h * inst.fps)) for h in task.horizons_s]
            run = run_protocol_measured(
                method, inst, protocol=task.protocol, n_observed=task.n_observed, rng=rng, delta_t=PAPER_DELTA_T,
                horizon_frames=max(steps, default=0), horizon_every=max(1, round(task.horizon_every_s * inst.fps)),
            )
            p = run.prediction
            arrays[f"{key}/{k}/joints"] = p.joints
            arrays[f"{key}/{k}/key_joints"] = p.key_joints
            if p.subevents is not None:
                arrays[f"{key}/{k}/subevents"] = p.subevents
            arrays[f"{key}/{k}/forecasts"] = run.forecasts
        seconds[key] = {"fit": fit_s, "total": _cpu() - tic}
        print(f"{key}: fit {fit_s:.1f} s CPU, fit+predict {seconds[key]['total']:.1f} s CPU "
              f"({len(train)} train, {len(task.test)} test)", flush=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--out", required=True)
    r.add_argument("--set", default="quick", choices=("quick", "extra", "full", "bench"))
    r.add_argument("--only", default="", help="comma-separated case names (default: all of the set)")
    c = sub.add_parser("compare")
    c.add_argument("reference")
    c.add_argument("candidate")
    args = ap.parse_args()
    if args.cmd == "run":
        arrays: dict[str, np.ndarray] = {}
        seconds: dict[str, dict[str, float]] = {}
        only = {s for s in args.only.split(",") if s}
        for case in _cases(args.set):
            if not only or case.name in only:
                run_case(case, arrays, seconds)
        arrays["__seconds__"] = np.array(json.dumps(seconds))
        np.savez_compressed(args.out, **arrays)
        return 0
    a, b = np.load(args.reference), np.load(args.candidate)
    keys_a, keys_b = set(a.files) - {"__seconds__"}, set(b.files) - {"__seconds__"}
    bad = 0
    for k in sorted(keys_a ^ keys_b):
        print(f"only in {'reference' if k in keys_a else 'candidate'}: {k}")
        bad += 1
    for k in sorted(keys_a & keys_b):
        x, y = a[k], b[k]
        if x.shape != y.shape or not np.array_equal(x, y, equal_nan=x.dtype.kind == "f"):
            diff = np.nanmax(np.abs(x - y)) if x.shape == y.shape else float("nan")
            print(f"DIFFERS {k}: shape {x.shape} vs {y.shape}, max |diff| {diff:.3g}")
            bad += 1
    print(f"{len(keys_a & keys_b)} arrays compared, {bad} differ or are missing")
    for name, f in (("reference", a), ("candidate", b)):
        if "__seconds__" in f.files:
            secs = json.loads(str(f["__seconds__"]))
            print(f"{name} CPU s: " + ", ".join(f"{k} {v['total']:.1f}" for k, v in secs.items()))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
