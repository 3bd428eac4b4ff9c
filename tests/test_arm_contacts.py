"""What the arms' balance terms share (sim/arm_contacts.py): the person's geoms, checked against MuJoCo's own
geom names and contact types, and the wrist frames, checked against the key frames' gather (stage.key_frames) and
the bodies the hinges' Jacobian is taken on."""

from __future__ import annotations

import mujoco
import numpy as np

from socialaff_sim.sim.arm_contacts import arm_hinges, person_geoms, wrist_frames
from socialaff_sim.sim.scene import PERSON_CONTYPE
from socialaff_sim.sim.stage import key_frames


def test_the_person_mask_is_the_persons_geoms_and_nothing_else(scene) -> None:
    m = scene.model
    mask = person_geoms(scene)
    assert mask.shape == (m.ngeom,) and mask.dtype == bool
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or "" for g in range(m.ngeom)]
    np.testing.assert_array_equal(mask, [n.startswith("human_") for n in names])
    np.testing.assert_array_equal(mask, m.geom_contype == PERSON_CONTYPE)
    assert not mask[np.flatnonzero(scene.arm_geom.any(axis=0))].any()  # no robot arm geom counts as the person


def test_the_wrist_frames_are_the_key_frames_wrists(scene) -> None:
    m = scene.model
    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    q = np.array(scene.home_qpos, dtype=np.float64)
    q[7:] += rng.normal(scale=0.3, size=len(q) - 7)  # an arbitrary posture: the frames move apart from home
    d.qpos[scene.robot_qadr] = q
    mujoco.mj_kinematics(m, d)
    frames = wrist_frames(scene)
    got = np.array([d.site_xpos[f] if site else d.xpos[f] for f, site in frames])
    np.testing.assert_array_equal(got, key_frames(scene, d)[1:3])
    bodies, cols = arm_hinges(scene)
    for s, (f, site) in enumerate(frames):
        assert bodies[s] == (int(m.site_bodyid[f]) if site else f)
        assert bodies[s] in set(m.dof_bodyid[np.asarray(scene.robot_vadr)[cols[s]]])  # its hinges move it
    assert not set(cols[0]) & set(cols[1])
