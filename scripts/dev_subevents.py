"""What the sub-events carry on the development split (issue 24, docs/design.md §8): never reads a test fold.

Reads the traces that ``scripts/dev_switching.py --v2`` cached (the default model's and V2's, one class and
rotation at a time: ``--cache`` and ``--suffix`` name them) and breaks the validation errors down:

* per frame horizon (seconds since agent 1's last observed frame, T0) and, for the handovers, per phase of the
  transfer read from the object track (``approach``: before the receiver's nearer wrist first comes within
  ``--reach`` m of the object; ``transfer``: from then until the giver's nearer wrist leaves it by more than
  ``--release`` m; ``retreat``: after), and per key joint, for ``hold``, Algorithm 2's plan (``plan``: the default
  model's, ``plan_v2``: V2's), the primitive alone (``promp``), the blends (``sw:default`` on the default model's
  traces, ``sw:v2_default`` on V2's) and each blend member alone;
* the plans' timing: the time at which the plan's and the truth's base first cover half of the truth's base
  displacement since T0, and the error left after the best monotone time alignment of the plan to the truth
  (dynamic time warping of the key joints: the part of the error that a different clock could not remove);
* the belief: its entropy, how often its arg-max changes, the arg-max label per phase; against the model's own offline
  parse of each validation instance (``best_parse`` of the whole recording): the share of frames where its arg-max is
  the same sub-event, one or more ahead, behind, or has *returned* below the highest rank (``order_ranks``) it reached
  in the instance, and the plans' errors on each;
* the parses of the training instances by the model fitted on all of them (refitted here with the script's
  seed: ``dev_switching.py`` fits it first from ``default_rng(seed)``, so it is the same model): intervals per
  instance and each type's duration;
* the inner CV's view of the plans: their error on the (cross-fitted) training rows against the validation rows.

Usage::

    python scripts/dev_subevents.py --data handover:../shared/data/handover_h2h --split pair --cache DIR/it0
        --suffix _cf_ng_tp0_od [--json OUT]

``--suffix`` may name an option's traces (e.g. ``_cf_ng_tp0_od_or``); without a V2 trace file beside them the V2 columns
repeat the default model's. The interaction primitive's traces are computed as ``dev_switching.py`` computes them (same generator) and cached
beside the others (suffix ``_prim``). Prints tables; the library never imports this script.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import pickle
import sys
from pathlib import Path

import numpy as np

_HERE = str(Path(__file__).resolve().parent)
if _HERE not in sys.path:  # run as `python scripts/dev_subevents.py` it is sys.path[0]; the tests load this file by path
    sys.path.append(_HERE)
from dev_switching import T0, VARIANTS, add_split_arguments  # noqa: E402  (the development split's constants and variants)
from socialaff_sim.data import Interaction, load_dataset  # noqa: E402
from socialaff_sim.evaluation.compare import paired_difference  # noqa: E402
from socialaff_sim.evaluation.crossval import fold_rng  # noqa: E402
from socialaff_sim.evaluation.splits import make_folds  # noqa: E402
from socialaff_sim.inference.body_fit import BodyFitConfig, BodyFitter  # noqa: E402
from socialaff_sim.inference.interaction_primitive import InteractionPrimitive, ProMPConfig  # noqa: E402
from socialaff_sim.inference.methods import AffordanceMethod, primitive_trace  # noqa: E402
from socialaff_sim.inference.reaction_regression import inner_folds, key_columns  # noqa: E402
from socialaff_sim.inference.switching import SwitchingConfig, SwitchingRegression, Trace, instance_rows  # noqa: E402
from socialaff_sim.inference.online_parse import closed_scores  # noqa: E402
from socialaff_sim.model.joints import canonical_joints, instance_frame  # noqa: E402
from socialaff_sim.model.transitions import order_ranks  # noqa: E402

PHASES = ("approach", "transfer", "retreat")
HORIZONS = (0.0, 0.5, 1.0, 2.0, 3.0, np.inf)  # seconds since T0: bin edges
KEY_NAMES = ("base", "wrist L", "wrist R", "ankle L", "ankle R")


def frame_errors(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """(N, 5) per-frame, per-key-joint distances, m, of (N, 15) predictions from (N, 15) truths."""
    return np.linalg.norm((pred - truth).reshape(len(pred), -1, 3), axis=-1)


def handover_phases(inst: Interaction, reach: float, release: float) -> np.ndarray:
    """(T,) int: 0 approach, 1 transfer, 2 retreat, from the object track and both agents' wrists (module docstring)."""
    k = inst.key_joints()
    T = inst.n_frames
    if inst.object is None:
        return np.zeros(T, np.int64)
    d_recv = np.nanmin(np.linalg.norm(k[:, 1, 1:3] - inst.object[:, None], axis=-1), axis=1)
    d_give = np.nanmin(np.linalg.norm(k[:, 0, 1:3] - inst.object[:, None], axis=-1), axis=1)
    near = np.flatnonzero(d_recv < reach)
    out = np.zeros(T, np.int64)
    if near.size == 0:
        return out
    t_reach = int(near[0])
    gone = np.flatnonzero((d_give > release) & (np.arange(T) > t_reach))
    t_release = int(gone[0]) if gone.size else T
    out[t_reach:] = 1
    out[t_release:] = 2
    return out


def dtw_error(pred: np.ndarray, truth: np.ndarray) -> float:
    """Mean per-frame key-joint distance, m, after the best monotone alignment of ``pred`` (N, 15) to ``truth``
    (N, 15) (dynamic time warping, steps (1,0), (0,1), (1,1); the least summed
    distance, divided by the path's length)."""
    cost = frame_errors(np.repeat(pred, len(truth), axis=0), np.tile(truth, (len(pred), 1))).mean(axis=1)
    cost = cost.reshape(len(pred), len(truth))
    n, m = cost.shape
    acc = np.full((n + 1, m + 1), np.inf)
    steps = np.zeros((n + 1, m + 1))
    acc[0, 0] = 0.0
    for i in range(1, n + 1):  # sequential by construction
        for j in range(1, m + 1):
            k = int(np.argmin((acc[i - 1, j], acc[i, j - 1], acc[i - 1, j - 1])))
            pi, pj = ((i - 1, j), (i, j - 1), (i - 1, j - 1))[k]
            acc[i, j] = acc[pi, pj] + cost[i - 1, j - 1]
            steps[i, j] = steps[pi, pj] + 1
    return float(acc[n, m] / steps[n, m])


def half_time(base_disp: np.ndarray, goal: np.ndarray, fps: float) -> float:
    """Seconds after T0 at which the base displacement (N, 3) first covers half of ``goal`` (3,), projected on it."""
    g = float(np.linalg.norm(goal))
    if g < 1e-6:
        return float("nan")
    prog = base_disp @ (goal / g)
    hit = np.flatnonzero(prog >= 0.5 * g)
    return float(hit[0] / fps) if hit.size else float("nan")


def member_parts(reg: SwitchingRegression, X: np.ndarray, O: np.ndarray, P: np.ndarray) -> list[tuple[str, float, np.ndarray]]:
    """(family, α, (N, J·3) displacement) of each member of the blend alone, as :meth:`displacement` adds them."""
    out = []
    for m in reg.members_:
        part = (O if m.prior == "from_plan" else P if m.prior == "from_primitive" else np.zeros_like(O)).copy()
        if len(m.columns):
            x = X[:, m.columns] / reg.scale_[m.columns]
            if reg.config.clip_features:
                x = np.clip(x, reg.lower_[m.columns], reg.upper_[m.columns])
            part += x @ m.coefficients
        out.append((f"{m.family}[{'+'.join(m.groups) or 'hold'} λ={m.penalty:g}]", m.weight, part))
    return out


def primitive_traces(train: list[Interaction], val: list[Interaction], tr: list[Trace], va: list[Trace], seed: int,
                     cache: Path) -> tuple[list[Trace], list[Trace]]:
    """The traces with the interaction primitive's predictions, exactly as ``dev_switching.py`` adds them
    (``--training-stream``, cross-fitted on their own split, same generator); cached in ``cache``."""
    if cache.exists():
        prim_tr, prim_va = pickle.loads(cache.read_bytes())
    else:
        prim_rng = np.random.default_rng(seed)
        body = BodyFitter(BodyFitConfig()).fit_interactions(train, agent=1, rng=prim_rng)
        parts = inner_folds(train, np.arange(len(train)), 2, prim_rng)
        prim_tr = list(tr)
        for part in parts:
            rest = [inst for i, inst in enumerate(train) if i not in set(part)]
            prim = InteractionPrimitive(ProMPConfig(training_stream=True)).fit(rest)
            for i in part:
                prim_tr[i] = primitive_trace(prim, body, tr[i], train[i], T0)
        prim_all = InteractionPrimitive().fit(train)
        prim_va = [primitive_trace(prim_all, body, t, i, T0) for i, t in zip(val, va, strict=True)]
        prim_tr = [(t.primitive, t.primitive_skeleton) for t in prim_tr]
        prim_va = [(t.primitive, t.primitive_skeleton) for t in prim_va]
        cache.write_bytes(pickle.dumps((prim_tr, prim_va)))
    def put(traces: list[Trace], prims: list[tuple[np.ndarray, np.ndarray]]) -> list[Trace]:
        return [dataclasses.replace(t, primitive=p, primitive_skeleton=s) for t, (p, s) in zip(traces, prims, strict=True)]
    return put(tr, prim_tr), put(va, prim_va)


def main() -> None:
    ap = argparse.ArgumentParser()
    add_split_arguments(ap)
    ap.add_argument("--cache", required=True, help="dev_switching.py's trace folder (with its it<N> subfolder)")
    ap.add_argument("--suffix", default="_cf_ng_tp0_od", help="the cached traces' name suffix (dev_switching.py's flags)")
    ap.add_argument("--reach", type=float, default=0.35, help="m: the receiver's wrist this near the object starts the transfer")
    ap.add_argument("--release", type=float, default=0.45, help="m: the giver's wrist this far from the object ends it")
    ap.add_argument("--no-refit", action="store_true", help="skip refitting the model for its training parses")
    ap.add_argument("--json", default="")
    args = ap.parse_args()
    ds = load_dataset(args.data)
    labels = [x for x in args.labels.split(",") if x] or list(ds.labels)
    report: dict[str, object] = {}
    for label in labels:
        insts = ds.of_label(label).interactions
        folds = make_folds(insts, 4, args.split, rng=fold_rng(0, label))
        dev = [list(folds[f][1]) for f in (1, 2, 3)]
        tr_idx = [i for k, f in enumerate(dev) if k != args.rotation for i in f]
        train = [insts[i] for i in tr_idx if insts[i].n_frames > T0 + 1]
        val = [insts[i] for i in dev[args.rotation] if insts[i].n_frames > T0 + 1]
        stem = f"{args.data.split(':')[0]}_{label}_r{args.rotation}_s{args.seed}{args.suffix}"
        cache = Path(args.cache)
        S, tr, va = pickle.loads((cache / f"{stem}.pkl").read_bytes())
        v2_file = cache / f"{stem}_v2.pkl"
        S2, tr2, va2 = pickle.loads(v2_file.read_bytes()) if v2_file.exists() else (S, tr, va)  # without V2: its own
        tr, va = primitive_traces(train, val, tr, va, args.seed, cache / f"{stem}_prim.pkl")
        tr2 = [dataclasses.replace(t, primitive=d.primitive, primitive_skeleton=d.primitive_skeleton) for t, d in zip(tr2, tr, strict=True)]
        va2 = [dataclasses.replace(t, primitive=d.primitive, primitive_skeleton=d.primitive_skeleton) for t, d in zip(va2, va, strict=True)]
        feats = SwitchingConfig().features
        kc = key_columns(train[0])
        rows = [instance_rows(i, t, T0, feats) for i, t in zip(val, va, strict=True)]
        rows2 = [instance_rows(i, t, T0, feats) for i, t in zip(val, va2, strict=True)]
        width, width2 = rows[0][0].shape[1], rows2[0][0].shape[1]
        plan_cols = width - 30 + np.arange(15)
        regs = {
            "sw:default": (SwitchingRegression(SwitchingConfig()).fit(train, tr, n_subevents=S, rng=np.random.default_rng(args.seed)), rows),
            "sw:v2_default": (SwitchingRegression(SwitchingConfig()).fit(train, tr2, n_subevents=S2, rng=np.random.default_rng(args.seed)), rows2),
            "ridge": (SwitchingRegression(SwitchingConfig(families=VARIANTS["ridge"][0], blend_steps=1)).fit(
                train, tr, n_subevents=S, rng=np.random.default_rng(args.seed)), rows),
        }
        # Per-frame errors (N, 5) per method and instance, with each frame's horizon and phase.
        per: dict[str, list[np.ndarray]] = {}
        horizon, phase = [], []
        for k, inst in enumerate(val):
            X, Y, O, P = rows[k]
            X2 = rows2[k][0]
            truth = Y[:, kc]
            per.setdefault("hold", []).append(frame_errors(np.zeros_like(truth), truth))
            per.setdefault("plan", []).append(frame_errors(X[:, plan_cols], truth))
            per.setdefault("plan_v2", []).append(frame_errors(X2[:, width2 - 30 + np.arange(15)], truth))
            per.setdefault("promp", []).append(frame_errors(X[:, plan_cols + 15], truth))
            for name, (reg, rr) in regs.items():
                Xr, _, Or, Pr = rr[k]
                per.setdefault(name, []).append(frame_errors(reg.displacement(Xr, Or, Pr)[:, kc], truth))
                if name != "ridge":
                    for m, a, part in member_parts(reg, Xr, Or, Pr):
                        per.setdefault(f"{name} member {m} (α={a:.1f})", []).append(frame_errors(part[:, kc], truth))
            frames = np.arange(T0, inst.n_frames)
            horizon.append((frames - (T0 - 1)) / inst.fps)
            phase.append(handover_phases(inst, args.reach, args.release)[frames])
        inst_mean = {n: np.array([e.mean() for e in v]) for n, v in per.items()}
        H, P = np.concatenate(horizon), np.concatenate(phase)
        out: dict[str, object] = {"n_train": len(train), "n_val": len(val), "S": S, "S_v2": S2}
        print(f"== {label}: {len(train)} training / {len(val)} validation instances, S = {S} (V2: {S2})")
        print("members: " + "; ".join(f"{n}: " + " + ".join(f"{m.weight:.1f}·{m.family}[{'+'.join(m.groups)} λ={m.penalty:g}]"
                                                           for m in reg.members_) for n, (reg, _) in regs.items()))
        out["members"] = {n: [(m.family, m.groups, m.penalty, m.weight) for m in reg.members_] for n, (reg, _) in regs.items()}
        out["blend_error_inner_cv"] = {n: float(reg.blend_error_) for n, (reg, _) in regs.items()}
        # Table 1: per-instance mean (the development measure), per horizon bin, per phase, per key joint.
        bins = list(zip(HORIZONS[:-1], HORIZONS[1:], strict=True))
        head = ["instance mean"] + [f"{a:g}–{b:g} s" for a, b in bins] + list(PHASES) + list(KEY_NAMES)
        print("| method | " + " | ".join(head) + " |")
        table: dict[str, dict[str, float]] = {}
        for name, errs in per.items():
            E = np.concatenate(errs)
            cells = {"instance mean": float(inst_mean[name].mean())}
            for a, b in bins:
                sel = (H > a) & (H <= b)
                cells[f"{a:g}–{b:g} s"] = float(E[sel].mean()) if sel.any() else float("nan")
            for p, pn in enumerate(PHASES):
                cells[pn] = float(E[P == p].mean()) if (P == p).any() else float("nan")
            for j, jn in enumerate(KEY_NAMES):
                cells[jn] = float(E[:, j].mean())
            table[name] = cells
            print(f"| {name} | " + " | ".join(f"{cells[h]:.4f}" for h in head) + " |")
        out["table"] = table
        out["frames_per_phase"] = [int((P == p).sum()) for p in range(3)]
        out["frames_per_horizon"] = [int(((H > a) & (H <= b)).sum()) for a, b in bins]
        print("frames per phase", out["frames_per_phase"], "per horizon bin", out["frames_per_horizon"])
        for a, b in (("plan_v2", "plan"), ("sw:v2_default", "sw:default")):
            d = paired_difference([inst_mean[a] - inst_mean[b]], rng=np.random.default_rng(0))
            print(f"{a} − {b}: {d[0]:+.4f} [{d[1]:+.4f}, {d[2]:+.4f}]")
            out[f"{a} − {b}"] = d
        # Timing: half-way times of the base, and the error left after the best time alignment.
        timing = {"truth": [], "plan": [], "plan_v2": []}
        dtw = {"plan": [], "plan_v2": []}
        for k, inst in enumerate(val):
            X, Y, _, _ = rows[k]
            X2 = rows2[k][0]
            truth = Y[:, kc]
            goal = truth[-1, :3]
            timing["truth"].append(half_time(truth[:, :3], goal, inst.fps))
            timing["plan"].append(half_time(X[:, plan_cols][:, :3], goal, inst.fps))
            timing["plan_v2"].append(half_time(X2[:, width2 - 30 + np.arange(15)][:, :3], goal, inst.fps))
            dtw["plan"].append(dtw_error(X[:, plan_cols], truth))
            dtw["plan_v2"].append(dtw_error(X2[:, width2 - 30 + np.arange(15)], truth))
        t_true = np.array(timing["truth"])
        for n in ("plan", "plan_v2"):
            t = np.array(timing[n])
            late = t - t_true
            print(f"{n}: base half-way {np.nanmean(t):.2f} s vs truth {np.nanmean(t_true):.2f} s (late by mean {np.nanmean(late):+.2f}, "
                  f"median {np.nanmedian(late):+.2f} s; never reached in {int(np.isnan(t).sum())}/{len(t)}); "
                  f"error {inst_mean[n].mean():.4f} → after time alignment {np.mean(dtw[n]):.4f} m")
        out["timing"] = {n: [float(x) for x in v] for n, v in timing.items()}
        out["dtw"] = {n: [float(x) for x in v] for n, v in dtw.items()}
        model = None
        if not args.no_refit:  # the model fitted on all training instances: dev_switching.py's first fit, same generator
            m = AffordanceMethod.from_preset("full", "default", reaction=None)
            m.learning = dataclasses.replace(m.learning, iterations=0)
            m.fit(train, rng=np.random.default_rng(args.seed))
            model = m.model_
        # The belief on the validation instances.
        ent, switches, argmax_phase = [], [], np.zeros((3, S))
        for k, inst in enumerate(val):
            b = va[k].belief[T0:]
            ent.append(float(np.mean(-np.sum(np.where(b > 0, b * np.log(np.where(b > 0, b, 1.0)), 0.0), axis=1)) / np.log(S)))
            am = b.argmax(axis=1)
            switches.append(int(np.sum(am[1:] != am[:-1])))
            ph = handover_phases(inst, args.reach, args.release)[T0:]
            for p in range(3):
                for s in range(S):
                    argmax_phase[p, s] += int(np.sum((ph == p) & (am == s)))
        print(f"belief: mean normalised entropy {np.mean(ent):.3f}; arg-max changes per instance {np.mean(switches):.1f} "
              f"(max {max(switches)}); arg-max label share per phase (rows {PHASES}):")
        print(np.round(argmax_phase / np.maximum(argmax_phase.sum(1, keepdims=True), 1), 2))
        out["belief"] = {"entropy": ent, "switches": switches, "argmax_per_phase": argmax_phase.tolist()}
        # The belief's clock against the model's own offline parse of each validation instance (its whole recording),
        # and the frames where the belief's arg-max has returned below the highest rank it reached in the instance.
        if model is not None:
            ranks = order_ranks(model.parses_, S)
            cls = {"same": [], "ahead 1": [], "ahead 2+": [], "behind": [], "returned": []}
            cls_v2 = {k: [] for k in cls}
            back: dict[int, list[tuple[float, float]]] = {}  # returned frames by the label returned to
            odds: list[float] = []  # their log-odds of the arg-max against the highest-ranked type reached
            for k, inst in enumerate(val):
                _, parse = model.best_parse(inst)
                lab = np.full(inst.n_frames, -1)
                pos = {}
                for n, (a, b, s_) in enumerate(parse):
                    lab[a:b] = s_
                    pos[int(s_)] = n
                am = va[k].belief.argmax(axis=1)
                e = frame_errors(rows[k][0][:, plan_cols], rows[k][1][:, kc]).mean(axis=1)
                e2 = frame_errors(rows2[k][0][:, width2 - 30 + np.arange(15)], rows2[k][1][:, kc]).mean(axis=1)
                top = -np.inf
                for i, t in enumerate(range(T0, inst.n_frames)):
                    r = ranks[am[t]]
                    if r < top:
                        c = "returned"
                    else:
                        d = pos.get(int(am[t]), 99) - pos.get(int(lab[t]), 99)
                        c = "same" if d == 0 else "ahead 1" if d == 1 else "ahead 2+" if d > 1 else "behind"
                    top = max(top, r)
                    cls[c].append(e[i])
                    cls_v2[c].append(e2[i])
                    if c == "returned":
                        back.setdefault(int(am[t]), []).append((e[i], e2[i]))
                        top_type = int(np.nanargmax(np.where(ranks <= top, ranks, -np.inf)))  # the highest reached
                        odds.append(float(np.log(va[k].belief[t, am[t]] / max(va[k].belief[t, top_type], 1e-300))))
            n_all = sum(len(v) for v in cls.values())
            print("belief arg-max against the offline parse: " + "; ".join(
                f"{c} {len(v) / n_all:.2f} of frames (plan {np.mean(v) if v else np.nan:.3f}, plan_v2 "
                f"{np.mean(cls_v2[c]) if v else np.nan:.3f} m)" for c, v in cls.items()))
            print("returned frames by the label returned to: " + "; ".join(
                f"type {s_}: {len(v)} frames (plan {np.mean([a for a, _ in v]):.3f}, plan_v2 {np.mean([b for _, b in v]):.3f} m)"
                for s_, v in sorted(back.items())))
            if odds:
                print("returned frames: log-odds of the arg-max against the highest type reached, quantiles 10/50/90 % "
                      + " / ".join(f"{q:.1f}" for q in np.percentile(odds, [10, 50, 90])) + " nats")
            print("mean belief at T0: " + " ".join(f"{b:.2f}" for b in np.mean([t_.belief[T0] for t_ in va], axis=0)))
            scores: dict[int, list[tuple[float, int]]] = {}
            for inst, parse in zip(train, model.parses_, strict=True):  # the training intervals' closed scores
                track = canonical_joints(inst, instance_frame(inst))
                for a, b, s_ in parse:
                    scores.setdefault(int(s_), []).append(
                        (float(closed_scores(model, track, inst.fps, np.array([a]), np.array([b]))[0, s_]), int(b - a)))
            print("training intervals' closed score under their own type (log, nats): " + "; ".join(
                f"type {s_}: mean {np.mean([x for x, _ in v]):.0f}, per frame {np.mean([x / n for x, n in v]):.1f}"
                for s_, v in sorted(scores.items())))
            out["clock"] = {c: {"share": len(v) / n_all, "plan": float(np.mean(v)) if v else None,
                                "plan_v2": float(np.mean(cls_v2[c])) if v else None} for c, v in cls.items()}
        # The inner CV's view: the plans' error on the cross-fitted training rows against the validation rows.
        for name, traces, w_ in (("plan", tr, width), ("plan_v2", tr2, width2)):
            errs = []
            for inst, t in zip(train, traces, strict=True):
                X, Y, _, _ = instance_rows(inst, t, T0, feats)
                errs.append(frame_errors(X[:, w_ - 30 + np.arange(15)], Y[:, kc]).mean())
            print(f"{name}: cross-fitted training rows {np.mean(errs):.4f} m, validation {inst_mean[name].mean():.4f} m")
            out[f"{name} train rows"] = float(np.mean(errs))
        # The training parses of the model fitted on all training instances (refitted above: the same model).
        if model is not None:
            n_int = [len(p) for p in model.parses_]
            print(f"training parses: intervals per instance {np.bincount(n_int).tolist()} (count of 0, 1, 2 …); "
                  f"names {model.subevent_names_}")
            order: dict[str, int] = {}
            for p in model.parses_:
                key = "→".join(str(int(s)) for s in p[:, 2])
                order[key] = order.get(key, 0) + 1
            print("label orders:", dict(sorted(order.items(), key=lambda kv: -kv[1])))
            for s in range(S):
                d = [(r[1] - r[0]) / train[0].fps for p in model.parses_ for r in p if r[2] == s]
                mu, sigma = model.duration_params_[s]
                print(f"  type {s}: {len(d)} intervals, duration median {np.median(d) if d else np.nan:.2f} s "
                      f"(IQR {np.percentile(d, 25) if d else np.nan:.2f}–{np.percentile(d, 75) if d else np.nan:.2f}); "
                      f"log-normal μ {mu:.2f} σ {sigma:.2f}")
            lengths = [i.n_frames / i.fps for i in train]
            print(f"  instances: {np.median(lengths):.2f} s median ({min(lengths):.2f}–{max(lengths):.2f})")
            out["parses"] = {"intervals": n_int, "orders": order, "names": list(model.subevent_names_)}
        report[label] = out
    if args.json:
        Path(args.json).write_text(json.dumps(report, default=float))


if __name__ == "__main__":
    main()
