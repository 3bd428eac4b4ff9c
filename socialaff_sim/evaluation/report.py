"""Write an evaluation's results: ``results.json`` (schema: :func:`~socialaff_sim.evaluation.runner.evaluate`),
a Markdown table like the paper's Table 1 titled with the protocol, split and preset, and a bar chart."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from .._atomic import atomic_path, atomic_write_text
from .metrics import METRICS

__all__ = ["format_tables", "horizon_lines", "write_results", "plot_results"]

_METRICS = tuple(zip(METRICS, ("Average key-joint error (m)", "Average joint error, full skeleton (m)"), strict=True))


def _clean(value: Any) -> Any:
    """NaN/inf → None (strict JSON)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, Mapping):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    return value


def _cell(value: float | None, best: bool) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "–"
    text = f"{value:.3f}"
    return f"**{text}**" if best else text


def format_tables(results: Mapping[str, Any]) -> str:
    """Markdown: per metric a table with methods as rows and interactions + average as columns."""
    per = results["per_interaction"]
    labels = list(per)
    methods = list(results["average"])
    settings = results.get("settings", {})
    title = results.get("title") or f"`{results['dataset']}`"
    lines = [f"# Experiment 1: {title}", ""]
    t0 = settings.get("n_observed", "?")
    lines.append(
        f"Average distance between synthesized and ground-truth agent-1 joints over the synthesized "
        f"frames (t ≥ T0 = {t0}); protocol `{results.get('protocol', '?')}`, split `{results.get('split', '?')}`, "
        f"preset `{results.get('preset', '?')}`. Lower is better; the best of each column is bold."
    )
    if results.get("upper_bound"):
        lines.append("Offline protocol: every method saw agent 0's whole track — an upper bound, not a reaction.")
    if results.get("optimistic"):
        lines.append("Block split: the same people and session are in training and test — optimistic.")
    reused = results.get("reused")
    if reused:
        lines.append(f"Not run again: {', '.join(reused['methods'])}, taken from `{reused['from']}` (same data, folds, "
                     "seed and protocol; the paired comparisons are recomputed over all methods).")
        inner = reused.get("earlier")
        while inner:  # that file had itself reused rows
            lines.append(f"That file took {', '.join(inner['methods'])} from `{inner['from']}`.")
            inner = inner.get("earlier")
    replicates = {m: r for m, r in (settings.get("replicates") or {}).items() if r}
    if replicates:
        lines.append("Method replicates (the same folds, another random stream for the method): "
                     + ", ".join(f"{m} {r}" for m, r in replicates.items()) + "; every other method ran replicate 0.")
    for key, title in _METRICS:
        lines += ["", f"## {title}", ""]
        lines.append("| Method | " + " | ".join(labels) + " | Average |")
        lines.append("|---|" + "---:|" * (len(labels) + 1))
        columns = [[per[lab][m][key] for m in methods] for lab in labels]
        columns.append([results["average"][m][key] for m in methods])
        best = [min((v for v in col if v is not None and not math.isnan(v)), default=None) for col in columns]
        for i, m in enumerate(methods):
            cells = [_cell(col[i], col[i] is not None and col[i] == b) for col, b in zip(columns, best, strict=True)]
            lines.append(f"| {m} | " + " | ".join(cells) + " |")
    lines += ["", "Test instances per interaction: " + ", ".join(
        f"{lab} {per[lab][methods[0]]['n_test']}" for lab in labels
    ) + "."]
    excluded = {k: v for k, v in results.get("excluded", {}).items() if v}
    if excluded:
        lines.append("Excluded as too short (T ≤ T0 + 1): " + ", ".join(f"{k} {v}" for k, v in excluded.items()) + ".")
    parse = results.get("parse_accuracy") or {}
    if parse:
        lines += ["", "## Sub-event parse accuracy (frames, after optimal label matching)", ""]
        lines.append("| Method | " + " | ".join(labels) + " |")
        lines.append("|---|" + "---:|" * len(labels))
        for m in methods:
            if not any(m in parse.get(lab, {}) for lab in labels):
                continue  # the method does not parse sub-events
            cells = [_cell(parse.get(lab, {}).get(m), False) for lab in labels]
            lines.append(f"| {m} | " + " | ".join(cells) + " |")
    lines += horizon_lines(results)
    lines += _paired_lines(results.get("paired"))
    lines += ["", "Fit + predict time summed over tasks (s): " + ", ".join(
        f"{m} {results['seconds'][m]:.1f}" for m in methods
    ) + "."]
    return "\n".join(lines) + "\n"


def horizon_lines(results: Mapping[str, Any], heading: str = "##") -> list[str]:
    """Markdown: key-joint error at each forecast horizon (averaged over the interactions, with the paired
    difference to ``hold`` where it was run) and the per-call latency of each method, under headings of
    level ``heading``; nothing for runs without them (results.json files written before they existed)."""
    horizons = results.get("horizons_s") or []
    average = results["average"]
    methods = list(average)
    lines: list[str] = []
    keys = [f"key_joint_error_{h:g}s_m" for h in horizons]
    if keys and any(not _missing(average[m].get(k)) for m in methods for k in keys):
        every = results.get("settings", {}).get("horizon_every_s")
        lines += ["", f"{heading} Key-joint error at forecast horizons (m)", ""]
        lines.append(
            "At each forecast time t (every " + (f"{every:g} s" if every else "few frames") + " from T0 on) the method, "
            "having seen agent 0 up to frame t, forecasts agent 1's frames t … t + h; the error of the frame h seconds "
            "ahead, averaged over the forecast times, the instances and the interactions (docs/evaluation.md). "
            "In brackets: the paired difference to `hold` with its 95 % interval."
        )
        lines += ["", "| Method | " + " | ".join(f"h = {h:g} s" for h in horizons) + " |", "|---|" + "---:|" * len(horizons)]
        hold = (results.get("paired") or {}).get("hold", {}).get("differences", {})
        for m in methods:
            cells = []
            for k in keys:
                text = _cell(average[m].get(k), False)
                d = hold.get(k, {}).get(m)
                if d:
                    text += f" ({d['mean_m']:+.3f} [{d['low_m']:+.3f}, {d['high_m']:+.3f}])"
                cells.append(text)
            lines.append(f"| {m} | " + " | ".join(cells) + " |")
    latency = results.get("latency_ms") or {}
    if latency:
        lines += ["", f"{heading} Latency per call (ms)", ""]
        lines.append(
            f"Wall time of each call of the method's reactor on the test instances (protocol `{results.get('protocol', '?')}`: "
            + ("one call per synthesized frame" if results.get("protocol") == "causal" else "one call per block")
            + "); pooled over all calls; tasks may have shared the machine."
        )
        lines += ["", "| Method | p50 | p99 | max | calls |", "|---|---:|---:|---:|---:|"]
        for m in methods:
            lat = latency.get(m) or {}
            lines.append(f"| {m} | {_ms(lat.get('p50'))} | {_ms(lat.get('p99'))} | {_ms(lat.get('max'))} | {lat.get('n_calls', 0)} |")
    return lines


def _missing(value: Any) -> bool:
    return value is None or (isinstance(value, float) and math.isnan(value))


def _ms(value: Any) -> str:
    return "–" if _missing(value) else f"{value:.2f}"


def _paired_lines(paired: Mapping[str, Any] | None) -> list[str]:
    """The paired-difference tables (against ``hold`` and against the best baseline), or nothing."""
    lines: list[str] = []
    names = {"hold": "`hold`", "best_baseline": "the best baseline"}
    for comparison, entry in (paired or {}).items():
        diffs = entry.get("differences", {}).get("key_joint_error_m")
        if not diffs:
            continue
        ref, level = entry["reference"], 100 * entry["confidence"]
        what = names.get(comparison, comparison)
        lines += ["", f"## Paired differences to {what} (`{ref}`), key joints, m", ""]
        lines.append(
            f"Each method's error minus {ref}'s on the same test instances, averaged like the table above; "
            f"the interval is a {level:g} % stratified bootstrap over the instances ({entry['n_resamples']} resamples). "
            "Negative: lower than the reference."
        )
        lines += ["", f"| Method | Difference | {level:g} % interval | Instances | Verdict |", "|---|---:|---:|---:|---|"]
        for m, d in diffs.items():
            lines.append(
                f"| {m} | {d['mean_m']:+.4f} | [{d['low_m']:+.4f}, {d['high_m']:+.4f}] | {d['n_instances']} | {d['verdict']} |"
            )
    return lines


def plot_results(results: Mapping[str, Any], path: str | Path) -> Path:
    """Grouped bar chart (PNG) of both errors per interaction and on average."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    per = results["per_interaction"]
    labels = list(per) + ["average"]
    methods = list(results["average"])
    fig, axes = plt.subplots(1, 2, figsize=(max(10.0, 2.2 * len(labels)), 4.2), squeeze=False)
    width = 0.8 / max(len(methods), 1)
    x = np.arange(len(labels))
    for ax, (key, title) in zip(axes[0], _METRICS, strict=True):
        for i, m in enumerate(methods):
            vals = [per[lab][m][key] for lab in labels[:-1]] + [results["average"][m][key]]
            vals = [np.nan if v is None else v for v in vals]
            ax.bar(x + (i - (len(methods) - 1) / 2) * width, vals, width, label=m)
        ax.set_xticks(x, labels, rotation=30, ha="right")
        ax.set_ylabel("metres")
        ax.set_title(title)
    axes[0][0].legend()
    fig.suptitle(f"Experiment 1 on {results['dataset']}: {results.get('protocol', '?')} protocol, "
                 f"{results.get('split', '?')} split, preset {results.get('preset', '?')}")
    fig.tight_layout()
    path = Path(path)
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, format="png", dpi=120)
    plt.close(fig)
    return path


def write_results(results: Mapping[str, Any], out_dir: str | Path) -> dict[str, Path]:
    """Write ``results.json``, ``results.md`` and ``results.png`` into ``out_dir``; returns their paths.

    The chart needs matplotlib (``pip install socialaff-sim[plot]``); without it the
    returned mapping has no ``"chart"`` entry.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    clean = _clean(results)
    paths = {"json": out / "results.json", "markdown": out / "results.md"}
    atomic_write_text(paths["json"], json.dumps(clean, indent=2, allow_nan=False) + "\n")
    atomic_write_text(paths["markdown"], format_tables(clean))
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return paths
    paths["chart"] = plot_results(clean, out / "results.png")
    return paths
