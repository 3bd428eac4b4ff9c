"""Paired CPU time of two code trees' causal reactors in one process (issue 24: speed work on a loaded, shared machine).

On the shared 2-core machine the same run's CPU time varies by up to 2× with the other jobs' load, so two trees timed
one after the other differ by the load as much as by their code. This script loads tree A's package, starts its
reactor (the default ``full`` method from a pickle, as ``scripts/bench_reactor.py --model`` writes it) on the
recordings or their stream, then does the same with tree B's package (each tree's classes keep their own module
globals), and steps both on the same frames in alternated blocks (A then B, then B then A: no first-mover bias), so
that both see the same machine state. It prints each tree's CPU ms per frame (and per call: p50, p99, max), the
per-block ratio B/A (median and quartiles) and per-stage CPU per frame (``time.thread_time`` around the same methods as
``scripts/profile_reactor.py``). Stages whose code the two trees share should come out at B/A ≈ 1: the check that
the pairing is fair. ``--set FIELD=VALUE`` changes tree B's synthesis (``--a`` and ``--b`` the same tree: the paired
cost of a setting). Both trees must import nothing of ``socialaff_sim`` lazily on the reactor's path (a lazy import
would bind to the tree loaded last). Usage::

    OMP_NUM_THREADS=1 nice -n 10 python scripts/ab_reactor.py --a /tmp/main_tree --b . \\
        --model /tmp/models/handover.pkl --data handover:../shared/data/handover_h2h --interaction hand_over \\
        --skip 40 --recordings 5 --seconds 120

The library never imports this script.
"""

from __future__ import annotations

import argparse
import functools
import importlib
import os
import pickle
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from _reactor_args import add_reactor_source_arguments, add_setting_argument, changed_synthesis  # noqa: E402  (scripts/ is sys.path[0] when run as a script)

T0 = 10
PARTS = (
    ("inference.body_fit", "BodyFitter", "fit_poses", "body fit"),
    ("inference.primitive_stream", "PrimitiveStream", "react_keys", "primitive"),
    ("inference.synthesis", "OnlineSynthesizer", "observe", "observe"),
    ("inference.synthesis", "OnlineSynthesizer", "step", "step"),
    ("inference.synthesis", "OnlineSynthesizer", "_replan", "step.replan"),
    ("inference.synthesis", "OnlineSynthesizer", "_advance_belief", "step.belief"),
    ("inference.reaction_features", "FeatureStream", "rows", "feature rows"),
)


def _load(tree: str, args: argparse.Namespace, acc: dict[str, float], settings: tuple[str, ...] | list[str] = (),
          parser: argparse.ArgumentParser | None = None) -> list[tuple]:
    """Import ``tree``'s package afresh, time its parts into ``acc`` and start its reactors: (frames, hidden, views,
    reactor) per instance; ``settings``: ``--set`` changes of the method's synthesis."""
    tree = os.path.abspath(tree)
    for k in [k for k in sys.modules if k == "socialaff_sim" or k.startswith("socialaff_sim.") or k == "bench_stream"]:
        del sys.modules[k]
    paths = [tree, os.path.join(tree, "scripts")]
    sys.path[:0] = paths
    try:
        import socialaff_sim

        if not os.path.abspath(socialaff_sim.__file__).startswith(tree + os.sep):
            raise SystemExit(f"--a/--b {tree}: imported socialaff_sim from {socialaff_sim.__file__} instead")
        for mod, cls, name, label in PARTS:
            owner = getattr(importlib.import_module("socialaff_sim." + mod), cls)
            f = getattr(owner, name)

            def g(*a: object, _f=f, _label=label, **k: object) -> object:  # noqa: ANN001
                c0 = time.thread_time()
                try:
                    return _f(*a, **k)
                finally:
                    acc[_label] = acc.get(_label, 0.0) + time.thread_time() - c0

            setattr(owner, name, functools.wraps(f)(g))
        from bench_stream import concatenate
        from socialaff_sim.data.growing import GrowingInteraction
        from socialaff_sim.data.specs import load_dataset
        from socialaff_sim.inference.protocol import observed_part

        with open(args.model, "rb") as fh:
            method = pickle.load(fh)
        if settings:
            method.synthesis = changed_synthesis(method.synthesis, list(settings), parser)  # type: ignore[arg-type]
        data = load_dataset(args.data)
        label = args.interaction or data[0].label
        pool = [i for i in data if i.label == label][args.skip : args.skip + args.recordings]
        insts = [concatenate(pool, int(round(args.seconds * pool[0].fps)), "stream")] if args.seconds > 0 else pool
        out = []
        for inst in insts:
            hidden = observed_part(inst, T0)
            reactor = method.start(n_observed=T0, offline=False, rng=np.random.default_rng(args.seed))
            out.append((inst.n_frames, hidden, GrowingInteraction(hidden), reactor))
        return out
    finally:
        for p in paths:
            sys.path.remove(p)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--a", required=True, help="tree A (the reference, e.g. a worktree of main)")
    p.add_argument("--b", required=True, help="tree B (the candidate)")
    add_reactor_source_arguments(p, seconds=120.0)
    add_setting_argument(p, "tree B's method (A runs the pickled one): the paired cost of a setting, --a and --b the same tree")
    p.add_argument("--block", type=int, default=100, help="frames per block (each tree steps a block in turn)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--by-index", type=int, default=0, metavar="K",
                   help="also print each tree's CPU per call by frame index (0: the first call after T0), median and "
                        "max over the recordings, for the first K calls of each")
    args = p.parse_args()
    acc: dict[str, dict[str, float]] = {"a": {}, "b": {}}
    runs = {k: _load(getattr(args, k), args, acc[k], args.set if k == "b" else [], p) for k in ("a", "b")}
    blocks: dict[str, list[float]] = {"a": [], "b": []}
    per_frame: dict[str, list[float]] = {"a": [], "b": []}
    by_index: dict[str, dict[int, list[float]]] = {"a": {}, "b": {}}
    frames = 0
    for i in range(len(runs["a"])):
        T = runs["a"][i][0]
        for j, lo in enumerate(range(T0, T, args.block)):
            hi = min(lo + args.block, T)
            for k in ("a", "b") if j % 2 == 0 else ("b", "a"):
                _, hidden, views, reactor = runs[k][i]
                c = 0.0
                for t in range(lo, hi):
                    views.append_from(hidden, t + 1)
                    view = views.view()
                    c0 = time.thread_time()
                    reactor.react(view, t, t + 1)
                    dt = time.thread_time() - c0
                    c += dt
                    per_frame[k].append(dt)
                    by_index[k].setdefault(t - T0, []).append(dt)
                blocks[k].append(c)
            frames += hi - lo
    a, b = np.array(blocks["a"]), np.array(blocks["b"])
    r = b / a
    print(f"{frames} frames in {a.size} paired blocks of {args.block}; load {tuple(round(x, 2) for x in os.getloadavg())}")
    print(f"A {args.a}: {a.sum() / frames * 1e3:.3f} ms CPU per frame, {frames / a.sum():.0f} frames/CPU s")
    print(f"B {args.b}{' with ' + ', '.join(args.set) if args.set else ''}: {b.sum() / frames * 1e3:.3f} ms CPU per frame, "
          f"{frames / b.sum():.0f} frames/CPU s")
    for k in ("a", "b"):  # CPU per call: on a loaded machine the tail is the load's as much as the code's
        x = np.array(per_frame[k]) * 1e3
        print(f"{k.upper()} per frame: p50 {np.percentile(x, 50):.3f}, p99 {np.percentile(x, 99):.3f}, max {x.max():.2f} ms CPU")
    for k in ("a", "b") if args.by_index else ():
        idx = sorted(by_index[k])[: args.by_index]
        print(f"{k.upper()} per call by index, median ms CPU: " + " ".join(f"{np.median(by_index[k][i]) * 1e3:.2f}" for i in idx))
        print(f"{k.upper()} per call by index, max ms CPU:    " + " ".join(f"{max(by_index[k][i]) * 1e3:.2f}" for i in idx))
    first = {k: per_frame[k][0] for k in ("a", "b")}  # each tree's first call: set-up, a JIT compile
    print(f"without each tree's first call: A {(a.sum() - first['a']) / (frames - 1) * 1e3:.3f}, "
          f"B {(b.sum() - first['b']) / (frames - 1) * 1e3:.3f} ms CPU per frame, "
          f"B/A {(b.sum() - first['b']) / (a.sum() - first['a']):.3f} (first calls: A {first['a'] * 1e3:.1f}, "
          f"B {first['b'] * 1e3:.1f} ms)")
    print(f"B/A: total {b.sum() / a.sum():.3f}; per block median {np.median(r):.3f} (quartiles {np.percentile(r, 25):.3f}–{np.percentile(r, 75):.3f})")
    for *_, label in PARTS:
        ta, tb = acc["a"].get(label, 0.0) / frames * 1e3, acc["b"].get(label, 0.0) / frames * 1e3
        print(f"  {label:14s} A {ta:6.3f}  B {tb:6.3f} ms/frame  B/A {tb / ta if ta else float('nan'):.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
