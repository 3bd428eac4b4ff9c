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
  hand stops, and the contact is judged by the sub-goal instead;
* an ankle, when the base is reachable and the ankle lies within the leg's length
  of its hip.

Joint ranges, self-collision and the joint velocity limit are not part of the
test: a target they make unreachable counts as a miss (the criterion errs
toward counting misses, never toward hiding them). The contact bands of the
scaler (``ScalingConfig.contact_far``) play no part.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from .human import HAND_SPHERE_RADIUS, HumanPose
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
    """Distance the IK keeps from the person (``IKConfig.min_distance``)."""


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
    size = model.geom_size[geoms]
    kind = model.geom_type[geoms]
    T = mujoco.mjtGeom
    reach = np.where(
        kind == int(T.mjGEOM_SPHERE), size[:, 0],
        np.where(kind == int(T.mjGEOM_CAPSULE), np.abs(cu[:, 2]) * size[:, 1] + size[:, 0],
        np.where(kind == int(T.mjGEOM_BOX), np.einsum("gi,gi->g", np.abs(cu), size),
        np.where(kind == int(T.mjGEOM_ELLIPSOID), np.sqrt(np.einsum("gi,gi->g", cu**2, size**2)),
        np.where(kind == int(T.mjGEOM_CYLINDER),
                 np.abs(cu[:, 2]) * size[:, 1] + size[:, 0] * np.sqrt(np.clip(1 - cu[:, 2] ** 2, 0, 1)),
                 model.geom_rbound[geoms])))))
    return data.geom_xpos[geoms] @ u + reach


def _subtree(model: mujoco.MjModel, root: int) -> np.ndarray:
    """(nbody,) bool: ``root`` and its descendants."""
    inside = np.zeros(model.nbody, dtype=bool)
    inside[root] = True
    for b in range(root + 1, model.nbody):  # MuJoCo numbers a body after its parent
        inside[b] = inside[model.body_parentid[b]]
    return inside


def reach_model(scene: Scene, arm: float, leg: float, shoulders: np.ndarray, hips: np.ndarray,
                clearance: float) -> ReachModel:
    """The :class:`ReachModel` of ``scene``'s robot at its home posture (measurements from
    :func:`~socialaff_sim.retarget.scaling.measure_robot`)."""
    m = scene.model
    d = mujoco.MjData(m)
    d.qpos[scene.robot_qadr] = scene.home_qpos
    mujoco.mj_kinematics(m, d)
    mujoco.mj_comPos(m, d)

    def frame_pos(k: int) -> np.ndarray:
        i = int(scene.frame_ids[k])
        return np.array(d.site_xpos[i] if scene.frame_kinds[k] == "site" else d.xpos[i])

    base = frame_pos(0)
    hand = np.array([_hand_extent(m, d, np.flatnonzero(scene.hand_geom[s]), frame_pos(1 + s)) for s in (0, 1)])
    collide = scene.robot_geom & ((m.geom_contype != 0) | (m.geom_conaffinity != 0))
    arms = _subtree(m, int(scene.limb_body_ids[0])) | _subtree(m, int(scene.limb_body_ids[1]))
    trunk = np.flatnonzero(collide & ~arms[m.geom_bodyid])
    angles = np.linspace(0.0, 2 * np.pi, 16, endpoint=False)
    radius = max(float((_support(m, d, trunk, np.array([np.cos(a), np.sin(a), 0.0]))
                        - base[:2] @ np.array([np.cos(a), np.sin(a)])).max()) for a in angles) if len(trunk) else 0.0
    return ReachModel(
        arm=float(arm), leg=float(leg), shoulders=np.asarray(shoulders, dtype=np.float64),
        hips=np.asarray(hips, dtype=np.float64), hand_reach=hand, trunk_radius=radius,
        hand_centre=np.array([np.linalg.norm(d.subtree_com[scene.grip_body[s]] - frame_pos(1 + s)) for s in (0, 1)]),
        shoulder_height=float(np.mean(np.asarray(shoulders)[:, 2])), base_height=float(base[2]),
        height=float(_support(m, d, np.flatnonzero(collide), np.array([0.0, 0.0, 1.0])).max()), clearance=float(clearance),
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
    trunk_gap = (point_segment_distance(axis, seg_a, seg_b) - radius[None]).min()
    base_ok = bool(trunk_gap >= model.trunk_radius + model.clearance)
    out = np.zeros(5, dtype=bool)
    out[0] = base_ok
    if not base_ok:
        return out
    hand_gap = (point_segment_distance(world[1:3], seg_a, seg_b) - radius[None]).min(axis=1)
    shoulder = targets[0] + model.shoulders
    hip = targets[0] + model.hips
    out[1:3] = (np.linalg.norm(targets[1:3] - shoulder, axis=1) <= model.arm) & (
        hand_gap >= model.hand_reach + model.clearance)
    out[3:5] = np.linalg.norm(targets[3:5] - hip, axis=1) <= model.leg
    return out
