"""Where the default ``full`` method's causal reactor spends its CPU time, per frame, by part.

Wraps the reactor's parts (the body fit, the interaction primitive's stream, the synthesizer's ``observe`` and
``step`` with its re-planning, forward belief and contact pull, the motion features, the switching regression's rows
and displacement) with ``time.thread_time`` accumulators, steps the reactor as the causal protocol does (views from a
:class:`~socialaff_sim.data.growing.GrowingInteraction`, agent 1 hidden after T0) and prints each part's CPU ms per
frame and share. Parts named ``step.*`` are inside ``step``. The model is a pickle written by
``scripts/bench_reactor.py --model PATH``.

    OMP_NUM_THREADS=1 nice -n 10 python scripts/profile_reactor.py --model /tmp/ho.pkl \\
        --data handover:../shared/data/handover_h2h --skip 40 --recordings 5
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import os
import pickle
import sys
import time
from collections.abc import Callable

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from socialaff_sim.data.growing import GrowingInteraction  # noqa: E402
from socialaff_sim.data.specs import load_dataset  # noqa: E402
from socialaff_sim.inference import body_fit, methods, primitive_stream, reaction_features, switching, synthesis  # noqa: E402
from socialaff_sim.inference.protocol import observed_part  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_stream import concatenate  # noqa: E402
from _reactor_args import add_reactor_source_arguments, add_setting_argument, changed_synthesis  # noqa: E402

T0 = 10
PARTS: list[tuple[object, str, str]] = [
    (body_fit.BodyFitter, "fit_poses", "body fit"),
    (primitive_stream.PrimitiveStream, "react_keys", "primitive"),
    (synthesis.OnlineSynthesizer, "observe", "observe"),
    (synthesis.OnlineSynthesizer, "step", "step"),
    (synthesis.OnlineSynthesizer, "_replan", "step.replan"),
    (synthesis.OnlineSynthesizer, "_advance_belief", "step.belief"),
    (synthesis.OnlineSynthesizer, "_pull_contacts", "step.contacts"),
    (reaction_features.FeatureStream, "rows", "feature rows"),
    (switching.SwitchingRegression, "displacement", "displacement"),
    (methods, "switching_rows", "switching rows"),
    (methods, "plan_displacement", "plan displacement"),
    (methods, "plan_offset", "plan offset"),
]


def _timed(f: Callable, label: str, acc: dict[str, float]) -> Callable:
    @functools.wraps(f)
    def g(*a: object, **k: object) -> object:
        c0 = time.thread_time()
        try:
            return f(*a, **k)
        finally:
            acc[label] = acc.get(label, 0.0) + time.thread_time() - c0
    return g


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_reactor_source_arguments(p, seconds=0.0)
    p.add_argument("--overrun-delta-t", action="store_true", help="the reactor with SynthesisConfig.overrun_delta_t")
    add_setting_argument(p, "the pickled method's synthesis")
    args = p.parse_args()
    acc: dict[str, float] = {}
    for owner, name, label in PARTS:
        setattr(owner, name, _timed(getattr(owner, name), label, acc))
    with open(args.model, "rb") as f:
        method = pickle.load(f)
    if args.overrun_delta_t:
        method.synthesis = dataclasses.replace(method.synthesis, overrun_delta_t=True)
    if args.set:
        method.synthesis = changed_synthesis(method.synthesis, args.set, p)
        print(f"synthesis changed: {', '.join(args.set)}")
    data = load_dataset(args.data)
    label = args.interaction or data[0].label
    pool = [i for i in data if i.label == label][args.skip : args.skip + args.recordings]
    insts = [concatenate(pool, int(args.seconds * pool[0].fps), "stream")] if args.seconds > 0 else pool
    total, n = 0.0, 0
    for inst in insts:
        hidden = observed_part(inst, T0)
        views = GrowingInteraction(hidden)
        reactor = method.start(n_observed=T0, offline=False, rng=np.random.default_rng(0))
        for t in range(T0, inst.n_frames):
            views.append_from(hidden, t + 1)
            view = views.view()
            c0 = time.thread_time()
            reactor.react(view, t, t + 1)
            total += time.thread_time() - c0
            n += 1
    print(f"{n} calls: {total / n * 1e3:.3f} ms CPU per frame, {n / total:.0f} frames/CPU s; load {os.getloadavg()}")
    for label, v in sorted(acc.items(), key=lambda kv: -kv[1]):
        print(f"  {label:18s} {v / n * 1e3:7.3f} ms/frame  {100 * v / total:5.1f} %")
    print(f"  {'rest of react':18s} {(total - sum(v for k, v in acc.items() if '.' not in k)) / n * 1e3:7.3f} ms/frame")


if __name__ == "__main__":
    main()
