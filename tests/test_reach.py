"""The reach criterion's clause for the robot's own base: a wrist target within the wrist core plus the
clearance of the geoms welded to the base is out of reach (closed forms), the model's measurements of the
wrist core and the base parts, and the IK never brings the wrist that close."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest
from test_retarget_ik import LAYOUT, ik_for, stick  # noqa: F401  (stick: the fixture)

from socialaff_sim.retarget.ik import IKConfig
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.retarget.scaling import measure_robot
from socialaff_sim.sim.reach import ReachModel, inner_capsules, reach_model, reachable_targets
from socialaff_sim.sim.scene import Scene, build_scene

PLAIN = ReachModel(arm=0.5, leg=0.4, shoulders=np.array([[0.0, 0.2, 0.4], [0.0, -0.2, 0.4]]),
                   hips=np.array([[0.0, 0.1, 0.0], [0.0, -0.1, 0.0]]), hand_reach=np.array([0.1, 0.1]),
                   hand_centre=np.array([0.05, 0.05]), trunk_radius=0.2, shoulder_height=0.4, base_height=0.6,
                   height=1.3, clearance=0.01)


def _far_person() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return np.array([[5.0, 0.0, 0.0]]), np.array([[5.0, 0.0, 2.0]]), np.array([0.1])


def test_wrist_next_to_its_own_base_by_hand() -> None:
    # The base: a capsule along y, 0.1 below the base frame, half-length 0.1, radius 0.12; wrist cores 3 cm.
    plain = dataclasses.replace(PLAIN, arm=0.8)  # every wrist target below within the arm's length
    model = dataclasses.replace(plain, wrist_core=np.array([0.03, 0.03]), base_a=np.array([[0.0, -0.1, -0.1]]),
                                base_b=np.array([[0.0, 0.1, -0.1]]), base_r=np.array([0.12]))
    base = np.array([0.0, 0.0, 0.6])
    limit = 0.12 + 0.03 + 0.01  # the capsule's radius, the wrist core, the clearance
    for ahead, expected in [(limit + 1e-3, True), (limit - 1e-3, False), (0.05, False)]:
        targets = np.array([base, base + (ahead, 0.05, -0.1), base + (0.3, -0.2, 0.1), base + (0.0, 0.1, -0.39),
                            base + (0.0, -0.1, -0.39)])
        out = reachable_targets(model, targets, targets, *_far_person())
        np.testing.assert_array_equal(out, [True, expected, True, True, True])
        # Without base parts the clause is off (the criterion as before).
        assert reachable_targets(plain, targets, targets, *_far_person())[1]
    # Past the capsule's end: the distance is to the end cap, not to the axis' line.
    targets[1] = base + (0.0, 0.1 + limit + 1e-3, -0.1)
    assert reachable_targets(model, targets, targets, *_far_person())[1]
    targets[1] = base + (0.0, 0.1 + limit - 1e-3, -0.1)
    assert not reachable_targets(model, targets, targets, *_far_person())[1]


def test_inner_capsules_lie_inside_their_geoms(rng: np.random.Generator) -> None:
    """Points of each inner capsule are inside its geom (checked with the geom's own implicit form)."""
    xml = """
    <mujoco><worldbody><body name="b" pos="0.1 0.2 0.3" quat="0.9 0.1 0.3 -0.2">
      <geom type="box" size="0.1 0.3 0.05"/><geom type="capsule" fromto="0 0 0 0.2 0.1 0" size="0.04"/>
      <geom type="sphere" pos="0.3 0 0" size="0.07"/><geom type="ellipsoid" pos="0 0.4 0" size="0.1 0.06 0.2"/>
      <geom type="cylinder" pos="0 0 0.4" size="0.05 0.2"/>
    </body></worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    a, b, r = inner_capsules(m, d, np.arange(m.ngeom))
    np.testing.assert_allclose(r, [0.05, 0.04, 0.07, 0.06, 0.05], atol=1e-12)
    T = mujoco.mjtGeom
    for g in range(m.ngeom):
        u = rng.uniform(0.0, 1.0, 400)
        dirs = rng.normal(size=(400, 3))
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        pts = a[g] + u[:, None] * (b[g] - a[g]) + (r[g] * 0.999 * rng.uniform(0, 1, 400) ** (1 / 3))[:, None] * dirs
        local = (pts - d.geom_xpos[g]) @ d.geom_xmat[g].reshape(3, 3)  # coordinates in the geom's frame
        size = m.geom_size[g]
        kind = m.geom_type[g]
        if kind == T.mjGEOM_BOX:
            inside = (np.abs(local) <= size).all(axis=1)
        elif kind == T.mjGEOM_CAPSULE:
            beyond = np.maximum(np.abs(local[:, 2]) - size[1], 0.0)  # past the segment's end
            inside = np.hypot(np.hypot(local[:, 0], local[:, 1]), beyond) <= size[0]
        elif kind == T.mjGEOM_SPHERE:
            inside = np.linalg.norm(local, axis=1) <= size[0]
        elif kind == T.mjGEOM_ELLIPSOID:
            inside = np.linalg.norm(local / size, axis=1) <= 1.0
        else:  # cylinder
            inside = (np.hypot(local[:, 0], local[:, 1]) <= size[0]) & (np.abs(local[:, 2]) <= size[1])
        assert inside.all(), g


def _reach_of(scene: Scene) -> ReachModel:
    meas = measure_robot(scene.model, scene.home_qpos, scene.frame_kinds, scene.frame_ids, scene.limb_body_ids)
    return reach_model(scene, meas.arm, meas.leg, meas.shoulders, meas.hips, 0.01)


def test_stick_wrist_core_and_no_base_parts(stick: Scene) -> None:  # noqa: F811
    reach = _reach_of(stick)
    # The wrist site is the centre of a 4 cm palm sphere.
    np.testing.assert_allclose(reach.wrist_core, [0.04, 0.04], atol=1e-9)
    # The palm is welded to the arm, a child of the pelvis: the pair never collides, so no base part.
    assert reach.base_r.size == 0


@pytest.fixture(scope="module")
def cmu() -> Scene:
    return build_scene(load_robot("cmu"), LAYOUT, physics=False)


def test_cmu_base_parts_are_its_pelvis(cmu: Scene) -> None:
    m = cmu.model
    reach = _reach_of(cmu)
    root = m.geom("robot/root_geom").id
    np.testing.assert_allclose(reach.base_r[0], m.geom_size[root, 0], atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(reach.base_b[0] - reach.base_a[0]), 2 * m.geom_size[root, 1], atol=1e-9)
    assert len(reach.base_r) == 3  # and the two small hip-joint capsules welded to it
    # The wrist frame (the wrist body's origin) lies inside the forearm capsule, at the end of its segment.
    d = mujoco.MjData(m)
    d.qpos[:] = cmu.home_qpos
    mujoco.mj_kinematics(m, d)
    g = m.geom("robot/lradius").id
    axis = d.geom_xmat[g].reshape(3, 3)[:, 2]
    wrist = d.xpos[m.body("robot/lwrist").id]
    along = np.clip((wrist - d.geom_xpos[g]) @ axis, -m.geom_size[g, 1], m.geom_size[g, 1])
    expected = m.geom_size[g, 0] - np.linalg.norm(wrist - d.geom_xpos[g] - along * axis)
    np.testing.assert_allclose(reach.wrist_core[0], expected, atol=1e-9)


def test_cmu_ik_keeps_the_wrist_core_off_its_pelvis(cmu: Scene) -> None:
    """The reason of the clause: aimed at the middle of its pelvis, the wrist stops the core plus the clearance away."""
    reach = _reach_of(cmu)
    ik = ik_for(cmu, 8.0)
    start = ik.frame_positions()
    base = start[0]
    a, b, r = base + reach.base_a[0], base + reach.base_b[0], reach.base_r[0]
    targets = start.copy()
    targets[1] = 0.5 * (a + b) + (0.05, 0.0, 0.0)  # inside the pelvis, a little forward of its axis
    gaps = []
    for _ in range(30):
        ik.solve(targets, 0.0, dt=1 / 15)
        p = ik.frame_positions()[1]
        t = np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
        gaps.append(np.linalg.norm(p - (a + t * (b - a))) - r)
    assert min(gaps) >= reach.wrist_core[0] + reach.clearance - IKConfig().collision_slack
    assert gaps[-1] <= reach.wrist_core[0] + reach.clearance + 0.05  # it did go for the target
    # The IK scene's home is the robot frame: the targets serve as both.
    assert not reachable_targets(reach, targets, targets, *_far_person())[1]
