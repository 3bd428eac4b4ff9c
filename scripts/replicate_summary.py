"""Summarise a method's replicates: the same folds, other random streams (``socialaff-sim evaluate --replicate R``).

The paired interval of one evaluation covers the sampling of the test instances only: the method is fitted
once per fold, so the randomness of its own fit and synthesis is not in it. Runs of the same data, folds and
seed with several replicates measure that randomness. For each dataset this prints, for ``--method``:

- per replicate: its average key-joint error and its paired difference (95 %) to each reference method;
- the spread of its average over the replicates (standard deviation and range);
- the replicate mean: every test instance's error averaged over the replicates (the expected error over the
  method's randomness, estimated from R draws), the references' likewise, paired with the same stratified
  bootstrap (:func:`socialaff_sim.evaluation.compare.paired_differences`).

Usage::

    python scripts/replicate_summary.py RESULTS.json [RESULTS.json ...] [--method full]
        [--references hold,ridge] [--seed 0]

Each file is one replicate of ``--method`` (merged files written by ``evaluate --reuse`` are fine). The
references are read from each file; in the replicate mean their per-instance errors are averaged over the
files too (a reference with randomness, such as ``ridge``'s inner folds, should be run in the same replicates;
one run in every file is averaged to itself). Files are grouped by dataset.
The library never imports this script.
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

from socialaff_sim.evaluation.compare import paired_differences

METRIC = "key_joint_error_m"


class UsageError(Exception):
    """A file or flag that cannot be used (the message names it)."""


def _replicate(results: dict[str, Any], method: str) -> int:
    return int((results["settings"].get("replicates") or {}).get(method, 0))


def replicate_mean(runs: list[dict[str, Any]], methods: list[str]) -> dict[str, Any]:
    """The first run with each of ``methods``' per-instance errors averaged over ``runs`` (which must test the
    same (instance, fold) pairs per class). A method without randomness keeps its errors."""
    out = copy.deepcopy(runs[0])
    for label, by_method in out["per_instance"].items():
        for method in methods:
            keyed = []
            for r in runs:
                rows = r["per_instance"][label][method]
                keyed.append({(row["instance_id"], row["fold"]): row[METRIC] for row in rows})
            if any(set(k) != set(keyed[0]) for k in keyed):
                raise UsageError(f"per_instance.{label}.{method}: the replicates test other (instance, fold) pairs")
            rows = []
            for key in keyed[0]:
                values = [k[key] for k in keyed]
                mean = None if any(v is None for v in values) else float(np.mean(values))
                rows.append({"instance_id": key[0], "fold": key[1], METRIC: mean})
            by_method[method] = rows
    return out


def summarise(runs: list[dict[str, Any]], method: str, references: list[str], seed: int) -> list[str]:
    """Markdown lines for one dataset's replicates."""
    runs = sorted(runs, key=lambda r: _replicate(r, method))
    reps = [_replicate(r, method) for r in runs]
    if len(set(reps)) != len(reps):
        raise UsageError(f"{runs[0]['dataset']}: replicates {reps} of {method!r}: each replicate once")
    ref_reps = {ref: sorted({_replicate(r, ref) for r in runs}) for ref in references}
    lines = [f"### {runs[0]['dataset']}: `{method}` over replicates {reps}", "",
             "References' replicates: " + ", ".join(f"`{ref}` {v}" for ref, v in ref_reps.items())
             + " (a reference run once is the same in every row).", "",
             "| replicate | " + method + " | " + " | ".join(f"− {ref} [95 %]" for ref in references) + " |",
             "|---|---:|" + "---|" * len(references)]
    averages = []
    for r, res in zip(reps, runs, strict=True):
        averages.append(res["average"][method][METRIC])
        cells = []
        for ref in references:
            d = paired_differences(res, ref, rng=np.random.default_rng(seed))[method]
            cells.append(f"{d.mean_m:+.4f} [{d.low_m:+.4f}, {d.high_m:+.4f}]")
        lines.append(f"| {r} | {averages[-1]:.4f} | " + " | ".join(cells) + " |")
    merged = replicate_mean(runs, [method, *references])
    cells = []
    for ref in references:
        d = paired_differences(merged, ref, rng=np.random.default_rng(seed))[method]
        cells.append(f"{d.mean_m:+.4f} [{d.low_m:+.4f}, {d.high_m:+.4f}]")
    lines.append(f"| **mean of {len(runs)}** | {np.mean(averages):.4f} | " + " | ".join(cells) + " |")
    spread = np.std(averages, ddof=1) if len(averages) > 1 else float("nan")
    lines += ["", f"Spread of `{method}`'s average over the replicates: standard deviation {spread:.4f} m, "
              f"range {min(averages):.4f}–{max(averages):.4f} m. The last row pairs the per-instance errors "
              "averaged over the files, the method's and each reference's.", ""]
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("results", nargs="+", type=Path, help="results.json of `socialaff-sim evaluate`, one per replicate")
    ap.add_argument("--method", default="full")
    ap.add_argument("--references", default="hold,ridge", help="comma-separated methods to pair against")
    ap.add_argument("--seed", type=int, default=0, help="bootstrap seed")
    args = ap.parse_args(argv)
    refs = [r for r in args.references.split(",") if r]
    by_data: dict[str, list[dict[str, Any]]] = defaultdict(list)
    try:
        for path in args.results:
            try:
                res = json.loads(path.read_text())
            except (OSError, json.JSONDecodeError) as exc:
                raise UsageError(f"{path}: expected a results.json of `socialaff-sim evaluate` ({exc})") from None
            for m in [args.method, *refs]:
                if m not in res.get("average", {}):
                    raise UsageError(f"{path}: method {m!r} was not evaluated (--method/--references)")
            by_data[res["dataset"]].append(res)
        lines = []
        for runs in by_data.values():
            lines += summarise(runs, args.method, refs, args.seed)
    except UsageError as exc:
        print(f"replicate_summary: {exc}", file=sys.stderr)
        return 2
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
