"""Decision points of Algorithm 2 (online synthesis), each pinned so that inverting it fails a test:
which candidate is kept, where the running sub-event ends (duration choice), which sub-event runs
(the prefix DP, also checked by brute force in test_synthesis.py and test_presets.py), when to re-plan,
which full-body cluster a frame is fitted from."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from socialaff_sim.data.dataset import Dataset
from socialaff_sim.inference.protocol import observed_part
from socialaff_sim.inference import BodyFitter, OnlineSynthesizer, SynthesisConfig
from socialaff_sim.inference.candidates import expected_error_choice
from socialaff_sim.inference.synthesis import _AGENT1
from socialaff_sim.learning.estimator import SocialAffordanceModel


class _Recorder(OnlineSynthesizer):
    """Records, at every re-planning, the candidates, their scores and the configuration kept."""

    def __init__(self, *a, **k) -> None:  # noqa: ANN002, ANN003
        super().__init__(*a, **k)
        self.selections: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self.plans: list[tuple[int, int, int, int]] = []

    def _select(self, s, z, cand, before, static, prior):  # noqa: ANN001, ANN202
        best = super()._select(s, z, cand, before, static, prior)
        self.selections.append((cand.copy(), self._score(s, z, cand, before, prior), best.copy()))
        return best

    def _end_frame(self, s: int, start: int, t: int) -> int:
        last = super()._end_frame(s, start, t)
        self.plans.append((t, s, start, last))
        return last


def _run(model: SocialAffordanceModel, inter, config: SynthesisConfig, seed: int = 0, plans: int | None = None) -> _Recorder:  # noqa: ANN001
    """Synthesize the instance (or only until ``plans`` re-plannings were made)."""
    syn = _Recorder(model, None, config)
    syn.reset(observed_part(inter, config.n_observed), rng=np.random.default_rng(seed))
    while not syn.done and (plans is None or len(syn.plans) < plans):
        syn.step()
    return syn


@pytest.mark.parametrize("config", [SynthesisConfig(selection="likelihood"), SynthesisConfig.paper()], ids=["likelihood", "paper"])
def test_candidate_selection_keeps_the_most_likely_of_the_n(shake8_model: SocialAffordanceModel, shake8: Dataset, config: SynthesisConfig) -> None:
    """Algorithm 2 keeps the arg-max of the N candidates' scores (an arg-min, or any other pick, fails)."""
    syn = _run(shake8_model, shake8[6], config)
    assert len(syn.selections) >= 5
    spread = 0
    for cand, score, best in syn.selections:
        extra = (0, config.prior_samples) if config.end_prior == "regression" else (0,)  # no regression for a rare type
        assert cand.shape[0] in {config.n_samples + e for e in extra}
        k = int(np.argmax(score))
        np.testing.assert_array_equal(best[_AGENT1], cand[k, _AGENT1])
        spread += int(np.ptp(score[np.isfinite(score)]) > 1.0)  # the choice matters: scores differ
    assert spread >= len(syn.selections) // 2


def test_default_selection_keeps_the_candidate_of_least_expected_error(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    """``selection="expected"`` (the default): the candidate nearest the score-weighted mean, which is not always
    the most likely one on this instance (so swapping in the arg-max fails)."""
    syn = _run(shake8_model, shake8[6], SynthesisConfig())
    assert len(syn.selections) >= 5
    differ = 0
    for cand, score, best in syn.selections:
        k = expected_error_choice(cand[:, _AGENT1], score, temperature=5.0)
        np.testing.assert_array_equal(best[_AGENT1], cand[k, _AGENT1])
        differ += int(k != int(np.argmax(score)))
    assert differ >= 1


def test_the_kept_candidate_is_reached_at_the_planned_end(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    """Linear interpolation reaches the kept configuration exactly at the predicted end frame when it falls
    inside the ΔT window (the target is the selection, not another candidate)."""
    inter = shake8[6]
    syn = _Recorder(shake8_model, None, SynthesisConfig.paper(delta_t=200))  # one plan: its end is always inside the window
    syn.reset(observed_part(inter, 10), rng=np.random.default_rng(3))
    while not syn.done:
        syn.step()
    (t, s, start, last), (_, _, best) = syn.plans[0], syn.selections[0]
    if last < inter.n_frames:
        np.testing.assert_allclose(syn._track[last, _AGENT1], best[_AGENT1], atol=1e-12)
        assert not np.allclose(syn._track[t, _AGENT1], best[_AGENT1])  # it was not reached at once


def test_duration_choice_median_is_the_conditional_median(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    """``duration="median"``: the end frame is start + the median of D | D > elapsed (scipy reference), at least t."""
    inter = shake8[6]
    syn = _run(shake8_model, inter, SynthesisConfig(duration="median"))
    assert syn.plans
    for t, s, start, last in syn.plans:
        mu, sigma = shake8_model.duration_params_[s]
        dist = stats.lognorm(s=sigma, scale=np.exp(mu))
        elapsed = (t - start) / inter.fps
        total = max(float(dist.isf(0.5 * dist.sf(max(elapsed, 1e-9)))), elapsed)
        assert last == max(start + int(round(total * inter.fps)), t + 1) - 1
        assert last >= t


def test_duration_choice_sample_follows_the_conditional_law(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    """``duration="sample"`` (the paper): predicted ends spread over the conditional law; none ends before t."""
    inter = shake8[6]
    lasts = []
    for seed in range(6):
        syn = _run(shake8_model, inter, SynthesisConfig.paper(), seed=seed, plans=1)
        t, s, start, last = syn.plans[0]
        assert last >= t
        lasts.append(last)
    assert len(set(lasts)) > 1  # drawn, not a fixed quantile


def test_replanning_every_delta_t_for_the_paper(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    """Re-plan at T0, T0 + ΔT, … (and, with ``replan_at_end``, also right after each predicted end)."""
    inter = shake8[6]
    syn = _run(shake8_model, inter, SynthesisConfig.paper())
    assert [p[0] for p in syn.plans] == list(range(10, inter.n_frames, 5))
    syn = _run(shake8_model, inter, SynthesisConfig(replan_at_end=True))
    first = [p for k, p in enumerate(syn.plans) if k == 0 or p[0] != syn.plans[k - 1][0]]  # the top branch sets the stop
    plans = [p[0] for p in first]
    for (t, _, _, last), nxt in zip(first, plans[1:] + [inter.n_frames]):
        assert nxt == min(t + 5, last + 1, inter.n_frames) or nxt == inter.n_frames


def test_sub_event_switch_follows_the_prefix_parse(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    """The running sub-event at each re-planning is the last label of the best parse of the frames so far,
    and its start that parse's last interval's first frame."""
    from socialaff_sim.inference.online_parse import parse_prefix
    from socialaff_sim.learning.atomic import cut_atoms

    inter = shake8[6]
    m = shake8_model
    syn = _run(m, inter, SynthesisConfig(belief="argmax"), plans=12)
    labels = {p[1] for p in syn.plans}
    assert len(labels) >= 2  # the sub-event does switch on this instance
    lc = m.learning
    for t, s, start, _ in syn.plans:
        prefix = syn._track[:t]
        bounds = cut_atoms(prefix, inter.fps, m.available_, m.centroids_, min_frames=lc.min_atomic_frames,
                           max_seconds=lc.max_atomic_seconds, tau=lc.velocity_seconds)
        parse = parse_prefix(m, prefix, inter.fps, bounds)
        assert (s, start) == (parse.current, parse.start)


def test_sub_event_of_the_default_follows_the_forward_belief(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    """``belief="forward"`` (the default): the first sub-event planned at each re-planning is the most probable
    label of the filtering posterior, from that label's most probable start (an arg-min fails)."""
    inter = shake8[6]
    cfg = SynthesisConfig(branches=1)
    starts_seen = []

    class Rec(_Recorder):
        def _replan(self, t: int) -> None:
            starts, post = self._filter.posterior(t)
            starts_seen.append((t, starts, post))
            super()._replan(t)

    syn = Rec(shake8_model, None, cfg)
    syn.reset(observed_part(inter, cfg.n_observed), rng=np.random.default_rng(0))
    while not syn.done:
        syn.step()
    assert len({p[1] for p in syn.plans}) >= 2
    for (t, s, start, _), (t2, starts, post) in zip(syn.plans, starts_seen, strict=True):
        assert t == t2
        b = post.sum(axis=0)
        assert s == int(np.argmax(b))
        assert start == int(starts[np.argmax(post[:, s])])


def test_full_body_fit_picks_the_nearest_cluster(shake8: Dataset) -> None:
    """Each frame's skeleton starts from the cluster whose base-relative key joints are nearest (brute force)."""
    body = BodyFitter().fit_interactions(list(shake8)[:4], agent=1, rng=np.random.default_rng(0))
    keys = body.keys_
    rng = np.random.default_rng(1)
    targets = keys[rng.integers(len(keys), size=12)] + rng.normal(0, 0.03, (12, *keys.shape[1:]))
    got = body.select_clusters(targets)
    rel = targets[:, 1:] - targets[:, :1]
    d = ((rel[:, None] - keys[None, :, 1:]) ** 2).sum(axis=(2, 3))
    np.testing.assert_array_equal(got, np.argmin(d, axis=1))
    assert len(set(got.tolist())) > 1
