"""``SimConfig.floor_time_constant``: a stiffer floor under the standing robot's feet (issue 25, the feet's slide in
the standing mode). The floor's contacts with and without it (their time constant from MuJoCo's mix, friction and
condim unchanged), a ball resting on it sinking in by MuJoCo's soft-contact law (r = g (1 − d) / (d k), k the spring
of the time constant), the setting's error, and a standing handshake whose planted feet slide less on it."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.scene import ObjectSpec, build_scene
from socialaff_sim.sim.sim_config import STANDING_FLOOR
from socialaff_sim.sim.simulator import SimConfig, Simulator
from test_balance_control import LAYOUT

BALL = ObjectSpec("sphere", (0.05,), 2.0)
TAU = 0.01


def _resting(tau: float | None) -> tuple[mujoco.MjModel, mujoco.MjData, object]:
    """Stubby at home on its rigid harness with its feet on the floor, the person out of the way and the ball
    resting on the floor 2 m away, after 1 s of physics."""
    sc = build_scene(load_robot("ours"), LAYOUT, BALL, compliant_person=False, floor_time_constant=tau)
    m = sc.model
    d = mujoco.MjData(m)
    d.qpos[sc.robot_qadr] = sc.home_qpos
    d.mocap_pos[sc.human_mocap] += np.array([5.0, 5.0, 0.0])
    qa = sc.object_qadr
    d.qpos[qa:qa + 7] = (2.0, -2.0, BALL.size[0], 1.0, 0.0, 0.0, 0.0)
    mujoco.mj_forward(m, d)
    d.mocap_pos[sc.anchor_mocap], d.mocap_quat[sc.anchor_mocap] = d.xpos[sc.root_body], d.xquat[sc.root_body]
    d.ctrl[sc.act_ids] = sc.ctrl_for(d.qpos[None].copy(), np.zeros(m.nv))[0]
    for _ in range(int(round(1.0 / m.opt.timestep))):
        mujoco.mj_step(m, d)
    return m, d, sc


def _floor_contacts(m, d, sc, other) -> list:
    """The contacts of the floor with the geoms flagged in ``other`` (ngeom,) bool."""
    out = []
    for i in range(d.ncon):
        c = d.contact[i]
        g = {int(c.geom1), int(c.geom2)}
        if sc.floor_geom in g and other[(g - {sc.floor_geom}).pop()]:
            out.append(c)
    return out


def test_the_floor_contacts_take_the_time_constant_only_with_the_option():
    m0, d0, s0 = _resting(None)
    m1, d1, s1 = _resting(TAU)
    robot0, robot1 = _floor_contacts(m0, d0, s0, s0.robot_geom), _floor_contacts(m1, d1, s1, s1.robot_geom)
    assert robot0 and robot1  # the feet stand on the floor in both
    for c in robot0:
        np.testing.assert_allclose(c.solref, (0.02, 1.0))  # MuJoCo's default, as without the option
    for c0, c1 in zip(robot0, robot1, strict=False):
        np.testing.assert_allclose(c1.solref[0], TAU, rtol=2e-3)  # the floor's, by its weight in the mix
        np.testing.assert_allclose(c1.friction, c0.friction)  # friction and condim mix as before
        assert c1.dim == c0.dim
        np.testing.assert_allclose(c1.solimp, c0.solimp)
    assert m0.geom_solmix[s0.floor_geom] == 1.0 and m1.geom_solmix[s1.floor_geom] > 100.0


def _sink(tau: float | None) -> float:
    m, d, sc = _resting(tau)
    ball = np.zeros(m.ngeom, dtype=bool)
    ball[sc.object_geom] = True
    (c,) = _floor_contacts(m, d, sc, ball)
    return -float(c.dist)


def _law(tau: float, depth: float) -> float:
    """MuJoCo's static sinking of a resting single contact, r = g (1 − d(r)) / (d(r) k), k = 1 / (d_max² τ² ζ²),
    ζ = 1, with d(r) the default solimp (0.9, 0.95, 0.001, 0.5, 2) at ``depth`` (its width's power-2 sigmoid)."""
    x = min(depth / 0.001, 1.0)
    y = 0.5 * (x / 0.5) ** 2 if x <= 0.5 else 1.0 - 0.5 * ((1.0 - x) / 0.5) ** 2
    dr = 0.9 + (0.95 - 0.9) * y
    k = 1.0 / (0.95 ** 2 * tau ** 2)
    return 9.81 * (1.0 - dr) / (dr * k)


def test_a_resting_ball_sinks_by_the_soft_contact_law():
    r0, r1 = _sink(None), _sink(TAU)
    # The law's ratio at the measured depths (its absolute value is off by the share of the load the friction
    # pyramid's rows carry, the same at both time constants): the stiffer floor's spring is 4 times the default's.
    np.testing.assert_allclose(r1 / r0, _law(TAU, r1) / _law(0.02, r0), rtol=0.05)
    assert r1 < 0.5 * r0  # stiffer, not softer


@pytest.mark.parametrize("bad", [0.0, -0.01])
def test_a_time_constant_not_above_zero_is_one_line_error(bad):
    with pytest.raises(ConfigError, match="SimConfig.floor_time_constant"):
        SimConfig(floor_time_constant=bad)


def test_the_standing_mode_has_the_stiffer_floor_and_the_harness_mode_not():
    # adopted into the standing mode by the rule of docs/design.md §5 (issue 25); the harness keeps MuJoCo's floor
    assert STANDING_FLOOR == TAU and SimConfig.standing().floor_time_constant == TAU
    assert SimConfig().floor_time_constant is None and SimConfig.harness().floor_time_constant is None
    assert SimConfig.standing(floor_time_constant=None).floor_time_constant is None


def test_standing_handshake_slides_less_on_the_stiffer_floor():
    """shake_hands_088 (a spent instance), ground truth, the standing mode: the contact phase's slide path (the
    support meter's) falls with the stiffer floor (5.0 → 1.4 cm when traced); the handshake is met either way."""
    inter = list(generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=89)).of_label(
        "shake_hands"))[88]
    out = {}
    for tau in (None, TAU):
        cfg = SimConfig.standing(floor_time_constant=tau)
        out[tau] = run_episode(Simulator(load_robot("ours"), "shake_hands", cfg), GroundTruthSource(), inter)
    before = out[None]["support"]["contact_phase"]["foot_slide_cm"]
    after = out[TAU]["support"]["contact_phase"]["foot_slide_cm"]
    assert out[None]["success"] and out[TAU]["success"]
    assert after < before - 1.0, (before, after)
