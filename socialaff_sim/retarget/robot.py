"""Robot descriptions: an MJCF humanoid plus a small mapping file (see docs/robots.md).

A mapping file (TOML, in ``assets/robots/``) names the model, its five key frames
(base, wrists, ankles, as sites or bodies), where its limb chains start
(shoulders, hips; used to measure limb lengths), which bodies form its hands, and
its home posture. :func:`load_robot` reads and validates one;
:meth:`RobotSpec.build_mjcf` returns a fresh ``dm_control.mjcf`` model of it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from dm_control import mjcf

from ..data.skeletons import KEY_JOINTS
from ..errors import ConfigError, choices
from ..resources import assets_dir
from ._toml import Table, read_toml

__all__ = ["FrameRef", "RobotSpec", "load_robot", "available_robots", "BUILTIN_MODELS"]

ROBOTS_SUBDIR = "robots"
LIMB_FRAMES = ("left_shoulder", "right_shoulder", "left_hip", "right_hip")
FRAME_KINDS = ("site", "body")


def _cmu_humanoid() -> mjcf.RootElement:
    # Imported here: dm_control.locomotion pulls in composer, only needed for this robot.
    from dm_control.locomotion.walkers import cmu_humanoid

    walker = cmu_humanoid.CMUHumanoidPositionControlledV2020()
    return walker.mjcf_model


BUILTIN_MODELS = {"dm_control.cmu_humanoid": _cmu_humanoid}
"""Models loaded from installed packages rather than from an MJCF file."""


@dataclass(frozen=True)
class FrameRef:
    """A frame of the robot model: a site or a body, by its name in the robot's MJCF."""

    kind: str
    """``"site"`` or ``"body"``."""
    name: str
    """Element name inside the robot model (without the scene's namespace prefix)."""

    def __str__(self) -> str:
        return f"{self.kind}:{self.name}"


@dataclass(frozen=True)
class RobotSpec:
    """A humanoid robot usable by the retargeter and the simulator."""

    name: str
    """Short name (``"cmu"``, ``"ours"``, or the mapping file's ``name``)."""
    mapping_file: Path
    """The TOML file this description was read from."""
    description: str
    """One line for humans."""
    mjcf_path: Path | None
    """The MJCF file, or ``None`` for a builtin model."""
    builtin: str | None
    """Key of :data:`BUILTIN_MODELS`, or ``None``."""
    frames: tuple[FrameRef, ...]
    """The five key frames in :data:`~socialaff_sim.data.skeletons.KEY_JOINTS` order."""
    limb_roots: tuple[FrameRef, ...]
    """Left shoulder, right shoulder, left hip, right hip: where the limb chains start."""
    hands: tuple[tuple[str, ...], tuple[str, ...]]
    """Bodies whose subtrees form the left and the right hand."""
    posture_keyframe: str | None
    """Name of a keyframe of the robot model giving its home joint angles, or ``None``."""
    posture_joints: Mapping[str, float] = field(default_factory=dict)
    """Home angles (rad) of individual joints, applied after the keyframe."""
    root_quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    """(w, x, y, z) orientation of the model's root that puts z up and x forward."""
    max_joint_velocity: float = 8.0
    """Velocity limit of every hinge in the IK, rad/s."""

    def build_mjcf(self) -> mjcf.RootElement:
        """A fresh dm_control MJCF model of the robot (safe to modify and attach)."""
        if self.builtin is not None:
            root = BUILTIN_MODELS[self.builtin]()
        else:
            assert self.mjcf_path is not None  # guaranteed by load_robot
            root = mjcf.from_path(str(self.mjcf_path))
        for ref in (*self.frames, *self.limb_roots):
            if root.find(ref.kind, ref.name) is None:
                present = [e.name for e in root.find_all(ref.kind) if e.name]
                raise ConfigError(
                    f"{self.mapping_file}: frame {str(ref)!r} is not in the robot model; "
                    f"{ref.kind}s present: {choices(present[:40])}"
                )
        for side in self.hands:
            for body in side:
                if root.find("body", body) is None:
                    present = [e.name for e in root.find_all("body") if e.name]
                    raise ConfigError(
                        f"{self.mapping_file}: hand body {body!r} is not in the robot model; "
                        f"bodies present: {choices(present[:40])}"
                    )
        joints = {j.name for j in root.find_all("joint")}
        for name in self.posture_joints:
            if name not in joints:
                raise ConfigError(
                    f"{self.mapping_file}: posture.joints names {name!r}, not a joint of the model; "
                    f"joints: {choices(sorted(j for j in joints if j))}"
                )
        if self.posture_keyframe is not None:
            keys = [k.name for k in root.find_all("key")]
            if self.posture_keyframe not in keys:
                raise ConfigError(
                    f"{self.mapping_file}: posture.keyframe {self.posture_keyframe!r} is not in the model; "
                    f"keyframes: {choices(keys)}"
                )
        return root


def available_robots() -> tuple[str, ...]:
    """Names of the mapping files shipped in ``assets/robots/``."""
    return tuple(sorted(p.stem for p in (assets_dir() / ROBOTS_SUBDIR).glob("*.toml")))


def _frame(table: Table, key: str) -> FrameRef:
    text = table.get_str(key)
    kind, sep, name = text.partition(":")
    if not sep or kind not in FRAME_KINDS or not name:
        raise table.error(key, "'site:NAME' or 'body:NAME'", text)
    return FrameRef(kind, name)


def load_robot(robot: str | Path) -> RobotSpec:
    """Read a robot mapping: a shipped name (``"cmu"``, ``"ours"``) or a path to a TOML file."""
    path = Path(robot)
    if path.suffix != ".toml":
        shipped = assets_dir() / ROBOTS_SUBDIR / f"{robot}.toml"
        if not shipped.exists():
            raise ConfigError(
                f"unknown robot {str(robot)!r}; shipped robots: {choices(available_robots())}, "
                "or give the path of a mapping .toml file (see docs/robots.md)"
            )
        path = shipped
    top = Table(read_toml(path), path)
    top.check_keys(["name", "description", "mjcf", "builtin", "frames", "limbs", "hands", "posture", "limits"])
    name = top.get_str("name", path.stem)
    has_file, has_builtin = "mjcf" in top, "builtin" in top
    if has_file == has_builtin:
        raise ConfigError(f"{path}: give exactly one of 'mjcf' (a model file) or 'builtin' ({choices(BUILTIN_MODELS)})")
    mjcf_path: Path | None = None
    builtin: str | None = None
    if has_file:
        mjcf_path = (path.parent / top.get_str("mjcf")).resolve()
        if not mjcf_path.exists():
            raise ConfigError(f"{path}: key 'mjcf': file {mjcf_path} does not exist")
    else:
        builtin = top.get_str("builtin", valid=BUILTIN_MODELS)

    frames_t = top.get_table("frames")
    frames_t.check_keys(KEY_JOINTS)
    frames = tuple(_frame(frames_t, k) for k in KEY_JOINTS)
    limbs_t = top.get_table("limbs")
    limbs_t.check_keys(LIMB_FRAMES)
    limbs = tuple(_frame(limbs_t, k) for k in LIMB_FRAMES)
    hands_t = top.get_table("hands")
    hands_t.check_keys(["left", "right"])
    hands = (tuple(hands_t.get_str_list("left")), tuple(hands_t.get_str_list("right")))

    posture_t = top.get_table("posture", Table({}, path, "posture"))
    posture_t.check_keys(["keyframe", "joints", "root_quat"])
    keyframe = posture_t.get_str("keyframe", None)
    joints: dict[str, float] = {}
    if "joints" in posture_t:
        jt = posture_t.get_table("joints")
        joints = {k: jt.get_float(k) for k in jt.data}
    quat = np.array(posture_t.get_float_list("root_quat", 4, [1.0, 0.0, 0.0, 0.0]))
    if np.linalg.norm(quat) < 1e-9:
        raise posture_t.error("root_quat", "a non-zero quaternion (w, x, y, z)", quat.tolist())
    quat = quat / np.linalg.norm(quat)

    limits_t = top.get_table("limits", Table({}, path, "limits"))
    limits_t.check_keys(["max_joint_velocity"])
    vmax = limits_t.get_float("max_joint_velocity", 8.0, lo=1e-3, hi=1e3)
    return RobotSpec(
        name=name,
        mapping_file=path,
        description=top.get_str("description", ""),
        mjcf_path=mjcf_path,
        builtin=builtin,
        frames=frames,
        limb_roots=limbs,
        hands=hands,
        posture_keyframe=keyframe,
        posture_joints=joints,
        root_quat=(float(quat[0]), float(quat[1]), float(quat[2]), float(quat[3])),
        max_joint_velocity=vmax,
    )
