"""Reusing methods' results from an earlier evaluation with the same data, folds, seed and protocol.

A new method (or a changed one) is usually compared with baselines whose code has not changed. Fitting them
again costs time and gives the same numbers; :func:`reuse_results` takes them from an earlier ``results.json``
instead, after checking that both runs tested the same instances in the same folds under the same settings,
and recomputes the paired comparisons over the union. The merged results name what was reused and from where
(``reused``), and every table rendered from them says so.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping
from typing import Any

from ..errors import ConfigError
from .crossval import EvaluationConfig
from .metrics import METRICS, horizon_metric
from .runner import paired_comparisons

__all__ = ["SAME_SETTINGS", "check_reusable", "reuse_results"]

SAME_SETTINGS = (
    "n_folds", "n_observed", "seed", "protocol", "split", "preset", "max_folds", "max_test",
    "interactions", "n_test_available", "horizons_s", "horizon_every_s",
)
"""The ``settings`` of ``results.json`` that must be equal for results to be reused."""

_PER_METHOD = ("average", "latency_ms", "seconds")
"""The top-level entries of ``results.json`` keyed by method."""


def _instances(per_instance: Mapping[str, Any], label: str, method: str) -> list[tuple[str, int]]:
    return sorted((str(r["instance_id"]), int(r["fold"])) for r in per_instance[label][method])


def _nan(value: Any) -> Any:
    """``None`` (how a saved results.json writes NaN) back to NaN, recursively."""
    if value is None:
        return math.nan
    if isinstance(value, Mapping):
        return {k: _nan(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_nan(v) for v in value]
    return value


def _compare(source: str, key: str, theirs: Any, mine: Any) -> None:
    if theirs != mine:
        raise ConfigError(
            f"{source}: settings.{key} is {theirs!r}, this run's is {mine!r}; results can be "
            "reused only from a run with the same data, folds, seed and protocol"
        )


def check_reusable(earlier: Mapping[str, Any], dataset: str, config: EvaluationConfig,
                   interactions: list[str], source: str) -> None:
    """Before any fit: raise :class:`~socialaff_sim.errors.ConfigError` if ``earlier`` was run on another
    dataset or with other folds, seed, protocol, split, preset, limits or classes than ``config``."""
    if earlier.get("dataset") != dataset:
        raise ConfigError(f"{source}: dataset is {earlier.get('dataset')!r}, this run's is {dataset!r}")
    theirs = earlier.get("settings") or {}
    for key in ("n_folds", "n_observed", "seed", "protocol", "split", "preset", "max_folds", "max_test"):
        _compare(source, key, theirs.get(key), getattr(config, key))
    _compare(source, "interactions", theirs.get("interactions"), list(interactions))
    _compare(source, "horizons_s", theirs.get("horizons_s"), list(config.horizons_s))


def reuse_results(results: Mapping[str, Any], earlier: Mapping[str, Any], source: str) -> dict[str, Any]:
    """``results`` (of :func:`~socialaff_sim.evaluation.evaluate`) plus every method of ``earlier`` that
    ``results`` does not have, with the paired comparisons recomputed over all of them.

    ``earlier`` is a loaded ``results.json``; ``source`` names it in errors and in the merged ``reused``
    entry. Raises :class:`~socialaff_sim.errors.ConfigError` naming the first field that differs: the
    dataset, a setting of :data:`SAME_SETTINGS`, or a class's tested (instance, fold) pairs. A method in
    both is taken from ``results`` (the new run). The merged order is ``results``' methods that ``earlier``
    lacks, then ``earlier``'s order (so that re-running some of a run's methods reproduces its tables,
    bootstrap draws included, when their errors are the same).
    """
    if earlier.get("dataset") != results["dataset"]:
        raise ConfigError(f"{source}: dataset is {earlier.get('dataset')!r}, this run's is {results['dataset']!r}")
    mine, theirs = results["settings"], earlier.get("settings") or {}
    for key in SAME_SETTINGS:
        _compare(source, key, theirs.get(key), mine.get(key))
    new_methods = list(results["average"])
    reused = [m for m in earlier["average"] if m not in new_methods]
    if not reused:
        raise ConfigError(f"{source}: no method to reuse: its methods {list(earlier['average'])} were all run again")
    out = copy.deepcopy(dict(results))
    theirs_per_instance = earlier["per_instance"]
    for label in mine["interactions"]:
        wanted = _instances(results["per_instance"], label, new_methods[0])
        for m in reused:
            if _instances(theirs_per_instance, label, m) != wanted:
                raise ConfigError(
                    f"{source}: per_instance.{label}.{m} tests other (instance, fold) pairs than this run; "
                    "results can be reused only from a run with the same data, folds, seed and protocol"
                )
            out["per_instance"][label][m] = _nan(copy.deepcopy(theirs_per_instance[label][m]))
            out["per_interaction"][label][m] = _nan(dict(earlier["per_interaction"][label][m]))
            parse = (earlier.get("parse_accuracy") or {}).get(label, {})
            if m in parse:
                out["parse_accuracy"].setdefault(label, {})[m] = _nan(parse[m])
    for key in _PER_METHOD:
        for m in reused:
            out[key][m] = _nan(copy.deepcopy(earlier[key][m]))
    order = [m for m in new_methods if m not in earlier["average"]] + list(earlier["average"])
    for key in _PER_METHOD:
        out[key] = {m: out[key][m] for m in order}
    for label in mine["interactions"]:
        for key in ("per_interaction", "per_instance"):
            out[key][label] = {m: out[key][label][m] for m in order}
    out["settings"]["methods"] = order
    # files written before replicates existed ran replicate 0
    replicates = {**(theirs.get("replicates") or {}), **(mine.get("replicates") or {})}
    out["settings"]["replicates"] = {m: int(replicates.get(m, 0)) for m in order}
    out["reused"] = {"from": source, "methods": reused}
    if earlier.get("reused"):  # the earlier file reused rows itself: keep where they came from
        out["reused"]["earlier"] = copy.deepcopy(earlier["reused"])
    metrics = list(METRICS) + [horizon_metric(h) for h in mine["horizons_s"]]
    out["paired"] = paired_comparisons(out, int(mine["seed"]), metrics)
    return out
