"""Statistics of ``scripts/train_residual.py``: success rates with Wilson intervals and the paired
trained − zero-residual differences with stratified bootstrap intervals, strata = the episodes' tasks."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from scipy import stats

from socialaff_sim.errors import ConfigError
from socialaff_sim.evaluation.compare import paired_difference

__all__ = ["summarize", "wilson"]

def wilson(k: int, n: int) -> tuple[float, float]:
    """Wilson score 95 % interval of a binomial proportion k / n."""
    ci = stats.binomtest(k, n).proportion_ci(0.95, method="wilson")
    return float(ci.low), float(ci.high)


def _task(row: Mapping[str, Any]) -> str:
    """The stratum of an episode: its task's interaction (rows written before ``task`` existed: the label)."""
    return str(row.get("task", row["interaction"]))


def _by_label(rows: Sequence[Mapping[str, Any]], key: str) -> dict[str, np.ndarray]:
    out: dict[str, list[float]] = {}
    for r in rows:
        out.setdefault(_task(r), []).append(float(r[key]))
    return {k: np.array(v) for k, v in sorted(out.items())}


def _policy_summary(rows: Sequence[Mapping[str, Any]], rng: np.random.Generator) -> dict[str, Any]:
    k, n = sum(r["success"] for r in rows), len(rows)
    ret, ret_lo, ret_hi = paired_difference(list(_by_label(rows, "return").values()), rng=rng)
    return {"episodes": n, "successes": int(k), "success_rate": k / n, "success_ci95": wilson(int(k), n),
            "subgoals_met": float(np.mean([r["subgoals_met"] for r in rows])),
            "failure_rate": float(np.mean([r["failed"] for r in rows])),
            "mean_return": ret, "mean_return_ci95": (ret_lo, ret_hi)}


def summarize(residual: Sequence[Mapping[str, Any]], zero: Sequence[Mapping[str, Any]], seed: int) -> dict[str, Any]:
    """Rates and the paired residual − zero differences, overall (interactions weighted equally: the strata
    are the episodes' tasks, so SBU's ``shaking_hands`` and NuiSI's ``handshake`` are one stratum,
    ``shake_hands``), per interaction and, where a task has several labels, per label.

    Episodes are paired by (instance, seed); the difference intervals are stratified percentile bootstraps over
    the pairs (:func:`socialaff_sim.evaluation.compare.paired_difference`). ``target_met``: the overall success
    difference's interval lies above zero."""
    key = {(r["instance"], r["seed"]): r for r in zero}
    if sorted(key) != sorted((r["instance"], r["seed"]) for r in residual):
        raise ConfigError("summarize: the two policies must be evaluated on the same (instance, seed) episodes")
    pairs = [(r, key[(r["instance"], r["seed"])]) for r in residual]
    rng = np.random.default_rng(seed)

    def block(sel: Sequence[tuple[Mapping[str, Any], Mapping[str, Any]]]) -> dict[str, Any]:
        res, ref = [p[0] for p in sel], [p[1] for p in sel]
        out: dict[str, Any] = {"residual": _policy_summary(res, rng), "zero_residual": _policy_summary(ref, rng)}
        for metric in ("success", "subgoals_met", "return"):
            diffs: dict[str, list[float]] = {}
            for a, b in sel:
                diffs.setdefault(_task(a), []).append(float(a[metric]) - float(b[metric]))
            mean, lo, hi = paired_difference([np.array(v) for _, v in sorted(diffs.items())], rng=rng)
            out[f"paired_{metric}_difference"] = {"mean": mean, "ci95": (lo, hi)}
        out["residual_only_successes"] = sum(a["success"] and not b["success"] for a, b in sel)
        out["zero_only_successes"] = sum(b["success"] and not a["success"] for a, b in sel)
        return out

    summary = block(pairs)
    summary["per_interaction"] = {task: block([p for p in pairs if _task(p[0]) == task])
                                  for task in sorted({_task(p[0]) for p in pairs})}
    labels = sorted({p[0]["interaction"] for p in pairs})
    if len(labels) > len(summary["per_interaction"]):
        summary["per_label"] = {lbl: block([p for p in pairs if p[0]["interaction"] == lbl]) for lbl in labels}
    summary["target_met"] = bool(summary["paired_success_difference"]["ci95"][0] > 0.0)
    return summary
