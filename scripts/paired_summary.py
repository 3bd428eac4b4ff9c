"""Summarise evaluation runs: per dataset the average key-joint error of every method (now and at the forecast
horizons), the per-call latency, and one method's paired differences against every other method.

Reads the ``results.json`` of ``socialaff-sim evaluate`` runs and prints Markdown. Usage::

    python scripts/paired_summary.py RESULTS.json [RESULTS.json ...] [--method full] [--seed 0]

The paired 95 % intervals are recomputed from the per-instance errors with the evaluation's own stratified
bootstrap (:func:`socialaff_sim.evaluation.compare.paired_differences`, 10,000 resamples, seeded), so
they are the intervals ``results.json`` would hold had that method been the reference. The library never
imports this script.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from socialaff_sim.evaluation.compare import paired_differences


def _f(x: object, fmt: str = ".3f") -> str:
    return "–" if x is None else format(x, fmt)


def _pairs(results: dict, method: str, metric: str, seed: int) -> list[str]:
    """'X: d [lo, hi] verdict' of ``method`` minus every other method X."""
    out = []
    for ref in results["average"]:
        if ref == method:
            continue
        rng = np.random.default_rng(seed)
        d = paired_differences(results, ref, metric=metric, rng=rng).get(method)
        if d is not None:
            out.append(f"{ref}: {d.mean_m:+.3f} [{d.low_m:+.3f}, {d.high_m:+.3f}] {d.verdict}")
    return out


def summarise(paths: list[Path], method: str, seed: int) -> list[str]:
    runs = [json.loads(p.read_text()) for p in paths]
    methods = list(dict.fromkeys(m for r in runs for m in r["average"]))  # every method of any run, in order
    lines = ["| dataset (test instances) | " + " | ".join(methods) + " |", "|---|" + "---:|" * len(methods)]
    for r in runs:
        first = next(iter(r["average"]))
        n = sum(v[first]["n_test"] for v in r["per_interaction"].values())
        lines.append(f"| {r['dataset']} ({n}) | " + " | ".join(_f(r["average"].get(m, {}).get("key_joint_error_m"))
                                                               for m in methods) + " |")
    for h in runs[0].get("horizons_s", []):
        key = f"key_joint_error_{h:g}s_m"
        lines += ["", f"Forecast {h:g} s ahead (key-joint error, m):", "",
                  "| dataset | " + " | ".join(methods) + " |", "|---|" + "---:|" * len(methods)]
        for r in runs:
            lines.append(f"| {r['dataset']} | " + " | ".join(_f(r["average"].get(m, {}).get(key)) for m in methods) + " |")
    lines += ["", "Per-call latency p50 / p99 (ms; causal: one call per frame):", "",
              "| dataset | " + " | ".join(methods) + " |", "|---|" + "---|" * len(methods)]
    for r in runs:
        lat = r.get("latency_ms", {})
        lines.append(f"| {r['dataset']} | " + " | ".join(
            f"{_f(lat.get(m, {}).get('p50'), '.2f')} / {_f(lat.get(m, {}).get('p99'), '.1f')}" for m in methods) + " |")
    for r in runs:
        if method not in r["average"]:
            continue
        lines += ["", f"`{method}` minus each method on `{r['dataset']}`, key joints, paired 95 % interval (m):", ""]
        lines += [f"- {item}" for item in _pairs(r, method, "key_joint_error_m", seed)]
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("results", nargs="+", type=Path)
    ap.add_argument("--method", default="full", help="the method whose paired differences are listed (default full)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    print("\n".join(summarise(args.results, args.method, args.seed)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
