"""Decision points of the default causal synthesis that hedge against wrong futures, each pinned so that
inverting it fails: the expected-error candidate choice, the sub-events planned and their weights, the
shrinkage toward ``hold``, and the belief exposed at every step (the forward filter's)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from socialaff_sim.data.dataset import Dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.inference import OnlineSynthesizer, SynthesisConfig
from socialaff_sim.inference.candidates import expected_error_choice
from socialaff_sim.inference.forward_belief import ForwardBelief
from socialaff_sim.inference.hedging import BRANCH_FLOOR, branch_plans, shrink_factor
from socialaff_sim.inference.protocol import observed_part
from socialaff_sim.inference.synthesis import _AGENT1
from socialaff_sim.learning import SocialAffordanceModel


def test_expected_error_choice_is_the_brute_force_minimiser(rng: np.random.Generator) -> None:
    cand = rng.normal(size=(40, 5, 3))
    cand[:, 2] = np.nan  # a joint absent from every candidate is ignored
    score = rng.normal(scale=2.0, size=40)
    score[3] = -np.inf
    p = np.where(np.isfinite(score), np.exp(score - score[np.isfinite(score)].max()), 0.0)
    p /= p.sum()
    x = np.nan_to_num(cand)
    risk = np.array([(p * ((x[i][None] - x) ** 2).sum(axis=(1, 2))).sum() for i in range(40)])
    risk[3] = np.inf
    assert expected_error_choice(cand, score) == int(np.argmin(risk))
    assert expected_error_choice(cand, 3.0 * score, temperature=3.0) == int(np.argmin(risk))


def test_expected_error_choice_prefers_the_mass_to_the_mode() -> None:
    """A lone most-likely candidate far from three nearly as likely ones that agree: the choice is among
    the three (the arg-max of the scores, the paper's choice, is the lone one)."""
    cand = np.zeros((4, 5, 3))
    cand[0, :, 0] = 1.0  # the mode, alone
    cand[1:, :, 0] = [[-0.01], [0.0], [0.01]]
    score = np.array([0.5, 0.0, 0.0, 0.0])
    k = expected_error_choice(cand, score)
    # weighted mean x = 0.5 e^0.5 / (e^0.5 + 3) ≈ 0.36 (tempered scores, see expected_error_choice): nearest is x = 0.01
    assert k == 3 and int(np.argmax(score)) == 0
    assert expected_error_choice(cand, np.full(4, -np.inf)) == 0


def test_branch_plans_weights_and_starts() -> None:
    starts = np.array([0, 4, 8])
    post = np.array([[0.05, 0.30, 0.02], [0.25, 0.05, 0.01], [0.20, 0.10, 0.02]])  # beliefs 0.5, 0.45, 0.05
    plans = branch_plans(starts, post, 3)
    assert [s for _, s, _ in plans] == [0, 1]  # label 2 is below the floor
    assert 0.05 < BRANCH_FLOOR
    np.testing.assert_allclose([w for w, _, _ in plans], [0.5 / 0.95, 0.45 / 0.95])
    assert [a for _, _, a in plans] == [4, 0]  # each label's most probable start
    assert [s for _, s, _ in branch_plans(starts, post, 1)] == [0]
    lone = np.array([[0.0, 0.02, 0.0], [0.0, 0.03, 0.0], [0.0, 0.0, 0.95]])
    assert branch_plans(starts, lone, 2) == [(1.0, 2, 8)]


def test_shrink_factor() -> None:
    assert shrink_factor(np.array([0.0, 1.0, 0.0]), 1.0) == 1.0
    assert shrink_factor(np.full(4, 0.25), 1.0) == pytest.approx(0.0)
    assert shrink_factor(np.full(4, 0.25), 0.4) == pytest.approx(0.6)
    a, b = shrink_factor(np.array([0.9, 0.1]), 1.0), shrink_factor(np.array([0.6, 0.4]), 1.0)
    assert 1.0 > a > b > 0.0  # less certain, less of the plan kept
    assert shrink_factor(np.array([1.0]), 1.0) == 1.0
    with pytest.raises(ConfigError, match="shrink"):
        SynthesisConfig(shrink=1.5)


def _steps(model: SocialAffordanceModel, inter, cfg: SynthesisConfig, seed: int = 0):  # noqa: ANN001, ANN202
    syn = OnlineSynthesizer(model, None, cfg)
    syn.reset(observed_part(inter, cfg.n_observed), rng=np.random.default_rng(seed))
    return syn, [syn.step() for _ in range(inter.n_frames)]


def test_shrinkage_pulls_the_emitted_track_toward_hold(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    """One re-planning from the same state: with shrink = 1 every emitted frame lies on the segment from
    hold to the unshrunk plan, at the fraction α of the belief at that moment."""
    base = dataclasses.replace(SynthesisConfig.reactive(), shrink=0.0, contact="none")
    inter = shake8[6]
    T0 = base.n_observed
    seen = []

    class Spy(OnlineSynthesizer):
        def _replan(self, t: int) -> None:
            before = self._track[t - 1, _AGENT1].copy()
            super()._replan(t)
            seen.append((t, self._planned_until, before, self._track[t : self._planned_until, _AGENT1].copy(), self._belief.copy()))

    outs = {}
    for shrink in (0.0, 1.0):
        seen.clear()
        syn = Spy(shake8_model, None, dataclasses.replace(base, shrink=shrink))
        syn.reset(observed_part(inter, T0), rng=np.random.default_rng(0))
        while not seen:
            syn.step()
        outs[shrink] = seen[0]
        hold = syn._track[T0 - 1, _AGENT1]
    (t, stop, _, plan, belief), (_, stop1, _, shrunk, _) = outs[0.0], outs[1.0]
    assert stop == stop1 and t == T0
    alpha = shrink_factor(belief, 1.0)
    assert 0.0 < alpha < 1.0  # the belief is uncertain at the first re-planning: the test has teeth
    np.testing.assert_allclose(shrunk, hold[None] + alpha * (plan - hold[None]), atol=1e-12)
    assert np.nanmax(np.abs(plan - hold[None])) > 1e-3


def test_branches_emit_the_belief_weighted_mean_of_their_plans(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    cfg = dataclasses.replace(SynthesisConfig.reactive(), shrink=0.0, contact="none", branches=2)
    records: list[list[tuple[np.ndarray, int]]] = []

    class Spy(OnlineSynthesizer):
        def _replan(self, t: int) -> None:
            records.append([])
            super()._replan(t)
            records[-1].append((self._track[t : self._planned_until, _AGENT1].copy(), -1))

        def _path(self, t, s, start, last, target, stop=None):  # noqa: ANN001, ANN202
            path, stop = super()._path(t, s, start, last, target, stop)
            records[-1].append((path.copy(), s))
            return path, stop

    syn = Spy(shake8_model, None, cfg)
    syn.reset(observed_part(shake8[6], cfg.n_observed), rng=np.random.default_rng(0))
    mixed = 0
    while not syn.done:
        t = syn.t
        syn.step()
        if records and len(records[-1]) == 3 and records[-1][-1][1] == -1:  # two branches were planned at t
            plans = branch_plans(*syn._filter.posterior(t), 2)
            (p0, s0), (p1, s1), (out, _) = records[-1]
            assert [s0, s1] == [s for _, s, _ in plans]
            (w0, _, _), (w1, _, _) = plans
            assert w0 >= w1 > 0
            np.testing.assert_allclose(out, w0 * p0 + w1 * p1, atol=1e-12)
            mixed += int(np.nanmax(np.abs(p0 - p1)) > 1e-6)
            records[-1].append((out, -2))
    assert mixed >= 1


def test_step_belief_is_the_forward_filter_of_the_track(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    """The belief the simulator reads at frame t is the forward posterior of the canonical track before t
    (agent 0 recorded, agent 1 observed then synthesized), recomputed independently after the run."""
    cfg = SynthesisConfig.reactive()
    inter = shake8[7]
    syn, steps = _steps(shake8_model, inter, cfg)
    fb = ForwardBelief(shake8_model, inter.fps, stride=syn._filter.stride, horizon=syn._filter.horizon)
    track = syn._track
    for st in steps[1:]:
        fb.advance(track, st.t)
        np.testing.assert_allclose(st.belief, fb.belief(st.t), atol=1e-12)
    assert np.ptp([st.belief.max() for st in steps[1:]]) > 0.1  # the belief moves during the instance


def test_order_ranks_are_mean_positions_in_the_parses() -> None:
    from socialaff_sim.model.transitions import order_ranks

    spans = [[(0, 5, 2), (5, 9, 0), (9, 12, 1)], [(4, 8, 2), (0, 4, 0), (8, 12, 1)], [(0, 6, 0), (6, 12, 1)]]
    # time order: 2→0→1, 0→2→1 (rows given out of order), 0→1; type 3 never used
    np.testing.assert_allclose(order_ranks(spans, 4), [(1 + 0 + 0) / 3, (2 + 2 + 1) / 3, (0 + 1) / 2, np.nan])


def test_branch_plans_restricted_to_the_allowed_sub_events() -> None:
    starts = np.array([0, 4, 8])
    post = np.array([[0.05, 0.30, 0.02], [0.25, 0.05, 0.01], [0.20, 0.10, 0.02]])  # beliefs 0.5, 0.45, 0.05
    assert branch_plans(starts, post, 2, np.ones(3, bool)) == branch_plans(starts, post, 2)
    plans = branch_plans(starts, post, 2, np.array([False, True, True]))
    # label 0 (the most probable) is excluded; renormalised, label 2 has 0.05 / 0.5 = 0.1 >= the floor
    assert [s for _, s, _ in plans] == [1, 2]
    np.testing.assert_allclose([w for w, _, _ in plans], [0.45 / 0.5, 0.05 / 0.5])
    assert [a for _, _, a in plans] == [0, 0]
    assert branch_plans(starts, post, 1, np.array([False, False, True])) == [(1.0, 2, 0)]
    assert branch_plans(starts, np.zeros((3, 3)) + post * [1, 1, 0], 1, np.array([False, False, True])) == []


def _planned(model: SocialAffordanceModel, inter, ordered: bool, horizon: float) -> list[int]:  # noqa: ANN001
    """The planned sub-event of every synthesized frame (frames ≥ T0)."""
    syn = OnlineSynthesizer(model, None, SynthesisConfig.reactive(ordered=ordered, belief_horizon=horizon))
    syn.reset(inter, rng=np.random.default_rng(0))
    steps = [syn.step() for _ in range(inter.n_frames)]
    return [s.subevent for s in steps[syn.config.n_observed:]]


def test_ordered_plan_never_returns_to_an_earlier_sub_event(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    """An instance held still for 100 frames after its end, with a belief horizon (10 s) longer than that: the
    default plan follows the forward belief back to a sub-event it has passed; with ``ordered`` the plan keeps the
    learned order (its rank never falls) and stays in the last sub-event; both agree until the first return."""
    from socialaff_sim.model.transitions import order_ranks

    ranks = order_ranks(shake8_model.parses_, shake8_model.n_subevents_)
    inter = shake8[6].extend_held(shake8[6].n_frames + 100)
    free = _planned(shake8_model, inter, False, 10.0)
    kept = _planned(shake8_model, inter, True, 10.0)
    back = np.flatnonzero(np.diff(ranks[free]) < 0)
    assert back.size  # the default plan goes back: the test has teeth
    assert np.all(np.diff(ranks[kept]) >= 0)
    assert free[: back[0] + 1] == kept[: back[0] + 1]
    assert kept[-1] == int(np.nanargmax(ranks))  # the last sub-event runs on


def test_ordered_plan_restarts_after_the_belief_horizon(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    """With the default 4-s horizon, the planned sub-event may fall in rank only once it began a horizon ago (a
    stream can start the interaction again, as the forward belief forgets the labels used before its horizon)."""
    from socialaff_sim.model.transitions import order_ranks

    ranks = order_ranks(shake8_model.parses_, shake8_model.n_subevents_)
    inter = shake8[6].extend_held(shake8[6].n_frames + 100)
    kept = np.array(_planned(shake8_model, inter, True, 4.0))
    horizon = int(round(4.0 * inter.fps))
    falls = np.flatnonzero(np.diff(ranks[kept]) < 0) + 1
    assert falls.size
    for k in falls:  # the sub-event left began at least a horizon before
        begun = k - 1
        while begun > 0 and kept[begun - 1] == kept[k - 1]:
            begun -= 1
        assert k - begun >= horizon - SynthesisConfig().delta_t
