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
import json
import os
import pickle
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from socialaff_sim.baselines.simple import HoldPose  # noqa: E402
from socialaff_sim.data.specs import load_dataset  # noqa: E402
from socialaff_sim.evaluation.compare import paired_difference  # noqa: E402
from socialaff_sim.evaluation.crossval import fold_rng, task_seed  # noqa: E402
from socialaff_sim.evaluation.metrics import joint_error, key_joint_error  # noqa: E402
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
                                        branches=1, end_prior="none")
    for name, change in {
        "argmax": dict(belief="argmax"),
        "two_branches": dict(branches=2),
        "three_branches": dict(branches=3),
        "shrink": dict(shrink=1.0),
        "likelihood": dict(selection="likelihood"),
        "sampled_duration": dict(duration="sample"),
        "no_end_regression": dict(end_prior="none"),
        "fine_step": dict(belief_step=0.07),
        "no_frame_regression": dict(frame_weight=0.0),
        "relative_frames": dict(frame_decay=float("inf")),
        "shrink_half": dict(shrink=0.5),
        "no_replan_at_end": dict(replan_at_end=False),
    }.items():
        out[name] = dataclasses.replace(default, **change)
    return out


def fold_models(spec: str, split: str, cache: Path, max_test: int | None, seed: int = 0,
                labels: list[str] | None = None) -> list[tuple[str, object, list, dict]]:
    """Per class: (label, fitted method, test instances, generator state after the fit), cached on disk."""
    data = load_dataset(spec)
    out = []
    for label in labels or data.labels:
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
    """(n, 2) key-joint and full-skeleton errors (m) of ``method`` on ``tests`` under the causal protocol."""
    rng = np.random.default_rng()
    rng.bit_generator.state = state
    out = []
    for inst in tests:
        pred = run_protocol(method, inst, protocol="causal", n_observed=N_OBSERVED, rng=rng)
        out.append((key_joint_error(pred, inst), joint_error(pred, inst)))
    return np.array(out)


def paired(diff: list[np.ndarray], seed: int = 0) -> tuple[float, float, float]:
    """Mean over classes of the per-class mean difference, with the evaluation's stratified bootstrap 95 % interval."""
    return paired_difference(diff, confidence=0.95, n_resamples=10_000, rng=np.random.default_rng(seed))


def recorded(path: Path | None, models: list) -> dict[str, dict[str, np.ndarray]]:
    """Per method of an earlier ``evaluate`` run's results.json (same folds and seed): per class the key-joint
    errors of this script's test instances, in their order."""
    if path is None:
        return {}
    per = json.loads(path.read_text())["per_instance"]
    out: dict[str, dict[str, np.ndarray]] = {}
    for label, _, tests, _ in models:
        for m, rows in per[label].items():
            by_id = {r["instance_id"]: r["key_joint_error_m"] for r in rows if r["fold"] == 0}
            out.setdefault(m, {})[label] = np.array([by_id[i.instance_id] for i in tests])
    return out


def render(path: Path, setting: str = "default") -> str:
    """Markdown: per interaction the key-joint error of ``before``, ``setting`` and the recorded baselines, the
    full-skeleton average, and ``setting``'s paired differences (95 %) against each, from a ``--json`` file."""
    d = json.loads(path.read_text())
    rec = d["recorded"]
    labels = list(d[setting])
    rows = {"before": {k: np.array(v)[:, 0] for k, v in d["before"].items()} if "before" in d else None,
            setting: {k: np.array(v)[:, 0] for k, v in d[setting].items()}}
    for m in ("hmm", "promp", "hold", "constvel"):
        if m in rec:
            rows[m] = {k: np.array(v) for k, v in rec[m].items()}
    lines = ["| method | " + " | ".join(labels) + " | **average** |", "|---|" + "---:|" * (len(labels) + 1)]
    for m, per in rows.items():
        if per is None:
            continue
        name = "full (default)" if m == setting else ("full (before)" if m == "before" else m)
        lines.append(f"| {name} | " + " | ".join(f"{per[k].mean():.3f}" for k in labels)
                     + f" | **{np.mean([per[k].mean() for k in labels]):.3f}** |")
    skel = np.mean([np.array(v)[:, 1].mean() for v in d[setting].values()])
    hold_skel = np.mean([np.array(v)[:, 1].mean() for v in d["hold"].values()])
    lines += ["", f"Full skeleton, average: full (default) {skel:.3f} m, hold {hold_skel:.3f} m.", "",
              "| full (default) − | difference | 95 % interval | verdict |", "|---|---:|---:|---|"]
    for m, per in rows.items():
        if m == setting or per is None:
            continue
        mean, lo, hi = paired([rows[setting][k] - per[k] for k in labels])
        verdict = "lower" if hi < 0 else ("higher" if lo > 0 else "indistinguishable")
        lines.append(f"| {m} | {mean:+.4f} | [{lo:+.4f}, {hi:+.4f}] | {verdict} |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True)
    ap.add_argument("--split", default="pair")
    ap.add_argument("--cache", type=Path, required=True)
    ap.add_argument("--max-test", type=int, default=None)
    ap.add_argument("--settings", default="before,default")
    ap.add_argument("--fit-only", action="store_true")
    ap.add_argument("--labels", default=None, help="comma-separated classes (default: all)")
    ap.add_argument("--reference", type=Path, default=None, help="results.json of an evaluate run with the same folds and seed")
    ap.add_argument("--json", type=Path, default=None, help="write per-instance errors of every setting here")
    ap.add_argument("--render", type=Path, default=None, help="print the Markdown tables of a --json file and exit")
    args = ap.parse_args()
    if args.render is not None:
        print(render(args.render))
        return
    args.cache.mkdir(parents=True, exist_ok=True)
    models = fold_models(args.data, args.split, args.cache, args.max_test,
                         labels=args.labels.split(",") if args.labels else None)
    if args.fit_only:
        return
    table = settings()
    hold = HoldPose()
    base = {label: errors(hold.fit(tests, rng=np.random.default_rng(0)), tests, st) for label, _, tests, st in models}
    refs = recorded(args.reference, models)
    if "hold" in refs:  # the same folds and instances as the recorded run: its hold must be ours
        gap = max(float(np.max(np.abs(refs["hold"][k] - base[k][:, 0]))) for k in base)
        print(f"recorded hold vs this hold: max |difference| {gap:.2e} m")
    refs["hold"] = {k: v[:, 0] for k, v in base.items()}
    print(f"{args.data}: hold {np.mean([b[:, 0].mean() for b in base.values()]):.4f} m (skeleton {np.mean([b[:, 1].mean() for b in base.values()]):.4f})")
    for m, per in refs.items():
        print(f"  recorded {m:9s} {np.mean([v.mean() for v in per.values()]):.4f}")
    dump: dict[str, object] = {"hold": {k: v.tolist() for k, v in base.items()},
                               "recorded": {m: {k: v.tolist() for k, v in per.items()} for m, per in refs.items()}}
    for name in args.settings.split(","):
        cfg = table[name]
        t0 = time.process_time()
        errs = {}
        for label, method, tests, st in models:
            method.synthesis = cfg
            errs[label] = errors(method, tests, st)
        key = {k: v[:, 0] for k, v in errs.items()}
        pairs = []
        for m in ("hold", "constvel", "hmm", "promp", "full"):
            if m in refs:
                d, lo, hi = paired([key[k] - refs[m][k] for k in key])
                pairs.append(f"−{m if m != 'full' else 'before'} {d:+.4f} [{lo:+.4f}, {hi:+.4f}]")
        per = " ".join(f"{k}={v.mean():.3f}" for k, v in key.items())
        print(f"{args.data}: {name:18s} {np.mean([e.mean() for e in key.values()]):.4f} m (skeleton "
              f"{np.mean([e[:, 1].mean() for e in errs.values()]):.4f}) {'; '.join(pairs)} "
              f"({time.process_time() - t0:.0f} s CPU) {per}", flush=True)
        dump[name] = {k: v.tolist() for k, v in errs.items()}
        if args.json is not None:
            args.json.write_text(json.dumps(dump))


if __name__ == "__main__":
    main()
