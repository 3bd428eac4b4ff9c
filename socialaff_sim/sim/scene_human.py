"""The replayed human inside the MuJoCo scene: its bodies, sizes and compliant parts.

:func:`add_human` writes the human of a :class:`~socialaff_sim.sim.human.HumanBody`
into the scene's MJCF: one capsule per skeleton bone and one sphere per hand. In
the physics scene the compliant parts (:attr:`HumanBody.compliant`: forearms and
hands) are free bodies held by soft welds to mocap targets; everything else, and
every part in the IK scene, is a mocap body. :func:`set_human_sizes` gives the
capsules an instance's bone lengths, :func:`pose_compliant` puts the free parts on
their targets. The scene itself is built by :func:`~socialaff_sim.sim.scene.build_scene`.
"""

from __future__ import annotations

from typing import Protocol

import mujoco
import numpy as np
from dm_control import mjcf

from .human import HAND_SPHERE_RADIUS, HumanBody

__all__ = ["HUMAN_RGBA", "HUMAN_CONTACT", "PERSON_CONTYPE", "HUMAN_DENSITY", "HUMAN_WELD_SOLREF", "part_names", "add_human",
           "set_human_sizes", "pose_compliant", "HumanScene"]

HUMAN_RGBA = (0.85, 0.2, 0.2, 1.0)
HUMAN_CONTACT = {"solref": (0.03, 1.0), "solimp": (0.6, 0.9, 0.02, 0.5, 2), "solmix": 1000.0}
"""Contact softness of the human's capsules (flesh, not steel); solmix makes them set the pair's values."""
PERSON_CONTYPE = 2
"""Collision bit (``contype``) of every geom of the person (their ``conaffinity`` is 0)."""
HUMAN_DENSITY = 1000.0
"""kg/m³ of the compliant arm parts of the human (about that of flesh)."""
HUMAN_WELD_SOLREF = (0.02, 1.0)
"""Time constant (s) and damping ratio of the soft welds holding the human's forearms and hands
to the recording: a hand of half a kilogram yields about 1 cm under 12 N."""


def part_names(body: HumanBody) -> list[str]:
    """Scene names of the human's B + 2 parts: its bones' capsules, then the left and right hand spheres."""
    return [f"human_{n}" for n in body.bone_names] + ["human_left_hand_sphere", "human_right_hand_sphere"]


def add_human(root: mjcf.RootElement, body: HumanBody, physics: bool) -> None:
    """Add the human's bodies to ``root``; its compliant parts are welded free bodies only if ``physics``."""
    compliant = set(body.compliant) if physics else set()
    for i, name in enumerate(part_names(body)):
        if i < body.n_bones:
            shape = {"type": "capsule", "size": [float(body.radii[i]), 0.05]}
        else:
            shape = {"type": "sphere", "size": [HAND_SPHERE_RADIUS]}
        geom = {"name": name, "contype": PERSON_CONTYPE, "conaffinity": 0, "rgba": HUMAN_RGBA, "group": 1, **HUMAN_CONTACT, **shape}
        if i not in compliant:
            root.worldbody.add("body", name=name, mocap=True).add("geom", **geom)
            continue
        target = root.worldbody.add("body", name=f"{name}_target", mocap=True)
        part = root.worldbody.add("body", name=name, gravcomp=1.0)
        part.add("freejoint", name=name)
        part.add("geom", density=HUMAN_DENSITY, **geom)
        root.equality.add("weld", name=name, body1=target, body2=part, relpose=(0, 0, 0, 1, 0, 0, 0),
                          solref=HUMAN_WELD_SOLREF, solimp=(0.9, 0.95, 0.001, 0.5, 2))


class HumanScene(Protocol):
    """What :func:`set_human_sizes` and :func:`pose_compliant` read of a built scene
    (:class:`~socialaff_sim.sim.scene.Scene` has it; declared here so this module does not import the scene)."""

    model: mujoco.MjModel
    human_geom_ids: np.ndarray
    human_free_qadr: np.ndarray
    human_free_vadr: np.ndarray

    @property
    def n_bones(self) -> int: ...


def set_human_sizes(scene: HumanScene, half_lengths: np.ndarray) -> None:
    """Give the human's capsules their half-lengths (B,) metres, keeping MuJoCo's bounds and masses consistent."""
    m = scene.model
    g = scene.human_geom_ids[: scene.n_bones]
    r = m.geom_size[g, 0]
    m.geom_size[g, 1] = half_lengths
    m.geom_rbound[g] = half_lengths + r
    m.geom_aabb[g, 3:] = np.stack([r, r, half_lengths + r], axis=1)
    free = scene.human_free_qadr[: scene.n_bones] >= 0
    if free.any():
        # Capsule mass and inertia about its centre (z along the axis), density HUMAN_DENSITY.
        gb = g[free]
        body = m.geom_bodyid[gb]
        rr, hh = r[free], half_lengths[free]
        m_cyl = HUMAN_DENSITY * np.pi * rr**2 * 2 * hh
        m_hem = HUMAN_DENSITY * 2.0 / 3.0 * np.pi * rr**3
        mass = m_cyl + 2 * m_hem
        izz = m_cyl * rr**2 / 2 + 2 * m_hem * 2 * rr**2 / 5
        ixx = (m_cyl * (3 * rr**2 + 4 * hh**2) / 12
               + 2 * m_hem * (2 * rr**2 / 5 + hh**2 + 3 * hh * rr / 8))
        m.body_mass[body] = mass
        m.body_inertia[body] = np.stack([ixx, ixx, izz], axis=1)
        m.body_subtreemass[body] = mass


def pose_compliant(scene: HumanScene, data: mujoco.MjData, pos: np.ndarray, quat: np.ndarray) -> None:
    """Put the compliant human parts exactly on their targets ``pos`` (B + 2, 3), ``quat`` (B + 2, 4), at rest."""
    free = scene.human_free_qadr >= 0
    qa, va = scene.human_free_qadr[free], scene.human_free_vadr[free]
    data.qpos[qa[:, None] + np.arange(3)] = pos[free]
    data.qpos[qa[:, None] + np.arange(3, 7)] = quat[free]
    data.qvel[va[:, None] + np.arange(6)] = 0.0
