"""Forecast horizons and per-call latency of the evaluation (evaluation.streaming.run_protocol_measured)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pytest
from test_ridge_baseline import T0, make_instance, make_set

from socialaff_sim.baselines.ridge import RidgeReaction
from socialaff_sim.data import Dataset, Interaction
from socialaff_sim.errors import ConfigError
from socialaff_sim.evaluation import EvaluationConfig, Prediction, evaluate, format_tables, get_method
from socialaff_sim.evaluation.metrics import horizon_key_joint_error, horizon_metric, is_horizon_metric
from socialaff_sim.evaluation.runner import _latency
from socialaff_sim.evaluation.streaming import run_protocol, run_protocol_measured


class _Noisy:
    """A stochastic reactor: agent 1's last observed pose plus fresh noise from the run's generator per call;
    it records the views its calls (and its copies' calls) were shown."""

    name = "noisy"

    def __init__(self) -> None:
        self.calls: list[tuple[int, int, int]] = []

    def fit(self, interactions: Sequence[Interaction], *, rng: np.random.Generator) -> _Noisy:
        return self

    def predict(self, interaction: Interaction, *, n_observed: int, rng: np.random.Generator) -> Prediction:
        raise AssertionError("start/react are used")

    def start(self, *, n_observed: int, offline: bool, rng: np.random.Generator) -> _NoisyReactor:
        return _NoisyReactor(self, rng, n_observed)


class _NoisyReactor:
    def __init__(self, method: _Noisy, rng: np.random.Generator, n_observed: int) -> None:
        self.method, self.rng, self.n_observed = method, rng, n_observed

    def react(self, view: Interaction, start: int, stop: int) -> Prediction:
        self.method.calls.append((view.n_frames, start, stop))
        pose = view.joints[self.n_observed - 1, 1]
        joints = pose[None] + self.rng.normal(0, 0.01, size=(stop - start,) + pose.shape)
        return Prediction(joints, view.layout.key_joints(joints), None, 0)


def test_forecasts_see_frames_up_to_t_and_leave_the_run_unchanged(rng: np.random.Generator) -> None:
    inst = make_instance(rng, "follow", T=31)
    plain = run_protocol(_Noisy(), inst, protocol="causal", n_observed=T0, rng=np.random.default_rng(3)).joints
    spy = _Noisy()
    run = run_protocol_measured(spy, inst, protocol="causal", n_observed=T0, rng=np.random.default_rng(3),
                                horizon_frames=5, horizon_every=4)
    np.testing.assert_array_equal(run.prediction.joints, plain)  # the copies draw from their own generators
    np.testing.assert_array_equal(run.forecast_times, [10, 14, 18, 22, 26, 30])
    forecasts = [c for c in spy.calls if c[2] - c[1] == 6]
    assert forecasts == [(t + 1, t, t + 6) for t in run.forecast_times]  # view [0, t], frames t … t + 5
    assert len(run.call_seconds) == len(run.call_frames) == inst.n_frames - T0 and (run.call_frames == 1).all()
    assert (run.call_seconds >= 0).all()
    assert run.forecasts.shape == (6, 6, 5, 3) and np.isnan(run.forecasts[-1, 1:]).all()  # past the end
    paper = run_protocol_measured(_Noisy(), inst, protocol="paper", n_observed=T0, rng=rng, horizon_frames=5, horizon_every=7)
    np.testing.assert_array_equal(paper.forecast_times, [10, 20, 25])  # first block start at or after 10, 17, 24, 31
    offline = run_protocol_measured(_Noisy(), inst, protocol="offline", n_observed=T0, rng=rng, horizon_frames=5)
    assert offline.forecast_times.size == 0 and len(offline.call_seconds) == 1
    with pytest.raises(ConfigError, match="horizons"):
        run_protocol_measured(_Noisy(), inst, protocol="causal", n_observed=T0, rng=rng, horizon_frames=-1)


def test_hold_horizon_error_by_brute_force(rng: np.random.Generator) -> None:
    inst = make_instance(rng, "follow", T=37)
    hold = get_method("hold")().fit([inst], rng=rng)
    run = run_protocol_measured(hold, inst, protocol="causal", n_observed=T0, rng=rng, horizon_frames=10, horizon_every=3)
    last = inst.joints[T0 - 1, 1]
    for k in (2, 5, 10):
        errs = [np.linalg.norm(inst.joints[t + k, 1] - last, axis=-1).mean() for t in range(T0, inst.n_frames, 3)
                if t + k < inst.n_frames]
        assert horizon_key_joint_error(run.forecast_times, run.forecasts, inst, k) == pytest.approx(np.mean(errs), abs=1e-12)


def test_forecasts_ignore_agent0_after_t(rng: np.random.Generator) -> None:
    m = RidgeReaction().fit(make_set(rng, "follow"), rng=rng)
    inst = make_instance(rng, "follow", T=40)
    a = run_protocol_measured(m, inst, protocol="causal", n_observed=T0, rng=rng, horizon_frames=10, horizon_every=5)
    t = 20
    joints = np.array(inst.joints)
    joints[t + 1:, 0] += 0.5
    b = run_protocol_measured(m, inst.replace(joints=joints), protocol="causal", n_observed=T0, rng=rng, horizon_frames=10,
                              horizon_every=5)
    early = a.forecast_times <= t
    np.testing.assert_array_equal(a.forecasts[early], b.forecasts[early])
    assert not np.allclose(a.forecasts[~early][:, :5], b.forecasts[~early][:, :5])
    # a forecast holds agent 0 at frame t: ridge's forecast differs from its causal frames further on
    assert not np.allclose(a.forecasts[1, 10], a.prediction.key_joints[a.forecast_times[1] + 10])


def test_horizon_metric_names() -> None:
    assert horizon_metric(0.5) == "key_joint_error_0.5s_m" and horizon_metric(1.0) == "key_joint_error_1s_m"
    assert is_horizon_metric("key_joint_error_0.2s_m") and not is_horizon_metric("key_joint_error_m")
    assert not is_horizon_metric("key_joint_error_xs_m")


def test_latency_percentiles() -> None:
    lat = _latency(np.arange(1, 101) / 1000.0)  # 1 … 100 ms
    assert lat["p50"] == pytest.approx(50.5) and lat["p99"] == pytest.approx(99.01) and lat["max"] == pytest.approx(100.0)
    assert lat["n_calls"] == 100
    assert _latency(np.zeros(0))["n_calls"] == 0


def test_evaluate_reports_horizons_latency_and_tables(rng: np.random.Generator) -> None:
    data = Dataset("toy", tuple(make_set(rng, "follow", 16)))
    res = evaluate(data, ["hold", "ridge"], config=EvaluationConfig(executor="serial", n_folds=2, horizon_every_s=0.3))
    assert res["horizons_s"] == [0.2, 0.5, 1.0] and res["settings"]["horizon_every_s"] == 0.3
    for m in ("hold", "ridge"):
        assert res["latency_ms"][m]["n_calls"] == 16 * (40 - T0)
        for h in (0.2, 0.5, 1.0):
            assert np.isfinite(res["average"][m][horizon_metric(h)])
    # holding still loses more the further ahead; ridge, which follows agent 0, beats hold at every horizon
    hold = [res["average"]["hold"][horizon_metric(h)] for h in (0.2, 0.5, 1.0)]
    assert hold[0] < hold[1] < hold[2]
    diffs = res["paired"]["hold"]["differences"]
    for h in (0.2, 0.5, 1.0):
        assert diffs[horizon_metric(h)]["ridge"]["verdict"] == "lower"
    text = format_tables(res)
    assert "## Key-joint error at forecast horizons (m)" in text and "h = 0.5 s" in text
    assert "## Latency per call (ms)" in text and "one call per synthesized frame" in text
    none = evaluate(data, ["hold"], config=EvaluationConfig(executor="serial", n_folds=2, horizons_s=()))
    assert none["horizons_s"] == [] and "forecast horizons" not in format_tables(none)
    with pytest.raises(ConfigError, match="horizons_s"):
        EvaluationConfig(horizons_s=(0.0,))
