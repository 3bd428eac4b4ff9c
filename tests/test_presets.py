"""The paper preset: one test per difference from the default, each pinning the paper's value and the
behaviour of the code path it selects, and an end-to-end fit and synthesis with it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import labelled_partitions

from socialaff_sim.data.dataset import Dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.inference.protocol import observed_part
from socialaff_sim.inference import OnlineSynthesizer, SynthesisConfig, parse_prefix, synthesize
from socialaff_sim.inference.presets import PRESETS, Preset, preset
from socialaff_sim.learning.algorithm import learn, make_spaces, temperatures
from socialaff_sim.learning.config import LearningConfig
from socialaff_sim.learning.mh import draw_move
from socialaff_sim.learning.estimator import SocialAffordanceModel
from socialaff_sim.model.config import AffordanceConfig
from socialaff_sim.model.joints import available_joints, canonical_joints
from socialaff_sim.model.potentials import reference_weights
from socialaff_sim.model.transitions import smoothed_probs, transition_loglik


@pytest.fixture(scope="module")
def paper_model(shake8: Dataset) -> SocialAffordanceModel:
    p = preset("paper")
    return SocialAffordanceModel(p.affordance, dataclasses.replace(p.learning, iterations=3)).fit(
        list(shake8)[:6], rng=np.random.default_rng(0)
    )


def test_preset_names_and_error() -> None:
    assert PRESETS == ("default", "paper")
    assert preset("default") == Preset(AffordanceConfig(), LearningConfig(), SynthesisConfig())
    assert preset("paper") == Preset(AffordanceConfig.paper(), LearningConfig.paper(), SynthesisConfig.paper())
    with pytest.raises(ConfigError, match="'default' or 'paper'"):
        preset("papr")


# -- model (section 3) ---------------------------------------------------------------------------
def test_reference_is_the_mass_centre_of_the_whole_group() -> None:
    """Paper: a grouped joint's reference is its group's mass centre, the joint included."""
    assert AffordanceConfig.paper().reference_self and not AffordanceConfig().reference_self
    z = np.array([0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 1])  # agent 0's left wrist, agent 1's left wrist, the object
    W = reference_weights(z, other_side=False, include_self=True)
    for j in (1, 6, 10):
        np.testing.assert_allclose(W[j], np.isin(np.arange(11), [1, 6, 10]) / 3.0)
    W0 = reference_weights(z, other_side=False, include_self=False)
    np.testing.assert_allclose(W0[1], np.isin(np.arange(11), [6, 10]) / 2.0)
    # A lone joint keeps the other agent's base in both (its own mass centre would be a zero offset).
    lone = np.array([0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0])
    assert reference_weights(lone, other_side=False, include_self=True)[1, 5] == 1.0


def test_reference_reads_group_mates_on_both_sides() -> None:
    """Paper: every group mate counts, also those of the joint's own agent (default: the other side only)."""
    assert not AffordanceConfig.paper().other_side_reference and AffordanceConfig().other_side_reference
    z = np.array([0, 1, 1, 0, 0, 0, 1, 0, 0, 0, 0])  # both wrists of agent 0 and agent 1's left wrist
    paper = reference_weights(z, other_side=False, include_self=True)[1]
    default = reference_weights(z, other_side=True)[1]
    np.testing.assert_allclose(paper, np.isin(np.arange(11), [1, 2, 6]) / 3.0)
    np.testing.assert_allclose(default, np.isin(np.arange(11), [6]) * 1.0)


def test_start_probability_is_uniform(paper_model: SocialAffordanceModel) -> None:
    """Paper: the parse probability has transitions only, so p(s_1) is uniform and the objective does
    not depend on which label starts."""
    assert not AffordanceConfig.paper().start_prior and AffordanceConfig().start_prior
    start, trans = np.array([5.0, 0.0, 1.0]), 1.0 - np.eye(3)
    p_start, _ = smoothed_probs(start, trans, 1.0, True, learn_start=False)
    np.testing.assert_allclose(p_start, np.full(3, 1 / 3))
    a = transition_loglik(start, trans, 1.0, True, learn_start=False)
    b = transition_loglik(start[::-1].copy(), trans, 1.0, True, learn_start=False)
    assert a == pytest.approx(b) and a == pytest.approx(6 * np.log(1 / 3) + transition_loglik(np.zeros(3), trans, 1.0, True))
    learned, _ = smoothed_probs(start, trans, 1.0, True)
    assert learned[0] > learned[1]
    np.testing.assert_allclose(paper_model.start_probs_, np.full(paper_model.n_subevents_, 1 / paper_model.n_subevents_))


def test_a_sub_event_type_may_recur(paper_model: SocialAffordanceModel, shake8: Dataset) -> None:
    """Paper: no one-interval-per-type constraint on parses."""
    assert not AffordanceConfig.paper().unique_labels and AffordanceConfig().unique_labels
    tracks = [canonical_joints(i) for i in list(shake8)[:2]]
    res = learn(tracks, [i.fps for i in list(shake8)[:2]], available_joints(tracks), 3, AffordanceConfig.paper(),
                LearningConfig.paper(iterations=0), rng=np.random.default_rng(0))
    spaces = make_spaces(res.atoms, 3, AffordanceConfig.paper())
    assert all(sp.max_repeats is None for sp in spaces)
    assert spaces[0].is_valid(type(res.parses[0])((0, 1, 2), (0, 1, 0)))
    assert not make_spaces(res.atoms, 3, AffordanceConfig())[0].is_valid(type(res.parses[0])((0, 1, 2), (0, 1, 0)))


def test_no_path_noise_term(paper_model: SocialAffordanceModel) -> None:
    """Paper: the potentials see a sub-event's two ends only; no term for the frames in between."""
    cfg = AffordanceConfig.paper()
    assert not cfg.path_noise and cfg.feature_path_profile is None and AffordanceConfig().path_noise
    assert np.isnan(paper_model.path_sigma_).all()


def test_left_and_right_as_recorded(paper_model: SocialAffordanceModel, shake8: Dataset) -> None:
    """Paper: no active-hand relabelling: the learned mean end configurations are those of the tracks as recorded."""
    assert not AffordanceConfig.paper().active_hand and AffordanceConfig().active_hand
    tracks = [canonical_joints(i) for i in list(shake8)[:6]]
    for s in range(paper_model.n_subevents_):
        ends = [x[f1 - 1] for x, rows in zip(tracks, paper_model.parses_, strict=True) for f0, f1, lab in rows if lab == s]
        if ends:
            np.testing.assert_allclose(paper_model.mean_end_[s], np.mean(ends, axis=0), atol=1e-9)


# -- Algorithm 1 (section 4) ----------------------------------------------------------------------
def test_paper_proposals_are_merge_split_relabel_only(rng: np.random.Generator) -> None:
    """Paper: merge 0.4, split 0.4, relabel 0.2, no shift move."""
    cfg = LearningConfig.paper()
    assert (cfg.p_merge, cfg.p_split, cfg.p_relabel, cfg.p_shift) == (0.4, 0.4, 0.2, 0.0)
    n = 6000
    drawn = [draw_move(cfg, rng) for _ in range(n)]
    freq = {m: drawn.count(m) / n for m in ("merge", "split", "relabel", "shift")}
    for m, p in (("merge", 0.4), ("split", 0.4), ("relabel", 0.2)):
        assert abs(freq[m] - p) < 5 * np.sqrt(p * (1 - p) / n)
    assert freq["shift"] == 0.0
    assert draw_move(LearningConfig(), np.random.default_rng(1)) in ("merge", "split", "relabel", "shift")


def test_paper_chain_starts_from_the_equal_parts_of_the_atoms(shake8: Dataset) -> None:
    """Paper: no hard-EM start, no type restructuring, no extra starts: the chain starts from the K-means atoms' equal parts."""
    cfg = LearningConfig.paper(iterations=0)
    assert (cfg.init_rounds, cfg.init_type_passes, cfg.init_starts) == (0, 0, 0)
    inters = list(shake8)[:3]
    tracks = [canonical_joints(i) for i in inters]
    res = learn(tracks, [i.fps for i in inters], available_joints(tracks), 4, AffordanceConfig.paper(), cfg,
                rng=np.random.default_rng(0))
    assert res.start_parses == tuple(sp.initial_parse(4) for sp in res.spaces)
    default = learn(tracks, [i.fps for i in inters], available_joints(tracks), 4, AffordanceConfig.paper(),
                    LearningConfig(iterations=0), rng=np.random.default_rng(0))
    assert default.start_parses != res.start_parses  # hard-EM moves the equal parts


def test_paper_chain_is_not_tempered() -> None:
    assert LearningConfig.paper().temperature == 1.0
    np.testing.assert_array_equal(temperatures(LearningConfig.paper(), 7), np.ones(7))
    t = temperatures(LearningConfig(temperature=100.0), 5)
    np.testing.assert_allclose(t, 100.0 ** np.array([1, 0.75, 0.5, 0.25, 0.0]))


# -- Algorithm 2 (section 5) ----------------------------------------------------------------------
def test_paper_synthesis_settings() -> None:
    c = SynthesisConfig.paper()
    assert (c.n_observed, c.delta_t, c.n_samples) == (10, 5, 100)
    assert (c.duration, c.interpolation, c.parse, c.end_prior, c.contact) == ("sample", "linear", "online", "none", "none")
    assert not (c.lookahead or c.replan_at_end) and c.frame_weight == 0.0 and c.refine_sweeps == 0
    assert c.parse_window is None and SynthesisConfig().parse_window is not None  # the DP reads every frame since the start


def test_no_vertical_sign_term(paper_model: SocialAffordanceModel, shake8: Dataset) -> None:
    """Paper: candidates are scored by the spatial and motion potentials alone (|dz|, no sign of dz)."""
    assert not SynthesisConfig.paper().vertical_sign and SynthesisConfig().vertical_sign
    syn = OnlineSynthesizer(paper_model, None, SynthesisConfig.paper())
    syn.reset(observed_part(shake8[6], 10), rng=np.random.default_rng(0))
    cand = np.repeat(canonical_joints(shake8[6])[20][None], 4, axis=0) + np.random.default_rng(2).normal(0, 0.05, (4, 11, 3))
    before = canonical_joints(shake8[6])[12]
    for s in range(paper_model.n_subevents_):
        z = paper_model.grouping_[s]
        expected = paper_model.log_spatial(s, cand) + paper_model.log_motion(s, cand - before[None])
        np.testing.assert_allclose(syn._score(s, z, cand, before, None), np.where(np.isnan(expected), -np.inf, expected))


def test_online_parse_scores_the_running_sub_event_as_closed(paper_model: SocialAffordanceModel, shake8: Dataset) -> None:
    """Paper: the online DP scores the running sub-event like any other interval, ending at the latest frame;
    checked against brute force over every labelled partition."""
    assert SynthesisConfig.paper().open_interval == "closed" and SynthesisConfig().open_interval == "survival"
    m = paper_model
    inter = shake8[6]
    track = m.canonical_track(inter)[:30]
    bounds = np.array([0, 6, 13, 21, 30])
    best = np.full(m.n_subevents_, -np.inf)
    for pts, labels in labelled_partitions(4, m.n_subevents_, distinct=m.config.distinct_neighbours, unique=False):
        score = m.log_start_probs_[labels[0]] + sum(m.log_transitions_[a, b] for a, b in zip(labels, labels[1:]))
        for (p, q), s in zip(zip(pts, pts[1:]), labels):
            f = m.interval_features(track, np.array([bounds[p]]), np.array([bounds[q]]), inter.fps)
            score += m.interval_log_score(f, s)[0]
        best[labels[-1]] = max(best[labels[-1]], score)
    parse = parse_prefix(m, track, inter.fps, bounds, "closed")
    assert parse.score == pytest.approx(best.max(), abs=1e-9)
    assert parse.current == int(np.argmax(best))
    assert parse_prefix(m, track, inter.fps, bounds, "survival").score != pytest.approx(parse.score)


def test_end_to_end_fit_and_synthesis_with_the_paper_preset(paper_model: SocialAffordanceModel, shake8: Dataset) -> None:
    h = paper_model.history_
    assert h["log_posterior"].shape == (4,) and sum(int(h[f"proposed_{m}"].sum()) for m in ("merge", "split", "relabel")) == 18
    assert int(h["proposed_shift"].sum()) == 0
    inter = shake8[7]
    cfg = SynthesisConfig.paper()
    keys, _, subs, _ = synthesize(paper_model, observed_part(inter, cfg.n_observed), rng=np.random.default_rng(0), config=cfg)
    avail = inter.key_available()
    assert keys.shape == inter.key_joints()[:, 1].shape and np.isfinite(keys[:, avail]).all()
    assert (subs[cfg.n_observed:] >= 0).all()
    again = synthesize(paper_model, observed_part(inter, cfg.n_observed), rng=np.random.default_rng(0), config=cfg)[0]
    np.testing.assert_array_equal(keys, again)


def test_stream_parser_scores_the_running_sub_event_as_parse_prefix_does(paper_model: SocialAffordanceModel, shake8: Dataset) -> None:
    """The synthesizer's incremental parser gives the same parse as :func:`parse_prefix` with the same
    ``open_interval`` (whole-stream window), re-planning after re-planning."""
    from socialaff_sim.inference.stream_parse import StreamParser
    from socialaff_sim.learning.atomic import cut_atoms

    m = paper_model
    inter = shake8[6]
    track = m.canonical_track(inter)
    lc = m.learning
    kw = dict(min_frames=lc.min_atomic_frames, max_seconds=lc.max_atomic_seconds, tau=lc.velocity_seconds)
    for mode in ("closed", "survival"):
        parser = StreamParser(m, inter.fps, None, open_interval=mode, **kw)
        for t in range(10, track.shape[0] + 1, 5):
            got, w0 = parser.parse(track, t, m.available_)
            bounds = cut_atoms(track[:t], inter.fps, m.available_, m.centroids_, **kw)
            want = parse_prefix(m, track[:t], inter.fps, bounds, mode)
            assert w0 == 0 and got.score == pytest.approx(want.score, abs=1e-9)
            np.testing.assert_array_equal(got.intervals, want.intervals)
