"""The two foot meters side by side, from ``scripts/bench_support.py --json`` runs: the ankle's sliding path
(``foot_slide_cm``) and the soles' slip on the floor (``foot_slip_cm``), with the steps and skims the slip leaves
out (``foot_steps``/``foot_step_cm``, ``foot_skims``/``foot_skim_cm``; socialaff_sim/sim/sole_slip.py).

Per robot, mode and interaction, over the episodes with a contact phase: their number, each meter's median and
how many episodes are within ``--target`` cm (2: issue 25's), the slip plus the skims' length (for whoever counts a
skim as slide), the steps; then all interactions pooled; with ``--pairs`` one line per episode. ``--same-slide
REF.json`` checks that the slide of every episode also in REF (an older run of the same code's defaults) is the
same to the last digit, and says how many differ. Usage::

    python scripts/slip_table.py RUN.json [RUN2.json ...] [--robot ours] [--pairs] [--same-slide REF.json ...]

The library never imports this script.
"""

from __future__ import annotations

import argparse
import collections
import json
import sys
from pathlib import Path

import numpy as np

COLUMNS = ("foot_slide_cm", "foot_slip_cm", "foot_skim_cm", "foot_steps", "foot_step_cm")


def load(paths: list[str]) -> list[dict]:
    """The rows of ``paths`` (``bench_support.py --json`` files), in order."""
    rows: list[dict] = []
    for p in paths:
        rows += json.loads(Path(p).read_text())["rows"]
    return rows


def summary(rows: list[dict], target: float) -> dict[str, float | int]:
    """Medians and counts of ``rows`` (their contact-phase figures; rows without a contact phase left out)."""
    have = [r for r in rows if r["contact_frames"]]
    if not have:
        return {"n": 0}
    slide = np.array([r["foot_slide_cm"] for r in have])
    slip = np.array([r["foot_slip_cm"] for r in have])
    both = slip + np.array([r["foot_skim_cm"] for r in have])
    return {"n": len(have), "slide_median": float(np.median(slide)), "slide_within": int((slide <= target).sum()),
            "slip_median": float(np.median(slip)), "slip_within": int((slip <= target).sum()),
            "slip_skim_median": float(np.median(both)), "slip_skim_within": int((both <= target).sum()),
            "steps": int(sum(r["foot_steps"] for r in have)), "step_cm": float(sum(r["foot_step_cm"] for r in have)),
            "skims": int(sum(r["foot_skims"] for r in have)),
            "slip_share": float(slip.sum() / slide.sum()) if slide.sum() > 0 else float("nan")}


def line(name: str, s: dict[str, float | int]) -> str:
    if not s["n"]:
        return f"{name:<14} no contact phase"
    n = s["n"]
    return (f"{name:<14}{n:>4}  slide (ankle path) median {s['slide_median']:5.2f} cm, <= target {s['slide_within']:>3}/{n:<3}"
            f"  slip (sole on floor) median {s['slip_median']:5.2f} cm, <= target {s['slip_within']:>3}/{n:<3}"
            f"  slip+skims median {s['slip_skim_median']:5.2f}, <= target {s['slip_skim_within']:>3}/{n:<3}"
            f"  steps {s['steps']} ({s['step_cm']:.1f} cm), skims {s['skims']}, slip/slide sums {s['slip_share']:.2f}")


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("runs", nargs="+", help="bench_support.py --json files")
    p.add_argument("--robot")
    p.add_argument("--mode")
    p.add_argument("--target", type=float, default=2.0, help="cm (default 2: issue 25's slide target)")
    p.add_argument("--pairs", action="store_true", help="one line per episode")
    p.add_argument("--same-slide", nargs="*", default=[], metavar="REF.json",
                   help="older runs whose foot_slide_cm every shared episode must equal")
    args = p.parse_args(argv)
    rows = [r for r in load(args.runs)
            if (args.robot is None or r["robot"] == args.robot) and (args.mode is None or r["mode"] == args.mode)]
    if rows and "foot_slip_cm" not in rows[0]:
        print("slip_table.py: these rows have no foot_slip_cm (made before the slip meter)", file=sys.stderr)
        raise SystemExit(2)
    groups: dict[tuple[str, str], list[dict]] = collections.defaultdict(list)
    for r in rows:
        groups[(r["robot"], r["mode"])].append(r)
    for (robot, mode), sel in sorted(groups.items()):
        print(f"== {robot} / {mode}: {len(sel)} episodes")
        for label in sorted({r["label"] for r in sel}):
            print(line(label, summary([r for r in sel if r["label"] == label], args.target)))
        print(line("all", summary(sel, args.target)))
        if args.pairs:
            print(f"{'episode':<18}{'slide':>8}{'slip':>8}{'skim cm':>9}{'skims':>7}{'steps':>7}{'step cm':>9}")
            for r in sorted(sel, key=lambda r: (r["label"], r["instance"])):
                if r["contact_frames"]:
                    print(f"{r['instance']:<18}{r['foot_slide_cm']:>8.2f}{r['foot_slip_cm']:>8.2f}{r['foot_skim_cm']:>9.2f}"
                          f"{r['foot_skims']:>7}{r['foot_steps']:>7}{r['foot_step_cm']:>9.2f}")
    if args.same_slide:
        ref = {(r["robot"], r["mode"], r["instance"]): r for r in load(args.same_slide)}
        shared = [(r, ref[k]) for r in rows if (k := (r["robot"], r["mode"], r["instance"])) in ref]
        differ = [a["instance"] for a, b in shared if a["foot_slide_cm"] != b["foot_slide_cm"]
                  or a["contact_frames"] != b["contact_frames"]]
        print(f"foot_slide_cm against {', '.join(args.same_slide)}: {len(shared)} shared episodes, "
              f"{len(differ)} differ{': ' + ', '.join(differ) if differ else ''}")


if __name__ == "__main__":
    sys.exit(main())
