"""Which key-frame targets the robot can reach: the criterion under which IK error is judged.

A target counts as *reachable* when a configuration meeting it exists that the
IK's own constraints allow, judged by geometry alone (not by what the solver
achieved, so that a solver miss is never explained away):

* the base, when the robot's trunk placed there clears the person: every
  capsule of the person stays at least ``trunk_radius + clearance`` from the
  robot's vertical axis between the floor and its shoulders, ``trunk_radius``
  being the horizontal extent of everything but the arms at home (closer,
  collision avoidance must move the robot away from its target);
* a wrist, when the base is reachable, the wrist lies within the arm's length of
  its shoulder (the shoulder at its home offset from the base target) and at
  least ``hand_reach + clearance`` from every capsule of the person: then the
  hand fits there whichever way it points. Closer to the person, collision
  avoidance (or, for a wanted contact, the person's surface) decides where the
  hand stops, and the contact is judged by the sub-goal instead. Nor is a wrist
  reachable within ``wrist_core + clearance`` of the robot's own base (the geoms
  welded to the base body, placed at the base target): the wrist frame lies
  ``wrist_core`` deep inside its forearm or hand, which the IK keeps
  ``clearance`` away from the base whatever the posture (a thrown ball met at the
  tall CMU humanoid's hip height puts wrist targets inside its pelvis);
* an ankle, when the base is reachable and the ankle lies within the leg's length
  of its hip.

Joint ranges, the joint velocity limit and self-collision with the parts that
move relative to the base (spine, thighs, the other arm) are not part of the
test: a target they make unreachable counts as a miss (the criterion errs
toward counting misses, never toward hiding them: the base's shapes and the
wrist core are taken from inside the geoms, so they never exclude too much).
The contact bands of the scaler (``ScalingConfig.contact_far``) play no part.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from ..retarget.collision import collision_pairs
from .geom_extent import primitive_extent
from .human import HAND_SPHERE_RADIUS, HumanPose
from ..retarget.kinematic_tree import subtree_mask
from .scene import Scene

__all__ = ["ReachModel", "reach_model", "human_segments", "point_segment_distance", "reachable_targets"]

AXIS_SAMPLES = 6
"""Points on the robot's vertical axis at which the trunk's clearance is tested."""


@dataclass(frozen=True)
class ReachModel:
    """The robot's dimensions the criterion needs, robot frame at home, metres."""

    arm: float
    """Arm length (shoulder to wrist frame along the chain)."""
    leg: float
    """Leg length (hip to ankle frame along the chain)."""
    shoulders: np.ndarray
    """(2, 3) shoulder offsets from the base."""
    hips: np.ndarray
    """(2, 3) hip offsets from the base."""
    hand_reach: np.ndarray
    """(2,) farthest point of each hand's collidable geoms from its wrist frame."""
    hand_centre: np.ndarray
    """(2,) distance from each wrist frame to its hand's centre of mass (the hand's first body's subtree)."""
    trunk_radius: float
    """Farthest horizontal extent of the robot's collidable geoms other than the forearms and hands
    from the base's vertical axis."""
    shoulder_height: float
    """Height of the shoulders above the base."""
    base_height: float
    """Height of the base above the floor."""
    height: float
    """Height of the robot's top (its highest collidable geom) above the floor."""
    clearance: float
    """Distance the IK keeps from the person and the forearms and hands from the rest of the robot
    (``IKConfig.min_distance``)."""
    wrist_core: np.ndarray = field(default_factory=lambda: np.zeros(2))
    """(2,) radius of a ball about each wrist frame inside that arm's own collidable geoms (0: none)."""
    base_a: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    """(P, 3) one end of each capsule inside a collidable geom welded to the base (the geoms the
    forearms and hands keep clear of), offset from the base, robot frame at home (the base target's
    orientation)."""
    base_b: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    """(P, 3) the other end."""
    base_r: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """(P,) their radii."""


def _directions(n: int = 200) -> np.ndarray:
    """(n, 3) unit vectors spread evenly over the sphere (a Fibonacci lattice)."""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    phi = np.pi * (1.0 + 5.0**0.5) * i
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def _hand_extent(model: mujoco.MjModel, data: mujoco.MjData, geoms: np.ndarray, centre: np.ndarray) -> float:
    """Largest distance from ``centre`` (3,) of any point of ``geoms`` (support functions over 200 directions)."""
    if len(geoms) == 0:
        return 0.0
    return max(float((_support(model, data, geoms, u) - centre @ u).max()) for u in _directions())


def _support(model: mujoco.MjModel, data: mujoco.MjData, geoms: np.ndarray, u: np.ndarray) -> np.ndarray:
    """(G,) support function h(u) = max over each geom of x·u for a unit direction ``u`` (3,).

    Exact for spheres, capsules, boxes, ellipsoids and cylinders; the bounding sphere otherwise.
    """
    axes = data.geom_xmat[geoms].reshape(-1, 3, 3)  # columns: the geom's axes in world coordinates
    cu = np.einsum("gji,j->gi", axes, u)  # u in each geom's frame
    reach = primitive_extent(model.geom_type[geoms], model.geom_size[geoms], cu, model.geom_rbound[geoms])
    return data.geom_xpos[geoms] @ u + reach


def _mesh_support(model: mujoco.MjModel, data: mujoco.MjData, geoms: np.ndarray, u: np.ndarray) -> np.ndarray:
    """(G,) the support function h(u) = max over each geom of x·u (unit direction ``u`` (3,), world frame) with the
    mesh geoms' exact value, the largest of their vertices' (a mesh collides as its convex hull, whose vertices are
    among the mesh's), the other geoms as :func:`_support` has them."""
    out = _support(model, data, geoms, u)
    for i, g in enumerate(np.asarray(geoms, dtype=np.int64)):
        mesh = int(model.geom_dataid[g])
        if int(model.geom_type[g]) != int(mujoco.mjtGeom.mjGEOM_MESH) or mesh < 0:
            continue
        a, n = int(model.mesh_vertadr[mesh]), int(model.mesh_vertnum[mesh])
        world = model.mesh_vert[a:a + n] @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g]
        out[i] = float((world @ u).max())
    return out


def inner_capsules(model: mujoco.MjModel, data: mujoco.MjData, geoms: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Capsules inside ``geoms`` as segment ends a, b (G, 3) and radii (G,), world frame, metres.

    Exact for spheres and capsules; a box gets the capsule along its longest axis as thick as its
    smallest half-size, a cylinder the capsule as thick as the smaller of its radius and half-height,
    an ellipsoid the sphere of its smallest semi-axis; other types a point (radius 0).
    """
    g = np.asarray(geoms, dtype=np.int64)
    T = mujoco.mjtGeom
    kind, size = model.geom_type[g], model.geom_size[g]
    axes = data.geom_xmat[g].reshape(-1, 3, 3)  # columns: the geom's axes in world coordinates
    centre = data.geom_xpos[g]
    radius = np.zeros(len(g))
    half = np.zeros(len(g))
    axis = axes[:, :, 2]
    sphere, capsule = kind == int(T.mjGEOM_SPHERE), kind == int(T.mjGEOM_CAPSULE)
    radius[sphere | capsule] = size[sphere | capsule, 0]
    half[capsule] = size[capsule, 1]
    cyl = kind == int(T.mjGEOM_CYLINDER)
    radius[cyl] = np.minimum(size[cyl, 0], size[cyl, 1])
    half[cyl] = size[cyl, 1] - radius[cyl]
    box = np.flatnonzero(kind == int(T.mjGEOM_BOX))
    longest = np.argmax(size[box], axis=1)
    radius[box] = size[box].min(axis=1)
    half[box] = size[box, longest] - radius[box]
    axis[box] = axes[box, :, longest]
    ell = kind == int(T.mjGEOM_ELLIPSOID)
    radius[ell] = size[ell].min(axis=1)
    return centre - half[:, None] * axis, centre + half[:, None] * axis, radius


def _base_parts(scene: Scene, core: np.ndarray, data: mujoco.MjData, base: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Inner capsules (ends relative to ``base`` (3,), radii) of the collidable geoms welded to the
    base body that both wrist-core geoms ``core`` (2,) may collide with."""
    m = scene.model
    kind, fid = scene.frame_kinds[0], int(scene.frame_ids[0])
    body = int(m.site_bodyid[fid]) if kind == "site" else fid
    collide = scene.robot_geom & ((m.geom_contype != 0) | (m.geom_conaffinity != 0))
    T = mujoco.mjtGeom
    shaped = np.isin(m.geom_type, [int(t) for t in (T.mjGEOM_SPHERE, T.mjGEOM_CAPSULE, T.mjGEOM_CYLINDER,
                                                        T.mjGEOM_BOX, T.mjGEOM_ELLIPSOID)])
    welded = np.flatnonzero(collide & shaped & (m.body_weldid[m.geom_bodyid] == m.body_weldid[body]))
    for g in core[core >= 0]:
        welded = np.intersect1d(welded, collision_pairs(m, np.array([g]), welded, bits=False)[:, 1])
    if core.min() < 0:
        welded = welded[:0]
    a, b, r = inner_capsules(m, data, welded)
    return a - base, b - base, r


def reach_model(scene: Scene, arm: float, leg: float, shoulders: np.ndarray, hips: np.ndarray,
                clearance: float, trunk_vertices: bool = False) -> ReachModel:
    """The :class:`ReachModel` of ``scene``'s robot at its home posture (measurements from
    :func:`~socialaff_sim.retarget.scaling.measure_robot`). ``trunk_vertices``: the trunk's radius takes a mesh
    geom's extent from its vertices (:func:`_mesh_support`) instead of its bounding sphere
    (``SimConfig.trunk_vertices``; a robot without mesh geoms gets the same radius either way)."""
    m = scene.model
    d = scene.home_data()
    mujoco.mj_comPos(m, d)

    def frame_pos(k: int) -> np.ndarray:
        i = int(scene.frame_ids[k])
        return np.array(d.site_xpos[i] if scene.frame_kinds[k] == "site" else d.xpos[i])

    base = frame_pos(0)
    hand = np.array([_hand_extent(m, d, np.flatnonzero(scene.hand_geom[s]), frame_pos(1 + s)) for s in (0, 1)])
    collide = scene.robot_geom & ((m.geom_contype != 0) | (m.geom_conaffinity != 0))
    arms = subtree_mask(m, int(scene.limb_body_ids[0])) | subtree_mask(m, int(scene.limb_body_ids[1]))
    trunk = np.flatnonzero(collide & ~arms[m.geom_bodyid])
    angles = np.linspace(0.0, 2 * np.pi, 16, endpoint=False)
    support = _mesh_support if trunk_vertices else _support
    radius = max(float((support(m, d, trunk, np.array([np.cos(a), np.sin(a), 0.0]))
                        - base[:2] @ np.array([np.cos(a), np.sin(a)])).max()) for a in angles) if len(trunk) else 0.0
    # The wrist core: the deepest the wrist frame lies inside one of its arm's geoms.
    core = np.full(2, -1, dtype=np.int64)
    depth = np.zeros(2)
    for s in (0, 1):
        arm_geoms = np.flatnonzero(scene.arm_geom[s])
        if len(arm_geoms):
            a, b, r = inner_capsules(m, d, arm_geoms)
            inside = r - point_segment_distance(frame_pos(1 + s)[None], a, b)[0]
            k = int(np.argmax(inside))
            if inside[k] > 0:
                core[s], depth[s] = arm_geoms[k], inside[k]
    base_a, base_b, base_r = _base_parts(scene, core, d, base)
    return ReachModel(
        arm=float(arm), leg=float(leg), shoulders=np.asarray(shoulders, dtype=np.float64),
        hips=np.asarray(hips, dtype=np.float64), hand_reach=hand, trunk_radius=radius,
        hand_centre=np.array([np.linalg.norm(d.subtree_com[scene.grip_body[s]] - frame_pos(1 + s)) for s in (0, 1)]),
        shoulder_height=float(np.mean(np.asarray(shoulders)[:, 2])), base_height=float(base[2]),
        height=float(_support(m, d, np.flatnonzero(collide), np.array([0.0, 0.0, 1.0])).max()), clearance=float(clearance),
        wrist_core=depth, base_a=base_a, base_b=base_b, base_r=base_r,
    )


def human_segments(pose: HumanPose, radii: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The person's capsules as segments: ends a, b (T, B + 2, 3) and radii (B + 2,), world frame, metres.

    ``radii`` (B,) are the bone capsules'; the two hand spheres are zero-length segments.
    """
    B = len(pose.half_lengths)
    q = pose.quat[:, :B]
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    axis = np.stack([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)], axis=-1)
    half = axis * pose.half_lengths[None, :, None]
    a = pose.pos.copy()
    b = pose.pos.copy()
    a[:, :B] -= half
    b[:, :B] += half
    r = np.concatenate([np.asarray(radii, dtype=np.float64), [HAND_SPHERE_RADIUS, HAND_SPHERE_RADIUS]])
    return a, b, r


def point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(P, S) distances of points ``p`` (P, 3) to segments from ``a`` to ``b`` (S, 3)."""
    ab = b - a
    ll = np.einsum("ij,ij->i", ab, ab)
    ap = p[:, None, :] - a[None, :, :]
    u = np.clip(np.einsum("psj,sj->ps", ap, ab) / np.where(ll > 0, ll, 1.0), 0.0, 1.0)
    closest = a[None] + u[..., None] * ab[None]
    return np.linalg.norm(p[:, None, :] - closest, axis=-1)


def reachable_targets(model: ReachModel, targets: np.ndarray, world: np.ndarray, seg_a: np.ndarray,
                      seg_b: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """(5,) bool: which of the five targets are reachable (see the module notes).

    ``targets`` (5, 3) robot frame (where the shoulder and hip offsets apply) and ``world``
    (5, 3) the same in the world frame; ``seg_a``, ``seg_b`` (S, 3) and ``radius`` (S,) the
    person's capsules at that frame, world frame, metres.
    """
    base = world[0]
    heights = np.linspace(-model.base_height, model.shoulder_height, AXIS_SAMPLES)
    axis = base[None, :] + heights[:, None] * np.array([0.0, 0.0, 1.0])
    # The axis' points and the two hands in one pass (each point's distances are computed alone: the same numbers).
    gaps = point_segment_distance(np.concatenate([axis, world[1:3]]), seg_a, seg_b) - radius[None]
    trunk_gap = gaps[:AXIS_SAMPLES].min()
    base_ok = bool(trunk_gap >= model.trunk_radius + model.clearance)
    out = np.zeros(5, dtype=bool)
    out[0] = base_ok
    if not base_ok:
        return out
    hand_gap = gaps[AXIS_SAMPLES:].min(axis=1)
    shoulder = targets[0] + model.shoulders
    hip = targets[0] + model.hips
    out[1:3] = (np.linalg.norm(targets[1:3] - shoulder, axis=1) <= model.arm) & (
        hand_gap >= model.hand_reach + model.clearance)
    if len(model.base_r):
        own = point_segment_distance(targets[1:3], targets[0] + model.base_a, targets[0] + model.base_b) - model.base_r
        out[1:3] &= own.min(axis=1) >= model.wrist_core + model.clearance
    out[3:5] = np.linalg.norm(targets[3:5] - hip, axis=1) <= model.leg
    return out
