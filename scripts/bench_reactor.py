"""Per-frame cost of the default ``full`` method's causal reactor, and of its interaction primitive, against elapsed time.

The reactor is the one the evaluation steps under ``--protocol causal`` (``method.start(...)``, then
``react(view, t, t + 1)`` with the view of frames [0, t] and agent 1 hidden after T0, as
:func:`~socialaff_sim.evaluation.streaming.run_protocol` calls it). Each call's CPU time (``time.thread_time``)
is recorded; per elapsed minute of the stream (per recording for the recordings) the p50, p99 and max, and overall
the frames per CPU second. The views come from a :class:`~socialaff_sim.data.growing.GrowingInteraction` filled
frame by frame, as the evaluation makes them (``protocol_view`` copied and validated the whole view, 70 ms at 18,000
frames); building each view is timed separately (``view_*`` figures), not in the reactor's. At each minute's end (and
after each run) the bytes of the NumPy buffers the reactor holds are recorded (:func:`state_bytes`: each buffer once at
its capacity; not the fitted method, not the evaluation's views, whose buffers are ``views_bytes_end``), not timed.

Two interaction-primitive paths are timed, on the same views:
``stream`` — :class:`~socialaff_sim.inference.primitive_stream.PrimitiveStream` (running sums; the reactor's path
since it was added) and ``batch`` — :meth:`InteractionPrimitive.react_keys` recomputing everything from the view
(the reactor's path at commit 7f68f7b). ``--overrun on`` runs the reactor with ``SynthesisConfig.overrun_delta_t`` (``both``: every run with it off, then on,
alternated). ``--part primitive`` times the primitive alone; ``--part reactor`` times
the whole reactor with each path (``batch`` swaps the reactor's stream for a call of ``react_keys``, exactly the
code of 7f68f7b). The batch path's cost grows with the frames seen: on the long stream it runs for
``--batch-minutes`` only.

    OMP_NUM_THREADS=1 nice -n 10 python scripts/bench_reactor.py --data handover:../shared/data/handover_h2h \\
        --fit 40 --recordings 5 --minutes 10 --json reactor.json
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import pickle
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from socialaff_sim._atomic import atomic_write_text  # noqa: E402
from socialaff_sim.data.growing import GrowingInteraction  # noqa: E402
from socialaff_sim.data.interaction import Interaction  # noqa: E402
from socialaff_sim.data.specs import load_dataset  # noqa: E402
from socialaff_sim.evaluation.registry import get_method  # noqa: E402
from socialaff_sim.inference.interaction_primitive import InteractionPrimitive  # noqa: E402
from socialaff_sim.inference.primitive_stream import PrimitiveStream  # noqa: E402
from socialaff_sim.inference.protocol import observed_part  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_stream import concatenate, reference_seconds  # noqa: E402

T0 = 10


class BatchPrimitive:
    """The primitive path of commit 7f68f7b: :meth:`InteractionPrimitive.react_keys` on the whole view."""

    def __init__(self, primitive: InteractionPrimitive, n_observed: int) -> None:
        self.primitive, self.n_observed = primitive, n_observed

    def react_keys(self, view: Interaction, start: int, stop: int) -> np.ndarray:
        return self.primitive.react_keys(view, start, stop, n_observed=self.n_observed)


def _children(x: object) -> list:
    if isinstance(x, dict):
        return [*x.keys(), *x.values()]
    if isinstance(x, (list, tuple, set, frozenset)):
        return list(x)
    return list(vars(x).values()) if hasattr(x, "__dict__") else []


def _reachable(objs: tuple[object, ...]) -> set[int]:
    """Ids of every object reachable from ``objs`` (attributes, containers; arrays and their bases)."""
    seen: set[int] = set()
    stack = list(objs)
    while stack:
        x = stack.pop()
        if id(x) in seen:
            continue
        seen.add(id(x))
        if isinstance(x, np.ndarray):
            if isinstance(x.base, np.ndarray):
                stack.append(x.base)
        elif not isinstance(x, (str, bytes, int, float, bool, type(None), np.random.Generator)):
            stack.extend(_children(x))
    return seen


def state_bytes(obj: object, exclude: tuple[object, ...]) -> int:
    """Bytes of the NumPy buffers reachable from ``obj`` (attributes, containers), each buffer counted once at its
    capacity (a view counts its base), not reaching into ``exclude`` (the fitted method: shared, fixed; nothing
    reachable from it is counted, also when the reactor holds it, e.g. the model and the primitive) nor into the
    view the reactor was last handed (the evaluation's frames, counted apart)."""
    seen: set[int] = _reachable(exclude)
    total, stack = 0, [obj]
    while stack:
        x = stack.pop()
        if id(x) in seen or isinstance(x, (str, bytes, int, float, bool, type(None), np.random.Generator)):
            continue
        seen.add(id(x))
        if isinstance(x, np.ndarray):
            base = x
            while isinstance(base.base, np.ndarray):
                base = base.base
            if base is not x:
                stack.append(base)
            else:
                total += x.nbytes
            continue
        if isinstance(x, Interaction):
            continue
        if isinstance(x, dict):
            stack.extend(x.keys())
            stack.extend(x.values())
        elif isinstance(x, (list, tuple, set, frozenset)):
            stack.extend(x)
        elif hasattr(x, "__dict__"):
            stack.extend(vars(x).values())
    return total


def _stats(ms: np.ndarray) -> dict[str, float]:
    if ms.size == 0:
        return {"frames": 0}
    return {"frames": int(ms.size), "p50_ms": float(np.percentile(ms, 50)), "p99_ms": float(np.percentile(ms, 99)),
            "max_ms": float(ms.max()), "frames_per_cpu_s": float(ms.size / max(ms.sum() / 1e3, 1e-12))}


def run(method, inst: Interaction, *, part: str, path: str, seconds: float | None, seed: int) -> dict:
    """CPU ms of every causal call on ``inst`` (up to ``seconds`` of it), summarized per elapsed minute."""
    hidden = observed_part(inst, T0)
    T = inst.n_frames if seconds is None else min(inst.n_frames, int(round(seconds * inst.fps)))
    if part == "reactor":
        reactor = method.start(n_observed=T0, offline=False, rng=np.random.default_rng(seed))
        if path == "batch":
            reactor.primitive = BatchPrimitive(method.primitive_, T0)
        call = reactor.react
    else:
        prim = (PrimitiveStream if path == "stream" else BatchPrimitive)(method.primitive_, T0)
        call = prim.react_keys
    ms, view_ms = np.full(T, np.nan), np.full(T, np.nan)
    load, ref = os.getloadavg(), reference_seconds(np.random.default_rng(0))
    views = GrowingInteraction(hidden)
    edges = np.r_[np.arange(0, T, int(60 * inst.fps)), T]
    owner = reactor if part == "reactor" else prim
    memory: dict[int, int] = {}  # frame → bytes of the reactor's state after it (not timed)
    for t in range(T0, T):
        c0 = time.thread_time()
        views.append_from(hidden, t + 1)
        view = views.view()
        c1 = time.thread_time()
        call(view, t, t + 1)
        ms[t], view_ms[t] = (time.thread_time() - c1) * 1e3, (c1 - c0) * 1e3
        if t + 1 in edges:
            memory[t] = state_bytes(owner, (method,))
    minutes = [{"minute": k, **_stats(ms[max(edges[k], T0):edges[k + 1]]), "state_bytes_at_end": memory.get(int(edges[k + 1]) - 1)}
               for k in range(len(edges) - 1)]
    views_ = {f"view_{k}": v for k, v in _stats(view_ms[T0:]).items() if k != "frames"}
    return {"instance": inst.instance_id, "part": part, "path": path, "frames": T, **_stats(ms[T0:]), **views_,
            "state_bytes_end": state_bytes(owner, (method,)), "views_bytes_end": state_bytes(views, ()),
            "per_minute": minutes, "load_avg_1_5_15": [round(x, 2) for x in load], "reference_ms": ref * 1e3}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", default="synthetic")
    p.add_argument("--interaction", default=None, help="label (default: the dataset's first)")
    p.add_argument("--fit", type=int, default=40, help="fit `full` on the first N recordings of the label")
    p.add_argument("--recordings", type=int, default=5, help="time the next N recordings (held out of the fit)")
    p.add_argument("--minutes", type=float, default=10.0, help="and a stream of the held-out recordings end to end")
    p.add_argument("--batch-minutes", type=float, default=1.0, help="the batch path on the long stream: its first minutes")
    p.add_argument("--part", default="primitive,reactor")
    p.add_argument("--paths", default="stream,batch", help="primitive paths to time (module docstring)")
    p.add_argument("--model", default=None, help="pickle of the fitted method: read if present, else written")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", default=None)
    p.add_argument("--overrun", default="off", choices=("off", "on", "both"),
                   help="SynthesisConfig.overrun_delta_t of the reactor (both: each run with off, then on)")
    args = p.parse_args()
    data = load_dataset(args.data)
    label = args.interaction or data[0].label
    pool = [i for i in data if i.label == label]
    train, test = pool[: args.fit], pool[args.fit : args.fit + args.recordings]
    out: dict = {"data": args.data, "interaction": label, "fit": len(train), "date_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
                 "omp_num_threads": os.environ.get("OMP_NUM_THREADS"), "clock": "CPU (time.thread_time) per react call", "runs": []}
    if args.model and os.path.exists(args.model):
        with open(args.model, "rb") as f:
            method = pickle.load(f)
    else:
        c0 = time.process_time()
        method = get_method("full")().fit(train, rng=np.random.default_rng(args.seed))
        out["fit_cpu_s"] = time.process_time() - c0
        print(f"fit: {len(train)} recordings, {out['fit_cpu_s']:.0f} s CPU", flush=True)
        if args.model:
            with open(args.model, "wb") as f:
                pickle.dump(method, f)
    print(f"interaction primitive: T_max {int(method.primitive_.durations_.max())} frames", flush=True)
    streams: list[tuple[str, Interaction]] = [("recording", i) for i in test]
    if args.minutes > 0:
        n = int(round(args.minutes * 60 * test[0].fps))
        streams.append(("stream", concatenate(test, n, f"{label}_{args.minutes:g}min")))
    synthesis = method.synthesis
    modes = {"off": [False], "on": [True], "both": [False, True]}[args.overrun]
    for part in [x for x in args.part.split(",") if x]:
        for path in [x for x in args.paths.split(",") if x]:
            for (kind, inst), overrun in [(x, o) for x in streams for o in modes]:
                secs = args.batch_minutes * 60 if (kind == "stream" and path == "batch") else None
                method.synthesis = dataclasses.replace(synthesis, overrun_delta_t=overrun)
                r = {"kind": kind, "overrun_delta_t": overrun,
                     **run(method, inst, part=part, path=path, seconds=secs, seed=args.seed)}
                out["runs"].append(r)
                print(f"[{part}/{path}{'/overrun ΔT' if overrun else ''}] {kind} {r['instance']}: {r['frames']} frames, {r['frames_per_cpu_s']:.0f} frames/CPU s, "
                      f"p50 {r['p50_ms']:.2f} p99 {r['p99_ms']:.2f} max {r['max_ms']:.1f} ms (view: p99 {r['view_p99_ms']:.3f} "
                      f"max {r['view_max_ms']:.2f} ms); state {r['state_bytes_end'] / 1e6:.2f} MB (views {r['views_bytes_end'] / 1e6:.2f} MB); "
                      f"load {r['load_avg_1_5_15']}, "
                      f"reference {r['reference_ms']:.1f} ms", flush=True)
                if kind == "stream":
                    for m in r["per_minute"]:
                        print(f"    minute {m['minute']:>2}: p50 {m['p50_ms']:6.2f} p99 {m['p99_ms']:6.2f} max {m['max_ms']:6.1f} ms, "
                              f"{m['frames_per_cpu_s']:.0f} frames/CPU s, state {m['state_bytes_at_end'] / 1e6:.2f} MB", flush=True)
                if args.json:
                    atomic_write_text(args.json, json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
