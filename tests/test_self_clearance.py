"""The arms kept clear of the body by the balance QP (sim/self_clearance.py, BalanceConfig(self_clearance=...)):
the rows' separation rate against finite differences of MuJoCo's own geom distance (a pair apart and a pair
overlapping, where the normal's sign turns), their drift against finite differences of the nearest points'
relative velocity, the detection distance, the QP's inequality rows holding, surviving the other relaxations and
dropped last, the settings' checks, and Stubby's forearm held out of its pelvis by the controller when its
reference swings it in."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.balance_control import BalanceController
from socialaff_sim.sim.contact_qp import solve_contact_qp
from socialaff_sim.sim.self_clearance import SelfClearance
from test_balance_control import standing_far
from test_balance_qp import _lean_forward, _problem

ROLL_IN = 0.2
"""Stubby's right shoulder roll (rad) that puts its right forearm 4.6 cm deep into its pelvis (home: −0.15, 11 cm
clear)."""


def _geom(m: mujoco.MjModel, name: str) -> int:
    return mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, name)


def _joint_q(scene, name: str) -> int:
    """Index into the robot's coordinates (nq_r,) of a hinge."""
    return 6 + list(scene.robot_joint_names).index(f"robot/{name}")


def _clearance(scene, detection: float = 0.1, bandwidth: float = 0.0) -> SelfClearance:
    return SelfClearance.of_scene(scene, 0.01, detection, bandwidth)


def _posed(scene, roll: float, rng: np.random.Generator) -> mujoco.MjData:
    """Stubby at home with its right shoulder rolled in by ``roll``, moving with random velocities."""
    m = scene.model
    d = mujoco.MjData(m)
    q = scene.home_qpos.copy()
    q[_joint_q(scene, "right_shoulder_roll")] = roll
    d.qpos[scene.robot_qadr] = q
    d.qvel[scene.robot_vadr] = rng.normal(scale=0.5, size=len(scene.robot_vadr))
    mujoco.mj_forward(m, d)
    return d


def _forearm_pelvis(scene, d: mujoco.MjData) -> float:
    m = scene.model
    return mujoco.mj_geomDistance(m, d, _geom(m, "robot/right_forearm"), _geom(m, "robot/pelvis"), 1.0, None)


@pytest.mark.parametrize("roll", [0.02, 0.2])  # 3 cm apart; 4.6 cm overlapping
def test_rows_give_the_rate_of_mujocos_own_distance(scene, roll, rng) -> None:
    # Along q(t) = q + q̇ t, the right forearm–pelvis row times q̇ must be d/dt of mj_geomDistance (whatever the
    # sign of the distance: overlapping, the normal is flipped) and the rows' other pairs likewise.
    m = scene.model
    d = _posed(scene, roll, rng)
    sc = _clearance(scene)
    out = sc.rows(m, d)
    assert out is not None
    A, _ = out
    pairs = [tuple(p) for p in sc.pairs.tolist()]
    # which pairs got a row: those within the detection distance, in the order of ``pairs``
    near = [p for p in pairs if mujoco.mj_geomDistance(m, d, p[0], p[1], 0.1, None) < 0.1]
    assert len(near) == len(A)
    target = (_geom(m, "robot/right_forearm"), _geom(m, "robot/pelvis"))
    assert target in near or target[::-1] in near
    eps = 1e-6

    def dist_at(t: float, g1: int, g2: int) -> float:
        e = mujoco.MjData(m)
        e.qpos[:] = d.qpos
        mujoco.mj_integratePos(m, e.qpos, d.qvel * t, 1.0)
        mujoco.mj_kinematics(m, e)
        return mujoco.mj_geomDistance(m, e, g1, g2, 1.0, None)

    qv = d.qvel[scene.robot_vadr]
    for row, (g1, g2) in zip(A, near, strict=True):
        fd = (dist_at(eps, g1, g2) - dist_at(-eps, g1, g2)) / (2.0 * eps)
        assert abs(row @ qv - fd) <= 1e-4 * max(1.0, abs(fd)), (m.geom(g1).name, m.geom(g2).name)
    k = near.index(target) if target in near else near.index(target[::-1])
    assert (sc.last_distance[k] < 0) == (roll > 0.1)


def test_drift_is_the_derivative_of_the_nearest_points_relative_velocity(scene, rng) -> None:
    # With ω = 0 the bound is −n·(J̇₂ − J̇₁) q̇: against central differences of n·(v₂ − v₁) of the two nearest points,
    # each carried with its body along q(t) = q + q̇ t (q̈ = 0), n held fixed.
    m = scene.model
    d = _posed(scene, 0.02, rng)
    sc = _clearance(scene)
    A, lo = sc.rows(m, d)  # type: ignore[misc]
    g1, g2 = _geom(m, "robot/right_forearm"), _geom(m, "robot/pelvis")
    pairs = [tuple(p) for p in sc.pairs.tolist()]
    near = [p for p in pairs if mujoco.mj_geomDistance(m, d, p[0], p[1], 0.1, None) < 0.1]
    k = near.index((g1, g2)) if (g1, g2) in near else near.index((g2, g1))
    a, b = near[k]
    ft = np.zeros(6)
    dist = mujoco.mj_geomDistance(m, d, a, b, 1.0, ft)
    n = (ft[3:] - ft[:3]) / dist
    local = []
    for g, p in ((a, ft[:3]), (b, ft[3:])):
        body = int(m.geom_bodyid[g])
        local.append((body, d.xmat[body].reshape(3, 3).T @ (p - d.xpos[body])))

    def rel_vel(t: float) -> float:
        e = mujoco.MjData(m)
        e.qpos[:] = d.qpos
        mujoco.mj_integratePos(m, e.qpos, d.qvel * t, 1.0)
        e.qvel[:] = d.qvel
        mujoco.mj_kinematics(m, e)
        mujoco.mj_comPos(m, e)
        v = []
        for body, r in local:
            jp = np.zeros((3, m.nv))
            mujoco.mj_jac(m, e, jp, None, e.xpos[body] + e.xmat[body].reshape(3, 3) @ r, body)
            v.append(jp @ e.qvel)
        return float(n @ (v[1] - v[0]))

    eps = 1e-6
    fd = (rel_vel(eps) - rel_vel(-eps)) / (2.0 * eps)
    assert abs(-lo[k] - fd) <= 1e-4 * max(1.0, abs(fd))
    assert abs(fd) > 1e-3  # there is a drift to check


def test_only_pairs_within_the_detection_distance_get_rows(scene, rng) -> None:
    m = scene.model
    home = _posed(scene, -0.15, rng)  # every arm geom at least 5 cm from the rest at home...
    assert _clearance(scene, detection=0.05).rows(m, home) is None
    near = _posed(scene, 0.02, rng)  # ...the forearm 3 cm from the pelvis
    assert 0.025 <= _forearm_pelvis(scene, near) <= 0.035
    sc = _clearance(scene, detection=0.05)
    assert sc.rows(m, near) is not None and (sc.last_distance < 0.05).all()
    assert _clearance(scene, detection=0.02).rows(m, near) is None


def test_barrier_bound_grows_with_the_approach_and_the_intrusion(scene, rng) -> None:
    # lo = −2ω ḋ − ω²(d − d_min) − drift: against the same state with ω = 0 (the drift alone).
    m = scene.model
    d = _posed(scene, 0.02, rng)
    A0, lo0 = _clearance(scene, bandwidth=0.0).rows(m, d)  # type: ignore[misc]
    sc = _clearance(scene, bandwidth=30.0)
    A, lo = sc.rows(m, d)  # type: ignore[misc]
    rate = A @ d.qvel[scene.robot_vadr]
    assert np.allclose(A, A0)
    assert np.allclose(lo - lo0, -60.0 * rate - 900.0 * (sc.last_distance - 0.01), atol=1e-9)


def _qp_in(pr: dict, ineq, eq=None, limits: np.ndarray | None = None):
    n = pr["M"].shape[0]
    lim = np.tile([-np.inf, np.inf], (n, 1)) if limits is None else limits
    return solve_contact_qp(pr["M"], pr["h"], pr["unactuated"], pr["point_jac"], pr["edges"], pr["tasks"],
                            pr["mass"], pr["w_force"], lim, None, pr["foot"], equalities=eq, inequalities=ineq)


def test_inequality_rows_hold_survive_the_other_relaxations_and_go_last() -> None:
    m, d, tasks = _lean_forward()  # the objective asks the trunk for 3 m/s² forward
    pr = _problem(m, d, tasks)
    n = m.nv
    free = _qp_in(pr, None)
    cap = (-np.eye(n)[:1], np.array([-0.5]))  # −q̈₀ ≥ −0.5: at most 0.5 m/s² forward
    held = _qp_in(pr, cap)
    assert free.found and held.found and not held.relaxed and not held.inequalities_dropped
    assert free.qacc[0] >= 1.0 and held.qacc[0] <= 0.5 + 1e-6
    assert np.abs(held.tau[:6]).max() <= 1e-6 * pr["mass"]  # the root's rows still hold
    # contradicting equalities are dropped, the inequality is kept
    both = _qp_in(pr, cap, eq=(np.vstack([np.eye(n)[:1]] * 2), np.array([0.2, -0.2])))
    assert both.relaxed and not both.inequalities_dropped and both.qacc[0] <= 0.5 + 1e-6
    # inequality rows that cannot hold (here: contradicting each other) are dropped, and the solution is the one
    # without them
    limits = np.tile([-40.0, 40.0], (n, 1))
    limits[:6] = [-np.inf, np.inf]
    bare = _qp_in(pr, None, limits=limits)
    hard = _qp_in(pr, (np.vstack([np.eye(n)[6:7], -np.eye(n)[6:7]]), np.array([1.0, 1.0])), limits=limits)
    assert hard.found and hard.inequalities_dropped
    assert np.allclose(hard.qacc, bare.qacc, atol=1e-6)


def test_self_clearance_settings_are_checked() -> None:
    with pytest.raises(ConfigError, match="self_clearance"):
        BalanceConfig(self_clearance=0.01)  # least squares: no hard rows
    with pytest.raises(ConfigError, match="self_clearance"):
        BalanceConfig(solver="qp", self_clearance=-0.01)
    with pytest.raises(ConfigError, match="clearance_bandwidth"):
        BalanceConfig(solver="qp", self_clearance=0.01, clearance_bandwidth=0.0)
    BalanceConfig(solver="qp", self_clearance=0.0)


def _swing_in(scene, config: BalanceConfig) -> tuple[float, BalanceController]:
    """Stubby released on its feet under the controller, its right arm's reference rolled into the pelvis
    (``ROLL_IN``) after 0.6 s; the smallest forearm–pelvis distance (m) over the next 0.6 s."""
    m = scene.model
    d, q, ctl, ctrl0 = standing_far(scene, config)
    ref = q.copy()
    closest = np.inf
    for k in range(int(round(1.2 / m.opt.timestep))):
        if k * m.opt.timestep >= 0.6:
            ref[_joint_q(scene, "right_shoulder_roll")] = ROLL_IN
            closest = min(closest, _forearm_pelvis(scene, d))
        if k % 25 == 0:
            ctl.begin_frame(ref, (True, True))
        d.ctrl[scene.act_ids] = ctrl0
        ctl.step(m, d, ref, np.zeros(len(scene.robot_vadr) - 6))
    return closest, ctl


@pytest.mark.parametrize("clearance", [None, 0.01])
def test_controller_keeps_a_forearm_swung_at_the_pelvis_out_of_it(scene, clearance) -> None:
    closest, ctl = _swing_in(scene, BalanceConfig(solver="qp", flat_feet=True, self_clearance=clearance))
    assert ctl.harness.released and ctl.harness.catches == 0 and ctl.qp_failures == 0
    if clearance is None:
        assert closest <= -0.005  # driven into the pelvis (its contact with the forearm holds it 7 mm deep)
    else:
        assert closest >= 0.008 and ctl.clearance_steps > 0 and ctl.clearance_dropped_steps == 0
