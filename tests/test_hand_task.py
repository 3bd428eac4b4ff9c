"""``BalanceConfig.hand_task`` (sim/hand_task.py): the wrist's rows give, solved exactly, the wrist acceleration
ω² (x* − x) − 2 ω ẋ (checked by finite differences of MuJoCo's forward kinematics along q(t) = q + q̇ t + ½ q̈ t²),
the targets are the plan's wrists, ``hand_task_touched`` gives rows only to touched arms (both arms without it), the
settings are checked, and the option reaches the controller and changes its torques (off: none added)."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.hand_task import HandTask
from socialaff_sim.sim.simulator import SimConfig, Simulator


def _moving(scene, rng: np.random.Generator):
    """(d, q, v): the robot at home with its arms raised, random velocities on every robot dof, after ``mj_step1``."""
    m = scene.model
    d = mujoco.MjData(m)
    q = np.array(scene.home_qpos, dtype=np.float64)
    q[7:] += rng.uniform(-0.3, 0.3, len(q) - 7)
    d.qpos[scene.robot_qadr] = q
    d.qvel[scene.robot_vadr] = rng.uniform(-1.0, 1.0, len(scene.robot_vadr))
    mujoco.mj_step1(m, d)
    return d


def _wrist_at(scene, task: HandTask, qpos: np.ndarray, s: int) -> np.ndarray:
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    mujoco.mj_kinematics(m, d)
    return task.positions(d)[s].copy()


def test_the_rows_solved_give_the_wanted_wrist_acceleration(scene) -> None:
    m = scene.model
    rng = np.random.default_rng(3)
    d = _moving(scene, rng)
    va = np.asarray(scene.robot_vadr)
    task = HandTask(scene, 10.0, 8.0)
    task.targets = np.array([task.positions(d)[s] for s in (0, 1)]) + np.array([[0.05, -0.02, 0.1], [-0.04, 0.03, 0.02]])
    rows = task.tasks(m, d, va, None)
    assert len(rows) == 2
    h = 1e-4
    for s, (J, b, w) in enumerate(rows):
        assert w == 10.0
        acc = np.zeros(m.nv)
        acc[va] = np.linalg.lstsq(J, b, rcond=None)[0]  # J q̈ = b exactly (n > 3)
        x = [None, None, None]
        for k, t in enumerate((-h, 0.0, h)):
            qp = d.qpos.copy()
            mujoco.mj_integratePos(m, qp, d.qvel + 0.5 * t * acc, t)  # q(t) = q + q̇ t + ½ q̈ t²
            x[k] = _wrist_at(scene, task, qp, s)
        xdd = (x[2] - 2.0 * x[1] + x[0]) / (h * h)
        xd = (x[2] - x[0]) / (2.0 * h)
        want = 64.0 * (task.targets[s] - x[1]) - 16.0 * xd
        np.testing.assert_allclose(xdd, want, atol=2e-3 * max(1.0, np.abs(want).max()))
        # without J̇ q̇ the same rows miss it: the term is not negligible here (so the check above can fail)
        Jd = np.zeros((3, m.nv))
        mujoco.mj_jacDot(m, d, Jd, None, task.positions(d)[s].copy(), task._bodies[s])
        assert np.abs(Jd[:, va] @ d.qvel[va]).max() > 0.05


def test_targets_are_the_plans_wrists(scene) -> None:
    m = scene.model
    plan = mujoco.MjData(m)
    plan.qpos[scene.robot_qadr] = scene.home_qpos
    mujoco.mj_kinematics(m, plan)
    task = HandTask(scene, 1.0, 10.0)
    task.begin_frame(plan)
    for s in (0, 1):
        np.testing.assert_array_equal(task.targets[s], task.positions(plan)[s])
    assert np.linalg.norm(task.targets[0] - task.targets[1]) > 0.1  # left and right, not one wrist twice


def test_touched_only_gives_rows_to_touched_arms_only(scene) -> None:
    m = scene.model
    d = _moving(scene, np.random.default_rng(4))
    va = np.asarray(scene.robot_vadr)
    both = HandTask(scene, 1.0, 10.0)
    gated = HandTask(scene, 1.0, 10.0, touched_only=True)
    for t in (both, gated):
        t.targets = np.zeros((2, 3))
    assert len(both.tasks(m, d, va, np.array([False, False]))) == 2
    assert len(both.tasks(m, d, va, None)) == 2
    assert gated.tasks(m, d, va, None) == []
    assert gated.tasks(m, d, va, np.array([False, False])) == []
    right = gated.tasks(m, d, va, np.array([False, True]))
    assert len(right) == 1
    np.testing.assert_array_equal(right[0][1], both.tasks(m, d, va, None)[1][1])  # the right arm's rows


def test_settings_are_checked_and_reach_the_controller() -> None:
    for bad in (dict(hand_task=0.0), dict(hand_task=1.0, hand_task_bandwidth=0.0), dict(hand_task_touched=True),
                dict(hand_task=1.0, hand_task_touched=True)):
        with pytest.raises(ConfigError, match="hand_"):
            BalanceConfig(**bad)
    assert BalanceConfig().hand_task is None and SimConfig.standing().balance.hand_task == 10.0  # (gated: the H1's)
    cfg = SimConfig.standing()
    inter = next(i for i in generate_dataset(seed=0) if i.instance_id == "shake_hands_004")
    for w in (None, 5.0):
        sim = Simulator("ours", "shake_hands", dataclasses.replace(
            cfg, balance=dataclasses.replace(cfg.balance, hand_task=w, hand_task_roll_free=False, flat_roll_free=False,
                                             hand_task_arm_weight=None, hand_task_plan_velocity=False,
                                             hand_task_velocity_until_touch=False)))
        bal = sim._get_stage(inter).stepper.balance
        assert (bal.hands is None) is (w is None)
        if w is not None:
            assert bal.hands.weight == w and not bal.hands.touched_only
