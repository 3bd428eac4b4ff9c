"""The learner's caches and shortcuts give bitwise what they replace (issues 23/24's speed work).

Each shortcut is checked against an independent, plain computation: the interval table against fresh
calls of ``interval_features``; the Weibull fit that steps only unfinished rows against a verbatim copy of
the loop that stepped every row; the row reductions against ``ndarray.mean`` / ``ndarray.std``; the Gibbs
key tables against a direct enumeration; and a whole fit against one whose interval features are
recomputed at every call.
"""

from __future__ import annotations

import numpy as np
import pytest

from socialaff_sim.learning import algorithm, gibbs, initial, scorer
from socialaff_sim.learning.config import LearningConfig
from socialaff_sim.learning.estimator import SocialAffordanceModel
from socialaff_sim.learning.interval_table import IntervalTable
from socialaff_sim.learning.likelihood import TypeLikelihood
from socialaff_sim.model.config import AffordanceConfig
from socialaff_sim.model.densities import fit_weibull, row_mean, row_std
from socialaff_sim.model.features import IntervalFeatures, interval_features, type_samples


def _track(rng: np.random.Generator, T: int) -> np.ndarray:
    x = np.cumsum(rng.normal(scale=0.02, size=(T, 11, 3)), axis=0)
    if rng.random() < 0.5:
        x[:, 10] = np.nan  # no object
    return x


def _same(a: IntervalFeatures, b: IntervalFeatures) -> bool:
    fields = ("end", "disp", "seconds", "path_sq", "path_n")
    return all(
        (getattr(a, f) is None and getattr(b, f) is None)
        or np.array_equal(getattr(a, f), getattr(b, f), equal_nan=True)
        for f in fields
    )


@pytest.mark.parametrize("profile", ["minjerk", "linear", None])
def test_interval_table_rows_equal_fresh_features(profile: str | None) -> None:
    rng = np.random.default_rng(11)
    tracks = [_track(rng, int(rng.integers(20, 160))) for _ in range(4)]
    fps = [30.0, 25.0, 30.0, 15.0]
    table = IntervalTable(tracks, fps, profile)
    for i, x in enumerate(tracks):
        T = x.shape[0]
        bounds = np.unique(np.r_[0, rng.choice(np.arange(1, T), size=min(T - 1, 12), replace=False), T])
        ia, ib = np.triu_indices(bounds.shape[0], k=1)
        pairs = table.all_pairs(i, bounds)
        assert _same(pairs, interval_features(x, bounds[ia], bounds[ib], fps[i], profile))
        assert table.all_pairs(i, bounds) is pairs  # computed once
        # Rows asked in any grouping (some first seen in all_pairs' batch, some alone) equal fresh rows.
        for _ in range(5):
            pick = rng.choice(ia.shape[0], size=int(rng.integers(1, 6)), replace=False)
            keys = [(i, int(bounds[ia[p]]), int(bounds[ib[p]])) for p in pick]
            got = table.rows(keys)
            for m, (_, f0, f1) in enumerate(keys):
                fresh = interval_features(x, np.array([f0]), np.array([f1]), fps[i], profile)
                assert _same(got.take(np.array([m])), fresh)


def test_interval_table_type_samples_equal_model_type_samples() -> None:
    rng = np.random.default_rng(3)
    tracks = [_track(rng, 60), _track(rng, 90), _track(rng, 45)]
    fps = [30.0, 30.0, 30.0]
    spans = [[(0, 20, 0), (20, 41, 1), (41, 60, 2)], [(0, 35, 1), (35, 90, 0)], [(0, 45, 2)]]
    table = IntervalTable(tracks, fps, "minjerk")
    for s in range(4):  # label 3 has no interval: an empty set
        assert _same(table.type_samples(spans, s), type_samples(tracks, fps, spans, s, "minjerk"))


def test_interval_table_refuses_other_bounds_for_an_instance() -> None:
    rng = np.random.default_rng(0)
    table = IntervalTable([_track(rng, 30)], [30.0], None)
    table.all_pairs(0, np.array([0, 10, 30]))
    with pytest.raises(Exception, match="other atom bounds"):
        table.all_pairs(0, np.array([0, 12, 30]))


def _weibull_every_row(x: np.ndarray, eps: float = 1e-3, shape_min: float = 0.3, shape_max: float = 20.0,
                       tol: float = 1e-10, max_steps: int = 30) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The Weibull fit as it was before the shortcut: every row stepped at every iteration."""
    x = np.maximum(x, eps)
    B, N = x.shape
    L = np.log(x)
    Lbar = L.mean(axis=1)
    u = L - L.max(axis=1, keepdims=True)
    sd = L.std(axis=1)
    with np.errstate(divide="ignore"):
        k = np.where(sd > 0, np.pi / (np.sqrt(6.0) * sd), shape_max)
    k = np.minimum(np.maximum(k, shape_min), shape_max)
    active = sd > 1e-12
    Lc = L - Lbar[:, None]
    for _ in range(max_steps):
        if not active.any():
            break
        e = np.exp(k[:, None] * u)
        eL = e * Lc
        s0 = e.sum(axis=1)
        m1 = eL.sum(axis=1) / s0
        m2 = (eL * Lc).sum(axis=1) / s0
        g = m1 - 1.0 / k
        dg = (m2 - m1 * m1) + 1.0 / (k * k)
        with np.errstate(all="ignore"):
            step = np.where(active, np.minimum(np.maximum(g / (k * dg), -2.0), 2.0), 0.0)
        k_new = np.minimum(np.maximum(k * np.exp(-step), shape_min), shape_max)
        active &= (np.abs(step) > tol) & (k_new != k)
        k = k_new
    e = np.exp(k[:, None] * u)
    log_lam = (np.log(e.mean(axis=1)) + k * L.max(axis=1)) / k
    ll = N * np.log(k) - N * k * log_lam + (k - 1.0) * L.sum(axis=1) - N
    return k, np.exp(log_lam), ll


@pytest.mark.parametrize("layout", ["C", "F"])
def test_weibull_stepping_unfinished_rows_only_is_bitwise_the_full_loop(layout: str) -> None:
    rng = np.random.default_rng(7)
    for _ in range(300):
        B, N = int(rng.integers(1, 25)), int(rng.integers(1, 200))
        x = rng.weibull(rng.uniform(0.4, 6.0), size=(B, N)) * rng.uniform(0.005, 3.0)
        if rng.random() < 0.3:
            x[rng.integers(B)] = 0.4  # all equal: never stepped
        if rng.random() < 0.3:
            x[rng.integers(B), : int(rng.integers(N + 1))] = 1e-5  # floored at eps
        if layout == "F":
            x = np.asfortranarray(x)
        got = fit_weibull(x)
        want = _weibull_every_row(x)
        for a, b in zip(got, want, strict=True):
            assert np.array_equal(a, b, equal_nan=True)


def test_row_reductions_are_bitwise_numpys() -> None:
    rng = np.random.default_rng(1)
    for _ in range(300):
        B, N = (int(v) for v in rng.integers(1, 300, size=2))
        x = rng.normal(size=(B, N)) * rng.uniform(1e-3, 1e3)
        if rng.random() < 0.4:
            x = np.asfortranarray(x)
        assert np.array_equal(row_mean(x), x.mean(axis=1))
        assert np.array_equal(row_std(x), x.std(axis=1))


def test_gibbs_key_tables_match_direct_enumeration() -> None:
    for mask in range(1 << 11):
        members = [j for j in range(11) if mask >> j & 1]
        assert gibbs._members(mask) == tuple(members)
        assert gibbs._group_keys(mask) == tuple(TypeLikelihood.key(m, mask & ~(1 << m)) for m in members)


def test_fit_is_bitwise_the_same_without_the_interval_table(monkeypatch: pytest.MonkeyPatch, shake8) -> None:  # noqa: ANN001
    """A whole (short) fit with the run's interval table equals one where every request recomputes the
    features from the tracks, as before the table."""
    lcfg = LearningConfig(iterations=3, init_rounds=2, init_type_passes=1, init_type_rounds=1)
    inters = shake8.interactions[:5]
    cached = SocialAffordanceModel(learning=lcfg).fit(inters, rng=np.random.default_rng(4))

    class Fresh(IntervalTable):
        def all_pairs(self, i: int, bounds: np.ndarray) -> IntervalFeatures:
            b = np.asarray(bounds, np.int64)
            ia, ib = np.triu_indices(b.shape[0], k=1)
            return interval_features(self.tracks[i], b[ia], b[ib], self.fps[i], self.path_profile)

        def rows(self, keys, n_joints: int = 11) -> IntervalFeatures:  # type: ignore[override]
            self._rows.clear()
            return super().rows(keys, n_joints)

    monkeypatch.setattr(initial, "IntervalTable", Fresh)
    monkeypatch.setattr(scorer, "IntervalTable", Fresh)
    monkeypatch.setattr(algorithm, "IntervalTable", Fresh)
    fresh = SocialAffordanceModel(learning=lcfg).fit(inters, rng=np.random.default_rng(4))
    assert np.array_equal(cached.spatial_params_, fresh.spatial_params_, equal_nan=True)
    assert np.array_equal(cached.grouping_, fresh.grouping_)
    assert cached.history_["log_posterior"].tolist() == fresh.history_["log_posterior"].tolist()


def test_gibbs_draw_is_generator_choice_with_the_same_stream() -> None:
    """The Gibbs sweep's draw gives rng.choice's index and leaves the generator where rng.choice does."""
    g = np.random.default_rng(0)
    r1, r2 = np.random.default_rng(123), np.random.default_rng(123)
    for _ in range(20000):
        n = int(g.integers(1, 9))
        logp = g.normal(size=n) * g.uniform(0.0, 50.0)
        if n > 1 and g.random() < 0.2:
            logp[g.integers(n)] = -np.inf
        p = np.exp(logp - logp.max())
        p = p / p.sum()
        assert gibbs._draw(r2, p) == int(r1.choice(n, p=p))
    assert r1.random() == r2.random()
    with pytest.raises(ValueError):
        gibbs._draw(r2, np.array([np.nan, 1.0]))  # numpy's own refusal


def test_group_sums_are_the_member_order_sums() -> None:
    rng = np.random.default_rng(2)
    end = rng.normal(size=(12, 11, 3))
    disp = rng.normal(scale=0.1, size=(12, 11, 3))
    lik = TypeLikelihood(end, disp, np.ones(11, bool), AffordanceConfig())
    for mask in (0b1, 0b1011, 0b11100000110, 0b11111111111):
        direct = sum(lik.spatial_term(m, mask & ~(1 << m)) for m in range(11) if mask >> m & 1)
        assert gibbs._group_terms(lik, mask) == direct
        assert gibbs._group_terms(lik, mask) == direct  # from the kept sum
