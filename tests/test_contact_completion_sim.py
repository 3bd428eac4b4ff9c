"""Contact completion inside the simulator: causal, switchable, and what it does in physics on `ours`."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.inference import SynthesisConfig
from socialaff_sim.learning import SocialAffordanceModel
from socialaff_sim.learning.config import LearningConfig
from socialaff_sim.retarget.model_source import ModelSource
from socialaff_sim.sim.contact_targets import ContactAnchors, object_radius
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.human import HumanPose
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.tasks import load_task

OFF = dataclasses.replace(SimConfig(), contact_completion=None)


def _shake_frame(inter) -> int:  # noqa: ANN001
    """The middle frame of the recorded shake."""
    names = inter.subevent_names
    shake = np.flatnonzero(np.asarray(inter.subevents) == names.index("shake"))
    return int(shake[len(shake) // 2])


def test_completion_reads_nothing_after_frame_t_and_can_be_switched_off(shake8) -> None:  # noqa: ANN001
    inter = list(shake8)[7]
    t = _shake_frame(inter)
    keys = inter.key_joints()[t, 1]
    recorded = inter.key_joints()[:, 1]
    sim = Simulator("ours", "shake_hands", SimConfig.harness())
    sim.reset(inter)
    sim.settle(sim.retarget(recorded[0], frame=0))
    while sim.frame < t - 1:  # the recorded agent 1 up to the frame before
        sim.step(sim.retarget(recorded[sim.frame + 1]))
    out = sim.retarget(keys, frame=t)
    assert sim._targets.completion is not None and sim._targets.completion.weight.max() > 0  # it engaged at this frame
    # The person's (and the scaler's) frames after t replaced by nonsense: frame t is completed the same way.
    pose = sim.pose
    far = HumanPose(pos=pose.pos.copy(), quat=pose.quat, half_lengths=pose.half_lengths, joints=pose.joints.copy())
    far.pos[t + 1:] += 5.0
    far.joints[t + 1:] += 5.0
    sim.pose = far
    np.testing.assert_array_equal(sim.retarget(keys, frame=t), out)
    sim.pose = pose
    sim._targets.completion = None  # the same state, the stage switched off
    scaled = sim.retarget(keys, frame=t)
    np.testing.assert_allclose(out[[0, 3, 4]], scaled[[0, 3, 4]], atol=1e-12)  # only the wrists change
    assert np.abs(out[1:3] - scaled[1:3]).max() > 0.005
    assert Simulator("ours", "shake_hands", OFF)._targets.completion is None


def test_anchors_follow_the_task_groups() -> None:
    shake = Simulator("ours", "shake_hands", SimConfig.harness())
    inter = generate_dataset(0, SyntheticConfig(interactions=("shake_hands",), instances_per_interaction=1))[0]
    shake.reset(inter)
    anchors = ContactAnchors(shake.scene, shake.task)
    assert anchors.allowed(None, gripped=False).tolist() == [[True, True], [True, True]]
    left_only = dataclasses.replace(shake.task, subgoals=(dataclasses.replace(
        shake.task.subgoals[0], robot="left_hand", human="right_hand", subevents=("shake",)),))
    rule = ContactAnchors(shake.scene, left_only)
    assert rule.allowed("shake", gripped=False).tolist() == [[False, True], [False, False]]
    assert not rule.allowed("reach", gripped=False).any()  # outside its sub-events the task wants nothing
    assert object_radius("cylinder", (0.045, 0.06)) == 0.045 and object_radius("box", (0.1, 0.02, 0.3)) == 0.02
    catch = load_task("throw_catch")
    ball = generate_dataset(0, SyntheticConfig(interactions=("throw_catch",), instances_per_interaction=1))[0]
    sim = Simulator("ours", catch, SimConfig.harness())
    sim.reset(ball)
    objects = ContactAnchors(sim.scene, catch)
    assert objects.allowed(None, gripped=False).tolist() == [[False, False, True], [False, False, True]]
    assert not objects.allowed(None, gripped=True).any()  # once a hand grips the ball, the model carries on


def _contact_span_gap(metrics: dict) -> tuple[int, float]:
    goal = metrics["subgoals"][0]
    now = np.array(goal["in_contact_per_frame"])
    gaps = np.array([np.nan if g is None else g for g in goal["gap_m_per_frame"]])
    touch = np.flatnonzero(now)
    return int(now.sum()), float(np.nanmax(gaps[touch[0]:touch[-1] + 1])) if len(touch) else np.inf


def test_a_synthesized_handshake_on_ours_holds_the_hands_together(shake8, shake8_model) -> None:  # noqa: ANN001
    inter = list(shake8)[7]  # actors a03 and a01: the pair is not among the six fitted
    source = ModelSource(shake8_model, config=SynthesisConfig.reactive())
    on = run_episode(Simulator("ours", "shake_hands", SimConfig.harness()), source, inter)
    assert on["success"]
    frames_on, gap_on = _contact_span_gap(on)
    # From the first touch to the last, the geoms stay within 2 cm (the hands never visibly part).
    assert gap_on <= 0.02
    # The completion's own effect needs a synthesized motion that leaves a gap by itself: on this pair the
    # default's plan (which follows the sub-events' learned order) keeps the hands together even without the
    # completion, the plan without ``ordered`` does not.
    unordered = ModelSource(shake8_model, config=SynthesisConfig.reactive(ordered=False))
    with_completion = run_episode(Simulator("ours", "shake_hands", SimConfig.harness()), unordered, inter)
    without = run_episode(Simulator("ours", "shake_hands", OFF), unordered, inter)
    frames_with, gap_with = _contact_span_gap(with_completion)
    frames_without, gap_without = _contact_span_gap(without)
    assert with_completion["success"]
    assert gap_with <= 0.02 < gap_without
    assert frames_with >= frames_without


@pytest.fixture(scope="module")
def high_five():  # noqa: ANN201
    data = list(generate_dataset(0, SyntheticConfig(interactions=("high_five",), instances_per_interaction=8)))
    model = SocialAffordanceModel(learning=LearningConfig(iterations=3)).fit(data[:6], rng=np.random.default_rng(0))
    return model, data[6]


def test_a_synthesized_high_five_on_ours_meets_palms_above_the_shoulders(high_five) -> None:  # noqa: ANN001
    model, inter = high_five
    sim = Simulator("ours", "high_five", SimConfig.harness())
    heights: list[tuple[float, float, float]] = []

    def watch(s: Simulator, result, subevent) -> None:  # noqa: ANN001
        if result is not None and any(result.subgoals_now.values()):
            d, sc = s.data, s.scene
            hand = max(float(d.geom_xpos[sc.hand_geom[k]][:, 2].mean()) for k in (0, 1))
            person = np.asarray(s.pose.joints[s.frame])
            names = s.interaction.layout.joint_names
            shoulders = [names.index(n) for n in ("left_shoulder", "right_shoulder")]
            heights.append((hand, float(d.xpos[sc.limb_body_ids[:2], 2].max()), float(person[shoulders, 2].max())))

    metrics = run_episode(sim, ModelSource(model, config=SynthesisConfig.reactive()), inter, on_frame=watch)
    assert metrics["success"] and heights
    hand, robot_shoulder, person_shoulder = np.array(heights).T
    assert (hand > robot_shoulder).all() and (hand > person_shoulder).all()


def _far_robot_at_the_strike(inside_next: bool) -> Simulator:
    """A causally placed Stubby whose source keeps agent 1 where it stood at frame 0 (far from the person),
    stepped to the recorded strike's first frame with the given ``contact_inside_next`` flag."""
    inter = list(generate_dataset(0, SyntheticConfig(interactions=("high_five",), instances_per_interaction=8)))[6]
    strike = int(np.flatnonzero(np.asarray(inter.subevents) == inter.subevent_names.index("strike"))[0])
    keys = inter.key_joints()[0, 1]
    sim = Simulator("ours", "high_five", SimConfig.harness())
    sim.reset(inter, placement_frames=10)
    sim.settle(sim.retarget(keys, frame=0))
    while sim.frame < strike:
        sim.step(sim.retarget(keys, contact=inside_next, contact_inside=inside_next, contact_inside_next=inside_next))
    return sim


def test_the_robot_moves_in_toward_a_raised_hand_only_when_the_model_means_a_touch_inside_its_sub_event() -> None:
    still = _far_robot_at_the_strike(False)
    assert not np.isfinite(still.scaler.stand_cap)  # no intent: where the model puts it
    moving = _far_robot_at_the_strike(True)
    assert np.isfinite(moving.scaler.stand_cap)
    d = [float(np.linalg.norm(s.robot_key_frames()[0, :2] - s.frame_R.to_robot(s.pose.joints[s.frame][:1])[0, :2]))
         for s in (still, moving)]
    assert d[1] < d[0] - 0.1  # physically nearer the person
    # Switched off, the flag changes nothing.
    off = dataclasses.replace(SimConfig().contact_completion, approach=False)  # type: ignore[arg-type]
    inter = still.interaction
    sim = Simulator("ours", "high_five", dataclasses.replace(SimConfig(), contact_completion=off))
    sim.reset(inter, placement_frames=10)  # type: ignore[arg-type]
    keys = inter.key_joints()[0, 1]  # type: ignore[union-attr]
    sim.settle(sim.retarget(keys, frame=0))
    while sim.frame < still.frame:
        sim.step(sim.retarget(keys, contact=True, contact_inside=True, contact_inside_next=True))
    assert not np.isfinite(sim.scaler.stand_cap)
