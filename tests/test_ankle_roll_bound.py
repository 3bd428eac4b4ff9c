"""The ankles' roll torque bounded by what the floor can hold with each foot flat (``BalanceConfig.roll_bound``,
sim/ankle_roll_bound.py; an option, off): the roll joints found on Stubby (and not with its feet's axes turned), the
lever from its 11 cm sole, the measured loads and moments against MuJoCo's own generalised constraint forces (a foot
rolled onto its edge: the exact torque that holds it there lies outside the window by m_r·F_z), the clip's window by
hand, a pushed Stubby's ankle torques inside the window with the option and outside it without, the settings' errors
(docs/design.md §5, "The standing mode's ankles' roll torque …")."""

from __future__ import annotations


import mujoco
import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.ankle_roll_bound import AnkleRollBound, roll_joint_rows
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.feet_on_floor import FeetOnFloor
from socialaff_sim.sim.scene import pose_compliant
import test_balance_control


def _names(m: mujoco.MjModel, vadr: np.ndarray, rows: list[int | None]) -> list[str | None]:
    jnt = {int(m.jnt_dofadr[j]): j for j in range(m.njnt)}
    return [None if r is None else m.joint(jnt[int(vadr[r])]).name.split("/")[-1] for r in rows]


def test_the_roll_joints_are_the_ankles_hinges_along_the_feet(scene) -> None:
    m = scene.model
    feet = FeetOnFloor(scene, 0.0)
    va = np.asarray(scene.robot_vadr)
    assert _names(m, va, roll_joint_rows(m, feet, va)) == ["left_ankle_roll", "right_ankle_roll"]
    feet.forward = np.array([[0.0, 1.0, 0.0]] * 2)  # feet pointing sideways: the pitch hinges lie along them
    assert _names(m, va, roll_joint_rows(m, feet, va)) == ["left_ankle_pitch", "right_ankle_pitch"]
    feet.forward = np.array([[0.0, 0.0, 1.0]] * 2)  # along no hinge of the foot: not bounded
    assert roll_joint_rows(m, feet, va) == [None, None]


def test_the_lever_is_half_the_soles_width_less_the_margin(scene) -> None:
    feet = FeetOnFloor(scene, 0.0)
    va = np.asarray(scene.robot_vadr)
    # Stubby's foot box: 0.11 m wide (assets/robots/ours.xml, size 0.11 0.055 0.025)
    np.testing.assert_allclose(AnkleRollBound(scene.model, feet, va, 0.01).arms, [0.045, 0.045], atol=1e-9)
    np.testing.assert_allclose(AnkleRollBound(scene.model, feet, va, 0.0).arms, [0.055, 0.055], atol=1e-9)
    np.testing.assert_allclose(AnkleRollBound(scene.model, feet, va, 0.07).arms, [0.0, 0.0], atol=0.0)


def _pressed(scene, roll: float, depth: float = 0.0015) -> mujoco.MjData:
    """Stubby at home, its ankles' roll hinges turned by ``roll`` (rad) (the feet rolled about their long axes, +y
    up for a positive roll about +x), its lowest sole corner
    ``depth`` into the floor, the person far away, the harness's weld off, kinematics and constraint forces worked out (mj_forward)."""
    m = scene.model
    d = mujoco.MjData(m)
    q = scene.home_qpos.copy()
    d.qpos[scene.robot_qadr] = q
    for side in ("left", "right"):
        d.qpos[m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, f"robot/{side}_ankle_roll")]] = roll
    far = np.array([10.0, 10.0, 1.0]) + np.arange(len(scene.human_mocap))[:, None] * [0.0, 0.3, 0.0]
    d.mocap_pos[scene.human_mocap] = far  # the person far away (as test_balance_control.standing_far)
    pose_compliant(scene, d, far, np.array(d.mocap_quat[scene.human_mocap]))
    weld = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, "robot_anchor")
    if weld >= 0:
        d.eq_active[weld] = 0
    mujoco.mj_kinematics(m, d)
    feet = [g for g in range(m.ngeom) if "foot" in (m.geom(g).name or "") and scene.robot_geom[g]
            and m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX]
    low = min(float((d.geom_xpos[g] + d.geom_xmat[g].reshape(3, 3) @ (m.geom_size[g] * [sx, sy, -1.0]))[2])
              for g in feet for sx in (-1, 1) for sy in (-1, 1))
    d.qpos[scene.robot_qadr[2]] -= low + depth
    mujoco.mj_forward(m, d)
    return d


@pytest.mark.parametrize("roll", [0.0, 0.02])
def test_measured_loads_and_moments_against_mujocos_constraint_forces(scene, roll) -> None:
    # MuJoCo's qfrc_constraint (Jᵀ of the solver's forces) is the exact moment of each foot's contacts about its
    # roll hinge (nothing else acts below it) and, on the root's vertical row, the feet's whole vertical load.
    m = scene.model
    d = _pressed(scene, roll)
    feet = FeetOnFloor(scene, 0.0)
    va = np.asarray(scene.robot_vadr)
    bound = AnkleRollBound(m, feet, va, 0.0)
    bound.measure(m, d)
    assert bound.loads.min() > 5.0
    assert bound.loads.sum() == pytest.approx(float(d.qfrc_constraint[va[2]]), rel=1e-6)
    exact = np.array([d.qfrc_constraint[va[r]] for r in bound.rows])
    if roll == 0.0:  # flat: the centre of pressure under the sole's middle, its moment the whole one
        np.testing.assert_allclose(bound.moments, exact, atol=1e-3 * bound.loads.max())
        return
    # rolled 1.15° (+y up): each foot stands on its −y edge, 5.5 cm from the middle: the exact moment is the
    # middle's plus the edge's lever times the load, and the torque that holds the foot there, −exact, lies on
    # the window's end with m_r = 0 and outside it by m_r·F_z with m_r = 1 cm
    ax = np.array([d.xaxis[j] for j in bound._joints])
    lever = np.einsum("si,si->s", ax, np.cross([[0.0, -0.055, 0.0]] * 2, np.c_[np.zeros((2, 2)), bound.loads]))
    np.testing.assert_allclose(exact - bound.moments, lever, rtol=0.03)
    n = len(va)
    for m_r, inside in ((0.0, True), (0.01, False)):
        b = AnkleRollBound(m, feet, va, m_r)
        b.measure(m, d)
        lim = b.clip(np.full((n, 2), [-1e3, 1e3]))
        for s, r in enumerate(b.rows):
            tau = -exact[s]
            gap = max(lim[r, 0] - tau, tau - lim[r, 1])
            if inside:
                assert abs(gap) <= 0.03 * 0.055 * b.loads[s]
            else:
                assert gap == pytest.approx(0.01 * b.loads[s], rel=0.3)


def test_the_clip_narrows_each_roll_row_to_the_floors_window_and_keeps_zero(scene) -> None:
    m = scene.model
    va = np.asarray(scene.robot_vadr)
    bound = AnkleRollBound(m, FeetOnFloor(scene, 0.0), va, 0.01)
    n = len(va)
    (l, r) = bound.rows
    bound.loads, bound.moments = np.array([300.0, 300.0]), np.array([2.0, 20.0])
    lim = bound.clip(np.full((n, 2), [-50.0, 50.0]))
    np.testing.assert_allclose(lim[l], [-2.0 - 13.5, -2.0 + 13.5])  # −M ± 0.045 · 300
    np.testing.assert_allclose(lim[r], [-33.5, 0.0])  # [−33.5, −6.5], widened to 0
    others = np.setdiff1d(np.arange(n), [l, r])
    np.testing.assert_array_equal(lim[others], np.full((len(others), 2), [-50.0, 50.0]))
    lim = bound.clip(np.full((n, 2), [-5.0, 5.0]))  # the row's own limits narrower
    np.testing.assert_allclose(lim[l], [-5.0, 5.0])
    np.testing.assert_allclose(lim[r], [-5.0, 0.0])
    bound.loads, bound.moments = np.array([-1.0, 0.0]), np.array([-3.0, 0.0])  # no load: τ = −M only, with 0
    lim = bound.clip(np.full((n, 2), [-50.0, 50.0]))
    np.testing.assert_allclose(lim[l], [0.0, 3.0])
    np.testing.assert_allclose(lim[r], [0.0, 0.0])


@pytest.mark.parametrize("on", [False, True])
def test_a_pushed_stubbys_ankle_roll_torques_stay_in_the_window_with_the_bound(scene, on) -> None:
    # Stubby released and pushed sideways with 80 N for 0.3 s. The window from the last step's contacts (as the
    # controller reads it, before its step), the torque the actuator then applies: inside at every driven step with
    # the bound; without it, outside at some steps.
    m = scene.model
    cfg = BalanceConfig(solver="qp", flat_feet=True, roll_bound=0.01 if on else None)
    d, q, ctl, ctrl0 = test_balance_control.standing_far(scene, cfg)
    window = AnkleRollBound(m, ctl.feet, ctl.vadr, 0.01)
    n = len(ctl.vadr)
    outside = []
    for k in range(int(round(1.0 / m.opt.timestep))):
        if k % 25 == 0:
            ctl.begin_frame(q, (True, True))
        t = k * m.opt.timestep
        d.xfrc_applied[ctl._torso, 1] = 80.0 if 0.3 <= t < 0.6 else 0.0
        d.ctrl[scene.act_ids] = ctrl0
        lim = window.clip(np.full((n, 2), [-np.inf, np.inf]))
        ctl.step(m, d, q, np.zeros(n - 6))
        window.measure(m, d)
        if ctl.active and k > 0:
            outside.extend(max(lim[r, 0] - float(d.qfrc_actuator[ctl.vadr[r]]),
                               float(d.qfrc_actuator[ctl.vadr[r]]) - lim[r, 1]) for r in window.rows)
    assert ctl.active_steps > 200 and ctl.qp_failures == 0
    worst = max(outside)
    if on:
        assert worst <= 1e-3
    else:
        assert worst > 0.05


def test_the_settings_errors() -> None:
    with pytest.raises(ConfigError, match="roll_bound"):
        BalanceConfig(roll_bound=0.01)  # the least-squares solver has no torque limits
    with pytest.raises(ConfigError, match="roll_bound"):
        BalanceConfig(solver="qp", roll_bound=-0.01)
    BalanceConfig(solver="qp", flat_feet=True, roll_bound=0.0)
