"""The default ``full`` method's causal reactor: its outputs on held-out recordings of the four data sets, saved from
one code tree and compared with another's (issue 24, the reactor's speed work: outputs must not change).

``run`` fits ``full`` (default preset, seed 0) on the first recordings of one class of each set — or reads the fitted
method from ``--models DIR`` (a pickle per case, written there the first time: both trees then share one fit, which
the reactor's work does not touch) — and steps the reactor on the next recordings as the evaluation does
(:func:`~socialaff_sim.evaluation.streaming.run_protocol_measured`, ``causal`` protocol, T0 = 10, horizon forecasts
every 0.5 s up to the longest of :data:`~socialaff_sim.evaluation.metrics.HORIZONS_S`), and on those recordings end
to end for ``--stream-seconds`` (a stream past the primitive's longest training duration and the belief's horizon). It saves agent 1's skeletons,
key joints, sub-events and forecasts and the per-instance key-joint, full-skeleton and horizon errors to one .npz.
``compare`` checks two such files: bitwise (``np.array_equal``, NaN equal to NaN) and, where not bitwise, the largest
difference against ``--tol`` (metres for positions and errors; sub-events must be equal). Usage::

    PYTHONPATH=/work/wt_sweep python scripts/check_reactor_outputs.py run --models /tmp/m --out ref.npz
    PYTHONPATH=$PWD          python scripts/check_reactor_outputs.py run --models /tmp/m --out new.npz
    python scripts/check_reactor_outputs.py compare ref.npz new.npz [--tol 1e-9]

``run --set FIELD=VALUE`` changes every method's causal synthesis in memory (e.g. ``belief_step=0.4``: how far an option
moves the outputs); ``compare`` also prints, per kind of array, how many differ, the largest difference and the rows
(frames) that differ by more than 1 µm (a changed choice rather than rounding).

The library never imports this script.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import pickle
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from socialaff_sim.data import load_dataset  # noqa: E402
from socialaff_sim.evaluation.metrics import HORIZONS_S, horizon_key_joint_error, joint_error, key_joint_error  # noqa: E402
from socialaff_sim.evaluation.registry import get_method  # noqa: E402
from socialaff_sim.evaluation.streaming import run_protocol_measured  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_stream import concatenate  # noqa: E402
from _reactor_args import add_setting_argument, changed_synthesis  # noqa: E402

_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
T0 = 10
EVERY_S = 0.5


@dataclasses.dataclass(frozen=True)
class Case:
    """One class of one set: ``n_fit`` recordings to fit on, the next ``n_test`` held out."""

    name: str
    spec: str
    label: str
    n_fit: int
    n_test: int


CASES = (
    Case("synthetic", "synthetic", "shake_hands", 12, 8),
    Case("sbu", f"sbu:{_DATA / 'sbu_kinect_interaction'}", "pushing", 16, 10),
    Case("handover", f"handover:{_DATA / 'handover_h2h'}", "hand_over", 40, 12),
    Case("nuisi", f"nuisi:{_DATA / 'nuisi_v1'}", "handshake", 14, 5),
)


def _method(case: Case, train: list, models: str | None) -> object:
    path = None if models is None else os.path.join(models, f"{case.name}.pkl")
    if path is not None and os.path.exists(path):
        with open(path, "rb") as f:
            return pickle.load(f)
    method = get_method("full")().fit(train, rng=np.random.default_rng(0))
    if path is not None:
        os.makedirs(models, exist_ok=True)  # type: ignore[arg-type]
        with open(path, "wb") as f:
            pickle.dump(method, f)
    return method


def run_case(case: Case, models: str | None, stream_s: float, arrays: dict[str, np.ndarray], seconds: dict[str, float],
             settings: list[str] | None = None, parser: argparse.ArgumentParser | None = None) -> None:
    pool = [i for i in load_dataset(case.spec) if i.label == case.label]
    train, test = pool[: case.n_fit], pool[case.n_fit : case.n_fit + case.n_test]
    method = _method(case, train, models)
    if settings:  # --set: the method's causal synthesis changed in memory (the pickle is not rewritten)
        method.synthesis = changed_synthesis(method.synthesis, settings, parser)  # type: ignore[attr-defined]
    tic = time.process_time()
    rng = np.random.default_rng(1)
    # The held-out recordings, then them end to end for ``stream_s`` seconds (past the primitive's longest
    # training duration and the forward belief's horizon: the bounded paths of a long stream).
    streams = list(test) + ([concatenate(test, int(round(stream_s * test[0].fps)), f"{case.name}_stream")] if stream_s > 0 else [])
    for k, inst in enumerate(streams):
        steps = [max(1, round(h * inst.fps)) for h in HORIZONS_S]
        run = run_protocol_measured(method, inst, protocol="causal", n_observed=T0, rng=rng,  # type: ignore[arg-type]
                                    horizon_frames=max(steps), horizon_every=max(1, round(EVERY_S * inst.fps)))
        p, key = run.prediction, f"{case.name}/{k}"
        arrays[f"{key}/joints"] = p.joints
        arrays[f"{key}/key_joints"] = p.key_joints
        if p.subevents is not None:
            arrays[f"{key}/subevents"] = p.subevents
        arrays[f"{key}/forecasts"] = run.forecasts
        arrays[f"{key}/errors"] = np.array(
            [key_joint_error(p, inst), joint_error(p, inst)]
            + [horizon_key_joint_error(run.forecast_times, run.forecasts, inst, s) for s in steps])
    seconds[case.name] = time.process_time() - tic
    print(f"{case.name}: {len(test)} held-out {case.label} recordings ({sum(i.n_frames for i in test)} frames) and a "
          f"stream of {stream_s:g} s, "
          f"{seconds[case.name]:.1f} s CPU", flush=True)


def compare(reference: str, candidate: str, tol: float) -> int:
    a, b = np.load(reference), np.load(candidate)
    keys_a, keys_b = set(a.files) - {"__seconds__"}, set(b.files) - {"__seconds__"}
    bad, inexact, worst = 0, 0, 0.0
    for k in sorted(keys_a ^ keys_b):
        print(f"only in {'reference' if k in keys_a else 'candidate'}: {k}")
        bad += 1
    for k in sorted(keys_a & keys_b):
        x, y = a[k], b[k]
        if x.shape == y.shape and np.array_equal(x, y, equal_nan=x.dtype.kind == "f"):
            continue
        if x.shape != y.shape or x.dtype.kind != "f" or not np.array_equal(np.isnan(x), np.isnan(y)):
            print(f"DIFFERS {k}: shape {x.shape} vs {y.shape} (or sub-events, or NaN pattern)")
            bad += 1
            continue
        diff = float(np.nanmax(np.abs(x - y)))
        worst = max(worst, diff)
        inexact += 1
        if diff > tol:
            print(f"DIFFERS {k}: max |diff| {diff:.3g} > {tol:g}")
            bad += 1
    for kind in ("key_joints", "joints", "forecasts", "errors", "subevents"):  # per kind: where and how much they differ
        ks = [k for k in sorted(keys_a & keys_b) if k.endswith("/" + kind)]
        diffs = [(k, a[k], b[k]) for k in ks if a[k].shape == b[k].shape and not np.array_equal(a[k], b[k], equal_nan=True)]
        if not diffs:
            continue
        if kind == "subevents":
            frames = sum(int((x != y).sum()) for _, x, y in diffs)
            total = sum(a[k].size for k in ks)
            print(f"  subevents: {len(diffs)} of {len(ks)} arrays differ, {frames} of {total} frames")
            continue
        worst_k, big = max(diffs, key=lambda d: np.nanmax(np.abs(d[1] - d[2]))), 0
        for _, x, y in diffs:  # frames (first axis) whose largest difference exceeds 1 µm: a changed choice, not rounding
            d = np.abs(x - y).reshape(len(x), -1)
            big += int((np.nanmax(np.where(np.isnan(d), 0.0, d), axis=1) > 1e-6).sum())
        w = float(np.nanmax(np.abs(worst_k[1] - worst_k[2])))
        print(f"  {kind}: {len(diffs)} of {len(ks)} arrays differ; largest |diff| {w:.3g} ({worst_k[0]}); "
              f"{big} rows with a difference > 1e-6")
    n = len(keys_a & keys_b)
    print(f"{n} arrays compared: {n - inexact - bad} bitwise equal, {inexact} within {tol:g} or not "
          f"(largest difference {worst:.3g}), {bad} differ or are missing")
    return 1 if bad else 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("--out", required=True)
    r.add_argument("--models", default=None, help="folder of fitted methods, one pickle per case (read, else written)")
    r.add_argument("--only", default="", help="comma-separated case names (default: all)")
    r.add_argument("--stream-seconds", type=float, default=120.0, help="the held-out recordings end to end (0: none)")
    add_setting_argument(r, "every case's method (in memory; e.g. belief_step=0.4)")
    c = sub.add_parser("compare")
    c.add_argument("reference")
    c.add_argument("candidate")
    c.add_argument("--tol", type=float, default=1e-9)
    args = ap.parse_args()
    if args.cmd == "compare":
        return compare(args.reference, args.candidate, args.tol)
    arrays: dict[str, np.ndarray] = {}
    seconds: dict[str, float] = {}
    only = {s for s in args.only.split(",") if s}
    for case in CASES:
        if not only or case.name in only:
            run_case(case, args.models, args.stream_seconds, arrays, seconds, args.set, r)
    arrays["__seconds__"] = np.array(json.dumps(seconds))
    np.savez_compressed(args.out, **arrays)
    return 0


if __name__ == "__main__":
    sys.exit(main())
