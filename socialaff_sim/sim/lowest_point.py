"""The robot's lowest point at a posture, with which :func:`~socialaff_sim.sim.scene.build_scene` stands its home
posture on the floor (the root's height at home is minus it)."""

from __future__ import annotations

import mujoco
import numpy as np

from .geom_extent import primitive_extent

__all__ = ["lowest_point"]


def lowest_point(model: mujoco.MjModel, qadr: np.ndarray, robot_q: np.ndarray, robot_geom: np.ndarray) -> float:
    """Lowest z of the robot's collidable geoms with its free joint at z = 0.

    Exact for spheres, capsules, boxes, ellipsoids, cylinders (support
    function along −z) and meshes (their lowest vertex); other shapes use their
    bounding box.
    """
    data = mujoco.MjData(model)
    data.qpos[qadr] = robot_q
    data.qpos[qadr[2]] = 0.0
    mujoco.mj_kinematics(model, data)
    g = np.flatnonzero(robot_geom & ((model.geom_contype != 0) | (model.geom_conaffinity != 0)))
    rz = data.geom_xmat[g].reshape(-1, 3, 3)[:, 2, :]  # each geom's axes' z components
    kind = model.geom_type[g]
    z = data.geom_xpos[g, 2]
    reach = primitive_extent(kind, model.geom_size[g], rz, np.full(len(g), np.nan))  # as far down as up
    for i in np.flatnonzero(kind == int(mujoco.mjtGeom.mjGEOM_MESH)):  # meshes: their lowest vertex, exactly
        mid = int(model.geom_dataid[g[i]])
        verts = model.mesh_vert[model.mesh_vertadr[mid]:model.mesh_vertadr[mid] + model.mesh_vertnum[mid]]
        reach[i] = -float((verts @ rz[i]).min())
    box = np.isnan(reach)
    if box.any():  # the rest: the geom's bounding box
        aabb = model.geom_aabb[g[box]]
        z[box] = z[box] + np.einsum("gj,gj->g", rz[box], aabb[:, :3])
        reach[box] = np.einsum("gj,gj->g", np.abs(rz[box]), aabb[:, 3:])
    return float((z - reach).min())
