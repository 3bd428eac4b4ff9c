"""The model's intent to touch in the simulator: which sub-events make contact (model.contact_keys.contact_types),
the person's held-out hand (sim.contact_targets.offered_hand), the robot moving in toward a contact beyond its
reach (KeyJointScaler.approach) and the intent capture of the completion stage; each decision point inverted
fails a test here."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest
from test_contact_completion import R, scene, settle
from test_retarget import ROBOT, pair

from socialaff_sim.errors import ConfigError
from socialaff_sim.model.contact_keys import CONTACT_END_RADIUS, ContactKeys, contact_types
from socialaff_sim.retarget.contact_completion import ContactCompletion, ContactCompletionConfig
from socialaff_sim.retarget.model_source import ModelSource
from socialaff_sim.retarget.scaling import KeyJointScaler, ScalingConfig
from socialaff_sim.sim.contact_targets import offered_hand

FPS = 10.0  # the toy pair's frame rate


def _ends(gaps: list[float]) -> np.ndarray:
    """(S, 11, 3) end configurations: agent 1's right wrist (model index 7) ``gaps[s]`` from agent 0's right
    wrist (index 2), everything else far apart."""
    S = len(gaps)
    ends = np.arange(S * 11 * 3, dtype=np.float64).reshape(S, 11, 3) * 10.0
    for s, g in enumerate(gaps):
        ends[s, 2] = (0.0, 0.0, 1.0)
        ends[s, 7] = (g, 0.0, 1.0)
    return ends


def test_contact_types_are_the_touching_end_configurations_and_the_keyframes() -> None:
    r = CONTACT_END_RADIUS
    keys = ContactKeys.empty(4)
    keys.phase[3, 2] = 0.5  # a touch inside the interval, released before its end (a high five's strike)
    got = contact_types(_ends([r - 0.01, r + 0.01, 1.0, 1.0]), keys)
    assert got.tolist() == [True, False, False, True]
    # The object (index 10) counts as a mate too; NaN (no object) never does.
    ends = _ends([1.0, 1.0])
    ends[0, 10] = ends[0, 7] + (0.05, 0.0, 0.0)
    ends[1, 10] = np.nan
    assert contact_types(ends, ContactKeys.empty(2)).tolist() == [True, False]


def test_model_source_flags_the_contact_types_and_the_keyframe_ones_likeliest_predecessors() -> None:
    S = 4
    keys = ContactKeys.empty(S)
    # Type 2 touches; 1 → 2 is the likeliest transition from 1, 0 → 3 from 0.
    trans = np.array([[0.0, 0.2, 0.1, 0.7], [0.0, 0.0, 0.9, 0.1], [0.5, 0.0, 0.0, 0.5], [0.9, 0.1, 0.0, 0.0]])
    model = SimpleNamespace(mean_end_=_ends([1.0, 1.0, 0.05, 1.0]), contact_keys_=keys, transitions_=trans)
    source = ModelSource(model)  # type: ignore[arg-type]
    assert source.contact_types.tolist() == [False, False, True, False]
    assert not source.contact_inside_types.any() and not source.contact_inside_next_types.any()
    # Type 2's touch a keyframe inside the interval instead: it and type 1 (2's likeliest predecessor) lead.
    keys.phase[2, 2] = 0.5
    model.mean_end_ = _ends([1.0, 1.0, 1.0, 1.0])
    source = ModelSource(model)  # type: ignore[arg-type]
    assert source.contact_types.tolist() == [False, False, True, False]
    assert source.contact_inside_types.tolist() == [False, False, True, False]
    assert source.contact_inside_next_types.tolist() == [False, True, True, False]


def test_the_offered_hand_is_the_one_farther_from_the_base() -> None:
    keys = np.array([[0.0, 0.0, 1.0], [0.05, 0.2, 0.75], [0.3, -0.2, 1.8], [0.0, 0.1, 0.1], [0.0, -0.1, 0.1]])
    assert offered_hand(keys) == 1
    keys[[1, 2]] = keys[[2, 1]]
    assert offered_hand(keys) == 0
    keys[1] = np.nan  # the raised hand unseen: the other one
    assert offered_hand(keys) == 1


def _far_pair() -> tuple[KeyJointScaler, np.ndarray, np.ndarray, np.ndarray]:
    """A scaler placed without contact samples (agents 3 m apart), agent 1's keys, agent 0's joints, and a
    point held out 1.4 m in front of agent 0, 0.1 m above the robot's shoulders (its arm is 0.4 m long)."""
    inter = pair(distance=3.0)
    scaler = KeyJointScaler(ROBOT, ScalingConfig(body_clearance=0.0, approach_speed=1.0))
    scaler.reset(inter, np.zeros(3))
    return scaler, np.array(inter.key_joints()[0, 1]), np.array(inter.joints[0, 0]), np.array([1.4, 0.0, 1.0])


def _shoulder_gap(scaler: KeyJointScaler, out: np.ndarray, point: np.ndarray) -> float:
    """Distance from the nearer robot shoulder to ``point``, the shoulders placed from the scaled base ``out[0]``."""
    base = scaler.frame.to_world(out[:1])[0]
    shoulders = base[None] + ROBOT.shoulders @ scaler.frame.rotation.T
    return float(np.linalg.norm(shoulders - point, axis=1).min())


def test_approach_moves_the_base_in_at_the_approach_speed_until_the_point_is_in_reach() -> None:
    scaler, keys, partner, point = _far_pair()
    assert scaler.contact_k is None and not np.isfinite(scaler.stand_cap)
    start = scaler(keys, partner)
    assert _shoulder_gap(scaler, start, point) > ROBOT.arm
    dist = [float(np.linalg.norm(scaler.frame.to_world(start[:1])[0, :2] - partner[0, :2]))]
    moved = False
    for _ in range(60):
        moved |= scaler.approach(point, np.array([1]), keys, partner)
        out = scaler(keys, partner)
        dist.append(float(np.linalg.norm(scaler.frame.to_world(out[:1])[0, :2] - partner[0, :2])))
    steps = -np.diff(dist)
    assert moved and steps[0] > 0 and (steps >= -1e-12).all() and steps.max() <= 1.0 / FPS + 1e-9
    # It stops where the shoulders (0.2 m to either side, both alike) are max_extension of the arm from the point.
    np.testing.assert_allclose(_shoulder_gap(scaler, out, point), 0.9 * ROBOT.arm, atol=1e-6)
    # Already within reach: nothing more.
    assert not scaler.approach(point, np.array([1]), keys, partner)


def test_approach_does_nothing_without_online_placement_or_for_a_point_no_placement_reaches() -> None:
    scaler, keys, partner, point = _far_pair()
    fixed = KeyJointScaler(ROBOT, dataclasses.replace(scaler.config, online_placement=False))
    fixed.reset(pair(distance=3.0), np.zeros(3))
    assert not fixed.approach(point, np.array([1]), keys, partner)
    high = point + (0.0, 0.0, 2.0)  # 2 m above the robot's shoulders: no standing place reaches it
    assert not scaler.approach(high, np.array([1]), keys, partner)
    assert not np.isfinite(scaler.stand_cap)


def test_the_models_own_walk_in_is_not_added_to_the_approach() -> None:
    scaler, keys, partner, point = _far_pair()
    for _ in range(60):
        scaler.approach(point, np.array([1]), keys, partner)
        scaler(keys, partner)
    cap = scaler.stand_cap
    assert np.isfinite(cap)
    # Agent 1 walks in by itself to well within the cap: the robot stands where the model alone puts it.
    closer = keys.copy()
    closer[:, 0] -= 2.0
    plain = KeyJointScaler(ROBOT, scaler.config)
    plain.reset(pair(distance=3.0), np.zeros(3))
    np.testing.assert_allclose(scaler(closer, partner)[0], plain(closer, partner)[0], atol=1e-12)
    assert float(np.linalg.norm(scaler.frame.to_world(scaler(closer, partner)[:1])[0, :2])) < cap


def test_negative_approach_speed_is_refused() -> None:
    with pytest.raises(ConfigError, match="approach_speed"):
        ScalingConfig(approach_speed=-1.0)


def test_intent_captures_a_person_hand_the_model_is_not_yet_reaching_for_only_when_meant() -> None:
    c = ContactCompletionConfig()
    assert c.intent and c.approach
    far = dataclasses.replace(scene(c.capture + 0.2), intent=True, inside=True)
    out = settle(ContactCompletion(c), far)
    expected = ContactCompletion(c).contact_targets(far)[1, 0]
    np.testing.assert_allclose(out[1], expected, atol=1e-12)
    # The source not meaning to touch, or the switch off: the model's target.
    np.testing.assert_array_equal(settle(ContactCompletion(c), dataclasses.replace(far, intent=False)), far.wrist_target)
    off = ContactCompletion(dataclasses.replace(c, intent=False))
    np.testing.assert_array_equal(settle(off, far), far.wrist_target)
    # A contact at the sub-event's end (a handshake's): the model's own end configuration reaches it; not captured.
    np.testing.assert_array_equal(settle(ContactCompletion(c), dataclasses.replace(far, inside=False)), far.wrist_target)


def test_intent_captures_an_object_only_while_it_flies() -> None:
    c = ContactCompletionConfig()
    ball = dataclasses.replace(scene(c.capture + 0.2, shared=True), intent=True, free=True)
    out = settle(ContactCompletion(c), ball)
    np.testing.assert_allclose(out[1], ContactCompletion(c).contact_targets(ball)[1, 0], atol=1e-12)
    held = dataclasses.replace(ball, free=False)  # a cup the person still carries: met as the model meets it
    np.testing.assert_array_equal(settle(ContactCompletion(c), held), held.wrist_target)


@pytest.mark.parametrize("shared", [False, True])
def test_intent_keeps_the_reach_gate(shared: bool) -> None:
    c = ContactCompletionConfig()
    # The shoulder 1.5 m behind: the contact lies far beyond the arm's reach, whatever the intent.
    x = dataclasses.replace(scene(c.capture + 0.2, shoulder_x=-1.5, shared=shared), intent=True, inside=not shared,
                            free=shared)
    np.testing.assert_array_equal(settle(ContactCompletion(c), x), x.wrist_target)


def test_intent_prefers_the_hand_that_reaches_the_persons_hand() -> None:
    c = ContactCompletionConfig()
    x = dataclasses.replace(scene(c.capture + 0.2), intent=True, inside=True)
    # The left hand: farther by intended gap (0.9 m) but its shoulder within reach of the anchor; the right
    # hand's shoulder 1.2 m from it (beyond the 1 m arm).
    wrist_now = x.wrist_now.copy()
    nearest = x.nearest.copy()
    nearest[0, 0] = (0.5, 0.3, 1.2)
    wrist_now[0] = (0.4, 0.3, 1.2)
    target = x.wrist_target.copy()
    target[0] = wrist_now[0] - (0.4, 0.0, 0.0)
    shoulder = np.array([[0.3, 0.3, 1.2], [-0.2, 0.0, 1.2]])
    y = dataclasses.replace(x, wrist_now=wrist_now, nearest=nearest, wrist_target=target, shoulder=shoulder)
    stage = ContactCompletion(c)
    settle(stage, y)
    assert stage.anchor.tolist() == [0, -1] and stage.weight[0] == 1.0
    # Without intent neither hand is within the capture distance: nothing.
    plain = ContactCompletion(c)
    settle(plain, dataclasses.replace(y, intent=False))
    assert plain.anchor.tolist() == [-1, -1]


@pytest.mark.parametrize("keep", [False, True])
def test_keep_holds_the_person_hand_being_completed(keep: bool) -> None:
    c = ContactCompletionConfig(keep=keep)
    stage = ContactCompletion(c)
    first = scene(0.05, anchors=2)  # the model's right hand for the anchor at y = 0 (the other at y = 0.3)
    settle(stage, first, frames=3)
    assert stage.anchor[1] == 0
    # The model's wrist drifts toward the other hand: both within the capture distance, the other one nearer.
    target = first.wrist_target.copy()
    target[1, 1] += 0.2
    drift = dataclasses.replace(first, wrist_target=target)
    gaps = stage.intended_gaps(drift)[1]
    assert gaps[1] < gaps[0] < c.capture
    stage(drift, 3, 0.1)
    assert stage.anchor[1] == (0 if keep else 1)


def test_reach_carried_captures_a_carried_object_for_the_nearer_hand_only_when_on() -> None:
    c = ContactCompletionConfig()
    assert not c.reach_carried
    cup = scene(c.capture + 0.2, shared=True)  # carried (free=False), within reach, beyond the capture distance
    # Off (the default): a carried object beyond the capture distance is met where the model meets it.
    np.testing.assert_array_equal(settle(ContactCompletion(c), cup), cup.wrist_target)
    on = dataclasses.replace(c, reach_carried=True)
    stage = ContactCompletion(on)
    out = settle(stage, cup)
    np.testing.assert_allclose(out[1], ContactCompletion(on).contact_targets(cup)[1, 0], atol=1e-12)
    # Only the hand of smallest intended gap (the right; the left is 2 m away): the left keeps the model's target.
    assert stage.anchor.tolist() == [-1, 0] and stage.weight.tolist() == [0.0, 1.0]
    np.testing.assert_array_equal(out[0], cup.wrist_target[0])


def test_reach_carried_leaves_a_free_object_a_disallowed_one_and_one_beyond_reach_alone() -> None:
    on = ContactCompletionConfig(reach_carried=True)
    cup = scene(on.capture + 0.2, shared=True)
    for x in (dataclasses.replace(cup, free=True),  # let go: only the intended gap (or intent) captures it
              dataclasses.replace(cup, allowed=np.zeros((2, 1), dtype=bool)),  # the task does not want it now
              scene(on.capture + 0.2, shared=True, shoulder_x=-1.5)):  # beyond the arm's reach
        np.testing.assert_array_equal(settle(ContactCompletion(on), x), x.wrist_target)


def test_reach_carried_picks_the_hand_of_smallest_intended_gap() -> None:
    on = ContactCompletionConfig(reach_carried=True)
    cup = scene(on.capture + 0.2, shared=True)
    # Bring the left hand nearer than the right (intended gap 0.4 vs the right's 0.5 m), its shoulder within reach.
    nearest, wrist_now = cup.nearest.copy(), cup.wrist_now.copy()
    nearest[0, 0] = (1.0 - R - 0.4, 0.05, 1.2)
    wrist_now[0] = nearest[0, 0] - (0.1, 0.0, 0.0)
    target = cup.wrist_target.copy()
    target[0] = wrist_now[0]
    shoulder = cup.shoulder.copy()
    shoulder[0] = (0.3, 0.05, 1.2)
    x = dataclasses.replace(cup, nearest=nearest, wrist_now=wrist_now, wrist_target=target, shoulder=shoulder)
    gaps = ContactCompletion(on).intended_gaps(x)[:, 0]
    assert gaps[0] < gaps[1]
    stage = ContactCompletion(on)
    settle(stage, x)
    assert stage.anchor.tolist() == [0, -1] and stage.weight[0] == 1.0
    # The nearer hand not allowed on it: the other, allowed hand reaches for it.
    only_right = dataclasses.replace(x, allowed=np.array([[False], [True]]))
    stage = ContactCompletion(on)
    settle(stage, only_right)
    assert stage.anchor.tolist() == [-1, 0] and stage.weight[1] == 1.0
