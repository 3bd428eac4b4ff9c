"""Issue 24's fit speed-ups give bitwise what they replace.

Each is checked with ``np.array_equal`` against the plain computation it replaces, kept here (or in the library
as the documented reference) for the purpose: the ridge's held-out residuals over its whole grid against one
:func:`ridge_solve` per (target, λ, group); the segmentation DP's vectorised label step against the loop over
labels it replaced; the interval scores from the polar table (:mod:`socialaff_sim.learning.polar_table`) against
``log_spatial`` + ``log_motion``; the sample-set memo (:mod:`socialaff_sim.learning.sample_fits`) against fresh fits, and a
whole fit with the memo against one where every sample set starts an empty memo.
"""

from __future__ import annotations

import numpy as np
import pytest

from socialaff_sim.learning import algorithm, initial
from socialaff_sim.learning.config import LearningConfig
from socialaff_sim.learning.estimator import SocialAffordanceModel
from socialaff_sim.learning.likelihood import TypeLikelihood
from socialaff_sim.learning.polar_table import PolarTable
from socialaff_sim.learning.sample_fits import SampleFits, SampleFitsStore
from socialaff_sim.model import ridge
from socialaff_sim.model.config import AffordanceConfig
from socialaff_sim.model.densities import lognorm_logpdf
from socialaff_sim.model.features import interval_features
from socialaff_sim.model.path import path_loglik
from socialaff_sim.model.potentials import fit_type_potentials, log_motion, log_spatial
from socialaff_sim.model.segment_dp import segmentation_tables


# -- ridge: the held-out grid ----------------------------------------------------------------------------------
def _fit_ridge_per_lambda(X: np.ndarray, Y: np.ndarray, groups: np.ndarray, cols: np.ndarray | None,
                          sigma_min: float) -> tuple[float, float, np.ndarray, np.ndarray]:
    """fit_ridge's choice as it was: every (α, λ) with its own held-out loop of ridge_solve calls."""
    best = None
    for alpha in (0.0,) if cols is None else (0.0, 1.0):
        Ya = Y - alpha * X[:, cols] if alpha and cols is not None else Y
        for lam in ridge.RIDGE_GRID:
            res = ridge._held_out_residuals(X, Ya, groups, lam)
            err = float(np.mean(res**2))
            if best is None or err < best[0]:
                best = (err, alpha, lam, res)
    _, alpha, lam, res = best
    Ya = Y - alpha * X[:, cols] if alpha and cols is not None else Y
    coef = ridge.ridge_solve(X, Ya, lam)[3]
    S = res.T @ res / X.shape[0]
    cov = 0.5 * S + 0.5 * np.diag(np.diag(S)) + sigma_min**2 * np.eye(Y.shape[1])
    return alpha, lam, coef, cov


def test_held_out_grid_is_bitwise_one_solve_per_lambda_and_group() -> None:
    rng = np.random.default_rng(5)
    for trial in range(12):
        M, C, D = int(rng.integers(8, 120)), int(rng.integers(2, 40)), int(rng.integers(1, 12))
        X = rng.normal(size=(M, C)) * rng.uniform(0.01, 5.0, size=C)
        X[:, int(rng.integers(C))] = 1.0  # a constant column (scale 1)
        Y = rng.normal(size=(M, D))
        groups = np.arange(M) if trial % 2 else rng.integers(0, int(rng.integers(3, 12)), size=M)
        targets = [Y, Y - 0.5 * X[:, :1]]
        got = ridge._held_out_grid(X, targets, groups, ridge.RIDGE_GRID)
        for t, Yt in enumerate(targets):
            for r, lam in enumerate(ridge.RIDGE_GRID):
                assert np.array_equal(got[t][r], ridge._held_out_residuals(X, Yt, groups, lam))


@pytest.mark.parametrize("offsets", [False, True])
def test_fit_ridge_is_bitwise_the_per_lambda_loop(offsets: bool) -> None:
    rng = np.random.default_rng(6)
    for _ in range(4):
        M, C, D = 60, 12, 4
        X = rng.normal(size=(M, C))
        Y = X[:, :D] * rng.uniform(0.5, 1.0) + rng.normal(scale=0.3, size=(M, D))
        groups = rng.integers(0, 7, size=M)
        cols = np.arange(D) if offsets else None
        reg = ridge.fit_ridge(X, Y, groups, sigma_min=0.01, offset_columns=cols)
        alpha, lam, coef, cov = _fit_ridge_per_lambda(X, Y, groups, cols, 0.01)
        assert (reg.offset_weight, reg.ridge) == (alpha, lam)
        assert np.array_equal(reg.coef, coef) and np.array_equal(reg.cov, cov)


# -- segmentation DP: the vectorised label step ------------------------------------------------------------------
def _tables_label_loop(seg: np.ndarray, log_start: np.ndarray, log_trans: np.ndarray, *, distinct: bool,
                       unique: bool) -> tuple[np.ndarray, np.ndarray]:
    """segmentation_tables as it was: candidates (a, m, s', s), then one label s at a time."""
    seg = np.where(np.isnan(seg), -np.inf, seg)
    B, S = seg.shape[0] - 1, log_start.shape[0]
    M = 1 << S if unique else 1
    trans = np.array(log_trans, dtype=float)
    if distinct:
        np.fill_diagonal(trans, -np.inf)
    best = np.full((B + 1, M, S), -np.inf)
    back = np.full((B + 1, M, S, 3), -1, dtype=np.int64)
    masks, bits = np.arange(M), 1 << np.arange(S)
    for b in range(1, B + 1):
        best[b, bits if unique else np.zeros(S, np.int64), np.arange(S)] = log_start + seg[0, b]
        if b == 1:
            continue
        cand = best[1:b, :, :, None] + trans[None, None] + seg[1:b, b][:, None, None, :]
        flat = cand.transpose(1, 3, 0, 2).reshape(M, S, -1)
        arg = np.argmax(flat, axis=2)
        val = np.take_along_axis(flat, arg[:, :, None], axis=2)[:, :, 0]
        for s in range(S):
            ms = masks[(masks & bits[s]) == 0] if unique else masks
            tgt = ms | bits[s] if unique else masks
            v = val[ms, s]
            better = v > best[b, tgt, s]
            t = tgt[better]
            best[b, t, s] = v[better]
            back[b, t, s, 0] = arg[ms[better], s] // S + 1
            back[b, t, s, 1] = ms[better]
            back[b, t, s, 2] = arg[ms[better], s] % S
    return best, back


@pytest.mark.parametrize("unique", [False, True])
@pytest.mark.parametrize("distinct", [False, True])
def test_segmentation_tables_are_bitwise_the_label_loop(distinct: bool, unique: bool) -> None:
    rng = np.random.default_rng(8)
    for trial in range(240):
        B, S = int(rng.integers(1, 14)), int(rng.integers(1, 5))
        seg = rng.normal(size=(B + 1, B + 1, S)) * 3.0
        ls, lt = np.log(rng.dirichlet(np.ones(S))), np.log(rng.dirichlet(np.ones(S), size=S))
        if trial % 3 == 1:  # integer scores: many ties, which argmax must break as before (first maximum)
            seg, ls, lt = np.round(seg), np.round(ls), np.round(lt)
        elif trial % 3 == 2:  # large scores that differ below their rounding: ties made by the sum's rounding alone
            seg = np.round(seg) * 1e3 + rng.normal(size=seg.shape) * 1e-13
        seg[rng.random(seg.shape) < 0.2] = -np.inf
        seg[rng.random(seg.shape) < 0.05] = np.nan
        lt[rng.random(lt.shape) < 0.2] = -np.inf
        want = _tables_label_loop(seg, ls, lt, distinct=distinct, unique=unique)
        got = segmentation_tables(seg, ls, lt, distinct=distinct, unique=unique)
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
        k = int(rng.integers(0, B + 1))  # resumed from the first k + 1 rows
        again = segmentation_tables(seg, ls, lt, distinct=distinct, unique=unique, rows=(want[0][: k + 1], want[1][: k + 1]))
        assert np.array_equal(again[0], want[0]) and np.array_equal(again[1], want[1])


# -- the sample-set memo ---------------------------------------------------------------------------------------------
def test_sample_fits_compute_once_per_key_and_per_whole_batch() -> None:
    fits = SampleFits()
    calls: list[object] = []

    def compute(tag: object) -> object:
        calls.append(tag)
        return [float(len(calls))]

    first = fits.batch((1, 2), lambda: compute("a"))
    assert fits.batch((1, 2), lambda: compute("b")) is first  # the same batch: stored, not recomputed
    fits.batch((2, 1), lambda: compute("c"))  # another order is another batch
    fits.batch((1,), lambda: compute("d"))  # and so is a part of one
    assert calls == ["a", "c", "d"]
    kept = fits.keep(("x", 1), lambda: compute("e"))
    assert fits.keep(("x", 1), lambda: compute("f")) is kept
    fits.keep(("x", 2), lambda: compute("g"))
    assert calls == ["a", "c", "d", "e", "g"]
    assert (fits.hits, fits.misses) == (2, 5)
    store = SampleFitsStore()
    assert store.of(((0, 1, 5),)) is store.of(((0, 1, 5),))
    assert store.of(((0, 1, 5),)) is not store.of(((0, 1, 6),))


def _lik_terms(lik: TypeLikelihood, requests: list[list[int]]) -> list[float]:
    for keys in requests:
        lik.ensure(keys)
    return [lik.memo[k] for keys in requests for k in keys] + lik.null_ll.tolist() + lik.aff_motion_ll.tolist()


def test_likelihood_with_shared_fits_is_bitwise_a_fresh_one() -> None:
    """Whatever the order of the requests, a likelihood reading a shared memo holds the terms a fresh one
    computes for the same requests (the von Mises fit depends on its batch, so the memo is by whole batch)."""
    rng = np.random.default_rng(9)
    end = rng.normal(size=(9, 11, 3))
    disp = rng.normal(scale=0.1, size=(9, 11, 3))
    available = np.ones(11, bool)
    available[10] = False
    cfg = AffordanceConfig()
    fits = SampleFits()
    keys = [TypeLikelihood.key(j, m) for j in range(10) for m in (0, 0b110, 0b1000000001 & ~(1 << j))]
    for _ in range(6):
        order = [list(rng.choice(keys, size=int(rng.integers(1, 8)), replace=False)) for _ in range(4)]
        order += [order[int(rng.integers(len(order)))]]  # a repeated request
        fresh = _lik_terms(TypeLikelihood(end, disp, available, cfg), order)
        shared = _lik_terms(TypeLikelihood(end, disp, available, cfg, fits), order)
        assert fresh == shared
    assert fits.hits > 0


class _NoMemo(SampleFitsStore):
    """Every sample set starts an empty memo: the fits as before the store."""

    def of(self, keys: tuple[tuple[int, int, int], ...]) -> SampleFits:
        return SampleFits()


def test_fit_with_the_memo_is_bitwise_the_fit_without(monkeypatch: pytest.MonkeyPatch, shake8) -> None:  # noqa: ANN001
    lcfg = LearningConfig(iterations=2, init_rounds=3, init_type_passes=1, init_type_rounds=2)
    inters = shake8.interactions[:6]
    made: list[SampleFitsStore] = []

    class Counting(SampleFitsStore):
        def __init__(self) -> None:
            super().__init__()
            made.append(self)

    monkeypatch.setattr(algorithm, "SampleFitsStore", Counting)
    memo = SocialAffordanceModel(learning=lcfg).fit(inters, rng=np.random.default_rng(4))
    assert made and made[0].hits > 0  # the memo was used
    monkeypatch.setattr(algorithm, "SampleFitsStore", _NoMemo)
    plain = SocialAffordanceModel(learning=lcfg).fit(inters, rng=np.random.default_rng(4))
    for key in vars(plain):
        if key.endswith("_") and key != "fit_seconds_" and isinstance(getattr(plain, key), np.ndarray):
            assert np.array_equal(getattr(memo, key), getattr(plain, key), equal_nan=True), key
    assert memo.history_["log_posterior"].tolist() == plain.history_["log_posterior"].tolist()


def test_the_memo_is_detached_for_the_chain(monkeypatch: pytest.MonkeyPatch, shake8) -> None:  # noqa: ANN001
    """The initial parse fills the run's memo; the MCMC chain neither reads nor grows it (bounded memory): its
    size and look-up count, observed after the initial parse and after every iteration, stay where the initial
    parse left them, though the chain's proposals score sample sets (a memo left attached would count them)."""
    lcfg = LearningConfig(iterations=3, init_rounds=3, init_type_passes=1, init_type_rounds=2)
    made: list[SampleFitsStore] = []

    class Counting(SampleFitsStore):
        def __init__(self) -> None:
            super().__init__()
            made.append(self)

    seen: list[tuple[int, int, int]] = []

    def watch(state: algorithm.FitProgress) -> None:
        store = made[0]
        seen.append((state.iteration, len(store), store.hits + store.misses))

    monkeypatch.setattr(algorithm, "SampleFitsStore", Counting)
    model = SocialAffordanceModel(learning=lcfg).fit(shake8.interactions[:6], rng=np.random.default_rng(4),
                                                     callback=watch)
    assert len(made) == 1 and [s[0] for s in seen] == list(range(lcfg.iterations + 1))
    assert seen[0][1] > 0 and seen[0][2] > 0  # the initial parse used the memo
    proposed = sum(int(np.sum(v)) for k, v in model.history_.items() if k.startswith("proposed_"))
    assert proposed > 0  # the chain proposed moves (and scored them)
    assert all(s[1:] == seen[0][1:] for s in seen), seen


# -- the polar table -----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("density", ["polar", "cartesian"])
def test_column_from_the_polar_table_is_bitwise_log_spatial_plus_log_motion(density: str) -> None:
    """A type's interval scores read from the polar table (kept over groupings and instances, evicted beyond
    ``keep``) equal the plain sum of :func:`log_spatial`, :func:`log_motion` and the duration and path terms."""
    rng = np.random.default_rng(10)
    acfg = AffordanceConfig(vector_density=density)
    polars = PolarTable(acfg, keep=2)
    tracks = [np.cumsum(rng.normal(scale=0.02, size=(int(rng.integers(40, 90)), 11, 3)), axis=0) for _ in range(3)]
    for x in tracks[1:]:
        x[:, 10] = np.nan  # no object
    available = np.ones(11, bool)
    available[10] = False
    bounds = [np.unique(np.r_[0, rng.choice(np.arange(1, len(x)), size=8, replace=False), len(x)]) for x in tracks]
    feats = [interval_features(x, b[np.triu_indices(len(b), 1)[0]], b[np.triu_indices(len(b), 1)[1]], 30.0, "minjerk")
             for x, b in zip(tracks, bounds, strict=True)]
    groupings = [np.where(available, rng.integers(0, 3, size=11), -1) for _ in range(4)] + [np.where(available, 0, -1)]
    for rep in range(3):  # revisits: hits, and after evictions, recomputations
        for z in groupings:
            z = z.astype(np.int64)
            sample = feats[0].take(rng.choice(len(feats[0]), size=12, replace=False))
            pot = fit_type_potentials(sample.end, sample.disp, z, acfg)
            dur, sigma = (0.1 * rep, 0.5), np.where(available, 0.02, np.nan)
            for i, (fe, b) in enumerate(zip(feats, bounds, strict=True)):
                ia, ib = np.triu_indices(len(b), 1)
                short = (b[ib] - b[ia]) < 3
                got = initial._column(pot, z, dur, sigma, i, fe, short, acfg, polars)
                cart = density == "cartesian"
                want = (
                    log_spatial(pot, z, fe.end, acfg.eps, other_side=acfg.other_side_reference,
                                include_self=acfg.reference_self, cartesian=cart)
                    + log_motion(pot, z, fe.disp, acfg.eps, cartesian=cart)
                    + lognorm_logpdf(fe.seconds, *dur)
                    + path_loglik(fe.path_sq, fe.path_n, sigma).sum(axis=1)
                )
                want = np.where(np.isnan(want) | short, -np.inf, want)
                assert np.array_equal(got, want)
    assert len(polars._spatial) == 2  # bounded
