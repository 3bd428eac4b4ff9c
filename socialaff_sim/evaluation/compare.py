"""Paired comparison of two methods' errors on the same test instances, with a bootstrap interval.

Two methods evaluated on the same folds are scored on the same test instances, so their errors are
paired: the spread that matters for "is A lower than B" is that of the per-instance differences, not
of each method's errors. The average error of an evaluation is the mean over classes of each class's
mean over its test instances; the interval here resamples the instances within each class (a
stratified percentile bootstrap), so it belongs to exactly that average.

The interval covers the sampling of the test instances only. The methods are fitted once per fold,
so the variation from refitting (another run seed: other MCMC chains, other k-means starts) is not in
it; docs/design.md shows cases where that variation is as large as the interval.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError, choices
from .metrics import METRICS, is_horizon_metric

__all__ = ["PairedDifference", "paired_difference", "paired_differences"]


@dataclass(frozen=True)
class PairedDifference:
    """Average error of ``method`` minus that of ``reference`` over the instances both scored."""

    method: str
    reference: str
    mean_m: float
    """Mean over classes of the class-mean difference (metres; negative: ``method`` is lower)."""
    low_m: float
    """Lower end of the bootstrap interval (metres)."""
    high_m: float
    """Upper end of the bootstrap interval (metres)."""
    confidence: float
    """Confidence level of [low_m, high_m], e.g. 0.95."""
    n_instances: int
    """Instances paired, over all classes."""

    @property
    def verdict(self) -> str:
        """``"lower"`` or ``"higher"`` when the interval excludes 0, else ``"indistinguishable"``."""
        if self.high_m < 0.0:
            return "lower"
        if self.low_m > 0.0:
            return "higher"
        return "indistinguishable"


def paired_difference(
    differences: Sequence[np.ndarray],
    *,
    confidence: float = 0.95,
    n_resamples: int = 10_000,
    rng: np.random.Generator,
) -> tuple[float, float, float]:
    """(mean, low, high) of the mean over classes of the class means of ``differences`` (one (n_c,)
    array per class, n_c ≥ 1), with a stratified percentile bootstrap interval at ``confidence``."""
    if not 0.0 < confidence < 1.0:
        raise ConfigError(f"confidence: expected a number in (0, 1), found {confidence!r}")
    if isinstance(n_resamples, bool) or not isinstance(n_resamples, int) or n_resamples < 1:
        raise ConfigError(f"n_resamples: expected an integer >= 1, found {n_resamples!r}")
    groups = [np.asarray(d, float).ravel() for d in differences]
    if not groups or any(g.size == 0 for g in groups):
        raise ConfigError("differences: expected at least one class, each with at least one instance")
    point = float(np.mean([g.mean() for g in groups]))
    boot = np.zeros(n_resamples)
    for g in groups:  # one vectorized draw per class: (B, n_c) indices
        boot += g[rng.integers(0, g.size, size=(n_resamples, g.size))].mean(axis=1)
    boot /= len(groups)
    tail = 100.0 * (1.0 - confidence) / 2.0
    low, high = np.percentile(boot, [tail, 100.0 - tail])
    return point, float(low), float(high)


def _scores(per_instance: Mapping[str, Mapping[str, Sequence[Mapping[str, object]]]], label: str, method: str, metric: str) -> dict[tuple[str, int], float]:
    """{(instance, fold): error}; a missing error (``None`` in a saved results.json) reads as NaN."""
    return {
        (str(r["instance_id"]), int(r["fold"])): math.nan if r[metric] is None else float(r[metric])  # type: ignore[arg-type]
        for r in per_instance[label][method]
    }


def paired_differences(
    results: Mapping[str, object],
    reference: str,
    *,
    metric: str = "key_joint_error_m",
    confidence: float = 0.95,
    n_resamples: int = 10_000,
    rng: np.random.Generator,
) -> dict[str, PairedDifference]:
    """Each other method of an evaluation's ``results`` (as :func:`~socialaff_sim.evaluation.evaluate`
    returns them) against ``reference``, paired by (instance, fold) within each class; instances
    where either error is NaN are left out, and so are classes with no pair left.

    One seed is drawn from ``rng`` and every method's bootstrap starts from it, so a method's interval
    does not depend on which other methods were evaluated or in what order, and methods paired on the
    same instances are resampled with the same draws (common random numbers)."""
    per_instance = results["per_instance"]
    methods = list(results["average"])  # type: ignore[call-overload]
    if reference not in methods:
        raise ConfigError(f"reference: {reference!r} is not among the evaluated methods {choices(methods)}")
    if metric not in METRICS and not is_horizon_metric(metric):
        raise ConfigError(f"metric: expected one of {choices(METRICS)}, found {metric!r}")
    refs = {label: _scores(per_instance, label, reference, metric) for label in per_instance}  # type: ignore[arg-type, union-attr]
    seed = int(rng.integers(0, 2**63 - 1))
    out: dict[str, PairedDifference] = {}
    for m in methods:
        if m == reference:
            continue
        diffs = []
        for label, ref in refs.items():
            other = _scores(per_instance, label, m, metric)  # type: ignore[arg-type]
            d = [other[k] - ref[k] for k in ref if k in other and math.isfinite(other[k]) and math.isfinite(ref[k])]
            if d:
                diffs.append(np.array(d))
        if not diffs:
            continue
        mean, low, high = paired_difference(diffs, confidence=confidence, n_resamples=n_resamples,
                                            rng=np.random.default_rng(seed))
        out[m] = PairedDifference(m, reference, mean, low, high, confidence, sum(d.size for d in diffs))
    return out
