"""The wrists' world-frame rows of the balance QP (sim/hand_task.py, BalanceConfig(hand_weight=...)): the rows'
acceleration against finite differences of MuJoCo's forward kinematics (J̇ q̇ included), the reference's velocity
against a finite difference of the plan, its reset after a gap, the give's offset and rate, the arm-only columns,
the settings' checks, and the QP's wrist acceleration with and without the rows."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.hand_task import HandTask, hand_rows
from socialaff_sim.sim.scene import build_scene
from test_balance_control import LAYOUT, standing_far


@pytest.fixture(scope="module")
def scene():
    return build_scene(load_robot("ours"), LAYOUT, harness_time_constant=0.02)


def _state(scene, rng: np.random.Generator) -> mujoco.MjData:
    """The robot at home, its hinges moved and every coordinate moving (a random velocity), after mj_step1's
    position and velocity stages."""
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[scene.robot_qadr] = scene.home_qpos
    d.qpos[scene.robot_qadr[7:]] += rng.uniform(-0.3, 0.3, size=len(scene.robot_qadr) - 7)
    d.qvel[scene.robot_vadr] = rng.normal(scale=0.8, size=len(scene.robot_vadr))
    mujoco.mj_forward(m, d)
    return d


def _wrist(scene, d: mujoco.MjData, s: int) -> np.ndarray:
    kind, i = scene.frame_kinds[1 + s], int(scene.frame_ids[1 + s])
    return (d.site_xpos[i] if kind == "site" else d.xpos[i]).copy()


def _path(scene, d: mujoco.MjData, qacc: np.ndarray, s: int, t: float) -> np.ndarray:
    """Reference: the wrist's position at time t along q(t) = q ⊕ (q̇ t + ½ q̈ t²), MuJoCo's own integration of the
    free joint's rotation and its forward kinematics (second-order exact at t = 0)."""
    m = scene.model
    e = mujoco.MjData(m)
    e.qpos[:] = d.qpos
    step = np.zeros(m.nv)
    step[scene.robot_vadr] = d.qvel[scene.robot_vadr] * t + 0.5 * qacc * t * t
    mujoco.mj_integratePos(m, e.qpos, step, 1.0)
    mujoco.mj_kinematics(m, e)
    return _wrist(scene, e, s)


def _accel(scene, d: mujoco.MjData, qacc: np.ndarray, s: int, h: float = 1e-3) -> np.ndarray:
    """(3,) the wrist's acceleration along that path: a central second difference."""
    return (_path(scene, d, qacc, s, h) - 2.0 * _path(scene, d, qacc, s, 0.0) + _path(scene, d, qacc, s, -h)) / (h * h)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_accelerations_that_meet_the_rows_move_the_wrist_as_the_critically_damped_law_says(scene, seed) -> None:
    rng = np.random.default_rng(seed)
    m = scene.model
    d = _state(scene, rng)
    task = HandTask(scene, bandwidth=20.0, weight=1.0, near=1e3, far=2e3)
    task.x_ref = np.array([_wrist(scene, d, s) for s in (0, 1)]) + rng.normal(scale=0.05, size=(2, 3))
    task.v_ref = rng.normal(scale=0.3, size=(2, 3))
    va = np.asarray(scene.robot_vadr)
    for s, (A, b, w) in enumerate(task.rows(m, d)):
        assert w == 1.0
        qacc = np.linalg.lstsq(A, b, rcond=None)[0]  # rows of full rank: met exactly
        assert A @ qacc == pytest.approx(b, abs=1e-8)
        x = _wrist(scene, d, s)
        v = (_path(scene, d, np.zeros(len(va)), s, 1e-6) - _path(scene, d, np.zeros(len(va)), s, -1e-6)) / 2e-6
        want = 400.0 * (task.x_ref[s] - x) + 40.0 * (task.v_ref[s] - v)
        got = _accel(scene, d, qacc, s)
        assert got == pytest.approx(want, abs=2e-3 * max(1.0, float(np.abs(want).max())))
        # without the velocity-product term the wrist would not follow the law (the term is not negligible here)
        jd = np.zeros((3, m.nv))
        mujoco.mj_jacDot(m, d, jd, None, x, task._bodies[s])
        b_wrong = b + jd[:, va] @ d.qvel[va]  # ... with J̇ q̇ left out
        off = _accel(scene, d, np.linalg.lstsq(A, b_wrong, rcond=None)[0], s)
        assert np.abs(off - want).max() > 0.05


def test_the_rows_move_only_the_arm_of_their_wrist(scene) -> None:
    rng = np.random.default_rng(4)
    m = scene.model
    d = _state(scene, rng)
    task = HandTask(scene, bandwidth=20.0, weight=3.0, near=1e3, far=2e3)
    task.x_ref = np.array([_wrist(scene, d, s) for s in (0, 1)])
    jp = np.zeros((3, m.nv))
    va = np.asarray(scene.robot_vadr)
    rows = task.rows(m, d)
    for s, (A, _, _) in enumerate(rows):
        mujoco.mj_jac(m, d, jp, None, _wrist(scene, d, s), task._bodies[s])
        J = jp[:, va]
        arm = task._arm[s]
        assert arm[6:].any() and not arm[:6].any()
        assert not (task._arm[0] & task._arm[1]).any()
        assert np.array_equal(A[:, arm], J[:, arm])  # the arm's own hinges: the wrist's Jacobian
        assert not A[:, ~arm].any()  # the root, legs, trunk and the other arm: none
        assert np.abs(J[:, ~arm]).max() > 0.1  # (the trunk does move the wrist: left out on purpose)


def test_the_reference_velocity_is_the_plans_finite_difference_and_zero_after_a_gap(scene) -> None:
    rng = np.random.default_rng(5)
    m = scene.model
    task = HandTask(scene, bandwidth=20.0, weight=1.0, near=1e3, far=2e3)
    q0 = np.array(scene.home_qpos, dtype=np.float64)
    qdot = rng.normal(scale=0.5, size=len(q0) - 7)
    q1 = q0.copy()
    q1[7:] += qdot * m.opt.timestep
    task.reference(m, 1, q0)
    assert not task.v_ref.any()  # the first step: nothing to difference
    task.reference(m, 2, q1)
    d = mujoco.MjData(m)
    d.qpos[scene.robot_qadr] = q0
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)
    jp = np.zeros((3, m.nv))
    for s in (0, 1):
        mujoco.mj_jac(m, d, jp, None, _wrist(scene, d, s), task._bodies[s])
        assert task.v_ref[s] == pytest.approx(jp[:, scene.robot_vadr[6:]] @ qdot, abs=5e-3)
        assert np.linalg.norm(task.v_ref[s]) > 0.05
    task.reference(m, 4, q0)  # step 3 not seen: no difference across the gap
    assert not task.v_ref.any()


def test_the_hands_give_moves_the_reference_along_its_offset_and_rate(scene) -> None:
    rng = np.random.default_rng(6)
    m = scene.model
    d = _state(scene, rng)
    task = HandTask(scene, bandwidth=10.0, weight=1.0, near=1e3, far=2e3)
    task.x_ref = np.array([_wrist(scene, d, s) for s in (0, 1)])
    offset, rate = np.array([[0.1, -0.05], [0.0, 0.02]]), np.array([[0.3, 0.0], [-0.1, 0.2]])
    plain = task.rows(m, d)
    moved = task.rows(m, d, offset, rate)
    for s in (0, 1):
        shift = moved[s][1] - plain[s][1]
        assert shift == pytest.approx(np.r_[100.0 * offset[s] + 20.0 * rate[s], 0.0], abs=1e-9)


def test_hand_rows_are_the_pd_law_and_zero_on_the_reference() -> None:
    J = np.arange(12.0).reshape(3, 4)
    x, v = np.array([0.1, 0.2, 0.3]), np.array([0.5, -0.5, 0.0])
    A, b = hand_rows(J, np.zeros(3), x, v, x, v, 15.0)
    assert A is J and not b.any()
    _, b = hand_rows(J, np.array([1.0, 0.0, 0.0]), x, v, x + [0.01, 0, 0], v + [0, 0.1, 0], 15.0)
    assert b == pytest.approx([225.0 * 0.01 - 1.0, 30.0 * 0.1, 0.0])


@pytest.mark.parametrize("kw", [{"hand_weight": -1.0}, {"hand_weight": 1.0, "hand_bandwidth": 0.0}])
def test_balance_config_rejects_bad_hand_settings(kw) -> None:
    with pytest.raises(ConfigError, match="hand_"):
        BalanceConfig(solver="qp", **kw)


def test_the_rows_weigh_by_the_distance_to_the_persons_hands_and_fade_with_their_force(scene) -> None:
    rng = np.random.default_rng(7)
    m = scene.model
    d = _state(scene, rng)
    task = HandTask(scene, bandwidth=20.0, weight=50.0, near=0.3, far=0.5, release=20.0)
    hands = d.geom_xpos[np.asarray(scene.human_geom_ids)[-2:]].copy()
    others = [d.geom_xpos[g] for g in np.asarray(scene.human_geom_ids)[:-2]]
    assert len(others)  # (the person's other parts do not count)
    # the left wrist's reference 0.2 m from the person's left hand, the right's 0.4 m from the right hand: brute
    # force over both hands (and no object in this scene) gives the nearest
    u = np.array([0.0, 0.0, 1.0])
    task.x_ref = np.array([hands[0] + 0.2 * u, hands[1] + 0.4 * u])
    near = [min(np.linalg.norm(x - h) for h in hands) for x in task.x_ref]
    want = np.clip((0.5 - np.array(near)) / 0.2, 0.0, 1.0)
    assert want[0] == pytest.approx(1.0) and 0.0 < want[1] < 1.0
    assert task.gates(d, None) == pytest.approx(want)
    rows = task.rows(m, d)
    assert [w for _, _, w in rows] == pytest.approx(50.0 * want)
    force = np.array([[0.0, 5.0, 0.0], [30.0, 0.0, 0.0]])
    assert task.gates(d, force) == pytest.approx(want * [0.75, 0.0])
    assert len(task.rows(m, d, force=force)) == 1  # a wrist without weight: no rows
    task.x_ref = hands + 0.6 * u
    assert not task.gates(d, None).any() and task.rows(m, d) == []


def _pushed_wrist_error(scene, config: BalanceConfig) -> tuple[float, np.ndarray]:
    """Stubby at home under the controller, pushed forward at the chest (60 N for 0.2 s) while its reference stays
    at home: the largest distance (m) of a wrist from where the reference puts it in the world, and the final qpos."""
    m = scene.model
    d, q, ctl, ctrl0 = standing_far(scene, config)
    plan = mujoco.MjData(m)
    plan.qpos[scene.robot_qadr] = q
    mujoco.mj_kinematics(m, plan)
    ref = np.array([_wrist(scene, plan, s) for s in (0, 1)])
    worst = 0.0
    for k in range(int(round(1.5 / m.opt.timestep))):
        if k % 25 == 0:
            ctl.begin_frame(q, (True, True))
        t = k * m.opt.timestep
        d.xfrc_applied[ctl._torso, 0] = 60.0 if 0.5 <= t < 0.7 else 0.0
        d.ctrl[scene.act_ids] = ctrl0
        ctl.step(m, d, q, np.zeros(len(scene.robot_vadr) - 6))
        if t >= 0.5:
            worst = max(worst, max(float(np.linalg.norm(_wrist(scene, d, s) - ref[s])) for s in (0, 1)))
    assert ctl.catches == 0 and ctl.released  # on its own feet throughout
    return worst, d.qpos.copy()


def test_under_the_controller_the_rows_hold_the_wrists_where_the_plan_puts_them_and_weigh_nothing_at_zero(scene) -> None:
    base = BalanceConfig(solver="qp", sole_gap=0.01, w_torso=3.0, flat_feet=True, hand_near=1e3, hand_far=2e3)
    without, q_without = _pushed_wrist_error(scene, base)
    zero, q_zero = _pushed_wrist_error(scene, dataclasses.replace(base, hand_weight=0.0))
    with_rows, _ = _pushed_wrist_error(scene, dataclasses.replace(base, hand_weight=100.0))
    assert np.array_equal(q_zero, q_without)  # a weight of 0: the same solve, bit for bit
    assert without >= 0.01  # the push moved the trunk, and the wrists with it
    assert with_rows <= 0.7 * without  # (1.08 → 0.65 cm here: the trunk's acceleration is left to the feedback)
