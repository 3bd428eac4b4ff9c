"""The joints handed over from the servos to the balance controller over a ramp (``BalanceConfig.torque_handover``,
:mod:`socialaff_sim.sim.torque_handover`): the blend's endpoints exactly the pure servo and pure controller torques,
the ramp's direction, and on the Unitree H1 in physics the actuators' forces against the servo law written out by
hand and against the torque limits read from the MJCF file itself."""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest

from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.balance_control import BalanceController
from socialaff_sim.sim.scene import Scene, build_scene
from socialaff_sim.sim.torque_handover import TorqueHandover, blend, handover_weight

from conftest import shared_robot
from test_balance_control import standing_far

RAMP = 0.2
QP = BalanceConfig(solver="qp", sole_gap=0.01, w_torso=3.0, flat_feet=True)


def test_weight_rises_from_the_servos_to_the_controller() -> None:
    dt = 0.004
    a = np.array([handover_weight(k, dt, RAMP) for k in range(80)])
    assert a[0] == 0.0 and a[50] == 1.0 and a[-1] == 1.0  # 0.2 s = 50 steps of 4 ms
    assert np.all(np.diff(a) >= 0.0) and np.all(np.diff(a[:51]) > 0.0)
    np.testing.assert_allclose(a[:51], np.linspace(0.0, 1.0, 51), atol=1e-12)


def test_blend_is_exactly_each_end_and_between_them(rng: np.random.Generator) -> None:
    for _ in range(50):
        lo = -rng.uniform(1.0, 300.0, 19)
        hi = rng.uniform(1.0, 300.0, 19)
        servo, ctrl = rng.uniform(lo, hi), rng.uniform(lo, hi)
        assert np.array_equal(blend(servo, ctrl, 0.0), servo)
        assert np.array_equal(blend(servo, ctrl, 1.0), ctrl)
        a = float(rng.uniform())
        mid = blend(servo, ctrl, a)
        np.testing.assert_allclose(mid, servo + a * (ctrl - servo), rtol=1e-12, atol=1e-9)
        assert np.all(mid >= lo - 1e-9) and np.all(mid <= hi + 1e-9)  # within limits both ends keep


def test_the_ramp_starts_again_after_an_idle_step() -> None:
    h = TorqueHandover(RAMP, 0.004)
    s, c = np.zeros(2), np.ones(2)
    first = [h.torque(s, c)[0] for _ in range(60)]
    assert first[0] == 0.0 and first[25] == pytest.approx(0.5) and first[-1] == 1.0
    assert h.ramp_steps == 50
    h.idle()  # caught: the next take-over begins at the servos' torque again
    assert h.torque(s, c)[0] == 0.0
    h.reset()
    assert h.ramp_steps == 0 and h.torque(s, c)[0] == 0.0


@pytest.mark.parametrize("ramp", [0.0, -0.1, float("nan")])
def test_config_rejects_a_ramp_that_is_not_positive(ramp: float) -> None:
    with pytest.raises(ConfigError, match="torque_handover"):
        BalanceConfig(torque_handover=ramp)


def _mjcf_limits(path, scene: Scene) -> np.ndarray:
    """(A,) each actuator's torque limit (N·m) as the MJCF file declares it: its motor's ``ctrlrange`` × gear."""
    motors = {el.get("joint"): el for el in ET.parse(path).getroot().iter("motor")}
    m = scene.model
    out = []
    for i in scene.act_ids:
        joint = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, int(m.actuator_trnid[i, 0])).split("/")[-1]
        el = motors[joint]
        gear = float((el.get("gear") or "1").split()[0])
        lo, hi = (float(x) for x in el.get("ctrlrange").split())
        assert lo == -hi
        out.append(hi * gear)
    return np.array(out)


@pytest.fixture(scope="module")
def h1():
    path = shared_robot("unitree_h1", "h1.xml")
    return path, build_scene(load_robot("unitree_h1", mjcf=path), get_layout("kinect_v2"), harness_time_constant=0.02)


def test_h1_released_exerts_the_servos_torque_then_the_blend_then_the_controllers(h1) -> None:
    path, scene = h1
    m = scene.model
    limit = _mjcf_limits(path, scene)
    d, q, ctl, ctrl0 = standing_far(scene, dataclasses.replace(QP, torque_handover=RAMP))
    kp = m.actuator_gainprm[scene.act_ids, 0]
    kv = -m.actuator_biasprm[scene.act_ids, 2]
    aq, av = np.asarray(scene.act_qadr), np.asarray(scene.act_vadr)
    dt = m.opt.timestep
    k_in, gap = None, 0.0
    for k in range(200):
        if k % 25 == 0:
            ctl.begin_frame(q, (True, True))
        d.ctrl[scene.act_ids] = ctrl0
        q0, v0 = d.qpos[aq].copy(), d.qvel[av].copy()  # the state the step's forces are computed at
        ctl.step(m, d, q, np.zeros(len(scene.robot_vadr) - 6))
        if not ctl.active:
            assert k_in is None  # released and not caught again within the test's span
            continue
        k_in = k if k_in is None else k_in
        servo, qp, a = ctl.handover.last
        # the servo's law written out: kp (ctrl − q) − kv q̇, within the motor's declared torque
        np.testing.assert_allclose(servo, np.clip(kp * (ctrl0 - q0) - kv * v0, -limit, limit), rtol=1e-9, atol=1e-6)
        assert a == pytest.approx(min((k - k_in) * dt / RAMP, 1.0), abs=1e-12)
        np.testing.assert_allclose(d.actuator_force[scene.act_ids], (1.0 - a) * servo + a * qp, rtol=1e-9, atol=1e-6)
        assert np.all(np.abs(d.actuator_force[scene.act_ids]) <= limit + 1e-6)
        if k == k_in:
            gap = float(np.max(np.abs(qp - servo) / limit))
    assert k_in is not None and 199 - k_in > RAMP / dt  # released, and the ramp ran to its end
    # At the take-over the two torques differ (by at least a tenth of a limit): an inverted ramp, starting at the
    # controller's torque, fails the first step's check above.
    assert gap >= 0.1
    assert ctl.handover.ramp_steps == round(RAMP / dt)


def test_without_the_option_the_controller_has_no_ramp(h1) -> None:
    _, scene = h1
    assert BalanceController(scene, QP).handover is None
