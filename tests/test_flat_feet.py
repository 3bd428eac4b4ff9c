"""Feet held flat (sim/flat_feet.py, BalanceConfig(flat_feet=True)) and the feet's drift (SupportMeter.feet_lo/hi,
episode.foot_drift): the sole's corners against MuJoCo's own box geometry, the feet's rows (the drift J̇q̇ against
finite differences of the feet's velocity), the level attitude, the QP's hard rows binding, the controller's
contact model and its centre of pressure against the one computed by hand from MuJoCo's contact forces, and the
drift against brute force and against the sliding path of a foot shaken in place."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.contact_qp import cop_rows, solve_contact_qp
from socialaff_sim.sim.episode import foot_drift
from socialaff_sim.sim.feet_on_floor import FeetOnFloor
from socialaff_sim.sim.flat_feet import flat_attitude, flat_contacts, foot_rows, sole_corners, sole_points, yaw_rows
from socialaff_sim.sim.support import FrameSupport, SupportMeter
import test_balance_control
from test_balance_control import _biped, _stand
from test_balance_qp import _cop, _lean_forward, _problem, _qp


def _rot(axis: np.ndarray, angle: float) -> np.ndarray:
    q = np.zeros(4)
    mujoco.mju_axisAngle2Quat(q, np.asarray(axis, dtype=np.float64), angle)
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, q)
    return R.reshape(3, 3)


def test_sole_corners_are_the_bottom_corners_of_stubbys_box_feet(scene) -> None:
    # The controller's sole (found from the contacts at home) against the foot geom's own box, posed by MuJoCo.
    ctl = test_balance_control.BalanceController(scene, BalanceConfig(solver="qp", flat_feet=True))
    m = scene.model
    d = mujoco.MjData(m)
    q = scene.home_qpos.copy()
    q[3:7] = [math.cos(0.2), 0.0, 0.0, math.sin(0.2)]  # turned by 0.4 rad
    d.qpos[scene.robot_qadr] = q
    mujoco.mj_forward(m, d)
    for s, body in enumerate(ctl._feet):
        g = [i for i in range(m.ngeom) if m.geom_bodyid[i] == body and m.geom_type[i] == mujoco.mjtGeom.mjGEOM_BOX][0]
        R, c, half = d.geom_xmat[g].reshape(3, 3), d.geom_xpos[g], m.geom_size[g]
        box = np.array([c + R @ (half * [sx, sy, -1.0]) for sx in (-1, 1) for sy in (-1, 1)])
        pts, frames = sole_points(d.xpos[body], d.xmat[body].reshape(3, 3), sole_corners(ctl.feet.soles[s]))
        # the same four points (in any order), to the 2 mm the sole was found pressed into the floor
        dist = np.linalg.norm(pts[:, None] - box[None], axis=2)
        assert dist.min(axis=1).max() <= 0.0025 and sorted(dist.argmin(axis=1).tolist()) == [0, 1, 2, 3]
        assert np.allclose(frames[:, 0], [0.0, 0.0, 1.0]) and np.allclose(np.einsum("pij,pkj->pik", frames, frames),
                                                                          np.eye(3))


def test_flat_attitude_keeps_the_heading_and_levels_the_sole() -> None:
    home = _rot([0.0, 1.0, 0.0], 0.3)  # a foot body whose frame is pitched at home (as the H1's ankle's may be)
    fwd = home.T @ np.array([1.0, 0.0, 0.0])
    ahead = np.array([math.cos(0.5), math.sin(0.5), 0.0])
    now = _rot(ahead, 0.08) @ _rot([0.0, 0.0, 1.0], 0.5) @ home  # turned 0.5 rad, then rolled about its heading
    goal = flat_attitude(now, home, fwd)
    assert np.allclose(goal @ home.T, _rot([0.0, 0.0, 1.0], 0.5), atol=1e-12)  # home turned about the vertical
    # its forward axis points where the foot's does on the floor
    f_now, f_goal = (now @ fwd)[:2], (goal @ fwd)[:2]
    assert abs(math.atan2(f_now[1], f_now[0]) - math.atan2(f_goal[1], f_goal[0])) <= 1e-12


def test_foot_rows_drift_is_the_derivative_of_the_jacobian_along_the_motion(rng) -> None:
    # J q̈ + J̇ q̇ must be the foot's acceleration: d/dt (J(q(t)) q̇(t)) by central differences along q(t) with
    # acceleration q̈. With stiffness and damping 0 the rows' b is −J̇q̇ alone.
    m, d = _biped(rng)
    b = m.body("lfoot").id
    vadr = np.arange(m.nv)
    A, rhs = foot_rows(m, d, b, vadr, d.xpos[b].copy(), d.xmat[b].reshape(3, 3).copy(), 0.0, 0.0)
    qacc = rng.normal(size=m.nv)
    eps = 1e-5

    def vel(t: float) -> np.ndarray:
        e = mujoco.MjData(m)
        e.qpos[:] = d.qpos
        mujoco.mj_integratePos(m, e.qpos, d.qvel * t + 0.5 * qacc * t * t, 1.0)
        e.qvel[:] = d.qvel + qacc * t
        mujoco.mj_forward(m, e)
        jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        mujoco.mj_jacBody(m, e, jp, jr, b)
        return np.vstack([jp, jr]) @ e.qvel

    acc = (vel(eps) - vel(-eps)) / (2.0 * eps)
    assert np.allclose(A @ qacc - rhs, acc, atol=1e-5 * max(1.0, np.abs(acc).max()))
    assert np.abs(rhs).max() > 1e-3  # the drift is there to be checked (the biped moves)


def test_foot_rows_feedback_points_back_to_the_goal(rng) -> None:
    m, d = _biped(rng)
    d.qvel[:] = 0.0
    mujoco.mj_forward(m, d)
    b = m.body("rfoot").id
    goal = d.xpos[b] + [0.01, -0.02, 0.0]
    goal_rot = _rot([1.0, 0.0, 0.0], 0.05) @ d.xmat[b].reshape(3, 3)
    _, rhs = foot_rows(m, d, b, np.arange(m.nv), goal, goal_rot, 100.0, 20.0)
    assert np.allclose(rhs[:3], 100.0 * np.array([0.01, -0.02, 0.0]), atol=1e-9)
    assert np.allclose(rhs[3:], 100.0 * np.array([0.05, 0.0, 0.0]), atol=1e-9)


def test_hard_rows_hold_exactly_where_the_objective_would_trade_them_away() -> None:
    # The biped asked for a forward trunk acceleration; a hard row pins the trunk's x acceleration to 0.5 m/s².
    m, d, tasks = _lean_forward()
    pr = _problem(m, d, tasks)
    free = _qp(pr)
    A = np.eye(m.nv)[:1]
    held = _qp_eq(pr, (A, np.array([0.5])))
    assert free.found and held.found and not held.relaxed
    assert abs(free.qacc[0] - 0.5) > 0.5  # the objective alone goes elsewhere...
    assert abs(held.qacc[0] - 0.5) <= 1e-6  # ...the row holds
    # and the rest of the equation of motion still does (the root's rows)
    tau = held.tau
    assert np.abs(tau[:6]).max() <= 1e-6 * pr["mass"]


def test_rows_that_cannot_hold_are_dropped_first_and_the_sole_bounds_kept() -> None:
    # Two contradicting hard rows: relaxed; the centre-of-pressure bounds still hold (the solution is the one
    # without the rows), and without bounds it is the objective's own solution.
    m, d, tasks = _lean_forward()
    pr = _problem(m, d, tasks)
    A = np.vstack([np.eye(m.nv)[:1], np.eye(m.nv)[:1]])
    res = _qp_eq(pr, (A, np.array([0.5, -0.5])))
    assert res.found and res.relaxed
    assert np.allclose(res.qacc, _qp(pr).qacc, atol=1e-6)
    free = _qp(pr)
    lo_x = float(max(_cop(free.forces, pr["pts"], pr["foot"] == s)[0] for s in (0, 1))) + 0.02
    bounds = np.array([[[lo_x, 1.0], [-1.0, 1.0]]] * 2)
    held = _qp_eq(pr, (A, np.array([0.5, -0.5])), bounds)
    assert held.found and held.relaxed
    assert np.allclose(held.qacc, _qp(pr, bounds=bounds).qacc, atol=1e-6)
    assert all(_cop(held.forces, pr["pts"], pr["foot"] == s)[0] >= lo_x - 1e-6 for s in (0, 1))


def _qp_eq(pr: dict, eq: tuple[np.ndarray, np.ndarray], bounds: np.ndarray | None = None):
    n = pr["M"].shape[0]
    cop = None if bounds is None else cop_rows(pr["pts"], pr["edges"], pr["foot"], np.eye(2), bounds)
    return solve_contact_qp(pr["M"], pr["h"], pr["unactuated"], pr["point_jac"], pr["edges"], pr["tasks"],
                            pr["mass"], pr["w_force"], np.tile([-np.inf, np.inf], (n, 1)), cop, pr["foot"],
                            equalities=eq)


def _cop_by_hand(m: mujoco.MjModel, d: mujoco.MjData, scene, body: int) -> tuple[np.ndarray | None, float]:
    """The centre of pressure (2,) of a foot's contacts with the floor from MuJoCo's contact forces, and the load."""
    f6 = np.zeros(6)
    pts, fz = [], []
    for i in range(d.ncon):
        c = d.contact[i]
        g = [int(x) for x in c.geom]
        if scene.floor_geom not in g:
            continue
        other = g[1] if g[0] == scene.floor_geom else g[0]
        if m.geom_bodyid[other] != body:
            continue
        mujoco.mj_contactForce(m, d, i, f6)
        pts.append(c.pos[:2].copy())
        fz.append(f6[0])  # normal force, contact frame (the floor's normal is vertical)
    if not fz or sum(fz) <= 0:
        return None, 0.0
    w = np.array(fz)
    return (w[:, None] * np.array(pts)).sum(axis=0) / w.sum(), float(w.sum())


@pytest.mark.parametrize("flat", [False, True])
def test_pushed_stubby_keeps_its_feet_level_and_its_pressure_inside_the_soles(scene, flat, monkeypatch) -> None:
    # Stubby released and pushed forward with 100 N for 0.2 s. Flat feet: tipped at most ~1.6°, 0.35° on
    # average (the soft contacts let a loaded heel sink); without: ~2°, 0.6°. The measured centres of pressure
    # (from MuJoCo's contact forces, by hand) stay on the soles in either case.
    tilts, cops = [], []

    class Probe(test_balance_control.BalanceController):
        def step(self, m, d, q_ref, qd_ref) -> None:  # type: ignore[no-untyped-def]
            super().step(m, d, q_ref, qd_ref)
            if not self.active:
                return
            for s, b in enumerate(self._feet):
                up = d.xmat[b].reshape(3, 3).T @ [0.0, 0.0, 1.0]
                tilts.append(math.degrees(math.acos(min(1.0, float(up @ (self._home_rot[s].T @ [0.0, 0.0, 1.0]))))))
                cop, load = _cop_by_hand(m, d, self.scene, b)
                if cop is not None and load > 20.0:
                    local = (np.array([*cop, 0.0]) - d.xpos[b]) @ d.xmat[b].reshape(3, 3)
                    lo, hi = self._corners[s].min(axis=0), self._corners[s].max(axis=0)
                    cops.append(min(local[0] - lo[0], hi[0] - local[0], local[1] - lo[1], hi[1] - local[1]))

    monkeypatch.setattr(test_balance_control, "BalanceController", Probe)
    ctl, _, _ = _stand(scene, BalanceConfig(solver="qp", flat_feet=flat), 1.5, push=(0.4, 0.6, 100.0))
    assert ctl.active_steps > 300 and ctl.harness.catches == 0 and ctl.qp_failures == 0
    t = np.array(tilts)
    if flat:
        assert t.max() <= 1.7 and t.mean() <= 0.4
    else:
        assert t.max() >= 1.8 and t.mean() >= 0.5
    assert min(cops) >= -0.002  # inside the sole (a contact point sits on the box's edge)


def test_flat_feet_needs_the_qp() -> None:
    with pytest.raises(ConfigError, match="flat_feet"):
        BalanceConfig(flat_feet=True)
    BalanceConfig(solver="qp", flat_feet=True)


def _frame(lo: list[float], hi: list[float]) -> FrameSupport:
    return FrameSupport(outside_mean=0.0, outside_peak=0.0, slide=0.0, penetration=0.0, torque_ratio=0.0,
                        saturated=0.0, at_limit=0.0, feet_lo=tuple(lo), feet_hi=tuple(hi))  # type: ignore[arg-type]


def test_foot_drift_is_the_larger_foots_box_diagonal(rng) -> None:
    pts = rng.normal(scale=0.01, size=(6, 2, 2))  # 6 frames, 2 feet, (x, y)
    pts[:, 1] *= 3.0  # the right foot wanders more
    frames = [_frame(p.reshape(-1).tolist(), p.reshape(-1).tolist()) for p in pts]
    frames.append(_frame([math.inf] * 4, [-math.inf] * 4))  # a frame with neither foot down changes nothing
    want = max(float(np.linalg.norm(np.ptp(pts[:, s], axis=0))) for s in (0, 1))
    assert foot_drift(frames) == pytest.approx(want, abs=1e-12)
    assert foot_drift([_frame([math.inf] * 4, [-math.inf] * 4)]) == 0.0


def test_a_foot_shaken_in_place_slides_a_long_path_but_drifts_its_amplitude(scene) -> None:
    # Stubby at home, feet pressed into the floor, moved 1 cm forward and back six times: the meter's sliding
    # path is 12 cm, the drift 1 cm.
    m = scene.model
    d = mujoco.MjData(m)
    meter = SupportMeter(scene)
    q = scene.home_qpos.copy()
    q[2] -= 0.002
    for k in range(13):
        d.qpos[scene.robot_qadr] = q + np.r_[0.01 * (k % 2), np.zeros(len(q) - 1)]
        mujoco.mj_forward(m, d)
        meter.update(d)
    fs = meter.end_frame()
    assert fs.slide == pytest.approx(0.12, abs=1e-9)
    assert foot_drift([fs]) == pytest.approx(0.01, abs=1e-9)


def _pressed_at_home(scene):  # noqa: ANN001, ANN202
    """Stubby at home pressed 1 mm into the floor: the model, its data, a flat-feet QP controller (sole_gap 1 cm),
    the live floor contacts (points, frames, feet), each foot's pose as its anchor, the robot's coordinates."""
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[scene.robot_qadr] = scene.home_qpos
    d.qpos[scene.robot_qadr[2]] -= 0.001
    mujoco.mj_forward(m, d)
    ctl = test_balance_control.BalanceController(scene, BalanceConfig(solver="qp", flat_feet=True, sole_gap=0.01))
    pts, frames, which = ctl.feet.contacts(d)
    anchors = [(d.xpos[b].copy(), d.xmat[b].reshape(3, 3).copy()) for b in ctl._feet]
    return m, d, ctl, pts, frames, which, anchors, np.asarray(scene.robot_vadr)


def test_a_foot_gets_its_corners_and_rows_in_contact_or_within_the_gap_only(scene) -> None:
    # Stubby at home pressed 1 mm into the floor; the right foot's contacts "lost for a step" (only the left's
    # passed). Within sole_gap the right foot stands on its corners too (8 points, 12 rows); with the floor 5 cm
    # lower than its sole (the left's contacts moved down) it is left out (4 points, 6 rows), its live contacts
    # (none) kept.
    m, d, ctl, pts, frames, which, anchors, va = _pressed_at_home(scene)
    left = which == 0
    args = (m, d, ctl._feet, ctl._corners, anchors, va)
    p, f, w, eq = flat_contacts(*args, pts[left], frames[left], which[left], 0.01, 100.0, 20.0)
    assert sorted(w.tolist()) == [0] * 4 + [1] * 4 and eq is not None and eq[0].shape == (12, len(va))
    low = pts[left] - [0.0, 0.0, 0.05]
    p, f, w, eq = flat_contacts(*args, low, frames[left], which[left], 0.01, 100.0, 20.0)
    assert w.tolist() == [0] * 4 and eq is not None and eq[0].shape == (6, len(va))
    assert np.allclose(p, sole_points(d.xpos[ctl._feet[0]], d.xmat[ctl._feet[0]].reshape(3, 3), ctl._corners[0])[0])


def test_optional_rows_go_first_and_the_others_stay_hard() -> None:
    # Hard rows x = 0.5, x = −0.5 (contradicting) and y = 0.2: marking the second optional drops it alone (the first and
    # third hold exactly, nothing relaxed); marking the first instead holds x = −0.5 (the decision inverted); without
    # optional rows all are dropped together (the objective's own solution).
    m, d, tasks = _lean_forward()
    pr = _problem(m, d, tasks)
    n = pr["M"].shape[0]
    A = np.vstack([np.eye(m.nv)[:1], np.eye(m.nv)[:1], np.eye(m.nv)[1:2]])
    b = np.array([0.5, -0.5, 0.2])

    def solve(optional):  # noqa: ANN001, ANN202
        return solve_contact_qp(pr["M"], pr["h"], pr["unactuated"], pr["point_jac"], pr["edges"], pr["tasks"],
                                pr["mass"], pr["w_force"], np.tile([-np.inf, np.inf], (n, 1)), None, pr["foot"],
                                equalities=(A, b), optional=optional)

    second = solve(np.array([False, True, False]))
    assert second.found and second.optional_dropped and not second.relaxed
    np.testing.assert_allclose(second.qacc[:2], [0.5, 0.2], atol=1e-6)
    first = solve(np.array([True, False, False]))
    assert first.optional_dropped and not first.relaxed
    np.testing.assert_allclose(first.qacc[:2], [-0.5, 0.2], atol=1e-6)
    none = solve(None)
    assert none.relaxed and not none.optional_dropped
    np.testing.assert_allclose(none.qacc, _qp(pr).qacc, atol=1e-6)
    # Rows that hold together: nothing is dropped, optional or not.
    ok = solve_contact_qp(pr["M"], pr["h"], pr["unactuated"], pr["point_jac"], pr["edges"], pr["tasks"], pr["mass"],
                          pr["w_force"], np.tile([-np.inf, np.inf], (n, 1)), None, pr["foot"],
                          equalities=(A[[0, 2]], b[[0, 2]]), optional=np.array([True, False]))
    assert not ok.optional_dropped and not ok.relaxed
    np.testing.assert_allclose(ok.qacc[:2], [0.5, 0.2], atol=1e-6)


def test_the_yaw_rows_are_each_foots_angular_vertical_row(scene) -> None:
    # Against MuJoCo's rotational Jacobian of each foot: the rows yaw_rows marks are its world-z row, for two feet.
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[scene.robot_qadr] = scene.home_qpos
    mujoco.mj_forward(m, d)
    va = np.asarray(scene.robot_vadr)
    feet = [int(b) for b in FeetOnFloor(scene, 0.0).bodies]
    rows = np.vstack([foot_rows(m, d, b, va, d.xpos[b].copy(), d.xmat[b].reshape(3, 3).copy(), 100.0, 20.0)[0]
                      for b in feet])
    mask = yaw_rows(len(rows))
    assert mask.tolist() == [False] * 5 + [True] + [False] * 5 + [True]
    for k, b in enumerate(feet):
        jr = np.zeros((3, m.nv))
        mujoco.mj_jacBody(m, d, None, jr, b)
        np.testing.assert_allclose(rows[mask][k], jr[2, va], atol=1e-12)
        np.testing.assert_allclose(rows[6 * k + 3:6 * k + 5], jr[:2, va], atol=1e-12)  # the other two turns: not marked
