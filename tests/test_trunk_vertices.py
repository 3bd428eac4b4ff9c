"""``SimConfig.trunk_vertices``: the robot's trunk radius from its mesh geoms' vertices instead of their bounding
spheres. The mesh support against the corners of a box mesh worked out by hand; the decision (vertices or bounding
sphere) in both directions on a mesh and on primitives; the H1's trunk radius against the largest horizontal distance
of its trunk meshes' vertices from the base axis, computed here apart; Stubby's reach model the same either way; the
placement it sets (the H1 nearer the cup), and the option off by default in every preset."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest
from conftest import shared_robot

from socialaff_sim.retarget.kinematic_tree import subtree_mask
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.reach import _mesh_support, _support
from socialaff_sim.sim.simulator import SimConfig, Simulator

_BOX = """
<mujoco><asset><mesh name="m" vertex="-0.1 -0.2 -0.05  0.1 -0.2 -0.05  0.1 0.2 -0.05  -0.1 0.2 -0.05
                                       -0.1 -0.2  0.05  0.1 -0.2  0.05  0.1 0.2  0.05  -0.1 0.2  0.05"/></asset>
  <worldbody><body pos="0.3 -0.1 0.5" quat="0.9 0.1 0.3 -0.2">
    <geom type="mesh" mesh="m"/><geom type="sphere" pos="0 0.4 0" size="0.07"/>
  </body></worldbody></mujoco>"""


def _box() -> tuple[mujoco.MjModel, mujoco.MjData]:
    m = mujoco.MjModel.from_xml_string(_BOX)
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    return m, d


def test_mesh_support_is_the_box_corners_and_the_sphere_is_left_alone(rng: np.random.Generator) -> None:
    m, d = _box()
    # The box's eight corners in the world, from the body's pose alone (not from MuJoCo's recentred mesh).
    corners = np.array([[x, y, z] for x in (-0.1, 0.1) for y in (-0.2, 0.2) for z in (-0.05, 0.05)])
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, np.array([0.9, 0.1, 0.3, -0.2]) / np.linalg.norm([0.9, 0.1, 0.3, -0.2]))
    world = corners @ R.reshape(3, 3).T + np.array([0.3, -0.1, 0.5])
    gaps = []
    for _ in range(50):
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        exact = _mesh_support(m, d, np.arange(m.ngeom), u)
        np.testing.assert_allclose(exact[0], (world @ u).max(), atol=1e-6)  # float32 vertices
        bound = _support(m, d, np.arange(m.ngeom), u)
        # The bounding sphere never reaches less far than the box ...
        assert bound[0] >= exact[0] - 1e-6
        gaps.append(bound[0] - exact[0])
        # ... and a primitive is the same either way.
        assert exact[1] == bound[1]
    assert max(gaps) > 0.05  # ... and farther in some directions (the decision is not a no-op)


def _h1() -> object:
    return load_robot("unitree_h1", mjcf=shared_robot("unitree_h1", "h1.xml"))


def _trunk_radius(spec: object, label: str, inter: object, on: bool) -> tuple[float, Simulator]:
    sim = Simulator(spec, label, SimConfig(trunk_vertices=on))  # type: ignore[arg-type]
    sim.reset(inter)  # type: ignore[arg-type]
    return float(sim.scaler.robot.trunk_radius), sim


@pytest.fixture(scope="module")
def hand_over():  # noqa: ANN201
    from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset

    return generate_dataset(0, SyntheticConfig(interactions=("hand_over",), instances_per_interaction=1)).by_id(
        "hand_over_000")


def test_h1_trunk_radius_from_its_vertices(hand_over) -> None:  # noqa: ANN001
    spec = _h1()
    off, _ = _trunk_radius(spec, "hand_over", hand_over, False)
    on, sim = _trunk_radius(spec, "hand_over", hand_over, True)
    # The reference: the largest horizontal distance from the base's vertical axis of any vertex of the trunk's
    # (everything but the arms) collidable meshes, at home.
    sc = sim.scene
    m = sc.model
    d = sc.home_data()
    mujoco.mj_kinematics(m, d)
    base = d.xpos[int(sc.frame_ids[0])]
    collide = sc.robot_geom & ((m.geom_contype != 0) | (m.geom_conaffinity != 0))
    arms = subtree_mask(m, int(sc.limb_body_ids[0])) | subtree_mask(m, int(sc.limb_body_ids[1]))
    far, prim = 0.0, 0.0
    for g in np.flatnonzero(collide & ~arms[m.geom_bodyid]):
        if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
            mesh = m.geom_dataid[g]
            v = m.mesh_vert[m.mesh_vertadr[mesh]:m.mesh_vertadr[mesh] + m.mesh_vertnum[mesh]]
            w = v @ d.geom_xmat[g].reshape(3, 3).T + d.geom_xpos[g]
            far = max(far, float(np.linalg.norm(w[:, :2] - base[:2], axis=1).max()))
        else:  # a primitive (the H1 has two small cylinders at the hips): bounded by its bounding sphere
            prim = max(prim, float(np.linalg.norm(d.geom_xpos[g, :2] - base[:2]) + m.geom_rbound[g]))
    assert prim < far  # the meshes decide the radius
    # 16 directions sample the support: the radius is within the polygon's shortfall of the true extent.
    assert far * np.cos(np.pi / 16) - 1e-9 <= on <= far + 1e-9
    assert on == pytest.approx(0.322, abs=0.005)
    assert off == pytest.approx(0.537, abs=0.005)  # the thighs' bounding spheres
    # The placement the radius bounds: the H1 stands nearer the person with the vertices' radius.
    k_off = Simulator(spec, "hand_over", SimConfig())
    k_off.reset(hand_over)
    assert sim.scaler.k < k_off.scaler.k


def test_stubby_reach_model_is_the_same_either_way(hand_over) -> None:  # noqa: ANN001
    a, sa = _trunk_radius("ours", "hand_over", hand_over, False)
    b, sb = _trunk_radius("ours", "hand_over", hand_over, True)
    assert a == b
    assert sa.scaler.k == sb.scaler.k
    ra, rb = sa._stage.reach, sb._stage.reach
    for f in dataclasses.fields(ra):
        np.testing.assert_array_equal(getattr(ra, f.name), getattr(rb, f.name))


def test_off_by_default_in_every_preset() -> None:
    assert SimConfig().trunk_vertices is False
    assert SimConfig.harness().trunk_vertices is False
    assert SimConfig.standing().trunk_vertices is False
