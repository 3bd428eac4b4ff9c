"""The robot's arms as the balance controller's arm terms see them: their hinges, wrists and the person's force.

:mod:`~.hand_yield` and :mod:`~.arm_compensation` both move an arm's hinge references from its wrist and both
fade with the person's contact force on that arm (the contacts with the person's geoms only), filtered the same
way; this module is what they share.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import mujoco
import numpy as np

from ..retarget.kinematic_tree import subtree_mask
from .scene import Scene

__all__ = ["arm_hinges", "filtered_arm_force", "person_geoms", "wrist_frames"]


def wrist_frames(scene: Scene) -> list[tuple[int, bool]]:
    """Per arm (left, right): its wrist frame's id (key frame 1 + side) and whether that frame is a site (else a
    body)."""
    return [(int(scene.frame_ids[1 + s]), scene.frame_kinds[1 + s] == "site") for s in (0, 1)]


def wrist_positions(d: mujoco.MjData, frames: Sequence[tuple[int, bool]]) -> np.ndarray:
    """(2, 3) the wrist frames ``frames`` (:func:`wrist_frames`) in ``d`` (world, m; after its kinematics)."""
    return np.array([d.site_xpos[f] if site else d.xpos[f] for f, site in frames])


def person_geoms(scene: Scene) -> np.ndarray:
    """(ngeom,) bool: the person's geoms (``scene.human_geom_ids``), whose contacts on an arm count."""
    mask = np.zeros(scene.model.ngeom, dtype=bool)
    mask[np.asarray(scene.human_geom_ids, dtype=np.int64)] = True
    return mask


def arm_hinges(scene: Scene) -> tuple[list[int], list[np.ndarray]]:
    """Per arm (left, right): the body of its wrist frame (:func:`wrist_frames`), and its hinges as columns into
    the robot's dofs (``scene.robot_vadr``; each ≥ 6, past the free root)."""
    m = scene.model
    vadr = np.asarray(scene.robot_vadr)
    wrists, cols = [], []
    for s, (fid, site) in enumerate(wrist_frames(scene)):
        wrists.append(int(m.site_bodyid[fid]) if site else fid)
        arm = subtree_mask(m, int(scene.limb_body_ids[s]))
        cols.append(np.flatnonzero(arm[m.dof_bodyid[vadr]] & (np.arange(len(vadr)) >= 6)))
    return wrists, cols


def filtered_arm_force(previous: np.ndarray, forces: np.ndarray, geoms: np.ndarray, arm_geom: np.ndarray,
                       m: mujoco.MjModel, filter_time: float) -> np.ndarray:
    """(2, 3) each arm's contact force (world, N) low-pass filtered over ``filter_time`` (s; 0: none) by one physics
    step: ``previous`` (2, 3) the last estimate, ``forces`` (K, 3) the step's contact forces on the robot geoms
    ``geoms`` (K,), ``arm_geom`` (2, ngeom) bool, which geoms belong to each arm."""
    now = (np.array([forces[arm_geom[s][geoms]].sum(axis=0) for s in (0, 1)]) if len(geoms)
           else np.zeros((2, 3)))  # (no contact, most steps: the zeros at once)
    a = math.exp(-m.opt.timestep / filter_time) if filter_time > 0 else 0.0
    return a * previous + (1.0 - a) * now
