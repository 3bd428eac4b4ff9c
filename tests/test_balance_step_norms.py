"""The standing step's third pass of bit-for-bit cuts (issue 25, the standing mode's CPU cost): the norms written
as ``np.linalg.norm`` computes them, the QP's contact forces worked out only when read, and the contact points'
Jacobians written in place and their robot columns taken once — each against the computation it replaces."""

from __future__ import annotations

import mujoco
import numpy as np

from socialaff_sim.sim import balance_control
from socialaff_sim.sim.arm_compensation import approach_gate, fade
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.contact_qp import solve_contact_qp
from socialaff_sim.sim.feet_on_floor import FeetOnFloor
from socialaff_sim.sim.hand_yield import yield_rate
from socialaff_sim.sim.scene import Scene
from test_balance_control import _stand
from test_balance_qp_rows import _random_qp


def test_the_qps_forces_read_when_wanted_are_each_points_edges_times_its_weights(rng) -> None:
    """``ContactQPResult.forces``, worked out on first reading: f_p = E_p β_p, point by point (to rounding), and the
    very bits of the einsum the solve computed before; read twice, the same array; no points, no forces."""
    for _ in range(5):
        pr = _random_qp(rng)
        res = solve_contact_qp(**pr)
        edges, P = pr["edges"], len(pr["edges"])
        by_point = np.array([edges[p] @ res.beta[4 * p: 4 * p + 4] for p in range(P)])
        np.testing.assert_allclose(res.forces, by_point, rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(res.forces, np.einsum("pik,pk->pi", edges, res.beta.reshape(P, 4)))
        assert res.forces is res.forces
        assert (res.forces[:, 2] >= -1e-9).all()  # the cones' edges push
    pr = _random_qp(rng)
    n = pr["M"].shape[0]
    pr.update(point_jac=np.zeros((0, 3, n)), edges=np.zeros((0, 3, 4)), cop=None, foot=np.zeros(0, dtype=np.int64),
              min_load=0.0)
    assert solve_contact_qp(**pr).forces.shape == (0, 3)


def test_the_norms_written_out_are_numpys_bit_for_bit(rng) -> None:
    """The arms' fade, the approach gate and the hands' yield rate give what they gave with ``np.linalg.norm``."""
    for _ in range(200):
        force = rng.normal(scale=rng.choice([0.1, 10.0, 100.0]), size=(2, 3))
        ref_fade = np.clip(1.0 - np.linalg.norm(force, axis=1) / 40.0, 0.0, 1.0)
        np.testing.assert_array_equal(fade(force, 40.0), ref_fade)
        wrists, targets = rng.normal(scale=0.3, size=(2, 3)), rng.normal(scale=0.3, size=(7, 3))
        touched = rng.random(2) < 0.3
        near = np.linalg.norm(wrists[:, None, :] - targets[None, :, :], axis=2).min(axis=1) <= 0.25
        np.testing.assert_array_equal(approach_gate(wrists, targets, touched, 0.25), (near & ~touched).astype(float))
        f = force[:, :2]
        total = float(np.linalg.norm(f.sum(axis=0)))
        allowance = rng.uniform(0.0, 2.0 * total + 1e-3)
        excess = total - 0.5 * allowance
        ref_rate = np.zeros((2, 2)) if excess <= 0.0 or total <= 0.0 else excess / 20.0 * f / total
        np.testing.assert_array_equal(yield_rate(f, allowance, 0.5, 20.0), ref_rate)


def test_the_feet_heading_is_the_one_normalised_by_numpys_norm(rng, scene: Scene) -> None:
    m = scene.model
    feet = FeetOnFloor(scene, 0.005)
    d = mujoco.MjData(m)
    for _ in range(20):
        d.qpos[scene.robot_qadr] = scene.home_qpos
        d.qpos[scene.robot_qadr[7:]] += rng.normal(scale=0.2, size=len(scene.robot_qadr) - 7)
        quat = rng.normal(size=4)
        d.qpos[scene.robot_qadr[3:7]] = quat / np.linalg.norm(quat)
        mujoco.mj_kinematics(m, d)
        f = sum(d.xmat[b].reshape(3, 3) @ a for b, a in zip(feet.bodies, feet.forward, strict=True))[:2]
        nrm = float(np.linalg.norm(f))
        np.testing.assert_array_equal(feet.heading(d), f / nrm if nrm > 1e-9 else np.array([1.0, 0.0]))


def test_the_controllers_contact_jacobians_are_mujocos_per_point(scene: Scene, monkeypatch) -> None:
    """The QP's point Jacobians, written in place for every contact point and their robot columns taken at once,
    are MuJoCo's ``mj_jac`` of each point on its foot, the robot's columns, at the state the controller acts on."""
    seen: dict[str, object] = {}
    checked = []
    real_torques = balance_control.BalanceController._torques
    real_flat = balance_control.flat_contacts
    real_solve = balance_control.solve_contact_qp

    def torques(self, m, d, *args):
        seen.update(ctl=self, m=m, d=d)
        return real_torques(self, m, d, *args)

    def flat(*args, **kwargs):
        out = real_flat(*args, **kwargs)
        seen.update(pts=out[0], which=out[2])
        return out

    def solve(M, h, unactuated, point_jac, *args, **kwargs):
        ctl, m, d = seen["ctl"], seen["m"], seen["d"]
        jp = np.zeros((3, m.nv))
        want = []
        for p, s in zip(seen["pts"], seen["which"], strict=True):
            mujoco.mj_jac(m, d, jp, None, p, int(ctl._feet[int(s)]))
            want.append(jp[:, ctl.vadr].copy())
        np.testing.assert_array_equal(point_jac, np.array(want))
        checked.append(len(want))
        return real_solve(M, h, unactuated, point_jac, *args, **kwargs)

    monkeypatch.setattr(balance_control.BalanceController, "_torques", torques)
    monkeypatch.setattr(balance_control, "flat_contacts", flat)
    monkeypatch.setattr(balance_control, "solve_contact_qp", solve)
    ctl, _, _ = _stand(scene, BalanceConfig(solver="qp", flat_feet=True, drive_harnessed=True), 0.1)
    assert ctl.active_steps > 0 and len(checked) == ctl.active_steps and min(checked) >= 3
