""":class:`~socialaff_sim.inference.row_density.RowSet` (issue 24, session 26) against the code it replaces, bitwise:
the type tables' former ``_density`` (:func:`~socialaff_sim.model.features.polar`, then
:func:`~socialaff_sim.model.potentials.polar_rows_logpdf` with the rows' log i0e(κ) and Weibull terms), on rows all
Weibull, all exponential and of both kinds, with a shape k = 1 (the 0 · log 0 convention), NaN parameters, and on
vectors that are zero (h, |dz| at the floor ε), NaN, huge and tiny, and on no vector and no row."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import i0e

from socialaff_sim.inference.row_density import RowSet
from socialaff_sim.model.densities import weibull_terms
from socialaff_sim.model.features import polar
from socialaff_sim.model.potentials import polar_rows_logpdf

EPS = 1e-3


def _replaced(vecs: np.ndarray, p: np.ndarray, e: np.ndarray) -> np.ndarray:
    """TypeTables._rows and _density as they were (commit 323edde), written out."""
    kh, lh, kv, lv = p.T[:4]
    log_i0e, weibull = np.log(i0e(p.T[5])), (weibull_terms(kh, lh), weibull_terms(kv, lv))
    h, v, th = polar(vecs, EPS)
    with np.errstate(divide="ignore", invalid="ignore"):
        return polar_rows_logpdf(h, v, th, p, e, log_i0e=log_i0e, weibull=weibull)


def _params(rng: np.random.Generator, K: int) -> np.ndarray:
    p = np.column_stack([rng.uniform(0.5, 4, K), rng.uniform(0.02, 1, K), rng.uniform(0.5, 4, K),
                         rng.uniform(0.02, 1, K), rng.uniform(-np.pi, np.pi, K), rng.uniform(0, 30, K)])
    if K > 2:
        p[1, 0] = p[1, 2] = 1.0  # k = 1: the 0 · log 0 convention's where
    if K > 4:
        p[3] = np.nan  # an absent row
    return p


def _vecs(rng: np.random.Generator, N: int, K: int) -> np.ndarray:
    v = rng.normal(scale=0.4, size=(N, K, 3))
    if N > 3 and K > 1:
        v[0, 0] = 0.0  # at the floors
        v[1, 1] = np.nan
        v[2, 0] = [1e6, -1e6, 1e6]
        v[3, 1] = [1e-12, 0.0, -0.0]
    return v


@pytest.mark.parametrize("kind", ["weibull", "expon", "mixed"])
@pytest.mark.parametrize(("N", "K"), [(1, 1), (7, 3), (40, 9), (120, 14), (0, 5), (6, 0)])
def test_row_logpdf_is_the_replaced_densitys_bitwise(rng: np.random.Generator, kind: str, N: int, K: int) -> None:
    p = _params(rng, K)
    e = {"weibull": np.zeros(K, bool), "expon": np.ones(K, bool), "mixed": rng.random(K) < 0.5}[kind]
    if kind == "mixed" and K >= 2:
        e[:2] = [True, False]  # both kinds present
    rows = RowSet(p, e, EPS)
    for _ in range(3):
        vecs = _vecs(rng, N, K)
        got, ref = rows.logpdf(vecs), _replaced(vecs, p, e)
        assert got.shape == ref.shape == (N, K)
        assert got.tobytes() == ref.tobytes()


def test_kind_decides_the_branch(rng: np.random.Generator) -> None:
    """Each branch on its own rows: were the kinds swapped (exponential rows read as Weibull), the values would differ."""
    p = _params(rng, 6)
    vecs = _vecs(rng, 10, 6)
    w, x = RowSet(p, None, EPS).logpdf(vecs), RowSet(p, np.ones(6, bool), EPS).logpdf(vecs)
    assert not np.allclose(w, x, equal_nan=True)
    assert w.tobytes() == _replaced(vecs, p, np.zeros(6, bool)).tobytes()
    assert x.tobytes() == _replaced(vecs, p, np.ones(6, bool)).tobytes()


def _score_replaced(syn, s: int, z: np.ndarray, configs: np.ndarray, before: np.ndarray) -> np.ndarray:  # noqa: ANN001
    """CandidatePlanner._score as it was (commit 323edde; no regression prior), written out."""
    from socialaff_sim.inference.candidates import SignTerms

    disp = configs - before[None]
    score = syn._tables.spatial(configs, s) + syn._tables.motion(disp, s)
    plan = syn._type_plan(s)
    sign = plan.sign if plan.sign is not None and np.array_equal(z, plan.z) else SignTerms.of(syn.model, s, z, syn._weights(s, z))
    score = score + sign.loglik(configs, disp)
    return np.where(np.isnan(score), -np.inf, score)


def test_spatial_motion_and_the_candidates_score_are_the_replaced_ones(shake8_model, rng: np.random.Generator) -> None:  # noqa: ANN001
    """TypeTables.spatial_motion against spatial + motion, and the planner's score against the one it replaces, on every
    type, on a type without spatial rows and one without any row (a grouping changed, as a refit would), with
    candidates NaN in a joint or whole, and with a grouping other than the plan's (its own sign terms)."""
    import copy

    from socialaff_sim.inference.synthesis import OnlineSynthesizer, SynthesisConfig
    from socialaff_sim.inference.type_tables import TypeTables

    model = copy.copy(shake8_model)
    grouping = np.array(model.grouping_, copy=True)
    grouping[1] = np.where(grouping[1] > 0, 0, grouping[1])  # type 1: no spatial rows (no affordable joint)
    grouping[2] = -1  # type 2: no rows at all
    model.grouping_ = grouping
    tab = TypeTables.of(model)
    assert tab._sp[1][0].size == 0 and tab._mo_joints[2].size == 0 and tab._sp[0][0].size > 0
    syn = OnlineSynthesizer(model, None, SynthesisConfig(vertical_sign=True))
    syn._refw, syn._available = {}, model.available_.copy()
    for s in range(model.n_subevents_):
        for N in (1, 5, 64):
            configs = rng.normal(scale=0.4, size=(N, 11, 3))
            configs[:, 10] = np.nan
            if N > 2:
                configs[1, 6] = np.nan
                configs[2] = np.nan
            before = rng.normal(scale=0.4, size=(11, 3))
            disp = configs - before[None]
            sp, mo = tab.spatial_motion(configs, disp, s)
            assert sp.tobytes() == tab.spatial(configs, s).tobytes() and mo.tobytes() == tab.motion(disp, s).tobytes()
            z = syn._type_plan(s).z
            other = z.copy()
            other[5] = 1 if other[5] != 1 else 2
            for zz in (z, z.copy(), other):
                assert syn._score(s, zz, configs, before, None).tobytes() == _score_replaced(syn, s, zz, configs, before).tobytes()
