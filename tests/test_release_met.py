"""The contact completion's release of a met touch (``ContactCompletionConfig.release_met``): the stage's decision
against hand-worked weights, the task's touches read from the sub-goals, and high_five_007 in the standing mode."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.retarget.contact_completion import CompletionInput, ContactCompletion, ContactCompletionConfig
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.frame_targets import FrameTargets
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.tasks import load_task

DT = 0.1
R = 0.05


def _scene(*, shared: bool = False, met: bool = False) -> CompletionInput:
    """One anchor at x = 1 (a person's hand, or with ``shared`` an object) that the model's right wrist target
    reaches (intended gap 0: captured, β → 1); the left hand far away and wanting nothing."""
    centre = np.array([[1.0, 0.0, 1.2]])
    nearest = np.array([[[0.0, 2.0, 1.2]], [[0.75, 0.0, 1.2]]])
    wrist_now = np.array([[-0.1, 2.0, 1.2], [0.65, 0.0, 1.2]])
    target = wrist_now.copy()
    target[1, 0] += 0.2  # the hand moved as the model moves it stops on the surface
    return CompletionInput(
        wrist_target=target, wrist_now=wrist_now, nearest=nearest, centre=centre, radius=np.array([R]),
        shared=np.array([shared]), allowed=np.array([[False], [True]]),
        shoulder=np.array([[0.0, 2.0, 1.2], [0.0, 0.0, 1.2]]), arm=1.0, met=met)


def _weights(config: ContactCompletionConfig, *, shared: bool = False, met_from: int = 3,
             frames: int = 7) -> list[float]:
    """The right hand's β per frame: captured from frame 0, the touches met from frame ``met_from`` on."""
    stage = ContactCompletion(config)
    out = []
    for t in range(frames):
        stage(_scene(shared=shared, met=t >= met_from), t, DT)
        out.append(float(stage.weight[1]))
    return out


def test_a_met_touch_is_released_and_ramps_out() -> None:
    """With the option, once the touches are met the person's hand is no longer captured: β ramps out at Δt / τ_r
    a frame (0.4 with τ_r 0.25 s, Δt 0.1 s) from its value at the meeting; the hand's target is the model's."""
    c = ContactCompletionConfig(ramp=0.25, release_met=True)
    np.testing.assert_allclose(_weights(c), [0.4, 0.8, 1.0, 0.6, 0.2, 0.0, 0.0], atol=1e-12)
    stage = ContactCompletion(c)
    x = _scene(met=True)
    for t in range(4):
        out = stage(x, t, DT)
    np.testing.assert_array_equal(out, x.wrist_target)  # type: ignore[possibly-undefined]


def test_without_the_option_a_met_touch_is_still_chased() -> None:
    """Off (the default), the met flag changes nothing (fails if the option's decision is inverted)."""
    c = ContactCompletionConfig(ramp=0.25)
    assert not c.release_met
    np.testing.assert_allclose(_weights(c), [0.4, 0.8, 1.0, 1.0, 1.0, 1.0, 1.0], atol=1e-12)


def test_before_the_touches_are_met_the_option_changes_nothing() -> None:
    c = ContactCompletionConfig(ramp=0.25, release_met=True)
    np.testing.assert_allclose(_weights(c, met_from=99), [0.4, 0.8, 1.0, 1.0, 1.0, 1.0, 1.0], atol=1e-12)


def test_an_object_is_still_captured_after_the_touches_are_met() -> None:
    """Only the person's hands are released: a shared anchor (an object) is captured as without the option."""
    c = ContactCompletionConfig(ramp=0.25, release_met=True)
    np.testing.assert_allclose(_weights(c, shared=True), [0.4, 0.8, 1.0, 1.0, 1.0, 1.0, 1.0], atol=1e-12)


def _frame_targets(label: str, fps: float) -> FrameTargets:
    ft = FrameTargets(load_task(label), ContactCompletionConfig(release_met=True), 0.5)
    ft.interaction = SimpleNamespace(fps=fps)  # type: ignore[assignment]
    return ft


@pytest.mark.parametrize("label, subgoals, fps, expected", [
    ("high_five", {"hands_meet": True}, 15.0, True),  # min_duration 0.01 s < 1/15 s: a touch, met
    ("high_five", {"hands_meet": False}, 15.0, False),  # not met yet
    ("high_five", None, 15.0, False),  # no frame yet
    ("high_five", {"hands_meet": True}, 100.0, False),  # 0.01 s is one frame at 100 fps: not shorter, no touch
    ("high_five", {"hands_meet": True}, 99.0, True),  # 0.01 s < 1/99 s
    ("shake_hands", {"hands_clasped": True}, 15.0, False),  # a handshake is held (0.3 s), not a touch
    ("pull_up", {"wrist_gripped": True}, 15.0, False),  # a grip (0.5 s)
    ("hand_over", {"cup_received": True}, 15.0, False),  # no contact sub-goal with the person
])
def test_the_tasks_touches_are_its_contact_sub_goals_shorter_than_a_frame(label: str, subgoals: dict | None,
                                                                          fps: float, expected: bool) -> None:
    assert _frame_targets(label, fps).touches_met(subgoals) is expected


def _run_007(release: bool) -> tuple[dict, list[np.ndarray], int]:
    """Standing high_five_007 (ground truth): its metrics, the completion's β per frame and the meeting's frame."""
    inter = list(generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=8))
                 .of_label("high_five"))[7]
    base = SimConfig.standing()
    cfg = dataclasses.replace(base, contact_completion=dataclasses.replace(base.contact_completion,
                                                                           release_met=release))
    weights: list[np.ndarray] = []
    met: list[int] = []

    def on_frame(s, r, sub):  # noqa: ANN001
        if r is None:
            return
        weights.append(np.zeros(2) if r.completion is None else np.asarray(r.completion))
        if not met and r.subgoals and all(r.subgoals.values()):
            met.append(len(weights) - 1)

    m = run_episode(Simulator("ours", "high_five", cfg), GroundTruthSource(), inter, on_frame=on_frame)
    return m, weights, (met[0] if met else -1)


def test_high_five_007_released_after_its_meeting_presses_nobody() -> None:
    """high_five_007 (standing, ground truth) meets its palm while the harness holds it; without the option the
    completion holds the hand on the palm after the meeting and follows it down onto the person (the
    ``contact_force`` failure); with it β only falls after the meeting, to 0, and the episode succeeds with no
    failure (fails with the option's decision inverted)."""
    m_off, w_off, met_off = _run_007(False)
    m_on, w_on, met_on = _run_007(True)
    assert met_off > 0 and met_on == met_off
    for a, b in zip(w_off[:met_on + 1], w_on[:met_on + 1], strict=True):
        np.testing.assert_array_equal(a, b)  # the same up to the meeting
    after = np.array([w[1] for w in w_on[met_on:]])
    assert np.all(np.diff(after) <= 0.0) and after[-1] == 0.0
    assert max(w[1] for w in w_off[met_off + 1:]) > 0.5  # off: the palm still chased after the meeting
    failed = lambda m: {f["kind"] for f in m["failures"] if f["triggered"]}  # noqa: E731
    assert "contact_force" in failed(m_off) and not m_off["success"]
    assert not failed(m_on) and m_on["success"]
