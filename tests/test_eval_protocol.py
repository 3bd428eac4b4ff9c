"""Evaluation protocols (causal, paper, offline) enforced by the evaluator; the hold and constvel baselines."""

from __future__ import annotations

import json
import math
from collections.abc import Sequence

import numpy as np
import pytest
from scipy import integrate
from test_body_fit import KINECT, place, standing_skeleton
from test_evaluation import toy_dataset, toy_interaction

from socialaff_sim.baselines.simple import ConstantVelocity, ConstVelConfig, HoldPose, damped_displacement, velocity_estimate
from socialaff_sim.data import Interaction
from socialaff_sim.errors import ConfigError, ModelError
from socialaff_sim.evaluation import Prediction, get_method, key_joint_error, observed_part
from socialaff_sim.inference.protocol import StreamingMethod, prediction_from_joints, protocol_view
from socialaff_sim.evaluation.streaming import PrefixReactor, run_protocol, schedule
from socialaff_sim.inference import AffordanceMethod, BodyFitter, SynthesisConfig, synthesize

T0 = 10


# -- schedules ------------------------------------------------------------------------------------
def test_schedules_say_what_each_protocol_shows() -> None:
    assert list(schedule("causal", 14, T0)) == [(11, 10, 11), (12, 11, 12), (13, 12, 13), (14, 13, 14)]
    assert list(schedule("paper", 23, T0)) == [(11, 10, 15), (16, 15, 20), (21, 20, 23)]
    assert list(schedule("offline", 23, T0)) == [(23, 10, 23)]
    with pytest.raises(ConfigError, match="protocol: expected"):
        list(schedule("future", 23, T0))


# -- enforcement ----------------------------------------------------------------------------------
class _Spy:
    """Records every view it is shown and answers with agent 0's latest visible base, held."""

    name = "spy"

    def __init__(self) -> None:
        self.calls: list[tuple[int, int, int]] = []
        self.peeks: list[bool] = []

    def fit(self, interactions: Sequence[Interaction], *, rng: np.random.Generator) -> _Spy:
        return self

    def predict(self, interaction: Interaction, *, n_observed: int, rng: np.random.Generator) -> Prediction:
        raise AssertionError("the evaluator uses start/react when a method has them")

    def start(self, *, n_observed: int, offline: bool, rng: np.random.Generator) -> _Spy:
        return self

    def react(self, view: Interaction, start: int, stop: int) -> Prediction:
        self.calls.append((view.n_frames, start, stop))
        assert view.subevents is None and np.isnan(view.joints[T0:, 1]).all()
        try:  # a method reading agent 0 one frame ahead of the current one
            view.joints[start + 1]
            self.peeks.append(True)
        except IndexError:
            self.peeks.append(False)
        joints = np.repeat(view.joints[-1:, 0], stop - start, axis=0)
        keys = np.repeat(view.key_joints()[-1:, 0], stop - start, axis=0)
        return Prediction(joints, keys, None, 0)


@pytest.mark.parametrize("protocol", ["causal", "paper", "offline"])
def test_the_evaluator_shows_only_what_the_protocol_allows(rng: np.random.Generator, protocol: str) -> None:
    inst = toy_interaction(rng, "shake_hands", ("a", "b"), 0, n_frames=27)
    spy = _Spy()
    assert isinstance(spy, StreamingMethod)
    pred = run_protocol(spy, inst, protocol=protocol, n_observed=T0, rng=rng)
    calls = np.array(spy.calls)
    if protocol == "offline":
        assert spy.calls == [(27, T0, 27)] and spy.peeks == [True]
    else:
        # frames [start, stop) from a view of frames [0, start]: agent 0's frame start + 1 does not exist
        np.testing.assert_array_equal(calls[:, 0], calls[:, 1] + 1)
        assert not any(spy.peeks)
        step = 1 if protocol == "causal" else 5
        np.testing.assert_array_equal(calls[:, 1], np.arange(T0, 27, step))
        np.testing.assert_array_equal(calls[:, 2], np.minimum(calls[:, 1] + step, 27))
        # so each produced frame t holds agent 0 at the start of its block, never later
        first = np.repeat(calls[:, 1], calls[:, 2] - calls[:, 1])
        np.testing.assert_array_equal(pred.joints[T0:], inst.joints[first, 0])
    np.testing.assert_array_equal(pred.joints[:T0], inst.joints[:T0, 1])


class _Oracle:
    """Predicts agent 1 at frame t as agent 0's recorded pose at frame t + 3: a method that reads the future."""

    name = "oracle"

    def fit(self, interactions: Sequence[Interaction], *, rng: np.random.Generator) -> _Oracle:
        return self

    def predict(self, interaction: Interaction, *, n_observed: int, rng: np.random.Generator) -> Prediction:
        a0 = interaction.filled_joints()[:, 0]
        ahead = a0[np.minimum(np.arange(interaction.n_frames) + 3, interaction.n_frames - 1)]
        return prediction_from_joints(interaction, ahead, n_observed=n_observed)


def test_a_method_that_reads_the_future_gets_nothing_from_it(rng: np.random.Generator) -> None:
    inst = toy_interaction(rng, "shake_hands", ("a", "b"), 0, n_frames=30)
    T = inst.n_frames
    lead = np.minimum(np.arange(T) + 3, T - 1)
    # agent 1 is agent 0 three frames ahead: exactly what the oracle would read
    leader = inst.replace(joints=np.stack([inst.joints[:, 0], inst.joints[lead, 0]], axis=1))
    oracle = _Oracle()
    offline = run_protocol(oracle, leader, protocol="offline", n_observed=T0, rng=rng)
    assert key_joint_error(offline, leader) < 1e-12
    causal = run_protocol(oracle, leader, protocol="causal", n_observed=T0, rng=rng)
    # causally the future is held at the latest frame: the oracle can only say agent 0's frame t
    expected = np.linalg.norm(leader.key_joints()[T0:, 0] - leader.key_joints()[T0:, 1], axis=-1).mean()
    np.testing.assert_allclose(key_joint_error(causal, leader), expected, rtol=1e-12)
    assert expected > 0.01
    assert isinstance(PrefixReactor(oracle, T0, rng), PrefixReactor)


def test_blocks_of_the_wrong_shape_are_refused(rng: np.random.Generator) -> None:
    inst = toy_interaction(rng, "shake_hands", ("a", "b"), 0, n_frames=20)

    class Short(_Spy):
        def react(self, view: Interaction, start: int, stop: int) -> Prediction:
            return super().react(view, start, start + 1 if stop - start > 1 else start + 2)

    with pytest.raises(ModelError, match=r"expected a Prediction of 5 frames"):
        run_protocol(Short(), inst, protocol="paper", n_observed=T0, rng=rng)
    with pytest.raises(ConfigError, match="visible"):
        protocol_view(inst, T0, T0)


def test_causal_affordance_method_equals_the_reactive_synthesizer(shake8, shake8_model) -> None:  # noqa: ANN001
    """Streaming views into the synthesizer changes nothing for a causal configuration: its frame t
    reads agent 0 before t only, so fed frame by frame it must emit what it emits on the whole track."""
    inst = shake8[7]
    method = AffordanceMethod("full")
    method.models_, method.model_ = [shake8_model], shake8_model
    method.body_ = BodyFitter().fit_interactions(list(shake8)[:6], agent=1, rng=np.random.default_rng(0))
    pred = run_protocol(method, inst, protocol="causal", n_observed=T0, rng=np.random.default_rng(3))
    keys = synthesize(shake8_model, observed_part(inst, T0), rng=np.random.default_rng(3),
                      config=SynthesisConfig.reactive(n_observed=T0))[0]
    np.testing.assert_allclose(pred.key_joints[T0:], keys[T0:], rtol=0, atol=1e-12)
    assert np.isfinite(pred.joints).all()
    # offline, the method runs its lookahead configuration on the whole track (an upper bound)
    off = run_protocol(method, inst, protocol="offline", n_observed=T0, rng=np.random.default_rng(3))
    ref = synthesize(shake8_model, observed_part(inst, T0), rng=np.random.default_rng(3),
                     config=SynthesisConfig.offline(n_observed=T0))[0]
    np.testing.assert_allclose(off.key_joints[T0:], ref[T0:], rtol=0, atol=1e-12)


# -- hold and constvel ----------------------------------------------------------------------------
def _mover(T: int = 24, fps: float = 10.0) -> Interaction:
    """Agent 1 walks at a constant 0.05 m/frame along x while raising its arm linearly; agent 0 stands."""
    t = np.arange(T, dtype=np.float64)
    a0 = place(standing_skeleton(np.zeros(T)), np.zeros(2), 0.0)
    body = standing_skeleton(0.02 * t)
    a1 = np.stack([place(body[k : k + 1], np.array([1.2 + 0.05 * k, 0.0]), np.pi)[0] for k in range(T)])
    return Interaction("shake_hands", fps, np.stack([a0, a1], axis=1), KINECT.joint_names, ("a", "b"))


@pytest.mark.parametrize("protocol", ["causal", "paper", "offline"])
def test_hold_keeps_the_last_observed_pose(protocol: str) -> None:
    inst = _mover()
    method = get_method("hold")().fit([inst], rng=np.random.default_rng(0))
    pred = run_protocol(method, inst, protocol=protocol, n_observed=T0, rng=np.random.default_rng(0))
    np.testing.assert_array_equal(pred.joints[T0:], np.repeat(inst.joints[T0 - 1 : T0, 1], inst.n_frames - T0, axis=0))
    keys = [inst.layout.key_indices[k] for k in range(5)]
    np.testing.assert_array_equal(pred.key_joints[T0:], np.repeat(inst.joints[T0 - 1 : T0, 1, keys], inst.n_frames - T0, axis=0))


def test_velocity_estimate_is_the_least_squares_slope(rng: np.random.Generator) -> None:
    x = rng.normal(size=(5, 4, 3))
    ref = np.polyfit(np.arange(5.0), x.reshape(5, -1), 1)[0].reshape(4, 3)
    np.testing.assert_allclose(velocity_estimate(x), ref, rtol=1e-10, atol=1e-12)


def test_damped_displacement_integrates_the_decaying_velocity() -> None:
    v, tau = np.array([0.3, -0.2, 0.05]), 7.0
    steps = np.array([0, 1, 4, 25])
    got = damped_displacement(v, steps, tau)
    for k, row in zip(steps, got, strict=True):
        ref = integrate.quad(lambda s: math.exp(-s / tau), 0.0, float(k))[0] * v
        np.testing.assert_allclose(row, ref, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(damped_displacement(v, steps, math.inf), steps[:, None] * v[None], rtol=1e-12)


def test_constvel_continues_the_observed_motion() -> None:
    inst = _mover(fps=10.0)
    T = inst.n_frames
    seen = inst.joints[:T0, 1]
    undamped = ConstantVelocity(ConstVelConfig(time_constant_s=math.inf)).fit([inst], rng=np.random.default_rng(0))
    pred = run_protocol(undamped, inst, protocol="causal", n_observed=T0, rng=np.random.default_rng(0))
    k = np.arange(1, T - T0 + 1)[:, None, None]
    slope = np.polyfit(np.arange(5.0), seen[-5:].reshape(5, -1), 1)[0].reshape(seen.shape[1:])
    np.testing.assert_allclose(pred.joints[T0:], seen[-1][None] + k * slope[None], rtol=0, atol=1e-9)
    base = KINECT.index("spine_base")
    # the base moves 0.05 m/frame along -x in the world (agent 1 faces back): continued exactly
    np.testing.assert_allclose(pred.joints[T0:, base, 0] - seen[-1, base, 0], 0.05 * k[:, 0, 0], atol=1e-9)
    damped = get_method("constvel")().fit([inst], rng=np.random.default_rng(0))
    out = run_protocol(damped, inst, protocol="paper", n_observed=T0, rng=np.random.default_rng(0))
    tau = 1.0 * 10.0  # the default 1 s at 10 fps, in frames
    np.testing.assert_allclose(out.joints[T0:], seen[-1][None] + tau * (1 - np.exp(-k / tau)) * slope[None], atol=1e-9)
    for bad in ({"window": 1}, {"time_constant_s": 0.0}):
        with pytest.raises(ConfigError):
            ConstVelConfig(**bad)  # type: ignore[arg-type]


def test_trivial_baselines_need_fit_and_ignore_agent_zero(rng: np.random.Generator) -> None:
    data = toy_dataset(seed=3, per_pair=1)
    inst = data.interactions[0]
    for cls in (HoldPose, ConstantVelocity):
        with pytest.raises(Exception, match="fit"):
            cls().start(n_observed=T0, offline=False, rng=rng)
        method = cls().fit(list(data.interactions), rng=rng)
        a = run_protocol(method, inst, protocol="causal", n_observed=T0, rng=rng)
        moved = inst.replace(joints=np.concatenate([inst.joints[:, :1] + 0.5, inst.joints[:, 1:]], axis=1))
        b = run_protocol(method, moved, protocol="causal", n_observed=T0, rng=rng)
        np.testing.assert_array_equal(a.joints, b.joints)


# -- causal ProMP -------------------------------------------------------------------------------
def _scaled(duration: int, k: int) -> Interaction:
    """One arm raise and lowering stretched over ``duration`` frames; agent 1 mirrors it (phase only)."""
    s = np.arange(duration) / (duration - 1)
    a0 = place(standing_skeleton(1.2 * np.sin(np.pi * s)), np.zeros(2), 0.0)
    a1 = place(standing_skeleton(1.0 * np.sin(np.pi * s) ** 2), np.array([1.2, 0.0]), np.pi)
    return Interaction("wave", 10.0, np.stack([a0, a1], axis=1), KINECT.joint_names, (f"a{k}", f"b{k}"),
                       instance_id=f"wave_{k}")


def test_causal_promp_estimates_the_duration_from_the_prefix() -> None:
    from socialaff_sim.baselines.promp import InteractionProMP

    train = [_scaled(d, k) for k, d in enumerate((20, 25, 30, 35, 40))]
    promp = InteractionProMP().fit(train, rng=np.random.default_rng(0))
    assert {20, 30, 40} <= set(promp.durations_.tolist())
    inst = _scaled(30, 9)
    for seen in (12, 18, 24):
        assert promp.estimate_duration(protocol_view(inst, seen, T0), seen) == 30
    # never shorter than the frames asked for
    assert promp.estimate_duration(protocol_view(inst, 24, T0), 33) >= 33
    causal = run_protocol(promp, inst, protocol="causal", n_observed=T0, rng=np.random.default_rng(0))
    offline = run_protocol(promp, inst, protocol="offline", n_observed=T0, rng=np.random.default_rng(0))
    # with the duration found, the causal prediction is close to the one that knows it
    assert key_joint_error(causal, inst) < key_joint_error(offline, inst) + 0.05


# -- results name their protocol, split and preset ------------------------------------------------
def test_results_and_tables_name_protocol_split_and_preset(tmp_path) -> None:  # noqa: ANN001
    from socialaff_sim.cli.main import main
    from socialaff_sim.data import Dataset, save_dataset
    from socialaff_sim.evaluation import EvaluationConfig, evaluate, format_tables, write_results
    from socialaff_sim.evaluation.runner import best_baseline

    data = toy_dataset(seed=5, per_pair=2)
    cont = Dataset("cont", tuple(i.replace(source=f"one.npz @ {k}") for k, i in enumerate(data.interactions)))
    res = evaluate(cont, ["hold", "constvel", "promp"],
                   config=EvaluationConfig(n_folds=2, protocol="offline", split="block", executor="serial"))
    assert (res["protocol"], res["split"], res["preset"]) == ("offline", "block", "default")
    assert res["upper_bound"] and res["optimistic"]
    table = format_tables(res)
    assert "upper bound" in table and "optimistic" in table and "offline protocol" in table.splitlines()[0]
    averages = {m: res["average"][m]["key_joint_error_m"] for m in res["average"]}
    assert res["paired"]["best_baseline"]["reference"] == min(averages, key=averages.get) == best_baseline(res["average"])
    for m, cell in res["paired"]["hold"]["differences"]["key_joint_error_m"].items():
        np.testing.assert_allclose(cell["mean_m"], averages[m] - averages["hold"], rtol=1e-9)
    paths = write_results(res, tmp_path / "out")
    assert '"protocol": "offline"' in paths["json"].read_text()
    causal = evaluate(data, ["hold"], config=EvaluationConfig(n_folds=2, max_folds=1, executor="serial"))
    assert not causal["upper_bound"] and "upper bound" not in format_tables(causal)
    assert "only the first 1 of the 2 folds" in causal["title"]
    assert {r["fold"] for r in causal["per_instance"]["shake_hands"]["hold"]} == {0}

    save_dataset(data, tmp_path / "data")
    out = tmp_path / "cli"
    assert main(["evaluate", "--data", f"npz:{tmp_path / 'data'}", "--methods", "hold,constvel", "--folds", "2",
                 "--protocol", "paper", "--split", "recording", "--out", str(out), "--executor", "serial", "--quiet"]) == 0
    saved = json.loads((out / "results.json").read_text())
    assert (saved["protocol"], saved["split"], saved["settings"]["protocol"]) == ("paper", "recording", "paper")
    assert main(["evaluate", "--data", f"npz:{tmp_path / 'data'}", "--methods", "hold", "--split", "actor",
                 "--out", str(out), "--executor", "serial"]) == 2  # toy pairs share no actors across pairs
    # argparse's choices: exit 2 with the valid protocols
    assert main(["evaluate", "--data", f"npz:{tmp_path / 'data'}", "--methods", "hold", "--protocol", "future",
                 "--out", str(out)]) == 2


def test_extend_held_adds_frames_that_carry_no_information(rng: np.random.Generator) -> None:
    inst = toy_dataset(seed=6, labels=("hand_over",), per_pair=1).interactions[0]
    T = inst.n_frames
    longer = inst.extend_held(T + 4)
    assert longer.n_frames == T + 4 and inst.extend_held(T) is inst and inst.extend_held(T - 3) is inst
    assert not np.asarray(longer.valid)[T:].any() and np.isnan(longer.joints[T:]).all()
    np.testing.assert_array_equal(longer.filled_joints()[T:], np.repeat(inst.joints[-1:], 4, axis=0))
    np.testing.assert_array_equal(longer.object[T:], np.repeat(inst.object[-1:], 4, axis=0))
    assert (longer.subevents[T:] == -1).all() and longer.same_as(longer.slice(0, T + 4))
    assert inst.same_as(longer.slice(0, T))


def test_preset_reaches_the_affordance_methods_only() -> None:
    import dataclasses

    from socialaff_sim.evaluation.crossval import make_method
    from socialaff_sim.inference.presets import preset
    from socialaff_sim.model.config import AffordanceConfig

    paper = preset("paper")
    for name, changes in (("full", {}), ("v1", {"use_grouping": False}), ("v2", {"use_subevents": False})):
        m = make_method(get_method(name), "paper")
        assert m.model_config == dataclasses.replace(paper.affordance, **changes)
        assert m.learning == paper.learning and m.synthesis == paper.synthesis == m.offline_synthesis
        d = make_method(get_method(name), "default")
        assert d.model_config == dataclasses.replace(AffordanceConfig(), **changes)
        assert d.synthesis == SynthesisConfig.reactive() and d.offline_synthesis == SynthesisConfig.offline()
        assert m.chains == d.chains == 1  # one fit per fold, like every baseline
    assert isinstance(make_method(get_method("hold"), "paper"), HoldPose)
