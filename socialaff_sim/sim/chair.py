"""The chair a seated person rises from (tasks with ``chair = true``, e.g. ``pull_up``).

:func:`add_chair` writes a mocap body ``chair`` into the physics scene: a seat,
four legs and a backrest, seen but not touched (no contacts: the person is a
replay and sits on it by construction, and the robot never reaches behind the
person). :func:`chair_pose` puts it under agent 0's thighs at the episode's first
frame: the seat's top at the lowest point of the thigh capsules, the seat's front
edge under the knees' middle, the backrest behind the hips, turned to face the
way the person faces (toward the robot).
"""

from __future__ import annotations

import mujoco
import numpy as np
from dm_control import mjcf

from ..errors import SimulationError
from .human import HumanBody

__all__ = ["add_chair", "chair_pose", "place_chair", "CHAIR_RGBA", "SEAT_HALF", "SEAT_THICKNESS"]

CHAIR_RGBA = (0.55, 0.38, 0.22, 1.0)
SEAT_HALF = 0.22
"""Half the seat's width and depth, m."""
SEAT_THICKNESS = 0.04
"""The seat board's thickness, m."""
_LEG_HEIGHT = 0.45
"""Legs modelled long enough for any seat; the part below the floor is hidden by it."""


def add_chair(root: mjcf.RootElement) -> None:
    """Add the mocap body ``chair`` to ``root``: its frame at the seat top's centre, x toward the seat's front."""
    chair = root.worldbody.add("body", name="chair", mocap=True, pos=(0.0, 0.0, -5.0))
    look = {"contype": 0, "conaffinity": 0, "rgba": CHAIR_RGBA, "group": 2}
    chair.add("geom", name="chair_seat", type="box", size=(SEAT_HALF, SEAT_HALF, SEAT_THICKNESS / 2),
              pos=(0.0, 0.0, -SEAT_THICKNESS / 2), **look)
    inner = SEAT_HALF - 0.03
    for i, (x, y) in enumerate(((inner, inner), (inner, -inner), (-inner, inner), (-inner, -inner))):
        chair.add("geom", name=f"chair_leg{i}", type="box", size=(0.02, 0.02, _LEG_HEIGHT),
                  pos=(x, y, -SEAT_THICKNESS - _LEG_HEIGHT), **look)
    chair.add("geom", name="chair_back", type="box", size=(0.02, SEAT_HALF, 0.22),
              pos=(-SEAT_HALF + 0.02, 0.0, 0.22), **look)


def chair_pose(body: HumanBody, joints: np.ndarray, radii: np.ndarray, facing_yaw: float) -> tuple[np.ndarray, np.ndarray]:
    """(position (3,), quaternion (4,)) of the chair under a seated person.

    ``joints`` (J, 3): agent 0's joints at the first frame, world frame, metres; ``radii`` (B,): the capsules'
    radii; ``facing_yaw`` (rad): the direction the person faces. The thighs are the bones ending at a knee.
    """
    names = body.layout.joint_names
    thighs = [i for i, (_, c) in enumerate(body.bones) if "knee" in names[c]]
    if not thighs:
        raise SimulationError(f"layout {body.layout.name!r} has no thigh bones (hip to knee) to seat a person on")
    ends = joints[body.bones[thighs]]  # (k, 2, 3): hip and knee of each thigh
    top = float((ends[..., 2].min(axis=1) - radii[thighs]).min())
    forward = np.array([np.cos(facing_yaw), np.sin(facing_yaw)])
    knees = ends[:, 1, :2].mean(axis=0)
    hips = ends[:, 0, :2].mean(axis=0)
    # The seat's front edge under the knees' middle (at most a seat's depth ahead of the hips).
    reach = float(np.clip(np.dot(knees - hips, forward), 0.0, 2 * SEAT_HALF))
    centre = hips + (reach - SEAT_HALF) * forward
    quat = np.array([np.cos(facing_yaw / 2), 0.0, 0.0, np.sin(facing_yaw / 2)])
    return np.array([centre[0], centre[1], max(top, SEAT_THICKNESS)]), quat


def place_chair(model: mujoco.MjModel, data: mujoco.MjData, pos: np.ndarray, quat: np.ndarray) -> bool:
    """Move the scene's chair (if it has one) to ``pos`` / ``quat``; whether it has one."""
    body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "chair")
    if body < 0:
        return False
    mocap = int(model.body_mocapid[body])
    data.mocap_pos[mocap] = pos
    data.mocap_quat[mocap] = quat
    return True
