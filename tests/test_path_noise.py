"""Path noise (socialaff_sim.model.path): residuals against a frame-by-frame loop, the fit against
scipy.stats.norm, and its place in the learning objective and the model."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from socialaff_sim.errors import ConfigError
from socialaff_sim.model.config import AffordanceConfig
from socialaff_sim.model.features import interval_features, type_samples
from socialaff_sim.model.path import fit_path_noise, path_loglik, path_residuals, profile


def _brute(x: np.ndarray, f0: int, f1: int, kind: str) -> tuple[np.ndarray, int]:
    a, e = max(f0 - 1, 0), f1 - 1
    out = np.zeros(x.shape[1])
    n = 0
    for t in range(a + 1, e):
        u = float(profile(np.array((t - a) / (e - a)), kind))
        r = x[t] - (x[a] + u * (x[e] - x[a]))
        out += (r * r).sum(axis=-1)
        n += 1
    return out, n


@pytest.mark.parametrize("kind", ["minjerk", "linear"])
def test_residuals_match_a_frame_loop(rng: np.random.Generator, kind: str) -> None:
    x = rng.normal(size=(40, 5, 3))
    starts = np.array([0, 0, 0, 3, 5, 10, 38, 12])
    stops = np.array([1, 2, 40, 9, 6, 40, 40, 31])
    sq, n = path_residuals(x, starts, stops, kind)
    for m in range(starts.size):
        ref, cnt = _brute(x, int(starts[m]), int(stops[m]), kind)
        assert n[m] == cnt
        np.testing.assert_allclose(sq[m], ref, rtol=1e-10, atol=1e-12)


def test_residuals_chunked_equal_unchunked(rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch) -> None:
    import socialaff_sim.model.path as path_mod

    x = rng.normal(size=(60, 3, 3))
    a, b = np.triu_indices(61, k=1)
    full, n = path_residuals(x, a, b)
    monkeypatch.setattr(path_mod, "_CHUNK", 100)
    chunked, n2 = path_residuals(x, a, b)
    np.testing.assert_allclose(chunked, full, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(n, n2)


def test_minjerk_profile_is_exact_on_minimum_jerk_motion() -> None:
    # A joint moving rest-to-rest on a minimum-jerk profile leaves no residual with "minjerk", some with "linear".
    T = 21
    v = np.arange(T) / (T - 1)
    x = np.zeros((T, 1, 3))
    x[:, 0, 0] = 0.8 * profile(v, "minjerk")
    sq_mj, _ = path_residuals(x, np.array([0]), np.array([T]), "minjerk")
    sq_lin, _ = path_residuals(x, np.array([0]), np.array([T]), "linear")
    assert sq_mj[0, 0] == pytest.approx(0.0, abs=1e-20)
    assert sq_lin[0, 0] > 0.01


def test_fit_is_the_gaussian_maximum_likelihood(rng: np.random.Generator) -> None:
    x = rng.normal(scale=0.05, size=(50, 4, 3))
    starts, stops = np.array([0, 10, 30]), np.array([10, 30, 50])
    sq, n = path_residuals(x, starts, stops, "linear")
    sigma, ll = fit_path_noise(sq, n, sigma_min=1e-6)
    # Closed form: σ² = Σ r² / (3 Σ n); the log-likelihood is the sum of normal log-densities of every coordinate.
    resid = []
    for f0, f1 in zip(starts, stops, strict=True):
        a, e = max(f0 - 1, 0), f1 - 1
        u = (np.arange(a + 1, e) - a) / (e - a)
        resid.append(x[a + 1 : e] - (x[a] + u[:, None, None] * (x[e] - x[a])))
    r = np.concatenate(resid)  # (Σn, J, 3)
    np.testing.assert_allclose(sigma, np.sqrt((r**2).sum(axis=(0, 2)) / (3 * r.shape[0])), rtol=1e-10)
    ref = stats.norm.logpdf(r, scale=sigma[None, :, None]).sum(axis=(0, 2))
    np.testing.assert_allclose(ll, ref, rtol=1e-10)
    # σ maximizes it: any other σ scores lower.
    for f in (0.8, 1.25):
        assert path_loglik(sq, n, sigma * f).sum(axis=0).max() < ll.max()


def test_fit_floors_sigma_and_skips_nan_joints() -> None:
    sq = np.array([[0.0, np.nan], [0.0, np.nan]])
    sigma, ll = fit_path_noise(sq, np.array([3, 4]), sigma_min=0.01)
    assert sigma[0] == pytest.approx(0.01, rel=1e-12)
    assert np.isnan(sigma[1]) and ll[1] == 0.0
    ref = stats.norm.logpdf(np.zeros(21), scale=0.01).sum()
    assert ll[0] == pytest.approx(ref, rel=1e-12)
    masked, ll_masked = fit_path_noise(np.array([[0.3, 0.2]]), np.array([5]), sigma_min=0.01, available=np.array([False, True]))
    assert np.isnan(masked[0]) and ll_masked[0] == 0.0
    assert masked[1] == pytest.approx(np.sqrt(0.2 / 15), rel=1e-12)


def test_features_carry_path_residuals_only_when_asked(rng: np.random.Generator) -> None:
    x = rng.normal(size=(20, 11, 3))
    f = interval_features(x, np.array([0, 5]), np.array([5, 20]), fps=10.0)
    assert f.path_sq is None and f.path_n is None
    f = interval_features(x, np.array([0, 5]), np.array([5, 20]), fps=10.0, path_profile="minjerk")
    sq, n = path_residuals(x, np.array([0, 5]), np.array([5, 20]), "minjerk")
    np.testing.assert_allclose(f.path_sq, sq, rtol=1e-12)
    np.testing.assert_array_equal(f.path_n, n)
    spans = [[(0, 5, 0), (5, 20, 1)], [(0, 12, 1), (12, 20, 0)]]
    tracks = [x, x[::-1].copy()]
    s0 = type_samples(tracks, [10.0, 10.0], spans, 0, "minjerk")
    assert s0.path_sq is not None and s0.path_sq.shape == (2, 11)
    np.testing.assert_allclose(s0.path_sq[1], path_residuals(tracks[1], np.array([12]), np.array([20]))[0][0], rtol=1e-12)


def test_config_validates_profile() -> None:
    with pytest.raises(ConfigError, match="path_profile.*'linear'"):
        AffordanceConfig(path_profile="cubic")
    with pytest.raises(ConfigError, match="path_sigma_min"):
        AffordanceConfig(path_sigma_min=0.0)


def test_model_scores_path_and_round_trips(tmp_path, shake_hands_fit_small) -> None:  # noqa: ANN001
    model, train = shake_hands_fit_small
    assert model.config.path_noise
    assert np.isfinite(model.path_sigma_[:, model.available_]).all()
    assert np.all(model.path_sigma_[:, model.available_] >= model.config.path_sigma_min)
    inter = train[0]
    track = model.canonical_track(inter)
    feats = model.interval_features(track, np.array([0, 4]), np.array([9, 20]), inter.fps)
    ref = path_loglik(feats.path_sq, feats.path_n, model.path_sigma_[1]).sum(axis=1)
    np.testing.assert_allclose(model.log_path(1, feats), ref, rtol=1e-12)
    paper = model.with_config(path_noise=False).fit(train, rng=np.random.default_rng(3))
    assert np.isnan(paper.path_sigma_).all()
    np.testing.assert_array_equal(paper.log_path(1, paper.interval_features(track, np.array([0]), np.array([9]), inter.fps)), [0.0])
    back = type(model).load(model.save(tmp_path / "m.npz"))
    np.testing.assert_array_equal(back.path_sigma_, model.path_sigma_)
    np.testing.assert_allclose(back.interval_log_score(feats, 1), model.interval_log_score(feats, 1), rtol=1e-12)


@pytest.fixture(scope="module")
def shake_hands_fit_small():  # noqa: ANN201
    from socialaff_sim.data.synthetic import generate_dataset
    from socialaff_sim.learning.config import LearningConfig
    from socialaff_sim.learning import SocialAffordanceModel

    inters = list(generate_dataset(seed=3).of_label("shake_hands"))[:6]
    cfg = AffordanceConfig(path_noise=True)
    model = SocialAffordanceModel(cfg, LearningConfig(iterations=3)).fit(inters, rng=np.random.default_rng(3))
    return model, inters
