"""The base's approach to a captured contact beyond the plan's reach (``ContactCompletionConfig.base_approach``).

The shift is checked against an independent reference: scipy's root finder on |w − (p + h·u)| = ℓ along the
horizontal unit u from the shoulder p to the wrist target w; then each decision point (captured or not, within reach
or not, the cap, the larger of two hands, the ramp in and out) and, in the simulator, the base target the frame's
targets carry with the option against the same frame without it.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.optimize import brentq

from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.base_approach import BaseApproach, horizontal_excess, residual_shift
from socialaff_sim.retarget.contact_completion import ContactCompletionConfig

ARM = 0.554  # m: the H1's arm


def _reference(w: np.ndarray, p: np.ndarray, arm: float) -> float:
    """The horizontal move h ≥ 0 of ``p`` toward ``w`` that puts ``w`` at ``arm`` from it (brentq)."""
    u = np.array([*(w[:2] - p[:2]), 0.0])
    u /= np.linalg.norm(u)
    f = lambda h: float(np.linalg.norm(w - (p + h * u))) - arm  # noqa: E731
    r = float(np.linalg.norm(w[:2] - p[:2]))
    if f(0.0) <= 0.0:
        return 0.0  # within reach already
    if f(r) > 0.0:
        return r  # the shoulder right below or above the wrist is still too far: the whole horizontal distance
    return brentq(f, 0.0, r)


def test_the_excess_is_the_horizontal_move_that_brings_the_wrist_to_the_arms_length(rng) -> None:  # noqa: ANN001
    for _ in range(50):
        p = rng.normal(size=3)
        yaw, pitch = rng.uniform(-np.pi, np.pi), rng.uniform(-0.5, 0.5)  # |z| < ℓ: a horizontal move reaches
        direction = np.array([np.cos(pitch) * np.cos(yaw), np.cos(pitch) * np.sin(yaw), np.sin(pitch)])
        w = p + direction * (ARM + rng.uniform(0.01, 0.3))
        assert horizontal_excess(w[None], p[None], ARM)[0] == pytest.approx(_reference(w, p, ARM), abs=1e-9)
    # Within the arm's length: not positive (the decision "beyond reach" inverted would make it so).
    p = np.zeros(3)
    for d in (0.1, 0.3, ARM - 1e-3):
        w = np.array([d * 0.8, d * 0.6 * 0.5, d * 0.6 * np.sqrt(0.75)])
        assert horizontal_excess(w[None], p[None], ARM)[0] <= 0.0
    # Straight above by more than the arm: the whole horizontal distance.
    assert horizontal_excess(np.array([[0.2, 0.0, 0.7]]), p[None], ARM)[0] == pytest.approx(0.2)


def _pair(beyond: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Wrist targets (2, 3) straight ahead (+x) of two shoulders 0.4 m apart, each ``beyond`` m past the arm."""
    shoulder = np.array([[0.0, 0.2, 1.3], [0.0, -0.2, 1.3]])
    wrist = shoulder + np.array([[ARM + beyond[0], 0.0, 0.0], [ARM + beyond[1], 0.0, 0.0]])
    return wrist, shoulder


def test_the_shift_is_zero_without_a_captured_contact_or_within_reach_from_none() -> None:
    wrist, shoulder = _pair((0.06, 0.06))
    none = np.zeros(2)
    assert residual_shift(wrist, shoulder, ARM, np.array([False, False]), np.array([0.05, 0.0]), 0.1).tolist() == [0, 0]
    np.testing.assert_allclose(residual_shift(wrist, shoulder, ARM, np.array([False, True]), none, 0.1), [0.06, 0.0],
                               atol=1e-12)
    wrist, shoulder = _pair((-0.02, -0.05))  # within reach and no shift before: nothing to give back
    assert residual_shift(wrist, shoulder, ARM, np.array([True, True]), none, 0.1).tolist() == [0.0, 0.0]


def test_the_shift_is_the_one_solved_with_plus_the_residual_from_the_solved_shoulders(rng) -> None:  # noqa: ANN001
    wrist, shoulder = _pair((0.04, 0.3))
    before = np.array([0.03, 0.0])
    # The residual adds to the shift the IK solved with (measured from its shoulders, not from the plan's).
    np.testing.assert_allclose(residual_shift(wrist, shoulder, ARM, np.array([True, False]), before, 0.1),
                               [0.07, 0.0], atol=1e-12)
    np.testing.assert_allclose(residual_shift(wrist, shoulder, ARM, np.array([False, True]), before, 0.1),
                               [0.1, 0.0], atol=1e-12)  # capped
    np.testing.assert_allclose(residual_shift(wrist, shoulder, ARM, np.array([True, True]), before, 0.5),
                               [0.33, 0.0], atol=1e-12)  # both captured: the hand that needs more
    # Within reach: the shift gives back the slack, down to zero and not past it.
    wrist, shoulder = _pair((-0.02, -0.5))
    np.testing.assert_allclose(residual_shift(wrist, shoulder, ARM, np.array([True, False]), before, 0.1),
                               [0.01, 0.0], atol=1e-12)
    assert residual_shift(wrist, shoulder, ARM, np.array([False, True]), before, 0.1).tolist() == [0.0, 0.0]
    for _ in range(20):  # any direction: the residual along the solved shoulder → wrist line's horizontal part
        p = rng.normal(size=(2, 3))
        d = rng.normal(size=(2, 3))
        d[:, 2] *= 0.3
        w = p + d / np.linalg.norm(d, axis=1, keepdims=True) * (ARM + 0.05)
        before = rng.normal(size=2) * 0.02
        s = residual_shift(w, p, ARM, np.array([True, False]), before, 0.5)
        u = (w[0, :2] - p[0, :2]) / np.linalg.norm(w[0, :2] - p[0, :2])
        np.testing.assert_allclose(s, before + _reference(w[0], p[0], ARM) * u, atol=1e-9)
        s = residual_shift(w, p, ARM, np.array([True, False]), before, 0.01)
        assert np.linalg.norm(s) == pytest.approx(0.01)


def test_the_shift_ramps_in_and_out_by_at_most_cap_dt_over_ramp_per_frame() -> None:
    """An IK that follows its base target: its shoulders move with the shift it solved with."""
    cap, ramp, dt = 0.1, 0.3, 0.1  # at most 1/30 m a frame
    stage = BaseApproach(cap, ramp)
    wrist, shoulder = _pair((0.08, -0.1))
    moved = lambda: shoulder + np.array([*stage.shift, 0.0])  # noqa: E731  (the last solution's shoulders)
    seen = [stage(wrist, moved(), ARM, np.array([True, False]), t, dt)[0] for t in range(6)]
    np.testing.assert_allclose(seen, [1 / 30, 2 / 30, 0.08, 0.08, 0.08, 0.08], atol=1e-12)
    again = stage(wrist, moved(), ARM, np.array([True, False]), 5, dt)  # the same frame again: the same shift
    assert again[0] == pytest.approx(0.08)
    out = [stage(wrist, moved(), ARM, np.array([False, False]), t, dt)[0] for t in range(6, 10)]
    np.testing.assert_allclose(out, [0.08 - 1 / 30, 0.08 - 2 / 30, 0.0, 0.0], atol=1e-12)
    # An IK whose shoulders stay put (a body that cannot follow): the residual keeps adding, up to the cap.
    still = BaseApproach(cap, ramp)
    far = [still(wrist, shoulder, ARM, np.array([True, False]), t, dt)[0] for t in range(8)]
    np.testing.assert_allclose(far, [1 / 30, 2 / 30, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1], atol=1e-12)
    # Frames skipped: as many steps at once; a frame before the last starts afresh from no shift.
    slow = BaseApproach(0.5, 3.0)  # 1/60 m a frame
    assert slow(wrist, shoulder, ARM, np.array([True, False]), 12, dt)[0] == pytest.approx(1 / 60)
    assert slow(wrist, shoulder, ARM, np.array([True, False]), 15, dt)[0] == pytest.approx(4 / 60)
    assert slow(wrist, shoulder, ARM, np.array([True, False]), 3, dt)[0] == pytest.approx(1 / 60)
    assert BaseApproach(cap, 0.0)(wrist, shoulder, ARM, np.array([True, False]), 0, dt)[0] == pytest.approx(0.08)


def test_the_settings_errors() -> None:
    assert ContactCompletionConfig().base_approach is None  # off by default
    with pytest.raises(ConfigError, match="base_approach"):
        ContactCompletionConfig(base_approach=0.0)
    with pytest.raises(ConfigError, match="base_approach_ramp"):
        ContactCompletionConfig(base_approach=0.1, base_approach_ramp=-1.0)
    with pytest.raises(ConfigError, match="base_approach"):
        BaseApproach(-0.1, 0.3)
    assert dataclasses.replace(ContactCompletionConfig(), base_approach=0.1).base_approach == 0.1


@pytest.fixture(scope="module", params=["ours", "unitree_h1"])
def strike_sim(request):  # noqa: ANN001, ANN201
    """A harnessed robot (Stubby; the H1, skipped without ../shared/robots) replaying a recorded high five to the frame
    before its strike, the completion's and the approach's ramps 0 (each frame's weight and shift are the ones
    wanted)."""
    from conftest import shared_robot

    from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
    from socialaff_sim.retarget.robot import load_robot
    from socialaff_sim.sim.simulator import SimConfig, Simulator
    from socialaff_sim.sim.tasks import load_task

    robot = request.param
    spec = (load_robot(robot, mjcf=shared_robot("unitree_h1", "h1.xml")) if robot == "unitree_h1"
            else load_robot(robot))
    inter = list(generate_dataset(0, SyntheticConfig(interactions=("high_five",), instances_per_interaction=8)))[6]
    t = int(np.flatnonzero(np.asarray(inter.subevents) == inter.subevent_names.index("strike"))[0])
    # ρ = 3: the completion captures a target up to three arms from the physical shoulder, so that the approach
    # (which measures the arm's length itself, not ρ times it) meets captured targets beyond the arm.
    cc = dataclasses.replace(ContactCompletionConfig(), ramp=0.0, reach=3.0, base_approach=0.1,
                             base_approach_ramp=0.0)
    task = load_task("high_five")  # the right hand only (one hand's decision)
    task = dataclasses.replace(task, subgoals=tuple(dataclasses.replace(g, robot="right_hand") for g in task.subgoals))
    sim = Simulator(spec, task, dataclasses.replace(SimConfig(), contact_completion=cc))
    keys = inter.key_joints()[:, 1]
    sim.reset(inter)
    sim.settle(sim.retarget(keys[0], frame=0))
    while sim.frame < t - 1:
        sim.step(sim.retarget(keys[sim.frame + 1]))
    return sim, keys[t], t


def _targets(sim, keys, t: int, arm: float, approach: bool):  # noqa: ANN001, ANN202
    """World targets (5, 3) of frame ``t`` with the arm's length set to ``arm``, with (from no shift before) or without
    the approach."""
    ft = sim._targets
    stage = ft.base_approach if approach else None
    if stage is not None:
        stage.reset()
    kept, ft.base_approach, ft.arm = ft.base_approach, stage, arm
    try:
        return sim.frame_R.to_world(sim.retarget(keys, frame=t, contact=True, contact_inside=True))
    finally:
        ft.base_approach = kept


def test_in_the_simulator_the_base_target_moves_by_the_excess_from_the_iks_shoulders(strike_sim) -> None:  # noqa: ANN001
    """Over a grid of arm lengths: each frame's base target with the approach against the same frame's without it,
    against the shift computed by the reference from that frame's wrist target and the shoulder of the IK's last
    solution (not the plan's: the home shoulder offset from the base target, which must give another shift in some
    case, so that measuring from it fails); the grid must cover each case (captured within reach, captured beyond it
    by less than the cap and by more, not captured beyond it)."""
    sim, keys, t = strike_sim
    ft = sim._targets
    side = 1
    seen = set()
    solved = np.array(sim._stage.ik.configuration.data.xpos[sim._stage.ik_scene.limb_body_ids[side]])
    differs = 0
    for arm in np.linspace(0.3, 1.6, 27):
        without = _targets(sim, keys, t, float(arm), False)
        beta = ft.completion.weight.copy()
        assert beta[0] == 0.0
        moved = _targets(sim, keys, t, float(arm), True)
        w = without[1 + side]
        excess = _reference(w, solved, float(arm))
        plan = sim.frame_R.to_world(sim.frame_R.to_robot(without[0]) + ft.scaler.robot.shoulders)[side]
        differs += int(abs(_reference(w, plan, float(arm)) - excess) > 0.01 and beta[side] > 0)
        shift = moved[0] - without[0]
        np.testing.assert_array_equal(moved[1:], without[1:])  # wrists and feet where they were
        assert shift[2] == 0.0
        if beta[side] > 0 and excess > 0:
            u = (w[:2] - solved[:2]) / np.linalg.norm(w[:2] - solved[:2])
            np.testing.assert_allclose(shift[:2], min(0.1, excess) * u, atol=1e-9)  # toward the wrist, capped
            seen.add("capped" if excess > 0.1 else "excess")
        else:
            assert shift.tolist() == [0.0, 0.0, 0.0]
            seen.add("within" if beta[side] > 0 else ("not captured" if excess > 0 else "neither"))
    assert {"capped", "excess", "within", "not captured"} <= seen, seen
    assert differs > 0  # the plan's shoulder would have given another shift
