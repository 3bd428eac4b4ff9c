"""Hands that give way to a force the feet cannot carry (sim/hand_yield.py, BalanceConfig(hand_yield=...)) and feet
that do not step while the hands hold on (FootLockConfig(hold_in_contact=True)): the feet's allowance against a
static equilibrium solved by numpy.linalg (the centre of pressure then sits exactly on the edge), the yield's
decision (none within the allowance, along the force beyond it), the offsets' growth, return and cap, the wrist
moved by the hinge offsets (MuJoCo's kinematics, not the Jacobian), the foot lock's hold, the settings' checks,
and a pull-up in physics."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.external_force import Contacts
from socialaff_sim.sim.footlock import FootLock, FootLockConfig
from socialaff_sim.sim.hand_yield import MAX_OFFSET, HandYield, feet_allowance, yield_rate
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.stance import StanceConfig
from socialaff_sim.sim.support_box import SupportBox


def _cop_along(u: np.ndarray, c: np.ndarray, weight: float, f_h: float, h: float, f_z: float, x: np.ndarray) -> float:
    """Reference: the centre of pressure's coordinate along ``u`` of a rigid body in static equilibrium in the
    (u, z) plane under its weight at ``c`` (2,), a force (f_h along u, f_z up) at ``x`` (2,) h above the floor, and
    the floor's reaction (F_t, N) at p: the forces F_t + f_h = 0, N − W + f_z = 0 and the moments about the origin
    (r_u F_z − r_z F_u) −W c_u + (x_u f_z − h f_h) + p N = 0, solved for p."""
    n = weight - f_z
    return (weight * float(c @ u) - (float(x @ u) * f_z - h * f_h)) / n


@pytest.mark.parametrize("heading", [0.0, 0.7, 2.5])
@pytest.mark.parametrize("angle", [0.3, 1.9, 4.0])
def test_the_feet_carry_a_force_up_to_the_centre_of_pressure_on_the_edge(heading, angle) -> None:
    rng = np.random.default_rng(3)
    fwd = np.array([np.cos(heading), np.sin(heading)])
    xy = rng.uniform(-0.15, 0.15, size=(8, 2))
    box = SupportBox(xy, fwd)
    u = np.array([np.cos(angle), np.sin(angle)])
    c = box.middle() + rng.uniform(-0.02, 0.02, size=2)
    weight, h, margin = 446.0, 1.0, 0.01
    corners = np.array([[a, b] for a in (box.lo[0], box.hi[0]) for b in (box.lo[1], box.hi[1])]) @ box.R
    edge = float((corners @ u).max()) - margin  # brute force: the box's farthest corner along u
    for f_z, x in ((0.0, None), (-90.0, c - 0.5 * u), (40.0, c - 0.3 * u)):
        allow = feet_allowance(box, u, c, margin, weight, h, f_z, x)
        xr = c if x is None else x
        assert allow > 0.0
        assert _cop_along(u, c, weight, allow, h, f_z, xr) == pytest.approx(edge, abs=1e-9)
        assert _cop_along(u, c, weight, 1.1 * allow, h, f_z, xr) > edge + 1e-4  # more tips it
    # a person leaning down on the hands in front of the robot lets it carry more; lifting them, less
    plain = feet_allowance(box, u, c, margin, weight, h)
    assert feet_allowance(box, u, c, margin, weight, h, -90.0, c - 0.5 * u) > plain
    assert feet_allowance(box, u, c, margin, weight, h, 40.0, c - 0.3 * u) < plain
    # the capture point past the edge: nothing to spare
    assert feet_allowance(box, u, c + 0.5 * u, margin, weight, h) == 0.0


def test_the_arms_give_way_only_beyond_the_allowance_and_along_their_own_force() -> None:
    f = np.array([[30.0, 40.0], [0.0, 0.0]])  # 50 N on the left arm
    assert not yield_rate(f, 100.0, 0.5, 50.0).any()  # 50 ≤ 0.5 · 100
    assert not yield_rate(f, 120.0, 0.5, 50.0).any()
    r = yield_rate(f, 60.0, 0.5, 50.0)  # 20 N over: 0.4 m/s along (0.6, 0.8)
    np.testing.assert_allclose(r, [[0.24, 0.32], [0.0, 0.0]], atol=1e-12)
    both = np.array([[30.0, 0.0], [10.0, 0.0]])
    r = yield_rate(both, 0.0, 0.5, 100.0)  # 40 N over, shared as the arms carry it
    np.testing.assert_allclose(r, [[0.3, 0.0], [0.1, 0.0]], atol=1e-12)


def _yield(scene) -> HandYield:
    return HandYield(scene, 0.5, 50.0, 0.5, 0.0)


def test_offsets_grow_along_the_force_return_when_it_drops_and_stop_at_the_cap(scene) -> None:
    hy = _yield(scene)
    box = SupportBox(np.array([[-0.1, -0.15], [0.1, -0.15], [-0.1, 0.15], [0.1, 0.15]]), np.array([1.0, 0.0]))
    hy.force = np.array([[-80.0, 0.0, 0.0], [0.0, 0.0, 0.0]])  # pushed backward at 1 m
    hy._height = 1.0
    dt = 0.004
    allow = feet_allowance(box, np.array([-1.0, 0.0]), np.zeros(2), 0.01, 446.0, 1.0)
    hy.update(dt, box, np.zeros(2), 0.0, 0.01, 446.0)
    np.testing.assert_allclose(hy.offset[0], [-dt * (80.0 - 0.5 * allow) / 50.0, 0.0], atol=1e-12)
    assert hy.yield_steps == 1
    for _ in range(2000):
        hy.update(dt, box, np.zeros(2), 0.0, 0.01, 446.0)
    assert np.linalg.norm(hy.offset[0]) == pytest.approx(MAX_OFFSET)
    hy.force[:] = 0.0
    before = hy.offset.copy()
    hy.update(dt, box, np.zeros(2), 0.0, 0.01, 446.0)
    np.testing.assert_allclose(hy.offset, before * (1.0 - dt / 0.5), atol=1e-12)


def test_hinge_offsets_move_the_wrist_by_the_offset(scene) -> None:
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[scene.robot_qadr] = scene.home_qpos
    mujoco.mj_forward(m, d)
    hy = _yield(scene)
    for s, off in ((0, np.array([0.01, -0.008])), (1, np.array([-0.006, 0.012]))):
        hy.offset[:] = 0.0
        hy.offset[s] = off
        dq, dv = hy.offsets(m, d)
        assert not dv.any()
        wrist = hy._wrist[s]
        p0 = d.xpos[wrist].copy()
        other = d.xpos[hy._wrist[1 - s]].copy()
        d2 = mujoco.MjData(m)
        d2.qpos[:] = d.qpos
        d2.qpos[scene.robot_qadr[7:]] += dq
        mujoco.mj_kinematics(m, d2)
        moved = d2.xpos[wrist] - p0
        np.testing.assert_allclose(moved[:2], off, atol=0.15 * np.linalg.norm(off))  # damped: a little short
        assert float(moved[:2] @ off) > 0.8 * float(off @ off)
        np.testing.assert_allclose(d2.xpos[hy._wrist[1 - s]], other, atol=1e-12)  # the other arm stays


def test_hold_in_contact_keeps_planted_feet_while_the_hands_hold_on() -> None:
    home = (0.08, 0.08)
    ankles = np.array([[0.0, 0.1, 0.08], [0.0, -0.1, 0.08]])
    away = ankles + np.array([[0.3, 0.0, 0.1], [0.0, 0.0, 0.0]])  # the left target steps 30 cm, 10 cm up
    for hold, touching, stays in ((True, True, True), (True, False, False), (False, True, False)):
        lock = FootLock(home, FootLockConfig(hold_lift=0.12, hold_in_contact=hold))
        lock.apply(ankles)
        out = lock.apply(away, touching)
        assert np.allclose(out[0], ankles[0]) == stays
        assert (lock.planted[0] is not None) == stays
    lock = FootLock(home, FootLockConfig(hold_in_contact=True))
    out = lock.apply(away, True)  # nothing planted yet: the targets decide
    assert lock.planted[0] is None and np.allclose(out[0], away[0])


def test_hand_yield_settings_are_checked() -> None:
    with pytest.raises(ConfigError, match="hand_yield"):
        BalanceConfig(hand_yield=-0.1)
    with pytest.raises(ConfigError, match="yield_damping"):
        BalanceConfig(hand_yield=0.5, yield_damping=0.0)
    with pytest.raises(ConfigError, match="yield_return"):
        BalanceConfig(yield_return=-1.0)
    assert BalanceConfig().hand_yield is None and not FootLockConfig().hold_in_contact


def test_a_pulled_robot_whose_hands_give_way_stays_upright_and_free_longer() -> None:
    """pull_up_001 (synthetic, seed 0), the balance QP on the steadied base with flat feet and the arms kept clear:
    the person's hand presses the robot's back with 30–60 N at 1 m and tips it over its heels (torso 14–15°)
    until the harness catches it; with the hands giving way it stands more upright and longer free of the harness
    in the contact phase."""
    inter = next(i for i in generate_dataset(seed=0) if i.instance_id == "pull_up_001")
    tilt, released = [], []
    for kappa in (None, 0.5):
        qp = BalanceConfig(solver="qp", sole_gap=0.01, w_torso=3.0, flat_feet=True, self_clearance=0.01,
                           hand_yield=kappa, yield_damping=50.0)
        sim = Simulator("ours", "pull_up", SimConfig(foot_lock=FootLockConfig(hold_lift=0.12), balance=qp,
                                                     stance=StanceConfig(release=False)))
        cp = run_episode(sim, GroundTruthSource(), inter)["support"]["contact_phase"]
        tilt.append(cp["torso_tilt_deg_max"])
        released.append(cp["released_frames"] / cp["frames"])
    assert tilt[1] < tilt[0] - 2.0 and released[1] > released[0]


def test_only_the_persons_contacts_set_the_arms_giving_way(scene) -> None:
    """An object a grip weld holds presses on the hand it is welded to (forces internal to robot and object): those
    contacts do not count, the person's do."""
    m = scene.model
    hy = _yield(scene)
    left = int(np.flatnonzero(scene.arm_geom[0])[0])
    person = int(scene.human_geom_ids[-1])
    other = int(next(g for g in range(m.ngeom) if g not in set(scene.human_geom_ids.tolist()) and not scene.robot_geom[g]))
    pts = np.array([[0.3, 0.1, 1.0], [0.3, 0.1, 0.9]])
    forces = np.array([[-40.0, 0.0, 5.0], [0.0, 70.0, 0.0]])
    hy.measure(m, Contacts(pts, forces, np.array([left, left]), np.array([person, other])))
    np.testing.assert_allclose(hy.force, [[-40.0, 0.0, 5.0], [0.0, 0.0, 0.0]], atol=1e-12)
    assert hy._height == pytest.approx(1.0)
