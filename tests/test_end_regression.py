"""End-configuration regression (model) and the offline synthesis that uses it with the observed parse."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import labelled_partitions
from scipy import stats

from socialaff_sim.data.dataset import Dataset
from socialaff_sim.errors import ConfigError, ModelError
from socialaff_sim.evaluation import get_method
from socialaff_sim.inference.protocol import observed_part
from socialaff_sim.inference import SynthesisConfig, synthesize
from socialaff_sim.inference.candidates import RegressionPrior
from socialaff_sim.inference.observed_parse import observed_joints, parse_observed
from socialaff_sim.learning import SocialAffordanceModel
from socialaff_sim.model.end_regression import end_context, fit_end_regression, interval_samples, n_context, offset_columns
from socialaff_sim.model.frame_regression import (
    fit_frame_regression,
    frame_context,
    frame_offset_columns,
    frame_samples,
    n_frame_context,
)
from socialaff_sim.model.ridge import RidgeRegression, fit_ridge, ridge_solve



def _configs(rng: np.random.Generator, M: int, available: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    end, before, first = rng.normal(size=(3, M, 11, 3))
    for x in (end, before, first):
        x[:, ~available] = np.nan
    return end, before, first


def test_ridge_matches_an_augmented_least_squares(rng: np.random.Generator) -> None:
    X = rng.normal(size=(12, 5))
    Y = rng.normal(size=(12, 3))
    lam = 2.5
    mean, scale, y_mean, coef = ridge_solve(X, Y, lam)
    Z = (X - mean) / scale
    # Independent reference: ridge is least squares on the system stacked with sqrt(λ) I.
    A = np.vstack([Z, np.sqrt(lam) * np.eye(5)])
    B = np.vstack([Y - y_mean, np.zeros((5, 3))])
    ref = np.linalg.lstsq(A, B, rcond=None)[0]
    np.testing.assert_allclose(coef, ref, atol=1e-10)
    np.testing.assert_allclose(mean, X.mean(axis=0), atol=1e-12)


def test_regression_recovers_a_planted_linear_relation(rng: np.random.Generator) -> None:
    available = np.ones(11, bool)
    available[10] = False
    end, before, first = _configs(rng, 60, available)
    C = n_context(available)
    ctx = end_context(end, before, first, available)
    assert ctx.shape == (60, C)
    W = rng.normal(scale=0.3, size=(C, 15))
    target = ctx @ W + 0.001 * rng.normal(size=(60, 15))
    end[:, 5:10] = target.reshape(60, 5, 3) + end[:, 0:1]
    reg = fit_end_regression(end, before, first, available, sigma_min=0.01)
    assert isinstance(reg, RidgeRegression)
    assert reg.ridge <= 1.0  # nearly noiseless: the LOO choice is a small penalty
    rel = np.linalg.norm(reg.predict(ctx) - target) / np.linalg.norm(target)
    assert rel < 0.03, rel  # the ridge shrinks a little; pure noise would give ≈ 1
    assert np.all(np.linalg.eigvalsh(reg.cov) >= 0.01**2 - 1e-12)


def test_regression_picks_a_large_penalty_for_pure_noise(rng: np.random.Generator) -> None:
    available = np.ones(11, bool)
    end, before, first = _configs(rng, 15, available)
    end[:, 5:10] = end[:, 0:1] + rng.normal(size=(15, 5, 3))  # target independent of the context
    reg = fit_end_regression(end, before, first, available, sigma_min=0.01)
    assert reg is not None and reg.ridge >= 100.0
    assert fit_end_regression(end[:2], before[:2], first[:2], available, sigma_min=0.01) is None


def test_log_density_matches_scipy(rng: np.random.Generator) -> None:
    A = rng.normal(size=(15, 15))
    cov = A @ A.T / 15 + 0.01 * np.eye(15)
    reg = RidgeRegression(np.zeros(3), np.ones(3), np.zeros(15), np.zeros((3, 15)), cov, 1.0)
    res = rng.normal(size=(7, 15))
    np.testing.assert_allclose(reg.log_density(res), stats.multivariate_normal(np.zeros(15), cov).logpdf(res), rtol=1e-10)


def test_prior_draws_follow_the_gaussian(shake8_model: SocialAffordanceModel, shake8: Dataset, rng: np.random.Generator) -> None:
    s = next(k for k, r in enumerate(shake8_model.end_regression_) if r is not None)
    track = shake8_model.canonical_track(shake8[7])
    prior = RegressionPrior.at(shake8_model.end_regression_[s], track[30], track[20], track[0], shake8_model.available_)
    draws = prior.draw(4000, rng)
    np.testing.assert_array_equal(draws[0], prior.mean)  # the mode is the first candidate
    np.testing.assert_allclose(draws.mean(axis=0), prior.mean, atol=5 * np.sqrt(np.diag(shake8_model.end_regression_[s].cov)).max() / np.sqrt(4000) + 1e-3)
    emp = np.cov(draws.reshape(4000, -1).T)
    np.testing.assert_allclose(emp, shake8_model.end_regression_[s].cov, atol=0.15 * np.abs(shake8_model.end_regression_[s].cov).max())


def test_model_fits_and_saves_the_regressions(shake8_model: SocialAffordanceModel, tmp_path) -> None:  # noqa: ANN001
    assert len(shake8_model.end_regression_) == len(shake8_model.frame_regression_) == shake8_model.n_subevents_
    assert any(r is not None for r in shake8_model.end_regression_)
    assert any(r is not None for r in shake8_model.frame_regression_)
    loaded = SocialAffordanceModel.load(shake8_model.save(tmp_path / "m.npz"))
    pairs = [*zip(shake8_model.end_regression_, loaded.end_regression_, strict=True),
             *zip(shake8_model.frame_regression_, loaded.frame_regression_, strict=True)]
    for a, b in pairs:
        assert (a is None) == (b is None)
        if a is not None:
            for name in ("context_mean", "context_scale", "target_mean", "coef", "cov", "ridge", "offset_columns", "offset_weight"):
                np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
            ctx = np.random.default_rng(0).normal(size=(3, a.context_mean.size))
            np.testing.assert_array_equal(a.predict(ctx), b.predict(ctx))


def _brute_observed(model: SocialAffordanceModel, x: np.ndarray, fps: float, bounds: np.ndarray) -> float:
    S = model.n_subevents_
    B = len(bounds) - 1
    cfg = model.config
    joints = observed_joints(model)
    best = -np.inf
    for pts, labels in labelled_partitions(B, S, distinct=cfg.distinct_neighbours, unique=cfg.unique_labels):
        score = model.log_start_probs_[labels[0]]
        score += sum(model.log_transitions_[a, b] for a, b in zip(labels, labels[1:]))
        for (p, q), s in zip(zip(pts, pts[1:]), labels):
            a, b = bounds[p], bounds[q]
            if b - a < cfg.min_subevent_seconds * fps:
                score = -np.inf
                break
            f = model.interval_features(x, np.array([a]), np.array([b]), fps)
            score += model.observed_log_score(f, s, joints)[0]
        best = max(best, score)
    return best


def test_observed_parse_matches_brute_force(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    inter = shake8[7]
    x = shake8_model.canonical_track(inter)[:24].copy()
    x[:, 5:10] = np.nan  # agent 1 is never read
    rows = parse_observed(shake8_model, x, inter.fps, step=6)
    xf = np.where(observed_joints(shake8_model)[None, :, None], x, 0.0)
    score = shake8_model.log_start_probs_[rows[0, 2]] + sum(shake8_model.log_transitions_[a, b] for a, b in zip(rows[:-1, 2], rows[1:, 2]))
    score += sum(
        shake8_model.observed_log_score(shake8_model.interval_features(xf, np.array([a]), np.array([b]), inter.fps), s, observed_joints(shake8_model))[0]
        for a, b, s in rows
    )
    brute = _brute_observed(shake8_model, xf, inter.fps, np.array([0, 6, 12, 18, 24]))
    assert np.isclose(score, brute, rtol=0, atol=1e-9)
    assert rows[0, 0] == 0 and rows[-1, 1] == 24 and np.all(rows[1:, 0] == rows[:-1, 1])
    with pytest.raises(ModelError, match="observed joints"):
        parse_observed(shake8_model, np.full_like(x, np.nan), inter.fps)


def test_offline_synthesis_reads_no_agent1_future_and_is_deterministic(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    cfg = SynthesisConfig.offline()
    inter = shake8[7]
    keys, _, subs, beliefs = synthesize(shake8_model, observed_part(inter, 10), rng=np.random.default_rng(2), config=cfg)
    assert np.all(subs[:10] == -1) and np.all(subs[10:] >= 0)  # the observed parse's sub-event is reported
    np.testing.assert_allclose(beliefs[10:].max(axis=1), 1.0, atol=0)
    again = synthesize(shake8_model, observed_part(inter, 10), rng=np.random.default_rng(2), config=cfg)[0]
    np.testing.assert_array_equal(keys, again)
    # Agent 1's recording after T0 is never read: changing it changes nothing.
    joints = inter.joints.copy()
    joints[10:, 1] += 0.7
    moved = synthesize(shake8_model, inter.replace(joints=joints), rng=np.random.default_rng(2), config=cfg)[0]
    np.testing.assert_array_equal(keys, moved)
    assert np.isfinite(keys).all()
    gt = inter.key_joints()[:, 1]
    hold = np.linalg.norm(gt[9][None] - gt[10:], axis=-1).mean()
    assert np.linalg.norm(keys[10:] - gt[10:], axis=-1).mean() < hold  # better than holding the last pose


def test_config_checks_and_methods() -> None:
    with pytest.raises(ConfigError, match="lookahead"):
        SynthesisConfig(parse="observed")
    with pytest.raises(ConfigError, match="'online' or 'observed'"):
        SynthesisConfig(parse="batch")
    with pytest.raises(ConfigError, match="'none' or 'regression'"):
        SynthesisConfig(end_prior="pose")
    with pytest.raises(ConfigError, match="frame_weight"):
        SynthesisConfig(frame_weight=1.5)
    assert SynthesisConfig.reactive().frame_weight == 0.5 and not SynthesisConfig.reactive().lookahead
    full = get_method("full")()  # causal protocols synthesize reactively, the offline one with lookahead
    assert full.synthesis == SynthesisConfig.reactive() and full.offline_synthesis == SynthesisConfig.offline()
    online = get_method("full_online")()
    assert online.name == "full_online" and online.synthesis == SynthesisConfig()


def test_interval_samples_pick_end_previous_and_reference_frames(rng: np.random.Generator) -> None:
    x1, x2 = rng.normal(size=(6, 11, 3)), rng.normal(size=(4, 11, 3))
    end, before, ref = interval_samples([x1, x2], [[(0, 2, 1), (2, 6, 0)], [(0, 4, 1)]], 1, reference=4)
    np.testing.assert_array_equal(end, np.stack([x1[1], x2[3]]))
    np.testing.assert_array_equal(before, np.stack([x1[0], x2[0]]))  # an interval at frame 0 starts from itself
    np.testing.assert_array_equal(ref, np.stack([x1[4], x2[3]]))  # x2 is shorter: its last frame
    end0, before0, _ = interval_samples([x1, x2], [[(0, 2, 1), (2, 6, 0)], [(0, 4, 1)]], 0, reference=4)
    np.testing.assert_array_equal(end0, x1[5:6])
    np.testing.assert_array_equal(before0, x1[1:2])
    assert interval_samples([x1], [[(0, 6, 0)]], 2, reference=4)[0].shape == (0, 11, 3)


def test_offset_columns_hold_agent_1_at_the_reference_frame(rng: np.random.Generator) -> None:
    for obj in (False, True):
        available = np.ones(11, bool)
        available[10] = obj
        end, before, ref = _configs(rng, 4, available)
        cols = offset_columns(available)
        np.testing.assert_allclose(
            end_context(end, before, ref, available)[:, cols], (ref[:, 5:10] - end[:, 0:1]).reshape(4, 15), atol=1e-12
        )
        fcols = frame_offset_columns(available)
        phase = np.array([0.1, 0.4, 0.7, 1.0])
        ctx = frame_context(end, ref, phase, available)
        np.testing.assert_allclose(ctx[:, fcols], (ref[:, 5:10] - end[:, 0:1]).reshape(4, 15), atol=1e-12)
        # The last 15 columns: the same pose scaled by the phase u, after u and u².
        np.testing.assert_allclose(ctx[:, -17:-15], np.stack([phase, phase**2], axis=1), atol=1e-12)
        np.testing.assert_allclose(ctx[:, -15:], phase[:, None] * ctx[:, fcols], atol=1e-12)


def test_the_offset_is_chosen_when_agent_1_stays_where_it_was_observed(rng: np.random.Generator) -> None:
    # Few noisy samples of "agent 1 ends where it was last observed": shrinking toward the
    # reference pose (α = 1) predicts better than shrinking toward the training mean.
    available = np.ones(11, bool)
    available[10] = False
    M = 8
    end, before, ref = _configs(rng, M, available)
    end[:, 5:10] = ref[:, 5:10] + 0.02 * rng.normal(size=(M, 5, 3))
    reg = fit_end_regression(end, before, ref, available, sigma_min=0.01)
    assert reg is not None and reg.offset_weight == 1.0
    new_end, new_before, new_ref = _configs(rng, 20, available)
    pred = reg.predict(end_context(new_end, new_before, new_ref, available)).reshape(20, 5, 3) + new_end[:, 0:1]
    err = np.linalg.norm(pred - new_ref[:, 5:10], axis=-1).mean()
    assert err < 0.25, err  # the pose moves by ≈ 1.6 m between samples; the training mean would be that far off
    # A target independent of the reference pose: α = 0.
    end[:, 5:10] = end[:, 0:1] + 1.0 + 0.02 * rng.normal(size=(M, 5, 3))
    reg0 = fit_end_regression(end, before, ref, available, sigma_min=0.01)
    assert reg0 is not None and reg0.offset_weight == 0.0


def _manual_held_out(X: np.ndarray, Y: np.ndarray, groups: np.ndarray, lam: float) -> float:
    """Held-out squared error summed over groups and coordinates, by an independent loop (augmented least squares)."""
    C = X.shape[1]
    sq = np.zeros(Y.shape[1])
    for g in np.unique(groups):
        tr, te = groups != g, groups == g
        mu, sd, ym = X[tr].mean(0), X[tr].std(0), Y[tr].mean(0)
        B = np.linalg.lstsq(np.vstack([(X[tr] - mu) / sd, np.sqrt(lam) * np.eye(C)]),
                            np.vstack([Y[tr] - ym, np.zeros((C, Y.shape[1]))]), rcond=None)[0]
        sq += (((X[te] - mu) / sd @ B + ym - Y[te]) ** 2).sum(axis=0)
    return float(sq.sum())


def test_held_out_error_chooses_the_offset_and_penalty_a_manual_loop_chooses(rng: np.random.Generator) -> None:
    X = rng.normal(size=(24, 5))
    Y = 0.8 * X[:, [3, 4]] + 0.4 * rng.normal(size=(24, 2))  # mostly the offset columns: α = 1 should win
    groups = np.repeat(np.arange(6), 4)
    grid = (0.1, 10.0, 1e3)
    cols = np.array([3, 4])
    reg = fit_ridge(X, Y, groups, sigma_min=0.01, grid=grid, offset_columns=cols)
    settings = [(a, lam) for a in (0.0, 1.0) for lam in grid]
    errs = [_manual_held_out(X, Y - a * X[:, cols], groups, lam) for a, lam in settings]
    print("held-out squared error by (α, λ):", dict(zip(settings, np.round(errs, 3).tolist())))
    alpha, lam = settings[int(np.argmin(errs))]
    assert (reg.offset_weight, reg.ridge) == (alpha, lam)
    assert alpha == 1.0
    # The prediction is the ridge of the shifted targets plus α times the offset columns.
    mu, sd, ym, coef = ridge_solve(X, Y - alpha * X[:, cols], lam)
    np.testing.assert_allclose(reg.predict(X[:3]), (X[:3] - mu) / sd @ coef + ym + alpha * X[:3, cols], atol=1e-10)


def test_group_held_out_error_picks_the_penalty_a_manual_loop_picks(rng: np.random.Generator) -> None:
    X = rng.normal(size=(30, 4))
    Y = X @ rng.normal(size=(4, 2)) + 0.5 * rng.normal(size=(30, 2))
    groups = np.repeat(np.arange(6), 5)
    grid = (0.01, 1.0, 100.0)
    reg = fit_ridge(X, Y, groups, sigma_min=0.01, grid=grid)
    errs = [_manual_held_out(X, Y, groups, lam) for lam in grid]
    assert reg.ridge == grid[int(np.argmin(errs))] and reg.offset_weight == 0.0


def test_frame_samples_and_a_planted_frame_relation(rng: np.random.Generator) -> None:
    x1, x2 = rng.normal(size=(6, 11, 3)), rng.normal(size=(5, 11, 3))
    frames, ref, phase, groups = frame_samples([x1, x2], [[(0, 2, 1), (2, 6, 0)], [(1, 5, 0)]], 0, reference=5)
    np.testing.assert_array_equal(frames, np.concatenate([x1[2:6], x2[1:5]]))
    np.testing.assert_array_equal(ref, np.concatenate([np.repeat(x1[5:6], 4, 0), np.repeat(x2[4:5], 4, 0)]))
    np.testing.assert_allclose(phase, [0.25, 0.5, 0.75, 1.0] * 2, atol=1e-12)
    np.testing.assert_array_equal(groups, [0] * 4 + [1] * 4)
    # Agent 1 a linear function of the frame context: recovered.
    available = np.ones(11, bool)
    M = 80
    frames = rng.normal(size=(M, 11, 3))
    first = rng.normal(size=(M, 11, 3))
    phase = rng.random(M)
    ctx = frame_context(frames, first, phase, available)
    assert ctx.shape == (M, n_frame_context(available))
    target = ctx @ rng.normal(scale=0.3, size=(ctx.shape[1], 15))
    frames[:, 5:10] = target.reshape(M, 5, 3) + frames[:, 0:1]
    reg = fit_frame_regression(frames, first, phase, np.arange(M) % 8, available, sigma_min=0.01)
    assert reg is not None
    rel = np.linalg.norm(reg.predict(ctx) - target) / np.linalg.norm(target)
    assert rel < 0.03, rel
    assert fit_frame_regression(frames, first, phase, np.arange(M) % 2, available, sigma_min=0.01) is None


def test_frame_regression_follows_an_approach_from_the_reference_pose(rng: np.random.Generator) -> None:
    # Agent 1 moves from its reference pose (relative to agent 0's base) to a fixed stance in front of
    # agent 0 as the phase u runs: (1 − u)·ref + u·stance, a product of u and the pose. With the
    # phase-scaled columns it is linear in the context and recovered; the fit is checked on fresh
    # instances against the closed form.
    available = np.ones(11, bool)
    available[10] = False
    stance = rng.normal(scale=0.3, size=15)

    def instances(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        m = 12
        frames = rng.normal(size=(n * m, 11, 3))
        frames[:, 10] = np.nan
        ref = np.repeat(rng.normal(size=(n, 11, 3)), m, axis=0)
        ref[:, 0] = frames[:, 0]  # agent 0's base does not move, so ref − anchor is the reference pose
        phase = np.tile((np.arange(m) + 1) / m, n)
        rel = (1 - phase[:, None]) * (ref[:, 5:10] - ref[:, 0:1]).reshape(-1, 15) + phase[:, None] * stance
        frames[:, 5:10] = rel.reshape(-1, 5, 3) + frames[:, 0:1]
        return frames, ref, phase, np.repeat(np.arange(n), m)

    frames, ref, phase, groups = instances(30)
    reg = fit_frame_regression(frames, ref, phase, groups, available, sigma_min=0.001)
    assert reg is not None
    test_frames, test_ref, test_phase, _ = instances(5)
    truth = (test_frames[:, 5:10] - test_frames[:, 0:1]).reshape(-1, 15)
    pred = reg.predict(frame_context(test_frames, test_ref, test_phase, available))
    np.testing.assert_allclose(pred, truth, atol=0.02)


def test_causal_frame_prediction_heads_for_the_pose_of_the_latest_frame(
    shake8_model: SocialAffordanceModel, shake8: Dataset
) -> None:
    # Without lookahead agent 0 and the phase are both read at t − 1: every frame of the block is the
    # same regression pose p approached from the last emitted pose, out_k = p + e^(−k/decay)·(prev − p).
    from socialaff_sim.inference.synthesis import OnlineSynthesizer

    cfg = SynthesisConfig.reactive()
    syn = OnlineSynthesizer(shake8_model, None, cfg)
    syn.reset(observed_part(shake8[7], 10), rng=np.random.default_rng(4))
    for _ in range(cfg.n_observed + 7):
        syn.step()
    t, start, last = syn.t, *syn._span  # noqa: SLF001 (the state under test)
    s = syn._sub  # noqa: SLF001
    reg = shake8_model.frame_regression_[s]
    assert reg is not None
    prev = syn._track[t - 1, 5:10]  # noqa: SLF001
    out = syn._frame_prediction(reg, t, t + 6, start, last, prev)  # noqa: SLF001
    fade = np.exp(-np.arange(1, 7) / cfg.frame_decay)[:, None, None]
    pose = (out - fade * prev[None]) / (1.0 - fade)
    np.testing.assert_allclose(pose, np.broadcast_to(pose[0], pose.shape), atol=1e-9)
    assert np.linalg.norm(pose[0] - prev, axis=-1).max() > 1e-3  # the regression does move the track


def test_frame_blend_keeps_the_track_continuous_and_causal(shake8_model: SocialAffordanceModel, shake8: Dataset) -> None:
    cfg = SynthesisConfig.reactive()
    inter = observed_part(shake8[7], 10)
    keys = synthesize(shake8_model, inter, rng=np.random.default_rng(4), config=cfg)[0]
    steps = np.linalg.norm(np.diff(keys, axis=0), axis=-1)
    assert steps[9:].max() < 0.25  # no jump at T0 or at a re-planning (the fading offset starts at the last pose)
    cut = 25
    joints = inter.joints.copy()
    joints[cut:, 0] += np.array([0.5, -0.3, 0.2])
    moved = synthesize(shake8_model, inter.replace(joints=joints), rng=np.random.default_rng(4), config=cfg)[0]
    np.testing.assert_array_equal(keys[: cut + 1], moved[: cut + 1])
    plain = synthesize(shake8_model, inter, rng=np.random.default_rng(4), config=SynthesisConfig())[0]
    assert not np.allclose(plain[10:], keys[10:])  # the frame regression does take part


def test_a_type_no_parse_uses_has_no_end_regression(rng: np.random.Generator) -> None:
    """A sub-event type without intervals (a parse that leaves a label unused, e.g. with no type restructuring):
    its samples are empty, their context has the usual width, and its regression is None (it used to raise in
    the reshape); with three intervals there is one."""
    tracks = [rng.normal(size=(30, 11, 3)) for _ in range(3)]
    spans = [[(0, 15, 0), (15, 30, 1)] for _ in tracks]
    available = np.ones(11, bool)
    end, before, ref = interval_samples(tracks, spans, 2, reference=9)
    assert end.shape == (0, 11, 3)
    assert end_context(end, before, ref, available).shape == (0, n_context(available))
    assert fit_end_regression(end, before, ref, available, sigma_min=0.01) is None
    used = interval_samples(tracks, spans, 1, reference=9)
    assert end_context(*used, available).shape == (3, n_context(available))
    assert fit_end_regression(*used, available, sigma_min=0.01) is not None
