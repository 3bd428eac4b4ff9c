"""``BalanceConfig.compensation_after_touch`` (sim/arm_compensation.py): with the approach gate's touch latch kept but not
applied, a touched arm keeps its offsets (equal to the ungated step's), the untouched one is unchanged, the approach
radius and the force's fade still shut it, the latch itself is still recorded (other options read it), the setting
needs ``arm_compensation`` and ``compensation_gate``, and it reaches the controller."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.arm_compensation import ArmCompensation
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.external_force import Contacts
from socialaff_sim.sim.simulator import SimConfig, Simulator


def _turned(scene, after_touch: bool, gate: float | None = 1e3):
    """(d, q_ref, comp): arms raised forward in the plan, the same joints on a root rolled 6° and pitched 3°."""
    m = scene.model
    comp = ArmCompensation(scene, 1.0, 20.0, 0.0, gate=gate, after_touch=after_touch)
    q_ref = np.array(scene.home_qpos, dtype=np.float64)
    for s in (0, 1):
        q_ref[comp._cols[s][[0, 3]] + 1] = [-0.8, -1.2]
    d = mujoco.MjData(m)
    q = q_ref.copy()
    turn = np.zeros(4)
    mujoco.mju_euler2Quat(turn, np.radians([6.0, 3.0, 0.0]), "xyz")
    mujoco.mju_mulQuat(q[3:7], turn, q_ref[3:7].copy())
    d.qpos[scene.robot_qadr] = q
    mujoco.mj_forward(m, d)
    return d, q_ref, comp


def test_a_touched_arm_keeps_its_compensation_only_with_the_option(scene) -> None:
    m = scene.model
    d, q_ref, free_comp = _turned(scene, False, gate=None)
    free = free_comp.offsets(m, d, q_ref)  # the ungated step
    cols = [free_comp._cols[s] - 6 for s in (0, 1)]
    assert np.abs(free[cols[0]]).max() > 0.01 and np.abs(free[cols[1]]).max() > 0.01
    for touched in ([False, True], [True, True]):
        _, _, latched = _turned(scene, False)
        latched.touched = np.array(touched)
        _, _, kept = _turned(scene, True)
        kept.touched = np.array(touched)
        off_latched, off_kept = latched.offsets(m, d, q_ref), kept.offsets(m, d, q_ref)
        for s in (0, 1):
            if touched[s]:
                assert not off_latched[cols[s]].any()  # without the option a touched arm gets none
                np.testing.assert_array_equal(off_kept[cols[s]], free[cols[s]])  # with it, the ungated offsets
            else:
                np.testing.assert_array_equal(off_latched[cols[s]], free[cols[s]])
                np.testing.assert_array_equal(off_kept[cols[s]], free[cols[s]])


def test_the_radius_and_the_force_still_shut_it(scene) -> None:
    m = scene.model
    d, q_ref, comp = _turned(scene, True, gate=1e-4)  # nothing is that near
    comp.touched[:] = True
    assert not comp.offsets(m, d, q_ref).any()
    d, q_ref, comp = _turned(scene, True)
    comp.touched[:] = True
    comp.force = np.array([[0.0, 0.0, 0.0], [30.0, 0.0, 0.0]])  # beyond F_r = 20 N on the right arm
    out = comp.offsets(m, d, q_ref)
    assert np.abs(out[comp._cols[0] - 6]).max() > 0.01 and not out[comp._cols[1] - 6].any()


def test_the_latch_is_still_recorded(scene) -> None:
    m = scene.model
    right = int(np.flatnonzero(scene.arm_geom[1])[0])
    person = int(scene.human_geom_ids[-1])
    touch = (np.array([[0.3, -0.1, 1.0]]), np.array([[1.0, 0.0, 0.0]]), np.array([right]), np.array([person]))
    comp = ArmCompensation(scene, 1.0, 20.0, 0.0, gate=0.5, after_touch=True)
    comp.measure(m, Contacts(*touch))
    np.testing.assert_array_equal(comp.touched, [False, True])


def test_settings_are_checked_and_reach_the_controller() -> None:
    with pytest.raises(ConfigError, match="compensation_after_touch"):
        BalanceConfig(compensation_after_touch=True)
    with pytest.raises(ConfigError, match="compensation_after_touch"):
        BalanceConfig(arm_compensation=1.0, compensation_after_touch=True)
    assert not BalanceConfig().compensation_after_touch
    assert not SimConfig.standing().balance.compensation_after_touch
    cfg = SimConfig.standing()
    inter = next(i for i in generate_dataset(seed=0) if i.instance_id == "high_five_004")
    for on in (False, True):
        sim = Simulator("ours", "high_five", dataclasses.replace(
            cfg, balance=dataclasses.replace(cfg.balance, compensation_after_touch=on)))
        assert sim._get_stage(inter).stepper.balance.compensation.after_touch is on
