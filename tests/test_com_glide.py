"""The centre-of-mass goal glided from the measured centre of mass onto the plan's (``BalanceConfig.com_glide``,
:mod:`socialaff_sim.sim.com_glide`): the glide's shape against finite differences and a closed form, the
wanted centre of pressure it asks for against an ODE solver's, the take-over's start and restart, and on the
Unitree H1 in physics the goal at each driven step against the measured centre of mass and the plan's goal read
from MuJoCo."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.balance_control import BalanceController
from socialaff_sim.sim.com_glide import ComGlide, glide_share, rest_lead
from socialaff_sim.sim.scene import build_scene

from conftest import shared_robot
from test_balance_control import standing_far

QP = BalanceConfig(solver="qp", sole_gap=0.01, w_torso=3.0, flat_feet=True, torque_handover=0.2)


def test_share_starts_at_one_with_zero_slope_and_falls_to_zero() -> None:
    T = 0.8
    t = np.linspace(0.0, 8.0, 4001)
    s = np.array([glide_share(x, T) for x in t])
    np.testing.assert_allclose(s, (1.0 + t / T) * np.exp(-t / T), rtol=1e-12)  # the closed form
    assert s[0] == 1.0 and np.all(np.diff(s) < 0.0)
    # d/dt (1 + t/T) e^{−t/T} = −(t/T²) e^{−t/T}: a central difference agrees, and at t = 0 the slope is 0
    h = 1e-6
    for x in (0.0, 0.3, 1.0, 2.5):
        fd = (glide_share(x + h, T) - glide_share(max(x - h, 0.0), T)) / (h + min(h, x))
        assert fd == pytest.approx(-(x / T ** 2) * math.exp(-x / T), abs=1e-5)
    assert glide_share(6.64 * T, T) < 0.01 < glide_share(6.6 * T, T)
    assert glide_share(-1.0, T) == 1.0  # before the take-over: the whole offset


def test_the_goal_starts_at_the_centre_of_mass_and_glides_onto_the_plan() -> None:
    dt, T = 0.004, 0.5
    g = ComGlide(T, dt)
    plan = np.array([0.3, -0.1])
    com = np.array([0.45, -0.05])
    first = g.goal(plan, com)
    assert np.array_equal(first, com)  # exactly the measured centre of mass (a start at the plan fails here)
    goals = [first] + [g.goal(plan, com + 0.01 * k) for k in range(1, 1700)]  # (the centre of mass read only once)
    for k, x in enumerate(goals):
        np.testing.assert_allclose(x, plan + glide_share(k * dt, T) * (com - plan), atol=1e-15)
    dist = np.linalg.norm(np.array(goals) - plan, axis=1)
    assert np.all(np.diff(dist) <= 0.0) and dist[-1] < 0.01 * dist[0]  # toward the plan, not away from it
    assert g.takeovers == 1


def test_a_take_over_after_an_idle_step_starts_a_new_glide() -> None:
    g = ComGlide(1.0, 0.004)
    plan = np.zeros(2)
    for k in range(100):
        g.goal(plan, np.array([0.2, 0.0]))
    mid = g.goal(plan, np.array([0.9, 0.9]))
    assert 0.0 < mid[0] < 0.2 and mid[1] == 0.0  # still the first glide's offset (the new centre of mass unread)
    g.idle()  # caught: the next release starts where the centre of mass is then
    assert np.array_equal(g.goal(plan, np.array([-0.1, 0.05])), np.array([-0.1, 0.05]))
    assert g.takeovers == 2
    g.reset()
    assert g.takeovers == 0 and np.array_equal(g.goal(plan, np.array([0.3, 0.3])), np.array([0.3, 0.3]))


def _pendulum_cop(goal, t_end: float, e0: float, w: float = 6.0, z: float = 1.0, h: float = 1.0,
                  g: float = 9.81) -> float:
    """The largest |p − c| (m) the feedback c̈ = ω² (c* − c) − 2ζω ċ asks for (p = c − c̈ h / g) over ``t_end``,
    from rest at e0 with the goal ``goal(t)``, integrated by scipy (an independent reference)."""
    sol = solve_ivp(lambda t, y: [y[1], w * w * (goal(t) - y[0]) - 2 * z * w * y[1]], (0.0, t_end), [e0, 0.0],
                    max_step=1e-3, rtol=1e-9, atol=1e-12, dense_output=True)
    t = np.linspace(0.0, t_end, 6001)
    c, v = sol.sol(t)
    acc = w * w * (np.array([goal(x) for x in t]) - c) - 2 * z * w * v
    return float(np.max(np.abs(acc)) * h / g)


def test_the_glide_asks_for_a_centre_of_pressure_near_the_centre_of_mass() -> None:
    e0 = 0.15  # the offset traced at the H1's release in shake_hands_002
    step = _pendulum_cop(lambda t: 0.0, 4.0, e0)
    assert step == pytest.approx(36.0 * e0 / 9.81, rel=1e-6)  # the goal at once: 55 cm beyond, at t = 0
    glided = {T: _pendulum_cop(lambda t, T=T: e0 * glide_share(t, T), 8.0, e0) for T in (0.5, 1.0, 2.0)}
    assert glided[1.0] < 0.01 and glided[0.5] < 0.021 and glided[2.0] < glided[1.0] < glided[0.5]
    assert glided[0.5] < step / 20.0


def test_config_rejects_a_time_constant_that_is_not_positive() -> None:
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ConfigError, match="com_glide"):
            BalanceConfig(com_glide=bad)


@pytest.fixture(scope="module")
def h1():
    path = shared_robot("unitree_h1", "h1.xml")
    return build_scene(load_robot("unitree_h1", mjcf=path), get_layout("kinect_v2"), harness_time_constant=0.02)


@pytest.mark.parametrize("glide,rest", [(None, False), (0.5, False), (0.5, True)])
def test_h1_the_goal_at_each_driven_step(h1, glide, rest) -> None:
    """Released on its feet at home, the plan's centre of mass moved 6 cm forward of the feet: with the option the
    goal starts at the measured centre of mass (with ``glide_rest`` at its rest goal) and glides; without it, it is
    the plan's at once."""
    scene = h1
    m = scene.model
    d, q, ctl, ctrl0 = standing_far(scene, dataclasses.replace(QP, com_glide=glide, glide_rest=rest))
    assert (ctl.glide is None) == (glide is None)
    feet, root, dt = ctl._feet, scene.root_body, m.opt.timestep
    seen: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    orig = ctl.glide.goal if ctl.glide is not None else None

    def spy(plan: np.ndarray, com: np.ndarray) -> np.ndarray:
        out = orig(plan, com)  # type: ignore[misc]
        seen.append((plan.copy(), com.copy(), out.copy()))
        return out

    if ctl.glide is not None:
        ctl.glide.goal = spy  # type: ignore[method-assign]
    k_in = None
    for k in range(150):
        if k % 25 == 0:
            ctl.begin_frame(q, (True, True))
            ctl._com_offset = ctl._com_offset + ctl.feet.heading(d) * 0.06  # the plan leaning 6 cm forward
        d.ctrl[scene.act_ids] = ctrl0
        probe = mujoco.MjData(m)  # the centre of mass's velocity at the state the step acts on, from MuJoCo
        probe.qpos[:], probe.qvel[:] = d.qpos, d.qvel
        mujoco.mj_forward(m, probe)
        jac = np.zeros((3, m.nv))
        mujoco.mj_jacSubtreeCom(m, probe, jac, root)
        vel = (jac @ probe.qvel)[:2]
        ctl.step(m, d, q, np.zeros(len(scene.robot_vadr) - 6))
        if not ctl.active:
            assert k_in is None
            continue
        k_in = k if k_in is None else k_in
        plan_read = d.xpos[feet, :2].mean(axis=0) + ctl._com_offset  # the plan's goal, from MuJoCo's state
        if glide is None:
            continue
        plan, com, out = seen[-1]
        np.testing.assert_allclose(plan, plan_read, atol=1e-12)
        if k == k_in and rest:  # the rest goal: c + (2ζω_c − ω₀)/ω_c² ċ, ω₀ = √(g / h), h the height over the soles
            w0 = math.sqrt(9.81 / d.subtree_com[root, 2])
            lead = (2.0 * QP.com_damping * QP.com_bandwidth - w0) / QP.com_bandwidth ** 2
            np.testing.assert_allclose(com, d.subtree_com[root, :2] + lead * vel, atol=2e-3 * np.linalg.norm(vel) + 1e-9)
            assert np.linalg.norm(vel) > 1e-3  # moving at the release, so that the rest goal is not the centre of mass
        elif glide is not None and k == k_in:
            np.testing.assert_allclose(com, d.subtree_com[root, :2], atol=1e-12)  # the centre of mass of the step
        if k == k_in:
            assert np.array_equal(out, com)
            assert np.linalg.norm(out - plan) > 0.04  # the plan's goal lies elsewhere: a start there fails above
        e0 = seen[0][1] - seen[0][0]  # the offset at the take-over
        np.testing.assert_allclose(out, plan + glide_share((k - k_in) * dt, glide) * e0, atol=1e-12)
    assert k_in is not None and 149 - k_in > 50  # released, and driven long enough to glide
    if glide is not None:
        assert len(seen) == 150 - k_in and ctl.glide.takeovers == 1


def test_without_the_option_the_controller_has_no_glide(h1) -> None:
    assert BalanceController(h1, QP).glide is None


def test_the_rest_lead_asks_for_the_capture_point_as_centre_of_pressure(rng: np.random.Generator) -> None:
    g = 9.81
    for _ in range(20):
        w, z, h = rng.uniform(2.0, 10.0), rng.uniform(0.5, 1.5), rng.uniform(0.5, 1.2)
        w0 = math.sqrt(g / h)
        c, v = rng.normal(size=2) * 0.1, rng.normal(size=2) * 0.5
        goal = c + rest_lead(w, z, w0) * v
        acc = w * w * (goal - c) - 2 * z * w * v  # the controller's feedback at that goal
        np.testing.assert_allclose(c - acc * h / g, c + v / w0, atol=1e-12)  # p at the capture point
        # from the centre of mass itself the centre of pressure lies 2ζω/ω₀ times as far from it
        acc0 = -2 * z * w * v
        np.testing.assert_allclose(-acc0 * h / g, (2 * z * w / w0) * (v / w0), atol=1e-12)
    # the pendulum brought to rest: integrated with p at its capture point the centre of mass stops there
    w0 = math.sqrt(g / 1.0)
    sol = solve_ivp(lambda t, y: [y[1], w0 ** 2 * (y[0] - (0.1 + 0.4 / w0))], (0.0, 3.0), [0.1, 0.4], rtol=1e-10,
                    atol=1e-12)
    assert sol.y[0, -1] == pytest.approx(0.1 + 0.4 / w0, abs=1e-4) and abs(sol.y[1, -1]) < 1e-3


def test_glide_rest_needs_the_glide() -> None:
    with pytest.raises(ConfigError, match="glide_rest"):
        BalanceConfig(glide_rest=True)
    assert BalanceConfig(com_glide=1.0, glide_rest=True).glide_rest


def test_the_joints_glide_from_the_measured_posture_onto_the_reference(rng: np.random.Generator) -> None:
    dt, T = 0.004, 0.6
    g = ComGlide(T, dt)
    ref, meas = rng.normal(size=19), rng.normal(size=19)
    offsets, rates = [], []
    for k in range(600):
        g.goal(np.zeros(2), np.ones(2))
        o, r = g.joints(ref + 0.001 * k * (k > 0), meas + 5.0 * (k > 0))  # (read at the take-over only)
        offsets.append(o)
        rates.append(r)
    np.testing.assert_allclose(ref + offsets[0], meas, atol=1e-14)  # the reference starts at the posture
    np.testing.assert_allclose(np.array(offsets), np.outer([glide_share(k * dt, T) for k in range(600)], meas - ref),
                               atol=1e-14)
    fd = (np.array(offsets[2:]) - np.array(offsets[:-2])) / (2 * dt)  # the rate against a central difference
    np.testing.assert_allclose(np.array(rates[1:-1]), fd, atol=2e-4 * np.abs(meas - ref).max())
    assert np.array_equal(rates[0], np.zeros(19))  # no rate at the take-over
    g.idle()
    g.goal(np.zeros(2), np.ones(2))
    o, _ = g.joints(ref, ref + 0.5)  # a new take-over reads the posture again
    np.testing.assert_allclose(o, 0.5, atol=1e-15)
    with pytest.raises(ConfigError, match="glide_joints"):
        BalanceConfig(glide_joints=True)


def test_h1_the_joints_reference_starts_at_the_measured_posture(h1) -> None:
    scene = h1
    m = scene.model
    d, q, ctl, ctrl0 = standing_far(scene, dataclasses.replace(QP, com_glide=0.5, glide_joints=True))
    q = q.copy()
    hinges = np.asarray(scene.robot_qadr[7:])
    seen = []
    orig = ctl.glide.joints

    def spy(ref: np.ndarray, measured: np.ndarray):
        out = orig(ref, measured)
        seen.append((ref.copy(), measured.copy(), out[0].copy()))
        return out

    ctl.glide.joints = spy  # type: ignore[method-assign]
    q[hinges] += 0.05  # the plan's posture 0.05 rad off every joint's
    for k in range(80):
        if k % 25 == 0:
            ctl.begin_frame(q, (True, True))
        d.ctrl[scene.act_ids] = ctrl0
        before = d.qpos[hinges].copy()
        ctl.step(m, d, q, np.zeros(len(scene.robot_vadr) - 6))
        if ctl.active and len(seen) == 1:
            ref, measured, off = seen[0]
            np.testing.assert_allclose(ref, q[hinges], atol=0.0)
            np.testing.assert_allclose(measured, before, atol=0.0)  # the posture of the step's state
            np.testing.assert_allclose(ref + off, before, atol=1e-12)  # the reference starts there, not at the plan's
            assert np.abs(off).max() > 0.04
    assert len(seen) > 20


def _released_speeds(scene, config: BalanceConfig, steps: int = 120) -> tuple[int | None, list[float]]:
    """The H1 at home under the controller: the first released step (None: none) and the centre of mass's
    horizontal speed (m/s) at every step's state, from MuJoCo's subtree Jacobian."""
    m = scene.model
    d, q, ctl, ctrl0 = standing_far(scene, config)
    first, speeds = None, []
    jac = np.zeros((3, m.nv))
    for k in range(steps):
        if k % 25 == 0:
            ctl.begin_frame(q, (True, True))
        d.ctrl[scene.act_ids] = ctrl0
        probe = mujoco.MjData(m)
        probe.qpos[:], probe.qvel[:] = d.qpos, d.qvel
        mujoco.mj_forward(m, probe)
        mujoco.mj_jacSubtreeCom(m, probe, jac, scene.root_body)
        speeds.append(float(np.linalg.norm((jac @ probe.qvel)[:2])))
        ctl.step(m, d, q, np.zeros(len(scene.robot_vadr) - 6))
        if ctl.released and first is None:
            first = k
    return first, speeds


def test_h1_the_release_waits_for_the_centre_of_mass_to_slow_down(h1) -> None:
    free, speeds = _released_speeds(h1, QP)
    assert free is not None and speeds[free] > 0.0
    v_r = 0.5 * speeds[free]  # slower than the robot moves when it is let go without the option
    held, speeds2 = _released_speeds(h1, dataclasses.replace(QP, release_speed=v_r), steps=400)
    assert speeds2[:free] == speeds[:free]  # the same robot until then
    assert held is not None and held > free  # later, once it moves slowly enough (an inverted test: at once)
    assert speeds2[held] <= v_r * (1 + 1e-9) + 1e-12
    none, _ = _released_speeds(h1, dataclasses.replace(QP, release_speed=0.0))
    assert none is None  # a robot never quite at rest is never let go at v_r = 0
    with pytest.raises(ConfigError, match="release_speed"):
        BalanceConfig(release_speed=-0.1)
