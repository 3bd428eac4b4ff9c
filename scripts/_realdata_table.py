"""The table of scripts/bench_realdata.py: per data set × label × robot × physics, the ground truth's and the
synthesis's successes on the same instances, the gap synth − GT with a paired 95 % interval, and the outcome
codes per source.

The gap is the mean over instances of d_i = success_synth,i − success_gt,i ∈ {−1, 0, 1} (a difference of success
rates, paired by instance); its interval is the percentile bootstrap of that mean over instances
(:func:`socialaff_sim.evaluation.compare.paired_difference`, one class, 10,000 resamples, a generator seeded from
the run's ``seed`` and the cell's name). Rows whose instance lacks one of the two sources are left out and counted.
"""

from __future__ import annotations

import zlib
from collections import Counter
from typing import Any

import numpy as np

from socialaff_sim.evaluation.compare import paired_difference

__all__ = ["CONFIDENCE", "RESAMPLES", "format_tables", "paired_gap", "table_rows"]

CONFIDENCE = 0.95
RESAMPLES = 10_000
CELL = ("dataset", "label", "robot", "physics")
SUPPORT = ("outside_support_mean", "contact_outside_support_mean", "foot_slide_cm", "torso_tilt_deg_max")
"""The episodes' support figures the third table averages over a cell's paired instances (per source)."""


def paired_gap(gt: np.ndarray, synth: np.ndarray, *, rng: np.random.Generator, confidence: float = CONFIDENCE,
               n_resamples: int = RESAMPLES) -> tuple[float, float, float]:
    """(gap, low, high): mean of synth − gt over paired instances (bool arrays of one length) and its percentile
    bootstrap interval at ``confidence``."""
    d = np.asarray(synth, dtype=float) - np.asarray(gt, dtype=float)
    return paired_difference([d], confidence=confidence, n_resamples=n_resamples, rng=rng)


def cell_rng(seed: int, cell: tuple[str, ...]) -> np.random.Generator:
    """The bootstrap's generator of one cell: from ``seed`` and the cell's name only."""
    return np.random.default_rng([seed, zlib.crc32("/".join(cell).encode())])


def table_rows(rows: list[dict[str, Any]], *, seed: int = 0, pooled: bool = False) -> list[dict[str, Any]]:
    """One summary per cell (data set, label, robot, physics) of episode rows, in first-seen order; ``pooled``
    adds, after them, one cell per robot and physics over all its instances (data set and label ``all``)."""
    cells: dict[tuple[str, ...], dict[str, dict[str, dict[str, Any]]]] = {}
    for r in rows:
        cell = tuple(str(r[k]) for k in CELL)
        cells.setdefault(cell, {}).setdefault(r["instance"], {})[r["source"]] = r
    if pooled:  # every instance of a robot and physics, whatever its class: one more cell each
        for cell, by_inst in list(cells.items()):
            into = cells.setdefault(("all", "all", *cell[2:]), {})
            into.update({f"{cell[0]}/{cell[1]}/{k}": v for k, v in by_inst.items()})
    out = []
    for cell, by_inst in cells.items():
        paired = [v for v in by_inst.values() if "gt" in v and "synth" in v]
        gt = np.array([v["gt"]["success"] for v in paired], dtype=bool)
        sy = np.array([v["synth"]["success"] for v in paired], dtype=bool)
        summary: dict[str, Any] = dict(zip(CELL, cell, strict=True))
        summary.update(n=len(paired), unpaired=len(by_inst) - len(paired), gt=int(gt.sum()), synth=int(sy.sum()),
                       both=int((gt & sy).sum()), lost=int((gt & ~sy).sum()), gained=int((~gt & sy).sum()),
                       folds=sorted({v["gt"]["fold"] for v in paired}),
                       split=(" / ".join(sorted({v["gt"]["split"] for v in paired})) if cell[0] != "all"
                              else "each class's"))
        if paired:
            gap, lo, hi = paired_gap(gt, sy, rng=cell_rng(seed, cell))
            summary.update(gap=gap, low=lo, high=hi)
        else:
            summary.update(gap=None, low=None, high=None)
        for s in ("gt", "synth"):
            summary[f"{s}_outcomes"] = dict(Counter(str(v[s].get("outcome")) for v in paired).most_common())
            summary[f"{s}_support"] = {k: _mean([v[s].get("support", {}).get(k) for v in paired]) for k in SUPPORT}
        out.append(summary)
    return out


def _mean(xs: list[float | None]) -> float | None:
    x = [v for v in xs if v is not None]
    return float(np.mean(x)) if x else None


def _fmt(x: float | None, scale: float = 1.0) -> str:
    return "–" if x is None else f"{scale * x:.1f}"


def _pct(k: int, n: int) -> str:
    return f"{k}/{n} ({100 * k / n:.0f} %)" if n else "–"


def _codes(c: dict[str, int]) -> str:
    return ", ".join(f"{k} {v}" for k, v in c.items() if k != "success") or "–"


def format_tables(cells: list[dict[str, Any]]) -> str:
    """Markdown: the success table, the outcome codes per source, the support figures (means over the paired
    instances) per source."""
    lines = ["| robot | physics | data set | label | split | n | ground truth | synthesized | gap synth − GT "
             f"[{100 * CONFIDENCE:.0f} % paired] | lost / gained |", "|" + "---|" * 10]
    for c in cells:
        gap = "–" if c["gap"] is None else (f"{100 * c['gap']:+.1f} [{100 * c['low']:+.1f}, {100 * c['high']:+.1f}] "
                                             "points")
        lines.append(f"| {c['robot']} | {c['physics']} | {c['dataset']} | {c['label']} | {c['split']} | {c['n']} | "
                     f"{_pct(c['gt'], c['n'])} | {_pct(c['synth'], c['n'])} | {gap} | {c['lost']} / {c['gained']} |")
    lines += ["", "| robot | physics | data set | label | ground truth's failures (outcome codes) | "
              "synthesized's failures (outcome codes) |", "|" + "---|" * 6]
    for c in cells:
        lines.append(f"| {c['robot']} | {c['physics']} | {c['dataset']} | {c['label']} | {_codes(c['gt_outcomes'])} | "
                     f"{_codes(c['synth_outcomes'])} |")
    lines += ["", "| robot | physics | data set | label | outside support, episode (GT / synth, % of weight) | "
              "in contact (GT / synth, %) | foot slide (GT / synth, cm) | largest tilt (GT / synth, °) |",
              "|" + "---|" * 8]
    for c in cells:
        g, y = c["gt_support"], c["synth_support"]
        lines.append(f"| {c['robot']} | {c['physics']} | {c['dataset']} | {c['label']} | "
                     f"{_fmt(g['outside_support_mean'], 100)} / {_fmt(y['outside_support_mean'], 100)} | "
                     f"{_fmt(g['contact_outside_support_mean'], 100)} / {_fmt(y['contact_outside_support_mean'], 100)} | "
                     f"{_fmt(g['foot_slide_cm'])} / {_fmt(y['foot_slide_cm'])} | "
                     f"{_fmt(g['torso_tilt_deg_max'])} / {_fmt(y['torso_tilt_deg_max'])} |")
    unpaired = sum(c["unpaired"] for c in cells)
    if unpaired:
        lines += ["", f"{unpaired} instance(s) with only one source left out."]
    return "\n".join(lines)
