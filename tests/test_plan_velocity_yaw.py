"""``BalanceConfig.plan_velocity_yaw`` (docs/design.md §5, "The standing mode's high fives: the trunk's turn past the
tilt bound"): past ``plan_velocity_tilt`` the torso's damping tracks the plan's turn about the vertical alone. The
decision (:meth:`PlanVelocity.turns`) against its table, the turn against an analytic rotation, and the rows the QP
gets on each side of the bound."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.plan_velocity import PlanVelocity
from socialaff_sim.sim.scene import Scene

from test_plan_velocity import QP, _posed, _rows, _swung, scene  # noqa: F401, F811  (the module's scene fixture)

ON = {"com_plan_velocity": True, "torso_plan_velocity": True}


@pytest.mark.parametrize("yaw, touched, tilt, until, want", [
    (True, False, 5.0, False, True), (True, False, 3.0, False, False), (True, False, 4.0, False, False),
    (True, True, 5.0, True, False), (True, True, 5.0, False, True), (False, False, 5.0, False, False)])
def test_turns_only_past_the_tilt_bound_and_before_the_latch(scene: Scene, yaw: bool, touched: bool, tilt: float,
                                                           until: bool, want: bool) -> None:
    pv = PlanVelocity.of_scene(scene, np.asarray(scene.limb_body_ids[2:4]), int(scene.limb_body_ids[0]), None,
                               until, 4.0, yaw)
    assert pv.turns(touched, tilt) == want
    if want:  # exactly where follows() gives up for the bound alone
        assert not pv.follows(touched, tilt)


def test_the_turn_about_the_vertical_against_an_analytic_rotation(scene: Scene) -> None:
    # The robot turned by θ about z and pitched by φ about x over T: ω_t = log(R_end R_startᵀ)/T; its vertical part
    # is (0, 0, ω_z), the horizontal part dropped.
    q = scene.home_qpos.copy()
    theta, phi, T = 0.3, 0.2, 0.0875
    turn = np.array([math.cos(theta / 2), 0.0, 0.0, math.sin(theta / 2)])
    pitch = np.array([math.cos(phi / 2), math.sin(phi / 2), 0.0, 0.0])
    rel, quat = np.zeros(4), np.zeros(4)
    mujoco.mju_mulQuat(rel, turn, pitch)
    mujoco.mju_mulQuat(quat, rel, q[3:7])
    end = q.copy()
    end[3:7] = quat
    pv = PlanVelocity.of_scene(scene, np.asarray(scene.limb_body_ids[2:4]), int(scene.limb_body_ids[0]), None,
                               False, 4.0, True)
    pv.measure(q, _posed(scene, end), T)
    # independent reference: the rotation vector of the composed quaternion written out (axis · angle / T)
    angle = 2.0 * math.acos(rel[0])
    axis = rel[1:] / math.sin(angle / 2.0)
    assert np.allclose(pv.torso, axis * angle / T, atol=1e-6)
    assert abs(pv.torso[0]) > 1.0  # the pitch is there to be dropped (not a vacuous comparison)
    assert np.allclose(pv.yaw(), [0.0, 0.0, axis[2] * angle / T], atol=1e-6) and pv.yaw()[:2].tolist() == [0.0, 0.0]


@pytest.mark.parametrize("leaning", [False, True])
def test_past_the_bound_the_torso_rows_track_the_plans_turn_alone(scene: Scene, leaning: bool,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    # The spied step's tilt decides: a bound under it (leaning) gives the rows toward rest plus 2 ω_o (ω_t · z) z on
    # the torso's rows and the centre of mass's rows toward rest; a bound over it the plan's full velocities, as
    # without the option.
    q, end = _swung(scene)
    turn = np.array([math.cos(0.15), 0.0, 0.0, math.sin(0.15)])  # the plan also turns the robot 0.3 rad about z
    quat = np.zeros(4)
    mujoco.mju_mulQuat(quat, turn, end[3:7])
    end[3:7] = quat
    seen: list[float] = []
    real = PlanVelocity.follows

    def spy(self, touched, tilt):  # noqa: ANN001, ANN202
        seen.append(tilt)
        return real(self, touched, tilt)

    monkeypatch.setattr(PlanVelocity, "follows", spy)
    _rows(scene, BalanceConfig(**QP, **ON), q, end, monkeypatch)
    monkeypatch.setattr(PlanVelocity, "follows", real)
    tilt = seen[-1]
    assert tilt > 1e-6
    bound = 0.5 * tilt if leaning else tilt + 5.0
    cfg = BalanceConfig(**QP, **ON, plan_velocity_tilt=bound, plan_velocity_yaw=True)
    tasks, ctl, _ = _rows(scene, cfg, q, end, monkeypatch)
    without, _, _ = _rows(scene, BalanceConfig(**QP, **ON, plan_velocity_tilt=bound), q, end, monkeypatch)
    rest, _, _ = _rows(scene, BalanceConfig(**QP), q, end, monkeypatch)
    wo = cfg.torso_bandwidth
    assert abs(ctl.plan_velocity.torso[2]) > 1.0  # the plan turns (not a vacuous comparison)
    if leaning:
        assert np.array_equal(tasks[-3][1], rest[-3][1])  # the centre of mass toward rest, bit for bit
        assert np.allclose(tasks[-2][1] - rest[-2][1], 2.0 * wo * ctl.plan_velocity.yaw(), atol=1e-9)
        assert np.array_equal(without[-2][1], rest[-2][1])  # without the option: toward rest
    else:
        assert np.array_equal(tasks[-2][1], without[-2][1]) and np.array_equal(tasks[-3][1], without[-3][1])
        assert np.allclose(tasks[-2][1] - rest[-2][1], 2.0 * wo * ctl.plan_velocity.torso, atol=1e-9)


@pytest.mark.parametrize("kw", [{"plan_velocity_yaw": True, "com_plan_velocity": True, "plan_velocity_tilt": 4.0},
                                {"plan_velocity_yaw": True, "torso_plan_velocity": True}])
def test_the_turn_without_the_torsos_velocity_or_the_bound_is_refused(kw: dict) -> None:
    with pytest.raises(ConfigError, match="plan_velocity_yaw"):
        BalanceConfig(**kw)


def test_off_by_default_in_both_modes() -> None:
    from socialaff_sim.sim.simulator import SimConfig
    assert not BalanceConfig().plan_velocity_yaw
    assert not SimConfig.standing().balance.plan_velocity_yaw
