"""Real weight: the support meter, the standing feed-forward torques, the compliant harness and foot planting."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim.feedforward import StandingFeedforward
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.footlock import FootLock, FootLockConfig
from socialaff_sim.sim.scene import build_scene, pose_compliant
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.stance import StanceConfig
from socialaff_sim.sim.support import SupportMeter

LAYOUT = get_layout("kinect_v2")


def _hold(scene, lift: float, steps: int, *, feedforward: bool, feet: tuple[bool, bool]) -> tuple[SupportMeter, mujoco.MjData]:
    """Hold the robot at home ``lift`` m above its standing height for ``steps`` physics steps."""
    m = scene.model
    d = mujoco.MjData(m)
    q = scene.home_qpos.copy()
    q[2] += lift
    d.qpos[scene.robot_qadr] = q
    d.mocap_pos[scene.anchor_mocap] = q[:3]
    d.mocap_quat[scene.anchor_mocap] = q[3:7]
    far = np.array([10.0, 10.0, 1.0]) + np.arange(len(scene.human_mocap))[:, None] * [0.0, 0.3, 0.0]
    d.mocap_pos[scene.human_mocap] = far  # the person far away, compliant parts (hands) too
    pose_compliant(scene, d, far, np.array(d.mocap_quat[scene.human_mocap]))
    meter, ff = SupportMeter(scene), StandingFeedforward(scene)
    mujoco.mj_forward(m, d)
    full = d.qpos.copy()
    full[scene.robot_qadr] = q
    ctrl = scene.ctrl_for(full) + (ff.ctrl_offset(full, feet) if feedforward else 0.0)
    for _ in range(steps):
        d.ctrl[scene.act_ids] = ctrl
        mujoco.mj_step(m, d)
        meter.update(d)
    meter.end_frame()
    return meter, d


@pytest.fixture(scope="module")
def ours():
    return load_robot("ours")


def test_a_hanging_robot_is_carried_by_its_harness_and_weighs_its_mass(ours) -> None:
    scene = build_scene(ours, LAYOUT)
    meter, d = _hold(scene, 1.0, 300, feedforward=True, feet=(False, False))
    m = scene.model
    robot = np.array([b == scene.root_body or scene.root_body in _ancestors(m, b) for b in range(m.nbody)])
    mass = float(m.body_mass[robot].sum())  # independent: the bodies' masses summed here
    assert meter.mass == pytest.approx(mass) and meter.weight == pytest.approx(mass * 9.81)
    assert meter.gravcomp_fraction == 0.0
    np.testing.assert_allclose(meter.harness_force(d), [0.0, 0.0, mass * 9.81], atol=0.01 * mass * 9.81)
    assert meter.frames[-1].outside_mean == pytest.approx(1.0, abs=0.05)
    assert meter.feet_down == (False, False) and meter.frames[-1].slide == 0.0


def _ancestors(m: mujoco.MjModel, b: int) -> list[int]:
    out = []
    while b > 0:
        b = int(m.body_parentid[b])
        out.append(b)
    return out


def test_gravity_compensation_is_counted_as_outside_support(ours) -> None:
    scene = build_scene(ours, LAYOUT, gravity_compensation=True)
    meter, d = _hold(scene, 1.0, 100, feedforward=False, feet=(False, False))
    assert meter.gravcomp_fraction == pytest.approx(1.0)
    assert np.linalg.norm(meter.harness_force(d)) < 0.01 * meter.weight  # weightless: the harness holds nothing
    assert meter.frames[-1].outside_mean == pytest.approx(1.0, abs=0.01)  # but the support is all outside


@pytest.mark.parametrize("feedforward", [True, False])
def test_standing_on_its_feet_with_feed_forward_torques(ours, feedforward: bool) -> None:
    scene = build_scene(ours, LAYOUT, harness_time_constant=0.02)
    meter, d = _hold(scene, 0.0, 400, feedforward=feedforward, feet=(True, True))
    out = np.linalg.norm(meter.harness_force(d)) / meter.weight
    assert meter.feet_down == (True, True)
    if feedforward:  # the feet carry the weight, the servos hold the pose
        assert out < 0.05 and meter.frames[-1].torque_ratio < 1.0
    else:  # without it the servos sag and the harness takes a share
        assert out > 0.05


def test_feed_forward_torques_balance_gravity_on_the_feet(ours) -> None:
    scene = build_scene(ours, LAYOUT)
    ff = StandingFeedforward(scene)
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[scene.robot_qadr] = scene.home_qpos
    mujoco.mj_forward(m, d)
    tau = ff.torques(d.qpos, (True, True))
    hanging = ff.torques(d.qpos, (False, False))
    # Hanging from the root: the torques that hold each limb up = gravity's generalised force (mj_rne).
    bias = np.zeros(m.nv)
    mujoco.mj_rne(m, d, 0, bias)
    np.testing.assert_allclose(hanging, bias[scene.act_vadr], atol=1e-9)
    # Standing: the leg joints now carry the body above them, several times their own limb's load.
    knee = [i for i, a in enumerate(scene.act_ids) if "knee" in m.actuator(int(a)).name]
    assert knee and np.all(np.abs(tau[knee]) > 3 * np.abs(hanging[knee]))


def test_foot_lock_plants_a_standing_foot_and_lets_a_step_go() -> None:
    lock = FootLock((0.08, 0.08), FootLockConfig(lift=0.04, radius=0.05))
    down = np.array([[0.0, 0.1, 0.09], [0.0, -0.1, 0.30]])  # left near the floor, right lifted
    out = lock.apply(down)
    np.testing.assert_allclose(out[0], [0.0, 0.1, 0.08])  # planted at home height
    np.testing.assert_allclose(out[1], down[1])  # a lifted foot is followed
    wander = np.array([[0.03, 0.12, 0.1], [0.0, -0.1, 0.30]])  # 3.6 cm away, 2 cm up: still planted
    np.testing.assert_allclose(lock.apply(wander)[0], [0.0, 0.1, 0.08])
    step = np.array([[0.06, 0.1, 0.09], [0.0, -0.1, 0.30]])  # 6 cm: a step, planted anew there
    np.testing.assert_allclose(lock.apply(step)[0], [0.06, 0.1, 0.08])
    lifted = np.array([[0.06, 0.1, 0.13], [0.0, -0.1, 0.30]])  # 5 cm above home height: released
    np.testing.assert_allclose(lock.apply(lifted)[0], lifted[0])
    assert lock.planted[0] is None


def test_hold_lift_keeps_a_planted_foot_through_a_heel_rise_but_plants_no_raised_foot() -> None:
    lock = FootLock((0.08, 0.08), FootLockConfig(lift=0.04, radius=0.05, hold_lift=0.12))
    lock.apply(np.array([[0.0, 0.1, 0.09], [0.0, -0.1, 0.09]]))  # both planted
    rise = np.array([[0.02, 0.1, 0.15], [0.0, -0.1, 0.09]])  # left target 7 cm up, 2 cm aside: a heel rise
    np.testing.assert_allclose(lock.apply(rise)[0], [0.0, 0.1, 0.08])  # held where it stood
    # Without hold_lift the same rise is a step (the foot follows its target).
    plain = FootLock((0.08, 0.08), FootLockConfig(lift=0.04, radius=0.05))
    plain.apply(np.array([[0.0, 0.1, 0.09], [0.0, -0.1, 0.09]]))
    np.testing.assert_allclose(plain.apply(rise)[0], rise[0])
    # Above hold_lift, or beyond the radius, the planted foot steps.
    high = np.array([[0.0, 0.1, 0.21], [0.0, -0.1, 0.09]])  # 13 cm up
    np.testing.assert_allclose(lock.apply(high)[0], high[0])
    assert lock.planted[0] is None
    # Hysteresis: a foot not planted is not planted by a target between lift and hold_lift.
    np.testing.assert_allclose(lock.apply(rise)[0], rise[0])
    assert lock.planted[0] is None
    lock.apply(np.array([[0.0, 0.1, 0.09], [0.0, -0.1, 0.09]]))  # down again: planted
    far = np.array([[0.07, 0.1, 0.15], [0.0, -0.1, 0.09]])  # 7 cm aside and up: a step
    np.testing.assert_allclose(lock.apply(far)[0], far[0])
    assert lock.planted[0] is None


@pytest.mark.parametrize("kw", [{"hold_lift": 0.03}, {"lift": -0.01}, {"radius": -0.1}])
def test_foot_lock_config_errors(kw) -> None:  # noqa: ANN001
    with pytest.raises(ConfigError, match="FootLockConfig"):
        FootLockConfig(**{"lift": 0.04, **kw})


def test_hold_lift_keeps_a_pulling_robot_planted_and_released_longer() -> None:
    """In a pull-up the recorded puller's ankle rises 4–7 cm without stepping (synthetic pull_up_001): with
    ``hold_lift`` the balance controller's robot keeps both feet planted in more frames and stands free of the
    harness for more physics steps."""
    inter = next(i for i in generate_dataset(seed=0) if i.instance_id == "pull_up_001")
    qp = BalanceConfig(solver="qp", sole_gap=0.01, w_torso=3.0)
    planted, released = [], []
    for hold in (None, 0.12):
        sim = Simulator("ours", "pull_up", SimConfig(foot_lock=FootLockConfig(hold_lift=hold), balance=qp,
                                                     stance=StanceConfig(release=False)))
        frames: list[bool] = []
        run_episode(sim, GroundTruthSource(), inter,
                    on_frame=lambda s, r, _: frames.append(all(p is not None for p in s._footlock.planted)))
        planted.append(sum(frames))
        released.append(sim._stage.stepper.balance.harness.released_steps)
    assert planted[1] > planted[0] and released[1] > released[0]
