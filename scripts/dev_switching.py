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
split) feed the ``primitive`` variants. ``--iterations N``: every affordance model fitted here runs N iterations of
Algorithm 1's MH chain instead of the preset's (traces cached in the subfolder ``itN`` of ``--cache``).
``--training-stream``: the cross-fitted training traces' primitive predictions from ``PrimitiveStream``
(``ProMPConfig.training_stream``); the validation traces keep the batch rule, so only the training side changes.
``--cross-fit-type-passes N``: the cross-fitted models of the training traces run N type-level restructuring passes
(``SwitchingConfig.cross_fit_type_passes``; the model fitted on all training instances keeps the preset's); the traces
are cached under their own name (suffix ``_tpN``).
``--overrun-delta-t``: the synthesizer's traces (training and validation) with ``SynthesisConfig.overrun_delta_t``
(cached apart, suffix ``_od``).
``--ordered``: the synthesizer's traces (training and validation) with ``SynthesisConfig.ordered`` (cached apart,
suffix ``_or``).
``--type-passes N``: the model fitted on all training instances runs N type-level restructuring passes
(``LearningConfig.init_type_passes``; the cross-fitted models too unless ``--cross-fit-type-passes`` is given); the
traces are cached under their own name (suffix ``_fpN``).
``--type-screen-rounds N``: the model fitted on all training instances screens its restructuring candidates after N
hard-EM rounds (``LearningConfig.init_type_screen_rounds``; the cross-fitted ones run no restructuring by default); the
traces are cached under their own name (suffix ``_srN``).
``--row-stride K``: every variant's regression reads the training rows of frames T0, T0 + K, … only
(``SwitchingConfig.row_stride``; default: the library's, 2 since session 22; before it the runs passed 1) and the
primitive's training traces are predicted at those frames only; the synthesizer's traces (and their cache) are the
same; the validation rows keep every frame.
``--inner-folds``, ``--penalties``, ``--draws K``: every variant's regression settings, and the default's regression
per draw of its inner folds (scripts/_dev_draws.py).
``--set FIELD=VALUE``: the default's causal synthesis changed; the fitted models shared (scripts/_dev_synthesis.py).
``--contiguous``: one pair's inner folds and cross-fitting parts as consecutive runs (``SwitchingConfig.contiguous``);
``--no-gated``: cheaper traces, no belief-gated variants. ``--clip-features on|off``, ``--clip-margin M``: every variant's
regression with ``SwitchingConfig.clip_features`` / ``clip_margin`` (default: the library's; the traces and their
cache are the same).

``--v2`` also fits the V2 ablation (preset ``default``, no sub-events) on the same training instances, its
training traces cross-fitted as the plans (its own split: the cached plans' split is not stored), and reports
``plan_v2`` (V2's plan alone), ``sw:default+plan_v2`` (today's default's families plus V2's plan as one more
family, ``plan_v2``: the same candidates as ``plan`` on V2's traces, blended by the same inner CV) and
``sw:v2_default`` (V2's own switching regression: today's default families on V2's traces; the primitive's
traces shared). The blend over several traces' families is fitted by ``blend_sources`` (scripts/_dev_blend.py),
which reproduces ``SwitchingRegression`` exactly when every family reads one trace set (checked on every class:
``check``).
Usage::

    python scripts/dev_switching.py --data nuisi:../shared/data/nuisi_v1 --split block [--rotation 0] [--labels a,b]
        [--cache DIR] [--variants default,primitive] [--contiguous] [--no-gated] [--v2] [--iterations N] [--training-stream]
        [--cross-fit-type-passes N] [--type-passes N] [--type-screen-rounds N] [--row-stride K]

Prints one line per class and the averages; the library never imports this script.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import pickle
import time
from pathlib import Path

import numpy as np

from socialaff_sim.data import load_dataset
from socialaff_sim.evaluation.compare import paired_difference
from socialaff_sim.evaluation.crossval import fold_rng
from socialaff_sim.evaluation.splits import make_folds
from socialaff_sim.inference.body_fit import BodyFitConfig, BodyFitter
from socialaff_sim.inference.interaction_primitive import InteractionPrimitive, ProMPConfig
from socialaff_sim.inference.methods import AffordanceMethod, primitive_trace, trace
from socialaff_sim.inference.reaction_regression import inner_folds, key_columns
from socialaff_sim.inference.switching import (
    FAMILIES, GATED_FAMILIES, PRIMITIVE_FAMILIES, SwitchingConfig, SwitchingRegression, Trace, instance_rows,
)

from _dev_blend import V2_FAMILY, blend_displacement, blend_sources  # scripts/ (sys.path[0])
from _dev_draws import add_regression_arguments, partition_draws, regression_settings
from _dev_synthesis import add_synthesis_arguments, fit_cached, settings_suffix, with_settings

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


def _with_primitive(traces: list[Trace], donor: list[Trace]) -> list[Trace]:
    return [dataclasses.replace(t, primitive=d.primitive, primitive_skeleton=d.primitive_skeleton)
            for t, d in zip(traces, donor, strict=True)]


def _with_iterations(method: AffordanceMethod, iterations: int | None) -> AffordanceMethod:
    """``method`` with ``iterations`` MH iterations in its learning configuration (``None``: the preset's)."""
    if iterations is not None:
        method.learning = dataclasses.replace(method.learning, iterations=iterations)
    return method


def _keep(per: dict[str, list[float]], name: str, errors: list[float]) -> float:
    """Record one variant's per-instance errors (m) of a class; return their mean."""
    per[name] = [float(e) for e in errors]
    return float(np.mean(errors))


def _err(pred: np.ndarray, truth: np.ndarray) -> float:
    return float(np.linalg.norm((pred - truth).reshape(len(pred), -1, 3), axis=-1).mean())


def add_split_arguments(ap: argparse.ArgumentParser) -> None:
    """The development split's arguments (data, split, rotation, labels, seed), shared with dev_subevents.py."""
    ap.add_argument("--data", required=True)
    ap.add_argument("--split", default="pair")
    ap.add_argument("--rotation", type=int, default=0, choices=(0, 1, 2))
    ap.add_argument("--labels", default="")
    ap.add_argument("--seed", type=int, default=0)


def main() -> None:
    ap = argparse.ArgumentParser()
    add_split_arguments(ap)
    ap.add_argument("--cross-fit", type=int, default=2, help="parts of the training traces' cross-fitting (1: in sample)")
    ap.add_argument("--variants", default=",".join(VARIANTS), help="comma-separated subset of " + ",".join(VARIANTS))
    ap.add_argument("--no-gated", action="store_true",
                    help="traces without the beliefs in the labels of the model fitted on all (cheaper: no in-sample "
                         "synthesis; the belief-gated variants are then not valid and are skipped)")
    ap.add_argument("--contiguous", action="store_true",
                    help="inner folds and cross-fitting parts as consecutive runs with one actor pair (SwitchingConfig.contiguous)")
    ap.add_argument("--v2", action="store_true", help="also V2's plan as one more family, and V2's own regression")
    ap.add_argument("--errors", default="", help="JSON file for every variant's per-instance errors, per class")
    ap.add_argument("--cache", default="", help="folder for the fitted traces (re-runs of the variants skip the fits)")
    ap.add_argument("--iterations", type=int, default=None,
                    help="Algorithm 1's MH iterations (LearningConfig.iterations) of every affordance model fitted here, "
                         "instead of the preset's; its traces are cached in the subfolder it<N> of --cache")
    ap.add_argument("--training-stream", action="store_true",
                    help="the training rows' primitive predictions from PrimitiveStream (ProMPConfig.training_stream); "
                         "the validation rows keep the batch rule, so only the training side differs")
    ap.add_argument("--clip-features", choices=("on", "off"), default="on" if SwitchingConfig().clip_features else "off",
                    help="every variant's regression clips its scaled columns to the training rows' range at prediction "
                    "(SwitchingConfig.clip_features, default on; the traces and their cache are the same)")
    ap.add_argument("--clip-margin", type=float, default=SwitchingConfig().clip_margin,
                    help="the clipped range widened on each side by this multiple of its width "
                    "(SwitchingConfig.clip_margin, default %(default)s)")
    ap.add_argument("--cross-fit-type-passes", type=int, default=None,
                    help="type-level restructuring passes of the cross-fitted models only (SwitchingConfig.cross_fit_type_passes; "
                         "default: the preset's); traces cached apart (suffix _tpN)")
    ap.add_argument("--overrun-delta-t", action="store_true",
                    help="the synthesizer's traces with SynthesisConfig.overrun_delta_t (re-plan every ΔT frames once the "
                         "running sub-event has overrun its predicted end); traces cached apart (suffix _od)")
    ap.add_argument("--ordered", action="store_true",
                    help="the synthesizer's traces with SynthesisConfig.ordered (the plan follows the sub-events' learned "
                         "order); traces cached apart (suffix _or)")
    ap.add_argument("--type-passes", type=int, default=None,
                    help="type-level restructuring passes of the model fitted on all training instances "
                         "(LearningConfig.init_type_passes; also the cross-fitted models' unless --cross-fit-type-passes); "
                         "default: the preset's; traces cached apart (suffix _fpN)")
    ap.add_argument("--type-screen-rounds", type=int, default=None,
                    help="hard-EM rounds of each restructuring candidate before the ranking, model fitted on all training "
                         "instances (LearningConfig.init_type_screen_rounds); default: the preset's; traces cached apart (suffix _srN)")
    ap.add_argument("--row-stride", type=int, default=SwitchingConfig().row_stride,
                    help="the regressions' training rows every K-th frame from T0 (SwitchingConfig.row_stride, default "
                         "%(default)s: the library's); the synthesizer's traces are unchanged (the same cache), the "
                         "primitive's predicted at those frames")
    add_regression_arguments(ap)
    add_synthesis_arguments(ap)
    args = ap.parse_args()
    settings = regression_settings(args)
    if args.type_screen_rounds is not None and args.type_screen_rounds < 0:
        raise SystemExit(f"--type-screen-rounds: expected an integer >= 0, found {args.type_screen_rounds}")
    if args.row_stride < 1:
        raise SystemExit(f"--row-stride: expected an integer >= 1, found {args.row_stride}")
    if args.type_passes is not None and args.type_passes < 0:
        raise SystemExit(f"--type-passes: expected an integer >= 0, found {args.type_passes}")
    if args.cross_fit_type_passes is not None and args.cross_fit_type_passes < 0:
        raise SystemExit(f"--cross-fit-type-passes: expected an integer >= 0, found {args.cross_fit_type_passes}")
    passes = args.cross_fit_type_passes
    if args.iterations is not None and args.iterations < 0:
        raise SystemExit(f"--iterations: expected an integer >= 0, found {args.iterations}")
    cache_dir = Path(args.cache) / f"it{args.iterations}" if args.cache and args.iterations is not None else Path(args.cache)
    ds = load_dataset(args.data)
    labels = [x for x in args.labels.split(",") if x] or list(ds.labels)
    table: dict[str, dict[str, float]] = {}
    counts: dict[str, int] = {}
    per_instance: dict[str, dict[str, list[float]]] = {}
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
        fit_key = f"{args.data.split(':')[0]}_{label}_r{args.rotation}_s{args.seed}{f'_fp{args.type_passes}' if args.type_passes is not None else ''}{f'_sr{args.type_screen_rounds}' if args.type_screen_rounds is not None else ''}"
        cache = cache_dir / f"{args.data.split(':')[0]}_{label}_r{args.rotation}_s{args.seed}{'_cf' if args.cross_fit > 1 else ''}{'_cc' if args.contiguous else ''}{'_ng' if args.no_gated else ''}{f'_tp{passes}' if passes is not None else ''}{f'_fp{args.type_passes}' if args.type_passes is not None else ''}{'_od' if args.overrun_delta_t else ''}{f'_sr{args.type_screen_rounds}' if args.type_screen_rounds is not None else ''}{'_or' if args.ordered else ''}{settings_suffix(args.set)}.pkl" if args.cache else None
        model_s = float("nan")  # the model fit alone (Algorithm 1 and the body clusters; nan: read from the cache)
        if cache is not None and cache.exists():
            S, tr_traces, va_traces = pickle.loads(cache.read_bytes())
        else:
            method = with_settings(_with_iterations(AffordanceMethod.from_preset("full", "default", reaction=None), args.iterations), args.set, ap)
            if args.overrun_delta_t:
                method.synthesis = dataclasses.replace(method.synthesis, overrun_delta_t=True)
            if args.ordered:
                method.synthesis = dataclasses.replace(method.synthesis, ordered=True)
            if args.type_passes is not None:  # the model fitted on all instances (issue 24: a cheaper fit)
                method.learning = dataclasses.replace(method.learning, init_type_passes=args.type_passes)
            if args.type_screen_rounds is not None:  # the restructuring's screening (issue 24: a cheaper fit)
                method.learning = dataclasses.replace(method.learning, init_type_screen_rounds=args.type_screen_rounds)
            model_s = fit_cached(method, train, rng, cache_dir / f"{fit_key}_fit.pkl" if args.cache else None)
            syn = dataclasses.replace(method.synthesis, n_observed=T0)
            tr_traces = method._training_traces(train, SwitchingConfig(families=FAMILIES if args.no_gated else GATED_FAMILIES, cross_fit=args.cross_fit, contiguous=args.contiguous, cross_fit_type_passes=passes), rng)
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
            prim = InteractionPrimitive(ProMPConfig(training_stream=args.training_stream)).fit(rest)
            for i in part:
                tr_traces[i] = primitive_trace(prim, body, tr_traces[i], train[i], T0, stride=args.row_stride)
        prim_all = InteractionPrimitive().fit(train)
        va_traces = [primitive_trace(prim_all, body, tr, i, T0) for i, tr in zip(val, va_traces, strict=True)]
        prim_s = time.perf_counter() - t1
        kc = key_columns(train[0])
        va_rows = [instance_rows(i, tr, T0, SwitchingConfig().features) for i, tr in zip(val, va_traces, strict=True)]
        per: dict[str, list[float]] = {}
        row = {"hold": _keep(per, "hold", [_err(np.zeros_like(Y[:, kc]), Y[:, kc]) for _, Y, _, _ in va_rows])}
        width = va_rows[0][0].shape[1]
        plan_cols = (width - 30 + np.arange(15)).reshape(5, 3)[train[0].layout.key_available].reshape(-1)
        row["plan"] = _keep(per, "plan", [_err(X[:, plan_cols], Y[:, kc]) for X, Y, _, _ in va_rows])
        row["promp"] = _keep(per, "promp", [_err(X[:, plan_cols + 15], Y[:, kc]) for X, Y, _, _ in va_rows])
        chosen = {}
        names = [v for v in args.variants.split(",") if v and not (args.no_gated and v in ("motion+subevent", "gated_all"))]
        for name in names:
            families, steps = VARIANTS[name]
            reg = SwitchingRegression(SwitchingConfig(families=families, blend_steps=steps, contiguous=args.contiguous,
                                                      clip_features=args.clip_features == "on", clip_margin=args.clip_margin,
                                                      row_stride=args.row_stride, **settings)).fit(  # type: ignore[arg-type]
                train, tr_traces, n_subevents=S, rng=np.random.default_rng(args.seed))
            row["sw:" + name] = _keep(per, "sw:" + name, [_err(reg.displacement(X, O, P)[:, kc], Y[:, kc]) for X, Y, O, P in va_rows])
            if name == "default" and args.draws > 1:  # the same regression per partition draw
                more, chosen["draws"] = partition_draws(reg.config, train, tr_traces, S, args.seed, args.draws, per["sw:default"],
                                                        lambda r: [_err(r.displacement(X, O, P)[:, kc], Y[:, kc]) for X, Y, O, P in va_rows])
                per.update(more)
                row.update({k: float(np.mean(v)) for k, v in more.items() if k.endswith("@mean")})
            chosen[name] = " + ".join(f"{m.weight:.1f}·[{'+'.join(m.groups)} λ={m.penalty:g}]" for m in reg.members_) or "hold"
        if args.v2:
            t2 = time.perf_counter()
            v2_cache = cache.with_name(cache.stem + "_v2.pkl") if cache is not None else None
            if v2_cache is not None and v2_cache.exists():
                S2, tr2, va2 = pickle.loads(v2_cache.read_bytes())
            else:
                rng2 = np.random.default_rng(args.seed)
                m2 = _with_iterations(AffordanceMethod.from_preset("v2", "default", reaction=None), args.iterations).fit(train, rng=rng2)
                syn2 = dataclasses.replace(m2.synthesis, n_observed=T0)
                tr2 = m2._training_traces(train, SwitchingConfig(families=FAMILIES, cross_fit=args.cross_fit, contiguous=args.contiguous, cross_fit_type_passes=passes), rng2)
                va2 = [trace(m2.model_, m2.body_, i, syn2, rng2) for i in val]
                S2 = m2.model_.n_subevents_
                if v2_cache is not None:
                    v2_cache.write_bytes(pickle.dumps((S2, tr2, va2)))
            v2_s = time.perf_counter() - t2
            tr2, va2 = _with_primitive(tr2, tr_traces), _with_primitive(va2, va_traces)
            va2_rows = [instance_rows(i, tr, T0, SwitchingConfig().features) for i, tr in zip(val, va2, strict=True)]
            plan_cols2 = plan_cols - width + va2_rows[0][0].shape[1]  # the same 15 columns, counted from the end
            row["plan_v2"] = _keep(per, "plan_v2", [_err(X[:, plan_cols2], Y[:, kc]) for X, Y, _, _ in va2_rows])
            reg2 = SwitchingRegression(SwitchingConfig(contiguous=args.contiguous)).fit(train, tr2, n_subevents=S2, rng=np.random.default_rng(args.seed))
            row["sw:v2_default"] = _keep(per, "sw:v2_default", [_err(reg2.displacement(X, O, P)[:, kc], Y[:, kc]) for X, Y, O, P in va2_rows])
            chosen["v2_default"] = " + ".join(f"{m.weight:.1f}·[{'+'.join(m.groups)} λ={m.penalty:g}]" for m in reg2.members_) or "hold"
            for name, fams in (("check", PRIMITIVE_FAMILIES), ("default+plan_v2", PRIMITIVE_FAMILIES + (V2_FAMILY,))):
                cfg = SwitchingConfig(families=fams, contiguous=args.contiguous)
                members, scale = blend_sources(train, {"own": tr_traces, "v2": tr2}, {"own": S, "v2": S2}, cfg,
                                               np.random.default_rng(args.seed))
                preds = [blend_displacement(members, scale, {"own": a, "v2": b}) for a, b in zip(va_rows, va2_rows, strict=True)]
                row["sw:" + name] = _keep(per, "sw:" + name, [_err(p[:, kc], r[1][:, kc]) for p, r in zip(preds, va_rows, strict=True)])
                chosen[name] = " + ".join(f"{a:.1f}·{f}[{'+'.join(g)} λ={lam:g}]" for f, g, lam, a, _, _ in members) or "hold"
            if "sw:default" in row and abs(row["sw:check"] - row["sw:default"]) > 1e-12:
                raise SystemExit(f"blend_sources does not reproduce SwitchingRegression: {row['sw:check']} vs {row['sw:default']}")
            print(f"{'':>14} V2 fits+traces {v2_s:.0f}s (S={S2})", flush=True)
        table[label] = row
        counts[label] = len(val)
        per_instance[label] = per
        print(f"{label:>14} n={len(train)}/{len(val)} S={S} fit+traces {fit_s:.0f}s (model fit {model_s:.0f}s) primitive {prim_s:.1f}s  "
              + "  ".join(f"{k} {v:.4f}" for k, v in row.items()), flush=True)
        print(f"{'':>14} chosen: " + "; ".join(f"{k}: {v}" for k, v in chosen.items()),
              flush=True)
    keys = next(iter(table.values())).keys()
    print(f"{'AVERAGE':>14} " + "  ".join(f"{k} {np.mean([r[k] for r in table.values()]):.4f}" for k in keys))
    if args.errors:
        Path(args.errors).write_text(json.dumps(per_instance))
    for name in ("sw:default+plan_v2", "sw:v2_default"):
        if name in keys and "sw:default" in keys:  # paired, stratified bootstrap over the validation instances
            diffs = [np.subtract(per_instance[c][name], per_instance[c]["sw:default"]) for c in table]
            cls = paired_difference(diffs, rng=np.random.default_rng(0))
            pooled = paired_difference([np.concatenate(diffs)], rng=np.random.default_rng(0))
            print(f"{name} − sw:default: class average {cls[0]:+.4f} [{cls[1]:+.4f}, {cls[2]:+.4f}], "
                  f"pooled {pooled[0]:+.4f} [{pooled[1]:+.4f}, {pooled[2]:+.4f}]")
    n = np.array([counts[c] for c in table])  # the mean over every validation instance
    print(f"{'POOLED':>14} n={n.sum()} " + "  ".join(f"{k} {np.dot(n, [r[k] for r in table.values()]) / n.sum():.4f}" for k in keys))


if __name__ == "__main__":
    main()
