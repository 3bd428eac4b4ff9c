"""Human-to-robot scaling of the five key joints.

Frames. The *world* frame is the simulator's (the data frame shifted so that the
floor is z = 0). The *robot frame* is fixed at reset: origin on the floor under
the robot's base, x toward the human partner, z up. Targets handed to the IK and
to :meth:`Simulator.step` are in the robot frame, in metres.

Scaling. Agent 1's key joints are read in its own heading frame (origin under its
base at frame 0, x toward agent 0) and mapped limb by limb:

* base: horizontally, the vector from agent 0's base to agent 1's, × k (see
  placement); height: h_r + s_leg · (z − h_h);
* wrist: base + shoulder_r + s_arm · (wrist − base − shoulder_h);
* ankle: base + hip_r + s_leg · (ankle − base − hip_h);

with s_arm = arm_r / arm_h and s_leg = leg_r / leg_h the ratios of limb lengths
(shoulder→elbow→wrist and hip→knee→ankle, measured along the chains on both
bodies) and shoulder/hip offsets measured from the base at rest.

Placement. The robot keeps agent 1's bearing from the partner at every frame but
at k = (arm_0 + arm_r) / (arm_0 + arm_1) times the distance, so that its shorter
(or longer) reach still meets the partner's where the two people touched.

Contact preservation. Near the partner (or the object) the interaction, not the
body, sets where a wrist must be: each wrist target is blended toward agent 1's
unscaled wrist position with weight w = smoothstep((far − d) / (far − near)),
where d is the distance from agent 1's wrist to the nearest joint of agent 0 or
the object. Far from everything the scaled target is used; in contact, the
recorded one, pushed w·δ further toward agent 0's nearest joint so that the
robot's hand closes the gap its different shape leaves (the IK stops it at the
person's surface).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from ..data.interaction import Interaction

__all__ = [
    "ScalingConfig",
    "BodyMeasurements",
    "RobotFrame",
    "measure_human",
    "measure_robot",
    "KeyJointScaler",
    "smoothstep",
]


@dataclass(frozen=True)
class ScalingConfig:
    """Settings of the human-to-robot mapping."""

    contact_near: float = 0.12
    """d_near, metres: at or below this wrist-to-partner distance the recorded wrist position is used."""
    contact_far: float = 0.35
    """d_far, metres: at or above this distance the scaled wrist position is used."""
    contact_push: float = 0.05
    """δ, metres: in contact (weight w) a wrist target is moved w·δ further toward the nearest joint
    of agent 0, so that the robot's hand, shaped unlike a human one, still closes the gap (the IK's
    collision limit stops it a few millimetres into the person)."""
    scale_placement: bool = True
    """Whether the robot's distance to the partner is scaled by the reach ratio (else agent 1's spot is used)."""


@dataclass(frozen=True)
class BodyMeasurements:
    """Limb lengths and offsets of one body, metres."""

    arm: float
    """Shoulder→elbow→wrist chain length (mean of both sides)."""
    leg: float
    """Hip→knee→ankle chain length (mean of both sides)."""
    base_height: float
    """Height of the base above the floor when standing."""
    shoulders: np.ndarray
    """(2, 3) left/right shoulder offset from the base in the body's heading frame (x forward, z up)."""
    hips: np.ndarray
    """(2, 3) left/right hip offset from the base in the heading frame."""


# Typical adult proportions used where a layout lacks the joints to measure them.
_DEFAULT_HUMAN = BodyMeasurements(
    arm=0.56, leg=0.84, base_height=0.95,
    shoulders=np.array([[0.0, 0.18, 0.45], [0.0, -0.18, 0.45]]),
    hips=np.array([[0.0, 0.09, -0.05], [0.0, -0.09, -0.05]]),
)


def smoothstep(x: np.ndarray | float) -> np.ndarray:
    """3x² − 2x³ on [0, 1], clamped outside."""
    x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _yaw_matrix(heading: np.ndarray) -> np.ndarray:
    """(3, 3) rotation whose columns are the heading frame's axes in world coordinates."""
    x = np.array([heading[0], heading[1], 0.0])
    n = np.linalg.norm(x)
    x = np.array([1.0, 0.0, 0.0]) if n < 1e-9 else x / n
    z = np.array([0.0, 0.0, 1.0])
    return np.stack([x, np.cross(z, x), z], axis=1)


@dataclass(frozen=True)
class RobotFrame:
    """The robot frame in world coordinates: a point on the floor and a yaw."""

    origin: np.ndarray
    """(3,) metres, z = 0."""
    rotation: np.ndarray
    """(3, 3): columns are the robot frame's x, y, z axes in world coordinates."""

    @property
    def yaw(self) -> float:
        """Heading angle, radians."""
        return float(np.arctan2(self.rotation[1, 0], self.rotation[0, 0]))

    def to_world(self, p: np.ndarray) -> np.ndarray:
        """Points (..., 3) from the robot frame to the world frame."""
        return np.asarray(p) @ self.rotation.T + self.origin

    def to_robot(self, p: np.ndarray) -> np.ndarray:
        """Points (..., 3) from the world frame to the robot frame."""
        return (np.asarray(p) - self.origin) @ self.rotation


def _chain(joints: np.ndarray, names: tuple[str, ...], parts: tuple[str, ...]) -> float | None:
    if not all(p in names for p in parts):
        return None
    idx = [names.index(p) for p in parts]
    seg = np.linalg.norm(np.diff(joints[:, idx], axis=1), axis=-1)  # (T, len-1)
    ok = np.isfinite(seg).all(axis=1)
    if not ok.any():
        return None
    return float(np.median(seg[ok], axis=0).sum())


def measure_human(inter: Interaction, agent: int, offset: np.ndarray) -> BodyMeasurements:
    """Limb lengths of one agent (medians over frames); typical adult values where joints are missing.

    ``offset`` (3,) shifts the data into the world frame (floor at z = 0).
    """
    joints = inter.filled_joints()[:, agent] + offset
    names = inter.joint_names
    key = inter.key_joints()[:, agent] + offset
    other = inter.key_joints()[0, 1 - agent] + offset
    heading = _yaw_matrix(other[0] - key[0, 0])
    arms = [_chain(joints, names, (f"{s}_shoulder", f"{s}_elbow", f"{s}_wrist")) for s in ("left", "right")]
    if None in arms:
        arms = [_chain(joints, names, (f"{s}_shoulder", f"{s}_elbow", f"{s}_hand")) for s in ("left", "right")]
    legs = [_chain(joints, names, (f"{s}_hip", f"{s}_knee", f"{s}_ankle")) for s in ("left", "right")]
    if None in legs:
        legs = [_chain(joints, names, (f"{s}_hip", f"{s}_knee", f"{s}_foot")) for s in ("left", "right")]
    base = key[:, 0]
    d = _DEFAULT_HUMAN

    def offsets(kind: str, default: np.ndarray) -> np.ndarray:
        out = default.copy()
        for i, s in enumerate(("left", "right")):
            n = f"{s}_{kind}"
            if n in names:
                rel = (joints[:, names.index(n)] - base) @ heading
                ok = np.isfinite(rel).all(axis=1)
                if ok.any():
                    out[i] = np.median(rel[ok], axis=0)
        return out

    height = float(np.nanmedian(base[:, 2])) if np.isfinite(base[:, 2]).any() else d.base_height
    return BodyMeasurements(
        arm=float(np.mean(arms)) if None not in arms else d.arm,  # type: ignore[arg-type]
        leg=float(np.mean(legs)) if None not in legs else d.leg,  # type: ignore[arg-type]
        base_height=height,
        shoulders=offsets("shoulder", d.shoulders),
        hips=offsets("hip", d.hips),
    )


def _path_length(model: mujoco.MjModel, data: mujoco.MjData, root_body: int, kind: str, fid: int) -> float:
    """Length of the chain of body origins from ``root_body`` down to a site or body."""
    if kind == "site":
        body = int(model.site_bodyid[fid])
        total = float(np.linalg.norm(data.site_xpos[fid] - data.xpos[body]))
    else:
        body, total = fid, 0.0
    while body != root_body:
        parent = int(model.body_parentid[body])
        if parent <= 0:
            raise ValueError(f"body {model.body(root_body).name!r} is not an ancestor of the key frame")
        total += float(np.linalg.norm(data.xpos[body] - data.xpos[parent]))
        body = parent
    return total


def measure_robot(model: mujoco.MjModel, qpos: np.ndarray, frame_kinds: tuple[str, ...], frame_ids: np.ndarray,
                  limb_body_ids: np.ndarray) -> BodyMeasurements:
    """Measurements of a robot at ``qpos`` (its home posture, robot frame, facing +x).

    ``limb_body_ids`` (4,): bodies where the left/right arm and left/right leg chains start.
    """
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)

    def pos(kind: str, i: int) -> np.ndarray:
        return np.array(data.site_xpos[i] if kind == "site" else data.xpos[i])

    base = pos(frame_kinds[0], int(frame_ids[0]))
    arms = [_path_length(model, data, int(limb_body_ids[s]), frame_kinds[1 + s], int(frame_ids[1 + s])) for s in (0, 1)]
    legs = [_path_length(model, data, int(limb_body_ids[2 + s]), frame_kinds[3 + s], int(frame_ids[3 + s])) for s in (0, 1)]
    return BodyMeasurements(
        arm=float(np.mean(arms)),
        leg=float(np.mean(legs)),
        base_height=float(base[2]),
        shoulders=np.array([data.xpos[int(limb_body_ids[s])] - base for s in (0, 1)]),
        hips=np.array([data.xpos[int(limb_body_ids[2 + s])] - base for s in (0, 1)]),
    )


class KeyJointScaler:
    """Maps agent 1's key joints (world frame) to robot-frame targets for one instance."""

    def __init__(self, robot: BodyMeasurements, config: ScalingConfig | None = None) -> None:
        self.robot = robot
        self.config = config or ScalingConfig()

    def reset(self, inter: Interaction, offset: np.ndarray) -> RobotFrame:
        """Measure the instance's people and place the robot; returns the robot frame."""
        offset = np.asarray(offset, dtype=np.float64)
        key0 = inter.key_joints()[0] + offset  # (2, 5, 3) at frame 0
        self.human = measure_human(inter, 1, offset)
        partner = measure_human(inter, 0, offset)
        a0 = np.array([key0[0, 0, 0], key0[0, 0, 1], 0.0])
        a1 = np.array([key0[1, 0, 0], key0[1, 0, 1], 0.0])
        self._agent_frame = RobotFrame(a1, _yaw_matrix(a0 - a1))
        k = 1.0
        if self.config.scale_placement:
            k = (partner.arm + self.robot.arm) / (partner.arm + self.human.arm)
        self.k = k
        origin = a0 + (a1 - a0) * k
        self.frame = RobotFrame(origin, _yaw_matrix(a0 - a1))
        idx = inter.layout.key_indices[0]
        self._partner_base = 0 if idx is None else idx
        self.s_arm = self.robot.arm / self.human.arm
        self.s_leg = self.robot.leg / self.human.leg
        return self.frame

    def scaled(self, keys: np.ndarray, partner_base: np.ndarray) -> np.ndarray:
        """(5, 3) robot-frame targets from agent 1's key joints ``keys`` (5, 3), world frame, by scaling alone.

        ``partner_base`` (3,): agent 0's base at the same frame, world frame.
        """
        h, r = self.human, self.robot
        keys = np.asarray(keys, dtype=np.float64)
        local = self._agent_frame.to_robot(keys)
        base = local[0]
        p0 = np.asarray(partner_base, dtype=np.float64)
        placed = self.frame.to_robot(p0 + self.k * (keys[0] - p0))
        out = np.empty((5, 3))
        out[0] = (placed[0], placed[1], r.base_height + self.s_leg * (base[2] - h.base_height))
        out[1:3] = out[0] + r.shoulders + self.s_arm * (local[1:3] - base - h.shoulders)
        out[3:5] = out[0] + r.hips + self.s_leg * (local[3:5] - base - h.hips)
        return out

    def _nearest(self, keys: np.ndarray, partner: np.ndarray, obj: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Distance (2,), nearest anchor (2, 3) and whether it is a joint of agent 0 (2,) for each wrist."""
        anchors = partner if obj is None else np.vstack([partner, obj[None]])
        is_joint = np.arange(len(anchors)) < len(partner)
        ok = np.isfinite(anchors).all(axis=1)
        anchors, is_joint = anchors[ok], is_joint[ok]
        if len(anchors) == 0:
            return np.full(2, np.inf), np.zeros((2, 3)), np.zeros(2, dtype=bool)
        d = np.linalg.norm(keys[1:3, None, :] - anchors[None], axis=-1)
        j = d.argmin(axis=1)
        return d[[0, 1], j], anchors[j], is_joint[j]

    def contact_weights(self, keys: np.ndarray, partner: np.ndarray, obj: np.ndarray | None = None) -> np.ndarray:
        """(2,) blend weight of the recorded position for the left and right wrist.

        ``partner`` (J, 3): agent 0's joints; ``obj`` (3,) or ``None``; all world frame.
        """
        d, _, _ = self._nearest(np.asarray(keys, dtype=np.float64), partner, obj)
        c = self.config
        return smoothstep((c.contact_far - d) / (c.contact_far - c.contact_near))

    def __call__(self, keys: np.ndarray, partner: np.ndarray, obj: np.ndarray | None = None) -> np.ndarray:
        """(5, 3) robot-frame targets: scaled, with wrists blended toward the recording near contacts."""
        keys = np.asarray(keys, dtype=np.float64)
        p0 = partner[self._partner_base]
        if not np.isfinite(p0).all():
            p0 = self.frame.origin + self.frame.rotation[:, 0]
        out = self.scaled(keys, p0)
        c = self.config
        d, anchor, is_joint = self._nearest(keys, partner, obj)
        w = smoothstep((c.contact_far - d) / (c.contact_far - c.contact_near))
        recorded = keys[1:3].copy()
        toward = anchor - recorded
        n = np.linalg.norm(toward, axis=1, keepdims=True)
        unit = np.divide(toward, n, out=np.zeros_like(toward), where=n > 1e-9)
        recorded += (w * c.contact_push * is_joint)[:, None] * unit
        out[1:3] = w[:, None] * self.frame.to_robot(recorded) + (1.0 - w[:, None]) * out[1:3]
        return out
