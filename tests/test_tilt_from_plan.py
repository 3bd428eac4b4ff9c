"""The harness's tilt read from the plan's torso attitude (``BalanceConfig.tilt_from_plan``): the angle between the
torso's up axis now and in the plan against scipy's rotations, and from upright without the option."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.balance_control import BalanceController
from socialaff_sim.sim.scene import Scene

EZ = np.array([0.0, 0.0, 1.0])


def _turned(scene: Scene, turn: Rotation) -> mujoco.MjData:
    """Stubby at home with its whole body turned by ``turn`` (world frame) about its root (kinematics only)."""
    m = scene.model
    d = mujoco.MjData(m)
    q = scene.home_qpos.copy()
    home = Rotation.from_quat(q[3:7], scalar_first=True)
    q[3:7] = (turn * home).as_quat(scalar_first=True)
    d.qpos[scene.robot_qadr] = q
    mujoco.mj_kinematics(m, d)
    return d


def _reference_tilt(turn: Rotation) -> float:
    """The angle (degrees) the turn tilts the vertical by: every body of a rigidly turned robot tilts by it."""
    return float(np.degrees(np.arccos(np.clip(turn.apply(EZ) @ EZ, -1.0, 1.0))))


@pytest.mark.parametrize("plan_deg, now_deg", [(8.0, 8.0), (8.0, 0.0), (0.0, 6.0), (-5.0, 7.0)])
def test_tilt_from_plan_reads_the_torsos_angle_from_the_plans_attitude(scene: Scene, plan_deg: float,
                                                                       now_deg: float) -> None:
    # The plan's and the robot's whole bodies pitched about y (the robot about x too, for the 3D angle); the
    # reference: scipy's angle between the two turns' verticals, and from upright without the option.
    plan_turn = Rotation.from_euler("Y", plan_deg, degrees=True)
    now_turn = Rotation.from_euler("YX", [now_deg, 2.0], degrees=True)
    plan = _turned(scene, plan_turn)
    now = _turned(scene, now_turn)
    for from_plan in (True, False):
        ctrl = BalanceController(scene, BalanceConfig(tilt_from_plan=from_plan))
        ctrl.begin_frame(plan.qpos[scene.robot_qadr].copy(), (True, True))
        want = (np.degrees(np.arccos(np.clip(now_turn.apply(EZ) @ plan_turn.apply(EZ), -1.0, 1.0))) if from_plan
                else _reference_tilt(now_turn))
        assert ctrl.attitude.tilt(now) == pytest.approx(want, abs=1e-4)
