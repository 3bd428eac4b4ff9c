"""The HTML page of an evaluation, rendered from its ``results.json`` (whatever keys it holds)."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..errors import DataError
from .html import Cell, Page, definitions, esc, figure, table

__all__ = ["write_evaluation_page", "EVALUATION_PAGE"]

EVALUATION_PAGE = "report.html"
"""File name of the page inside the evaluation's output folder."""

_METRIC_TITLES = {
    "key_joint_error_m": "Average key-joint error (m)",
    "joint_error_m": "Average joint error, full skeleton (m)",
}
_NOT_RECORDED = "not recorded in results.json"


def _number(value: Any) -> float | None:
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) else None


def _lookup(results: Mapping[str, Any], key: str) -> Any:
    """``key`` at the top level of results.json or in its ``settings``."""
    if key in results:
        return results[key]
    settings = results.get("settings")
    return settings.get(key) if isinstance(settings, Mapping) else None


def _describe(value: Any) -> str:
    if value is None:
        return _NOT_RECORDED
    if isinstance(value, Mapping):
        return ", ".join(f"{k}: {v}" for k, v in value.items())
    if isinstance(value, (list, tuple)):
        return ", ".join(str(v) for v in value)
    return str(value)


def _protocol_line(results: Mapping[str, Any]) -> str:
    folds = _lookup(results, "n_folds")
    t0 = _lookup(results, "n_observed")
    return (f"Protocol: {_describe(_lookup(results, 'protocol'))}. Split: {_describe(_lookup(results, 'split'))}"
            f"{f', {folds} folds' if folds is not None else ''}. Preset: {_describe(_lookup(results, 'preset'))}. "
            f"T0 = {t0 if t0 is not None else '?'} observed frames; errors are averaged over the synthesized frames.")


def _error_tables(results: Mapping[str, Any]) -> str:
    per = results.get("per_interaction") or {}
    average = results.get("average") or {}
    labels = list(per)
    methods = list(average) or sorted({m for lab in labels for m in per[lab]})
    metrics = [k for k in _METRIC_TITLES if any(k in (average.get(m) or {}) for m in methods)]
    metrics = metrics or [k for k in _METRIC_TITLES if any(k in v for lab in labels for v in per[lab].values())]
    parts = []
    for key in metrics:
        rows: list[list[Cell]] = []
        for m in methods:
            row: list[Cell] = [m]
            row += [_number((per[lab].get(m) or {}).get(key)) for lab in labels]
            row.append(_number((average.get(m) or {}).get(key)))
            rows.append(row)
        best = [set()]
        for c in range(1, len(labels) + 2):
            col = [(r[c], i) for i, r in enumerate(rows) if isinstance(r[c], float)]
            best.append({min(col)[1]} if col else set())
        parts.append(f"<h3>{esc(_METRIC_TITLES[key])}</h3>")
        parts.append(table(["method", *labels, "average"], rows, best=best,
                           caption=_protocol_line(results) + " Lower is better; the best of each column in bold."))
    if labels and methods:
        counts = [f"{lab} {(per[lab].get(methods[0]) or {}).get('n_test', '?')}" for lab in labels]
        parts.append(f"<p class=\"note\">Test instances per interaction: {esc(', '.join(counts))}.</p>")
    excluded = {k: v for k, v in (results.get("excluded") or {}).items() if v}
    if excluded:
        parts.append("<p class=\"note\">Left out of testing as too short (T ≤ T0 + 1): "
                     + esc(", ".join(f"{k} {v}" for k, v in excluded.items())) + ".</p>")
    return "\n".join(parts)


def _paired_blocks(results: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    """Every paired comparison in results.json: ``paired`` (one or a list) and any ``paired_*`` entries."""
    blocks: list[Mapping[str, Any]] = []
    for key, value in results.items():
        if not str(key).startswith("paired"):
            continue
        items = value if isinstance(value, list) else list(value.values()) if (
            isinstance(value, Mapping) and "differences" not in value) else [value]
        blocks += [b for b in items if isinstance(b, Mapping) and isinstance(b.get("differences"), Mapping)]
    return blocks


def _paired_section(results: Mapping[str, Any]) -> str:
    parts = []
    for block in _paired_blocks(results):
        ref = block.get("reference", "the reference")
        level = _number(block.get("confidence"))
        level_text = f"{100 * level:g} %" if level is not None else "confidence"
        for key, diffs in block["differences"].items():
            if not isinstance(diffs, Mapping) or not diffs:
                continue
            rows: list[list[Cell]] = [[
                m, _number(d.get("mean_m")), _number(d.get("low_m")), _number(d.get("high_m")),
                d.get("n_instances"), str(d.get("verdict", "")),
            ] for m, d in diffs.items() if isinstance(d, Mapping)]
            parts.append(f"<h3>{esc(_METRIC_TITLES.get(key, key))}: each method minus {esc(ref)}</h3>")
            parts.append(table(
                ["method", "mean difference (m)", f"{level_text} low (m)", f"{level_text} high (m)", "instances", "verdict"],
                rows, digits=4, signed=True,
                caption=(f"Paired over the same test instances; {level_text} bootstrap interval"
                         f"{' (' + str(block['n_resamples']) + ' resamples)' if 'n_resamples' in block else ''}. "
                         f"Negative: lower error than {ref}. {_protocol_line(results)}"),
            ))
    return "\n".join(parts)


def write_evaluation_page(out_dir: str | Path, results: Mapping[str, Any] | None = None) -> Path:
    """Write ``report.html`` into an evaluation's folder; ``results`` defaults to its ``results.json``.

    Renders the keys present and says which settings were not recorded; links ``results.png`` when it exists.
    """
    out = Path(out_dir)
    if results is None:
        source = out / "results.json"
        try:
            results = json.loads(source.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise DataError(f"{source}: not found; run `socialaff-sim evaluate --out {out}` first") from None
        except json.JSONDecodeError as exc:
            raise DataError(f"{source}: not valid JSON ({exc.msg} at line {exc.lineno})") from None
    if not isinstance(results, Mapping):
        raise DataError(f"{out / 'results.json'}: expected a JSON object, found {type(results).__name__}")
    dataset = results.get("dataset", "?")
    page = Page(f"Evaluation on {dataset}",
                "How close each method's synthesized reaction comes to the recorded second person, "
                "by interaction, with paired differences between methods on the same test instances.")
    settings = results.get("settings") if isinstance(results.get("settings"), Mapping) else {}
    items: list[tuple[str, Cell]] = [("dataset", str(dataset))]
    for key in ("protocol", "split", "preset"):
        items.append((key, _describe(_lookup(results, key))))
    items += [(str(k), _describe(v)) for k, v in settings.items() if k not in ("protocol", "split", "preset")]
    page.section("settings", "What was run", definitions(items))
    page.section("errors", "Errors", _error_tables(results))
    if (out / "results.png").exists():
        page.section("chart", "Chart", figure("results.png", "Both errors per interaction and on average, metres "
                                                            "(lower is better), one bar per method."))
    paired = _paired_section(results)
    if paired:
        page.section("paired", "Paired differences", paired)
    parse = results.get("parse_accuracy") or {}
    if parse:
        labels = list(parse)
        methods = sorted({m for lab in labels for m in parse[lab]})
        page.section("parse", "Sub-event parse accuracy", table(
            ["method", *labels], [[m, *(_number(parse[lab].get(m)) for lab in labels)] for m in methods],
            caption="Fraction of labelled frames whose parsed sub-event matches the ground truth after "
                    "one-to-one label matching per fold.",
        ))
    seconds = results.get("seconds") or {}
    if seconds:
        page.section("time", "Time", table(["method", "fit + predict, summed over tasks (s)"],
                                           [[m, _number(v)] for m, v in seconds.items()], digits=1))
    return page.write(out / EVALUATION_PAGE)
