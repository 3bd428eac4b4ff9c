"""The re-planning's per-type cache (issue 24, real-time speed): what it keeps is bitwise what each re-planning
computed before — the draws' parameter columns, the vertical-sign terms, the end regression's factor — so the
candidates, their scores and the plan are bitwise the same."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from socialaff_sim.data.dataset import Dataset
from socialaff_sim.inference.candidate_planner import CandidatePlanner
from socialaff_sim.inference.candidates import (
    AGENT1, RegressionPrior, SignTerms, draw_from, draw_vectors, gaussian_factor, sign_loglik, vector_rows,
)
from socialaff_sim.inference.protocol import observed_part
from socialaff_sim.inference.synthesis import OnlineSynthesizer, SynthesisConfig
from socialaff_sim.learning import SocialAffordanceModel
from socialaff_sim.model.joints import canonical_joints
from socialaff_sim.model.nan_fill import nan_to_value, nan_to_zero
from socialaff_sim.model.potentials import reference_weights


def _old_draw(params: np.ndarray, up: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """draw_vectors as it was written before the cache (commit b5f56f9)."""
    K = params.shape[0]
    kh, lh, kv, lv, mu, kap = nan_to_value(np.asarray(params, dtype=float), 1.0).T
    h = lh * rng.weibull(kh, size=(n, K))
    v = lv * rng.weibull(kv, size=(n, K))
    sign = np.where(rng.random((n, K)) < up, 1.0, -1.0)
    th = rng.vonmises(mu, np.maximum(kap, 1e-9), size=(n, K))
    return np.stack([h * np.cos(th), h * np.sin(th), sign * v], axis=-1)


def _old_sign(model, s: int, z: np.ndarray, cand: np.ndarray, disp: np.ndarray) -> np.ndarray:  # noqa: ANN001
    """sign_loglik as it was written before the cache (commit b5f56f9)."""
    up = np.clip(model.vertical_up_[s], 1e-3, 1 - 1e-3)
    aff = AGENT1[z[AGENT1] > 0]
    out = np.zeros(cand.shape[0])
    if aff.size:
        weights = reference_weights(z, other_side=model.config.other_side_reference, include_self=model.config.reference_self)
        off_z = cand[:, aff, 2] - np.einsum("kj,nj->nk", weights[aff], nan_to_zero(cand[:, :, 2]))
        out += np.where(off_z > 0, np.log(up[0, aff]), np.log1p(-up[0, aff])).sum(axis=1)
    moving = AGENT1[z[AGENT1] >= 0]
    if moving.size:
        out += np.where(disp[:, moving, 2] > 0, np.log(up[1, moving]), np.log1p(-up[1, moving])).sum(axis=1)
    return out


def test_draws_from_cached_columns_are_bitwise_the_old_draws(shake8_model: SocialAffordanceModel) -> None:
    m = shake8_model
    for s in range(m.n_subevents_):
        params = m.spatial_params_[s, AGENT1].copy()
        params[1, 5] = np.nan  # a NaN κ: read as 1
        up = m.vertical_up_[s, 0, AGENT1]
        a, b = np.random.default_rng(s), np.random.default_rng(s)
        rows = vector_rows(params)
        got = [draw_from(rows, up, 37, a) for _ in range(3)]  # the same columns drawn from again
        ref = [_old_draw(params, up, 37, b) for _ in range(3)]
        for g, r in zip(got, ref, strict=True):
            np.testing.assert_array_equal(g, r)
        assert a.random() == b.random()  # the generator advanced alike
        np.testing.assert_array_equal(draw_vectors(params, up, 5, np.random.default_rng(9)), _old_draw(params, up, 5, np.random.default_rng(9)))


def test_sign_terms_are_bitwise_the_old_sign_loglik(shake8_model: SocialAffordanceModel, rng: np.random.Generator) -> None:
    m = shake8_model
    cand = rng.normal(scale=0.4, size=(60, 11, 3))
    cand[4, 6] = np.nan
    disp = rng.normal(scale=0.2, size=(60, 11, 3))
    seen_aff = 0
    for s in range(m.n_subevents_):
        z = m.grouping_[s].copy()
        z[~m.available_] = -1
        ref = _old_sign(m, s, z, cand, disp)
        terms = SignTerms.of(m, s, z)
        seen_aff += terms.aff.size
        np.testing.assert_array_equal(terms.loglik(cand, disp), ref)
        np.testing.assert_array_equal(terms.loglik(cand, disp), ref)  # read again
        np.testing.assert_array_equal(sign_loglik(m, s, z, cand, disp), ref)
    assert seen_aff > 0


def test_prior_with_a_kept_factor_is_bitwise_the_ridge_density(shake8_model: SocialAffordanceModel, shake8: Dataset, rng: np.random.Generator) -> None:
    m = shake8_model
    track = canonical_joints(shake8[6])
    regs = [(s, r) for s, r in enumerate(m.end_regression_) if r is not None]
    assert regs
    for s, reg in regs:
        plain = RegressionPrior.at(reg, track[30], track[20], track[0], m.available_)
        kept = RegressionPrior.at(reg, track[30], track[20], track[0], m.available_, gaussian_factor(reg))
        np.testing.assert_array_equal(kept.mean, plain.mean)
        configs = track[30][None] + rng.normal(scale=0.1, size=(40, 11, 3))
        a1 = configs[:, AGENT1]
        res = np.where(np.isfinite(a1), a1 - plain.mean[None], 0.0).reshape(40, -1)
        np.testing.assert_array_equal(kept.log_density(configs), reg.log_density(res))
        np.testing.assert_array_equal(plain.log_density(configs), reg.log_density(res))
        np.testing.assert_array_equal(kept.draw(20, np.random.default_rng(s)), plain.draw(20, np.random.default_rng(s)))


class _Uncached(OnlineSynthesizer):
    """Every re-planning makes its type plan anew: what each re-planning computed before the cache."""

    made = 0

    def _type_plan(self, s: int):  # noqa: ANN202
        type(self).made += 1
        return self._make_type_plan(s)


@pytest.mark.parametrize("config", [SynthesisConfig(), SynthesisConfig(coherent_fraction=0.5, refine_sweeps=1)])
def test_replans_with_the_cache_are_bitwise_those_without(shake8: Dataset, shake8_model: SocialAffordanceModel, config: SynthesisConfig) -> None:
    made: list[int] = []

    class Counted(OnlineSynthesizer):
        def _make_type_plan(self, s: int):  # noqa: ANN202
            made.append(s)
            return super()._make_type_plan(s)

    runs = []
    model = copy.copy(shake8_model)  # a model object of its own: nothing made for it yet (the plans are kept per model)
    for cls in (Counted, _Uncached):
        syn = cls(model, None, config)
        keys = []
        for inst in (shake8[6], shake8[7]):  # two episodes: each looks the plans up anew at its reset
            syn.reset(observed_part(inst, config.n_observed), rng=np.random.default_rng(3))
            first = dict(syn.__dict__.get("_plans", (None, {}))[1])
            assert not first or syn._plans[0] is not syn._refw  # nothing kept from the episode before
            while not syn.done:
                keys.append(syn.step().key_joints)
        runs.append(np.array(keys))
    np.testing.assert_array_equal(runs[0], runs[1])
    # Every type once per model, at the first episode's start; the second episode reads the same plans.
    assert sorted(made) == list(range(shake8_model.n_subevents_))
    assert _Uncached.made > len(made)  # the uncached planner did re-plan more often than it made plans


def test_type_plan_equals_what_a_replanning_computed(shake8: Dataset, shake8_model: SocialAffordanceModel) -> None:
    m = shake8_model
    syn = OnlineSynthesizer(m, None, SynthesisConfig())
    syn.reset(observed_part(shake8[6], 10), rng=np.random.default_rng(0))
    for s in range(m.n_subevents_):
        plan = syn._type_plan(s)
        assert plan is syn._type_plan(s)
        z = m.grouping_[s].copy()
        z[~syn._available] = -1
        np.testing.assert_array_equal(plan.z, z)
        aff = AGENT1[z[AGENT1] > 0]
        np.testing.assert_array_equal(plan.aff, aff)
        np.testing.assert_array_equal(plan.static, AGENT1[syn._available[AGENT1] & ~np.isin(AGENT1, aff)])
        assert not plan.z.flags.writeable
    assert isinstance(syn, CandidatePlanner)


def test_expected_error_choice_is_the_old_choice(rng: np.random.Generator) -> None:
    """The weighted mean by one np.dot (what np.tensordot called) gives bitwise the old means, so the same choices."""
    from socialaff_sim.inference.candidates import expected_error_choice

    for n in (1, 2, 7, 150):
        cand = rng.normal(size=(n, 5, 3))
        cand[:, 2] = np.nan if n > 2 else cand[:, 2]  # a joint absent in every candidate: ignored
        score = rng.normal(scale=5.0, size=n)
        score[0] = -np.inf
        w = np.where(np.isfinite(score / 5.0), np.exp(score / 5.0 - np.max(score[np.isfinite(score)] / 5.0)), 0.0) if n > 1 else np.ones(1)
        w /= w.sum()
        x = nan_to_zero(cand)
        ref_mean = np.tensordot(w, x, axes=(0, 0))
        d2 = ((x - ref_mean[None]) ** 2).sum(axis=(1, 2))
        ref = int(np.argmin(np.where(np.isfinite(score / 5.0), d2, np.inf))) if n > 1 else 0
        assert expected_error_choice(cand, score, temperature=5.0) == ref
        np.testing.assert_array_equal(np.dot(w.reshape(1, -1), x.reshape(n, -1)).reshape(5, 3), ref_mean)
