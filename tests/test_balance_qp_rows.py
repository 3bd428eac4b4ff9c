"""The balance QP's and step's shortcuts of issue 25 (the standing mode's CPU cost, second pass), each against an
independent construction, bit for bit: the constraint rows handed to DAQP (and the subsets the relaxations hand it)
against an entry-by-entry build; the joints' task as a diagonal task against its (n − 6) × n rows; a foot's
feedback and drift against MuJoCo's Jacobians and :func:`foot_rows`; the flat feet's rows from the caller's feedback;
both feet's centre-of-pressure intervals at once against one foot at a time; the cone edges the controller keeps
while the contact frames repeat."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from socialaff_sim.sim import balance_control, contact_qp
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.contact_dynamics import cone_edges
from socialaff_sim.sim.contact_qp import cop_rows, solve_contact_qp
from socialaff_sim.sim.flat_feet import flat_contacts, foot_drift, foot_feedback, foot_rows
from socialaff_sim.sim.scene import Scene
from socialaff_sim.sim.support_box import cop_interval, cop_intervals
from test_balance_control import _stand

INF = 1e30


def _random_qp(rng, n: int = 9, P: int = 6, unbounded: bool = True) -> dict:
    """A random problem with every kind of row: torque limits (some infinite), hard task rows, inequality rows,
    foot loads on two feet (one point of neither) and centre-of-pressure rows."""
    B = rng.normal(size=(n, n))
    M = B @ B.T + n * np.eye(n)
    unact = np.zeros(n, dtype=bool)
    unact[rng.choice(n, size=3, replace=False)] = True  # not only the first rows: the rows' order is tested
    frames = np.tile(np.eye(3)[[2, 0, 1]], (P, 1, 1))
    edges = cone_edges(frames, 0.7)
    foot = np.array([0, 1, 0, 1, -1, 0][:P]) if unbounded else np.array([0, 1] * (P // 2))
    lim = np.column_stack([-rng.uniform(5, 50, n), rng.uniform(5, 50, n)])
    lim[rng.choice(n, size=2, replace=False)] = [-np.inf, np.inf]
    pts = np.column_stack([rng.uniform(-0.1, 0.1, size=(P, 2)), np.zeros(P)])
    bounds = np.stack([np.full((2, 2), -0.05), np.full((2, 2), 0.05)], axis=2)
    return {"M": M, "h": rng.normal(size=n) * 10, "unactuated": unact, "point_jac": rng.normal(size=(P, 3, n)),
            "edges": edges, "tasks": [(rng.normal(size=(3, n)), rng.normal(size=3), 2.0)], "mass": 7.5,
            "w_force": 1e-3, "tau_limits": lim, "cop": cop_rows(pts, edges, foot, np.eye(2), bounds), "foot": foot,
            "min_load": 3.0, "equalities": (rng.normal(size=(2, n)), rng.normal(size=2)),
            "inequalities": (rng.normal(size=(2, n)), rng.normal(size=2))}


def _rows_by_entry(pr: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict]:
    """The constraint rows (before scaling), row by row and entry by entry, in the documented order, with the row
    ranges of each block."""
    M, h, mass, edges, foot = pr["M"], pr["h"], pr["mass"], pr["edges"], pr["foot"]
    n, P = M.shape[0], len(edges)
    K = 4 * P
    G = np.einsum("pin,pik->npk", pr["point_jac"], edges).reshape(n, K)  # the module's own definition of G
    rows, up, lo, sense = [], [], [], []

    def add(row, u, lw, s):
        rows.append(row)
        up.append(u)
        lo.append(lw)
        sense.append(s)

    for i in [i for i in range(n) if pr["unactuated"][i]] + [i for i in range(n) if not pr["unactuated"][i]]:
        row = np.array([-G[i, k] for k in range(K)] + [M[i, j] / mass for j in range(n)])
        if pr["unactuated"][i]:
            add(row, -(h[i] / mass), -(h[i] / mass), 5)
        else:
            tl, th = pr["tau_limits"][i]
            add(row, th / mass - h[i] / mass if np.isfinite(th) else INF,
                tl / mass - h[i] / mass if np.isfinite(tl) else -INF, 0)
    blocks = {"dyn": (0, n)}
    start = len(rows)
    for a, lw in zip(*pr["inequalities"], strict=True):
        add(np.concatenate([np.zeros(K), a]), INF, lw, 0)
    blocks["ineq"] = (start, len(rows))
    start = len(rows)
    for a, b in zip(*pr["equalities"], strict=True):
        add(np.concatenate([np.zeros(K), a]), b, b, 5)
    blocks["eq"] = (start, len(rows))
    start = len(rows)
    for s in sorted({int(f) for f in foot if f >= 0}):
        row = np.zeros(K + n)
        for p in range(P):
            if foot[p] == s:
                row[4 * p: 4 * p + 4] = edges[p, 2, :]
        add(row, INF, pr["min_load"] / mass, 0)
    blocks["load"] = (start, len(rows))
    start = len(rows)
    for c in pr["cop"]:
        add(np.concatenate([c, np.zeros(n)]), INF, 0.0, 0)
    blocks["cop"] = (start, len(rows))
    return np.array(rows), np.array(up), np.array(lo), np.array(sense), blocks


def _capture(monkeypatch, fail: int) -> list:
    """Every call of the module's DAQP wrapper, the first ``fail`` of them answered "infeasible", the rest
    "solved" (whatever DAQP says: the sequence of calls is what is tested)."""
    calls: list = []
    real = contact_qp._daqp

    def spy(H, f, K, A, up, lo, sn):
        calls.append((A.copy(), up.copy(), lo.copy(), sn.copy()))
        x, _ = real(H, f, K, A, up, lo, sn)
        return (x, -1) if len(calls) <= fail else (x, 1)

    monkeypatch.setattr(contact_qp, "_daqp", spy)
    return calls


@pytest.mark.parametrize("fail", [0, 1, 2, 3])
def test_the_qps_rows_and_each_relaxations_rows_are_those_built_entry_by_entry(rng, monkeypatch, fail) -> None:
    pr = _random_qp(rng)
    calls = _capture(monkeypatch, fail)
    res = solve_contact_qp(**pr)
    A, up, lo, sn, blocks = _rows_by_entry(pr)
    R = len(A)
    everything = np.arange(R)
    without_eq = np.setdiff1d(everything, np.arange(*blocks["eq"]))
    base = np.arange(blocks["ineq"][1])  # the equation of motion and the inequality rows
    dyn = np.arange(n := pr["M"].shape[0])
    expected = [everything, without_eq, base, dyn][:fail + 1]
    assert len(calls) == len(expected)
    for (gA, gup, glo, gsn), keep in zip(calls, expected, strict=True):
        assert gA.flags.c_contiguous  # (the rows' norms are summed along contiguous rows, as before)
        np.testing.assert_array_equal(gA, A[keep])
        np.testing.assert_array_equal(gup, up[keep])
        np.testing.assert_array_equal(glo, lo[keep])
        np.testing.assert_array_equal(gsn, sn[keep])
    assert res.relaxed == (fail >= 1)
    assert res.inequalities_dropped == (fail >= 3)
    assert len(dyn) == n


def test_without_optional_rows_the_qp_gets_the_equation_of_motion_only(rng, monkeypatch) -> None:
    pr = _random_qp(rng)
    pr.update(cop=None, min_load=0.0, equalities=None, inequalities=None)
    calls = _capture(monkeypatch, 0)
    solve_contact_qp(**pr)
    A, up, lo, sn, blocks = _rows_by_entry({**pr, "cop": np.zeros((0, 4 * len(pr["edges"]))),
                                            "equalities": (np.zeros((0, 9)), np.zeros(0)),
                                            "inequalities": (np.zeros((0, 9)), np.zeros(0)), "foot": -np.ones(6)})
    assert blocks["cop"][1] == blocks["dyn"][1] == len(A) == len(calls[0][0])
    np.testing.assert_array_equal(calls[0][0], A)
    np.testing.assert_array_equal(calls[0][2], lo)


def test_a_diagonal_task_gives_the_bits_of_its_rows(rng) -> None:
    """The joints' task as the controller hands it to the QP, (A (n,), b (n,)) with zeros on the root, gives the
    same solution, bit for bit, as its (n − 6) × n rows; a change of one weight does not."""
    for _ in range(10):
        pr = _random_qp(rng, n=12)
        scale = rng.uniform(0.1, 1.0, size=6)
        want = rng.normal(size=6)
        rows = np.eye(12)[6:] * scale[:, None]
        full = solve_contact_qp(**{**pr, "tasks": [*pr["tasks"], (rows, want * scale, 0.5)]})
        diag = solve_contact_qp(**{**pr, "tasks": [*pr["tasks"], (np.concatenate([np.zeros(6), scale]),
                                                                  np.concatenate([np.zeros(6), want * scale]), 0.5)]})
        np.testing.assert_array_equal(full.tau, diag.tau)
        np.testing.assert_array_equal(full.qacc, diag.qacc)
        np.testing.assert_array_equal(full.beta, diag.beta)
        other = solve_contact_qp(**{**pr, "tasks": [*pr["tasks"], (np.concatenate([np.zeros(6), scale]),
                                                                   np.concatenate([np.zeros(6), want * scale]), 0.6)]})
        assert not np.array_equal(full.qacc, other.qacc)


def moving_home(rng: np.random.Generator, scene: Scene) -> tuple[mujoco.MjModel, mujoco.MjData, np.ndarray]:
    """Stubby at its home pose with random joint velocities (rad/s, m/s; σ 0.5), forward-computed: (model, data, the
    robot's velocity addresses)."""
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[scene.robot_qadr] = scene.home_qpos
    d.qvel[:] = rng.normal(scale=0.5, size=m.nv)
    mujoco.mj_forward(m, d)
    return m, d, np.asarray(scene.robot_vadr)


def _foot(scene: Scene) -> int:
    m, k = scene.model, 3
    return int(m.site_bodyid[scene.frame_ids[k]]) if scene.frame_kinds[k] == "site" else int(scene.frame_ids[k])


def test_a_foots_feedback_and_drift_against_mujocos_jacobians_and_foot_rows(rng, scene: Scene) -> None:
    m, d, vadr = moving_home(rng, scene)
    body = _foot(scene)
    goal = d.xpos[body] + rng.normal(scale=0.01, size=3)
    rot = np.array([[np.cos(0.1), -np.sin(0.1), 0.0], [np.sin(0.1), np.cos(0.1), 0.0], [0.0, 0.0, 1.0]])
    J, b = foot_feedback(m, d, body, vadr, goal, rot, 100.0, 20.0, np.full((6, m.nv), np.nan))
    jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))  # independently: MuJoCo's Jacobian and the rotation's vector
    mujoco.mj_jacBody(m, d, jp, jr, body)
    Jr = np.vstack([jp[:, vadr], jr[:, vadr]])
    quat, vel = np.zeros(4), np.zeros(3)
    mujoco.mju_mat2Quat(quat, (rot @ d.xmat[body].reshape(3, 3).T).ravel())
    mujoco.mju_quat2Vel(vel, quat, 1.0)
    np.testing.assert_array_equal(J, Jr)
    np.testing.assert_array_equal(b, 100.0 * np.concatenate([goal - d.xpos[body], vel]) - 20.0 * (Jr @ d.qvel[vadr]))
    jpd, jrd = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    mujoco.mj_jacDot(m, d, jpd, jrd, d.xpos[body], body)
    np.testing.assert_array_equal(foot_drift(m, d, body), np.vstack([jpd, jrd]) @ d.qvel)
    A, rhs = foot_rows(m, d, body, vadr, goal, rot, 100.0, 20.0)
    np.testing.assert_array_equal(A, J)
    np.testing.assert_array_equal(rhs, b - foot_drift(m, d, body))


def test_flat_contacts_from_the_callers_feedback_are_the_same_bits(rng, scene: Scene) -> None:
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[scene.robot_qadr] = scene.home_qpos
    d.qpos[scene.robot_qadr[2]] -= 0.001  # pressed 1 mm into the floor: both feet in contact
    d.qvel[:] = rng.normal(scale=0.3, size=m.nv)
    mujoco.mj_forward(m, d)
    ctl = balance_control.BalanceController(scene, BalanceConfig(solver="qp", flat_feet=True))
    vadr = np.asarray(scene.robot_vadr)
    pts, frames, which = ctl.feet.contacts(d)
    assert len(pts)
    anchors = [(d.xpos[b] + rng.normal(scale=0.005, size=3), d.xmat[b].reshape(3, 3).copy()) for b in ctl._feet]
    corners = ctl._corners
    feedback = [foot_feedback(m, d, b, vadr, p, r, 80.0, 15.0) for b, (p, r) in zip(ctl._feet, anchors, strict=True)]
    args = (m, d, ctl._feet, corners, anchors, vadr, pts, frames, which, 0.01, 80.0, 15.0)
    plain = flat_contacts(*args)
    given = flat_contacts(*args, None, feedback)
    for a, b in zip(plain[:3], given[:3], strict=True):
        np.testing.assert_array_equal(a, b)
    assert plain[3] is not None and given[3] is not None
    np.testing.assert_array_equal(plain[3][0], given[3][0])
    np.testing.assert_array_equal(plain[3][1], given[3][1])
    wrong = flat_contacts(*args, None, [foot_feedback(m, d, b, vadr, p, r, 81.0, 15.0)  # other gains: other rows
                                        for b, (p, r) in zip(ctl._feet, anchors, strict=True)])
    assert not np.array_equal(plain[3][1], wrong[3][1])


def test_both_feets_cop_intervals_at_once_are_each_foots_own(rng) -> None:
    for _ in range(30):
        t = rng.uniform(0.0, np.pi)
        axes = np.array([[np.cos(t), np.sin(t)], [-np.sin(t), np.cos(t)]])
        soles = [rng.normal(scale=0.1, size=(8, 2)) + rng.normal(size=2) for _ in range(2)]
        points = [s[rng.choice(8, size=int(rng.integers(1, 6)), replace=False)] + rng.normal(scale=0.03, size=2)
                  for s in soles]
        margin = float(rng.uniform(0.0, 0.08))
        both = cop_intervals(axes, soles, points, margin)
        assert both.shape == (2, 2, 2)
        for f in range(2):
            np.testing.assert_array_equal(both[f], cop_interval(axes, soles[f], points[f], margin))
            # and by hand, per axis: the shrunk sole (its middle where too narrow) within the points' extent
            for a in range(2):
                s, p = soles[f] @ axes[a], points[f] @ axes[a]
                lo, hi = min(s.min() + margin, 0.5 * (s.min() + s.max())), max(s.max() - margin, 0.5 * (s.min() + s.max()))
                lo2, hi2 = max(lo, p.min()), min(hi, p.max())
                if lo2 > hi2:
                    lo2 = hi2 = min(max(0.5 * (lo + hi), p.min()), p.max())
                np.testing.assert_allclose(both[f, a], [lo2, hi2], atol=1e-12)


def test_the_controller_keeps_the_cone_edges_while_the_frames_repeat(scene: Scene, monkeypatch) -> None:
    made: list[np.ndarray] = []
    real = balance_control.cone_edges

    def counted(frames, mu):
        made.append(frames.copy())
        return real(frames, mu)

    monkeypatch.setattr(balance_control, "cone_edges", counted)
    ctl, _, _ = _stand(scene, BalanceConfig(solver="qp", flat_feet=True, drive_harnessed=True), 0.2)
    assert ctl.active_steps > 10
    assert 1 <= len(made) < ctl.active_steps  # the flat feet's level frames: made once, not every step
    for a, b in zip(made, made[1:]):  # made again only for other frames
        assert a.shape != b.shape or not np.array_equal(a, b)
    key, edges = ctl._edges
    np.testing.assert_array_equal(edges, real(made[-1], ctl.config.friction))
    assert key == made[-1].tobytes() and not edges.flags.writeable
