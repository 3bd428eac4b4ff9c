"""``BalanceConfig.shear_couple``: a cost on the two feet's planned shear resultants' split across the line between
the feet (their couple about the vertical), ``shear_couple_form`` the whole split or the whole moment,
``shear_couple_touched`` after the first touch (docs/design.md §5, issue 25, session 35, wip/pullslip3)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.contact_dynamics import cone_edges
from socialaff_sim.sim.contact_qp import solve_contact_qp
from socialaff_sim.sim.scene import Scene
from socialaff_sim.sim.shear_spread import feet_shear_cost, shear_couple, shear_couple_cost, shear_spread_cost
from socialaff_sim.sim.simulator import SimConfig

from test_balance_qp_rows import _random_qp
from test_shear_spread import _random_edges, _solves


def _feet(rng: np.random.Generator, P: int) -> tuple[np.ndarray, np.ndarray]:
    """Each point's foot (both feet present) and its position: the feet's centroids apart along a random line."""
    which = rng.permutation(np.arange(P) % 2)
    line = rng.normal(size=2)
    pts = np.column_stack([rng.uniform(-0.05, 0.05, size=(P, 2)) + np.outer(which - 0.5, line), np.zeros(P)])
    return which, pts


def _brute(forces: np.ndarray, which: np.ndarray, pts: np.ndarray, form: str) -> float:
    """q² summed point by point (an independent reference: the couple as the moment of the feet's resultants about
    the centroids' midpoint over the line's length; the moment point by point with a cross product)."""
    T = [np.zeros(2), np.zeros(2)]
    c = [np.zeros(2), np.zeros(2)]
    for f, p, w in zip(forces, pts, which, strict=True):
        T[w] = T[w] + f[:2]
        c[w] = c[w] + p[:2] / np.count_nonzero(which == w)
    s = (T[1] - T[0]) / 2
    d = c[1] - c[0]
    mid = (c[0] + c[1]) / 2
    if form == "moment":
        return float(sum(np.cross(np.append(p[:2] - mid, 0.0), np.append(f[:2], 0.0))[2]
                         for p, f in zip(pts, forces, strict=True)) ** 2 / float(d @ d))
    if form == "split":
        return float(s[0] ** 2 + s[1] ** 2)
    moment = sum(float((ci - mid)[0] * Ti[1] - (ci - mid)[1] * Ti[0]) for ci, Ti in zip(c, T, strict=True))  # z
    return moment ** 2 / float(d @ d)


@pytest.mark.parametrize("form", ["couple", "split", "moment"])
def test_the_cost_is_the_feet_couple(rng, form: str) -> None:
    # ½ β'ᵀWβ' against the brute-force couple (or whole split) of the forces E_p β_p, frames in any orientation.
    for P in (2, 3, 8):
        edges = _random_edges(rng, P)
        which, pts = _feet(rng, P)
        for w in (1.0, 42.0):
            W = shear_couple_cost(edges, which, pts, w, form)
            np.testing.assert_allclose(W, W.T, atol=1e-12)
            assert np.linalg.eigvalsh(W).min() > -1e-9
            for _ in range(4):
                beta = rng.uniform(0.0, 3.0, 4 * P)
                forces = np.einsum("pik,pk->pi", edges, beta.reshape(P, 4))
                ref = _brute(forces, which, pts, form)
                assert beta @ W @ beta == pytest.approx(w * ref, rel=1e-9, abs=1e-12)
                assert shear_couple(forces, which, pts, form) == pytest.approx(ref, rel=1e-9, abs=1e-12)


def test_the_net_and_the_within_foot_spread_cost_nothing_the_couple_does(rng) -> None:
    # Level floor, feet along y (centroids at y = ∓0.1): each foot the same resultant (the net shared) and shear moved
    # between the points of one foot (its resultant kept) are in W's null space; the feet's opposed x shears (a turn
    # about the vertical) are not; the squeeze (opposed y shears, along the line) costs only in the "split" form.
    P = 8
    edges = cone_edges(np.tile(np.eye(3)[[2, 0, 1]], (P, 1, 1)), 0.7)
    which = np.repeat([0, 1], 4)
    pts = np.column_stack([np.tile([-0.05, -0.02, 0.03, 0.04], 2), np.where(which == 1, 0.1, -0.1), np.zeros(P)])
    W, Wsq, Wm = (shear_couple_cost(edges, which, pts, 1.0, f) for f in ("couple", "split", "moment"))
    px, mx, py, my = np.array([1.2, 0.8, 1.0, 1.0]), np.array([0.8, 1.2, 1.0, 1.0]), np.array(
        [1.0, 1.0, 1.2, 0.8]), np.array([1.0, 1.0, 0.8, 1.2])
    net = np.tile(px, P)
    within = np.concatenate([px, mx, px, mx, np.tile(py, 2), np.tile(my, 2)])  # each foot's resultant zero
    turn = np.concatenate([np.tile(px, 4), np.tile(mx, 4)])
    squeeze = np.concatenate([np.tile(py, 4), np.tile(my, 4)])
    for beta in (net, within):
        assert beta @ W @ beta == pytest.approx(0.0, abs=1e-12) and beta @ Wsq @ beta == pytest.approx(0.0, abs=1e-12)
    assert net @ Wm @ net == pytest.approx(0.0, abs=1e-12)
    assert within @ Wm @ within > 1e-4  # the moment form charges a sole's own torsion
    assert turn @ W @ turn > 0.01 and turn @ Wsq @ turn == pytest.approx(turn @ W @ turn)
    assert turn @ Wm @ turn > 0.01
    assert squeeze @ W @ squeeze == pytest.approx(0.0, abs=1e-12) and squeeze @ Wsq @ squeeze > 0.01
    # the spread's cost (shear_spread) charges the within-foot spread that this one leaves free
    assert within @ shear_spread_cost(edges, 1.0) @ within > 0.01
    assert not shear_couple_cost(edges, np.zeros(P, dtype=int), pts, 1.0).any()  # one foot: no couple


def test_feet_shear_cost_adds_what_is_on() -> None:
    rng = np.random.default_rng(3)
    edges = _random_edges(rng, 4)
    which, pts = _feet(rng, 4)
    S = shear_spread_cost(edges, 2.0)
    C = shear_couple_cost(edges, which, pts, 5.0)
    assert feet_shear_cost(None, True, None, True, "couple", edges, which, pts) is None
    assert feet_shear_cost(S, False, 5.0, False, "couple", edges, which, pts) is None
    assert feet_shear_cost(S, True, 5.0, False, "couple", edges, which, pts) is S
    np.testing.assert_allclose(feet_shear_cost(None, True, 5.0, True, "couple", edges, which, pts), C)
    np.testing.assert_allclose(feet_shear_cost(S, True, 5.0, True, "couple", edges, which, pts), S + C)


def test_shear_couple_is_off_by_default_and_checked() -> None:
    base = SimConfig.standing().balance
    c = BalanceConfig()
    assert (c.shear_couple, c.shear_couple_touched, c.shear_couple_form) == (None, False, "couple")
    # the standing mode's since rule #53 (session 35; pinned in tests/test_physics_mode.py)
    assert (base.shear_couple, base.shear_couple_touched, base.shear_couple_form) == (300.0, True, "moment")
    dataclasses.replace(base, shear_couple=50.0, shear_couple_form="moment", shear_couple_touched=True)
    with pytest.raises(ConfigError, match="shear_couple_form"):
        dataclasses.replace(base, shear_couple=50.0, shear_couple_form="torsion")
    for bad in (0.0, -1.0):
        with pytest.raises(ConfigError, match="shear_couple"):
            dataclasses.replace(base, shear_couple=bad)
    with pytest.raises(ConfigError, match="shear_couple"):
        dataclasses.replace(base, solver="lsq", shear_couple=50.0)
    with pytest.raises(ConfigError, match="shear_couple_touched"):
        dataclasses.replace(base, shear_couple=None, shear_couple_touched=True)
    with pytest.raises(ConfigError, match="shear_couple_touched"):
        dataclasses.replace(base, shear_couple=50.0, shear_couple_touched=True, arm_compensation=None,
                            compensation_gate=None, touch_friction=None, shear_spread=None)


@pytest.mark.parametrize("kernel", ["numpy", "numba"])
def test_the_qp_trades_the_couple_for_its_tasks(rng, kernel: str) -> None:
    # Random problems solved without and with the cost (both assemblies): the planned couple falls as w_c rises and
    # the root's rows hold; the numba solve agrees with numpy's. The cost's sign inverted fails the comparison.
    if kernel == "numba":
        pytest.importorskip("numba", reason="qp_kernel=\"numba\" needs numba (the [fast] extra)")
    lower = 0
    for _ in range(6):
        pr = _random_qp(rng, unbounded=False)
        P = len(pr["edges"])
        which, pts = np.array([0, 1] * (P // 2)), np.column_stack([rng.normal(size=(P, 2)) * 0.05, np.zeros(P)])
        pts[:, 1] += np.where(which == 1, 0.1, -0.1)
        couples = []
        for w in (None, 1.0, 100.0):
            W = None if w is None else shear_couple_cost(pr["edges"], which, pts, w)
            res = solve_contact_qp(**pr, force_cost=W, kernel=kernel)
            assert res.found
            np.testing.assert_allclose(res.tau[pr["unactuated"]], 0.0, atol=1e-6 * max(1.0, pr["mass"]))
            if kernel == "numba":
                ref = solve_contact_qp(**pr, force_cost=W)
                np.testing.assert_allclose(res.beta, ref.beta, rtol=1e-6, atol=1e-6 * max(1.0, np.abs(ref.beta).max()))
            couples.append(shear_couple(res.forces, which, pts))
        assert couples[1] <= couples[0] * (1 + 1e-6) + 1e-9 and couples[2] <= couples[1] * (1 + 1e-6) + 1e-9
        lower += couples[2] < couples[0] * 0.9
    assert lower >= 3


@pytest.mark.parametrize("touched", [False, True])
def test_the_controller_passes_the_couple_with_the_option_and_its_gate(scene: Scene, touched: bool,
                                                                       monkeypatch) -> None:
    # Stubby standing: without the option no cost; ungated every solve gets a cost whose form is the couple of the
    # solve's cones (a probe β across the feet against the brute-force couple needs the points: the cost's rank is
    # one and the net shared by the feet costs nothing); gated, none before the latch and one after it.
    off = dataclasses.replace(SimConfig.standing().balance, shear_couple=None, shear_couple_touched=False,
                              shear_couple_form="couple")  # (the standing mode's is on since rule #53)
    plain = _solves(scene, off, monkeypatch)
    assert all(W is None for _, _, W in plain)
    on = dataclasses.replace(off, shear_couple=60.0)
    for _, edges, W in _solves(scene, on, monkeypatch):
        assert W is not None and W.shape == (edges.size // 3, edges.size // 3)
        assert np.linalg.matrix_rank(W, tol=1e-9 * max(1.0, np.abs(W).max())) <= 1
        same = np.tile([1.2, 0.8, 1.0, 1.0], len(edges))  # every point the same shear on level cones
        if np.allclose(edges[:, 2, :], edges[0, 2, :]):
            assert abs(same @ W @ same) < 1e-9 * max(1.0, np.abs(W).max())
    gated = dataclasses.replace(on, shear_couple_touched=True)
    seen = _solves(scene, gated, monkeypatch, touch_after=80 if touched else None)
    before = [W for k, _, W in seen if k < 80]
    after = [W for k, _, W in seen if k >= 80]
    assert before and after and all(W is None for W in before)
    assert all((W is not None) == touched for W in after)
