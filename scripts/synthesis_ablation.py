"""Causal-synthesis ablation on cached fold models: the full model's synthesis settings against ``hold``.

``socialaff-sim evaluate`` refits every model for every run; to compare synthesis settings (which do not
change the fitted model) this script fits the registered ``full`` method once per class on the training
set of fold 1 (the same folds, seeds and generator as ``evaluate``'s task ``(class, fold 0, "full")``),
pickles it with its generator state, and then runs each synthesis setting under the causal protocol on
that fold's test instances, always from the same generator state, next to ``hold``. It prints per
dataset the average key-joint error over the interactions and the paired difference against ``hold``
(mean over test instances, 95 % stratified bootstrap). The final tables come from ``evaluate``
(scripts/bench_accuracy.py); this is the tool for choosing among settings fixed a priori. Usage::

    OMP_NUM_THREADS=1 python scripts/synthesis_ablation.py --data synthetic --cache /tmp/abl \\
        [--split pair] [--max-test 15] [--settings before,default,...] [--fit-only]

The library never imports this script.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import pickle
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from socialaff_sim.baselines.simple import HoldPose  # noqa: E402
from socialaff_sim.data.specs import load_dataset  # noqa: E402
from socialaff_sim.evaluation.crossval import fold_rng, task_seed  # noqa: E402
from socialaff_sim.evaluation.metrics import key_joint_error  # noqa: E402
from socialaff_sim.evaluation.splits import make_folds  # noqa: E402
from socialaff_sim.evaluation.streaming import run_protocol  # noqa: E402
from socialaff_sim.inference.methods import AffordanceMethod  # noqa: E402
from socialaff_sim.inference.synthesis_config import SynthesisConfig  # noqa: E402

N_OBSERVED = 10


def settings() -> dict[str, SynthesisConfig]:
    """Named causal synthesis settings: ``before`` is the default preset's synthesis before issue 24's
    forward belief (hard DP arg-max, sampled duration and end, interpolation toward it); each other
    name is today's default with one change (or the default itself)."""
    default = SynthesisConfig.reactive()
    out = {"default": default}
    out["before"] = dataclasses.replace(default, belief="argmax", shrink=0.0, selection="likelihood", duration="sample",
                                        branches=1)
    for name, change in {
        "argmax": dict(belief="argmax"),
        "one_branch": dict(branches=1),
        "three_branches": dict(branches=3),
        "no_shrink": dict(shrink=0.0),
        "likelihood": dict(selection="likelihood"),
        "sampled_duration": dict(duration="sample"),
        "end_regression": dict(end_prior="regression"),
        "fine_step": dict(belief_step=0.07),
        "no_frame_regression": dict(frame_weight=0.0),
    }.items():
        out[name] = dataclasses.replace(default, **change)
    return out


def fold_models(spec: str, split: str, cache: Path, max_test: int | None, seed: int = 0) -> list[tuple[str, object, list, dict]]:
    """Per class: (label, fitted method, test instances, generator state after the fit), cached on disk."""
    data = load_dataset(spec)
    out = []
    for label in data.labels:
        path = cache / f"{spec.split(':')[0]}_{label}.pkl"
        insts = data.of_label(label).interactions
        train, test = make_folds(insts, 4, split, rng=fold_rng(seed, label))[0]
        tests = [insts[i] for i in test if insts[i].n_frames > N_OBSERVED + 1][:max_test]
        if path.exists():
            with path.open("rb") as fh:
                method, state = pickle.load(fh)
        else:
            rng = np.random.default_rng(task_seed(seed, label, 0, "full"))
            t0 = time.process_time()
            method = AffordanceMethod.from_preset("full", "default").fit([insts[i] for i in train], rng=rng)
            state = rng.bit_generator.state
            with path.open("wb") as fh:
                pickle.dump((method, state), fh)
            print(f"fitted {label}: {time.process_time() - t0:.0f} s CPU", flush=True)
        out.append((label, method, tests, state))
    return out


def errors(method: object, tests: list, state: dict) -> np.ndarray:
    rng = np.random.default_rng()
    rng.bit_generator.state = state
    return np.array([key_joint_error(run_protocol(method, inst, protocol="causal", n_observed=N_OBSERVED, rng=rng), inst)
                     for inst in tests])


def paired(diff: list[np.ndarray], seed: int = 0, n: int = 2000) -> tuple[float, float, float]:
    """Mean over classes of the per-class mean difference, with a stratified bootstrap 95 % interval."""
    rng = np.random.default_rng(seed)
    mean = float(np.mean([d.mean() for d in diff]))
    boots = np.mean([[rng.choice(d, d.size).mean() for _ in range(n)] for d in diff], axis=0)
    lo, hi = np.percentile(boots, [2.5, 97.5])
    return mean, float(lo), float(hi)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--split", default="pair")
    ap.add_argument("--cache", type=Path, required=True)
    ap.add_argument("--max-test", type=int, default=None)
    ap.add_argument("--settings", default="before,default")
    ap.add_argument("--fit-only", action="store_true")
    args = ap.parse_args()
    args.cache.mkdir(parents=True, exist_ok=True)
    models = fold_models(args.data, args.split, args.cache, args.max_test)
    if args.fit_only:
        return
    table = settings()
    hold = HoldPose()
    base = {label: errors(hold.fit(tests, rng=np.random.default_rng(0)), tests, st) for label, _, tests, st in models}
    print(f"{args.data}: hold {np.mean([b.mean() for b in base.values()]):.4f} m")
    for name in args.settings.split(","):
        cfg = table[name]
        t0 = time.process_time()
        errs = {}
        for label, method, tests, st in models:
            method.synthesis = cfg
            errs[label] = errors(method, tests, st)
        m, lo, hi = paired([errs[k] - base[k] for k in errs])
        per = " ".join(f"{k}={v.mean():.3f}" for k, v in errs.items())
        print(f"{args.data}: {name:18s} {np.mean([e.mean() for e in errs.values()]):.4f} m  − hold {m:+.4f} "
              f"[{lo:+.4f}, {hi:+.4f}]  ({time.process_time() - t0:.0f} s CPU)  {per}", flush=True)


if __name__ == "__main__":
    main()
