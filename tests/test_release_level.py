"""The harness let go only of a robot whose feet stand level (``BalanceConfig.release_level``): each foot's tilt
(sim/feet_on_floor.py) against scipy's rotations, the limit's comparison both ways, the release's delay restarted
by a foot off level, nothing read without the option, and the setting's errors."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.balance_control import BalanceController
from socialaff_sim.sim.feet_on_floor import FeetOnFloor
from socialaff_sim.sim.scene import Scene, build_scene

from test_balance_control import standing_far

EZ = np.array([0.0, 0.0, 1.0])


@pytest.fixture(scope="module")
def scene() -> Scene:
    return build_scene(load_robot("ours"), get_layout("kinect_v2"), harness_time_constant=0.02)


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


@pytest.mark.parametrize("euler", [(0.0, 0.0, 0.0), (40.0, 0.0, 0.0), (40.0, 7.0, 0.0), (-15.0, -3.0, 11.0),
                                   (0.0, 25.0, -20.0)])
def test_each_foots_tilt_is_the_angle_the_turn_tilts_the_vertical_by(scene: Scene, euler) -> None:
    turn = Rotation.from_euler("ZYX", euler, degrees=True)
    tilts = FeetOnFloor(scene, 0.0).tilts(_turned(scene, turn))
    assert tilts.shape == (2,)
    np.testing.assert_allclose(tilts, _reference_tilt(turn), atol=1e-5)
    if euler[1] == euler[2] == 0.0:  # a turn about the vertical alone tilts nothing
        np.testing.assert_allclose(tilts, 0.0, atol=1e-5)


@pytest.mark.parametrize("pitch, level", [(3.9, True), (4.1, False)])
def test_feet_level_compares_the_larger_tilt_with_the_limit(scene: Scene, pitch: float, level: bool) -> None:
    d = _turned(scene, Rotation.from_euler("Y", pitch, degrees=True))
    assert BalanceController(scene, BalanceConfig(release_level=4.0)).feet_level(d) is level
    assert BalanceController(scene, BalanceConfig()).feet_level(d) is True  # without the option: always level


def _first_release(scene: Scene, config: BalanceConfig, tilts, seconds: float = 0.8) -> float | None:
    """Stubby at home on its feet under a fresh controller (the person far away), each foot's tilt read as
    ``tilts(t)`` (degrees at simulated time t; ``None``: the tilts must not be read at all): the time of the first
    physics step after which the harness is off (``None``: never)."""
    m = scene.model
    d, q, ctl, ctrl0 = standing_far(scene, config)
    clock = {"t": 0.0}

    def scripted(_data: mujoco.MjData) -> np.ndarray:
        if tilts is None:
            raise AssertionError("the feet's tilts were read without release_level")
        return np.array([tilts(clock["t"]), 0.0])

    ctl.feet.tilts = scripted  # type: ignore[method-assign]
    dt = m.opt.timestep
    for k in range(int(round(seconds / dt))):
        clock["t"] = k * dt
        if k % 25 == 0:
            ctl.begin_frame(q, (True, True))
        d.ctrl[scene.act_ids] = ctrl0
        ctl.step(m, d, q, np.zeros(len(scene.robot_vadr) - 6))
        if ctl.released:
            return clock["t"]
    return None


def test_a_foot_off_level_restarts_the_releases_delay(scene: Scene) -> None:
    delay, until = 0.15, 0.3
    plain = _first_release(scene, BalanceConfig(release_delay=delay), None)
    assert plain is not None and delay - 0.01 <= plain <= delay + 0.02  # let go after the delay
    # A foot 10° off level until 0.3 s: let go only a whole delay after it stands level.
    gated = _first_release(scene, BalanceConfig(release_delay=delay, release_level=4.0),
                           lambda t: 10.0 if t < until else 0.0)
    assert gated is not None and until + delay - 0.01 <= gated <= until + delay + 0.02
    # Within the limit throughout: let go exactly as without the option.
    assert _first_release(scene, BalanceConfig(release_delay=delay, release_level=4.0), lambda t: 3.0) == plain
    # Off level throughout: never let go.
    assert _first_release(scene, BalanceConfig(release_delay=delay, release_level=4.0), lambda t: 4.5) is None


@pytest.mark.parametrize("value", [-1.0, 90.0, float("nan")])
def test_release_level_rejects_bad_values(value: float) -> None:
    with pytest.raises(ConfigError, match="release_level"):
        BalanceConfig(release_level=value)


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
        assert ctrl._tilt(now) == pytest.approx(want, abs=1e-4)
