"""Development split for the switching regression (issue 24): never reads an evaluation test fold's results.

For every interaction class of a dataset the evaluation's own folds are made (seed 0, 4 folds, the
dataset's split); the instances of folds 2–4 (the training data of the evaluation's fold 1) form the
development pool: rotation r trains on two of those folds and validates on the third (fold 2 + r).
The affordance model (preset ``default``) is fitted once per class and rotation; the synthesizer's
causal traces (belief, phase, plan) of the training and validation instances are computed once (the training
plans cross-fitted as in ``AffordanceMethod.fit``, ``--cross-fit 1``: in sample); then
each variant of the switching regression (which groups the inner CV may choose among) is fitted on the
training traces and scored on the validation instances (mean key-joint distance per instance, frames
≥ T0, averaged per class, then over classes). Also reported: ``hold`` and the plan itself (Algorithm 2's
key joints, the full model before this change) and ``promp``: the interaction primitive's causal prediction
alone (the ``promp`` baseline on the development split), whose traces (cross-fitted like the plans, on their own
split) feed the ``primitive`` variants. ``--contiguous``: one pair's inner folds and cross-fitting parts as
consecutive runs (``SwitchingConfig.contiguous``); ``--no-gated``: cheaper traces, no belief-gated variants.
Usage::

    python scripts/dev_switching.py --data nuisi:../shared/data/nuisi_v1 --split block [--rotation 0] [--labels a,b]
        [--cache DIR] [--variants default,primitive] [--contiguous] [--no-gated]

Prints one line per class and the averages; the library never imports this script.
"""

from __future__ import annotations

import argparse
import dataclasses
import pickle
import time
from pathlib import Path

import numpy as np

from socialaff_sim.data import load_dataset
from socialaff_sim.evaluation.crossval import fold_rng
from socialaff_sim.evaluation.splits import make_folds
from socialaff_sim.inference.body_fit import BodyFitConfig, BodyFitter
from socialaff_sim.inference.interaction_primitive import InteractionPrimitive
from socialaff_sim.inference.methods import AffordanceMethod, primitive_trace, trace
from socialaff_sim.inference.reaction_regression import inner_folds, key_columns
from socialaff_sim.inference.switching import (
    FAMILIES, GATED_FAMILIES, PRIMITIVE_FAMILIES, SwitchingConfig, SwitchingRegression, instance_rows,
)

T0 = 10
_G = dict(GATED_FAMILIES)
VARIANTS = {  # name: (families, blend steps)
    "ridge": ((("motion", _G["motion"]),), 1),
    "motion+subevent": ((("motion", _G["motion"]), ("subevent", _G["subevent"])), 10),
    "default": (PRIMITIVE_FAMILIES, 10),  # today's default (since the primitive's family)
    "noprimitive": (FAMILIES, 10),  # the default before it: the tables of design.md §8 call it "today's default"
    "noprimitive_best1": (FAMILIES, 1),
    "gated_all": (GATED_FAMILIES, 10),
    "primitive": (PRIMITIVE_FAMILIES, 10),
    "motion+primitive": ((FAMILIES[0], PRIMITIVE_FAMILIES[-1]), 10),
    "primitive_best1": (PRIMITIVE_FAMILIES, 1),
}


def _err(pred: np.ndarray, truth: np.ndarray) -> float:
    return float(np.linalg.norm((pred - truth).reshape(len(pred), -1, 3), axis=-1).mean())


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", required=True)
    ap.add_argument("--split", default="pair")
    ap.add_argument("--rotation", type=int, default=0, choices=(0, 1, 2))
    ap.add_argument("--labels", default="")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cross-fit", type=int, default=2, help="parts of the training traces' cross-fitting (1: in sample)")
    ap.add_argument("--variants", default=",".join(VARIANTS), help="comma-separated subset of " + ",".join(VARIANTS))
    ap.add_argument("--no-gated", action="store_true",
                    help="traces without the beliefs in the labels of the model fitted on all (cheaper: no in-sample "
                         "synthesis; the belief-gated variants are then not valid and are skipped)")
    ap.add_argument("--contiguous", action="store_true",
                    help="inner folds and cross-fitting parts as consecutive runs with one actor pair (SwitchingConfig.contiguous)")
    ap.add_argument("--cache", default="", help="folder for the fitted traces (re-runs of the variants skip the fits)")
    args = ap.parse_args()
    ds = load_dataset(args.data)
    labels = [x for x in args.labels.split(",") if x] or list(ds.labels)
    table: dict[str, dict[str, float]] = {}
    for label in labels:
        insts = ds.of_label(label).interactions
        folds = make_folds(insts, 4, args.split, rng=fold_rng(0, label))
        dev = [list(folds[f][1]) for f in (1, 2, 3)]
        val_idx = dev[args.rotation]
        tr_idx = [i for k, f in enumerate(dev) if k != args.rotation for i in f]
        train = [insts[i] for i in tr_idx if insts[i].n_frames > T0 + 1]
        val = [insts[i] for i in val_idx if insts[i].n_frames > T0 + 1]
        rng = np.random.default_rng(args.seed)
        t0 = time.perf_counter()
        cache = Path(args.cache) / f"{args.data.split(':')[0]}_{label}_r{args.rotation}_s{args.seed}{'_cf' if args.cross_fit > 1 else ''}{'_cc' if args.contiguous else ''}{'_ng' if args.no_gated else ''}.pkl" if args.cache else None
        if cache is not None and cache.exists():
            S, tr_traces, va_traces = pickle.loads(cache.read_bytes())
        else:
            method = AffordanceMethod.from_preset("full", "default", reaction=None).fit(train, rng=rng)
            syn = dataclasses.replace(method.synthesis, n_observed=T0)
            tr_traces = method._training_traces(train, SwitchingConfig(families=FAMILIES if args.no_gated else GATED_FAMILIES, cross_fit=args.cross_fit, contiguous=args.contiguous), rng)
            va_traces = [trace(method.model_, method.body_, i, syn, rng) for i in val]
            S = method.model_.n_subevents_
            if cache is not None:
                cache.parent.mkdir(parents=True, exist_ok=True)
                cache.write_bytes(pickle.dumps((S, tr_traces, va_traces)))
        fit_s = time.perf_counter() - t0
        # The interaction primitive's traces (not cached: cheap), cross-fitted as AffordanceMethod.fit does
        # (its own split of the training instances; the cached plans' split is not stored).
        t1 = time.perf_counter()
        prim_rng = np.random.default_rng(args.seed)
        body = BodyFitter(BodyFitConfig()).fit_interactions(train, agent=1, rng=prim_rng)
        parts = inner_folds(train, np.arange(len(train)), args.cross_fit, prim_rng, contiguous=args.contiguous) if args.cross_fit > 1 else [list(range(len(train)))]
        tr_traces = list(tr_traces)
        for part in parts:
            rest = [inst for i, inst in enumerate(train) if i not in set(part)] if args.cross_fit > 1 else train
            prim = InteractionPrimitive().fit(rest)
            for i in part:
                tr_traces[i] = primitive_trace(prim, body, tr_traces[i], train[i], T0)
        prim_all = InteractionPrimitive().fit(train)
        va_traces = [primitive_trace(prim_all, body, tr, i, T0) for i, tr in zip(val, va_traces, strict=True)]
        prim_s = time.perf_counter() - t1
        kc = key_columns(train[0])
        va_rows = [instance_rows(i, tr, T0, SwitchingConfig().features) for i, tr in zip(val, va_traces, strict=True)]
        row = {"hold": float(np.mean([_err(np.zeros_like(Y[:, kc]), Y[:, kc]) for _, Y, _, _ in va_rows]))}
        width = va_rows[0][0].shape[1]
        plan_cols = (width - 30 + np.arange(15)).reshape(5, 3)[train[0].layout.key_available].reshape(-1)
        row["plan"] = float(np.mean([_err(X[:, plan_cols], Y[:, kc]) for X, Y, _, _ in va_rows]))
        row["promp"] = float(np.mean([_err(X[:, plan_cols + 15], Y[:, kc]) for X, Y, _, _ in va_rows]))
        chosen = {}
        names = [v for v in args.variants.split(",") if v and not (args.no_gated and v in ("motion+subevent", "gated_all"))]
        for name in names:
            families, steps = VARIANTS[name]
            reg = SwitchingRegression(SwitchingConfig(families=families, blend_steps=steps, contiguous=args.contiguous)).fit(
                train, tr_traces, n_subevents=S, rng=np.random.default_rng(args.seed))
            row["sw:" + name] = float(np.mean([_err(reg.displacement(X, O, P)[:, kc], Y[:, kc]) for X, Y, O, P in va_rows]))
            chosen[name] = " + ".join(f"{m.weight:.1f}·[{'+'.join(m.groups)} λ={m.penalty:g}]" for m in reg.members_) or "hold"
        table[label] = row
        print(f"{label:>14} n={len(train)}/{len(val)} S={S} fit+traces {fit_s:.0f}s primitive {prim_s:.1f}s  "
              + "  ".join(f"{k} {v:.4f}" for k, v in row.items()), flush=True)
        print(f"{'':>14} chosen: " + "; ".join(f"{k}: {v}" for k, v in chosen.items()),
              flush=True)
    keys = next(iter(table.values())).keys()
    print(f"{'AVERAGE':>14} " + "  ".join(f"{k} {np.mean([r[k] for r in table.values()]):.4f}" for k in keys))


if __name__ == "__main__":
    main()
