"""The standing step's fourth pass of bit-for-bit cuts (issue 25, session 33): the QP's row order made once per
mask, its diagonal set through the flat index, the rows' scaling without copies when every row is kept, the cop
intervals' extents stacked when the feet have as many points, the box's clip, the arms' damping made once and
the feet's middle without NumPy's wrappers — each against the computation it replaces."""

from __future__ import annotations

import daqp
import numpy as np

from socialaff_sim.sim import contact_qp
from socialaff_sim.sim.arm_compensation import DAMPING_LAMBDA, compensation_step
from socialaff_sim.sim.com_reference import ComReference
from socialaff_sim.sim.contact_qp import _daqp, _rows_order, solve_contact_qp
from socialaff_sim.sim.support_box import SupportBox, _extents, cop_intervals
from test_balance_qp_rows import _random_qp


def test_the_rows_order_is_the_unactuated_rows_then_the_actuated_ones_made_once(rng) -> None:
    """``_rows_order``: the actuated mask, the unactuated rows ascending then the actuated ones ascending, their
    count; the second call with the same mask returns the very same read-only arrays."""
    for _ in range(5):
        unact = rng.random(12) < 0.4
        act, order, nu = _rows_order(unact.tobytes())
        np.testing.assert_array_equal(act, ~unact)
        assert order.tolist() == [i for i in range(12) if unact[i]] + [i for i in range(12) if not unact[i]]
        assert nu == int(unact.sum())
        again = _rows_order(unact.copy().tobytes())
        assert again[0] is act and again[1] is order
        assert not act.flags.writeable and not order.flags.writeable


def _daqp_before(H, f, K, A_all, up, lo, sn):
    """``_daqp`` as it was before the cut (every row copied, the bounds concatenated): the reference."""
    norm = np.sqrt(np.add.reduce(A_all * A_all, axis=1))
    keep = norm > 1e-9
    k = 1.0 / norm[keep]
    A = np.ascontiguousarray(A_all[keep] * k[:, None])
    u = np.where(up[keep] < contact_qp._INF, up[keep] * k, contact_qp._INF)
    lw = np.where(lo[keep] > -contact_qp._INF, lo[keep] * k, -contact_qp._INF)
    x, _, flag, _ = daqp.solve(H, f, A, np.concatenate([np.full(K, contact_qp._INF), u]),
                               np.concatenate([np.zeros(K), lw]), np.concatenate([np.zeros(K, dtype=np.intc), sn[keep]]))
    return np.asarray(x), int(flag)


def test_the_rows_scaling_solves_as_before_with_and_without_empty_rows(rng) -> None:
    """``_daqp`` bit for bit as the copying version, on problems with every row kept and on the same problems with
    empty rows among them (dropped: with them DAQP fails, so keeping them fails this test)."""
    for empty in (False, True):
        for _ in range(4):
            n, K, R = 8, 6, 7
            B = rng.normal(size=(n + K, n + K))
            H = np.ascontiguousarray(B @ B.T + np.eye(n + K))
            f = rng.normal(size=n + K)
            A = rng.normal(size=(R, n + K))
            up, lo = rng.uniform(1, 2, R), rng.uniform(-2, -1, R)
            sn = np.zeros(R, dtype=np.intc)
            if empty:
                A[[1, 4]] = 0.0
            x, flag = _daqp(H, f, K, A, up, lo, sn)
            x0, flag0 = _daqp_before(H, f, K, A, up, lo, sn)
            assert flag == flag0 == 1
            np.testing.assert_array_equal(x, x0)


def test_the_qps_diagonal_through_the_flat_index_is_the_fancy_index_bit_for_bit(rng, monkeypatch) -> None:
    """The whole solve with a diagonal task (the joints' rows) equals, bit for bit, the solve with the same task as
    full rows whose products are the diagonal's own (a diagonal A: AᵀA has A_i² on its diagonal, zeros off it),
    and its Hessian's diagonal holds w_f, then ε plus the task's w A_i²."""
    seen = []
    real = contact_qp._daqp
    monkeypatch.setattr(contact_qp, "_daqp", lambda H, *a: seen.append(H.copy()) or real(H, *a))
    for _ in range(3):
        pr = _random_qp(rng)
        n, K = pr["M"].shape[0], 4 * len(pr["edges"])
        a, b = rng.uniform(0.5, 2.0, n), rng.normal(size=n)
        seen.clear()
        diag = solve_contact_qp(**{**pr, "tasks": [*pr["tasks"], (a, b, 1.5)]})
        H = seen[0]
        np.testing.assert_array_equal(np.diag(H)[:K], np.full(K, pr["w_force"]))
        full = pr["tasks"][0][0]
        want = 1e-6 + 2.0 * np.diag(full.T @ full) + 1.5 * (a * a)
        np.testing.assert_allclose(np.diag(H)[K:], want, rtol=1e-12)
        rows = solve_contact_qp(**{**pr, "tasks": [*pr["tasks"], (np.diag(a), a * b / a, 1.5)]})
        np.testing.assert_allclose(rows.tau, diag.tau, rtol=1e-9, atol=1e-9)


def test_the_extents_stacked_are_the_extents_foot_by_foot(rng) -> None:
    """``_extents``: the minima and maxima along the first axis, foot by foot, with equal lengths (stacked) and
    unequal ones; ``cop_intervals`` of two feet with four points each equals its foot-by-foot reference."""
    for lengths in ((4, 4), (8, 8), (3, 5), (4,)):
        coords = [rng.normal(size=(k, 2)) for k in lengths]
        lo, hi = _extents(coords)
        np.testing.assert_array_equal(lo, np.array([c.min(axis=0) for c in coords]))
        np.testing.assert_array_equal(hi, np.array([c.max(axis=0) for c in coords]))
    ang = rng.uniform(-np.pi, np.pi)
    axes = np.array([[np.cos(ang), np.sin(ang)], [-np.sin(ang), np.cos(ang)]])
    soles = [rng.normal(size=(8, 2)) * 0.1 for _ in range(2)]
    pts = [rng.normal(size=(4, 2)) * 0.1 for _ in range(2)]
    got = cop_intervals(axes, soles, pts, 0.01)
    for f in range(2):
        s, p = soles[f] @ axes.T, pts[f] @ axes.T
        s_lo, s_hi = s.min(axis=0) + 0.01, s.max(axis=0) - 0.01
        mid = 0.5 * (s.min(axis=0) + s.max(axis=0))
        s_lo, s_hi = np.minimum(s_lo, mid), np.maximum(s_hi, mid)
        lo, hi = np.maximum(s_lo, p.min(axis=0)), np.minimum(s_hi, p.max(axis=0))
        near = np.clip(0.5 * (s_lo + s_hi), p.min(axis=0), p.max(axis=0))
        np.testing.assert_array_equal(got[f, :, 0], np.where(lo > hi, near, lo))
        np.testing.assert_array_equal(got[f, :, 1], np.where(lo > hi, near, hi))


def test_the_box_clip_is_numpys_clip_bit_for_bit(rng) -> None:
    """``SupportBox.clip``: np.clip of the point's box coordinates, back in the world, bit for bit (also for a
    margin wider than the box, where the interval is its middle)."""
    for margin in (0.0, 0.02, 0.5):
        for _ in range(50):
            ang = rng.uniform(-np.pi, np.pi)
            box = SupportBox(rng.normal(size=(8, 2)) * 0.2, np.array([np.cos(ang), np.sin(ang)]))
            p = rng.normal(size=2) * 0.3
            lo, hi = box.lo + margin, box.hi - margin
            mid = 0.5 * (box.lo + box.hi)
            lo, hi = np.minimum(lo, mid), np.maximum(hi, mid)
            np.testing.assert_array_equal(box.clip(p, margin), np.clip(box.R @ p, lo, hi) @ box.R)


def test_the_compensation_step_with_its_damping_made_once_is_the_formula_bit_for_bit(rng) -> None:
    """``compensation_step``: Jᵀ (J Jᵀ + λ² I)⁻¹ e with the default λ (its λ² I made once) and another λ (made per
    call), bit for bit as the formula written out; a larger λ moves less."""
    for _ in range(20):
        J, e = rng.normal(size=(3, 7)), rng.normal(size=3) * 0.1
        for lam in (DAMPING_LAMBDA, 0.2):
            want = J.T @ np.linalg.solve(J @ J.T + lam * lam * np.eye(3), e)
            np.testing.assert_array_equal(compensation_step(J, e, lam), want)
        assert np.linalg.norm(compensation_step(J, e, 0.5)) < np.linalg.norm(compensation_step(J, e))


def test_the_feet_middle_is_numpys_mean_bit_for_bit(rng) -> None:
    """``ComReference._middle``: the mean of the feet's horizontal positions as ``np.mean`` computes it."""
    class _D:
        xpos = rng.normal(size=(12, 3))
    ref = ComReference.__new__(ComReference)
    for feet in ([3, 7], [0, 11], [5, 5]):
        ref._feet = feet
        np.testing.assert_array_equal(ref._middle(_D), _D.xpos[feet, :2].mean(axis=0))
