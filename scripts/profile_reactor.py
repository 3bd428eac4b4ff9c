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
import cProfile
import dataclasses
import functools
import io
import os
import pickle
import pstats
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
    p.add_argument("--by-index", type=int, default=0, metavar="K", help="CPU per call by frame index, first K calls")
    p.add_argument("--frames", default=None, metavar="LO:HI", help="time only the calls of index LO ≤ i < HI")
    p.add_argument("--cprofile", type=int, default=0, metavar="N", help="cProfile those calls; print N functions")
    args = p.parse_args()
    lo, hi = 0, None
    if args.frames is not None:
        try:
            lo_s, hi_s = args.frames.split(":")
            lo, hi = int(lo_s or 0), (int(hi_s) if hi_s else None)
        except ValueError:
            p.error(f"--frames {args.frames!r}: expected LO:HI (integers, either may be empty)")
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
    prof = cProfile.Profile(time.thread_time) if args.cprofile else None
    total, n, start_cpu = 0.0, 0, 0.0
    by_index: list[list[float]] = []
    for inst in insts:
        hidden = observed_part(inst, T0)
        views = GrowingInteraction(hidden)
        c0 = time.thread_time()
        reactor = method.start(n_observed=T0, offline=False, rng=np.random.default_rng(0))
        start_cpu += time.thread_time() - c0
        calls = []
        for t in range(T0, inst.n_frames):
            views.append_from(hidden, t + 1)
            view = views.view()
            on = lo <= t - T0 and (hi is None or t - T0 < hi)
            if not on:  # stepped, not timed: the parts' accumulators are reset after it
                before = dict(acc)
                reactor.react(view, t, t + 1)
                acc.clear()
                acc.update(before)
                continue
            if prof is not None:
                prof.enable()
            c0 = time.thread_time()
            reactor.react(view, t, t + 1)
            dt = time.thread_time() - c0
            if prof is not None:
                prof.disable()
            total += dt
            n += 1
            calls.append(dt)
        by_index.append(calls)
    if not n:
        p.error("--frames: no call in that range")
    print(f"{n} calls: {total / n * 1e3:.3f} ms CPU per frame, {n / total:.0f} frames/CPU s; load {os.getloadavg()}")
    print(f"  method.start: {start_cpu / len(insts) * 1e3:.3f} ms CPU per recording (not in the calls' figures)")
    if args.by_index:
        k = min(args.by_index, max(len(c) for c in by_index))
        med = [np.median([c[i] for c in by_index if len(c) > i]) * 1e3 for i in range(k)]
        top = [max(c[i] for c in by_index if len(c) > i) * 1e3 for i in range(k)]
        print(f"  CPU ms per call by index from {lo} (median over {len(by_index)} recordings): "
              + " ".join(f"{x:.2f}" for x in med))
        print("  max: " + " ".join(f"{x:.2f}" for x in top))
    for label, v in sorted(acc.items(), key=lambda kv: -kv[1]):
        print(f"  {label:18s} {v / n * 1e3:7.3f} ms/frame  {100 * v / total:5.1f} %")
    print(f"  {'rest of react':18s} {(total - sum(v for k, v in acc.items() if '.' not in k)) / n * 1e3:7.3f} ms/frame")
    if prof is not None:
        out = io.StringIO()
        stats = pstats.Stats(prof, stream=out).sort_stats("cumulative")
        stats.print_stats(args.cprofile)
        if os.environ.get("PROFILE_DUMP"):  # the raw profile, for pstats (callers, callees)
            stats.dump_stats(os.environ["PROFILE_DUMP"])
        print(out.getvalue())


if __name__ == "__main__":
    main()
