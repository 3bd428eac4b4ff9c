"""The ankles' reach (:mod:`socialaff_sim.sim.ankle_reach`, ``BalanceConfig.release_reach``): the interval
against a linear programme (scipy), the hinges' moments against MuJoCo's own generalized forces, and the
harness's release decision both ways."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from scipy.optimize import linprog

from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.ankle_reach import AnkleReach, moment_range, reach_interval, wanted_cop
from socialaff_sim.sim.balance_config import BalanceConfig

from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.scene import Scene, build_scene

from test_balance_control import _stand


@pytest.fixture(scope="module")
def stubby() -> Scene:
    return build_scene(load_robot("ours"), get_layout("kinect_v2"), harness_time_constant=0.02)


def _lp(weight: float, ankle: np.ndarray, sole: np.ndarray, moment: np.ndarray, mu: float) -> np.ndarray:
    """[c_lo, c_hi] by scipy's linprog over (F_1, F_2, x_1, x_2)."""
    out = []
    for sign in (-1.0, 1.0):
        a_ub, b_ub = [], []
        for i in (0, 1):
            e = np.zeros(4)
            e[2 + i] = 1.0
            if np.isfinite(moment[i, 1]):
                a_ub.append(e)
                b_ub.append(moment[i, 1])
            if np.isfinite(moment[i, 0]):
                a_ub.append(-e)
                b_ub.append(-moment[i, 0])
            r = e.copy()
            r[i] = -(sole[i, 1] - ankle[i])  # x_i ≤ F_i (s_hi − a)
            a_ub.append(r)
            b_ub.append(0.0)
            r = -e
            r[i] = sole[i, 0] - ankle[i]  # x_i ≥ F_i (s_lo − a)
            a_ub.append(r)
            b_ub.append(0.0)
        c = -sign * np.array([ankle[0], ankle[1], 1.0, 1.0])
        res = linprog(c, A_ub=a_ub, b_ub=b_ub, A_eq=[[1.0, 1.0, 0.0, 0.0]], b_eq=[weight],
                      bounds=[(mu * weight, (1 - mu) * weight)] * 2 + [(None, None)] * 2)
        assert res.status == 0
        out.append(-sign * res.fun / weight)
    return np.array(out)


def test_reach_interval_is_the_linear_programmes_optimum(rng: np.random.Generator) -> None:
    for k in range(200):
        weight = rng.uniform(100.0, 1000.0)
        ankle = rng.uniform(-0.3, 0.3, 2)
        sole = np.stack([ankle - rng.uniform(0.0, 0.2, 2), ankle + rng.uniform(0.0, 0.3, 2)], axis=1)
        moment = np.stack([-rng.uniform(0.0, 100.0, 2), rng.uniform(0.0, 100.0, 2)], axis=1)
        if k % 5 == 0:
            moment[rng.integers(2)] = [-np.inf, np.inf]  # a foot without an ankle of its own
        mu = float(rng.choice([0.0, 0.05, 0.2]))
        np.testing.assert_allclose(reach_interval(weight, ankle, sole, moment, mu),
                                   _lp(weight, ankle, sole, moment, mu), atol=1e-9)


def test_reach_of_two_equal_feet_by_hand() -> None:
    # 500 N on two feet side by side, ankles at 0, soles from −0.1 to +0.2 m, 40 N·m each: ahead the ankles bind
    # (80 / 500 = 0.16 m), behind the heels do (−0.1 m).
    r = reach_interval(500.0, np.zeros(2), np.array([[-0.1, 0.2]] * 2), np.array([[-40.0, 40.0]] * 2))
    np.testing.assert_allclose(r, [-0.1, 0.16])


FOOT = """
<mujoco>
  <option gravity="0 0 0"/>
  <worldbody>
    <body name="foot" pos="0.3 0.1 0.05">
      <joint name="ankle" type="hinge" axis="{axis}"/>
      <geom type="box" size="0.1 0.03 0.02" mass="1"/>
    </body>
  </worldbody>
  <actuator><motor joint="ankle" ctrlrange="-1 1" ctrllimited="false" forcerange="{lo} {hi}" forcelimited="true"/></actuator>
</mujoco>
"""


@pytest.mark.parametrize("axis", ["0 1 0", "0 -1 0", "0.3 1 0.2", "1 0 0"])
def test_moment_range_is_what_the_hinge_must_exert_by_mujocos_generalized_forces(axis: str) -> None:
    lo, hi = -10.0, 40.0
    m = mujoco.MjModel.from_xml_string(FOOT.format(axis=axis, lo=lo, hi=hi))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    u = np.array([1.0, 0.0, 0.0])
    lateral = np.cross([0.0, 0.0, 1.0], u)
    rng_m = moment_range(d.xaxis[:1], np.array([[lo, hi]]), lateral)
    for fd in np.linspace(-12.0, 12.0, 49):  # F·d, N·m: 100 N at d = fd / 100 ahead of the ankle
        qfrc = np.zeros(m.nv)
        point = d.xanchor[0] + fd / 100.0 * u
        mujoco.mj_applyFT(m, d, np.array([0.0, 0.0, 100.0]), np.zeros(3), point, 1, qfrc)
        tau = -qfrc[0]  # the hinge holds the foot still against the floor's force
        assert (lo - 1e-9 <= tau <= hi + 1e-9) == (rng_m[0] - 1e-9 <= fd <= rng_m[1] + 1e-9), (axis, fd, tau, rng_m)
    if axis == "1 0 0":
        assert np.all(np.isinf(rng_m))  # a hinge along the heading carries no fore-aft moment


def test_ankle_reach_of_a_model_uses_its_servos_limits_and_kappa() -> None:
    m = mujoco.MjModel.from_xml_string(FOOT.format(axis="0 1 0", lo=-40, hi=40))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    reach = AnkleReach(m, [1, 1], np.array([0]), 1.0)  # the one foot twice: two ankles at x = 0.3
    soles = np.array([[0.2, 0.5]] * 2)
    np.testing.assert_allclose(reach.interval(m, d, np.array([1.0, 0.0]), soles, 500.0, 0.0), [0.2, 0.46])
    half = AnkleReach(m, [1, 1], np.array([0]), 0.5)
    np.testing.assert_allclose(half.interval(m, d, np.array([1.0, 0.0]), soles, 500.0, 0.0), [0.22, 0.38])


def test_the_harness_waits_while_the_centre_of_mass_is_beyond_the_ankles_reach(stubby: Scene) -> None:
    # Stubby standing at home: with the whole of its ankles' torque its centre of mass is within reach and the
    # harness lets go as without the gate; with a sliver of it (κ = 0.002) the reach shrinks onto the ankles'
    # line, which the centre of mass is not on, and the harness stays on.
    base, _, _ = _stand(stubby, BalanceConfig(release_delay=0.1), 0.4)
    full, _, _ = _stand(stubby, BalanceConfig(release_delay=0.1, release_reach=1.0), 0.4)
    tiny, _, trace = _stand(stubby, BalanceConfig(release_delay=0.1, release_reach=0.002), 0.4)
    assert base.released_steps > 0 and full.released_steps == base.released_steps and full.reach.withheld == 0
    assert tiny.released_steps == 0 and tiny.reach.withheld > 0 and all(on == 1 for _, on in trace)


def test_release_reach_is_checked() -> None:
    for bad in (0.0, 1.5, -0.2):
        with pytest.raises(ConfigError, match="release_reach"):
            BalanceConfig(release_reach=bad)


def test_wanted_cop_gives_the_wanted_acceleration_on_the_pendulum(rng: np.random.Generator) -> None:
    for _ in range(20):
        c, v, goal = rng.normal(size=2), rng.normal(size=2), rng.normal(size=2)
        h, g, wc, z = rng.uniform(0.5, 1.2), 9.81, rng.uniform(2.0, 8.0), rng.uniform(0.5, 1.5)
        p = wanted_cop(c, v, goal, wc, z, h, g)
        # the linear inverted pendulum over p: c̈ = (g / h)(c − p)
        np.testing.assert_allclose((g / h) * (c - p), wc ** 2 * (goal - c) - 2.0 * z * wc * v, atol=1e-12)


def test_holds_needs_every_point_within_the_reach() -> None:
    m = mujoco.MjModel.from_xml_string(FOOT.format(axis="0 1 0", lo=-40, hi=40))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    sole = np.array([[x, y, -0.02] for x in (-0.1, 0.2) for y in (-0.03, 0.03)])  # the foot's frame
    reach = AnkleReach(m, [1, 1], np.array([0]), 1.0, [sole, sole])  # ankles at x = 0.3: reach [0.2, 0.46]
    fwd, none = np.array([1.0, 0.0]), np.zeros((0, 3))
    inside, ahead, behind = np.array([0.45, 0.1]), np.array([0.47, 0.1]), np.array([0.19, 0.1])
    assert reach.holds(m, d, fwd, (inside, inside, inside), none, np.zeros(0, int), 500.0, 0.0)
    for p in (ahead, behind):  # any one point beyond: no
        for k in range(3):
            pts = [inside, inside, inside]
            pts[k] = p
            assert not reach.holds(m, d, fwd, tuple(pts), none, np.zeros(0, int), 500.0, 0.0)
    assert reach.withheld == 6
