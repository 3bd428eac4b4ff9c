"""``qp_kernel = "numba"``'s compiled pieces of the balance controller against their NumPy references (session 34):
the support box (:mod:`socialaff_sim.sim.support_kernel`), the feet's tasks and flat contacts
(:mod:`socialaff_sim.sim.feet_kernel`), the arms' damped steps, give and compensation share
(:mod:`socialaff_sim.sim.arm_kernel`), the self-clearance rows (:mod:`socialaff_sim.sim.clearance_kernel`), and which
controller holds them."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from socialaff_sim.sim.arm_compensation import ArmCompensation, approach_gate, fade
from socialaff_sim.sim.arm_kernel import compensation_share, damped_step
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.balance_control import BalanceController
from socialaff_sim.sim.clearance_kernel import CompiledClearance
from socialaff_sim.sim.feet_kernel import CompiledFeet, rotation_vector
from socialaff_sim.sim.feet_on_floor import FeetOnFloor
from socialaff_sim.sim.flat_feet import flat_attitude, flat_contacts, foot_feedback
from socialaff_sim.sim.hand_yield import HandYield
from socialaff_sim.sim.self_clearance import SelfClearance
from socialaff_sim.sim.support_box import SupportBox
from socialaff_sim.sim.support_kernel import CompiledSupport

pytest.importorskip("numba", reason="qp_kernel=\"numba\" needs numba (the [fast] extra)")


def _standing(scene, rng: np.random.Generator) -> mujoco.MjData:
    """Stubby pressed 1 mm into the floor (both feet touch), its hinges moved a little, random velocities."""
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[scene.robot_qadr] = scene.home_qpos
    d.qpos[scene.robot_qadr[7:]] += rng.normal(scale=0.02, size=len(scene.robot_qadr) - 7)
    d.qpos[scene.robot_qadr[2]] -= 0.001
    d.qvel[scene.robot_vadr] = rng.normal(scale=0.3, size=len(scene.robot_vadr))
    mujoco.mj_forward(m, d)
    return d


def test_the_compiled_support_is_numpys_to_rounding(scene, rng) -> None:
    """The feet's contacts exactly FeetOnFloor's; soles in the world, the box's axes and extents: within 1e-12 of
    FeetOnFloor's and SupportBox's, over states
    with both feet down and with one foot's sole above the floor by more than the gap (left out of the box) or within
    it (kept)."""
    feet = FeetOnFloor(scene, 0.01)
    cs = CompiledSupport(feet)
    seen = set()
    for case in range(12):
        d = _standing(scene, rng)
        pts, frames, which = feet.contacts(d)
        assert len(pts)
        for got, want in zip(cs.contacts(d), (pts, frames, which), strict=True):  # bit for bit
            np.testing.assert_array_equal(got, want)
        if case % 3:  # only the left foot's contacts live; the right sole raised by 5 mm or 3 cm
            keep = which == 0
            pts, which = pts[keep], which[keep]
            d.xpos[feet.bodies[1], 2] += 0.005 if case % 3 == 1 else 0.03
        soles, box = cs.support(d, pts, which)
        want = feet.soles_at(d)
        ref = SupportBox(feet.footprint(d, pts, which, want), feet.heading(d))
        for a, b in zip(soles, want, strict=True):
            np.testing.assert_allclose(a, b, atol=1e-12)
        for a, b in ((box.R, ref.R), (box.lo, ref.lo), (box.hi, ref.hi)):
            np.testing.assert_allclose(a, b, atol=1e-12)
        both = SupportBox(np.vstack([s[:, :2] for s in want]), feet.heading(d))
        seen.add(bool(np.allclose(box.lo, both.lo) and np.allclose(box.hi, both.hi)))
    assert seen == {True, False}  # the raised foot was both kept (within the gap) and left out


def test_the_rotation_vector_is_mujocos(rng) -> None:
    """:func:`rotation_vector` against ``mju_mat2Quat`` then ``mju_quat2Vel`` (dt = 1): random rotations, rotations
    near the identity (a planted foot's) and half turns' neighbours (each branch of the quaternion's extraction)."""
    for i in range(400):
        q = rng.normal(size=4)
        if i % 4 == 1:
            q = np.array([1.0, 0.0, 0.0, 0.0]) + 1e-4 * rng.normal(size=4)
        if i % 4 == 2:
            q = np.array([1e-3, *rng.normal(size=3)])
        q /= np.linalg.norm(q)
        E = np.zeros(9)
        mujoco.mju_quat2Mat(E, q)
        quat, want = np.empty(4), np.empty(3)
        mujoco.mju_mat2Quat(quat, E)
        mujoco.mju_quat2Vel(want, quat, 1.0)
        np.testing.assert_allclose(rotation_vector(E.reshape(3, 3)), want, atol=1e-10)


def test_the_compiled_feet_are_numpys_to_rounding(scene, rng) -> None:
    """Each foot's task (J exactly, b within 1e-12 relative), and the flat contacts (points, frames, feet) and hard rows
    of :func:`flat_contacts`, toward anchors moved and turned away from the feet, with both feet flat and with one
    foot's sole above the gap (its live contacts gone: not flat, no rows)."""
    m = scene.model
    feet = FeetOnFloor(scene, 0.01)
    va = np.asarray(scene.robot_vadr)
    cf = CompiledFeet(m, feet.bodies, feet.corners, va, 0.01, 400.0, 40.0)
    scratch = (np.zeros((6, m.nv)), np.zeros((6, m.nv)))
    flats = set()
    for case in range(8):
        d = _standing(scene, rng)
        pts, frames, which = feet.contacts(d)
        if case % 2:  # the right foot's contacts gone and its sole 3 cm up
            keep = which == 0
            pts, frames, which = pts[keep], frames[keep], which[keep]
            d.xpos[feet.bodies[1], 2] += 0.03
        anchor = [(d.xpos[b] + rng.normal(scale=0.01, size=3),
                   flat_attitude(d.xmat[b].reshape(3, 3), feet.home_rot[s], feet.forward[s]))
                  for s, b in enumerate(feet.bodies)]
        tasks, p2, f2, w2, eq = cf(m, d, anchor, pts, frames, which)
        ref = [foot_feedback(m, d, b, va, p, r, 400.0, 40.0, scratch[0]) for b, (p, r) in zip(feet.bodies, anchor,
                                                                                                strict=True)]
        for (J, b), (J0, b0) in zip(tasks, ref, strict=True):
            np.testing.assert_array_equal(J, J0)
            np.testing.assert_allclose(b, b0, rtol=1e-12, atol=1e-12)
        P, F, W, E = flat_contacts(m, d, feet.bodies, feet.corners, anchor, va, pts, frames, which, 0.01, 400.0, 40.0,
                                   scratch, ref, None)
        np.testing.assert_array_equal(w2, W)
        np.testing.assert_array_equal(f2, F)
        np.testing.assert_allclose(p2, P, atol=1e-12)
        np.testing.assert_array_equal(eq[0], E[0])
        np.testing.assert_allclose(eq[1], E[1], rtol=1e-12, atol=1e-12)
        flats.add(len(E[1]) // 6)
    assert flats == {1, 2}


def test_the_damped_step_is_the_damped_least_squares_minimiser(rng) -> None:
    """Jᵀ (J Jᵀ + λ² I)⁻¹ e on three rows and on the first two, against least squares on the stacked system
    [J; λ I] x = [e; 0] (an independent reference), for each right-hand side."""
    for k in (3, 5, 7):
        jac = rng.normal(size=(3, 12))
        dofs = np.sort(rng.choice(12, size=k, replace=False)).astype(np.int64)
        lam = 0.05
        for rows in (3, 2):
            J = jac[:rows][:, dofs]
            es = [rng.normal(scale=0.1, size=rows) for _ in range(2)]
            got = damped_step(jac[:rows] if rows == 3 else jac, dofs, lam, *es)
            for e, g in zip(es, got, strict=True):
                ref = np.linalg.lstsq(np.vstack([J, lam * np.eye(k)]), np.concatenate([e, np.zeros(k)]), rcond=None)[0]
                np.testing.assert_allclose(g, ref, atol=1e-10)


def test_the_compiled_give_is_numpys(scene, rng) -> None:
    """:meth:`HandYield.update` compiled against NumPy's from the same states: pushes beyond and within the
    allowance, none (the offsets return), with and without the twist bound; the arms gave way in some and not all."""
    gave = set()
    for twist in (None, 0.02):
        a, b = (HandYield(scene, 0.5, 50.0, 0.5, 0.0, twist, kernel=k) for k in ("numpy", "numba"))
        assert b._compiled and not a._compiled
        box = SupportBox(np.array([[-0.1, -0.15], [0.1, -0.15], [-0.1, 0.15], [0.1, 0.15]]), np.array([0.8, 0.6]))
        for i in range(40):
            force = rng.normal(scale=60.0, size=(2, 3)) * (i % 4 != 0)
            offset = rng.normal(scale=0.05, size=(2, 2))
            for h in (a, b):
                h.force, h.offset, h._height, h._at = force.copy(), offset.copy(), 1.0, rng.normal(scale=0.1, size=2)
            b._at = a._at.copy()
            steps = a.yield_steps
            for h in (a, b):
                h.update(0.004, box, np.array([0.01, 0.02]), 0.0, 0.01, 300.0)
            assert a.yield_steps == b.yield_steps
            gave.add(a.yield_steps > steps)
            np.testing.assert_allclose(b.offset, a.offset, atol=1e-13)
            np.testing.assert_allclose(b.rate, a.rate, atol=1e-12)
    assert gave == {True, False}


def test_the_compiled_share_is_fade_times_the_gate(rng) -> None:
    """:func:`compensation_share` against c · :func:`fade`, and times :func:`approach_gate` when gated (wrists near
    and far from the targets, an arm touched, no targets at all: none)."""
    for i in range(60):
        force = rng.normal(scale=15.0, size=(2, 3))
        wrists, targets = rng.normal(scale=0.5, size=(2, 3)), rng.normal(scale=0.5, size=(int(rng.integers(0, 4)), 3))
        touched = rng.random(2) < 0.3
        radius = float(rng.uniform(0.1, 0.8))
        want = 0.8 * fade(force, 20.0)
        np.testing.assert_allclose(compensation_share(force, 20.0, 0.8, False, wrists, targets, touched, radius), want,
                                   atol=1e-15)
        np.testing.assert_allclose(compensation_share(force, 20.0, 0.8, True, wrists, targets, touched, radius),
                                   want * approach_gate(wrists, targets, touched, radius), atol=1e-15)


def test_the_compiled_clearance_rows_are_numpys(scene, rng) -> None:
    """Rows, bounds and the distances kept against :meth:`SelfClearance.rows` at states with the arms folded in toward
    the body (pairs within the detection distance), and none within a detection distance of 0.1 mm."""
    m = scene.model
    a = SelfClearance.of_scene(scene, 0.01, 0.1, 30.0)
    b = SelfClearance.of_scene(scene, 0.01, 0.1, 30.0)
    cc = CompiledClearance(m, b)
    comp = ArmCompensation(scene, 1.0, 20.0, 0.0)
    rows_seen = []
    for case in range(10):
        d = _standing(scene, rng)
        if case:  # the arms' hinges swung toward the body
            for s in (0, 1):
                d.qpos[scene.robot_qadr[comp._cols[s] + 1]] += rng.normal(scale=0.8, size=len(comp._cols[s]))
            mujoco.mj_forward(m, d)
        want, got = a.rows(m, d), cc.rows(m, d)
        assert (want is None) == (got is None)
        np.testing.assert_array_equal(b.last_distance, a.last_distance)
        if want is not None:
            np.testing.assert_allclose(got[0], want[0], atol=1e-12)
            np.testing.assert_allclose(got[1], want[1], rtol=1e-12, atol=1e-10)
        rows_seen.append(0 if want is None else len(want[1]))
    assert len(set(rows_seen)) > 1  # pairs came and went
    tight = SelfClearance.of_scene(scene, 0.01, 1e-4, 30.0)  # a detection distance nothing is within at home: none
    d = _standing(scene, rng)
    assert tight.rows(m, d) is None and CompiledClearance(m, tight).rows(m, d) is None


def test_the_controller_holds_the_compiled_pieces_only_with_numba(scene) -> None:
    """``qp_kernel="numba"``: the support, the feet (with ``flat_feet``), the clearance rows, the arms' steps compiled;
    ``"numpy"``: none of them; without ``flat_feet`` no compiled feet."""
    base = dict(solver="qp", flat_feet=True, self_clearance=0.01, hand_yield=0.5, arm_compensation=1.0)
    ctl = BalanceController(scene, BalanceConfig(**base, qp_kernel="numba"))
    k = ctl._kernel
    assert k.support is not None and k.flat is not None and isinstance(k.clearance_rows.__self__, CompiledClearance)
    assert ctl.hand_yield._compiled and ctl.compensation._compiled
    ref = BalanceController(scene, BalanceConfig(**base))
    assert ref._kernel is None and not ref.hand_yield._compiled and not ref.compensation._compiled
    bare = BalanceController(scene, BalanceConfig(**{**base, "flat_feet": False, "self_clearance": None},
                                                  qp_kernel="numba"))
    assert bare._kernel.flat is None and bare._kernel.clearance_rows is None and bare._kernel.support is not None
