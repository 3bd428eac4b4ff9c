"""The SocialAffordanceModel: fitting (Algorithm 1), learned attributes, hooks, scoring, CLI."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy import stats

from socialaff_sim.data import save_dataset
from socialaff_sim.data.dataset import Dataset
from socialaff_sim.data.interaction import Interaction
from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.errors import ConfigError, ModelError, NotFittedError
from socialaff_sim.learning.algorithm import learn
from socialaff_sim.learning.config import LearningConfig
from socialaff_sim.learning.gibbs import joint_log_prob
from socialaff_sim.learning.likelihood import TypeLikelihood
from socialaff_sim.learning.mh import mh_step
from socialaff_sim.learning.scorer import AffordanceTarget
from socialaff_sim.learning import SocialAffordanceModel
from socialaff_sim.model.config import AffordanceConfig, default_n_subevents
from socialaff_sim.model.densities import fit_lognorm
from socialaff_sim.model.features import type_samples
from socialaff_sim.model.joints import JOINT_NAMES, N_JOINTS, OBJECT, available_joints, canonical_joints, instance_frame
from socialaff_sim.model.potentials import reference_weights
from socialaff_sim.model.transitions import count_transitions, transition_loglik

FAST = LearningConfig(iterations=3)


@pytest.fixture(scope="module")
def hand_over() -> Dataset:
    return generate_dataset(0, SyntheticConfig(interactions=("hand_over",), instances_per_interaction=7))


@pytest.fixture(scope="module")
def fitted(hand_over: Dataset) -> SocialAffordanceModel:
    return SocialAffordanceModel(learning=FAST).fit(list(hand_over)[:6], rng=np.random.default_rng(0))


def test_not_fitted_errors() -> None:
    model = SocialAffordanceModel()
    for call in (lambda: model.grouping_, lambda: model.log_spatial(0, np.zeros((1, N_JOINTS, 3))), lambda: model.save("x.npz")):
        with pytest.raises(NotFittedError, match="not fitted"):
            call()
    assert "unfitted" in repr(model)


def test_fit_rejects_bad_input(hand_over: Dataset) -> None:
    with pytest.raises(ModelError, match="at least one"):
        SocialAffordanceModel().fit([], rng=np.random.default_rng(0))
    other = generate_dataset(0, SyntheticConfig(interactions=("high_five",), instances_per_interaction=1))
    with pytest.raises(ModelError, match="labels"):
        SocialAffordanceModel().fit([hand_over[0], other[0]], rng=np.random.default_rng(0))
    with pytest.raises(ConfigError, match="beta"):
        AffordanceConfig(beta=1.5)
    with pytest.raises(ConfigError, match="p_merge"):
        LearningConfig(p_merge=0.9)


def test_learned_attributes(fitted: SocialAffordanceModel, hand_over: Dataset) -> None:
    S = default_n_subevents("hand_over")
    assert S == 4 and fitted.n_subevents_ == S and len(fitted.subevent_names_) == S
    assert fitted.grouping_.shape == (S, N_JOINTS)
    assert fitted.available_.all()  # kinect_v2 has every key joint; hand_over has the cup
    assert fitted.spatial_params_.shape == fitted.motion_params_.shape == (S, N_JOINTS, 6)
    np.testing.assert_allclose(fitted.transitions_.sum(axis=1), 1.0)
    np.testing.assert_allclose(np.diag(fitted.transitions_), 0.0)
    assert fitted.start_probs_.sum() == pytest.approx(1.0)
    assert fitted.trace_.shape == (FAST.iterations + 1,) and fitted.acceptance_.shape == (FAST.iterations,)
    assert 0.0 <= fitted.acceptance_rate_ <= 1.0
    assert fitted.log_posterior_ >= fitted.trace_.max() - 1e-9
    for inter, rows in zip(list(hand_over)[:6], fitted.parses_, strict=True):
        assert rows[0, 0] == 0 and rows[-1, 1] == inter.n_frames
        np.testing.assert_array_equal(rows[1:, 0], rows[:-1, 1])
        assert len(set(rows[:, 2].tolist())) == len(rows)  # each type at most once (unique_labels)


def _active_hand_track(inter: Interaction) -> np.ndarray:
    """canonical_joints with each agent's left/right key joints swapped, by name, where its left wrist's
    summed frame-to-frame travel is the longer (an independent rewrite of the model's relabelling)."""
    x = canonical_joints(inter)
    out = x.copy()
    for a in (0, 1):
        travel = {side: sum(np.linalg.norm(x[t + 1, JOINT_NAMES.index(f"agent{a}.{side}_wrist")]
                                           - x[t, JOINT_NAMES.index(f"agent{a}.{side}_wrist")])
                            for t in range(len(x) - 1)) for side in ("left", "right")}
        if travel["left"] > travel["right"]:
            for part in ("wrist", "ankle"):
                i, j = JOINT_NAMES.index(f"agent{a}.left_{part}"), JOINT_NAMES.index(f"agent{a}.right_{part}")
                out[:, [i, j]] = x[:, [j, i]]
    return out


def test_final_parameters_are_the_fit_of_the_final_parses(fitted: SocialAffordanceModel, hand_over: Dataset) -> None:
    inters = list(hand_over)[:6]
    tracks = [_active_hand_track(i) for i in inters]
    assert any(not np.array_equal(t, canonical_joints(i), equal_nan=True) for t, i in zip(tracks, inters, strict=True))
    spans = [[tuple(r) for r in rows.tolist()] for rows in fitted.parses_]
    for s in range(fitted.n_subevents_):
        feats = type_samples(tracks, [i.fps for i in inters], spans, s)
        if not len(feats):
            continue
        ln = fit_lognorm(feats.seconds)
        np.testing.assert_allclose(fitted.duration_params_[s], [ln.mu[0], ln.sigma[0]], rtol=1e-12)
        # Frequency of upward displacements (add-one smoothed), for synthesis to tell up from down.
        up = (np.sum(feats.disp[:, :, 2] > 0, axis=0) + 1.0) / (len(feats) + 2.0)
        np.testing.assert_allclose(fitted.vertical_up_[s, 1], up)
        np.testing.assert_allclose(fitted.mean_end_[s], feats.end.mean(axis=0))
        # The hooks reproduce the maximized log-likelihood of the grouping on the training samples.
        lik = TypeLikelihood(feats.end, feats.disp, fitted.available_, fitted.config)
        total = fitted.log_spatial(s, feats.end).sum() + fitted.log_motion(s, feats.disp).sum()
        assert total == pytest.approx(lik.loglik(fitted.grouping_[s]), rel=1e-9)


def test_fit_is_deterministic(hand_over: Dataset, fitted: SocialAffordanceModel) -> None:
    again = SocialAffordanceModel(learning=FAST).fit(list(hand_over)[:6], rng=np.random.default_rng(0))
    np.testing.assert_array_equal(again.grouping_, fitted.grouping_)
    np.testing.assert_array_equal(again.trace_, fitted.trace_)
    for a, b in zip(again.parses_, fitted.parses_, strict=True):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(again.spatial_params_, fitted.spatial_params_)


def test_hooks(fitted: SocialAffordanceModel, hand_over: Dataset, rng: np.random.Generator) -> None:
    inter = hand_over[6]
    frame = instance_frame(inter)
    track = fitted.canonical_track(inter, frame)
    np.testing.assert_allclose(frame.to_world(track[:, OBJECT]), inter.object, atol=1e-9)
    starts = np.array([0, 0, 5, 10])
    stops = np.array([5, 10, 20, 30])
    feats = fitted.interval_features(track, starts, stops, inter.fps)
    for s in range(fitted.n_subevents_):
        score = fitted.interval_log_score(feats, s)
        parts = (fitted.log_spatial(s, feats.end) + fitted.log_motion(s, feats.disp)
                 + fitted.log_duration(s, feats.seconds) + fitted.log_path(s, feats))
        np.testing.assert_allclose(score, parts, rtol=1e-12)
        assert score.shape == (4,)
        cand = feats.end[:1] + rng.normal(0, 0.05, (100, N_JOINTS, 3))
        assert fitted.log_spatial(s, cand).shape == (100,)
        assert fitted.log_motion(s, cand - track[0]).shape == (100,)
    np.testing.assert_allclose(np.exp(fitted.log_transitions_).sum(axis=1), 1.0)
    assert fitted.log_start_probs_.shape == (fitted.n_subevents_,)
    with pytest.raises(ModelError, match="sub-event index"):
        fitted.log_duration(fitted.n_subevents_, 1.0)


def test_score_and_best_parse(fitted: SocialAffordanceModel, hand_over: Dataset) -> None:
    inter = hand_over[6]
    total, rows = fitted.best_parse(inter)
    assert rows[0, 0] == 0 and rows[-1, 1] == inter.n_frames
    # The DP's value is the model's log probability of the parse it returns.
    track = fitted.canonical_track(inter)
    feats = fitted.interval_features(track, rows[:, 0], rows[:, 1], inter.fps)
    labels = rows[:, 2]
    direct = fitted.log_start_probs_[labels[0]] + sum(fitted.log_transitions_[a, b] for a, b in zip(labels, labels[1:]))
    direct += sum(fitted.interval_log_score(feats, int(s))[k] for k, s in enumerate(labels))
    assert total == pytest.approx(direct, rel=1e-10)
    assert fitted.score([inter]) == pytest.approx(total / inter.n_frames)


@pytest.mark.parametrize(
    "options",
    [{}, {"likelihood": "held_out", "vector_density": "cartesian", "duration_density": "log_seconds"}],
)
def test_incremental_target_matches_a_fresh_evaluation(hand_over: Dataset, rng: np.random.Generator, options: dict) -> None:
    """After accepted MH moves, the cached per-type statistics equal a from-scratch evaluation."""
    inters = list(hand_over)[:5]
    tracks = [canonical_joints(i) for i in inters]
    fps = [i.fps for i in inters]
    av = available_joints(tracks)
    acfg, lcfg = AffordanceConfig(**options), LearningConfig(init_rounds=0)
    res = learn(tracks, fps, av, 4, acfg, dataclasses.replace(lcfg, iterations=0), rng=rng)
    target = AffordanceTarget(tracks, fps, list(res.spaces), list(res.parses), av, 4, acfg, lcfg, rng)
    current = target.log_prob
    accepted = 0
    for k in range(60):
        i = k % len(inters)
        step = mh_step(res.spaces[i], i, target.parses[i], current, target, dataclasses.replace(lcfg, p_shift=0.9), rng)
        current = step.log_p
        accepted += step.accepted
        assert current == pytest.approx(target.log_prob, abs=1e-9)
    assert accepted > 0
    spans = [sp.frame_spans(p) for sp, p in zip(res.spaces, target.parses, strict=True)]
    expected = transition_loglik(*count_transitions(spans, 4), acfg.transition_alpha, True)
    for s, ts in enumerate(target.types):
        feats = type_samples(tracks, fps, spans, s)
        lik = TypeLikelihood(feats.end, feats.disp, av, acfg)
        assert ts.potential == pytest.approx(joint_log_prob(lik, ts.z, acfg.beta, acfg.gamma), abs=1e-8)
        if not len(feats):
            dur = 0.0
        elif acfg.likelihood == "held_out":  # each duration under the log-normal fitted to the others
            x = feats.seconds
            dur = sum(
                stats.lognorm.logpdf(x[n], *_lognorm_args(np.delete(x, n))) for n in range(x.size)
            ) if x.size > 1 else fit_lognorm(x).loglik[0]
        else:
            dur = fit_lognorm(feats.seconds).loglik[0]
        if len(feats) and acfg.duration_density == "log_seconds":
            dur += np.log(feats.seconds).sum()
        assert ts.duration == pytest.approx(dur, abs=1e-9)
        assert ts.path == pytest.approx(_path_reference(tracks, spans, s, av, acfg), rel=1e-9)
        expected += ts.potential + ts.duration + ts.path
    assert target.log_prob == pytest.approx(expected, abs=1e-8)


def _path_reference(tracks, spans, s: int, av: np.ndarray, acfg: AffordanceConfig) -> float:  # noqa: ANN001
    """Path-noise log-likelihood of type s by a frame loop and scipy.stats.norm at the closed-form σ."""
    if not acfg.path_noise:
        return 0.0
    resid = []
    for x, sp in zip(tracks, spans, strict=True):
        for f0, f1, lab in sp:
            if lab != s:
                continue
            a, e = max(f0 - 1, 0), f1 - 1
            for t in range(a + 1, e):
                v = (t - a) / (e - a)
                u = 10 * v**3 - 15 * v**4 + 6 * v**5
                resid.append(x[t, av] - (x[a, av] + u * (x[e, av] - x[a, av])))
    if not resid:
        return 0.0
    r = np.stack(resid)  # (n, J, 3)
    sigma = np.maximum(np.sqrt((r**2).sum(axis=(0, 2)) / (3 * r.shape[0])), acfg.path_sigma_min)
    return float(stats.norm.logpdf(r, scale=sigma[None, :, None]).sum())


def _lognorm_args(x: np.ndarray) -> tuple[float, int, float]:
    """scipy.stats.lognorm (s, loc, scale) of the floored ML fit of durations ``x``."""
    f = fit_lognorm(x, sigma_min=AffordanceConfig().sigma_min)
    return float(f.sigma[0]), 0, float(np.exp(f.mu[0]))


def test_ablations(hand_over: Dataset) -> None:
    inters = list(hand_over)[:5]
    v1 = SocialAffordanceModel(AffordanceConfig(use_grouping=False), FAST).fit(inters, rng=np.random.default_rng(1))
    assert (v1.grouping_ > 0).all()  # every joint affordable ...
    for z in v1.grouping_:
        assert len(set(z.tolist())) == N_JOINTS  # ... and alone in its group
    v2 = SocialAffordanceModel(AffordanceConfig(use_subevents=False), FAST).fit(inters, rng=np.random.default_rng(1))
    assert v2.n_subevents_ == 1 and v2.trace_.shape == (1,)
    for inter, rows in zip(inters, v2.parses_, strict=True):
        np.testing.assert_array_equal(rows, [[0, inter.n_frames, 0]])


def test_cli_fit_and_show(tmp_path, hand_over: Dataset, capsys: pytest.CaptureFixture[str]) -> None:  # noqa: ANN001
    from socialaff_sim.cli.main import main

    save_dataset(Dataset("small", tuple(hand_over)[:5]), tmp_path / "data")
    out = tmp_path / "model.npz"
    code = main(["fit", "--data", f"npz:{tmp_path / 'data'}", "--interaction", "hand_over", "--out", str(out),
                 "--iterations", "2", "--seed", "3", "--no-progress"])
    assert code == 0 and out.is_file()
    assert "fitted 'hand_over' on 5 instances" in capsys.readouterr().out
    fig = tmp_path / "groups.png"
    assert main(["show", str(out), "--figure", str(fig)]) == 0
    text = capsys.readouterr().out
    assert "agent1.right_wrist" in text and "object" in text and ("Null" in text or "group" in text)
    assert fig.stat().st_size > 1000
    assert main(["fit", "--data", f"npz:{tmp_path / 'data'}", "--interaction", "nope", "--out", str(out), "--no-progress"]) == 2


def test_config_defaults_and_round_trip() -> None:
    cfg = AffordanceConfig()
    assert (cfg.beta, cfg.gamma) == (0.3, 1.0)
    lc = LearningConfig()
    assert (lc.p_merge, lc.p_split, lc.p_relabel, lc.lam, lc.n_clusters, lc.iterations) == (0.4, 0.4, 0.2, 1.0, 50, 0)
    # The paper's Algorithm 1 keeps its 100 MH iterations; only this project's default starts from the parse alone.
    assert LearningConfig.paper().iterations == 100
    assert AffordanceConfig.from_dict(cfg.to_dict()) == cfg and LearningConfig.from_dict(lc.to_dict()) == lc
    with pytest.raises(ConfigError, match="unknown fields"):
        AffordanceConfig.from_dict({"nope": 1})
    assert (cfg.likelihood, cfg.vector_density, cfg.duration_density, lc.init_starts) == ("profile", "polar", "seconds", 0)
    for name in ("likelihood", "vector_density", "duration_density"):
        with pytest.raises(ConfigError, match=name):
            AffordanceConfig(**{name: "nope"})
    with pytest.raises(ConfigError, match="init_starts"):
        LearningConfig(init_starts=-1)
    with pytest.raises(ConfigError, match="init_dirichlet"):
        LearningConfig(init_dirichlet=0.0)
    assert default_n_subevents("throw_catch") == 5
    assert default_n_subevents("not_in_the_synthetic_set") == 4


def test_corrected_objective_options_fit_and_hooks(hand_over: Dataset) -> None:
    """The non-paper options fit end to end, and the hooks add the documented Jacobians to the paper's potentials."""
    options = {"likelihood": "held_out", "vector_density": "cartesian", "duration_density": "log_seconds"}
    learning = dataclasses.replace(FAST, init_starts=2)
    model = SocialAffordanceModel(AffordanceConfig(**options), learning).fit(list(hand_over)[:6], rng=np.random.default_rng(0))
    assert model.log_posterior_ >= model.trace_.max() - 1e-9
    # The same learned potentials scored as the paper's polar densities.
    polar = SocialAffordanceModel(AffordanceConfig(), learning)
    polar.__dict__.update({k: v for k, v in model.__dict__.items() if k.endswith("_")})
    track = model.canonical_track(hand_over[6])
    feats = model.interval_features(track, np.array([0, 4]), np.array([9, 20]), hand_over[6].fps)
    for s in range(model.n_subevents_):
        z = model.grouping_[s]
        W = reference_weights(np.where(model.available_, z, -1), other_side=True)
        aff = np.flatnonzero((z > 0) & model.available_)
        off = feats.end[:, aff] - np.einsum("kj,njd->nkd", W[aff][:, model.available_], feats.end[:, model.available_])
        jac = -np.log(2.0 * np.maximum(np.hypot(off[..., 0], off[..., 1]), model.config.eps)).sum(axis=1)
        np.testing.assert_allclose(model.log_spatial(s, feats.end), polar.log_spatial(s, feats.end) + jac, rtol=1e-12)
        d = feats.disp[:, model.available_]
        jac_m = -np.log(2.0 * np.maximum(np.hypot(d[..., 0], d[..., 1]), model.config.eps)).sum(axis=1)
        np.testing.assert_allclose(model.log_motion(s, feats.disp), polar.log_motion(s, feats.disp) + jac_m, rtol=1e-12)
        np.testing.assert_allclose(
            model.log_duration(s, feats.seconds), polar.log_duration(s, feats.seconds) + np.log(feats.seconds), rtol=1e-12
        )
