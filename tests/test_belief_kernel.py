"""The forward belief's compiled cuts and posterior (``kernel="numba"``, :mod:`socialaff_sim.inference.belief_kernel`)
against the NumPy cut they replace (:class:`~socialaff_sim.inference.forward_belief.ForwardBelief` with
``kernel="numpy"``), within the tolerance declared in docs/design.md §7 (session 27): 1e-12 relative. Checked at every
frame of streams longer than several horizons (the long bucket), labels unique or not, a type without a duration (−inf
rows), intervals too short (−inf), every row −inf at once (the uniform fallback), a one-type model, resets at later
origins, cuts done several at a time in one call (NuiSI's first call), an absent joint NaN throughout, and the closed
intervals' scores of a cut against ``ForwardBelief._closing`` directly. Skipped without numba; the error without it is
tested by monkeypatching."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from socialaff_sim.errors import ConfigError, ModelError
from socialaff_sim.inference import belief_kernel, belief_scores, compiled
from conftest import belief_track, model_with
from socialaff_sim.inference.forward_belief import ForwardBelief
from socialaff_sim.inference.row_density import RowSet
from socialaff_sim.inference.track_window import TrackWindow

needs_numba = pytest.mark.skipif(not compiled.available(), reason="numba (the [fast] extra) is not installed")
REL = 1e-12



def _one_type(base):  # noqa: ANN001, ANN202
    """The model restricted to its first sub-event type (S = 1)."""
    m = copy.copy(base)
    m.n_subevents_ = 1
    for name in ("grouping_", "spatial_params_", "motion_params_", "duration_params_", "path_sigma_"):
        setattr(m, name, np.array(getattr(base, name))[:1])
    m.transitions_ = np.ones((1, 1))
    m.start_probs_ = np.ones(1)
    return m


def _close(a: np.ndarray, b: np.ndarray, what: str) -> None:
    """Equal where either is not finite (−inf, NaN at the same places), else within REL of max(1, |a|)."""
    assert a.shape == b.shape, what
    fa, fb = np.isfinite(a), np.isfinite(b)
    assert np.array_equal(fa, fb), what
    assert np.array_equal(a[~fa], b[~fb], equal_nan=True), what
    if fa.any():
        err = np.abs(a[fa] - b[fa]) / np.maximum(1.0, np.abs(a[fa]))
        assert err.max() <= REL, (what, float(err.max()))


def _close_sums(a: np.ndarray, b: np.ndarray, what: str) -> None:
    """The path sums' packed rows: anchors equal, sums within REL, except the coordinates of a NaN anchor. There NumPy's
    sums may already hold the NaN that its anchor frame adds (a zero, or NaN) when it is summed alongside older rows;
    the kernel starts after the anchor; the residual of such a coordinate is NaN either way (its D is NaN)."""
    J3 = a.shape[1] // 5  # x_a, Σ y², and Σ k^p y for the three powers of the minimum-jerk profile
    assert a.shape == b.shape, what
    _close(a[:, :J3], b[:, :J3], what)
    ok = np.tile(np.isfinite(a[:, :J3]), (1, 4))
    _close(a[:, J3:][ok], b[:, J3:][ok], what)


def _both(model, rng: np.random.Generator, T: int, stride: int, horizon: int, *, resets: tuple[int, ...] = (),  # noqa: ANN001
          jumps: int = 1, fps: float = 30.0) -> dict[str, bool]:
    """Drive the NumPy and the compiled belief over one track, reading every ``jumps`` frames (so that several cuts are
    due at once); compare their state and posterior at each read. Returns which edge cases were met."""
    track = belief_track(rng, T)
    ref = ForwardBelief(model, fps, stride=stride, horizon=horizon)
    new = ForwardBelief(model, fps, stride=stride, horizon=horizon, kernel="numba")
    assert new._compiled is not None  # the compiled path is the one under test
    seen = {"long": False, "none": False, "batch": False}
    for t in range(1, T, jumps):
        if t in resets:
            ref.reset(t - 3)
            new.reset(t - 3)
        before = new.cuts
        ref.advance(track, t)
        new.advance(track, t)
        seen["batch"] |= new.cuts - before > 1
        assert new.cuts == ref.cuts and new._next == ref._next
        assert np.array_equal(new._starts, ref._starts) and new._has_long == ref._has_long
        for got, want, what in ((new._F, ref._F, "F"), (new._long, ref._long, "long"), (new._G, ref._G, "G"),
                                (new._G_long, ref._G_long, "G_long")):
            _close(got, want, f"{what} at {t}")
        _close_sums(new._sums._rows, ref._sums._rows, f"sums at {t}")
        assert np.array_equal(new._sums._a, ref._sums._a) and np.array_equal(new._sums._upto, ref._sums._upto)
        (s_new, p_new), (s_ref, p_ref) = new.posterior(t), ref.posterior(t)
        assert np.array_equal(s_new, s_ref), t
        assert p_new.shape == p_ref.shape and np.abs(p_new - p_ref).max() <= REL, t  # probabilities: relative to 1
        assert np.abs(new.belief(t) - ref.belief(t)).max() <= REL
        seen["long"] |= ref._has_long
        seen["none"] |= not np.isfinite(ref._F).any()
    return seen


@needs_numba
@pytest.mark.parametrize("unique", [True, False])
@pytest.mark.parametrize(("stride", "horizon", "jumps"), [(6, 60, 1), (1, 9, 1), (4, 30, 1), (2, 40, 11)])
def test_compiled_cuts_are_the_numpy_cuts(shake8_model, rng: np.random.Generator, unique: bool, stride: int,  # noqa: ANN001
                                          horizon: int, jumps: int) -> None:
    seen = _both(model_with(shake8_model, unique_labels=unique), rng, 260, stride, horizon, resets=(150,), jumps=jumps)
    assert seen["long"]
    if jumps > stride:
        assert seen["batch"]  # several cuts in one compiled call


@needs_numba
def test_random_models(shake8_model, rng: np.random.Generator) -> None:  # noqa: ANN001
    """Parameters scaled at random (shapes, scales, concentrations, durations, path noise, transitions)."""
    for _ in range(3):
        m = copy.copy(shake8_model)
        m.spatial_params_ = m.spatial_params_ * rng.uniform(0.7, 1.4, size=m.spatial_params_.shape)
        m.motion_params_ = m.motion_params_ * rng.uniform(0.7, 1.4, size=m.motion_params_.shape)
        m.duration_params_ = m.duration_params_ + rng.normal(scale=0.2, size=m.duration_params_.shape)
        m.path_sigma_ = m.path_sigma_ * rng.uniform(0.5, 2.0, size=m.path_sigma_.shape)
        tr = m.transitions_ * rng.uniform(0.5, 1.5, size=m.transitions_.shape)
        m.transitions_ = tr / tr.sum(axis=1, keepdims=True)
        assert _both(m, rng, 200, 3, 45)["long"]


@needs_numba
def test_short_intervals_and_a_type_without_duration(shake8_model, rng: np.random.Generator) -> None:  # noqa: ANN001
    model = model_with(shake8_model, min_subevent_seconds=0.5)
    model.duration_params_ = np.array(model.duration_params_, float)
    model.duration_params_[1] = np.nan  # that type's intervals: −inf
    assert _both(model, rng, 200, 3, 36)["long"]


@needs_numba
def test_nothing_possible_gives_the_uniform_fallback(shake8_model, rng: np.random.Generator) -> None:  # noqa: ANN001
    model = model_with(shake8_model, min_subevent_seconds=5.0)
    assert _both(model, rng, 120, 6, 30)["none"]


@needs_numba
@pytest.mark.parametrize("unique", [True, False])
def test_one_type(shake8_model, rng: np.random.Generator, unique: bool) -> None:  # noqa: ANN001
    model = _one_type(model_with(shake8_model, unique_labels=unique))
    assert _both(model, rng, 150, 5, 25, jumps=3)["long"]


@needs_numba
@pytest.mark.parametrize("kind", ["weibull", "exponential", "mixed"])
def test_polar_row_is_the_row_densities(rng: np.random.Generator, kind: str) -> None:
    """One row's compiled density against :meth:`RowSet.logpdf` (the NumPy code the belief's cut reads) on random
    vectors and the edge cases: x = y = 0 (also −0.0: the cosine by atan2, as NumPy), below ε, NaN, ±inf, huge and
    tiny, k = 1 rows (the convention's branch), κ = 0."""
    belief_kernel.load()
    R, eps = 12, 1e-6
    params = np.column_stack([rng.uniform(0.5, 3.0, R), rng.uniform(0.05, 1.0, R), rng.uniform(0.5, 3.0, R),
                              rng.uniform(0.05, 1.0, R), rng.uniform(-np.pi, np.pi, R), rng.uniform(0.0, 20.0, R)])
    params[0, 0] = params[1, 2] = 1.0  # k = 1
    params[2, 5] = 0.0  # κ = 0
    expon = {"weibull": np.zeros(R, bool), "exponential": np.ones(R, bool), "mixed": rng.random(R) < 0.5}[kind]
    vecs = rng.normal(scale=0.3, size=(40, R, 3))
    vecs[1] = 0.0
    vecs[2, :, 0], vecs[2, :, 1] = -0.0, 0.0
    vecs[3] *= 1e-9  # below ε
    vecs[4, ::3, 0] = np.nan
    vecs[5, ::2, 1] = np.inf
    vecs[6, 1::2, 2] = -np.inf
    vecs[7] *= 1e6
    vecs[8, :, 1] = 0.0  # on the x axis (θ = 0 or π)
    ref = RowSet(params, expon, eps).logpdf(vecs)
    f, g = belief_scores.row_terms(params, expon)
    got = np.array([[belief_scores._polar_row(*vecs[i, r], f, g, r, eps) for r in range(R)] for i in range(vecs.shape[0])])
    _close(got, ref, kind)
    assert np.isnan(ref).any() and np.isfinite(ref).sum() > 300  # the edge cases were met, most rows are finite


@needs_numba
def test_closed_interval_scores_are_closing(shake8_model, rng: np.random.Generator) -> None:  # noqa: ANN001
    """Each cut's (K, S) closed-interval scores (the long bucket's row included) against ``_closing``."""
    model = model_with(shake8_model, min_subevent_seconds=0.3)
    track = belief_track(rng, 200)
    ref = ForwardBelief(model, 30.0, stride=4, horizon=40)
    new = ForwardBelief(model, 30.0, stride=4, horizon=40, kernel="numba")
    c = new._compiled
    checked = 0
    for t in range(1, 200):
        b = ref._next
        if b <= t - 1 and b != ref.origin:
            starts = np.concatenate((ref._starts, (b - ref.horizon,))) if ref._has_long else ref._starts
            sums = new._sums
            seg, code, _ = belief_scores.closed_scores(track, 0, b, new._starts, new._starts.size, new._has_long, new.horizon,
                                              sums._a, sums._upto.copy(), sums._rows.copy(), *c[:10], *c[13:18],
                                              *c[20:23], c[24], new.S)
            assert code == belief_scores.NO_ERROR
            _close(seg, ref._closing(track, starts, b), f"seg at {b}")
            checked += ref._has_long
        ref.advance(track, t)
        new.advance(track, t)
    assert checked > 10


@needs_numba
def test_a_window_below_its_floor_is_an_error(shake8_model, rng: np.random.Generator) -> None:  # noqa: ANN001
    """Read from a TrackWindow whose floor passed a frame the cut reads: a ModelError naming the frame, the cuts before
    it applied, as the NumPy path's window raises."""
    track = belief_track(rng, 120)
    w = TrackWindow.of(track)
    fb = ForwardBelief(shake8_model, 30.0, stride=6, horizon=30, kernel="numba")
    fb.advance(w, 60)
    w.forget(70)
    with pytest.raises(ModelError, match="frame .* is read"):
        fb.advance(w, 100)
    ref = ForwardBelief(shake8_model, 30.0, stride=6, horizon=30)
    ref.advance(track, 60)
    assert fb.cuts == ref.cuts  # nothing past the failing cut was applied


def test_numba_kernel_without_numba_is_a_config_error(shake8_model, monkeypatch: pytest.MonkeyPatch) -> None:  # noqa: ANN001
    monkeypatch.setattr(compiled, "available", lambda: False)
    monkeypatch.setattr(compiled, "_ONCE", {})  # as in a new process: nothing compiled yet
    with pytest.raises(ConfigError, match=r"socialaff-sim\[fast\]"):
        ForwardBelief(shake8_model, 30.0, stride=6, horizon=30, kernel="numba")
    with pytest.raises(ConfigError, match="kernel: expected"):
        ForwardBelief(shake8_model, 30.0, stride=6, horizon=30, kernel="cython")
    ForwardBelief(shake8_model, 30.0, stride=6, horizon=30)  # NumPy's path needs nothing
