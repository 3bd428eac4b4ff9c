"""``BalanceConfig.qp_kernel = "numba"``: the balance QP's cost and rows assembled in one compiled loop
(:mod:`socialaff_sim.sim.qp_kernel`) against the NumPy assembly (the reference), and the solve through it."""

from __future__ import annotations

import numpy as np
import pytest

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim import contact_qp
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.contact_qp import _numpy_rows, _rows_order, solve_contact_qp
from socialaff_sim.sim.qp_kernel import compiled_rows
from test_balance_qp_rows import _random_qp

pytest.importorskip("numba", reason="qp_kernel=\"numba\" needs numba (the [fast] extra)")


def _rows_args(pr: dict, diag: tuple | None = None) -> tuple:
    """The arguments both assemblies take, from a :func:`_random_qp` problem (with a diagonal task ``diag``)."""
    _, order, nu = _rows_order(pr["unactuated"].tobytes())
    foot = pr["foot"]
    loaded = np.flatnonzero(np.bincount(foot[foot >= 0], minlength=1))
    tasks = pr["tasks"] + ([] if diag is None else [diag])
    return (pr["M"], pr["h"], order, nu, pr["point_jac"], pr["edges"], tasks, pr["w_force"], 1e-6, pr["mass"],
            pr["tau_limits"], pr["inequalities"], pr["equalities"], loaded, foot, pr["min_load"], pr["cop"])


def test_the_compiled_assembly_is_numpys_to_rounding(rng) -> None:
    """H, f, G, the rows, their bounds and senses of :func:`compiled_rows` against the NumPy assembly (an independent
    evaluation of the same sums): equal to 1e-12 relative, the senses and infinite bounds exactly."""
    for _ in range(6):
        pr = _random_qp(rng)
        n = pr["M"].shape[0]
        args = _rows_args(pr, (rng.uniform(0.5, 2, n), rng.normal(size=n), 1.5))
        R = n + 2 + 2 + 2 + len(pr["cop"])
        want = _numpy_rows(*args, R)
        got = compiled_rows(*args)
        for w, g in zip(want[:4], got[:4], strict=True):
            np.testing.assert_allclose(g, w, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(w).max()))
        for w, g in zip(want[4:6], got[4:6], strict=True):
            np.testing.assert_array_equal(np.abs(g) >= 1e30, np.abs(w) >= 1e30)
            np.testing.assert_allclose(g, w, rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(got[6], want[6])
        assert got[7] is not None  # every row non-empty: solved on the compiled scaling, as DAQP on NumPy's
        x0, flag0 = contact_qp._daqp(want[0], want[1], 4 * len(pr["edges"]), *want[3:])
        assert got[7][1] == flag0
        if flag0 > 0:
            np.testing.assert_allclose(got[7][0], x0, rtol=1e-6, atol=1e-6 * max(1.0, np.abs(x0).max()))


def test_the_solve_through_the_kernel_is_the_numpy_solve_to_the_solvers_tolerance(rng) -> None:
    """The torques, accelerations and forces of ``kernel="numba"`` against ``kernel="numpy"`` (1e-6 relative), the
    flags alike, also for a problem with an empty row (the NumPy scaling drops it) and one relaxed."""
    for case in range(8):
        pr = _random_qp(rng)
        if case == 6:  # an empty hard row: the compiled scaling declines, the NumPy one drops it
            pr["equalities"] = (np.vstack([pr["equalities"][0], np.zeros(pr["M"].shape[0])]),
                                np.append(pr["equalities"][1], 0.0))
        if case == 7:  # hard rows that cannot hold together: relaxed
            A = pr["equalities"][0][:1]
            pr["equalities"] = (np.vstack([A, A]), np.array([1.0, -1.0]))
        a, b = solve_contact_qp(**pr), solve_contact_qp(**pr, kernel="numba")
        assert (a.found, a.relaxed, a.inequalities_dropped) == (b.found, b.relaxed, b.inequalities_dropped)
        for x, y in ((a.tau, b.tau), (a.qacc, b.qacc), (a.beta, b.beta)):
            np.testing.assert_allclose(y, x, rtol=1e-6, atol=1e-6 * max(1.0, np.abs(x).max()))
        assert case != 7 or b.relaxed


def test_the_kernel_setting_picks_the_assembly(rng, monkeypatch) -> None:
    """``kernel="numba"`` assembles through :func:`compiled_rows` only, ``"numpy"`` through the NumPy rows only."""
    calls = {"numba": 0, "numpy": 0}
    real_c, real_n = contact_qp.compiled_rows, contact_qp._numpy_rows

    def spy_c(*a):
        calls["numba"] += 1
        return real_c(*a)

    def spy_n(*a):
        calls["numpy"] += 1
        return real_n(*a)

    monkeypatch.setattr(contact_qp, "compiled_rows", spy_c)
    monkeypatch.setattr(contact_qp, "_numpy_rows", spy_n)
    pr = _random_qp(rng)
    solve_contact_qp(**pr)
    assert calls == {"numba": 0, "numpy": 1}
    solve_contact_qp(**pr, kernel="numba")
    assert calls == {"numba": 1, "numpy": 1}


def test_the_setting_is_checked() -> None:
    """Unknown kernels, and the compiled one without the QP, are refused; the default is NumPy."""
    assert BalanceConfig().qp_kernel == "numpy"
    BalanceConfig(solver="qp", qp_kernel="numba")
    with pytest.raises(ConfigError):
        BalanceConfig(solver="qp", qp_kernel="cuda")
    with pytest.raises(ConfigError):
        BalanceConfig(solver="lsq", qp_kernel="numba")


def test_the_controller_makes_the_kernel_when_made_and_solves_through_it(scene) -> None:
    """A controller with ``qp_kernel="numba"`` holds the compiled kernel from its construction (the JIT is not paid
    at the first driven step) and its QP's torques at a standing state are the NumPy controller's to the solver's
    tolerance; with ``"numpy"`` it holds none."""
    import mujoco

    from socialaff_sim.sim.balance_control import BalanceController

    cfgs = {k: BalanceConfig(solver="qp", flat_feet=True, qp_kernel=k) for k in ("numpy", "numba")}
    ctls = {k: BalanceController(scene, c) for k, c in cfgs.items()}
    assert ctls["numpy"]._kernel is None and ctls["numba"]._kernel is not None
    m = scene.model
    taus = {}
    for k, ctl in ctls.items():
        d = mujoco.MjData(m)
        d.qpos[scene.robot_qadr] = scene.home_qpos
        d.qpos[scene.robot_qadr[2]] -= 0.001  # pressed 1 mm into the floor: both feet in contact
        mujoco.mj_forward(m, d)
        ctl.begin_frame(np.asarray(scene.home_qpos), (True, True))
        ctl.harness.released = True  # (as if let go: the controller drives)
        ctl.step(m, d, np.asarray(scene.home_qpos), np.zeros(len(ctl.vadr) - 6))
        assert ctl.active
        taus[k] = d.ctrl[scene.act_ids].copy()
    np.testing.assert_allclose(taus["numba"], taus["numpy"], rtol=1e-6, atol=1e-6)
