"""The body that carries a foot's sole (sim/feet_on_floor.py: sole_body, FeetOnFloor.bodies): the lowest body every
floor contact of the foot at home hangs from, on a model written out here (a sole below an ankle-roll hinge, a
sole split over heel and toe bodies, a foot without contacts), and on the robots: the key frame's own body on
Stubby and the H1, the G1's ankle_roll_link below its ankle frame (ankle_pitch_link), its sole against the four
spheres of its MJCF read with ElementTree."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest
from conftest import shared_robot

from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.feet_on_floor import FeetOnFloor, sole_body
from socialaff_sim.sim.flat_feet import leg_dofs, roll_free_axes
from socialaff_sim.sim.scene import build_scene

_FOOT = """
<mujoco><worldbody><body name="shin" pos="0 0 1"><freejoint/><geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.03"/>
  <body name="ankle_pitch" pos="0 0 -0.4"><joint type="hinge" axis="0 1 0"/><geom type="sphere" size="0.02"/>
    <body name="ankle_roll" pos="0 0 -0.02"><joint type="hinge" axis="1 0 0"/>
      <body name="heel" pos="-0.05 0 -0.03"><geom type="sphere" size="0.005"/></body>
      <body name="toe" pos="0.12 0 -0.03"><joint type="hinge" axis="0 1 0"/><geom type="sphere" size="0.005"/></body>
    </body></body></body></worldbody></mujoco>
"""


def _ids(m: mujoco.MjModel, *names: str) -> list[int]:
    return [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, n) for n in names]


def test_the_sole_body_is_the_lowest_body_all_the_contacts_hang_from() -> None:
    m = mujoco.MjModel.from_xml_string(_FOOT)
    pitch, roll, heel, toe = _ids(m, "ankle_pitch", "ankle_roll", "heel", "toe")
    # heel and toe touching: their common parent, the roll body below the ankle frame's (pitch) body
    assert sole_body(m, pitch, np.array([heel, toe, heel])) == roll
    # the toe alone: the toe's own body; the frame's own body when it carries the contact
    assert sole_body(m, pitch, np.array([toe])) == toe
    assert sole_body(m, pitch, np.array([pitch, toe])) == pitch
    # no contact at home: the ankle frame's body
    assert sole_body(m, pitch, np.zeros(0, dtype=np.int64)) == pitch


def _feet(name: str, path=None) -> tuple[FeetOnFloor, mujoco.MjModel, object]:  # noqa: ANN001
    robot = load_robot(name) if path is None else load_robot(name, mjcf=path)
    scene = build_scene(robot, get_layout("kinect_v2"), harness_time_constant=0.02)
    return FeetOnFloor(scene, 0.0), scene.model, scene


@pytest.mark.parametrize(("name", "xml", "body"), [("ours", None, "foot"), ("unitree_h1", ("unitree_h1", "h1.xml"), "ankle_link")])
def test_stubby_and_the_h1_keep_their_ankle_frames_body(name, xml, body) -> None:  # noqa: ANN001
    feet, m, scene = _feet(name, None if xml is None else shared_robot(*xml))
    frames = [int(scene.frame_ids[k]) if scene.frame_kinds[k] == "body" else int(m.site_bodyid[scene.frame_ids[k]])
              for k in (3, 4)]
    assert feet.bodies == frames
    assert [m.body(b).name for b in feet.bodies] == [f"robot/left_{body}", f"robot/right_{body}"]


def test_the_g1s_sole_is_its_ankle_roll_link_with_the_four_spheres_corners() -> None:
    path = shared_robot("unitree_g1", "g1_29dof.xml")
    feet, m, scene = _feet("unitree_g1", path)
    assert [m.body(b).name for b in feet.bodies] == ["robot/left_ankle_roll_link", "robot/right_ankle_roll_link"]
    # the legs now count their ankle roll: six joints each, so flat_roll_free leaves the G1's rows whole
    assert [leg_dofs(m, b, scene.root_body) for b in feet.bodies] == [6, 6]
    assert roll_free_axes(m, feet.bodies, feet.forward, scene.root_body) == [None, None]
    # the sole's box: the spheres' centres (read from the XML) widened to the box of their lowest points, which
    # the home pose (level soles) presses 2 mm into the floor: the contact points sit 1 mm above the bottom
    root = ET.parse(path).getroot()
    for s, side in enumerate(("left", "right")):
        body = next(b for b in root.iter("body") if b.get("name") == f"{side}_ankle_roll_link")
        spheres = [g for g in body.findall("geom") if g.get("size") and g.get("type") in (None, "sphere")]
        pos = np.array([[float(v) for v in g.get("pos").split()] for g in spheres])
        r = float(spheres[0].get("size"))
        assert len(pos) == 4
        sole = feet.soles[s]
        assert np.allclose(sole[:, :2].min(axis=0), pos[:, :2].min(axis=0), atol=2e-4)
        assert np.allclose(sole[:, :2].max(axis=0), pos[:, :2].max(axis=0), atol=2e-4)
        assert np.allclose(sole[:, 2], pos[0, 2] - r + 0.001, atol=2e-4)
