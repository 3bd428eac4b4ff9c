"""``BalanceConfig.shear_spread``: a cost on the balance QP's planned horizontal contact forces about their mean, the
feet's opposed shears (docs/design.md §5, issue 25, session 35, wip/pullslip2)."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim import balance_control
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.contact_dynamics import cone_edges
from socialaff_sim.sim.contact_qp import solve_contact_qp
from socialaff_sim.sim.scene import Scene
from socialaff_sim.sim.shear_spread import shear_spread, shear_spread_cost
from socialaff_sim.sim.simulator import SimConfig

from test_balance_control import standing_far
from test_balance_qp_rows import _random_qp


def _random_edges(rng: np.random.Generator, P: int, mu: float = 0.7) -> np.ndarray:
    frames = np.stack([np.linalg.qr(rng.normal(size=(3, 3)))[0].T for _ in range(P)])  # any orthonormal frames
    return cone_edges(frames, mu)


def test_the_cost_is_the_spread_of_the_horizontal_forces(rng) -> None:
    # ½ β'ᵀWβ' against Σ_p ‖t_p − t̄‖² of the forces E_p β_p summed point by point (the reference), for frames in any
    # orientation and any weights: the quadratic form is the spread times w_s, to rounding.
    for P in (2, 3, 8):
        edges = _random_edges(rng, P)
        for w in (1.0, 37.5):
            W = shear_spread_cost(edges, w)
            np.testing.assert_allclose(W, W.T, atol=1e-12)
            assert np.linalg.eigvalsh(W).min() > -1e-9  # a sum of squares
            for _ in range(4):
                beta = rng.uniform(0.0, 3.0, 4 * P)
                forces = np.einsum("pik,pk->pi", edges, beta.reshape(P, 4))
                ref = sum(float(np.sum((forces[p, :2] - forces[:, :2].mean(axis=0)) ** 2)) for p in range(P))
                assert beta @ W @ beta == pytest.approx(w * ref, rel=1e-10, abs=1e-12)
                assert shear_spread(forces) == pytest.approx(ref, rel=1e-12, abs=1e-12)


def test_the_net_costs_nothing_and_the_split_does(rng) -> None:
    # On a level floor: every point carrying the same horizontal force (only the net) is in W's null space; the two
    # feet pushed sideways against each other (equal and opposite) is not. Swapping the cost's sign or its mean
    # (each point's force alone) fails one of the two.
    P = 8
    frames = np.tile(np.eye(3)[[2, 0, 1]], (P, 1, 1))  # normal z, tangents x and y
    edges = cone_edges(frames, 0.7)
    W = shear_spread_cost(edges, 1.0)
    # the +x edge (k = 0) against the −x edge (k = 1): β = (a + s, a − s, a, a) gives t = (2 s μ / √(1 + μ²), 0)
    same = np.tile([1.2, 0.8, 1.0, 1.0], P)
    assert same @ W @ same == pytest.approx(0.0, abs=1e-12)
    split = np.concatenate([np.tile([1.2, 0.8, 1.0, 1.0], 4), np.tile([0.8, 1.2, 1.0, 1.0], 4)])
    forces = np.einsum("pik,pk->pi", edges, split.reshape(P, 4))
    assert split @ W @ split == pytest.approx(shear_spread(forces)) and shear_spread(forces) > 0.01
    assert not shear_spread_cost(edges[:1], 1.0).any()  # one point: no spread


def test_shear_spread_is_off_by_default_and_checked() -> None:
    assert BalanceConfig().shear_spread is None
    assert SimConfig.standing().balance.shear_spread is None
    base = SimConfig.standing().balance
    dataclasses.replace(base, shear_spread=100.0)
    for bad in (0.0, -1.0):
        with pytest.raises(ConfigError, match="shear_spread"):
            dataclasses.replace(base, shear_spread=bad)
    with pytest.raises(ConfigError, match="shear_spread"):  # the least squares has no such cost
        dataclasses.replace(base, solver="lsq", shear_spread=100.0)
    assert BalanceConfig().shear_spread_touched is False and SimConfig.standing().balance.shear_spread_touched is False
    dataclasses.replace(base, shear_spread=30.0, shear_spread_touched=True)
    with pytest.raises(ConfigError, match="shear_spread_touched"):  # the gate without the cost
        dataclasses.replace(base, shear_spread_touched=True)
    with pytest.raises(ConfigError, match="shear_spread_touched"):  # nor without the touch latch
        dataclasses.replace(base, shear_spread=30.0, shear_spread_touched=True, arm_compensation=None,
                            compensation_gate=None, touch_friction=None, shear_couple_touched=False)


def test_the_qp_trades_the_spread_for_its_tasks(rng) -> None:
    # The same random problems solved with and without the cost: with it the planned forces' spread is smaller (the
    # cost is minimised, not ignored), and a heavier cost lowers it further; the root's rows hold in both. Adding the
    # cost with the wrong sign, or not at all, fails the comparison.
    lower = 0
    for _ in range(6):
        pr = _random_qp(rng)
        P = len(pr["edges"])
        spreads = []
        for w in (None, 1.0, 100.0):
            res = solve_contact_qp(**pr, force_cost=None if w is None else shear_spread_cost(pr["edges"], w))
            assert res.found
            np.testing.assert_allclose(res.tau[pr["unactuated"]], 0.0, atol=1e-6 * max(1.0, pr["mass"]))
            spreads.append(shear_spread(res.forces) if P > 1 else 0.0)
        assert spreads[1] <= spreads[0] * (1 + 1e-6) + 1e-9 and spreads[2] <= spreads[1] * (1 + 1e-6) + 1e-9
        lower += spreads[2] < spreads[0] * 0.9
    assert lower >= 3  # the cost bites on most problems, not only in the limit


def test_the_numba_assembly_adds_the_cost_as_numpy_does(rng) -> None:
    pytest.importorskip("numba", reason="qp_kernel=\"numba\" needs numba (the [fast] extra)")
    for _ in range(4):
        pr = _random_qp(rng)
        W = shear_spread_cost(pr["edges"], 50.0)
        a = solve_contact_qp(**pr, force_cost=W)
        b = solve_contact_qp(**pr, force_cost=W, kernel="numba")
        c = solve_contact_qp(**pr, kernel="numba")
        assert (a.found, a.relaxed) == (b.found, b.relaxed)
        for x, y in ((a.tau, b.tau), (a.qacc, b.qacc), (a.beta, b.beta)):
            np.testing.assert_allclose(y, x, rtol=1e-6, atol=1e-6 * max(1.0, np.abs(x).max()))
        assert not np.allclose(c.beta, b.beta, rtol=1e-4, atol=1e-4 * max(1.0, np.abs(b.beta).max())) or (
            shear_spread(c.forces) < 1e-9)  # the cost changes the numba solve too


def _solves(scene: Scene, config: BalanceConfig, monkeypatch, touch_after: int | None = None
            ) -> list[tuple[int, np.ndarray, np.ndarray | None]]:
    """Stubby standing under a controller of ``config``, the person far away, 100 physics steps (released after
    0.1 s: the QP solves); at step ``touch_after`` the arms' touch latch is set (the right arm touched). Each QP
    solve's (step, cone edges, ``force_cost``)."""
    seen: list[tuple[int, np.ndarray, np.ndarray | None]] = []
    real = balance_control.solve_contact_qp
    k = 0

    def spy(*a, **kw):
        seen.append((k, np.array(a[4]), kw.get("force_cost")))
        return real(*a, **kw)

    monkeypatch.setattr(balance_control, "solve_contact_qp", spy)
    d, q, ctl, ctrl0 = standing_far(scene, config)
    m = scene.model
    for k in range(100):
        if k == touch_after:
            ctl.compensation.touched[:] = [False, True]  # type: ignore[union-attr]
        if k % 25 == 0:
            ctl.begin_frame(q, (True, True))
        d.ctrl[scene.act_ids] = ctrl0
        ctl.step(m, d, q, np.zeros(len(scene.robot_vadr) - 6))
    assert isinstance(d, mujoco.MjData) and seen, "the QP never solved"
    return seen


@pytest.mark.parametrize("option", [None, 80.0])
def test_the_controller_passes_the_cost_only_with_the_option(scene: Scene, option: float | None, monkeypatch) -> None:
    # Stubby standing under the controller: with the option every QP solve gets the spread's cost of the very cones it
    # solves with (checked against shear_spread_cost of the passed edges, and by the brute-force spread on a probe
    # β); without it, none. Inverting the decision fails either run.
    seen = _solves(scene, dataclasses.replace(SimConfig.standing().balance, shear_spread=option, shear_couple=None,
                                              shear_couple_touched=False), monkeypatch)  # (the spread's cost alone)
    for _, edges, W in seen:
        if option is None:
            assert W is None
            continue
        assert W is not None and W.shape == (edges.size // 3, edges.size // 3)
        beta = np.linspace(0.1, 1.0, W.shape[0])
        forces = np.einsum("pik,pk->pi", edges, beta.reshape(len(edges), 4))
        assert 0.5 * beta @ W @ beta == pytest.approx(0.5 * option * shear_spread(forces), rel=1e-9)


@pytest.mark.parametrize("touched", [False, True])
def test_shear_spread_touched_waits_for_the_touch(scene: Scene, touched: bool, monkeypatch) -> None:
    # With shear_spread_touched the solves before the latch get no cost and those after it get it; without the gate
    # every solve gets it, touched or not. Inverting the gate (the cost before the touch, or none after it) fails.
    w = 30.0
    gated = dataclasses.replace(SimConfig.standing().balance, shear_spread=w, shear_spread_touched=True,
                                shear_couple=None, shear_couple_touched=False)  # (the spread's cost alone)
    seen = _solves(scene, gated, monkeypatch, touch_after=80 if touched else None)
    before = [W for k, _, W in seen if k < 80]
    after = [(e, W) for k, e, W in seen if k >= 80]
    assert before and after
    assert all(W is None for W in before)
    if not touched:
        assert all(W is None for _, W in after)
    else:
        for edges, W in after:
            assert W is not None
            np.testing.assert_allclose(W, shear_spread_cost(edges, w), rtol=0, atol=1e-12)
    ungated = _solves(scene, dataclasses.replace(gated, shear_spread_touched=False), monkeypatch)
    assert all(W is not None for _, _, W in ungated)
