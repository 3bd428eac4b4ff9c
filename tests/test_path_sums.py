"""The forward belief's path terms from running sums (socialaff_sim.inference.path_sums) against the brute-force
``path_residuals``, and the belief they give against the belief of ``path_residuals``, within the tolerance declared
in docs/design.md §7 (not bitwise: a difference of sums, not a sum of squares)."""

from __future__ import annotations

import numpy as np
import pytest

import socialaff_sim.model.features as features_mod
from socialaff_sim.data.dataset import Dataset
from socialaff_sim.errors import ConfigError, ModelError
from socialaff_sim.inference.forward_belief import ForwardBelief
from socialaff_sim.inference.path_sums import PathSums
from socialaff_sim.learning import SocialAffordanceModel
from socialaff_sim.model.joints import canonical_joints, instance_frame
from socialaff_sim.model.path import PROFILE_POLYNOMIALS, path_residuals, profile

REL = 1e-10  # docs/design.md §7, (i): of the scale Σ‖y_k‖² + n‖D‖²


def _scale(x: np.ndarray, starts: np.ndarray, stop: int) -> np.ndarray:
    """(K, J) Σ_k ‖x_{a+k} − x_a‖² + n ‖x_e − x_a‖², the magnitudes the closed form subtracts."""
    e = stop - 1
    out = np.zeros((starts.size, x.shape[1]))
    for i, s in enumerate(starts):
        a = max(int(s) - 1, 0)
        y = x[a + 1 : e] - x[a]
        out[i] = np.nansum(y * y, axis=(0, 2)) + max(e - a - 1, 0) * np.nansum((x[e] - x[a]) ** 2, axis=-1)
    return out


def _check(ps: PathSums, x: np.ndarray, stop: int, kind: str) -> None:
    sq, n = ps.residuals(x, stop)
    ref, n_ref = path_residuals(x, ps.starts, np.full(len(ps), stop), kind)
    np.testing.assert_array_equal(n, n_ref)
    np.testing.assert_array_equal(np.isnan(sq), np.isnan(ref))
    ok = ~np.isnan(ref)
    assert np.all(np.abs(sq - ref)[ok] <= REL * _scale(x, ps.starts, stop)[ok] + 1e-300)


def test_profile_polynomials_are_the_profiles(rng: np.random.Generator) -> None:
    v = rng.random(50)
    for kind, terms in PROFILE_POLYNOMIALS.items():
        np.testing.assert_allclose(sum(c * v**p for p, c in terms), profile(v, kind), rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("kind", ["minjerk", "linear"])
def test_running_sums_equal_path_residuals_as_the_belief_uses_them(rng: np.random.Generator, kind: str) -> None:
    """Rows added at every cut, the end moving on by a stride, old rows dropped: every cut's residuals of every
    kept start within the declared tolerance of ``path_residuals`` (a random walk of metres, a NaN joint inside
    some intervals only, a start at 0 whose anchor is its own first frame)."""
    T, J, stride, horizon = 300, 11, 5, 60
    x = np.cumsum(rng.normal(scale=0.03, size=(T, J, 3)), axis=0) + rng.normal(size=(1, J, 3))
    x[97, 4, 2] = np.nan
    ps = PathSums(kind, J)
    for b in range(0, T, stride):
        if len(ps):
            _check(ps, x, b, kind)
        ps.add(x, b)
        ps.keep(ps.starts > b - horizon)
    assert len(ps) == horizon // stride


@pytest.mark.parametrize("kind", ["minjerk", "linear"])
def test_running_sums_every_start_and_end(rng: np.random.Generator, kind: str) -> None:
    """Every (start, stop) of a short track, stop growing one frame at a time (no interior frame, one, many)."""
    T, J = 40, 3
    x = rng.normal(size=(T, J, 3))
    for start in range(T - 1):
        ps = PathSums(kind, J)
        ps.add(x, start)
        for stop in range(start + 1, T + 1):
            _check(ps, x, stop, kind)


def test_exact_on_a_straight_minimum_jerk_movement() -> None:
    """No residual where the path is exact: the closed form's difference of sums is ≥ 0 (clipped) and within the
    declared tolerance of 0 (``path_residuals`` gives 0 to rounding)."""
    T = 31
    v = np.arange(T) / (T - 1)
    x = np.zeros((T, 1, 3))
    x[:, 0] = 0.8 * profile(v, "minjerk")[:, None] * np.array([1.0, -0.5, 0.25])
    ps = PathSums("minjerk", 1)
    ps.add(x, 0)
    sq, n = ps.residuals(x, T)
    assert n[0] == T - 2 and 0.0 <= sq[0, 0] <= REL * _scale(x, np.array([0]), T)[0, 0]
    assert _scale(x, np.array([0]), T)[0, 0] > 1.0


def test_errors() -> None:
    with pytest.raises(ConfigError, match="path_profile"):
        PathSums("cubic", 11)
    x = np.zeros((30, 2, 3))
    ps = PathSums("linear", 2)
    ps.add(x, 3)
    ps.residuals(x, 20)
    with pytest.raises(ModelError, match="stop went back"):
        ps.residuals(x, 12)


def _track(inter) -> np.ndarray:  # noqa: ANN001
    return canonical_joints(inter, instance_frame(inter))


def _posteriors(fb: ForwardBelief, track: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    out = []
    for t in range(1, track.shape[0]):
        fb.advance(track, t)
        out.append(fb.posterior(t))
    return out


def test_belief_from_running_sums_equals_the_brute_force_path(
    shake8: Dataset, shake8_model: SocialAffordanceModel, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A stream past the horizon (the long bucket in use, starts dropped): at every frame the posterior within 1e-9
    and its logarithm within 1e-8 nats (where P ≥ 1e-12) of the belief computed with ``path_residuals``; and the
    belief does take the running sums (``path_residuals`` is not called by its cuts)."""
    assert shake8_model.config.path_noise
    track = np.concatenate([_track(i) for i in list(shake8)[6:]] * 3)
    fps = list(shake8)[0].fps
    old = ForwardBelief(shake8_model, fps, stride=2, horizon=20)
    old._sums = None  # the path of main: model.interval_features → path_residuals at every cut
    ref = _posteriors(old, track)

    def refuse(*a: object, **k: object) -> None:
        raise AssertionError("path_residuals called")

    monkeypatch.setattr(features_mod, "path_residuals", refuse)
    fb = ForwardBelief(shake8_model, fps, stride=2, horizon=20)
    got = _posteriors(fb, track)
    assert track.shape[0] > 5 * fb.horizon and np.isfinite(fb._long).any()
    worst = 0.0
    for (s_a, p_a), (s_b, p_b) in zip(got, ref, strict=True):
        np.testing.assert_array_equal(s_a, s_b)
        assert np.max(np.abs(p_a - p_b)) <= 1e-9
        m = p_b >= 1e-12
        worst = max(worst, float(np.max(np.abs(np.log(p_a[m]) - np.log(p_b[m])))))
    assert worst <= 1e-8
    # The path terms matter here: without them the belief differs by far more than the tolerance.
    nopath = ForwardBelief(shake8_model, fps, stride=2, horizon=20)
    nopath._sums = None
    monkeypatch.setattr(features_mod, "path_residuals", lambda x, s, e, k: (np.zeros((len(s), x.shape[1])), np.zeros(len(s), np.int64)))
    far = _posteriors(nopath, track)
    assert max(float(np.max(np.abs(a[1] - b[1]))) for a, b in zip(far, ref, strict=True)) > 1e-3


def test_long_bucket_start_outside_the_rows_falls_back_to_the_frames(shake8: Dataset, shake8_model: SocialAffordanceModel) -> None:
    """The long bucket's start is the oldest kept row's; were it not (none kept), its path terms come from the frames."""
    track = _track(list(shake8)[6])
    fps = list(shake8)[0].fps
    fb = ForwardBelief(shake8_model, fps, stride=2, horizon=20)
    fb.advance(track, 41)
    b = 42
    starts = np.append(fb._starts, 3)  # a start no row holds
    feats = fb._features(track, starts, b)
    ref = shake8_model.interval_features(track, starts, np.full(starts.size, b), fps)
    np.testing.assert_array_equal(feats.path_n, ref.path_n)
    np.testing.assert_allclose(feats.path_sq, ref.path_sq, rtol=1e-9, atol=1e-12)
    np.testing.assert_array_equal(feats.path_sq[-1], ref.path_sq[-1])  # from path_residuals itself: bitwise
    np.testing.assert_array_equal(feats.end, ref.end)
    np.testing.assert_array_equal(feats.disp, ref.disp)
    np.testing.assert_array_equal(feats.seconds, ref.seconds)


def test_closing_scores_every_type_at_once_equal_the_models_path_terms(shake8: Dataset, shake8_model: SocialAffordanceModel) -> None:
    """The cut's closed-interval scores (path terms of every type at once) against the model's own scoring of the
    same intervals, type by type (``interval_log_score``, path_residuals inside)."""
    m = shake8_model
    track = _track(list(shake8)[6])
    fps = list(shake8)[0].fps
    fb = ForwardBelief(m, fps, stride=2, horizon=20)
    fb.advance(track, 31)
    b = 32
    starts = fb._starts.copy()
    got = fb._closing(track, starts, b)
    feats = m.interval_features(track, starts, np.full(starts.size, b), fps)
    ref = np.column_stack([m.interval_log_score(feats, s) for s in range(m.n_subevents_)])
    ref[(b - starts) < m.config.min_subevent_seconds * fps] = -np.inf
    assert np.isfinite(ref).sum() > starts.size  # scores to compare, not only −inf
    np.testing.assert_array_equal(np.isneginf(got), np.isneginf(ref))
    fin = np.isfinite(ref)
    np.testing.assert_allclose(got[fin], ref[fin], rtol=1e-10, atol=1e-8)
    assert np.ptp(np.column_stack([m.log_path(s, feats) for s in range(m.n_subevents_)])) > 1.0  # the path terms weigh
