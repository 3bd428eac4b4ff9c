"""Paired comparison of methods: the stratified bootstrap against scipy.stats.bootstrap, pairing and verdicts."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from socialaff_sim.errors import ConfigError
from socialaff_sim.evaluation import PairedDifference, paired_differences
from socialaff_sim.evaluation.compare import paired_difference


def _scipy_interval(samples: list[np.ndarray], rng: np.random.Generator, n: int) -> tuple[float, float]:
    """scipy's percentile bootstrap of the mean of sample means; with several samples and paired=False
    it resamples each sample on its own, which is the stratified bootstrap."""

    def stat(*xs: np.ndarray, axis: int) -> np.ndarray:
        return np.mean([x.mean(axis=axis) for x in xs], axis=0)

    res = stats.bootstrap(tuple(samples), stat, n_resamples=n, method="percentile", vectorized=True, rng=rng)
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


@pytest.mark.parametrize("sizes", [(40,), (12, 30, 7)])
def test_interval_matches_scipy_bootstrap(sizes: tuple[int, ...], rng: np.random.Generator) -> None:
    samples = [rng.normal(loc=0.01 * k, scale=0.02 * (k + 1), size=n) for k, n in enumerate(sizes)]
    mean, low, high = paired_difference(samples, n_resamples=40_000, rng=np.random.default_rng(rng.integers(2**32)))
    ref_low, ref_high = _scipy_interval(samples, np.random.default_rng(rng.integers(2**32)), 40_000)
    se = np.sqrt(sum(s.var() / s.size for s in samples)) / len(samples)  # closed-form SD of the bootstrap statistic
    np.testing.assert_allclose(mean, np.mean([s.mean() for s in samples]), rtol=1e-12)
    # two independent Monte Carlo estimates of the same percentiles: agree to a small share of the standard error
    np.testing.assert_allclose([low, high], [ref_low, ref_high], rtol=0, atol=0.05 * se)
    # and for these sizes the percentile interval is close to the normal one, mean ± 1.96 se
    np.testing.assert_allclose([low, high], [mean - 1.96 * se, mean + 1.96 * se], rtol=0, atol=0.25 * se)


def test_a_class_with_one_instance_adds_a_constant(rng: np.random.Generator) -> None:
    other = rng.normal(scale=0.01, size=25)
    mean, low, high = paired_difference([other, np.array([0.3])], n_resamples=20_000, rng=np.random.default_rng(1))
    m1, l1, h1 = paired_difference([other], n_resamples=20_000, rng=np.random.default_rng(1))
    np.testing.assert_allclose([mean, low, high], [(m1 + 0.3) / 2, (l1 + 0.3) / 2, (h1 + 0.3) / 2], rtol=0, atol=1e-12)


def _results(per_class: dict[str, dict[str, list[tuple[str, int, float | None]]]]) -> dict[str, object]:
    methods = list(next(iter(per_class.values())))
    return {
        "average": {m: {} for m in methods},
        "per_instance": {
            label: {m: [{"instance_id": i, "fold": f, "key_joint_error_m": e, "joint_error_m": e} for i, f, e in rows] for m, rows in by.items()}
            for label, by in per_class.items()
        },
    }


def test_pairs_by_instance_and_fold_and_drops_missing_errors() -> None:
    ref = [("x0", 0, 0.10), ("x1", 0, 0.20), ("x2", 1, 0.30), ("x3", 1, None)]  # None: as a saved results.json has NaN
    lower = [("x3", 1, 0.05), ("x2", 1, 0.25), ("x1", 0, 0.15), ("x0", 0, 0.05)]  # other order; 0.05 lower each
    same = [(i, f, None if e is None else e + d) for (i, f, e), d in zip(ref, (0.01, -0.01, 0.0, 0.0), strict=True)]
    results = _results({"a": {"full": ref, "lower": lower, "same": same}, "b": {"full": ref[:2], "lower": lower[2:], "same": same[:2]}})
    out = paired_differences(results, "full", n_resamples=2000, rng=np.random.default_rng(0))
    assert set(out) == {"lower", "same"}
    low = out["lower"]
    assert isinstance(low, PairedDifference) and low.n_instances == 3 + 2
    # every pair differs by exactly -0.05: the interval collapses onto it
    np.testing.assert_allclose([low.mean_m, low.low_m, low.high_m], [-0.05] * 3, rtol=0, atol=1e-12)
    assert low.verdict == "lower"
    assert out["same"].verdict == "indistinguishable" and out["same"].low_m < 0 < out["same"].high_m
    again = paired_differences(results, "full", n_resamples=2000, rng=np.random.default_rng(0))
    assert again == out


def test_errors_list_the_choices() -> None:
    results = _results({"a": {"full": [("x", 0, 0.1)], "hmm": [("x", 0, 0.2)]}})
    with pytest.raises(ConfigError, match=r"reference: 'v1' is not among the evaluated methods.*full.*hmm"):
        paired_differences(results, "v1", rng=np.random.default_rng(0))
    with pytest.raises(ConfigError, match="metric: expected one of"):
        paired_differences(results, "full", metric="error", rng=np.random.default_rng(0))
    with pytest.raises(ConfigError, match="confidence"):
        paired_difference([np.zeros(3)], confidence=1.5, rng=np.random.default_rng(0))
    with pytest.raises(ConfigError, match="at least one instance"):
        paired_difference([np.zeros(0)], rng=np.random.default_rng(0))


def test_a_methods_interval_does_not_depend_on_the_other_methods(rng: np.random.Generator) -> None:
    def rows(errors: np.ndarray) -> list[tuple[str, int, float | None]]:
        return [(f"x{i}", i % 4, float(e)) for i, e in enumerate(errors)]

    ref = {c: rng.uniform(0.1, 0.3, size=n) for c, n in (("a", 30), ("b", 17))}
    full = {c: r + rng.normal(-0.01, 0.02, size=r.size) for c, r in ref.items()}
    other = {c: r + rng.normal(0.05, 0.04, size=r.size) for c, r in ref.items()}
    alone = _results({c: {"ref": rows(ref[c]), "full": rows(full[c])} for c in ref})
    crowded = _results({c: {"other": rows(other[c]), "ref": rows(ref[c]), "full": rows(full[c])} for c in ref})
    a = paired_differences(alone, "ref", n_resamples=3000, rng=np.random.default_rng(5))["full"]
    b = paired_differences(crowded, "ref", n_resamples=3000, rng=np.random.default_rng(5))["full"]
    assert a == b  # with a shared stream, "other" drawn first would have moved full's interval
    # the interval is the stratified bootstrap started from the one seed drawn from the caller's generator
    seed = int(np.random.default_rng(5).integers(0, 2**63 - 1))
    expect = paired_difference([full[c] - ref[c] for c in ref], n_resamples=3000, rng=np.random.default_rng(seed))
    np.testing.assert_allclose([a.mean_m, a.low_m, a.high_m], expect, rtol=0, atol=1e-15)
    # methods with the same differences get the same draws: equal intervals
    twin = _results({c: {"ref": rows(ref[c]), "full": rows(full[c]), "twin": rows(full[c])} for c in ref})
    t = paired_differences(twin, "ref", n_resamples=3000, rng=np.random.default_rng(9))
    assert (t["full"].low_m, t["full"].high_m) == (t["twin"].low_m, t["twin"].high_m)
