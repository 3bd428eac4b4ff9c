"""``BalanceConfig.angmom_weight`` (:mod:`socialaff_sim.sim.centroidal_momentum`): the centroidal angular momentum's
matrix and rate against MuJoCo's own subtree angular momentum (``mj_subtreeVel``) and its finite differences, the
rows' reference, and the decision whether the balance QP gets the rows."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.centroidal_momentum import CentroidalMomentum, plan_velocity
from socialaff_sim.sim.scene import Scene, build_scene

from test_balance_control import LAYOUT
from test_plan_velocity import QP, _rows, _swung


@pytest.fixture(scope="module")
def scene() -> Scene:
    return build_scene(load_robot("ours"), LAYOUT, harness_time_constant=0.02)


def _moving(scene: Scene, seed: int) -> tuple[mujoco.MjData, np.ndarray]:
    """A posed robot with random joint angles and velocities (its velocities after ``mj_forward``)."""
    m, rng = scene.model, np.random.default_rng(seed)
    d = scene.home_data()
    va, qa = np.asarray(scene.robot_vadr), np.asarray(scene.robot_qadr)
    d.qpos[qa[7:]] += rng.normal(scale=0.3, size=len(qa) - 7)
    d.qvel[va] = rng.normal(size=len(va))
    mujoco.mj_forward(m, d)
    return d, va


def _angmom(m: mujoco.MjModel, d: mujoco.MjData, root: int) -> np.ndarray:
    mujoco.mj_subtreeVel(m, d)
    return d.subtree_angmom[root].copy()


def _advanced(m: mujoco.MjModel, d: mujoco.MjData, qacc: np.ndarray, t: float) -> mujoco.MjData:
    """A copy of ``d``'s state moved on by t (s) at constant joint acceleration ``qacc`` (nv,), forward-computed: the
    central differences' two sides."""
    e = mujoco.MjData(m)
    e.qpos[:] = d.qpos
    mujoco.mj_integratePos(m, e.qpos, d.qvel + 0.5 * t * qacc, t)
    e.qvel[:] = d.qvel + t * qacc
    mujoco.mj_forward(m, e)
    return e


@pytest.mark.parametrize("seed", [0, 1])
def test_the_momentum_is_mujocos_subtree_angular_momentum(scene: Scene, seed: int) -> None:
    d, va = _moving(scene, seed)
    cm = CentroidalMomentum(scene.model, scene.root_body, va, 10.0)
    want = _angmom(scene.model, d, scene.root_body)
    assert np.linalg.norm(want) > 0.1  # not a vacuous comparison
    assert np.allclose(cm.matrix(scene.model, d) @ d.qvel[va], want, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("seed", [0, 1])
def test_the_rate_is_the_finite_difference_of_mujocos_momentum(scene: Scene, seed: int) -> None:
    # along q(t) = q + q̇ t + q̈ t²/2, q̇(t) = q̇ + q̈ t: dk/dt at t = 0 by central differences of subtree_angmom
    m = scene.model
    d, va = _moving(scene, seed)
    qacc = np.zeros(m.nv)
    qacc[va] = np.random.default_rng(seed + 10).normal(size=len(va))
    cm = CentroidalMomentum(m, scene.root_body, va, 10.0)
    A = cm.matrix(m, d, rates=True)
    got = A @ qacc[va] + cm.bias(d, d.qvel[va])

    def at(t: float) -> np.ndarray:
        return _angmom(m, _advanced(m, d, qacc, t), scene.root_body)

    h = 1e-6
    want = (at(h) - at(-h)) / (2 * h)
    assert np.linalg.norm(cm.bias(d, d.qvel[va])) > 0.1  # the bias matters at this state
    assert np.allclose(got, want, rtol=1e-5, atol=1e-5)


def test_about_a_point_the_momentum_and_its_rate_add_the_centre_of_masss_moment(scene: Scene) -> None:
    # k_p = k_c + m (c − p) × ċ (MuJoCo's subtree momentum and velocity), and its rate by central differences with p
    # fixed: the decision about_feet's reference, not the centroidal one
    m, root = scene.model, scene.root_body
    d, va = _moving(scene, 5)
    p = np.array([0.05, -0.02, 0.0])
    qacc = np.zeros(m.nv)
    qacc[va] = np.random.default_rng(6).normal(size=len(va))
    cm = CentroidalMomentum(m, root, va, 10.0)

    def about(e: mujoco.MjData) -> np.ndarray:
        k = _angmom(m, e, root)
        return k + cm.mass * np.cross(e.subtree_com[root] - p, e.subtree_linvel[root])

    A = cm.matrix(m, d, rates=True, point=p)
    assert np.allclose(A @ d.qvel[va], about(d), rtol=1e-9, atol=1e-12)
    assert not np.allclose(A @ d.qvel[va], _angmom(m, d, root), atol=1e-3)  # the point matters

    def at(t: float) -> np.ndarray:
        return about(_advanced(m, d, qacc, t))

    h = 1e-6
    got = A @ qacc[va] + cm.bias(d, d.qvel[va], p)
    assert np.allclose(got, (at(h) - at(-h)) / (2 * h), rtol=1e-5, atol=1e-5)


def test_the_rows_rate_is_toward_the_plans_momentum(scene: Scene) -> None:
    m = scene.model
    d, va = _moving(scene, 2)
    cm = CentroidalMomentum(m, scene.root_body, va, 7.0)
    A0 = cm.matrix(m, d, rates=True)
    qv = d.qvel[va]
    k, bias = A0 @ qv, cm.bias(d, qv)
    A, b = cm.rows(m, d, np.zeros(len(va)))  # a plan at rest: toward zero momentum
    assert np.allclose(A, A0 / cm.mass) and np.allclose(b, (-7.0 * k - bias) / cm.mass)
    plan = np.random.default_rng(3).normal(size=len(va))
    _, b = cm.rows(m, d, plan)
    assert np.allclose(b, (7.0 * (A0 @ plan - k) - bias) / cm.mass)
    _, b = cm.rows(m, d, qv)  # the plan's velocity is the measured one: the rate cancels the bias only
    assert np.allclose(b, -bias / cm.mass)


def test_the_plans_velocity_is_mujocos_difference_of_positions(scene: Scene) -> None:
    m, rng = scene.model, np.random.default_rng(4)
    qa = np.asarray(scene.robot_qadr)
    q0 = scene.home_qpos.copy()
    q1 = q0.copy()
    q1[:3] += rng.normal(scale=0.1, size=3)
    turn = np.zeros(4)
    mujoco.mju_axisAngle2Quat(turn, rng.normal(size=3) / 2.0, 0.4)
    mujoco.mju_mulQuat(q1[3:7], q0[3:7], turn)
    q1[7:] += rng.normal(scale=0.2, size=len(q1) - 7)
    a, b = scene.home_data().qpos.copy(), scene.home_data().qpos.copy()
    a[qa], b[qa] = q0, q1
    want = np.zeros(m.nv)
    mujoco.mj_differentiatePos(m, want, 0.25, a, b)
    assert np.allclose(plan_velocity(q0, q1, 0.25), want[np.asarray(scene.robot_vadr)], atol=1e-12)


@pytest.mark.parametrize("on", [False, True])
def test_the_qp_gets_the_momentum_rows_only_when_asked(scene: Scene, on: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    q, end = _swung(scene)
    cfg = BalanceConfig(**QP, angmom_weight=1e3 if on else None)
    tasks, ctl, d = _rows(scene, cfg, q, end, monkeypatch)
    n = len(scene.robot_vadr)
    if on:  # after the torso's rows, before the joints'
        A, b, w = tasks[-2]
        assert w == 1e3 and A.shape == (3, n)
        assert np.allclose(A, ctl.angmom.matrix(scene.model, d) / ctl.angmom.mass, atol=1e-12)
        assert np.allclose(ctl._plan_qvel, plan_velocity(q, end, 0.0875))
    else:
        assert ctl.angmom is None
        assert tasks[-2][0].shape == (3, n) and tasks[-2][2] == cfg.w_torso  # the torso's rows, as before


@pytest.mark.parametrize("still", [False, True])
def test_root_still_drops_the_plans_root_velocity_from_the_reference(scene: Scene, still: bool,
                                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    # a plan that turns the whole robot about the vertical and swings an arm
    q, end = _swung(scene)
    half = np.array([np.cos(0.15), 0.0, 0.0, np.sin(0.15)])
    turned = end.copy()
    mujoco.mju_mulQuat(turned[3:7], half, end[3:7])
    cfg = BalanceConfig(**QP, angmom_weight=1e3, angmom_root_still=still)
    _, ctl, _ = _rows(scene, cfg, q, turned, monkeypatch)
    full = plan_velocity(q, turned, 0.0875)
    assert np.linalg.norm(full[3:6]) > 1.0  # the plan turns its root
    assert np.allclose(ctl._plan_qvel[6:], full[6:])
    assert np.allclose(ctl._plan_qvel[:6], 0.0 if still else full[:6])


@pytest.mark.parametrize("kw", [{"angmom_weight": 0.0}, {"angmom_weight": -1.0},
                                {"angmom_weight": 1.0, "angmom_bandwidth": -1.0}, {"angmom_root_still": True},
                                {"angmom_about_feet": True}])
def test_a_bad_weight_or_bandwidth_is_refused(kw: dict) -> None:
    with pytest.raises(ConfigError, match="angmom"):
        BalanceConfig(**kw)


@pytest.mark.parametrize("feet", [False, True])
def test_about_feet_takes_the_momentum_about_the_contacts_mean(scene: Scene, feet: bool,
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    points: list = []
    real = CentroidalMomentum.rows

    def spy(self, m, d, qd_plan, point=None):  # noqa: ANN001, ANN202
        points.append(None if point is None else np.array(point))
        return real(self, m, d, qd_plan, point)

    monkeypatch.setattr(CentroidalMomentum, "rows", spy)
    q, end = _swung(scene)
    tasks, ctl, d = _rows(scene, BalanceConfig(**QP, angmom_weight=1e3, angmom_about_feet=feet), q, end, monkeypatch)
    assert points
    if feet:  # on the floor, under the robot: within the feet's reach of the root, below the centre of mass
        p = points[-1]
        assert abs(p[2]) < 0.02
        assert np.linalg.norm(p[:2] - d.subtree_com[scene.root_body, :2]) < 0.2
    else:
        assert all(p is None for p in points)
