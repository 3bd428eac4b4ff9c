"""The zero-residual reference and the console report of ``scripts/train_residual.py``.

A ``--reference-only`` run writes ``reference.json`` (the zero residual on the training instances); a later run
may reuse it (``--reference``) only when it was made with the same training set, models and training reward
(:data:`REFERENCE_KEYS`). The report lines are what the script prints after a run.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from socialaff_sim.errors import ConfigError

__all__ = ["REFERENCE_KEYS", "load_reference", "load_start_reference", "reference_lines", "reference_summary", "result_lines"]

REFERENCE_KEYS = ("labels", "seed", "train_instances", "fit_iterations", "train_affordance_weight", "physics",
                  "train_fall_penalty", "control_dt", "max_frames", "robot", "data", "split", "folds", "held_out_fold")
"""Settings a ``reference.json`` must share with a run that reuses it (the training set, the models and the
training reward)."""


def reference_summary(rows: Sequence[dict[str, Any]], labels: Sequence[str]) -> dict[str, dict[str, float]]:
    """Per label, the success rate and mean return of the zero residual's training rows (the learning curve's
    dashed references)."""
    return {lbl: {"success": float(np.mean([r["success"] for r in rows if r["interaction"] == lbl])),
                  "return": float(np.mean([r["return"] for r in rows if r["interaction"] == lbl]))}
            for lbl in labels}


def load_reference(path: Path, s: Any) -> dict[str, dict[str, float]]:
    """The zero-residual reference of a ``--reference-only`` run, checked to be of the same training set as the
    run's settings ``s`` (a ``train_residual.Settings``)."""
    saved = json.loads(path.read_text())
    mine = json.loads(json.dumps(dataclasses.asdict(s)))
    default = json.loads(json.dumps(dataclasses.asdict(type(s)())))  # a key older files lack had its default
    differ = [k for k in REFERENCE_KEYS if saved["settings"].get(k, default[k]) != mine[k]]
    if differ:
        raise ConfigError(f"--reference {path}: made with other settings ({', '.join(differ)}); expected the run's own")
    return saved["train_reference_zero_residual"]


def load_start_reference(path: Path, s: Any) -> dict[str, dict[str, float]] | None:
    """The start's reference (the zero action through the gate and bias) of a ``--reference-only`` run of the same
    training set (:func:`load_reference`'s check) and the same ``residual_labels`` and ``action_bias``; ``None``
    when the file has none or another gate or bias."""
    load_reference(path, s)
    saved = json.loads(path.read_text())
    mine = json.loads(json.dumps(dataclasses.asdict(s)))
    if "train_reference_start" not in saved or any(saved["settings"].get(k) != mine[k]
                                                    for k in ("residual_labels", "action_bias")):
        return None
    return saved["train_reference_start"]


def reference_lines(r: dict[str, Any]) -> list[str]:
    """The report of a ``--reference-only`` run."""
    out = []
    for key, name in (("train_reference_zero_residual", "zero residual"), ("train_reference_start", "start")):
        for lbl, ref in r.get(key, {}).items():
            n = sum(row["interaction"] == lbl for row in r["episodes"])
            out.append(f"{lbl:14s} {name} on the training instances: success {ref['success']:.3f} (n={n}), "
                       f"return {ref['return']:.2f}")
    return out


def result_lines(r: dict[str, Any]) -> list[str]:
    """The report of a training run: per block, both policies' success and return, the paired differences."""
    out = []
    for key, name, ref in (("summary", "residual", "zero"), ("summary_constant", "constant", "zero"),
                           ("summary_start", "start", "zero"), ("summary_learned", "residual", "start")):
        if key not in r:
            continue
        sm = r[key]
        for label, block in [("all", sm), *sm["per_interaction"].items(), *sm.get("per_label", {}).items()]:
            for pol in ("zero_residual", "residual"):
                p = block[pol]
                out.append(f"{label:12s} {name if pol == 'residual' else ref:14s} success {p['success_rate']:.3f} "
                           f"[{p['success_ci95'][0]:.3f}, {p['success_ci95'][1]:.3f}]  return {p['mean_return']:7.2f} "
                           f"[{p['mean_return_ci95'][0]:.2f}, {p['mean_return_ci95'][1]:.2f}]  n={p['episodes']}")
            dsu, dre = block["paired_success_difference"], block["paired_return_difference"]
            out.append(f"{label:12s} paired {name} - {ref}: success {dsu['mean']:+.3f} [{dsu['ci95'][0]:+.3f}, "
                       f"{dsu['ci95'][1]:+.3f}]  return {dre['mean']:+.2f} [{dre['ci95'][0]:+.2f}, {dre['ci95'][1]:+.2f}]")
    sel = r.get("selection")
    if sel:
        cps = ", ".join(f"{c['updates']}: {c['successes']}" for c in sel["checkpoints"])
        chosen = "the start (nothing trained counts)" if sel["chosen"] is None else \
            f"the checkpoint after {sel['checkpoints'][sel['chosen']]['updates']} updates"
        out.append(f"selection on {sel['episodes']} training episodes: start {sel['start']['successes']}; "
                   f"checkpoints (updates: successes) {cps}; chosen: {chosen}")
    out.append(f"target met: {r['summary']['target_met']}; trained {r['timesteps_trained']} steps"
               f"{' (stopped by the budget)' if r['stopped_by_budget'] else ''} in {r['train_wall_s']:.0f} s wall; "
               f"total {r['total_wall_s']:.0f} s")
    return out
