"""The balance controller's quadratic program (sim/contact_qp.py, BalanceConfig(solver="qp")): the solution against
MuJoCo's forward dynamics and against scipy on the same problem, each constraint (torque limits, centre of pressure,
minimum foot load) shown to bind where the unconstrained solution breaks it, the actuators' limits against MuJoCo's
own clipping, the support box's hovering foot, determinism and the configuration's errors."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from scipy.optimize import minimize

from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.balance_control import BalanceController
from socialaff_sim.sim.contact_dynamics import cone_edges
from socialaff_sim.sim.contact_qp import actuator_limits, cop_rows, solve_contact_qp
from socialaff_sim.sim.scene import build_scene
from socialaff_sim.sim.simulator import SimConfig
from socialaff_sim.sim.stance import StanceConfig
from socialaff_sim.sim.support_box import cop_interval
import test_balance_control
from test_balance_control import BIPED, _biped, _episode, _points, _stand

MU = 0.7
W_FORCE = 1e-3
AXES = np.eye(2)


def _problem(m: mujoco.MjModel, d: mujoco.MjData, tasks: list) -> dict:
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    pts, bodies, jac = _points(m, d)
    frames = np.tile(np.eye(3)[[2, 0, 1]], (len(pts), 1, 1))  # normal +z, tangents x and y
    unact = np.zeros(m.nv, dtype=bool)
    unact[:6] = True
    foot = (bodies == m.body("rfoot").id).astype(np.int64)
    return {"M": M, "h": d.qfrc_bias.copy(), "unactuated": unact, "point_jac": jac, "edges": cone_edges(frames, MU),
            "tasks": tasks, "mass": float(m.body_mass.sum()), "w_force": W_FORCE, "pts": pts, "bodies": bodies,
            "foot": foot}


def _qp(pr: dict, limits: np.ndarray | None = None, bounds: np.ndarray | None = None, min_load: float = 0.0):
    n = pr["M"].shape[0]
    lim = np.tile([-np.inf, np.inf], (n, 1)) if limits is None else limits
    cop = None if bounds is None else cop_rows(pr["pts"], pr["edges"], pr["foot"], AXES, bounds)
    return solve_contact_qp(pr["M"], pr["h"], pr["unactuated"], pr["point_jac"], pr["edges"], pr["tasks"], pr["mass"],
                            pr["w_force"], lim, cop, pr["foot"], min_load)


def _cop(forces: np.ndarray, pts: np.ndarray, mask: np.ndarray) -> np.ndarray:
    return (forces[mask, 2, None] * pts[mask, :2]).sum(axis=0) / forces[mask, 2].sum()


def _lean_forward(sideways: float = 0.0) -> tuple[mujoco.MjModel, mujoco.MjData, list]:
    """The biped standing straight, asked for a strong forward (and ``sideways``) acceleration of its trunk and
    still hinges: the floor must push behind its centre of mass, toward the heels."""
    m = mujoco.MjModel.from_xml_string(BIPED)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    tasks = [(np.eye(m.nv)[:3], np.array([3.0, sideways, 0.0]), 100.0), (np.eye(m.nv)[3:6], np.zeros(3), 10.0),
             (np.eye(m.nv)[6:], np.zeros(m.nv - 6), 1.0)]
    return m, d, tasks


def test_qp_solution_obeys_the_equation_of_motion_and_every_constraint_in_forward_dynamics(rng) -> None:
    m, d = _biped(rng)
    tasks = [(np.eye(m.nv)[6:], rng.normal(scale=2.0, size=m.nv - 6), 1.0), (np.eye(m.nv)[:6], np.zeros(6), 10.0)]
    pr = _problem(m, d, tasks)
    limits = np.tile([-40.0, 40.0], (m.nv, 1))
    # Per foot and world axis: the middle 40 % of its contact points' extent.
    bounds = np.zeros((2, 2, 2))
    for s in (0, 1):
        xy = pr["pts"][pr["foot"] == s, :2]
        lo, hi = xy.min(axis=0), xy.max(axis=0)
        bounds[s] = np.stack([lo + 0.3 * (hi - lo), hi - 0.3 * (hi - lo)], axis=1)
    res = _qp(pr, limits, bounds, min_load=20.0)
    assert res.found
    # Independent: MuJoCo's forward dynamics with τ on the hinges and the forces at the points gives q̈ back.
    f = mujoco.MjData(m)
    f.qpos[:], f.qvel[:] = d.qpos, d.qvel
    f.qfrc_applied[6:] = res.tau[6:]
    mujoco.mj_forward(m, f)  # the bodies' poses, which mj_applyFT reads
    for p, b, force in zip(pr["pts"], pr["bodies"], res.forces, strict=True):
        mujoco.mj_applyFT(m, f, force, np.zeros(3), p, int(b), f.qfrc_applied)
    mujoco.mj_forward(m, f)
    np.testing.assert_allclose(f.qacc, res.qacc, atol=1e-5 * max(1.0, np.abs(res.qacc).max()))
    weight = pr["mass"] * 9.81
    assert np.abs(res.tau[:6]).max() <= 1e-6 * weight  # the root takes no torque (a hard equality)
    assert (np.abs(res.tau[6:]) <= 40.0 + 1e-6 * weight).all()
    assert (res.beta >= 0.0).all() and (res.forces[:, 2] >= 0.0).all()
    assert (np.abs(res.forces[:, :2]).max(axis=1) <= MU * res.forces[:, 2] + 1e-6 * weight).all()  # the pyramid
    for s in (0, 1):
        mine = pr["foot"] == s
        assert res.forces[mine, 2].sum() >= 20.0 - 1e-6 * weight
        cop = _cop(res.forces, pr["pts"], mine)
        assert (cop >= bounds[s, :, 0] - 1e-6).all() and (cop <= bounds[s, :, 1] + 1e-6).all()


def test_qp_agrees_with_scipy_on_the_same_problem(rng) -> None:
    m, d = _biped(rng)
    tasks = [(np.eye(m.nv)[6:], rng.normal(scale=2.0, size=m.nv - 6), 1.0), (np.eye(m.nv)[:6], np.zeros(6), 10.0)]
    pr = _problem(m, d, tasks)
    limits = np.tile([-30.0, 30.0], (m.nv, 1))
    res = _qp(pr, limits)
    n, K, mass = m.nv, 4 * len(pr["pts"]), pr["mass"]
    G = np.einsum("pin,pik->npk", pr["point_jac"], pr["edges"]).reshape(n, K)

    # The same problem written out directly in N and rad/s², solved by SLSQP.
    def cost(x: np.ndarray) -> float:
        q, b = x[:n], x[n:]
        return float(sum(w * np.sum((A @ q - t) ** 2) for A, t, w in tasks) + W_FORCE * np.sum((b / mass) ** 2)
                     + 1e-6 * q @ q)

    def tau(x: np.ndarray) -> np.ndarray:
        return pr["M"] @ x[:n] + pr["h"] - G @ x[n:]

    cons = [{"type": "eq", "fun": lambda x: tau(x)[:6] / mass},
            {"type": "ineq", "fun": lambda x: (30.0 - tau(x)[6:]) / mass},
            {"type": "ineq", "fun": lambda x: (30.0 + tau(x)[6:]) / mass}]
    x0 = np.concatenate([res.qacc, res.beta]) + rng.normal(scale=0.1, size=n + K)
    ref = minimize(cost, x0, method="SLSQP", constraints=cons, bounds=[(None, None)] * n + [(0.0, None)] * K,
                   options={"maxiter": 500, "ftol": 1e-12})
    assert ref.success
    assert cost(np.concatenate([res.qacc, res.beta])) <= ref.fun * (1 + 1e-6) + 1e-9
    np.testing.assert_allclose(res.qacc, ref.x[:n], atol=1e-3 * max(1.0, np.abs(ref.x[:n]).max()))
    np.testing.assert_allclose(G @ res.beta, G @ ref.x[n:], atol=1e-3 * mass * 9.81)


def test_torque_limit_binds_where_the_unconstrained_solution_exceeds_it(rng) -> None:
    m, d = _biped(rng)
    tasks = [(np.eye(m.nv)[6:], np.array([30.0, -30.0, 30.0, -30.0]), 1.0), (np.eye(m.nv)[:6], np.zeros(6), 10.0)]
    pr = _problem(m, d, tasks)
    free = _qp(pr)
    cap = 0.5 * np.abs(free.tau[6:]).max()
    assert cap > 1.0  # the unconstrained solution asks for twice the cap somewhere
    limits = np.tile([-np.inf, np.inf], (m.nv, 1))
    limits[6:] = [-cap, cap]
    res = _qp(pr, limits)
    assert np.abs(res.tau[6:]).max() <= cap * (1 + 1e-6)
    assert res.at_limit[6:].any() and not res.at_limit[:6].any() and not free.at_limit.any()
    assert np.abs(res.tau[:6]).max() <= 1e-6 * pr["mass"] * 9.81


def test_centre_of_pressure_bound_binds_where_the_unconstrained_solution_leaves_it() -> None:
    m, d, tasks = _lean_forward()
    pr = _problem(m, d, tasks)
    free = _qp(pr)
    weight = pr["mass"] * 9.81
    feet = [pr["foot"] == s for s in (0, 1)]
    assert all(free.forces[f, 2].sum() >= 0.3 * weight for f in feet)  # both feet carry the robot
    cop_free = np.array([_cop(free.forces, pr["pts"], f)[0] for f in feet])
    # Pushing the trunk forward, the floor pushes behind the centre of mass: at the heels. Keep each foot's centre
    # of pressure 2 cm ahead of where the free solution put the more forward one.
    lo_x = float(cop_free.max()) + 0.02
    assert lo_x < float(pr["pts"][:, 0].max())
    res = _qp(pr, bounds=np.array([[[lo_x, 1.0], [-1.0, 1.0]]] * 2))
    assert all(res.forces[f, 2].sum() >= 0.3 * weight for f in feet)
    for f in feet:
        assert _cop(res.forces, pr["pts"], f)[0] >= lo_x - 1e-6
    assert np.abs(res.tau[:6]).max() <= 1e-6 * weight


def test_minimum_foot_load_binds() -> None:
    m, d, tasks = _lean_forward(sideways=2.0)  # the free solution leaves one foot nearly unloaded
    pr = _problem(m, d, tasks)
    free = _qp(pr)
    loads = [free.forces[pr["foot"] == s, 2].sum() for s in (0, 1)]
    need = min(loads) + 30.0
    assert need < 0.5 * pr["mass"] * 9.81
    res = _qp(pr, min_load=need)
    assert min(res.forces[pr["foot"] == s, 2].sum() for s in (0, 1)) >= need - 1e-6 * pr["mass"] * 9.81


ACTUATED = """
<mujoco>
  <option gravity="0 0 0"/>
  <worldbody>
    <body><joint name="a" axis="0 1 0" actuatorfrclimited="true" actuatorfrcrange="-7 5"/>
      <geom size="0.1" mass="1"/>
      <body pos="0 0 -0.3"><joint name="b" axis="0 1 0"/><geom size="0.1" mass="1"/>
        <body pos="0 0 -0.3"><joint name="c" axis="0 1 0"/><geom size="0.1" mass="1"/></body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor joint="a" gear="1" ctrlrange="-100 100" ctrllimited="true"/>
    <position joint="b" kp="50" kv="3" ctrlrange="-0.5 0.8" ctrllimited="true" forcerange="-20 12" forcelimited="true"/>
    <motor joint="c" gear="1" ctrlrange="-2 3" ctrllimited="true"/>
  </actuator>
</mujoco>
"""


def test_actuator_limits_are_the_forces_mujoco_clips_to(rng) -> None:
    m = mujoco.MjModel.from_xml_string(ACTUATED)
    d = mujoco.MjData(m)
    for _ in range(5):
        d.qpos[:] = rng.uniform(-1.0, 1.0, size=3)
        d.qvel[:] = rng.normal(size=3)
        lim = actuator_limits(m, np.arange(3), d.qpos.copy(), d.qvel.copy())
        # Independent: the force MuJoCo delivers to each joint (one actuator, gear 1, per joint) with the control
        # far beyond each end.
        for end, col in ((-1e6, 0), (1e6, 1)):
            d.ctrl[:] = end
            mujoco.mj_forward(m, d)
            np.testing.assert_allclose(d.qfrc_actuator, lim[:, col], atol=1e-9)


def test_cop_interval_shrinks_the_sole_within_the_contacts() -> None:
    sole = np.array([[-0.05, -0.04], [0.15, 0.04]])
    pts = np.array([[-0.05, -0.04], [0.15, 0.04]])
    np.testing.assert_allclose(cop_interval(AXES, sole, pts, 0.01), [[-0.04, 0.14], [-0.03, 0.03]])
    # Contacts on the toes only: the interval is theirs.
    np.testing.assert_allclose(cop_interval(AXES, sole, pts + [0.15, 0.0], 0.01)[0], [0.1, 0.14])
    # A margin wider than half the sole: the middle.
    np.testing.assert_allclose(cop_interval(AXES, sole, pts, 0.06)[1], [0.0, 0.0])
    # Contacts all outside the shrunk sole: their end nearest to it.
    np.testing.assert_allclose(cop_interval(AXES, sole, np.array([[0.145, 0.0], [0.15, 0.0]]), 0.01)[0], [0.145, 0.145])


def test_a_hovering_planted_foot_counts_for_the_support_box_only_with_sole_gap() -> None:
    scene = build_scene(load_robot("ours"), get_layout("kinect_v2"), harness_time_constant=0.02)
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[scene.robot_qadr] = scene.home_qpos
    d.qpos[scene.robot_qadr[2]] -= 0.001
    mujoco.mj_forward(m, d)
    widths = []
    for gap in (0.0, 0.01):
        ctl = BalanceController(scene, BalanceConfig(sole_gap=gap))
        pts, _, which = ctl.feet.contacts(d)
        assert set(which.tolist()) == {0, 1}
        xy = ctl.feet.footprint(d, pts[which == 0], which[which == 0])  # the right foot's contacts lost for a step
        widths.append(float(np.ptp(xy[:, 1])))
    assert widths[1] >= widths[0] + 0.1  # both soles (the feet are 20+ cm apart) against one


def test_an_episode_under_the_qp_is_deterministic(ours) -> None:
    cfg = SimConfig(balance=BalanceConfig(solver="qp", sole_gap=0.01), stance=StanceConfig(release=False))
    a, b = _episode(ours, cfg), _episode(ours, cfg)
    assert [r.support for r in a] == [r.support for r in b]
    assert [r.subgoals for r in a] == [r.subgoals for r in b]
    assert any(r.support.outside_peak == 0.0 for r in a)  # the harness did let go


@pytest.fixture(scope="module")
def ours():
    return load_robot("ours")


class _Recorder(BalanceController):
    """The controller, recording the actuator forces (as fractions of their force range) of the steps it drove."""

    ratios: list[float] = []

    def step(self, m, d, q_ref, qd_ref) -> None:  # type: ignore[no-untyped-def]
        super().step(m, d, q_ref, qd_ref)
        if self.active:
            ids = self.scene.act_ids
            _Recorder.ratios.append(float((np.abs(d.actuator_force[ids]) / m.actuator_forcerange[ids, 1]).max()))


FRACTION, PUSH = 0.1, 150.0


@pytest.mark.parametrize("solver", ["qp", "lsq"])
def test_driven_torques_stay_within_the_fraction_of_the_limits_the_qp_is_given(monkeypatch, solver) -> None:
    # A FRACTION cap on every actuator while Stubby is shoved: the QP keeps every driven step's forces under it and
    # says when it had to; the least-squares solve (which knows no limit) goes over it.
    scene = build_scene(load_robot("ours"), get_layout("kinect_v2"), harness_time_constant=0.02)
    monkeypatch.setattr(test_balance_control, "BalanceController", _Recorder)
    _Recorder.ratios = []
    ctl, _, _ = _stand(scene, BalanceConfig(solver=solver, torque_fraction=FRACTION), 1.0, push=(0.4, 0.6, PUSH))
    assert ctl.active_steps > 100 and len(_Recorder.ratios) == ctl.active_steps
    if solver == "qp":
        assert max(_Recorder.ratios) <= FRACTION + 1e-6 and ctl.limit_steps > 0 and ctl.qp_failures == 0
    else:
        assert max(_Recorder.ratios) > FRACTION + 0.05


@pytest.mark.parametrize("kw", [{"solver": "osqp"}, {"torque_fraction": 0.0}, {"torque_fraction": 1.2},
                                {"min_foot_load": 0.5}, {"min_foot_load": -0.1}, {"cop_margin": -0.01},
                                {"upper_weight": -1.0}, {"sole_gap": -0.01}])
def test_balance_config_rejects_bad_qp_values(kw) -> None:
    with pytest.raises(ConfigError, match="BalanceConfig"):
        BalanceConfig(**kw)
