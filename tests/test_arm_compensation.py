"""The arms' references moved to make up for the trunk's pose error (sim/arm_compensation.py,
BalanceConfig(arm_compensation=...)): the damped least-squares step against numpy.linalg.lstsq on the stacked system,
the force's fade, the wrist put back where the plan has it on a turned and shifted trunk (MuJoCo's forward
kinematics, not the Jacobian), nothing without a trunk error, an arm the person holds left alone, only the person's
contacts counted, the settings' checks, and a high five in physics that the standing robot meets only with it."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest

from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim.arm_compensation import DAMPING_LAMBDA, ArmCompensation, approach_gate, compensation_step, fade
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.external_force import Contacts
from socialaff_sim.sim.simulator import SimConfig, Simulator


@pytest.mark.parametrize("k", [3, 5, 7])
def test_the_step_is_the_damped_least_squares_minimiser(k) -> None:
    rng = np.random.default_rng(k)
    J = rng.normal(size=(3, k))
    e = rng.normal(scale=0.1, size=3)
    lam = 0.05
    # reference: min ‖J x − e‖² + λ² ‖x‖² as an ordinary least squares on the stacked system [J; λI] x = [e; 0]
    ref = np.linalg.lstsq(np.vstack([J, lam * np.eye(k)]), np.concatenate([e, np.zeros(k)]), rcond=None)[0]
    np.testing.assert_allclose(compensation_step(J, e, lam), ref, atol=1e-10)
    # undamped and J of full row rank: the shift is met exactly
    np.testing.assert_allclose(J @ compensation_step(J, e, 0.0), e, atol=1e-10)


def test_the_force_on_an_arm_fades_the_compensation_out() -> None:
    f = np.array([[0.0, 0.0, 0.0], [6.0, 8.0, 0.0]])  # 0 N and 10 N
    np.testing.assert_allclose(fade(f, 20.0), [1.0, 0.5])
    np.testing.assert_allclose(fade(f, 10.0), [1.0, 0.0])
    np.testing.assert_allclose(fade(3.0 * f, 20.0), [1.0, 0.0])  # beyond F_r: none, not negative
    assert fade(np.array([[1.0, 0, 0], [2.0, 0, 0]]), 20.0)[0] > fade(np.array([[1.0, 0, 0], [2.0, 0, 0]]), 20.0)[1]


def _state(scene, roll_deg: float = 0.0, pitch_deg: float = 0.0, shift=(0.0, 0.0, 0.0)):
    """(d, q_ref, comp): the robot at home with its arms raised forward as the plan ``q_ref``; ``d`` the same joints on a
    root turned by ``roll_deg`` about x and ``pitch_deg`` about y and moved by ``shift`` (m)."""
    m = scene.model
    q_ref = np.array(scene.home_qpos, dtype=np.float64)
    comp = ArmCompensation(scene, 1.0, 20.0, 0.0)
    for s in (0, 1):  # the arms raised forward, elbows bent (away from the straight arm's singular Jacobian)
        q_ref[comp._cols[s][[0, 3]] + 1] = [-0.8, -1.2]
    d = mujoco.MjData(m)
    q = q_ref.copy()
    q[:3] += np.asarray(shift)
    turn = np.zeros(4)
    mujoco.mju_euler2Quat(turn, np.radians([roll_deg, pitch_deg, 0.0]), "xyz")
    mujoco.mju_mulQuat(q[3:7], turn, q_ref[3:7].copy())
    d.qpos[scene.robot_qadr] = q
    mujoco.mj_forward(m, d)
    return d, q_ref, comp


def _wrists_with(scene, d, comp, dq: np.ndarray) -> np.ndarray:
    """(2, 3) MuJoCo's wrists of ``d`` with the hinges moved by ``dq`` (n − 6,)."""
    m = scene.model
    d2 = mujoco.MjData(m)
    d2.qpos[:] = d.qpos
    d2.qpos[scene.robot_qadr[7:]] += dq
    mujoco.mj_kinematics(m, d2)
    return comp._wrists(d2)


def _plan_wrists(scene, d, q_ref, comp) -> np.ndarray:
    m = scene.model
    d2 = mujoco.MjData(m)
    d2.qpos[:] = d.qpos
    d2.qpos[scene.robot_qadr] = q_ref
    mujoco.mj_kinematics(m, d2)
    return comp._wrists(d2)


@pytest.mark.parametrize("roll, pitch, shift", [(6.0, 0.0, (0.0, 0.0, 0.0)), (0.0, -8.0, (0.0, 0.0, 0.0)),
                                                (-4.0, 5.0, (-0.04, 0.02, 0.0))])
def test_the_wrists_go_back_where_the_plan_has_them_on_a_turned_trunk(scene, roll, pitch, shift) -> None:
    d, q_ref, comp = _state(scene, roll, pitch, shift)
    plan = _plan_wrists(scene, d, q_ref, comp)
    before = np.linalg.norm(_wrists_with(scene, d, comp, np.zeros(len(q_ref) - 7)) - plan, axis=1)
    assert (before > 0.03).all()  # the turned trunk moves each hand by centimetres
    dq = comp.offsets(scene.model, d, q_ref)
    after = np.linalg.norm(_wrists_with(scene, d, comp, dq) - plan, axis=1)
    assert (after < 0.35 * before).all()  # linearised and damped: most of it, not all
    backwards = np.linalg.norm(_wrists_with(scene, d, comp, -dq) - plan, axis=1)
    assert (backwards > before).all()  # the sign matters
    arms = np.zeros(len(q_ref) - 7, dtype=bool)
    for s in (0, 1):
        arms[comp._cols[s] - 6] = True
    assert not dq[~arms].any() and np.abs(dq[arms]).max() > 0.01  # only the arms' hinges move


def test_what_is_left_is_of_second_order(scene) -> None:
    """One linearised step: the wrist's residual shrinks faster than the trunk's error (a wrong Jacobian would
    leave a residual proportional to it)."""
    ratio = []
    for pitch in (-8.0, -2.0):
        d, q_ref, comp = _state(scene, 0.0, pitch)
        plan = _plan_wrists(scene, d, q_ref, comp)
        before = np.linalg.norm(_wrists_with(scene, d, comp, np.zeros(len(q_ref) - 7)) - plan, axis=1)
        after = np.linalg.norm(_wrists_with(scene, d, comp, comp.offsets(scene.model, d, q_ref)) - plan, axis=1)
        ratio.append(after / before)
    assert (ratio[1] < 0.5 * ratio[0]).all()


def test_no_trunk_error_no_offset_and_the_fraction_scales_it(scene) -> None:
    d, q_ref, comp = _state(scene)
    np.testing.assert_allclose(comp.offsets(scene.model, d, q_ref), 0.0, atol=1e-12)
    d, q_ref, comp = _state(scene, 6.0, 3.0)
    full = comp.offsets(scene.model, d, q_ref)
    comp.fraction = 0.5
    np.testing.assert_allclose(comp.offsets(scene.model, d, q_ref), 0.5 * full, atol=1e-12)
    comp.fraction = 0.0
    assert not comp.offsets(scene.model, d, q_ref).any()


def test_an_arm_the_person_holds_is_left_alone(scene) -> None:
    d, q_ref, comp = _state(scene, 6.0, 3.0)
    free = comp.offsets(scene.model, d, q_ref)
    cols = [comp._cols[s] - 6 for s in (0, 1)]
    comp.force = np.array([[25.0, 0.0, 0.0], [0.0, 10.0, 0.0]])  # left beyond F_r = 20 N, right half of it
    held = comp.offsets(scene.model, d, q_ref)
    assert not held[cols[0]].any()
    np.testing.assert_allclose(held[cols[1]], 0.5 * free[cols[1]], atol=1e-12)


def test_only_the_persons_contacts_count(scene) -> None:
    m = scene.model
    comp = ArmCompensation(scene, 1.0, 20.0, 0.0)
    right = int(np.flatnonzero(scene.arm_geom[1])[0])
    person = int(scene.human_geom_ids[-1])
    other = int(next(g for g in range(m.ngeom) if g not in set(scene.human_geom_ids.tolist()) and not scene.robot_geom[g]))
    pts = np.array([[0.3, -0.1, 1.0], [0.3, -0.1, 0.9]])
    forces = np.array([[-40.0, 0.0, 5.0], [0.0, 70.0, 0.0]])
    comp.measure(m, Contacts(pts, forces, np.array([right, right]), np.array([person, other])))
    np.testing.assert_allclose(comp.force, [[0.0, 0.0, 0.0], [-40.0, 0.0, 5.0]], atol=1e-12)


def test_the_approach_gate_against_brute_force() -> None:
    rng = np.random.default_rng(7)
    for _ in range(50):
        w = rng.normal(scale=0.5, size=(2, 3))
        t = rng.normal(scale=0.5, size=(int(rng.integers(1, 6)), 3))
        touched = rng.random(2) < 0.3
        r = float(rng.uniform(0.05, 0.8))
        ref = [float(not touched[s] and min(math.dist(w[s], p) for p in t) <= r) for s in (0, 1)]
        np.testing.assert_array_equal(approach_gate(w, t, touched, r), ref)
    w = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    t = np.array([[0.3, 0.0, 0.0]])
    np.testing.assert_array_equal(approach_gate(w, t, np.zeros(2, bool), 0.5), [1.0, 0.0])  # near opens, far shuts
    np.testing.assert_array_equal(approach_gate(w, t, np.array([True, False]), 0.5), [0.0, 0.0])  # a touch shuts
    np.testing.assert_array_equal(approach_gate(w, t, np.zeros(2, bool), 0.8), [1.0, 1.0])
    np.testing.assert_array_equal(approach_gate(w, np.zeros((0, 3)), np.zeros(2, bool), 9.0), [0.0, 0.0])


def test_the_gate_confines_the_offsets_to_an_untouched_arm_near_the_person(scene) -> None:
    d, q_ref, comp = _state(scene, 6.0, 3.0)
    free = comp.offsets(scene.model, d, q_ref)
    cols = [comp._cols[s] - 6 for s in (0, 1)]
    assert np.abs(free[cols[0]]).max() > 0.01 and np.abs(free[cols[1]]).max() > 0.01
    comp.gate = 1e3  # everything is near: the same offsets as ungated
    np.testing.assert_array_equal(comp.offsets(scene.model, d, q_ref), free)
    comp.gate = 1e-4  # nothing is that near: none
    assert not comp.offsets(scene.model, d, q_ref).any() and not comp.shift.any()
    comp.gate = 1e3
    comp.touched = np.array([False, True])  # the right arm has touched: only the left is compensated
    gated = comp.offsets(scene.model, d, q_ref)
    np.testing.assert_array_equal(gated[cols[0]], free[cols[0]])
    assert not gated[cols[1]].any()
    comp.touched[:] = True
    assert not comp.offsets(scene.model, d, q_ref).any()
    # the radius is measured from the plan's wrist to the person's nearest geom centre
    plan = _plan_wrists(scene, d, q_ref, comp)
    dist = np.linalg.norm(plan[:, None] - d.geom_xpos[scene.human_geom_ids][None], axis=2).min(axis=1)
    comp.touched[:] = False
    comp.gate = float(dist.min() + dist.max()) / 2.0
    near = int(np.argmin(dist))
    if dist.max() - dist.min() > 1e-3:
        gated = comp.offsets(scene.model, d, q_ref)
        np.testing.assert_array_equal(gated[cols[near]], free[cols[near]])
        assert not gated[cols[1 - near]].any()


def test_an_arms_first_touch_of_the_person_latches_its_gate(scene) -> None:
    m = scene.model
    right = int(np.flatnonzero(scene.arm_geom[1])[0])
    person = int(scene.human_geom_ids[-1])
    other = int(next(g for g in range(m.ngeom) if g not in set(scene.human_geom_ids.tolist()) and not scene.robot_geom[g]
                     and g != scene.object_geom))
    none = (np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.int64), np.zeros(0, np.int64))
    touch = (np.array([[0.3, -0.1, 1.0]]), np.array([[1.0, 0.0, 0.0]]), np.array([right]), np.array([person]))
    stray = (touch[0], touch[1], np.array([right]), np.array([other]))
    ungated = ArmCompensation(scene, 1.0, 20.0, 0.0)
    ungated.measure(m, Contacts(*touch))
    assert not ungated.touched.any()  # ungated: no latch
    comp = ArmCompensation(scene, 1.0, 20.0, 0.0, gate=0.5)
    comp.measure(m, Contacts(*stray))
    assert not comp.touched.any()  # not the person nor the object
    comp.measure(m, Contacts(*touch))
    np.testing.assert_array_equal(comp.touched, [False, True])  # the right arm, not the left
    comp.measure(m, Contacts(*none))
    np.testing.assert_array_equal(comp.touched, [False, True])  # it stays shut after the touch
    comp.reset()
    assert not comp.touched.any()  # until the next episode


def test_the_gate_reaches_the_controller() -> None:
    cfg = SimConfig.standing()
    inter = next(i for i in generate_dataset(seed=0) if i.instance_id == "high_five_004")
    for gate in (None, 0.4):
        sim = Simulator("ours", "high_five", dataclasses.replace(
            cfg, balance=dataclasses.replace(cfg.balance, arm_compensation=1.0, compensation_gate=gate,
                                             com_plan_velocity=False, torso_plan_velocity=False,
                                             plan_velocity_until_touch=False, plan_velocity_raised=None,
                                             plan_velocity_tilt=None, com_shift=None, shift_until_touch=False,
                                             hand_task_velocity_until_touch=False,
                                             touch_friction=None, shear_couple=None,
                                             shear_couple_touched=False)))  # (these read the gate's latch)
        assert sim._get_stage(inter).stepper.balance.compensation.gate == gate


def test_settings_are_checked() -> None:
    with pytest.raises(ConfigError, match="arm_compensation"):
        BalanceConfig(arm_compensation=-0.5)
    with pytest.raises(ConfigError, match="compensation_release"):
        BalanceConfig(arm_compensation=1.0, compensation_release=0.0)
    for bad in (0.0, -0.1, float("nan")):
        with pytest.raises(ConfigError, match="compensation_gate"):
            BalanceConfig(arm_compensation=1.0, compensation_gate=bad)
    assert BalanceConfig().compensation_gate is None
    assert BalanceConfig().arm_compensation is None
    assert DAMPING_LAMBDA > 0.0


def test_a_standing_robot_meets_the_high_five_its_turned_trunk_missed() -> None:
    """high_five_004 (synthetic, seed 0), Stubby in ``SimConfig.standing()``: released under the balance QP, the
    trunk turns 5° off the plan's base during the raise and the hand stops 7–8 cm short; the contact completion's
    target then lies beyond the arm's reach and its weight stays 0. With the arms' references compensated the hand
    meets the raised hand, and the completion's gate opens (partly: β 0.13) (docs/benchmarks.md, "Why the standing
    robot's hand stops short of a high five …")."""
    inter = next(i for i in generate_dataset(seed=0) if i.instance_id == "high_five_004")
    met, beta = [], []
    for c, gate in ((None, None), (1.0, None), (1.0, 0.4)):  # the last confined to the approach (d_g 0.4 m)
        cfg = SimConfig.standing(floor_time_constant=None)  # on MuJoCo's floor, as traced
        sim = Simulator("ours", "high_five", dataclasses.replace(
            cfg, balance=dataclasses.replace(cfg.balance, arm_compensation=c, compensation_gate=gate,
                                             com_plan_velocity=False, torso_plan_velocity=False,
                                             plan_velocity_until_touch=False, plan_velocity_raised=None,
                                             plan_velocity_tilt=None, com_shift=None, shift_until_touch=False,
                                             hand_task_velocity_until_touch=False,
                                             touch_friction=None, shear_couple=None,
                                             shear_couple_touched=False)))  # as the rule found it
        met.append(run_episode(sim, GroundTruthSource(), inter)["success"])
        beta.append(max(float(np.max(r.completion)) for r in sim.results if r.completion is not None))
    assert met == [False, True, True]
    assert beta[0] == 0.0 and beta[1] > 0.05 and beta[2] > 0.05
