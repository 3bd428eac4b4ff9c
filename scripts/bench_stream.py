"""Online synthesis latency against elapsed time, on recordings and on long streams.

Steps :class:`~socialaff_sim.inference.synthesis.OnlineSynthesizer` frame by frame (as the simulator
does) and records the wall time of every ``step()``: per elapsed minute (or per quarter of a
recording) the mean, p50, p99 and max latency and the process's resident memory, and overall the
frames per second and p50/p99. Streams are built by concatenating recordings of one interaction end
to end (``--minutes`` at the data's frame rate; ``--repeat K`` instead repeats the longest recording K
times, the figure of issue 24). A fixed NumPy reference workload is timed in the same process before
each part, so that the figures can be read against the machine's load at that moment.

    OMP_NUM_THREADS=1 python scripts/bench_stream.py --data handover:../shared/data/handover_h2h \\
        --interaction hand_over --fit 60 --minutes 10 --json stream.json

``--model PATH`` reads a saved model instead of fitting one (``--fit N`` fits on the first N
recordings, seed ``--seed``, and also reports the fit's CPU time per interaction). ``--synthesis``:
``reactive`` (:meth:`SynthesisConfig.reactive`, causal, the simulator's setting) and/or ``paper``
(``SynthesisConfig()``). ``--window`` overrides :attr:`SynthesisConfig.parse_window`.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from socialaff_sim._atomic import atomic_write_text  # noqa: E402
from socialaff_sim.data.interaction import Interaction  # noqa: E402
from socialaff_sim.data.specs import load_dataset  # noqa: E402
from socialaff_sim.inference import OnlineSynthesizer, SynthesisConfig  # noqa: E402
from socialaff_sim.learning import SocialAffordanceModel  # noqa: E402
from socialaff_sim.learning.config import LearningConfig  # noqa: E402
from socialaff_sim.learning.estimator import load_model  # noqa: E402
from socialaff_sim.learning.model_io import save_model  # noqa: E402

MODES = {"reactive": SynthesisConfig.reactive, "paper": SynthesisConfig}


def concatenate(parts: list[Interaction], n_frames: int, instance_id: str) -> Interaction:
    """One instance of exactly ``n_frames`` frames: ``parts`` end to end, cycled as often as needed."""
    joints, valid, objs = [], [], []
    total, k = 0, 0
    while total < n_frames:
        p = parts[k % len(parts)]
        joints.append(p.joints)
        valid.append(np.ones(p.joints.shape[:3], bool) if p.valid is None else p.valid)
        objs.append(p.object)
        total += p.n_frames
        k += 1
    has_obj = all(o is not None for o in objs)
    return parts[0].replace(
        joints=np.concatenate(joints)[:n_frames],
        valid=np.concatenate(valid)[:n_frames],
        object=np.concatenate(objs)[:n_frames] if has_obj else None,
        subevents=None,
        subevent_names=(),
        instance_id=instance_id,
        source=f"{k} recordings concatenated",
    )


def reference_seconds(rng: np.random.Generator) -> float:
    """Wall seconds of a fixed NumPy workload (200 solves of a 48×48 system): the machine's speed now."""
    a = rng.standard_normal((48, 48)) + 48 * np.eye(48)
    b = rng.standard_normal(48)
    start = time.perf_counter()
    for _ in range(200):
        np.linalg.solve(a, b)
    return time.perf_counter() - start


def _rss_mib() -> float:
    """Resident memory of this process, MiB (Linux /proc; NaN elsewhere)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
    except OSError:
        return float("nan")


def _stats(ms: np.ndarray) -> dict[str, float]:
    if ms.size == 0:
        return {"frames": 0}
    return {"frames": int(ms.size), "mean_ms": float(ms.mean()), "p50_ms": float(np.percentile(ms, 50)),
            "p99_ms": float(np.percentile(ms, 99)), "max_ms": float(ms.max())}


def run_stream(model: SocialAffordanceModel, inter: Interaction, cfg: SynthesisConfig, *, seed: int,
               parts: int | None = None) -> dict:
    """Step the synthesizer over ``inter``; latency per part (``parts`` equal parts, else per minute)."""
    syn = OnlineSynthesizer(model, None, cfg)
    syn.reset(inter, rng=np.random.default_rng(seed))
    T = inter.n_frames
    ms = np.empty(T)
    cpu = np.empty(T)
    rss = []
    edges = (np.linspace(0, T, parts + 1).astype(int) if parts else np.r_[np.arange(0, T, int(60 * inter.fps)), T])
    load = os.getloadavg()
    ref = reference_seconds(np.random.default_rng(0))
    start = time.perf_counter()
    rows = 0
    for t in range(T):
        c0, t0 = time.thread_time(), time.perf_counter()
        syn.step()
        ms[t] = (time.perf_counter() - t0) * 1e3
        cpu[t] = (time.thread_time() - c0) * 1e3
        rows = max(rows, syn.belief_rows or 0)
        if t + 1 in edges:
            rss.append(_rss_mib())
    wall = time.perf_counter() - start
    synth = ms[cfg.n_observed:]
    cpu_synth = cpu[cfg.n_observed:]
    per = []
    for k in range(len(edges) - 1):
        lo, hi = max(edges[k], cfg.n_observed), edges[k + 1]
        per.append({**_stats(ms[lo:hi]), "cpu": _stats(cpu[lo:hi]), "span": [int(edges[k]), int(hi)], "rss_mib": rss[k]})
    return {"instance": inter.instance_id, "n_frames": T, "fps": inter.fps, "wall_s": wall,
            "frames_per_s": T / wall, **_stats(synth), "cpu_s": float(cpu.sum() / 1e3),
            "frames_per_cpu_s": T / max(float(cpu.sum() / 1e3), 1e-9), "cpu": _stats(cpu_synth), "parts": per,
            "load_avg_1_5_15": [round(x, 2) for x in load], "reference_s": ref,
            "parse_totals": dict(syn.work.totals) if getattr(syn, "work", None) is not None else {},
            "belief_rows_max": rows}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", default="synthetic", help="dataset spec (e.g. handover:PATH, synthetic)")
    p.add_argument("--interaction", default=None, help="interaction label (default: the dataset's first)")
    p.add_argument("--model", default=None, help="a saved model (else one is fitted)")
    p.add_argument("--fit", type=int, default=18, help="fit on the first N recordings of the label")
    p.add_argument("--iterations", type=int, default=None, help="outer MCMC iterations of the fit (default: the default)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--synthesis", default="reactive,paper", help="comma-separated modes of " + ", ".join(MODES))
    p.add_argument("--window", type=float, default=None, help="override SynthesisConfig.parse_window (seconds; 0 = unbounded)")
    p.add_argument("--minutes", type=float, default=10.0, help="length of the concatenated stream (0: none)")
    p.add_argument("--repeat", type=int, default=0, help="also a stream of the longest recording repeated K times")
    p.add_argument("--recordings", type=int, default=0, help="also step over the first N recordings (quarters)")
    p.add_argument("--save-model", default=None, help="also save the fitted model here")
    p.add_argument("--json", default=None, help="write the results here (atomically)")
    args = p.parse_args()
    data = load_dataset(args.data)
    label = args.interaction or data[0].label
    pool = [i for i in data if i.label == label]
    if not pool:
        p.error(f"--interaction: no recording labelled {label!r} in {args.data}")
    out: dict = {"data": args.data, "interaction": label, "seed": args.seed, "machine_cpus": os.cpu_count(),
                 "date_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
                 "clock": "wall (time.perf_counter) per step()", "omp_num_threads": os.environ.get("OMP_NUM_THREADS")}
    if args.model:
        model = load_model(args.model)
    else:
        learning = LearningConfig() if args.iterations is None else LearningConfig(iterations=args.iterations)
        train = pool[: args.fit]
        c0 = time.process_time()
        model = SocialAffordanceModel(learning=learning).fit(train, rng=np.random.default_rng(args.seed))
        cpu = time.process_time() - c0
        out["fit"] = {"instances": len(train), "cpu_s": cpu, "cpu_s_per_instance": cpu / len(train),
                      "load_avg_1_5_15": [round(x, 2) for x in os.getloadavg()]}
        if args.save_model:
            save_model(model, args.save_model)
        print(f"fit: {len(train)} instances, {cpu:.1f} s CPU ({cpu / len(train):.2f} s per instance)", flush=True)
    streams: list[tuple[str, Interaction, int | None]] = []
    for inter in pool[: args.recordings]:
        streams.append(("recording", inter, 4))
    if args.repeat:
        longest = max(pool, key=lambda i: i.n_frames)
        streams.append(("repeat", concatenate([longest], args.repeat * longest.n_frames, f"{longest.instance_id}x{args.repeat}"), 4))
    if args.minutes > 0:
        n = int(round(args.minutes * 60 * pool[0].fps))
        streams.append(("stream", concatenate(pool, n, f"{label}_{args.minutes:g}min"), None))
    out["modes"] = {}
    for mode in [m for m in args.synthesis.split(",") if m]:
        if mode not in MODES:
            p.error(f"--synthesis: unknown mode {mode!r}; choose from {', '.join(MODES)}")
        cfg = MODES[mode]()
        if args.window is not None:
            cfg = dataclasses.replace(cfg, parse_window=args.window if args.window > 0 else None)
        rows = []
        for kind, inter, parts in streams:
            r = {"kind": kind, **run_stream(model, inter, cfg, seed=args.seed, parts=parts)}
            rows.append(r)
            c = r["cpu"]
            print(f"[{mode}] {kind} {r['instance']}: {r['n_frames']} frames, wall {r['frames_per_s']:.0f} frames/s "
                  f"p50 {r['p50_ms']:.2f} p99 {r['p99_ms']:.2f} max {r['max_ms']:.1f} ms; CPU {r['frames_per_cpu_s']:.0f} "
                  f"frames/s p50 {c['p50_ms']:.2f} p99 {c['p99_ms']:.2f} max {c['max_ms']:.1f} ms; "
                  f"load {r['load_avg_1_5_15']}, reference {r['reference_s'] * 1e3:.1f} ms", flush=True)
            for q in r["parts"]:
                print(f"    frames {q['span'][0]:>6}-{q['span'][1]:<6} wall mean {q['mean_ms']:6.2f} p50 {q['p50_ms']:6.2f} "
                      f"p99 {q['p99_ms']:7.2f} max {q['max_ms']:7.1f} | CPU mean {q['cpu']['mean_ms']:6.2f} "
                      f"p99 {q['cpu']['p99_ms']:7.2f} ms | rss {q['rss_mib']:.0f} MiB", flush=True)
        out["modes"][mode] = {"config": dataclasses.asdict(cfg), "runs": rows}
    if args.json:
        atomic_write_text(args.json, json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
