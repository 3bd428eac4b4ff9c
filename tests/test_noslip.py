"""``SimConfig.noslip_iterations``: MuJoCo's no-slip post-solve on the physics scene (issue 25, the standing mode's
feet). The premise checked against Coulomb's law on a plain block: a load inside the friction cone creeps under the
soft contacts alone and holds with the post-solve; a load beyond the cone slides either way."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.errors import ConfigError
from socialaff_sim.sim.simulator import SimConfig, Simulator

# A 40 kg block with Stubby's sole (16 × 8 cm) on the floor, μ = 1: it carries a horizontal force up to its weight
# W, and a moment about the vertical up to W·8.9 cm (MuJoCo touches a box at its four corners, 8.9 cm from the
# centre): 2.24 in the units of ``_push``'s moment.
BLOCK = """<mujoco><option timestep="0.004"/><worldbody>
<geom type="plane" size="2 2 .1" friction="1 0.005 0.0001"/>
<body name="b" pos="0 0 0.03"><freejoint/><geom type="box" size="0.08 0.04 0.02" mass="40"/></body>
</worldbody></mujoco>"""


def _push(noslip: int, force: float, moment: float, seconds: float = 2.0) -> tuple[float, float]:
    """The block's horizontal displacement (m) and turn about the vertical (deg) after ``seconds`` of a constant
    horizontal ``force`` and vertical ``moment`` (fractions of W and of W·4 cm) at its centre, from rest."""
    m = mujoco.MjModel.from_xml_string(BLOCK)
    m.opt.noslip_iterations = noslip
    d = mujoco.MjData(m)
    for _ in range(100):  # settle on the floor
        mujoco.mj_step(m, d)
    p0 = d.qpos[:2].copy()
    w = float(m.body_subtreemass[1]) * 9.81
    for _ in range(int(round(seconds / m.opt.timestep))):
        d.xfrc_applied[1, 0] = force * w
        d.xfrc_applied[1, 5] = moment * w * 0.04
        mujoco.mj_step(m, d)
    yaw = 2.0 * np.arctan2(d.qpos[6], d.qpos[3])
    return float(np.linalg.norm(d.qpos[:2] - p0)), float(abs(np.degrees(yaw)))


def test_a_load_inside_the_cone_creeps_on_soft_contacts_and_holds_with_the_post_solve() -> None:
    # 30 % of the sliding force, and a moment at 67 % of the sole's torsional capacity (the traced handshake asked
    # up to 25 N·m of Stubby's loaded foot, carrying 350-400 N: about 70 % of its corners' capacity).
    moved, turned = _push(0, 0.3, 0.0)
    assert moved > 1e-3  # soft contacts: millimetres in 2 s, though Coulomb's law says it sticks
    held, held_turn = _push(10, 0.3, 0.0)
    assert held < 1e-4 and held_turn < 0.01
    _, turned = _push(0, 0.0, 1.5)
    assert turned > 2.0  # degrees, turning about the vertical
    _, held_turn = _push(10, 0.0, 1.5)
    assert held_turn < 0.05


def test_a_load_beyond_the_cone_slides_with_the_post_solve_too() -> None:
    # The post-solve removes the soft model's creep, not friction's limit: beyond μ·W the block slides.
    for noslip in (0, 10):
        moved, _ = _push(noslip, 1.2, 0.0, seconds=0.5)
        assert moved > 0.05
        _, turned = _push(noslip, 0.0, 4.0, seconds=0.5)  # beyond the corners' 2.24
        assert turned > 10.0


def test_the_simulator_sets_the_post_solve_on_its_physics_scene() -> None:
    inter = generate_dataset(seed=0).of_label("high_five")[0]
    sim = Simulator("ours", "high_five", SimConfig(noslip_iterations=7))
    sim.reset(inter)
    assert sim.scene.model.opt.noslip_iterations == 7
    sim.step(sim.home_key_frames)
    assert sim.scene.model.opt.noslip_iterations == 7
    plain = Simulator("ours", "high_five", SimConfig())
    plain.reset(inter)
    assert plain.scene.model.opt.noslip_iterations == 0  # MuJoCo's default: the harness is as before


@pytest.mark.parametrize("bad", [-1, 2.5, True, "10"])
def test_noslip_iterations_must_be_a_count(bad: object) -> None:
    with pytest.raises(ConfigError, match="SimConfig.noslip_iterations"):
        SimConfig(noslip_iterations=bad)  # type: ignore[arg-type]
