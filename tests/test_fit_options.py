"""Issue 24's cheaper-fit options (model changes, off by default): the switching regression's training rows every
k-th frame (``SwitchingConfig.row_stride``) and the restructuring's candidates screened without a hard-EM round
(``LearningConfig.init_type_screen_rounds``). Each decision is checked both ways: the option's value changes what is
computed, the default leaves it as before."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy import stats

from socialaff_sim.data import Interaction, load_dataset
from socialaff_sim.errors import ConfigError, ModelError
from socialaff_sim.inference.body_fit import BodyFitter
from socialaff_sim.inference.interaction_primitive import InteractionPrimitive
from socialaff_sim.inference import methods as methods_module
from socialaff_sim.inference.methods import AffordanceMethod, primitive_trace, trace
from socialaff_sim.inference.primitive_stream import stream_key_joints
from socialaff_sim.inference.reaction_features import FeatureConfig
from socialaff_sim.inference.switching import SwitchingConfig, SwitchingRegression
from socialaff_sim.inference.switching_rows import Trace, instance_rows
from socialaff_sim.learning import algorithm
from socialaff_sim.learning.config import LearningConfig
from socialaff_sim.learning.estimator import SocialAffordanceModel
from socialaff_sim.learning.parse import Parse, ParseSpace
from socialaff_sim.learning.restructure import restructure
from socialaff_sim.model.densities import expon_logpdf, vonmises_logpdf, weibull_logpdf
from socialaff_sim.model.potentials import polar_rows_logpdf

from test_fit_speed import _instance

T0 = 10


def _trace(inst: Interaction, rng: np.random.Generator, S: int = 3) -> Trace:
    """A trace with random beliefs, phases and plans (what the regression reads; no model needed)."""
    T = inst.n_frames
    belief = rng.dirichlet(np.ones(S), size=T)
    plan = inst.filled_joints()[:, 1][:, :5] + rng.normal(0, 0.02, size=(T, 5, 3))
    return Trace(belief=belief, phase=rng.uniform(0, 1, T), plan=plan,
                 skeleton=inst.filled_joints()[:, 1] + rng.normal(0, 0.02, size=(T, inst.joints.shape[2], 3)))


def test_row_stride_config_is_checked_and_two_by_default() -> None:
    # 2 since session 22 (its development-split rule held, docs/design.md §8); 1 keeps every frame's row.
    assert SwitchingConfig().row_stride == 2
    for bad in (0, -2, 1.5, True):
        with pytest.raises(ConfigError, match="row_stride"):
            SwitchingConfig(row_stride=bad)  # type: ignore[arg-type]


def test_instance_rows_with_a_stride_are_every_kth_row(rng: np.random.Generator) -> None:
    """stride k: the rows (and targets and priors) of frames T0, T0 + k, …, each the same as without the stride;
    k = 1 is every frame from T0."""
    inst = _instance(rng, 1, gaps=True, obj=False)
    tr = _trace(inst, rng)
    full = instance_rows(inst, tr, T0, FeatureConfig())
    assert len(full[0]) == inst.n_frames - T0
    for k in (2, 3):
        sub = instance_rows(inst, tr, T0, FeatureConfig(), stride=k)
        assert len(sub[0]) == len(range(T0, inst.n_frames, k))
        for a, b in zip(full, sub, strict=True):
            np.testing.assert_allclose(b, a[::k], rtol=0, atol=1e-12)
        assert not np.array_equal(sub[1], full[1][: len(sub[1])])  # not the first rows: every k-th


def test_switching_regression_with_a_stride_fits_on_every_kth_row(rng: np.random.Generator) -> None:
    """The regression fitted with ``row_stride`` k is the one fitted on traces whose instances keep only those rows'
    information: its column scales come from every k-th row (each instance still weighing one); k = 1 reads all."""
    insts = [_instance(rng, k, gaps=False, obj=False) for k in range(6)]
    traces = [_trace(i, rng) for i in insts]
    small = dict(families=SwitchingConfig().families[:1], motion=(("agent0",), ("agent0", "gap")), penalties=(0.1, 10.0))
    one = SwitchingRegression(SwitchingConfig(**small, row_stride=1)).fit(  # type: ignore[arg-type]
        insts, traces, n_subevents=3, rng=np.random.default_rng(0))
    two = SwitchingRegression(SwitchingConfig(**small, row_stride=2)).fit(  # type: ignore[arg-type]
        insts, traces, n_subevents=3, rng=np.random.default_rng(0))
    rows1 = [instance_rows(i, t, T0, FeatureConfig()) for i, t in zip(insts, traces, strict=True)]
    rows2 = [instance_rows(i, t, T0, FeatureConfig(), stride=2) for i, t in zip(insts, traces, strict=True)]
    lo1 = np.min([r[0].min(axis=0) for r in rows1], axis=0) / one.scale_
    lo2 = np.min([r[0].min(axis=0) for r in rows2], axis=0) / two.scale_
    span1, span2 = one.upper_ - one.lower_, two.upper_ - two.lower_
    # the clipped range (margin 1: [lo − w, hi + w], w = hi − lo) starts at lo − w of the rows each read
    np.testing.assert_allclose(one.lower_, lo1 - span1 / 3, atol=1e-9)
    np.testing.assert_allclose(two.lower_, lo2 - span2 / 3, atol=1e-9)
    assert not np.allclose(one.scale_, two.scale_)


def test_stream_key_joints_with_a_stride_are_the_streams_values_at_those_frames(rng: np.random.Generator) -> None:
    """The stream still reads every frame: at frames T0, T0 + k, … bitwise the every-frame stream's values (with
    agent 0's base first tracked late (a rebuild), gaps that close and an object), NaN at the others; a stride
    below 1 is an error."""
    insts = [_instance(rng, k, gaps=True, obj=True) for k in range(5)]
    prim = InteractionPrimitive().fit(insts[1:])
    for inst, k in ((insts[0], 3), (_instance(rng, 7, gaps=True, obj=True), 2)):
        every = stream_key_joints(prim, inst, T0)
        got = stream_key_joints(prim, inst, T0, stride=k)
        at = np.arange(T0, inst.n_frames, k)
        assert np.array_equal(got[at], every[at]) and np.isfinite(got[at]).all()
        assert np.isnan(got[np.setdiff1d(np.arange(inst.n_frames), at)]).all()
    with pytest.raises(ModelError, match="stride"):
        stream_key_joints(prim, insts[0], T0, stride=0)


def test_trace_skeletons_with_a_stride_only_at_those_frames(rng: np.random.Generator) -> None:
    """``primitive_trace`` with a stride fits the skeletons at frames T0, T0 + k, … (the same values as without it)
    and leaves the others NaN."""
    insts = [_instance(rng, k, gaps=False, obj=False) for k in range(9)]
    body = BodyFitter().fit_interactions(insts[1:], agent=1, rng=np.random.default_rng(0))
    prim = InteractionPrimitive().fit(insts[1:])
    empty = Trace(belief=np.zeros((1, 1)), phase=np.zeros(1), plan=np.zeros((1, 5, 3)), skeleton=np.zeros((1, 1, 3)))
    full = primitive_trace(prim, body, empty, insts[0], T0)
    sub = primitive_trace(prim, body, empty, insts[0], T0, stride=3)
    at = np.arange(T0, insts[0].n_frames, 3)
    np.testing.assert_allclose(sub.primitive_skeleton[at], full.primitive_skeleton[at], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(sub.primitive[at], full.primitive[at])
    off = np.setdiff1d(np.arange(T0, insts[0].n_frames), at)
    assert np.isnan(sub.primitive_skeleton[off]).all() and np.isfinite(full.primitive_skeleton[off]).all()
    assert trace.__kwdefaults__ == {"stride": 1}


def test_screen_rounds_config_is_checked_and_one_by_default() -> None:
    assert LearningConfig().init_type_screen_rounds == 1
    with pytest.raises(ConfigError, match="init_type_screen_rounds"):
        LearningConfig(init_type_screen_rounds=-1)


def _toy_restructure(screen_rounds: int) -> tuple[list[tuple[int, int]], list[Parse]]:
    """A restructuring over 2 instances with 4 labels, a refine that records its calls, and a score that ranks
    the candidates differently before and after refining: the calls and the chosen parses."""
    spaces = [ParseSpace(np.arange(0, 90, 10), np.ones(9), 4, True, None) for _ in range(2)]
    parses = [sp.initial_parse(4) for sp in spaces]
    calls: list[tuple[int, int]] = []
    state: dict[int, int] = {}

    def refine(ps: list[Parse], rounds: int) -> list[Parse]:
        calls.append((len(calls), rounds))
        out = [Parse(p.starts, p.labels) for p in ps]
        state[id(out[0])] = state.get(id(ps[0]), 0) + rounds
        return out

    def score(ps: list[Parse]) -> float:
        refined = state.get(id(ps[0]), 0)
        # labels' order as a number: unrefined candidates rank by it, refined ones by its negation
        key = float(sum(s * 10**i for i, s in enumerate(ps[0].labels)))
        return key if refined == 0 else -key + 1e9 * refined

    best, _ = restructure(spaces, parses, 4, refine=refine, score=score, passes=1, rounds=3,
                          screen_rounds=screen_rounds)
    return calls, best


def test_restructure_screen_rounds_decide_the_screening_and_the_rest() -> None:
    """screen_rounds 1 (the default): every candidate gets one round, the kept three get rounds − 1 = 2 more;
    0: the candidates are ranked as they are (no round) and the kept three get all 3 rounds; the ranking then
    differs, so the chosen parses differ."""
    calls1, best1 = _toy_restructure(1)
    calls0, best0 = _toy_restructure(0)
    n_cand = sum(1 for r in calls1 if r[1] == 1)
    assert n_cand == 12 and [r for _, r in calls1[n_cand:]] == [2, 2, 2]
    assert [r for _, r in calls0] == [0] * n_cand + [3, 3, 3]
    assert best0 != best1


class _Reached(Exception):
    pass


@pytest.mark.parametrize("screen", [0, 2])
def test_screen_rounds_reach_the_restructuring(monkeypatch: pytest.MonkeyPatch, screen: int) -> None:
    """``LearningConfig.init_type_screen_rounds`` is what Algorithm 1's start passes to :func:`restructure` (the
    fit stops there)."""
    seen: list[int] = []

    def spy(*args: object, **kwargs: object) -> None:
        seen.append(int(kwargs["screen_rounds"]))  # type: ignore[call-overload]
        raise _Reached

    monkeypatch.setattr(algorithm, "restructure", spy)
    data = load_dataset("synthetic").of_label("shake_hands").interactions[:3]
    cfg = dataclasses.replace(LearningConfig(), init_type_passes=1, init_type_screen_rounds=screen, init_rounds=1,
                              n_clusters=8, initial_gibbs_sweeps=1, kmeans_iterations=5)
    with pytest.raises(_Reached):
        SocialAffordanceModel(learning=cfg).fit(data, rng=np.random.default_rng(0))
    assert seen == [screen]


@pytest.mark.parametrize("kinds", ["mixed", "weibull", "expon"])
def test_polar_rows_logpdf_scores_each_kind_on_its_columns(rng: np.random.Generator, kinds: str) -> None:
    """Rows of both kinds (Weibull and exponential distances) are scored each on its own columns: bitwise the
    computation on every column followed by ``np.where`` that it replaced, and scipy's densities per column
    (x = 0 and x < 0 included)."""
    N, K = 40, 7
    h, v = rng.uniform(0, 2, (N, K)), rng.uniform(0, 2, (N, K))
    h[0, :], v[1, :], h[2, :] = 0.0, 0.0, -0.5
    th = rng.uniform(-np.pi, np.pi, (N, K))
    params = np.c_[rng.uniform(0.5, 3, K), rng.uniform(0.1, 1, K), rng.uniform(0.5, 3, K), rng.uniform(0.1, 1, K),
                   rng.uniform(-3, 3, K), rng.uniform(0, 5, K)]
    params[0, 0] = 1.0  # k = 1 at x = 0
    expon = {"mixed": rng.random(K) < 0.5, "weibull": np.zeros(K, bool), "expon": np.ones(K, bool)}[kinds]
    if kinds == "mixed":
        expon[:2] = [True, False]
    kh, lh, kv, lv, mu, kap = params.T
    with np.errstate(divide="ignore", invalid="ignore"):
        old = np.where(expon, expon_logpdf(h, lh) + expon_logpdf(v, lv),
                       weibull_logpdf(h, kh, lh) + weibull_logpdf(v, kv, lv)) + vonmises_logpdf(th, mu, kap)
        got = polar_rows_logpdf(h, v, th, params, expon)
    assert np.array_equal(got, old)
    for j in range(K):
        dist = (stats.expon(scale=lh[j]).logpdf(h[:, j]) + stats.expon(scale=lv[j]).logpdf(v[:, j]) if expon[j] else
                stats.weibull_min(kh[j], scale=lh[j]).logpdf(h[:, j]) + stats.weibull_min(kv[j], scale=lv[j]).logpdf(v[:, j]))
        want = dist + stats.vonmises(kap[j], loc=mu[j]).logpdf(th[:, j])
        np.testing.assert_allclose(got[:, j], want, rtol=1e-9, atol=1e-9)  # ±inf where scipy has them


@pytest.mark.parametrize(("stride", "cross_fit"), [(1, 2), (3, 2), (3, 1)])
def test_row_stride_reaches_every_training_trace(monkeypatch: pytest.MonkeyPatch, rng: np.random.Generator, stride: int,
                                                 cross_fit: int) -> None:
    """``AffordanceMethod._training_traces`` passes ``SwitchingConfig.row_stride`` to every synthesizer trace and
    primitive trace it computes (cross-fitted or in sample); 1 (the default) to all of them otherwise."""
    strides: list[tuple[str, int]] = []

    class FakeModel:
        def __init__(self, *args: object) -> None:
            pass

        def fit(self, insts: list[Interaction], *, rng: np.random.Generator | None = None) -> FakeModel:
            return self

    def fake_trace(model: FakeModel, body: object, inst: Interaction, config: object, rng: object, *, stride: int = 1) -> Trace:
        strides.append(("trace", stride))
        T = inst.n_frames
        return Trace(belief=np.zeros((T, 2)), phase=np.zeros(T), plan=np.zeros((T, 5, 3)), skeleton=np.zeros((T, 5, 3)))

    def fake_primitive_trace(prim: FakeModel, body: object, tr: Trace, inst: Interaction, n_observed: int, *,
                             stride: int = 1) -> Trace:
        strides.append(("primitive", stride))
        return tr

    monkeypatch.setattr(methods_module, "SocialAffordanceModel", FakeModel)
    monkeypatch.setattr(methods_module, "InteractionPrimitive", FakeModel)
    monkeypatch.setattr(methods_module, "trace", fake_trace)
    monkeypatch.setattr(methods_module, "primitive_trace", fake_primitive_trace)
    insts = [_instance(rng, k, gaps=False, obj=False) for k in range(6)]
    m = AffordanceMethod("full")
    m.model_ = m.primitive_ = FakeModel()
    m.body_ = None
    m._training_traces(insts, SwitchingConfig(row_stride=stride, cross_fit=cross_fit), rng)
    assert {kind for kind, _ in strides} == {"trace", "primitive"}
    assert len(strides) == 2 * len(insts) and all(k == stride for _, k in strides)
