"""Where the robot stands: the bounds on the placement factor k of :class:`~.scaling.KeyJointScaler`.

The robot's base stands at p₀ + k·(b₁ − p₀) horizontally (p₀ agent 0's base, b₁ agent 1's; the
placement in :mod:`~socialaff_sim.retarget.scaling`'s notes). Each function here answers one question about
k, all points in the world frame, metres:

* :func:`k_within_reach`: the largest k keeping contact samples within the robot's reach (a quadratic
  in k per sample: the robot's shoulder, moving with k, within ``extension``·arm of the wrist);
* :func:`k_clear_of_trunk`: the smallest k keeping the samples' wrists outside the robot's trunk
  (a quadratic in k per sample: |w − p₀ − k·(b₁ − p₀)| ≥ trunk radius + clearance horizontally);
* :func:`body_clearance_k`, :func:`frame_clearance_k`: the smallest k (scanned in steps of 0.01) at which
  the robot's trunk clears the partner's trunk, head and legs by ``body_clearance``, over a whole instance
  or at one frame.
"""

from __future__ import annotations

import numpy as np

from ..data.interaction import Interaction
from .measure import BodyMeasurements
from .scaling_config import ScalingConfig

__all__ = ["k_within_reach", "k_clear_of_trunk", "body_clearance_k", "frame_clearance_k", "is_body_joint"]


def is_body_joint(name: str) -> bool:
    """Whether joint ``name`` is of the trunk, head or legs (not of an arm): what the robot's trunk keeps clear of."""
    return not any(p in name for p in ("elbow", "wrist", "hand", "thumb", "tip"))


def k_within_reach(wrist: np.ndarray, base1: np.ndarray, p0: np.ndarray, side: np.ndarray, rotation: np.ndarray,
                   robot: BodyMeasurements, human: BodyMeasurements, s_leg: float, extension: np.ndarray
                   ) -> float | None:
    """The largest k keeping N contact samples within the robot's reach, ``None`` when no sample can be.

    ``wrist``, ``base1``: agent 1's wrist and base, ``p0``: agent 0's base (N, 3), world frame; ``side`` (N,):
    the wrist's side (0 left, 1 right); ``rotation`` (3, 3): the robot frame's axes in the world; ``robot``,
    ``human``: the robot's and agent 1's measurements; ``s_leg``: their leg ratio (the base height's scale);
    ``extension`` (N,): the fraction of the robot's arm each sample may use.
    """
    reach = extension * robot.arm
    # Robot shoulder for placement k: p₀ + k·(b₁ − p₀) horizontally, at the scaled base height, plus its offset.
    D = np.zeros_like(base1)
    D[:, :2] = base1[:, :2] - p0[:, :2]
    A = np.zeros_like(base1)
    A[:, :2] = p0[:, :2]
    A[:, 2] = robot.base_height + s_leg * (base1[:, 2] - human.base_height)
    A += robot.shoulders[side] @ rotation.T - wrist
    dd = np.einsum("ij,ij->i", D, D)
    ad = np.einsum("ij,ij->i", A, D)
    aa = np.einsum("ij,ij->i", A, A)
    disc = ad * ad - dd * (aa - reach * reach)
    # Largest k within reach. A sample no placement brings within reach (a contact far below
    # a tall robot's shoulders, which it meets by bending) says nothing about where to stand.
    valid = (dd > 1e-6) & (disc >= 0)
    if not valid.any():
        return None
    upper = (-ad[valid] + np.sqrt(disc[valid])) / dd[valid]
    return float(upper.min())


def k_clear_of_trunk(wrist: np.ndarray, base1: np.ndarray, p0: np.ndarray, trunk_radius: float,
                     clearance: float) -> float | None:
    """The smallest k putting every contact sample's ``wrist`` (N, 3) at least ``trunk_radius`` + ``clearance``
    (m) horizontally from the robot's base axis, agent 1's base ``base1`` and agent 0's ``p0`` (N, 3) world
    frame; ``None`` when no sample needs it (the wrist is clear at every k) or the robot has no trunk radius."""
    if trunk_radius <= 0:
        return None
    r = trunk_radius + clearance
    W = wrist[:, :2] - p0[:, :2]
    D = base1[:, :2] - p0[:, :2]
    # |W − k·D| ≥ r: outside the roots of a quadratic in k; the robot stands back (the larger root).
    dd = np.einsum("ij,ij->i", D, D)
    wd = np.einsum("ij,ij->i", W, D)
    disc = wd * wd - dd * (np.einsum("ij,ij->i", W, W) - r * r)
    need = (dd > 1e-6) & (disc > 0)
    if not need.any():
        return None
    return float(((wd[need] + np.sqrt(disc[need])) / dd[need]).max())


def body_clearance_k(inter: Interaction, offset: np.ndarray, partner_base: int, k0: float, robot: BodyMeasurements,
                     config: ScalingConfig) -> float:
    """The smallest k ≥ ``k0`` (in steps of 0.01, up to ``config.k_max``) at which the robot's trunk clears the
    partner's trunk, head and legs by ``config.body_clearance`` at every frame of ``inter`` (``k0`` when it
    already does). ``offset`` (3,): the data-to-world shift; ``partner_base``: agent 0's base joint index."""
    c, r = config, robot
    names = inter.joint_names
    body = [j for j, n in enumerate(names) if is_body_joint(n)]
    joints = inter.filled_joints()[:, 0][:, body] + offset  # (T, J, 3) the partner's body joints
    keys = inter.key_joints()[:, 1] + offset
    p0 = (inter.filled_joints()[:, 0, partner_base] + offset)[:, :2]
    D = keys[:, 0, :2] - p0  # (T, 2)
    ok = np.isfinite(D).all(axis=1) & np.isfinite(p0).all(axis=1)
    top = r.height if r.height > 0 else np.inf
    relevant = np.isfinite(joints).all(axis=2) & (joints[..., 2] <= top) & ok[:, None]
    if not relevant.any():
        return k0
    ks = np.arange(k0, max(k0, c.k_max) + 1e-9, 0.01)
    base = p0[None, :, :] + ks[:, None, None] * D[None, :, :]  # (K, T, 2)
    gap = np.linalg.norm(base[:, :, None, :] - joints[None, :, :, :2], axis=-1)  # (K, T, J)
    clear = np.where(relevant[None], gap >= r.trunk_radius + c.body_clearance, True).all(axis=(1, 2))
    return float(ks[np.argmax(clear)]) if clear.any() else float(ks[-1])


def frame_clearance_k(body: np.ndarray, base1: np.ndarray, p0: np.ndarray, k: float, robot: BodyMeasurements,
                      config: ScalingConfig) -> float:
    """The smallest k (steps of 0.01 from ``config.k_min`` up to ``k``) at which the robot's trunk clears agent 0's
    trunk, head and legs ``body`` (J, 3) of one frame by ``config.body_clearance``, agent 1's base ``base1`` and
    agent 0's ``p0`` (3,), world frame (``k`` when none does; ``k_min`` without a trunk or a finite joint)."""
    c, r = config, robot
    joints = body[np.isfinite(body).all(axis=1)]
    if r.trunk_radius <= 0 or not len(joints):
        return c.k_min
    ks = np.arange(c.k_min, max(c.k_min, k) + 1e-9, 0.01)
    base = p0[None, :2] + ks[:, None] * (base1[:2] - p0[:2])[None]  # (K, 2)
    gap = np.linalg.norm(base[:, None, :] - joints[None, :, :2], axis=-1).min(axis=1)
    clear = gap >= r.trunk_radius + c.body_clearance
    return float(ks[np.argmax(clear)]) if clear.any() else k
