"""Run Experiment 1: every (class, fold, method) task on an executor, then aggregate.

Executors: a local process pool (default), a Ray cluster (optional extra
``socialaff-sim[distributed]``) or the calling process. Results are identical
whichever is used (only the timings differ).

The process pool starts its workers with the ``spawn`` method, so a script
that calls :func:`evaluate` must guard its entry point with
``if __name__ == "__main__":``, and registered method factories must be
importable by name (module-level functions or classes).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from multiprocessing import get_context

import numpy as np

from ..data.dataset import Dataset
from ..errors import ConfigError, choices
from .compare import paired_differences
from .crossval import EvaluationConfig, Task, TaskResult, make_method, make_tasks, run_task
from .metrics import METRICS, horizon_metric, matched_accuracy
from .registry import get_method
from .splits import OPTIMISTIC_SPLITS

__all__ = ["BASELINES", "best_baseline", "evaluate", "paired_comparisons", "run_tasks", "run_title"]

Progress = Callable[[str], None]

PAIRED_CONFIDENCE = 0.95
"""Confidence level of the paired bootstrap intervals in ``results.json``."""
PAIRED_RESAMPLES = 10_000
"""Bootstrap resamples of those intervals."""


_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS")


@contextmanager
def _single_threaded_children() -> Iterator[None]:
    """Set the BLAS/OpenMP thread variables to 1 for processes spawned inside the block.

    One task per core: without this each worker's BLAS would start a thread per
    core and the workers would oversubscribe the machine. The parent's own
    environment is restored afterwards.
    """
    saved = {k: os.environ.get(k) for k in _THREAD_VARS}
    os.environ.update({k: "1" for k in _THREAD_VARS})
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _run_process(tasks: Sequence[Task], workers: int | None, progress: Progress | None) -> list[TaskResult]:
    n = max(min(workers or os.cpu_count() or 1, len(tasks)), 1)
    out = []
    # "spawn": fresh interpreters that read the thread variables at start-up (a fork would
    # inherit the parent's already initialized BLAS thread pool).
    with _single_threaded_children(), ProcessPoolExecutor(max_workers=n, mp_context=get_context("spawn")) as pool:
        futures = {pool.submit(run_task, t): t for t in tasks}
        for k, fut in enumerate(as_completed(futures), 1):
            res = fut.result()
            out.append(res)
            if progress:
                progress(f"[{k}/{len(tasks)}] {res.method} on {res.label} fold {res.fold}: {res.seconds:.1f} s")
    return out


def _run_ray(tasks: Sequence[Task], workers: int | None, address: str | None, progress: Progress | None) -> list[TaskResult]:
    try:
        import ray
    except ImportError:
        raise ConfigError(
            "executor 'ray' needs Ray, which is not installed: pip install socialaff-sim[distributed] "
            "(or use --executor process)"
        ) from None
    started = not ray.is_initialized()
    if started:
        kwargs: dict[str, object] = {"include_dashboard": False, "log_to_driver": False}
        if address is not None:
            kwargs["address"] = address
        elif workers is not None:
            kwargs["num_cpus"] = workers
        ray.init(**kwargs)
    try:
        remote = ray.remote(num_cpus=1)(run_task)
        pending = {remote.remote(t): t for t in tasks}
        out = []
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            for ref in done:
                pending.pop(ref)
                res = ray.get(ref)
                out.append(res)
                if progress:
                    progress(f"[{len(out)}/{len(tasks)}] {res.method} on {res.label} fold {res.fold}: {res.seconds:.1f} s")
        return out
    finally:
        if started:
            ray.shutdown()


def run_tasks(tasks: Sequence[Task], config: EvaluationConfig, progress: Progress | None = None) -> list[TaskResult]:
    """Run tasks on the configured executor; results sorted by (class, fold, method)."""
    if not tasks:
        return []
    if config.executor == "serial":
        out = []
        for k, t in enumerate(tasks, 1):
            out.append(run_task(t))
            if progress:
                progress(f"[{k}/{len(tasks)}] {t.method} on {t.label} fold {t.fold}: {out[-1].seconds:.1f} s")
    elif config.executor == "process":
        out = _run_process(tasks, config.workers, progress)
    else:
        out = _run_ray(tasks, config.workers, config.address, progress)
    return sorted(out, key=lambda r: (r.label, r.fold, r.method))


def _mean(values: list[float]) -> float:
    finite = [v for v in values if not math.isnan(v)]
    return float(np.mean(finite)) if finite else float("nan")


BASELINES: tuple[str, ...] = ("hold", "constvel", "hmm", "promp", "ridge", "gru")
"""The baselines among which the best (lowest average key-joint error) is the second paired reference."""


def evaluate(
    dataset: Dataset,
    methods: Sequence[str],
    *,
    interactions: Sequence[str] | None = None,
    config: EvaluationConfig | None = None,
    progress: Progress | None = None,
) -> dict[str, object]:
    """k-fold cross-validation of each method per class under one protocol and split.

    Returns the content of ``results.json`` (strict JSON once NaN is written as null)::

        {"dataset": str,
         "protocol": "causal" | "paper" | "offline",  # what the methods saw (evaluation.streaming)
         "split": "pair" | "actor" | "recording" | "block",  # how the folds hold data apart (evaluation.splits)
         "preset": "default" | "paper",                # configurations of the affordance methods
         "upper_bound": bool,                          # true for the offline protocol
         "optimistic": bool,                           # true for the block split
         "title": str,                                 # one line naming all of the above, for every table
         "per_interaction": {class: {method: {"key_joint_error_m", "joint_error_m", "n_test",
                                              "key_joint_error_<h>s_m" for each horizon h}}},
         "average": {method: {"key_joint_error_m", "joint_error_m", "key_joint_error_<h>s_m" …}},
         "horizons_s": [h, …],                          # forecast horizons (empty under offline: null errors)
         "latency_ms": {method: {"p50", "p99", "max", "n_calls"}},  # wall time per reactor call
         "seconds": {method: float},
         "parse_accuracy": {class: {method: float}},   # where ground truth and a parse exist
         "excluded": {class: int},                      # test instances with T <= T0 + 1
         "per_instance": {class: {method: [{"instance_id", "fold", "key_joint_error_m", "joint_error_m",
                                            "key_joint_error_<h>s_m" …}]}},
         "paired": {comparison: {"reference": method, "confidence": 0.95, "n_resamples": int,
                                 "differences": {metric: {method: {"mean_m", "low_m", "high_m",
                                                                   "n_instances", "verdict"}}}}},
         "settings": {"n_folds", "n_observed", "seed", "protocol", "split", "preset", "max_folds", "max_test",
                      "methods", "interactions", "n_test_available", "horizons_s", "horizon_every_s",
                      "replicates": {method: r}}}   # each method's replicate (EvaluationConfig.replicate)

    ``paired`` has up to two comparisons: ``"hold"`` (every method minus ``hold``, when ``hold`` was
    evaluated) and ``"best_baseline"`` (every method minus the evaluated baseline of :data:`BASELINES`
    with the lowest average key-joint error; its name is the entry's ``reference``), each instance by
    instance (:func:`~socialaff_sim.evaluation.compare.paired_differences`; the bootstrap draws from
    a generator seeded by ``config.seed``). A difference is negative when the method is lower.

    A class's error is the mean over its test instances of each instance's mean
    distance over the synthesized frames; ``average`` is the mean over classes;
    ``seconds`` sums each method's fit + predict wall time over its tasks. The horizon
    errors ``key_joint_error_<h>s_m`` (e.g. ``key_joint_error_0.5s_m``) are the errors of the
    forecasts h seconds ahead of each forecast time (:mod:`.streaming`, docs/evaluation.md), averaged
    the same way; ``paired`` carries them too. ``latency_ms`` pools the wall time of every call of a
    method's reactor on every test instance (one call per frame under ``causal``; measured while other
    tasks may share the machine, so compare methods of one run, not runs). Parse
    accuracy matches the method's labels to the ground truth one-to-one per fold
    (pooled over the fold's test instances, all frames with a ground-truth label)
    and weighs the folds by their labelled frames. Test instances with
    T ≤ T0 + 1 are left out of testing (counted in ``excluded``) but still train.
    """
    config = config or EvaluationConfig()
    if not methods:
        raise ConfigError("methods: expected at least one method name")
    if len(set(methods)) != len(methods):
        raise ConfigError(f"methods: each method at most once, found {list(methods)}")
    factories = [(m, get_method(m)) for m in methods]
    for _, factory in factories:  # fail before any task runs (e.g. gru without torch names the extra)
        make_method(factory, config.preset)
    hkeys = [horizon_metric(h) for h in config.horizons_s]
    metrics = list(METRICS) + hkeys
    labels = list(interactions) if interactions else list(dataset.labels)
    unknown = [lab for lab in labels if lab not in dataset.labels]
    if unknown:
        raise ConfigError(f"interactions: {unknown} not in dataset {dataset.name!r}; present: {choices(dataset.labels)}")
    tasks, excluded, n_test = make_tasks(dataset, factories, labels, config)
    results = run_tasks(tasks, config, progress)

    per_interaction: dict[str, dict[str, dict[str, float | int]]] = {}
    per_instance: dict[str, dict[str, list[dict[str, object]]]] = {}
    parse: dict[str, dict[str, float]] = {}
    seconds = {m: 0.0 for m in methods}
    calls: dict[str, list[np.ndarray]] = {m: [] for m in methods}
    for label in labels:
        per_interaction[label], per_instance[label] = {}, {}
        for m in methods:
            mine = [r for r in results if r.label == label and r.method == m]
            scores = [(r.fold, s) for r in mine for s in r.scores]
            per_interaction[label][m] = {
                "key_joint_error_m": _mean([s.key_joint_error_m for _, s in scores]),
                "joint_error_m": _mean([s.joint_error_m for _, s in scores]),
                "n_test": len(scores),
            }
            for i, key in enumerate(hkeys):
                per_interaction[label][m][key] = _mean([s.horizon_errors_m[i] for _, s in scores])
            per_instance[label][m] = [
                {"instance_id": s.instance_id, "fold": f, "key_joint_error_m": s.key_joint_error_m, "joint_error_m": s.joint_error_m,
                 **{key: s.horizon_errors_m[i] for i, key in enumerate(hkeys)}}
                for f, s in scores
            ]
            calls[m].append(np.concatenate([r.call_seconds for r in mine]) if mine else np.zeros(0))
            seconds[m] += sum(r.seconds for r in mine)
            parsed = [r for r in mine if r.confusion is not None]
            if parsed:
                acc = [matched_accuracy(r.confusion, r.n_labelled) * r.n_labelled for r in parsed]
                total = sum(r.n_labelled for r in parsed)
                if total:
                    parse.setdefault(label, {})[m] = float(sum(acc) / total)
    average = {
        m: {
            key: _mean([float(per_interaction[lab][m][key]) for lab in labels])
            for key in metrics
        }
        for m in methods
    }
    out: dict[str, object] = {
        "dataset": dataset.name,
        "protocol": config.protocol,
        "split": config.split,
        "preset": config.preset,
        "upper_bound": config.protocol == "offline",
        "optimistic": config.split in OPTIMISTIC_SPLITS,
        "title": run_title(dataset.name, config),
        "per_interaction": per_interaction,
        "average": average,
        "horizons_s": list(config.horizons_s),
        "latency_ms": {m: _latency(np.concatenate(calls[m])) for m in methods},
        "seconds": seconds,
        "parse_accuracy": parse,
        "excluded": excluded,
        "per_instance": per_instance,
        "settings": {
            "n_folds": config.n_folds,
            "n_observed": config.n_observed,
            "seed": config.seed,
            "protocol": config.protocol,
            "split": config.split,
            "preset": config.preset,
            "max_folds": config.max_folds,
            "max_test": config.max_test,
            "methods": list(methods),
            "interactions": labels,
            "n_test_available": n_test,
            "horizons_s": list(config.horizons_s),
            "horizon_every_s": config.horizon_every_s,
            "replicates": {m: config.replicate for m in methods},
        },
    }
    out["paired"] = paired_comparisons(out, config.seed, metrics)
    return out


def paired_comparisons(results: dict[str, object], seed: int, metrics: Sequence[str] = METRICS) -> dict[str, object]:
    """The ``paired`` entry of ``results.json`` for ``results`` (with its ``average`` and ``per_instance``):
    every method against ``hold`` (when evaluated) and against the best baseline, bootstrap seeded by ``seed``."""
    average: dict[str, dict[str, float]] = results["average"]  # type: ignore[assignment]
    paired: dict[str, object] = {}
    if len(average) > 1:
        if "hold" in average:
            paired["hold"] = _paired(results, "hold", seed, 0, metrics)
        best = best_baseline(average)
        if best is not None:
            paired["best_baseline"] = _paired(results, best, seed, 1, metrics)
    return paired


def run_title(dataset: str, config: EvaluationConfig) -> str:
    """One line naming the dataset, protocol, split and preset (with "upper bound" / "optimistic" where due)."""
    protocol = f"{config.protocol} protocol" + (" (upper bound: agent 0's future is seen)" if config.protocol == "offline" else "")
    split = f"{config.n_folds}-fold {config.split}-disjoint split" if config.split != "block" else (
        f"{config.n_folds}-fold block split (optimistic: same people and session in training and test)"
    )
    limited = f", only the first {config.max_folds} of the {config.n_folds} folds run" if config.max_folds else ""
    limited += f", at most {config.max_test} test instances per fold" if config.max_test else ""
    limited += f", method replicate {config.replicate}" if config.replicate else ""
    return f"`{dataset}`, {protocol}, {split}, preset {config.preset}{limited}"


def best_baseline(average: dict[str, dict[str, float]]) -> str | None:
    """The evaluated baseline of :data:`BASELINES` with the lowest average key-joint error, if any."""
    scored = [(average[m]["key_joint_error_m"], m) for m in BASELINES if m in average]
    scored = [(v, m) for v, m in scored if not math.isnan(v)]
    return min(scored)[1] if scored else None


def _latency(call_seconds: np.ndarray) -> dict[str, float | int]:
    """p50, p99 and max of the per-call wall times, milliseconds, and the number of calls."""
    if call_seconds.size == 0:
        return {"p50": float("nan"), "p99": float("nan"), "max": float("nan"), "n_calls": 0}
    p50, p99 = np.percentile(call_seconds * 1e3, [50, 99])
    return {"p50": float(p50), "p99": float(p99), "max": float(call_seconds.max() * 1e3), "n_calls": int(call_seconds.size)}


def _paired(results: dict[str, object], reference: str, seed: int, comparison: int,
            metrics: Sequence[str] = METRICS) -> dict[str, object]:
    """One entry of ``paired`` in ``results.json``: each method minus ``reference``, per metric."""
    differences: dict[str, dict[str, dict[str, object]]] = {}
    for k, metric in enumerate(metrics):
        # spawn key 2: apart from the folds' (0, …) and the tasks' (1, …) streams of the same seed
        rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(2, comparison, k)))
        pairs = paired_differences(results, reference, metric=metric, confidence=PAIRED_CONFIDENCE,
                                   n_resamples=PAIRED_RESAMPLES, rng=rng)
        differences[metric] = {
            m: {"mean_m": p.mean_m, "low_m": p.low_m, "high_m": p.high_m, "n_instances": p.n_instances, "verdict": p.verdict}
            for m, p in pairs.items()
        }
    return {"reference": reference, "confidence": PAIRED_CONFIDENCE, "n_resamples": PAIRED_RESAMPLES, "differences": differences}
