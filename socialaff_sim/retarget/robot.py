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
from .model_prep import FRAME_SITE_PREFIX, FrameRef, keyframe_angles, prepare_model

__all__ = ["FrameRef", "RobotSpec", "load_robot", "available_robots", "BUILTIN_MODELS", "PHYSICS_MODES"]

ROBOTS_SUBDIR = "robots"
LIMB_FRAMES = ("left_shoulder", "right_shoulder", "left_hip", "right_hip")
FRAME_KINDS = ("site", "body")
PHYSICS_MODES = ("harness", "standing")
"""The simulator's named physics modes (``SimConfig.harness``, the robot's root hanging from a compliant harness,
and ``SimConfig.standing``, on its own feet): what a mapping's ``physics`` key may name."""


def _cmu_humanoid() -> mjcf.RootElement:
    # Imported here: dm_control.locomotion pulls in composer, only needed for this robot.
    from dm_control.locomotion.walkers import cmu_humanoid

    walker = cmu_humanoid.CMUHumanoidPositionControlledV2020()
    return walker.mjcf_model


BUILTIN_MODELS = {"dm_control.cmu_humanoid": _cmu_humanoid}
"""Models loaded from installed packages rather than from an MJCF file."""


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
    ignore_bodies: tuple[str, ...] = ()
    """Top-level bodies of the MJCF that are not part of the robot (H1's dummy ``not_use_body``): removed,
    with the joints, actuators, sensors and equalities that refer to them."""
    mjcf_source: str = ""
    """Where a user gets the model when the mapping does not point at a file (shown in errors)."""
    physics: str = "harness"
    """The physics mode the simulator runs this robot in when it is given none (one of :data:`PHYSICS_MODES`;
    the mapping's ``physics`` key): each robot's own, because a mode is adopted per robot by its measured
    figures (docs/design.md §5)."""

    def build_mjcf(self) -> mjcf.RootElement:
        """A fresh dm_control MJCF model of the robot (safe to modify and attach); see :meth:`build_model`."""
        return self.build_model()[0]

    def build_model(self) -> tuple[mjcf.RootElement, dict[str, float]]:
        """A fresh dm_control MJCF model of the robot and its home joint angles by joint name (rad).

        The model is made attachable: the root body's own free joint, if any, is removed (the
        simulator adds one), as are sensors, ``ignore_bodies`` and what refers to them; the
        frames given as body offsets get their sites.
        """
        if self.builtin is not None:
            root = BUILTIN_MODELS[self.builtin]()
        else:
            if self.mjcf_path is None:
                raise ConfigError(
                    f"{self.mapping_file}: robot {self.name!r} needs its MJCF model, which the project does not "
                    f"ship: give its path (--mjcf PATH, or load_robot({self.name!r}, mjcf=PATH))"
                    + (f"; the model: {self.mjcf_source}" if self.mjcf_source else "")
                )
            try:
                root = mjcf.from_path(str(self.mjcf_path))
            except (ValueError, OSError) as exc:  # dm_control raises ValueError on bad XML or missing meshes
                raise ConfigError(f"{self.mapping_file}: the robot model {self.mjcf_path} cannot be read: {exc}") from None
        if self.posture_keyframe is not None:
            keys = [k.name for k in root.find_all("key")]
            if self.posture_keyframe not in keys:
                raise ConfigError(
                    f"{self.mapping_file}: posture.keyframe {self.posture_keyframe!r} is not in the model; "
                    f"keyframes: {choices(keys)}"
                )
        home = keyframe_angles(root, self.posture_keyframe)
        prepare_model(root, self.mapping_file, self.ignore_bodies, self.frames)
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
        home = {k: v for k, v in home.items() if k in joints}
        home.update(self.posture_joints)
        for key in root.find_all("key"):
            key.remove()
        return root, home


def available_robots() -> tuple[str, ...]:
    """Names of the mapping files shipped in ``assets/robots/``."""
    return tuple(sorted(p.stem for p in (assets_dir() / ROBOTS_SUBDIR).glob("*.toml")))


def _frame(table: Table, key: str) -> FrameRef:
    if isinstance(table.data.get(key), dict):
        sub = table.get_table(key)
        sub.check_keys(["body", "pos"])
        body = sub.get_str("body")
        pos = sub.get_float_list("pos", 3, [0.0, 0.0, 0.0])
        return FrameRef("site", f"{FRAME_SITE_PREFIX}{key}", body, (pos[0], pos[1], pos[2]))
    text = table.get_str(key)
    kind, sep, name = text.partition(":")
    if not sep or kind not in FRAME_KINDS or not name:
        raise table.error(key, "'site:NAME', 'body:NAME' or { body = NAME, pos = [x, y, z] }", text)
    return FrameRef(kind, name)


def load_robot(robot: str | Path, mjcf: str | Path | None = None) -> RobotSpec:
    """Read a robot mapping: a shipped name (``"cmu"``, ``"ours"``, ``"unitree_h1"``...) or a path to a TOML file.

    ``mjcf``: the robot's MJCF file, overriding the mapping's ``mjcf`` key (the shipped mappings of
    robots whose models the project does not ship, such as the Unitree ones, need it).
    """
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
    top.check_keys(["name", "description", "mjcf", "mjcf_source", "builtin", "ignore_bodies", "frames", "limbs",
                    "hands", "posture", "limits", "physics"])
    name = top.get_str("name", path.stem)
    source = top.get_str("mjcf_source", "")
    has_file, has_builtin = "mjcf" in top, "builtin" in top
    if has_file and has_builtin:
        raise ConfigError(f"{path}: give at most one of 'mjcf' (a model file) or 'builtin' ({choices(BUILTIN_MODELS)})")
    if has_builtin and mjcf is not None:
        raise ConfigError(f"{path}: robot {name!r} is a builtin model ({top.get_str('builtin')}); it takes no --mjcf")
    if not has_file and not has_builtin and not source:
        raise ConfigError(f"{path}: give one of 'mjcf' (a model file), 'builtin' ({choices(BUILTIN_MODELS)}) "
                          "or 'mjcf_source' (where users get the model they pass with --mjcf)")
    mjcf_path: Path | None = None
    builtin: str | None = None
    if mjcf is not None:
        mjcf_path = Path(mjcf).expanduser().resolve()
        if not mjcf_path.is_file():
            raise ConfigError(f"--mjcf: file {mjcf_path} does not exist (the MJCF model of robot {name!r})")
    elif has_file:
        mjcf_path = (path.parent / top.get_str("mjcf")).resolve()
        if not mjcf_path.exists():
            raise ConfigError(f"{path}: key 'mjcf': file {mjcf_path} does not exist")
    elif has_builtin:
        builtin = top.get_str("builtin", valid=BUILTIN_MODELS)
    else:
        raise ConfigError(
            f"{path}: robot {name!r} needs its MJCF model, which the project does not ship: give its path "
            f"(--mjcf PATH, or load_robot({name!r}, mjcf=PATH)); the model: {source}"
        )
    ignore = tuple(top.get_str_list("ignore_bodies", []))
    physics = top.get_str("physics", "harness", valid=PHYSICS_MODES)

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
        ignore_bodies=ignore,
        mjcf_source=source,
        physics=physics,
    )
