"""The hand target on a thrown object's predicted flight (retarget/flight_target.py and the completion's
``catch_flight``): the prediction against MuJoCo's own free fall, the reach clamp, and every decision point."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.contact_completion import (CompletionInput, ContactCompletion, ContactCompletionConfig,
                                                       paced)
from socialaff_sim.retarget.flight_target import FlightState, ballistic, flight_targets, landing_time

G = 9.81
R = 0.1  # the ball's radius (the task's play ball)
DT = 0.1


def _sphere(floor: bool, integrator: str = "RK4", timestep: float = 1e-3) -> tuple[mujoco.MjModel, mujoco.MjData]:
    xml = f"""<mujoco><option timestep="{timestep}" integrator="{integrator}" gravity="0 0 -{G}"/>
    <worldbody>{'<geom name="floor" type="plane" size="5 5 0.1"/>' if floor else ''}
    <body name="ball"><freejoint/><geom type="sphere" size="{R}" mass="0.15"/></body></worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    return m, mujoco.MjData(m)


def test_the_prediction_is_mujocos_own_free_fall_of_a_sphere() -> None:
    m, d = _sphere(floor=False)
    p0, v0 = np.array([0.3, -0.2, 1.6]), np.array([2.5, 0.4, 1.8])
    d.qpos[:3], d.qvel[:3] = p0, v0
    times, seen = [], []
    for k in range(1, 801):
        mujoco.mj_step(m, d)
        if k % 50 == 0:
            times.append(d.time)
            seen.append(d.qpos[:3].copy())
    p, v = ballistic(p0, v0, np.array(times), G)
    np.testing.assert_allclose(p, np.array(seen), atol=1e-9)
    np.testing.assert_allclose(v[-1], d.qvel[:3], atol=1e-9)


def test_the_landing_time_is_when_mujocos_sphere_first_touches_the_floor() -> None:
    m, d = _sphere(floor=True, integrator="Euler", timestep=2e-4)
    p0, v0 = np.array([0.0, 0.0, 1.4]), np.array([1.0, 0.0, 2.0])
    d.qpos[:3], d.qvel[:3] = p0, v0
    while True:
        mujoco.mj_step(m, d)
        if d.ncon and d.contact.dist[0] <= 0.0:
            break
    expect = landing_time(FlightState(p0, v0, 0.0, G), R)
    assert abs(d.time - expect) <= 3 * m.opt.timestep  # Euler's error and one step's granularity
    # and the closed form is the root of the height equation (numpy's polynomial roots)
    roots = np.roots([-0.5 * G, v0[2], p0[2] - R])
    assert expect == pytest.approx(roots.real.max(), abs=1e-12)
    assert landing_time(FlightState(np.array([0.0, 0.0, R - 0.01]), v0, 0.0, G), R) == 0.0  # down already


def _fall(start_x: float = 1.0, vx: float = -2.0) -> FlightState:
    """A ball coming at the robot (at the origin, facing +x) from ``start_x``, 1.6 m up, moving toward it."""
    return FlightState(np.array([start_x, 0.0, 1.6]), np.array([vx, 0.0, 1.0]), lead=0.1, gravity=G)


# The right hand at y = 0: wrist and its point 0.1 m apart; the shoulder 0.3 m above the wrist; arm 0.6 m.
WRIST = np.array([[0.3, 0.3, 1.0], [0.3, 0.0, 1.0]])
NEAR = WRIST + [0.1, 0.0, 0.0]
SHOULDER = np.array([[0.0, 0.3, 1.3], [0.0, 0.0, 1.3]])
SIDE = np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]])  # each hand's own side: outward from the other shoulder


V_H = 1.5  # the hand's speed, m/s


def _dense(state: FlightState, reach: float, horizon: float = 1.0, n: int = 20001, speed: float = V_H):
    """Brute force: the same construction on a dense grid of the path."""
    return flight_targets(state, R, 0.015, NEAR, WRIST, SHOULDER, reach, horizon, speed, samples=n)


def _brute(state: FlightState, reach: float, speed: float, n: int = 20001) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Written out point by point: per hand the wrist target of every time on a fine grid, whether it is within
    reach and whether the hand gets there in time (its distance from the wrist now over the time left)."""
    end = min(state.lead + 1.0, landing_time(state, R))
    times = np.linspace(state.lead, end, n)
    wrists = np.zeros((2, n, 3))
    for s in (0, 1):
        for i, tau in enumerate(times):
            p = state.position + state.velocity * tau - 0.5 * G * tau * tau * np.array([0.0, 0.0, 1.0])
            v = state.velocity - G * tau * np.array([0.0, 0.0, 1.0])
            u = (p - NEAR[s]) / np.linalg.norm(p - NEAR[s])
            d = v / np.linalg.norm(v) - u + SIDE[s]
            d /= np.linalg.norm(d)
            wrists[s, i] = WRIST[s] + (p + (R - 0.015) * d - NEAR[s])
    inside = np.linalg.norm(wrists - SHOULDER[:, None], axis=-1) <= reach
    in_time = np.linalg.norm(wrists - WRIST[:, None], axis=-1) <= speed * times[None]
    return times, inside, in_time


def test_within_reach_the_hand_goes_to_the_earliest_point_it_can_be_at_in_time() -> None:
    state, reach = _fall(), 0.6
    target, beyond, when, _ = flight_targets(state, R, 0.015, NEAR, WRIST, SHOULDER, reach, 1.0, V_H)
    assert (beyond <= 0).all() and (np.linalg.norm(target - SHOULDER, axis=1) <= reach + 1e-12).all()
    # the hand's point lands press inside the ball's surface at the predicted centre of the chosen time
    p, _ = ballistic(state.position, state.velocity, when, G)
    point = target + (NEAR - WRIST)
    np.testing.assert_allclose(np.linalg.norm(point - p, axis=1), R - 0.015, atol=1e-12)
    # the earliest time within reach and in time, against the point-by-point construction on a 20,001-point grid
    times, inside, in_time = _brute(state, reach, V_H)
    ok = inside & in_time
    assert ok.any(axis=1).all()
    earliest = times[np.argmax(ok, axis=1)]
    step = (times[-1] - times[0]) / 63  # the function's own grid
    assert ((when >= earliest - 1e-9) & (when <= earliest + step + 1e-9)).all()
    # in time and within reach, and not the earliest reachable point when that one cannot be made in time
    assert (np.linalg.norm(target - WRIST, axis=1) <= V_H * when + 1e-9).all()
    reachable_first = times[np.argmax(inside, axis=1)]
    assert (earliest > reachable_first).any()  # the speed decides here: the test fails if it is ignored


def test_a_hand_too_slow_for_every_point_goes_where_it_is_least_late() -> None:
    state, reach, slow = _fall(), 0.6, 0.05
    target, _, when, _ = flight_targets(state, R, 0.015, NEAR, WRIST, SHOULDER, reach, 1.0, slow)
    times, inside, in_time = _brute(state, reach, slow, n=64)  # the same 64 times as the function's grid
    assert not (inside & in_time).any()
    travel = np.linalg.norm(target - WRIST, axis=1)
    for s in (0, 1):
        i = int(np.argmin(np.abs(times - when[s])))
        assert inside[s, i]
        # the slack v_h·τ − travel is the largest over the reachable points of the grid
        p, v = ballistic(state.position, state.velocity, times, G)
        u = p - NEAR[s]
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        d = v / np.linalg.norm(v, axis=1, keepdims=True) - u + SIDE[s]
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        w = WRIST[s] + p + (R - 0.015) * d - NEAR[s]
        slack = slow * times - np.linalg.norm(w - WRIST[s], axis=1)
        assert slow * when[s] - travel[s] == pytest.approx(slack[inside[s]].max(), abs=1e-12)


def test_out_of_reach_the_target_is_clamped_onto_the_reach_and_how_far_beyond_is_told() -> None:
    state = FlightState(np.array([2.0, 1.5, 1.6]), np.array([0.0, -0.5, 1.0]), lead=0.1, gravity=G)  # passes wide
    reach = 0.6
    target, beyond, _, _ = flight_targets(state, R, 0.015, NEAR, WRIST, SHOULDER, reach, 1.0, V_H)
    np.testing.assert_allclose(np.linalg.norm(target - SHOULDER, axis=1), reach, atol=1e-12)  # the clamp
    assert (beyond > 0).all()
    _, dense_beyond, _, _ = _dense(state, reach)
    np.testing.assert_allclose(beyond, dense_beyond, atol=0.01)  # the path's nearest approach, brute force


def test_the_hands_go_to_the_side_the_ball_heads_for_each_on_its_own_side() -> None:
    """Palms facing the ball: each hand's point on the ball's leading half (toward its velocity) and on the hand's
    own side of the body, the two on either side of the ball; inverted (the trailing side, or one side for both),
    the ball would leave the hands behind, or the hands would strike each other."""
    state = _fall()
    target, _, when, _ = flight_targets(state, R, 0.015, NEAR, WRIST, SHOULDER, 0.6, 1.0, V_H)
    p, v = ballistic(state.position, state.velocity, when, G)
    off = target + (NEAR - WRIST) - p  # from the ball's centre to where each hand's point goes
    vhat = v / np.linalg.norm(v, axis=1, keepdims=True)
    assert ((off * vhat).sum(axis=1) > 0).all()
    assert ((off * SIDE).sum(axis=1) > 0).all()
    # both hands' points (at the same ball position) are on opposite sides of it
    same = flight_targets(dataclasses.replace(state, velocity=np.array([-2.0, 0.0, 1.0])), R, 0.015,
                          np.array([NEAR[1], NEAR[1]]), np.array([WRIST[1], WRIST[1]]), SHOULDER, 0.6, 1.0, V_H)
    assert (same[0][0] - same[0][1])[1] > 0.05  # the left hand's wrist target to the left of the right's


def test_the_path_ends_where_the_ball_lands() -> None:
    state = FlightState(np.array([0.4, 0.0, 0.5]), np.array([0.0, 0.0, -1.0]), lead=0.0, gravity=G)
    _, _, when, _ = flight_targets(state, R, 0.015, NEAR, WRIST, SHOULDER, 0.6, 5.0, V_H)
    assert (when <= landing_time(state, R) + 1e-12).all()


# -- the completion with the option ------------------------------------------------------------------------


def _catch_input(catch: bool = True, state: FlightState | None = None, gap_far: bool = True) -> CompletionInput:
    """The ball as the one anchor (shared), the model's wrists left where they are (no intent: the recording)."""
    state = state or _fall()
    centre = ballistic(state.position, state.velocity, np.array([state.lead]), G)[0]
    nearest = np.repeat(NEAR[:, None, :], 1, axis=1)
    return CompletionInput(
        wrist_target=WRIST.copy(), wrist_now=WRIST.copy(), nearest=nearest, centre=centre, radius=np.array([R]),
        shared=np.array([True]), allowed=np.ones((2, 1), dtype=bool), shoulder=SHOULDER.copy(), arm=0.6,
        free=True, catch=catch, flight=state,
    )


# The lead's and the pace's own decisions are tested apart.
ON = ContactCompletionConfig(catch_flight=True, flight_lead=10.0, flight_pace=None)


def _settle(c: ContactCompletionConfig, x: CompletionInput, frames: int = 10) -> tuple[np.ndarray, np.ndarray]:
    stage = ContactCompletion(c)
    out = x.wrist_target
    for t in range(frames):
        out = stage(x, t, DT)
    return out, stage.weight


def test_on_by_default_and_off_it_is_the_completion_without_the_flight_bit_for_bit() -> None:
    assert ContactCompletionConfig().catch_flight is True and ContactCompletionConfig().catch_approach is True
    x = _catch_input()
    no = ContactCompletionConfig(catch_flight=False, catch_approach=False)
    today = _settle(no, dataclasses.replace(x, catch=False, flight=None))
    off = _settle(no, x)  # the window open, the option off
    np.testing.assert_array_equal(off[0], today[0])
    np.testing.assert_array_equal(off[1], today[1])
    assert not today[1].any()  # the ball's intended gap is beyond capture and the recording has no intent


def test_the_window_open_sends_the_hand_the_flight_passes_nearest_onto_it_and_closed_leaves_todays_target() -> None:
    x = _catch_input()
    out, beta = _settle(ON, x)
    expect, _, _, closest = flight_targets(x.flight, R, ON.press, NEAR, WRIST, SHOULDER, ON.reach * x.arm,
                                           ON.flight_horizon, ON.hand_speed)
    s = int(np.argmin(closest))
    assert closest[s] < closest[1 - s] - 0.05  # the ball comes in on the right (y = 0): the right hand's
    np.testing.assert_allclose(out[s], expect[s], atol=1e-12)  # captured by the window whatever the gap: β = 1
    assert beta[s] == 1.0
    # the other hand is completed as today: here its intended gap is beyond capture and there is no intent
    np.testing.assert_array_equal(out[1 - s], x.wrist_target[1 - s])
    assert beta[1 - s] == 0.0
    closed, beta_closed = _settle(ON, dataclasses.replace(x, catch=False))
    np.testing.assert_array_equal(closed, x.wrist_target)
    assert not beta_closed.any()
    no_state, _ = _settle(ON, dataclasses.replace(x, flight=None))  # no state known: no prediction
    np.testing.assert_array_equal(no_state, x.wrist_target)
    # the ball coming in on the left: the left hand goes
    left = _catch_input(state=FlightState(np.array([1.0, 0.3, 1.6]), np.array([-2.0, 0.0, 1.0]), 0.1, G))
    _, beta_left = _settle(ON, left)
    assert beta_left[0] == 1.0 and beta_left[1] == 0.0


def test_the_window_ramps_the_weight_in_as_any_contact_does() -> None:
    stage = ContactCompletion(ON)
    x = _catch_input()
    stage(x, 0, DT)
    assert sorted(stage.weight.tolist()) == [0.0, DT / ON.ramp]


def test_a_flight_beyond_the_reach_gate_is_left_alone_and_one_within_the_band_is_clamped() -> None:
    wide = FlightState(np.array([2.0, 1.5, 1.6]), np.array([0.0, -0.5, 1.0]), lead=0.1, gravity=G)
    x = _catch_input(state=wide)
    out, beta = _settle(ON, x)
    np.testing.assert_array_equal(out, x.wrist_target)  # beyond ρ·arm + b: the gate is shut
    assert not beta.any()
    # the same path, the arm just long enough that the nearest approach lies inside the band: partial weight
    _, beyond, _, _ = flight_targets(wide, R, ON.press, NEAR, WRIST, SHOULDER, 0.6, ON.flight_horizon, ON.hand_speed)
    arm = (0.6 + beyond.min() - 0.5 * ON.reach_band)
    y = dataclasses.replace(x, arm=float(arm))
    out, beta = _settle(ON, y)
    s = int(np.argmin(beyond))
    assert 0.0 < beta[s] < 1.0
    target, _, _, _ = flight_targets(wide, R, ON.press, NEAR, WRIST, SHOULDER, arm, ON.flight_horizon, ON.hand_speed)
    np.testing.assert_allclose(np.linalg.norm(target[s] - SHOULDER[s]), arm, atol=1e-12)  # clamped onto the reach
    np.testing.assert_allclose(out[s], (1 - beta[s]) * WRIST[s] + beta[s] * target[s], atol=1e-12)


def test_the_horizon_and_the_speed_are_checked() -> None:
    with pytest.raises(ConfigError, match="flight_horizon"):
        ContactCompletionConfig(flight_horizon=-0.1)
    with pytest.raises(ConfigError, match="hand_speed"):
        ContactCompletionConfig(hand_speed=0.0)
    with pytest.raises(ConfigError, match="flight_pace"):
        ContactCompletionConfig(flight_pace=0.0)


def test_the_hand_goes_onto_the_flight_only_within_the_lead_of_the_balls_arrival() -> None:
    """Before the ball is within ``flight_lead`` of the chosen point the hand is completed as without the option;
    inverted (going early, holding back late), both assertions fail."""
    x = _catch_input()
    _, _, when, closest = flight_targets(x.flight, R, ON.press, NEAR, WRIST, SHOULDER, ON.reach * x.arm,
                                         ON.flight_horizon, ON.hand_speed)
    s = int(np.argmin(closest))
    early = ContactCompletionConfig(catch_flight=True, flight_lead=float(when[s]) - 0.01)
    out, beta = _settle(early, x)
    np.testing.assert_array_equal(out, x.wrist_target)  # too early: today's completion (nothing here)
    assert not beta.any()
    near = ContactCompletionConfig(catch_flight=True, flight_lead=float(when[s]) + 0.01)
    _, beta = _settle(near, x)
    assert beta[s] == 1.0


# -- the pace (``flight_pace``) ----------------------------------------------------------------------------------


def test_paced_moves_a_far_target_back_along_its_line_to_the_step_and_leaves_a_near_one() -> None:
    rng = np.random.default_rng(7)
    for _ in range(200):
        now = rng.normal(size=(2, 3))
        target = now + rng.normal(size=(2, 3)) * rng.uniform(0.01, 1.0, size=(2, 1))
        step = float(rng.uniform(0.05, 0.5))
        out = paced(target, now, step)
        for s in (0, 1):  # written out: the target if within the step, else the point at the step toward it
            d = target[s] - now[s]
            n = float(np.sqrt(d @ d))
            expect = target[s] if n <= step else now[s] + step * d / n
            np.testing.assert_allclose(out[s], expect, atol=1e-12)
    same = paced(now, now, 0.1)  # a target on the wrist: no division by zero, left there
    np.testing.assert_array_equal(same, now)


def test_the_pace_holds_both_hands_within_the_hand_speed_of_their_wrists_only_while_the_window_is_open() -> None:
    """Inverted (no pace in the window, or a pace outside it) one of the assertions fails."""
    x = _catch_input()
    x = dataclasses.replace(x, wrist_target=x.wrist_target + np.array([[0.0, 0.5, 0.0], [0.0, -0.5, 0.0]]))
    paced_on = dataclasses.replace(ON, flight_pace=1.5)
    free, _ = _settle(ON, x, frames=1)
    assert (np.linalg.norm(free - x.wrist_now, axis=1) > 0.3).all()  # without the pace: far from the wrists
    out, _ = _settle(paced_on, x, frames=1)
    step = 1.5 * DT
    np.testing.assert_allclose(out, paced(free, x.wrist_now, step), atol=1e-12)  # both hands, the flight's too
    np.testing.assert_allclose(np.linalg.norm(out - x.wrist_now, axis=1), step, atol=1e-12)
    closed = dataclasses.replace(x, catch=False)  # the window shut (a hand-over, the ball held): no pace
    np.testing.assert_array_equal(_settle(paced_on, closed, frames=1)[0], _settle(ON, closed, frames=1)[0])
    np.testing.assert_array_equal(_settle(paced_on, closed, frames=1)[0], closed.wrist_target)
    assert ContactCompletionConfig().flight_pace == 3.0


def test_the_pace_allows_the_hand_speed_over_every_frame_since_the_last_one() -> None:
    x = _catch_input()
    x = dataclasses.replace(x, wrist_target=x.wrist_target + np.array([[0.0, 0.5, 0.0], [0.0, -0.5, 0.0]]))
    c = dataclasses.replace(ON, flight_pace=1.5, ramp=0.0)
    stage = ContactCompletion(c)
    stage(x, 0, DT)
    out = stage(x, 3, DT)  # three frames on: three frames' travel allowed
    free = ContactCompletion(dataclasses.replace(c, flight_pace=None))
    free(x, 0, DT)
    np.testing.assert_allclose(out, paced(free(x, 3, DT), x.wrist_now, 3 * 1.5 * DT), atol=1e-12)
