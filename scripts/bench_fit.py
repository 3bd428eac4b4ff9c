"""Fit time per interaction of an evaluation method (default ``full``), one core, CPU seconds (issue 24).

For each dataset and interaction class asked for, the method is fitted on the training instances of one
fold exactly as ``socialaff-sim evaluate`` builds them (:func:`~socialaff_sim.evaluation.crossval.make_tasks`: the
run seed's folds and the task's own generator; pair split, block split for NuiSI), and the CPU time of the fit
(``time.process_time``: this process alone, so another job on the machine slows the wall clock but not the
figure much) is reported, split into the parts of :meth:`~socialaff_sim.inference.methods.AffordanceMethod.fit`:

* ``learn``: Algorithm 1 (:meth:`SocialAffordanceModel.fit`), the model on all instances and the ``cross_fit``
  models of the switching regression's training plans;
* ``trace``: the synthesizer run causally over the training instances (:func:`~socialaff_sim.inference.methods.trace`);
* ``primitive``: the interaction primitive's fits and causal predictions of the training rows
  (:func:`~socialaff_sim.inference.methods.primitive_trace`, and ``InteractionPrimitive.fit``);
* ``switching``: the switching regression's inner cross-validation and refit;
* ``other``: the rest (the body fitter, canonical tracks, ...).

The parts are timed by wrapping those functions for the run (the library is not changed). ``--stream`` sets
``ProMPConfig.training_stream`` (the default since 2026-11-26; ``--batch-rows`` turns it off); ``--iterations N``
runs every Algorithm 1 fit with N outer Metropolis–Hastings iterations (a model change); ``--cross-fit-type-passes N``
sets ``SwitchingConfig.cross_fit_type_passes`` (the cross-fitted models' restructuring passes; a model change);
``--type-passes N`` sets ``LearningConfig.init_type_passes`` (the model fitted on all instances; a model change);
``--type-screen-rounds N`` sets ``LearningConfig.init_type_screen_rounds`` (a model change); ``--row-stride K`` sets
``SwitchingConfig.row_stride`` (the training rows every K-th frame; a model change); ``--primitive`` times
the interaction primitive's causal predictions alone (:func:`primitive_only`; with ``--stream`` also the stream's). A fingerprint of
the fitted method (the model's learned arrays, the switching regression's members and scales) is printed so that
two code trees can be compared for bitwise-equal fits. Usage::

    OMP_NUM_THREADS=1 nice -n 10 python scripts/bench_fit.py [--datasets synthetic sbu handover nuisi]
        [--classes NAME ...] [--fold 0] [--method full] [--seed 0] [--stream | --batch-rows] [--iterations N]
        [--cross-fit-type-passes N] [--type-passes N] [--type-screen-rounds N] [--row-stride K] [--primitive] [--data-root ../shared/data]
        [--json PATH]

Without ``--classes`` every class of each dataset is fitted (long on the handovers: one class of 112 training
instances). The library never imports this script.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import os
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from socialaff_sim._atomic import atomic_write_text
from socialaff_sim.data import load_dataset
from socialaff_sim.evaluation.crossval import EvaluationConfig, make_method, make_tasks, task_seed
from socialaff_sim.evaluation.registry import get_method
from socialaff_sim.inference import methods as methods_module
from socialaff_sim.data.interaction import Interaction
from socialaff_sim.inference.interaction_primitive import InteractionPrimitive
try:
    from socialaff_sim.inference.primitive_stream import stream_key_joints
except ImportError:  # a tree before wip/fit (the "before" runs of docs/benchmarks.md): no --stream there
    stream_key_joints = None
from socialaff_sim.inference.protocol import DEFAULT_N_OBSERVED
from socialaff_sim.inference.switching import SwitchingRegression
from socialaff_sim.learning.config import LearningConfig
from socialaff_sim.learning.estimator import SocialAffordanceModel

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
DATASETS = {  # name: (spec with {root}, split)
    "synthetic": ("synthetic", "pair"),
    "sbu": ("sbu:{root}/sbu_kinect_interaction", "pair"),
    "handover": ("handover:{root}/handover_h2h", "pair"),
    "nuisi": ("nuisi:{root}/nuisi_v1", "block"),
}


@contextmanager
def timed_parts(seconds: dict[str, float]) -> Iterator[None]:
    """Wrap the fit's parts so that their CPU seconds add up in ``seconds`` (outermost call only)."""
    targets: list[tuple[object, str, str]] = [
        (SocialAffordanceModel, "fit", "learn"),
        (methods_module, "trace", "trace"),
        (methods_module, "primitive_trace", "primitive"),
        (InteractionPrimitive, "fit", "primitive"),
        (SwitchingRegression, "fit", "switching"),
    ]
    saved = [(obj, name, getattr(obj, name)) for obj, name, _ in targets]
    depth = {"n": 0}

    def wrap(f: Callable[..., object], key: str) -> Callable[..., object]:
        def g(*args: object, **kwargs: object) -> object:
            depth["n"] += 1
            tic = time.process_time()
            try:
                return f(*args, **kwargs)
            finally:
                depth["n"] -= 1
                if depth["n"] == 0:
                    seconds[key] = seconds.get(key, 0.0) + time.process_time() - tic
        return g

    for obj, name, key in targets:
        setattr(obj, name, wrap(getattr(obj, name), key))
    try:
        yield
    finally:
        for obj, name, f in saved:
            setattr(obj, name, f)


def fingerprint(method: object) -> str:
    """SHA-256 (first 16 hex digits) of the fitted method's learned arrays: the model's parses, groupings,
    centroids and log posterior, and the switching regression's members and column scales."""
    h = hashlib.sha256()

    def feed(value: object) -> None:
        if isinstance(value, np.ndarray):
            h.update(str((value.dtype, value.shape)).encode() + np.ascontiguousarray(value).tobytes())
        elif isinstance(value, (list, tuple)):
            for v in value:
                feed(v)
        elif isinstance(value, dict):
            for k in sorted(value, key=repr):
                h.update(repr(k).encode())
                feed(value[k])
        else:
            h.update(repr(value).encode())

    model = getattr(method, "model_", None)
    if model is not None:
        for key in sorted(vars(model)):
            if key.endswith("_") and key != "fit_seconds_":
                h.update(key.encode())
                feed(getattr(model, key))
    reaction = getattr(method, "reaction_", None)
    if reaction is not None:
        h.update(reaction.scale_.tobytes())
        for m in reaction.members_:
            h.update(repr((m.family, m.groups, m.penalty, m.weight)).encode() + m.columns.tobytes() + m.coefficients.tobytes())
    return h.hexdigest()[:16]


def primitive_only(train: list[Interaction], stream: bool) -> dict[str, float]:
    """The interaction primitive's part alone: fitted on every other training instance (``train[0::2]``), its causal
    predictions of the others (``train[1::2]``, every frame ≥ T0) by the batch path and, with ``stream``, by
    :func:`~socialaff_sim.inference.primitive_stream.stream_key_joints`: CPU seconds and the largest difference (m)."""
    prim = InteractionPrimitive().fit(train[0::2])
    out = {"frames": 0.0, "batch_s": 0.0, "stream_s": 0.0, "max_diff_m": 0.0}
    for inst in train[1::2]:
        tic = time.process_time()
        batch = prim.causal_key_joints(inst, DEFAULT_N_OBSERVED)
        out["batch_s"] += time.process_time() - tic
        out["frames"] += max(inst.n_frames - DEFAULT_N_OBSERVED, 0)
        if stream and stream_key_joints is not None:
            tic = time.process_time()
            streamed = stream_key_joints(prim, inst, DEFAULT_N_OBSERVED)
            out["stream_s"] += time.process_time() - tic
            out["max_diff_m"] = max(out["max_diff_m"], float(np.nanmax(np.abs(streamed - batch))))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--datasets", nargs="+", default=["synthetic", "sbu", "handover", "nuisi"], choices=list(DATASETS))
    ap.add_argument("--classes", nargs="*", default=None, help="interaction classes (default: every class)")
    ap.add_argument("--fold", type=int, default=0, help="which of the 4 folds' training set (default 0)")
    ap.add_argument("--method", default="full")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--stream", action="store_true", help="ProMPConfig.training_stream on (the default since 2026-11-26)")
    ap.add_argument("--batch-rows", action="store_true",
                    help="ProMPConfig.training_stream off: the training rows from the batch conditioning (the default before)")
    ap.add_argument("--iterations", type=int, default=None,
                    help="LearningConfig.iterations of every Algorithm 1 run (a model change; default: the preset's)")
    ap.add_argument("--cross-fit-type-passes", type=int, default=None,
                    help="SwitchingConfig.cross_fit_type_passes: restructuring passes of the cross-fitted models (a model change)")
    ap.add_argument("--type-passes", type=int, default=None,
                    help="LearningConfig.init_type_passes of the model fitted on all instances (and of the cross-fitted "
                         "ones unless SwitchingConfig.cross_fit_type_passes sets theirs; a model change)")
    ap.add_argument("--type-screen-rounds", type=int, default=None,
                    help="LearningConfig.init_type_screen_rounds (a model change; default: the preset's)")
    ap.add_argument("--row-stride", type=int, default=None,
                    help="SwitchingConfig.row_stride: the switching regression's training rows every K-th frame (a model change)")
    ap.add_argument("--primitive", action="store_true",
                    help="time only the interaction primitive's causal predictions (see primitive_only)")
    ap.add_argument("--data-root", type=Path, default=DATA)
    ap.add_argument("--json", type=Path, default=None, help="also write the rows here (atomically)")
    args = ap.parse_args(argv)
    rows = []
    print(f"{'dataset':10s} {'class':18s} {'n':>4s} {'frames':>7s} {'fit s':>7s} {'learn':>7s} {'trace':>7s} "
          f"{'primit.':>7s} {'switch':>7s} {'other':>6s}  fingerprint", flush=True)
    for name in args.datasets:
        spec, split = DATASETS[name]
        data = load_dataset(spec.format(root=args.data_root))
        labels = args.classes or list(data.labels)
        config = EvaluationConfig(split=split, seed=args.seed)
        factory = get_method(args.method)
        for label in (lab for lab in labels if lab in data.labels):
            tasks, _, _ = make_tasks(data, [(args.method, factory)], [label], config)
            task = next(t for t in tasks if t.fold == args.fold)
            if args.primitive:
                rows.append({"dataset": name, "class": label, **primitive_only(list(task.train), args.stream)})
                print(f"{name:10s} {label:18s} primitive only: {rows[-1]}", flush=True)
                continue
            method = make_method(task.factory, task.preset)
            if args.stream or args.batch_rows:
                reaction = method.reaction
                method.reaction = dataclasses.replace(
                    reaction, primitive=dataclasses.replace(reaction.primitive, training_stream=not args.batch_rows))
            if args.cross_fit_type_passes is not None:
                method.reaction = dataclasses.replace(method.reaction, cross_fit_type_passes=args.cross_fit_type_passes)
            if args.row_stride is not None:
                method.reaction = dataclasses.replace(method.reaction, row_stride=args.row_stride)
            if args.type_screen_rounds is not None:
                method.learning = dataclasses.replace(method.learning or LearningConfig(),
                                                      init_type_screen_rounds=args.type_screen_rounds)
            if args.iterations is not None:
                method.learning = dataclasses.replace(method.learning or LearningConfig(), iterations=args.iterations)
            if args.type_passes is not None:
                method.learning = dataclasses.replace(method.learning or LearningConfig(), init_type_passes=args.type_passes)
            rng = np.random.default_rng(task_seed(task.seed, task.label, task.fold, task.method))
            parts: dict[str, float] = {}
            load = os.getloadavg()[0]
            with timed_parts(parts):
                tic = time.process_time()
                method.fit(task.train, rng=rng)
                total = time.process_time() - tic
            other = total - sum(parts.values())
            frames = sum(i.n_frames for i in task.train)
            row = {"dataset": name, "class": label, "fold": args.fold, "instances": len(task.train), "frames": frames,
                   "fit_cpu_s": total, **{f"{k}_s": v for k, v in parts.items()}, "other_s": other,
                   "load_before": load, "fingerprint": fingerprint(method)}
            rows.append(row)
            print(f"{name:10s} {label:18s} {len(task.train):4d} {frames:7d} {total:7.1f} {parts.get('learn', 0):7.1f} "
                  f"{parts.get('trace', 0):7.1f} {parts.get('primitive', 0):7.1f} {parts.get('switching', 0):7.1f} "
                  f"{other:6.1f}  {row['fingerprint']}", flush=True)
    if args.json:
        settings = {"method": args.method, "seed": args.seed, "fold": args.fold, "stream": args.stream,
                    "iterations": args.iterations, "cross_fit_type_passes": args.cross_fit_type_passes,
                    "type_passes": args.type_passes, "type_screen_rounds": args.type_screen_rounds,
                    "row_stride": args.row_stride,
                    "clock": "CPU (time.process_time)", "omp_num_threads": os.environ.get("OMP_NUM_THREADS")}
        atomic_write_text(args.json, json.dumps({"settings": settings, "rows": rows}, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
