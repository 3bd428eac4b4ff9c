"""Contact completion (retarget/contact_completion.py): every decision point, against hand-worked geometry."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.contact_completion import CompletionInput, ContactCompletion, ContactCompletionConfig
from socialaff_sim.retarget.scaling import smoothstep

DT = 0.1
R = 0.05  # anchor radius (a person's hand sphere)


def scene(gap_model: float, *, hand_gap_now: float = 0.2, shoulder_x: float = 0.0, arm: float = 1.0,
          allowed: bool = True, shared: bool = False, anchors: int = 1) -> CompletionInput:
    """One anchor on the x axis at x = 1; the right hand's nearest point now ``hand_gap_now`` short of its
    surface (the wrist 0.1 m behind it); the model's wrist target such that the hand would stop ``gap_model``
    short of the surface. The left hand far away. With ``anchors`` = 2 a second anchor at y = 0.3."""
    centre = np.array([[1.0, 0.0, 1.2], [1.0, 0.3, 1.2]])[:anchors]
    near_x = 1.0 - R - hand_gap_now
    nearest = np.zeros((2, anchors, 3))
    nearest[1, :] = [near_x, 0.0, 1.2]
    nearest[0, :] = [0.0, 2.0, 1.2]
    wrist_now = np.array([[-0.1, 2.0, 1.2], [near_x - 0.1, 0.0, 1.2]])
    target = wrist_now.copy()
    target[1, 0] += hand_gap_now - gap_model
    return CompletionInput(
        wrist_target=target, wrist_now=wrist_now, nearest=nearest, centre=centre, radius=np.full(anchors, R),
        shared=np.full(anchors, shared), allowed=np.full((2, anchors), allowed),
        shoulder=np.array([[shoulder_x, 2.0, 1.2], [shoulder_x, 0.0, 1.2]]), arm=arm,
    )


def settle(stage: ContactCompletion, x: CompletionInput, frames: int = 10) -> np.ndarray:
    out = x.wrist_target
    for t in range(frames):
        out = stage(x, t, DT)
    return out


@pytest.mark.parametrize("changes", [dict(capture=0.05, engage=0.08), dict(engage=-0.01), dict(press=-0.01),
                                     dict(reach=0.0), dict(reach_band=0.0), dict(ramp=-1.0)])
def test_bad_settings_are_refused_naming_the_field(changes: dict) -> None:
    with pytest.raises(ConfigError, match="ContactCompletionConfig"):
        ContactCompletionConfig(**changes)


def test_outside_the_capture_distance_the_targets_are_the_models() -> None:
    c = ContactCompletionConfig()
    x = scene(c.capture + 0.01)
    out = settle(ContactCompletion(c), x)
    np.testing.assert_array_equal(out, x.wrist_target)


def test_within_engage_the_hand_is_sent_press_inside_the_anchors_surface() -> None:
    c = ContactCompletionConfig()
    x = scene(c.engage - 0.01)
    stage = ContactCompletion(c)
    out = settle(stage, x)
    assert stage.weight[1] == 1.0 and stage.anchor[1] == 0
    # Moved as the wrist moves, the hand's nearest point lies `press` inside the sphere, along the approach.
    moved = x.nearest[1, 0] + (out[1] - x.wrist_now[1])
    np.testing.assert_allclose(moved, [1.0 - R + c.press, 0.0, 1.2], atol=1e-12)
    np.testing.assert_array_equal(out[0], x.wrist_target[0])  # the other hand wanted nothing


@pytest.mark.parametrize("gap", [0.18, 0.22, 0.27])
def test_between_engage_and_capture_the_weight_is_the_smoothstep_of_the_intended_gap(gap: float) -> None:
    c = dataclasses.replace(ContactCompletionConfig(), ramp=0.0)
    x = scene(gap)
    stage = ContactCompletion(c)
    out = stage(x, 0, DT)
    beta = float(smoothstep((c.capture - gap) / (c.capture - c.engage)))
    assert 0.0 < beta < 1.0
    assert stage.weight[1] == pytest.approx(beta)
    full = ContactCompletion(c).contact_targets(x)[1, 0]
    np.testing.assert_allclose(out[1], (1 - beta) * x.wrist_target[1] + beta * full, atol=1e-12)


def test_the_nearer_the_models_hand_the_stronger_the_pull() -> None:
    c = dataclasses.replace(ContactCompletionConfig(), ramp=0.0)
    weights = []
    for gap in (0.29, 0.26, 0.22, 0.19, 0.16):
        stage = ContactCompletion(c)
        stage(scene(gap), 0, DT)
        weights.append(stage.weight[1])
    assert np.all(np.diff(weights) > 0)


def test_a_contact_beyond_the_arms_reach_is_left_alone_and_one_within_it_is_completed() -> None:
    c = dataclasses.replace(ContactCompletionConfig(), ramp=0.0)
    # The completed wrist target lies at x = 1 − R + press − 0.1 from a shoulder at x = 0.
    wrist_x = 1.0 - R + c.press - 0.1
    far = ContactCompletion(c)
    far(scene(0.0, arm=wrist_x - c.reach_band - 0.01), 0, DT)
    assert far.weight[1] == 0.0
    edge = ContactCompletion(c)
    edge(scene(0.0, arm=wrist_x - 0.5 * c.reach_band), 0, DT)
    assert edge.weight[1] == pytest.approx(0.5)
    near = ContactCompletion(c)
    near(scene(0.0, arm=wrist_x + 0.01), 0, DT)
    assert near.weight[1] == 1.0


def test_a_contact_the_task_does_not_want_is_left_alone() -> None:
    x = scene(0.0, allowed=False)
    np.testing.assert_array_equal(settle(ContactCompletion(), x), x.wrist_target)


def test_the_weight_ramps_in_and_out_at_most_dt_over_ramp_per_frame() -> None:
    c = ContactCompletionConfig(ramp=0.25)
    stage = ContactCompletion(c)
    seen = [stage(scene(0.0), t, DT) is not None and stage.weight[1] for t in range(4)]
    np.testing.assert_allclose(seen, [0.4, 0.8, 1.0, 1.0])
    out = [stage(scene(1.0), t, DT) is not None and stage.weight[1] for t in range(4, 7)]
    np.testing.assert_allclose(out, [0.6, 0.2, 0.0], atol=1e-12)


def test_asking_for_the_same_frame_again_gives_the_same_answer_and_reset_forgets() -> None:
    stage = ContactCompletion(ContactCompletionConfig(ramp=0.25))
    stage(scene(0.0), 0, DT)
    first = stage(scene(0.0), 1, DT)
    again = stage(scene(0.0), 1, DT)
    np.testing.assert_array_equal(first, again)
    assert stage.weight[1] == pytest.approx(0.8)
    stage.reset()
    stage(scene(0.0), 5, DT)
    assert stage.weight[1] == pytest.approx(0.4)


def test_one_pair_of_hands_at_most_meets_the_persons_hands() -> None:
    c = dataclasses.replace(ContactCompletionConfig(), ramp=0.0)
    x = scene(0.05, anchors=2)
    # The left hand's model target lies near the second anchor too, a little farther than the right's.
    left = dataclasses.replace(
        x, nearest=np.stack([np.repeat([[1.0 - R - 0.06, 0.3, 1.2]], 2, axis=0), x.nearest[1]]),
        wrist_now=np.array([[1.0 - R - 0.16, 0.3, 1.2], x.wrist_now[1]]),
        wrist_target=np.array([[1.0 - R - 0.16, 0.3, 1.2], x.wrist_target[1]]),
        shoulder=np.array([[0.0, 0.3, 1.2], x.shoulder[1]]))
    stage = ContactCompletion(c)
    out = stage(left, 0, DT)
    assert stage.anchor.tolist() == [-1, 0] and stage.weight[0] == 0.0
    np.testing.assert_array_equal(out[0], left.wrist_target[0])
    # An object may be closed on by both hands.
    both = ContactCompletion(c)
    both(dataclasses.replace(left, shared=np.ones(2, dtype=bool)), 0, DT)
    assert both.anchor.tolist() == [1, 0] and (both.weight > 0).all()


def test_without_anchors_nothing_changes() -> None:
    x = scene(0.0)
    empty = dataclasses.replace(x, nearest=np.zeros((2, 0, 3)), centre=np.zeros((0, 3)), radius=np.zeros(0),
                                shared=np.zeros(0, dtype=bool), allowed=np.zeros((2, 0), dtype=bool))
    np.testing.assert_array_equal(ContactCompletion()(empty, 0, DT), x.wrist_target)
