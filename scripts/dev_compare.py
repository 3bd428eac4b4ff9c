"""Paired comparison of two ``scripts/dev_switching.py --errors`` files of one development split (issue 24).

Prints, for the pooled validation instances, ``hold``, the two runs' mean ``sw:default`` (or ``--key``) key-joint
error, the paired 95 % percentile bootstrap of their difference (``paired_difference``, seed 0), Algorithm 2's plan alone
in both, and how many instances changed. Usage::

    python scripts/dev_compare.py BASE.json OTHER.json [--key sw:default] [--label NAME]

Only development-split files; the library never imports this script.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from socialaff_sim.evaluation.compare import paired_difference


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("base")
    ap.add_argument("other")
    ap.add_argument("--key", default="sw:default")
    ap.add_argument("--label", default="")
    args = ap.parse_args()
    with open(args.base, encoding="utf-8") as f:
        base = json.load(f)
    with open(args.other, encoding="utf-8") as f:
        other = json.load(f)
    classes = list(base)
    if set(classes) != set(other):
        raise SystemExit(f"{args.other}: expected the classes {sorted(classes)}, found {sorted(other)}")
    b = np.concatenate([base[c][args.key] for c in classes])
    o = np.concatenate([other[c][args.key] for c in classes])
    pb = np.concatenate([base[c]["plan"] for c in classes])
    po = np.concatenate([other[c]["plan"] for c in classes])
    hold = np.concatenate([base[c]["hold"] for c in classes])
    m, lo, hi = paired_difference([o - b], rng=np.random.default_rng(0))
    print(f"| {args.label or args.other} | {b.size} | {hold.mean():.4f} | {b.mean():.4f} | {o.mean():.4f} | "
          f"{m:+.4f} [{lo:+.4f}, {hi:+.4f}] | {pb.mean():.4f} → {po.mean():.4f} | changed {int((o != b).sum())}/{b.size} |")


if __name__ == "__main__":
    main()
