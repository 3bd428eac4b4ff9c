"""``BalanceConfig.hand_task_arm_weight`` (sim/hand_task.py: arm_row_scale): the joint rows of the arms the hands'
task drives weighted by w_a (the rows' scale times √w_a), every other row as before: the numerics against weights
written out by hand, the decision (only a controller with the hands' task gets it: Stubby under the roll-free gate
does not, and runs bit for bit as without the options), the arms' chains (shoulder to wrist, on Stubby and the H1), the settings checked. And ``hand_task_plan_velocity``: the
rows' target velocity the planned wrist's over the frame (against the two poses written out here), only with the
option, and with ``hand_task_velocity_until_touch`` only for an arm that has not touched."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from conftest import assert_gate_keeps_stubby, shared_robot, synthetic_instance

from socialaff_sim.errors import ConfigError, SimulationError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.hand_task import HandTask, arm_row_scale, chain_columns
from socialaff_sim.sim.simulator import SimConfig, Simulator


def test_the_arms_rows_get_the_factor_and_no_other_row() -> None:
    weights = np.array([1.0, 1.0, 0.5, 0.5, 0.5, 0.5, 2.0])  # per-row weights of 7 hinges (dofs 6..12)
    cols = [np.array([8, 9]), np.array([11])]  # the arms' hinges as columns into the dofs (≥ 6)
    scale = np.sqrt(weights)
    out = arm_row_scale(scale, cols, 0.1)
    want = weights.copy()
    want[[2, 3, 5]] *= 0.1  # by hand: dofs 8, 9, 11 are rows 2, 3, 5
    np.testing.assert_allclose(out ** 2, want, rtol=1e-12)
    np.testing.assert_array_equal(scale, np.sqrt(weights))  # the input untouched
    assert arm_row_scale(scale, cols, None) is scale


_OFF = dict(flat_roll_free=False, hand_task=None, hand_task_roll_free=False, hand_task_arm_weight=None,
            hand_task_plan_velocity=False, hand_task_velocity_until_touch=False)


def _cfg(**over) -> SimConfig:  # noqa: ANN003
    """``SimConfig.standing()`` without the hand task's adopted fields (``_OFF``), then ``over``."""
    cfg = SimConfig.standing()
    return dataclasses.replace(cfg, balance=dataclasses.replace(cfg.balance, **{**_OFF, **over}))


def test_only_a_controller_with_the_hands_task_weights_its_arms_down() -> None:
    inter = synthetic_instance("shake_hands", 1)
    base = Simulator("ours", "shake_hands", _cfg())._get_stage(inter).stepper.balance
    # Stubby with the task (no gate): the arms' rows scaled by √0.1, the legs' and head's as before
    bal = Simulator("ours", "shake_hands", _cfg(hand_task=10.0, hand_task_arm_weight=0.1))._get_stage(
        inter).stepper.balance
    assert bal.hands is not None
    arm = np.zeros(len(base._joint_scale), dtype=bool)
    for cols in bal.hands.arm_columns(bal.scene.model, bal._torso, bal.vadr):
        arm[cols - 6] = True
    assert arm.any() and (~arm).any()
    np.testing.assert_allclose(bal._joint_scale[arm], base._joint_scale[arm] * np.sqrt(0.1), rtol=1e-12)
    np.testing.assert_array_equal(bal._joint_scale[~arm], base._joint_scale[~arm])
    np.testing.assert_array_equal(bal._joint_diag[6:], bal._joint_scale)
    # Stubby under the roll-free gate has no task, so no lighter arms
    gated = Simulator("ours", "shake_hands", _cfg(flat_roll_free=True, hand_task=10.0, hand_task_roll_free=True,
                                                   hand_task_arm_weight=0.1))._get_stage(inter).stepper.balance
    assert gated.hands is None
    np.testing.assert_array_equal(gated._joint_scale, base._joint_scale)


def test_settings_are_checked() -> None:
    for bad in (dict(hand_task_arm_weight=0.1), dict(hand_task=10.0, hand_task_arm_weight=0.0),
                dict(hand_task=10.0, hand_task_arm_weight=1.5)):
        with pytest.raises(ConfigError, match="hand_task_arm_weight"):
            BalanceConfig(**bad)
    with pytest.raises(ConfigError, match="hand_task_arm_weight"):
        BalanceConfig(hand_task=10.0, hand_task_touched=True, arm_compensation=1.0, compensation_gate=1e9,
                      hand_task_arm_weight=0.1)
    assert BalanceConfig().hand_task_arm_weight is None and SimConfig.standing().balance.hand_task_arm_weight == 0.1
    assert BalanceConfig(hand_task=10.0, hand_task_arm_weight=1.0).hand_task_arm_weight == 1.0


def test_stubby_under_the_gate_runs_bit_for_bit_as_without_the_options() -> None:
    inter = synthetic_instance("shake_hands", 1)
    # ungated, Stubby's arms get the task and the lighter rows: its motion changes (so the check can fail)
    assert_gate_keeps_stubby(inter, _cfg(), _cfg(flat_roll_free=True, hand_task=10.0, hand_task_roll_free=True,
                                                 hand_task_arm_weight=0.1), _cfg(hand_task=10.0, hand_task_arm_weight=0.1))


def _chain_names(bal) -> list[list[str]]:  # noqa: ANN001
    m = bal.scene.model
    return [[mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, int(m.dof_jntid[bal.vadr[c]])).split("/")[-1]
             for c in cols] for cols in bal.hands.arm_columns(m, bal._torso, bal.vadr)]


def test_the_arms_chains_run_from_the_shoulder_to_the_wrist() -> None:
    inter = synthetic_instance("shake_hands", 1)
    bal = Simulator("ours", "shake_hands", _cfg(hand_task=10.0))._get_stage(inter).stepper.balance
    for side, names in zip(("left", "right"), _chain_names(bal), strict=True):
        assert names == [f"{side}_{j}" for j in ("shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow",
                                                 "wrist_roll", "wrist_pitch")]
    with pytest.raises(SimulationError):  # the torso does not hang from a wrist
        chain_columns(bal.scene.model, bal._torso, bal.hands._bodies[0], bal.vadr)
    # the H1 (skipped without ../shared/robots): the shoulder's pitch is the chain's first joint (the scene's limb
    # bodies start below it)
    spec = load_robot("unitree_h1", mjcf=shared_robot("unitree_h1", "h1.xml"))
    bal = Simulator(spec, "shake_hands", _cfg(hand_task=10.0))._get_stage(inter).stepper.balance
    for side, names in zip(("left", "right"), _chain_names(bal), strict=True):
        assert names == [f"{side}_{j}_joint" for j in ("shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow")]


# -- hand_task_plan_velocity: the planned wrist's velocity over the frame as the rows' target velocity ----------------

def _posed(scene, q: np.ndarray) -> mujoco.MjData:  # noqa: ANN001
    d = mujoco.MjData(scene.model)
    d.qpos[np.asarray(scene.robot_qadr)] = q
    mujoco.mj_kinematics(scene.model, d)
    return d


def test_the_plans_wrist_velocity_moves_the_rows_only_with_the_option(scene) -> None:
    m = scene.model
    rng = np.random.default_rng(5)
    q0 = np.array(scene.home_qpos, dtype=np.float64)
    q1 = q0.copy()
    q1[7:] += rng.uniform(-0.3, 0.3, len(q1) - 7)
    end, start = _posed(scene, q1), _posed(scene, q0)
    d = mujoco.MjData(m)
    d.qpos[np.asarray(scene.robot_qadr)] = q0
    d.qvel[np.asarray(scene.robot_vadr)] = rng.uniform(-1.0, 1.0, len(scene.robot_vadr))
    mujoco.mj_step1(m, d)
    va = np.asarray(scene.robot_vadr)
    on, off = HandTask(scene, 10.0, 8.0, plan_velocity=True), HandTask(scene, 10.0, 8.0)
    T = 0.04
    on.begin_frame(end, q0, T)
    off.begin_frame(end, q0, T)
    assert off.velocities is None  # off: the target at rest whatever the frame's start
    x_end = np.array([end.site_xpos[f] if site else end.xpos[f] for f, site in on._frames])
    x_start = np.array([start.site_xpos[f] if site else start.xpos[f] for f, site in on._frames])
    np.testing.assert_allclose(on.velocities, (x_end - x_start) / T, rtol=1e-12, atol=1e-12)
    assert np.abs(on.velocities).max() > 0.1
    for (J1, b1, _), (J0, b0, _), v in zip(on.tasks(m, d, va, None), off.tasks(m, d, va, None), on.velocities,
                                           strict=True):
        np.testing.assert_array_equal(J1, J0)
        np.testing.assert_allclose(b1 - b0, 2.0 * 8.0 * v, rtol=1e-9, atol=1e-9)  # + 2 ω ẋ*
    # hand_task_velocity_until_touch: a touched arm's rows at rest, the untouched arm's with the velocity
    gated = HandTask(scene, 10.0, 8.0, plan_velocity=True, velocity_until_touch=True)
    gated.begin_frame(end, q0, T)
    touched = np.array([True, False])
    rows_g, rows_on, rows_off = (t.tasks(m, d, va, touched) for t in (gated, on, off))
    np.testing.assert_array_equal(rows_g[0][1], rows_off[0][1])
    np.testing.assert_array_equal(rows_g[1][1], rows_on[1][1])
    assert not np.array_equal(rows_g[0][1], rows_on[0][1])
    np.testing.assert_array_equal(gated.tasks(m, d, va, None)[0][1], rows_on[0][1])  # no latch yet: both move
    with pytest.raises(ConfigError, match="hand_task_velocity_until_touch"):
        BalanceConfig(hand_task=10.0, hand_task_velocity_until_touch=True)
    on.begin_frame(end)  # no start (the first frame): at rest
    assert on.velocities is None
    with pytest.raises(ConfigError, match="hand_task_plan_velocity"):
        BalanceConfig(hand_task_plan_velocity=True)
    assert not BalanceConfig().hand_task_plan_velocity
    b = SimConfig.standing().balance  # adopted (rule on the H1's 392–423)
    assert b.hand_task_plan_velocity and b.hand_task_velocity_until_touch and b.flat_roll_free and b.hand_task_roll_free
