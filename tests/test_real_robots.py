"""Real robot models through the mapping mechanism: Unitree H1 and G1 (models in ../shared/robots).

Independent references: the models' own XML read with ElementTree (torque limits,
keyframe), and MuJoCo's kinematics of the unmodified model (the wrist site).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
import pytest
from conftest import shared_robot
from dm_control import mjcf

from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.errors import ConfigError
from socialaff_sim.resources import asset_path
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.robot_mjcf import motors_to_servos
from socialaff_sim.sim.scene import build_scene

LAYOUT = get_layout("kinect_v2")


def _h1() -> Path:
    return shared_robot("unitree_h1", "h1.xml")


def _g1() -> Path:
    return shared_robot("unitree_g1", "g1_29dof.xml")


def _torque_limits(xml: Path) -> dict[str, float]:
    """Joint name → the torque limit its motor may exert, read from the XML by hand."""
    root = ET.parse(xml).getroot()
    frc = {j.get("name"): float(j.get("actuatorfrcrange").split()[1])
           for j in root.iter("joint") if j.get("actuatorfrcrange")}
    out = {}
    for m in root.iter("motor"):
        lim = [float(m.get("ctrlrange").split()[1])] if m.get("ctrlrange") else []
        if m.get("joint") in frc:
            lim.append(frc[m.get("joint")])
        if lim:
            out[m.get("joint")] = min(lim)
    return out


def test_the_unitree_mappings_need_the_users_model() -> None:
    with pytest.raises(ConfigError, match=r"unitree_h1\.toml: robot 'unitree_h1' needs its MJCF model.*--mjcf PATH.*unitree_mujoco"):
        load_robot("unitree_h1")
    with pytest.raises(ConfigError, match=r"--mjcf: file .*nowhere\.xml does not exist"):
        load_robot("unitree_g1", mjcf="/nowhere.xml")
    with pytest.raises(ConfigError, match=r"builtin model .* takes no --mjcf"):
        load_robot("cmu", mjcf=asset_path("robots/ours.xml"))


@pytest.mark.parametrize(("name", "model", "n_servo"), [("unitree_h1", _h1, 19), ("unitree_g1", _g1, 29)])
def test_unitree_scene_motors_become_servos_with_the_real_torque_limits(name: str, model: object, n_servo: int) -> None:
    xml = model()  # type: ignore[operator]
    scene = build_scene(load_robot(name, mjcf=xml), LAYOUT)
    m = scene.model
    assert len(scene.act_ids) == n_servo
    assert len(scene.robot_joint_names) == 1 + n_servo  # free joint + hinges; H1's dummy hinge is gone
    assert not any("not_use" in m.body(b).name for b in range(m.nbody))
    limits = _torque_limits(xml)
    for a in scene.act_ids:
        joint = m.joint(int(m.actuator_trnid[a, 0])).name.removeprefix("robot/")
        assert m.actuator_forcelimited[a] == 1
        assert m.actuator_forcerange[a, 1] == pytest.approx(limits[joint]), joint
        assert m.actuator_gainprm[a, 0] > 0 and m.actuator_biasprm[a, 1] == -m.actuator_gainprm[a, 0]
    # Standing on the floor: the lowest robot geom touches z = 0 at home.
    d = mujoco.MjData(m)
    d.qpos[scene.robot_qadr] = scene.home_qpos
    mujoco.mj_forward(m, d)
    pelvis = d.xpos[m.body("robot/pelvis").id, 2]
    # SOURCE.md: pelvis 1.045 m (H1) and 0.792 m (G1) above the soles with straight legs; the home posture
    # bends hips, knees and ankles by 0.2/0.4/0.2 rad, lowering it by thigh·(1 − cos 0.2) + shin·(1 − cos 0.2).
    thigh_shin = {"unitree_h1": 0.8, "unitree_g1": 0.6}[name]
    straight = {"unitree_h1": 1.045, "unitree_g1": 0.792}[name]
    assert pelvis == pytest.approx(straight - thigh_shin * (1 - np.cos(0.2)), abs=0.02)
    floor = [c.dist for c in d.contact[: d.ncon] if scene.floor_geom in (c.geom1, c.geom2)]
    assert floor and min(floor) > -2e-3  # on the floor, not in it (meshes: the lowest point of their bounding box)


def test_h1_home_posture_and_wrist_offset_site() -> None:
    xml = _h1()
    spec = load_robot("unitree_h1", mjcf=xml)
    root, home = spec.build_model()
    # The keyframe's torso angle (0) and the mapping's overrides (knees 0.4).
    assert home["torso_joint"] == 0.0 and home["left_knee_joint"] == 0.4 and home["left_hip_yaw_joint"] == 0.0
    assert "not_use_joint" not in home
    # The wrist frame is a site 0.22 m along the forearm: same place as in the unmodified model's kinematics.
    scene = build_scene(spec, LAYOUT, physics=False)
    d = mujoco.MjData(scene.model)
    d.qpos[scene.robot_qadr] = scene.home_qpos
    mujoco.mj_kinematics(scene.model, d)
    site = d.site_xpos[scene.frame_ids[1]]
    ref = mujoco.MjModel.from_xml_path(str(xml))
    rd = mujoco.MjData(ref)
    for k in range(ref.njnt):
        jn = ref.joint(k).name.removeprefix("robot/")
        if jn in home:
            rd.qpos[ref.jnt_qposadr[k]] = home[jn]
    mujoco.mj_kinematics(ref, rd)
    b = ref.body("left_elbow_link_ball_hand").id
    want = rd.xpos[b] + rd.xmat[b].reshape(3, 3) @ np.array([0.22, 0.0, -0.015])
    got_rel = site - d.xpos[scene.model.body("robot/pelvis").id]
    want_rel = want - rd.xpos[ref.body("pelvis").id]
    np.testing.assert_allclose(got_rel, want_rel, atol=1e-9)


def _h1_mapping(tmp_path: Path, old: str = "", new: str = "") -> Path:
    text = asset_path("robots/unitree_h1.toml").read_text()
    text = text.replace("ignore_bodies", f'mjcf = "{_h1()}"\nignore_bodies', 1)
    if old:
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / "my_h1.toml"
    path.write_text(text)
    return path


def test_a_robot_from_a_temporary_mapping_file(tmp_path: Path) -> None:
    spec = load_robot(_h1_mapping(tmp_path, 'name = "unitree_h1"', 'name = "my_h1"'))
    assert spec.name == "my_h1" and spec.mjcf_path == _h1().resolve()
    scene = build_scene(spec, LAYOUT)
    assert len(scene.act_ids) == 19


@pytest.mark.parametrize(
    ("old", "new", "pattern"),
    [
        ('ignore_bodies = ["not_use_body"]', "", r"exactly one top-level body .* 'pelvis' or 'not_use_body'.*ignore_bodies"),
        ('ignore_bodies = ["not_use_body"]', 'ignore_bodies = ["dummy"]', r"ignore_bodies names 'dummy', not a body.*'pelvis'"),
        ('body = "left_elbow_link_ball_hand"', 'body = "left_hand"', r"body 'left_hand' is not in the robot model; bodies: .*'left_elbow_link_ball_hand'"),
        ('left_ankle = "body:left_ankle_link"', 'left_ankle = "body:left_foot"', r"frame 'body:left_foot' is not in the robot model; bodys present: .*'left_ankle_link'"),
        ('left_elbow_joint = 0.6', 'left_wrist_joint = 0.6', r"posture\.joints names 'left_wrist_joint', not a joint.*'left_elbow_joint'"),
        ('pos = [0.22, 0.0, -0.015] }', 'pos = [0.22, 0.0] }', r"frames\.left_wrist\.pos'.*a list of 3 finite numbers"),
    ],
)
def test_real_robot_mapping_errors_name_what_is_missing(tmp_path: Path, old: str, new: str, pattern: str) -> None:
    path = _h1_mapping(tmp_path, old, new)
    with pytest.raises(ConfigError, match=pattern) as info:
        load_robot(path).build_mjcf()
    assert str(path) in str(info.value)


def test_motors_become_servos_with_the_tightest_torque_limit() -> None:
    root = mjcf.from_xml_string("""
    <mujoco><worldbody><body name="a"><geom size="0.1"/>
      <body name="b"><joint name="j1" axis="0 1 0" actuatorfrcrange="-7 7"/><geom size="0.1"/>
        <body name="c"><joint name="j2" axis="0 1 0"/><geom size="0.1"/>
          <body name="d"><joint name="j3" axis="0 1 0"/><geom size="0.1"/></body></body></body></body></worldbody>
    <actuator><motor joint="j1" ctrlrange="-5 5" gear="2"/><motor joint="j2" ctrlrange="-5 5" gear="2"/>
      <motor name="free" joint="j3"/></actuator></mujoco>""")
    assert motors_to_servos(root) == 3
    acts = root.find_all("actuator")
    assert [a.tag for a in acts] == ["position"] * 3
    assert list(acts[0].forcerange) == [-7.0, 7.0]  # the joint's limit is below 5 × 2
    assert list(acts[1].forcerange) == [-10.0, 10.0]  # ctrlrange × gear
    assert acts[2].forcerange is None and acts[2].name == "free"  # no limit given: none invented
