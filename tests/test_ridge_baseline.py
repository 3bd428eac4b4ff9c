"""The ``ridge`` baseline and the causal features it shares with ``gru``: closed form, features by hand,
causality, and the shrinkage decision (``hold`` is a candidate and wins ties)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import socialaff_sim.baselines.gru as gru_module

from socialaff_sim.inference.reaction_features import (
    FEATURE_GROUPS,
    N_FEATURES,
    Anchor,
    FeatureConfig,
    FeatureStream,
    forward_fill,
    group_columns,
    training_rows,
)
from socialaff_sim.baselines.ridge import HOLD, RidgeConfig, RidgeReaction, ridge_solve, select
from socialaff_sim.data import Dataset, Interaction
from socialaff_sim.data.skeletons import KEY_JOINTS
from socialaff_sim.errors import ConfigError, ModelError, NotFittedError
from socialaff_sim.evaluation import EvaluationConfig, available_methods, evaluate, get_method, key_joint_error
from socialaff_sim.evaluation.streaming import run_protocol

T0 = 10
FPS = 10.0


def _rot(h: float) -> np.ndarray:
    c, s = math.cos(h), math.sin(h)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def make_instance(rng: np.random.Generator, kind: str, *, T: int = 40, pair: int = 0, heading: float | None = None) -> Interaction:
    """Two key5 skeletons facing each other 1.5 m apart on a random heading. Agent 0's joints wander
    smoothly. ``follow``: after frame T0 − 1 agent 1's joints move by −0.5 × agent 0's displacement since
    T0 − 1 (in the frame of the two agents); ``noise``: agent 1 moves at random, unrelated to agent 0;
    ``still``: agent 1 never moves."""
    h = rng.uniform(-math.pi, math.pi) if heading is None else heading
    R = _rot(h)
    body = np.array([[0, 0, 0.9], [0, 0.3, 1.0], [0, -0.3, 1.0], [0, 0.1, 0.05], [0, -0.1, 0.05]], float)
    steps = rng.normal(0, 0.02, size=(T, 5, 3)).cumsum(0)
    a0 = body[None] + steps  # in the agents' frame, agent 0 at the origin, agent 1 at x = 1.5
    a1 = np.repeat((body + [1.5, 0, 0])[None], T, 0)
    if kind == "follow":
        a1[T0 - 1:] += -0.5 * (a0[T0 - 1:] - a0[T0 - 1])
    elif kind == "noise":
        a1[T0 - 1:] += rng.normal(0, 0.05, size=(T - T0 + 1, 5, 3)).cumsum(0)
    joints = np.stack([a0, a1], axis=1) @ R.T + np.array([2.0, -1.0, 0.0])
    return Interaction(label="toy", fps=FPS, joints=joints, joint_names=KEY_JOINTS, actors=(f"p{pair}", f"q{pair}"),
                       instance_id=f"{kind}{pair}_{rng.integers(1 << 30)}")


def make_set(rng: np.random.Generator, kind: str, n: int = 12) -> list[Interaction]:
    return [make_instance(rng, kind, pair=i % 6) for i in range(n)]


# -- closed form ----------------------------------------------------------------------------------
def test_ridge_solve_matches_augmented_least_squares(rng: np.random.Generator) -> None:
    X = rng.normal(size=(30, 4))
    Y = rng.normal(size=(30, 2))
    w = rng.uniform(0.1, 2.0, size=30)
    lam = 0.7
    W = ridge_solve((X * w[:, None]).T @ X, (X * w[:, None]).T @ Y, lam)
    A = np.vstack([np.sqrt(w)[:, None] * X, math.sqrt(lam) * np.eye(4)])
    B = np.vstack([np.sqrt(w)[:, None] * Y, np.zeros((4, 2))])
    ref = np.linalg.lstsq(A, B, rcond=None)[0]
    np.testing.assert_allclose(W, ref, atol=1e-10)


def test_fitted_weights_are_the_weighted_ridge_solution(rng: np.random.Generator) -> None:
    train = make_set(rng, "follow", 6)
    cfg = RidgeConfig(candidates=(("agent0",),), penalties=(0.3,))
    m = RidgeReaction(cfg).fit(train, rng=rng)
    assert m.groups_ == ("agent0",) and m.penalty_ == 0.3
    # independent reference: stack each instance's rows, weight 1 / (rows · instances), scale, lstsq
    rows = [training_rows(i, T0, cfg.features) for i in train]
    X = np.concatenate([r[0] for r in rows])
    Y = np.concatenate([r[1] for r in rows])
    w = np.concatenate([np.full(len(r[0]), 1.0 / (len(r[0]) * len(rows))) for r in rows])
    rms = np.sqrt((w[:, None] * X**2).sum(0))
    cols = group_columns(("agent0",))
    Xs = X[:, cols] / rms[cols]
    A = np.vstack([np.sqrt(w)[:, None] * Xs, math.sqrt(0.3) * np.eye(len(cols))])
    B = np.vstack([np.sqrt(w)[:, None] * Y, np.zeros((len(cols), Y.shape[1]))])
    np.testing.assert_allclose(m.weights_, np.linalg.lstsq(A, B, rcond=None)[0], atol=1e-9)


# -- features by hand -----------------------------------------------------------------------------
def test_features_by_hand() -> None:
    """Agent 0 walks toward agent 1 at 0.5 m/s; agent 1 had been rising at 0.2 m/s; the pair stands on a 90° heading."""
    T, R = 20, _rot(math.pi / 2)
    body = np.zeros((5, 3))
    t = np.arange(T, dtype=float)[:, None, None]
    a0 = body[None] + t * np.array([0.05, 0, 0])  # 0.5 m/s along the line to agent 1
    a1 = np.repeat((body + [1.5, 0, 0])[None], T, 0) + np.minimum(t, T0 - 1) * np.array([0, 0, 0.02])
    inst = Interaction(label="toy", fps=FPS, joints=np.stack([a0, a1], 1) @ R.T, joint_names=KEY_JOINTS, actors=("a", "b"))
    cfg = FeatureConfig()
    X, Y, frames = training_rows(inst, T0, cfg)
    assert frames[0] == T0 and len(frames) == T - T0
    s = (frames - (T0 - 1)) / FPS
    ramp = 1 - np.exp(-s / cfg.time_constant_s)
    d0 = X[:, group_columns(("agent0",))].reshape(-1, 5, 3)
    np.testing.assert_allclose(d0, np.broadcast_to((0.5 * s)[:, None, None] * np.array([1.0, 0, 0]), d0.shape), atol=1e-12)
    gap = X[:, group_columns(("gap",))]
    np.testing.assert_allclose(gap[:, 0], (0.05 * frames - 1.5) * ramp, atol=1e-12)
    np.testing.assert_allclose(gap[:, 3], ramp, atol=1e-12)
    own = X[:, group_columns(("own_velocity",))].reshape(-1, 5, 3)
    np.testing.assert_allclose(own, np.broadcast_to((cfg.time_constant_s * ramp)[:, None, None] * np.array([0, 0, 0.2]), own.shape),
                               atol=1e-12)
    v0 = X[:, group_columns(("agent0_velocity",))].reshape(-1, 5, 3)
    np.testing.assert_allclose(v0, np.broadcast_to([0.5, 0, 0], v0.shape), atol=1e-12)
    np.testing.assert_allclose(Y, 0.0, atol=1e-12)  # agent 1 stopped at T0 − 1
    assert X.shape[1] == N_FEATURES == sum(len(group_columns((g,))) for g in FEATURE_GROUPS)


def test_forward_fill_holds_the_last_tracked_frame() -> None:
    x = np.arange(6, dtype=float)[:, None, None] * np.ones((6, 1, 3))
    ok = np.array([False, True, False, False, True, False])[:, None]
    out = forward_fill(x, ok)[:, 0, 0]
    np.testing.assert_array_equal(out, [1, 1, 1, 1, 4, 4])


def test_stream_rows_equal_the_training_rows(rng: np.random.Generator) -> None:
    """The causal stream (one frame per call, as the causal protocol asks) gives the rows training used."""
    inst = make_instance(rng, "follow", T=30)
    X, _, frames = training_rows(inst, T0, FeatureConfig())
    stream = FeatureStream(T0, FeatureConfig())
    with pytest.raises(ModelError, match="no view seen yet"):
        stream.anchor  # noqa: B018
    view_src = inst.hide_agent_after(1, T0)
    rows = np.concatenate([stream.rows(view_src.slice(0, t + 1), t, t + 1) for t in frames])
    np.testing.assert_allclose(rows, X, atol=1e-12)
    assert isinstance(stream.anchor, Anchor)


# -- causality ------------------------------------------------------------------------------------
def test_ridge_is_causal(rng: np.random.Generator) -> None:
    m = RidgeReaction().fit(make_set(rng, "follow"), rng=rng)
    assert m.groups_ and "agent0" in m.groups_
    inst = make_instance(rng, "follow", T=30)
    base = run_protocol(m, inst, protocol="causal", n_observed=T0, rng=rng).joints
    t = 18
    joints = np.array(inst.joints)
    joints[t + 1:, 0] += 0.4  # agent 0's future
    later = run_protocol(m, inst.replace(joints=joints), protocol="causal", n_observed=T0, rng=rng).joints
    np.testing.assert_array_equal(later[: t + 1], base[: t + 1])
    assert not np.allclose(later[t + 1:], base[t + 1:])  # the change is seen once it happens


# -- the shrinkage decision -----------------------------------------------------------------------
def test_regression_chosen_where_it_predicts_and_beats_hold(rng: np.random.Generator) -> None:
    m = RidgeReaction().fit(make_set(rng, "follow"), rng=rng)
    assert "agent0" in m.groups_ and m.cv_errors_[(m.groups_, m.penalty_)] < m.cv_errors_[(HOLD, math.inf)]
    hold = get_method("hold")().fit(make_set(rng, "follow", 2), rng=rng)
    test = make_set(rng, "follow", 4)
    e_r = np.mean([key_joint_error(run_protocol(m, i, protocol="causal", n_observed=T0, rng=rng), i) for i in test])
    e_h = np.mean([key_joint_error(run_protocol(hold, i, protocol="causal", n_observed=T0, rng=rng), i) for i in test])
    assert e_r < 0.1 * e_h


def test_select_takes_the_lowest_and_hold_on_a_tie() -> None:
    hold, a, b = (HOLD, math.inf), (("agent0",), 1.0), (("agent0", "gap"), 0.1)
    assert select({hold: 0.2, a: 0.1, b: 0.15}) == a
    assert select({hold: 0.1, a: 0.2, b: 0.15}) == hold
    assert select({a: 0.1, hold: 0.1, b: 0.1}) == hold
    assert select({a: 0.1, b: 0.1}) == a  # the larger λ among tied regressions


def test_hold_chosen_where_the_regression_only_overfits(rng: np.random.Generator) -> None:
    """Agent 1 moves at random; with a vanishing penalty every regression fits noise and loses to hold on
    the held-out training instances."""
    m = RidgeReaction(RidgeConfig(penalties=(1e-6,))).fit(make_set(rng, "noise", 18), rng=rng)
    assert m.groups_ == HOLD and m.penalty_ == math.inf
    assert m.cv_errors_[(HOLD, math.inf)] <= min(m.cv_errors_.values())
    inst = make_instance(rng, "noise")
    p = run_protocol(m, inst, protocol="causal", n_observed=T0, rng=rng)
    np.testing.assert_allclose(p.joints[T0:], np.repeat(inst.joints[T0 - 1, 1][None], inst.n_frames - T0, 0), atol=1e-12)


def test_hold_wins_a_tie(rng: np.random.Generator) -> None:
    """Agent 1 never moves: every candidate predicts zero displacement exactly; the simplest (hold) is kept."""
    m = RidgeReaction().fit(make_set(rng, "still"), rng=rng)
    assert max(m.cv_errors_.values()) < 1e-9
    assert m.groups_ == HOLD


def test_errors_and_config() -> None:
    with pytest.raises(NotFittedError, match="ridge"):
        RidgeReaction().start(n_observed=T0, offline=False, rng=np.random.default_rng(0))
    with pytest.raises(ConfigError, match="penalties"):
        RidgeConfig(penalties=(0.0,))
    with pytest.raises(ConfigError, match="candidates"):
        RidgeConfig(candidates=(("elbows",),))
    assert get_method("ridge")().name == "ridge"


def test_predict_equals_the_offline_protocol(rng: np.random.Generator) -> None:
    m = RidgeReaction().fit(make_set(rng, "follow"), rng=rng)
    inst = make_instance(rng, "follow")
    a = m.predict(inst, n_observed=T0, rng=rng).joints
    b = run_protocol(m, inst, protocol="offline", n_observed=T0, rng=rng).joints
    c = run_protocol(m, inst, protocol="causal", n_observed=T0, rng=rng).joints
    np.testing.assert_allclose(a, b, atol=1e-12)
    np.testing.assert_allclose(b, c, atol=1e-9)  # ridge reads only agent 0's frames ≤ t, so all agree


def test_without_torch_the_registry_works_and_gru_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(gru_module, "torch", None)
    assert "gru" in available_methods() and "ridge" in available_methods()
    with pytest.raises(ConfigError, match=r"socialaff-sim\[neural\]"):
        get_method("gru")()
    data = Dataset("toy", tuple(make_set(np.random.default_rng(0), "follow", 8)))
    done: list[str] = []
    with pytest.raises(ConfigError, match=r"needs PyTorch"):
        evaluate(data, ["hold", "gru"], config=EvaluationConfig(executor="serial", n_folds=2), progress=done.append)
    assert done == []  # refused before any task ran (hold's would have reported)
