"""The full model's switching regression: the belief-gated mixture against brute force, the inner CV against an
explicit loop, each selection decision (``hold``, the ``from_plan`` prior, the gated experts), and the full
method end to end (default preset uses it, the paper preset does not)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from socialaff_sim.data import Interaction
from socialaff_sim.data.skeletons import KEY_JOINTS
from socialaff_sim.errors import ConfigError, ModelError, NotFittedError
from socialaff_sim.evaluation.streaming import run_protocol
from socialaff_sim.inference.body_fit import BodyFitter
from socialaff_sim.inference.methods import AffordanceMethod, trace
from socialaff_sim.inference.synthesis_config import SynthesisConfig
from socialaff_sim.inference.reaction_features import FEATURE_GROUPS, N_FEATURES, RAMP_COLUMN, group_columns
from socialaff_sim.inference.reaction_regression import (
    HOLD,
    blend_weights,
    cv_errors,
    fold_predictions,
    key_error,
    ridge_solve,
    select,
    simplex_grid,
)
import socialaff_sim.inference.methods as methods_module
from socialaff_sim.inference.switching import (
    FAMILIES,
    GATED_FAMILIES,
    SwitchingConfig,
    SwitchingRegression,
    Trace,
    instance_rows,
    switching_columns,
    switching_rows,
    switching_scale,
)
from socialaff_sim.learning.config import LearningConfig

T0 = 10


def test_gated_columns_are_the_mixture_of_experts(rng: np.random.Generator) -> None:
    """rows[:, gated columns] @ W equals Σ_s b_s (x @ W_s), computed by brute force per row and expert."""
    N, S = 7, 3
    x = rng.normal(size=(N, N_FEATURES))
    b = rng.dirichlet(np.ones(S), size=N)
    rows = switching_rows(x, b, rng.uniform(size=N), rng.normal(size=(N, 15)))
    groups = ("agent0", "own_velocity")
    motion = group_columns(groups)
    experts = rng.normal(size=(S, len(motion), 2))
    gated = switching_columns(groups + ("gated",), S)[len(motion):]
    got = rows[:, gated] @ experts.reshape(S * len(motion), 2)
    ref = np.array([[sum(b[n, s] * x[n, motion] @ experts[s][:, d] for s in range(S)) for d in range(2)] for n in range(N)])
    np.testing.assert_allclose(got, ref, atol=1e-12)


def test_subevent_and_phase_columns(rng: np.random.Generator) -> None:
    N, S = 5, 4
    x = rng.normal(size=(N, N_FEATURES))
    b = rng.dirichlet(np.ones(S), size=N)
    phi = rng.uniform(size=N)
    phi[0] = np.nan  # observed frames: counts as 0
    plan = rng.normal(size=(N, 15))
    rows = switching_rows(x, b, phi, plan)
    r = x[:, RAMP_COLUMN]
    np.testing.assert_allclose(rows[:, switching_columns(("subevent",), S)], b * r[:, None])
    np.testing.assert_allclose(rows[:, switching_columns(("phase",), S)], b * (np.nan_to_num(phi) * r)[:, None])
    np.testing.assert_allclose(rows[:, switching_columns(("plan",), S)], plan)
    np.testing.assert_allclose(rows[:, switching_columns(FEATURE_GROUPS, S)], x)
    assert switching_columns(("from_plan",), S).size == 0  # the prior has no columns
    assert rows.shape[1] == N_FEATURES + 2 * S + S * N_FEATURES + 30  # and the primitive's 15 (zeros here)


def test_cv_errors_match_an_explicit_loop(rng: np.random.Generator) -> None:
    """The eigen-decomposed inner CV, with and without the offset prior, against per-λ solves."""
    N, F, K = 60, 6, 3
    X = rng.normal(size=(N, F))
    Y = X[:, :2] @ rng.normal(size=(2, K)) + 0.1 * rng.normal(size=(N, K))
    off = 0.5 * Y + 0.05 * rng.normal(size=(N, K))
    w = rng.uniform(0.5, 1.5, size=N)
    ids = np.repeat(np.arange(12), 5)
    folds = [[0, 1, 2, 3], [4, 5, 6, 7], [8, 9, 10, 11]]
    cands = {("a",): np.array([0, 1]), ("b",): np.array([0, 1, 2, 3, 4, 5]), ("a", "from_plan"): np.array([0, 1]),
             ("from_plan",): np.zeros(0, np.int64)}
    pens = (0.01, 1.0)
    got = cv_errors(X, Y, w, ids, folds, cands, pens, offset=off, from_offset=[("a", "from_plan"), ("from_plan",)])
    for name, cols in cands.items():
        base = off if "from_plan" in name else np.zeros_like(Y)
        for lam in (pens if len(cols) else (math.inf,)):
            errs = []
            for held in folds:
                ho = np.isin(ids, held)
                tr = ~ho
                wt = w[tr] / w[tr].sum()
                if len(cols):
                    Xt = X[tr][:, cols]
                    W = ridge_solve((Xt * wt[:, None]).T @ Xt, (Xt * wt[:, None]).T @ (Y[tr] - base[tr]), lam)
                    pred = base[ho] + X[ho][:, cols] @ W
                else:
                    pred = base[ho]
                errs.append(key_error(pred, Y[ho], ids[ho]))
            assert got[(name, lam)] == pytest.approx(np.mean(errs), rel=1e-9)
    assert got[(HOLD, math.inf)] == pytest.approx(np.mean([key_error(0 * Y[np.isin(ids, f)], Y[np.isin(ids, f)],
                                                                       ids[np.isin(ids, f)]) for f in folds]))


def test_fold_predictions_and_blend_against_brute_force(rng: np.random.Generator) -> None:
    N, K = 40, 3
    X = rng.normal(size=(N, 4))
    Y = X[:, :1] @ rng.normal(size=(1, K)) + 0.2 * rng.normal(size=(N, K))
    w = np.ones(N)
    ids = np.repeat(np.arange(8), 5)
    folds = [[0, 1, 2], [3, 4, 5], [6, 7]]
    base = 0.3 * Y
    got = fold_predictions(X, Y, w, ids, folds, np.array([0, 2]), 0.5, base)
    for held in folds:
        ho = np.isin(ids, held)
        Xt = X[~ho][:, [0, 2]]
        W = np.linalg.lstsq(np.vstack([Xt / np.sqrt((~ho).sum()), np.sqrt(0.5) * np.eye(2)]),
                            np.vstack([(Y[~ho] - base[~ho]) / np.sqrt((~ho).sum()), np.zeros((2, K))]), rcond=None)[0]
        np.testing.assert_allclose(got[ho], base[ho] + X[ho][:, [0, 2]] @ W, atol=1e-10)
    np.testing.assert_array_equal(fold_predictions(X, Y, w, ids, folds, np.zeros(0, np.int64), math.inf, base), base)
    # The blend: an explicit search over every weight vector of the grid, with the evaluation's metric.
    preds = np.stack([got, 0.8 * Y + 0.1 * rng.normal(size=(N, K)), rng.normal(size=(N, K))])
    grid = simplex_grid(3, 5)
    assert len(grid) == 56 and np.all(grid[0] == 0) and np.all(grid.sum(1) <= 1 + 1e-12)
    alpha, err = blend_weights(preds, Y, ids, 5)
    errs = [key_error(np.tensordot(a, preds, 1), Y, ids) for a in grid]
    assert err == pytest.approx(min(errs)) and np.allclose(alpha, grid[int(np.argmin(errs))])
    assert alpha[2] == 0 and alpha[1] > 0.5  # the noise predictor gets no weight, the good one most
    # Nothing beats hold: all weight stays on hold (ties go to the smaller total weight).
    alpha, _ = blend_weights(np.zeros((2, N, K)), Y, ids, 5)
    assert np.all(alpha == 0)


# -- selection decisions on toy data ---------------------------------------------------------------
def _instance(rng: np.random.Generator, k: int, T: int = 30) -> Interaction:
    """Agent 0 wanders; agent 1 is set later by the tests (through the traces only the rows matter)."""
    body = np.array([[0, 0, 0.9], [0, 0.3, 1.0], [0, -0.3, 1.0], [0, 0.1, 0.05], [0, -0.1, 0.05]], float)
    a0 = body[None] + rng.normal(0, 0.03, size=(T, 5, 3)).cumsum(0)
    a1 = np.repeat((body + [1.5, 0, 0])[None], T, 0)
    return Interaction(label="toy", fps=10.0, joints=np.stack([a0, a1], 1), joint_names=KEY_JOINTS,
                       actors=(f"p{k % 4}", f"q{k % 4}"), instance_id=f"toy{k}")


def _toy(rng: np.random.Generator, rule: str, n: int = 12) -> tuple[list[Interaction], list[Trace]]:
    """Instances whose agent 1 follows ``rule`` after T0: ``plan`` (agent 1 = the trace's plan, which is
    unrelated to agent 0), ``switch`` (agent 1 moves by +agent 0's displacement in sub-event 0 and by −it in
    sub-event 1, the belief one-hot and known), ``still``."""
    insts, traces = [], []
    for k in range(n):
        inst = _instance(rng, k)
        T = inst.n_frames
        joints = inst.joints.copy()
        a0 = joints[:, 0]
        s = np.zeros(T, int)
        s[T // 2:] = k % 2  # odd instances switch to sub-event 1 half-way
        plan_keys = joints[:, 1] + rng.normal(0, 0.2, size=(T, 5, 3)).cumsum(0) * (np.arange(T) >= T0)[:, None, None]
        if rule == "plan":
            joints[T0:, 1] = plan_keys[T0:]
        elif rule == "switch":
            sign = np.where(s == 0, 1.0, -1.0)[:, None, None]
            joints[T0:, 1] = joints[T0 - 1, 1] + sign[T0:] * (a0[T0:] - a0[T0 - 1])
        inst = inst.replace(joints=joints)
        traces.append(Trace(belief=np.eye(2)[s], phase=np.linspace(0, 1, T), plan=plan_keys, skeleton=plan_keys))
        insts.append(inst)
    return insts, traces


def test_plan_prior_is_selected_when_the_plan_is_right(rng: np.random.Generator) -> None:
    insts, traces = _toy(rng, "plan")
    reg = SwitchingRegression().fit(insts, traces, n_subevents=2, rng=rng)
    assert sum(m.weight for m in reg.members_ if m.from_plan) == pytest.approx(1.0)
    assert reg.blend_error_ < 0.02
    X, Y, O, _ = instance_rows(insts[0], traces[0], T0, reg.config.features)
    np.testing.assert_allclose(reg.displacement(X, O), Y, atol=0.02)  # without the prior added back: off by the plan


def test_hold_is_selected_when_nothing_predicts(rng: np.random.Generator) -> None:
    insts, traces = _toy(rng, "still")
    reg = SwitchingRegression().fit(insts, traces, n_subevents=2, rng=rng)
    assert reg.members_ == [] and reg.groups_ == HOLD
    X, _, O, _ = instance_rows(insts[0], traces[0], T0, reg.config.features)
    assert np.all(reg.displacement(X, O) == 0)
    assert select({(HOLD, math.inf): 0.1, (("agent0",), 1.0): 0.1}) == (HOLD, math.inf)  # hold wins ties


def test_gated_experts_are_selected_for_a_switching_reaction(rng: np.random.Generator) -> None:
    insts, traces = _toy(rng, "switch", 16)
    families = tuple(f for f in GATED_FAMILIES if f[0] != "plan")
    reg = SwitchingRegression(SwitchingConfig(motion=(("agent0",),), families=families)).fit(
        insts, traces, n_subevents=2, rng=rng)
    (member,) = [m for m in reg.members_ if m.weight >= 0.5]
    assert "gated" in member.groups and not member.from_plan
    ungated = min(v for (g, _), v in reg.cv_errors_.items() if "gated" not in g)
    assert reg.cv_errors_[(member.groups, member.penalty)] < 0.5 * ungated
    assert reg.blend_error_ < 0.5 * ungated


def test_config_and_fit_errors(rng: np.random.Generator) -> None:
    with pytest.raises(ConfigError, match="families"):
        SwitchingConfig(families=(("x", (("nope",),)),))
    with pytest.raises(ConfigError, match="blend_steps"):
        SwitchingConfig(blend_steps=0)
    with pytest.raises(ConfigError, match="motion"):
        SwitchingConfig(motion=((),))
    with pytest.raises(ConfigError, match="penalties"):
        SwitchingConfig(penalties=(0.0,))
    with pytest.raises(NotFittedError):
        SwitchingRegression().displacement(np.zeros((1, 3)), np.zeros((1, 3)))
    insts, traces = _toy(rng, "still", 3)
    with pytest.raises(ModelError, match="traces"):
        SwitchingRegression().fit(insts, traces[:2], n_subevents=2, rng=rng)
    assert all(len(c) for f, _ in SwitchingConfig().families for c in SwitchingConfig().candidates(f))
    assert ("from_plan",) in SwitchingConfig().candidates("plan")  # the plan alone (Algorithm 2 itself) is a candidate
    assert set(SwitchingConfig().candidates("motion")) == set(SwitchingConfig().motion)  # ridge's candidates


# -- the method end to end -------------------------------------------------------------------------
def test_default_full_method_uses_the_switching_regression(shake8) -> None:  # noqa: ANN001
    data = list(shake8)
    learning = LearningConfig(iterations=2)
    assert AffordanceMethod.from_preset("full", "default").reaction == SwitchingConfig()
    assert AffordanceMethod.from_preset("full", "paper").reaction is None  # the paper preset: Algorithm 2's output
    m = AffordanceMethod("full", learning=learning, reaction=SwitchingConfig()).fit(data[:6], rng=np.random.default_rng(0))
    assert isinstance(m.reaction_, SwitchingRegression)
    pred = run_protocol(m, data[6], protocol="causal", n_observed=T0, rng=np.random.default_rng(1))
    assert np.isfinite(pred.key_joints[T0:]).all() and pred.joints.shape == data[6].joints[:, 1].shape
    # The reactor's output is the regression's displacement from agent 1's last observed pose.
    if m.reaction_.groups_ == HOLD:
        np.testing.assert_allclose(pred.joints[T0:], np.repeat(data[6].filled_joints()[T0 - 1, 1][None],
                                                               data[6].n_frames - T0, 0), atol=1e-9)


def test_training_instances_no_longer_than_t0_are_skipped(shake8, shake8_model) -> None:  # noqa: ANN001
    """SBU holds recordings of exactly T0 frames: their trace is empty (no synthesis is run on them; before, the
    synthesizer raised) and the switching regression fits on the others."""
    data = list(shake8)
    short = data[0].slice(0, T0)
    body = BodyFitter().fit_interactions(data[:6], agent=1, rng=np.random.default_rng(0))
    cfg = SynthesisConfig(n_observed=T0)
    empty = trace(shake8_model, body, short, cfg, np.random.default_rng(0))
    assert empty.plan.shape == (T0, 5, 3) and np.isnan(empty.plan).all() and np.isnan(empty.belief).all()
    insts = [short, data[1], data[2], data[3]]
    traces = [empty] + [trace(shake8_model, body, d, cfg, np.random.default_rng(0)) for d in insts[1:]]
    reg = SwitchingRegression(SwitchingConfig(inner_folds=2)).fit(
        insts, traces, n_subevents=shake8_model.n_subevents_, rng=np.random.default_rng(0))
    assert np.isfinite(reg.scale_).all()


def test_belief_weighted_columns_take_the_scale_of_what_they_weight(rng: np.random.Generator) -> None:
    """A sub-event the training rows never believed in must not get an inflated column: with each column scaled by
    its own RMS, a test row believing in it would be multiplied by ~1e9."""
    N, S = 50, 2
    x = rng.normal(size=(N, N_FEATURES))
    b = np.column_stack([np.ones(N) - 1e-10, np.full(N, 1e-10)])
    rows = switching_rows(x, b, rng.uniform(size=N), rng.normal(size=(N, 15)))
    scale = switching_scale(rows, np.ones(N), S)
    motion = scale[:N_FEATURES]
    gated = switching_columns(FEATURE_GROUPS + ("gated",), S)[N_FEATURES:]
    np.testing.assert_allclose(scale[gated], np.tile(motion, S))
    np.testing.assert_allclose(scale[switching_columns(("subevent", "phase"), S)], scale[RAMP_COLUMN])
    assert scale[gated[N_FEATURES:]].min() > 1e-3  # the rarely believed sub-event's columns keep a motion scale


def test_training_plans_are_cross_fitted(monkeypatch: pytest.MonkeyPatch, rng: np.random.Generator) -> None:
    """Every training instance's plan comes from a model fitted without it (cross_fit = 2); its belief, when a
    family reads one, from the model fitted on all (whose sub-event labels the test rows carry)."""
    fitted: list[set[str]] = []

    class FakeModel:
        def __init__(self, *args: object) -> None:
            pass

        def fit(self, insts: list[Interaction], *, rng: np.random.Generator) -> FakeModel:
            self.ids = {i.instance_id for i in insts}
            fitted.append(self.ids)
            return self

    def fake_trace(model: FakeModel, body: object, inst: Interaction, config: object, rng: object, *, stride: int = 1) -> Trace:
        T = inst.n_frames
        own = float(inst.instance_id in model.ids)  # 1: the model saw this instance
        return Trace(belief=np.full((T, 2), own), phase=np.zeros(T), plan=np.full((T, 5, 3), own),
                     skeleton=np.full((T, 5, 3), own))

    monkeypatch.setattr(methods_module, "SocialAffordanceModel", FakeModel)
    monkeypatch.setattr(methods_module, "trace", fake_trace)
    insts = [_instance(rng, k) for k in range(8)]
    m = AffordanceMethod("full")
    m.model_ = FakeModel().fit(insts, rng=rng)
    m.body_ = None
    for cfg, seen_plan in [(SwitchingConfig(families=FAMILIES), 0.0), (SwitchingConfig(families=FAMILIES, cross_fit=1), 1.0)]:
        traces = m._training_traces(insts, cfg, rng)
        assert all(np.all(t.plan == seen_plan) for t in traces)
    traces = m._training_traces(insts, SwitchingConfig(families=GATED_FAMILIES), rng)
    assert all(np.all(t.plan == 0.0) and np.all(t.belief == 1.0) for t in traces)
    assert len(fitted) >= 3 and all(len(ids) < len(insts) for ids in fitted[1:])


def test_cross_fit_type_passes_reach_the_cross_fitted_models_only(monkeypatch: pytest.MonkeyPatch, rng: np.random.Generator) -> None:
    """``SwitchingConfig.cross_fit_type_passes`` sets the restructuring passes of the cross-fitted models; None keeps
    the method's own learning configuration (the model on all instances is not fitted here and keeps it too)."""
    seen: list[LearningConfig | None] = []

    class FakeModel:
        def __init__(self, config: object, learning: LearningConfig | None) -> None:
            seen.append(learning)

        def fit(self, insts: list[Interaction], *, rng: np.random.Generator) -> FakeModel:
            return self

    def fake_trace(model: FakeModel, body: object, inst: Interaction, config: object, rng: object, *, stride: int = 1) -> Trace:
        T = inst.n_frames
        return Trace(belief=np.zeros((T, 2)), phase=np.zeros(T), plan=np.zeros((T, 5, 3)), skeleton=np.zeros((T, 5, 3)))

    monkeypatch.setattr(methods_module, "SocialAffordanceModel", FakeModel)
    monkeypatch.setattr(methods_module, "trace", fake_trace)
    insts = [_instance(rng, k) for k in range(6)]
    own = LearningConfig(init_type_passes=3, init_rounds=4)
    m = AffordanceMethod("full", learning=own)
    m.body_ = None
    m._training_traces(insts, SwitchingConfig(families=FAMILIES, cross_fit_type_passes=None), rng)
    assert len(seen) == 2 and all(cfg is own for cfg in seen)
    seen.clear()
    assert SwitchingConfig().cross_fit_type_passes == 0  # the default since its development-split rule held
    m._training_traces(insts, SwitchingConfig(families=FAMILIES), rng)
    assert len(seen) == 2 and all(cfg == dataclasses.replace(own, init_type_passes=0) for cfg in seen)
    with pytest.raises(ConfigError):
        SwitchingConfig(cross_fit_type_passes=-1)


def test_clip_features_bounds_each_column_by_the_training_rows(rng: np.random.Generator) -> None:
    """``SwitchingConfig.clip_features``: at prediction each scaled column is clipped to its training range, so a
    row far outside it gives the prediction of the row clipped there; rows inside are unchanged; off: linear."""
    insts, traces = _toy(rng, "switch", 16)
    families = tuple(f for f in GATED_FAMILIES if f[0] != "plan")
    assert SwitchingConfig().clip_features and SwitchingConfig().clip_margin == 1.0  # the defaults since their rule held
    config = SwitchingConfig(motion=(("agent0",),), families=families, clip_features=False, clip_margin=0.0,
                            row_stride=1)  # every frame: the rows below
    free = SwitchingRegression(config).fit(insts, traces, n_subevents=2, rng=np.random.default_rng(1))
    clipped = SwitchingRegression(dataclasses.replace(config, clip_features=True)).fit(
        insts, traces, n_subevents=2, rng=np.random.default_rng(1))
    rows = [instance_rows(i, t, T0, config.features)[0] for i, t in zip(insts, traces, strict=True)]
    Xs = np.concatenate(rows) / free.scale_  # every training row weighs > 0 here
    np.testing.assert_array_equal(clipped.lower_, Xs.min(axis=0))
    np.testing.assert_array_equal(clipped.upper_, Xs.max(axis=0))
    X, _, O, _ = instance_rows(insts[0], traces[0], T0, config.features)
    np.testing.assert_array_equal(clipped.displacement(X, O), free.displacement(X, O))  # inside: unchanged
    far = X * 50.0
    inside = np.clip(far / free.scale_, free.lower_, free.upper_) * free.scale_
    np.testing.assert_allclose(clipped.displacement(far, O), free.displacement(inside, O), rtol=1e-10, atol=1e-12)
    assert np.abs(free.displacement(far, O)).max() > 5 * np.abs(clipped.displacement(far, O)).max()
    wide = SwitchingRegression(dataclasses.replace(config, clip_features=True, clip_margin=0.5)).fit(
        insts, traces, n_subevents=2, rng=np.random.default_rng(1))
    width = Xs.max(axis=0) - Xs.min(axis=0)
    np.testing.assert_allclose(wide.lower_, Xs.min(axis=0) - 0.5 * width, rtol=0, atol=1e-12)
    np.testing.assert_allclose(wide.upper_, Xs.max(axis=0) + 0.5 * width, rtol=0, atol=1e-12)
    with pytest.raises(ConfigError, match="clip_margin"):
        SwitchingConfig(clip_margin=-0.1)
