"""Making a robot's own MJCF attachable to the scene (real robot models as their makers ship them).

:func:`prepare_model` works on the ``dm_control.mjcf`` tree of a robot, in place:

* bodies listed in the mapping's ``ignore_bodies`` (H1's dummy ``not_use_body``)
  are removed, with every actuator, sensor and equality that refers to their joints;
* the model must then have one top-level body, the robot's root;
* the root body's own free joint is removed: the simulator attaches the root
  under a free joint of its own (a free joint deeper in the tree is an error);
* sensors are removed (the simulator reads the state itself; a sensor of a
  removed element would not compile);
* a key frame given as an offset from a body (a robot without a wrist body: the
  H1's ball hand is part of its forearm) becomes a site on that body.

Errors name the mapping file and list what the model contains.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from dm_control import mjcf

from ..errors import ConfigError, choices

__all__ = ["FRAME_SITE_PREFIX", "FrameRef", "prepare_model", "body_names", "keyframe_angles"]

FRAME_SITE_PREFIX = "keyframe_"
"""Name prefix of the sites added for key frames given as body offsets."""


@dataclass(frozen=True)
class FrameRef:
    """A frame of the robot model: a site or a body, by its name in the robot's MJCF."""

    kind: str
    """``"site"`` or ``"body"``."""
    name: str
    """Element name inside the robot model (without the scene's namespace prefix)."""
    body: str | None = None
    """For a frame given as an offset from a body (``{ body = ..., pos = [...] }``): that body. The
    mapping then adds a site ``name`` there (:meth:`RobotSpec.build_mjcf`); ``None`` otherwise."""
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Offset (m) of the added site in ``body``'s frame."""

    def __str__(self) -> str:
        if self.body is not None:
            return f"body:{self.body}+{list(self.pos)}"
        return f"{self.kind}:{self.name}"


def body_names(root: mjcf.RootElement) -> list[str]:
    """Names of the model's bodies, in tree order (unnamed ones left out)."""
    return [b.name for b in root.find_all("body") if b.name]


def _ref_name(value: object) -> str | None:
    """The name an MJCF reference attribute points at (an element or a string)."""
    if value is None:
        return None
    return str(getattr(value, "name", value))


def keyframe_angles(root: mjcf.RootElement, keyframe: str | None) -> dict[str, float]:
    """Angles (rad) of the hinge and slide joints in keyframe ``keyframe`` of the unmodified model, by joint name.

    A keyframe's qpos lists every joint's coordinates in tree order (free joints 7, ball joints 4).
    """
    if keyframe is None:
        return {}
    key = root.find("key", keyframe)
    values = [float(v) for v in (key.qpos if key.qpos is not None else [])]
    home: dict[str, float] = {}
    i = 0
    for j in root.find_all("joint"):
        width = {"free": 7, "ball": 4}.get(_joint_type(j) or "hinge", 1)
        if width == 1 and i < len(values) and j.name:
            home[j.name] = values[i]
        i += width
    return home


def _joint_type(el: mjcf.Element) -> str | None:
    """``"free"``, ``"ball"``, ``"hinge"``, ``"slide"`` for a joint element (``<freejoint>`` too); ``None`` otherwise."""
    if el.tag == "freejoint":
        return "free"
    if el.tag != "joint":
        return None
    return el.type or "hinge"


def _remove_body(root: mjcf.RootElement, mapping_file: Path, name: str) -> None:
    body = root.find("body", name)
    if body is None:
        raise ConfigError(f"{mapping_file}: ignore_bodies names {name!r}, not a body of the model; "
                          f"bodies: {choices(body_names(root))}")
    joints = {j.name for j in body.find_all("joint") if j.name}
    bodies = {name} | {b.name for b in body.find_all("body") if b.name}
    for act in list(root.find_all("actuator")):
        if _ref_name(getattr(act, "joint", None)) in joints:
            act.remove()
    for sensor in list(root.sensor.all_children()):
        if _ref_name(getattr(sensor, "joint", None)) in joints or _ref_name(getattr(sensor, "body", None)) in bodies:
            sensor.remove()
    for eq in list(root.equality.all_children()):
        refs = {_ref_name(getattr(eq, a, None)) for a in ("joint1", "joint2", "body1", "body2")}
        if refs & (joints | bodies):
            eq.remove()
    for pair in list(root.contact.all_children()):
        if {_ref_name(getattr(pair, a, None)) for a in ("body1", "body2")} & bodies:
            pair.remove()
    body.remove()


def prepare_model(root: mjcf.RootElement, mapping_file: Path, ignore_bodies: Sequence[str],
                  frames: Sequence[FrameRef]) -> None:
    """Make ``root`` (the robot's MJCF) attachable under the scene's free joint; see the module docstring.

    ``mapping_file`` names the mapping in errors; ``ignore_bodies`` and ``frames`` are the mapping's."""
    for name in ignore_bodies:
        _remove_body(root, mapping_file, name)
    tops = [b for b in root.worldbody.all_children() if b.tag == "body"]
    if len(tops) != 1:
        raise ConfigError(
            f"{mapping_file}: the robot model must have exactly one top-level body (the robot's root), "
            f"found {len(tops)}: {choices([b.name or '(unnamed)' for b in tops])}; list the others in "
            "'ignore_bodies'"
        )
    top = tops[0]
    for j in top.all_children():
        if _joint_type(j) == "free":
            j.remove()
    for j in root.find_all("joint"):
        if _joint_type(j) in ("free", "ball"):
            where = j.parent.name or "(unnamed)"
            raise ConfigError(f"{mapping_file}: joint {j.name or '(unnamed)'!r} of body {where!r} is a "
                              f"{_joint_type(j)} joint; only the root may be free, and joints below it must be "
                              "hinges or slides")
    for sensor in list(root.sensor.all_children()):
        sensor.remove()
    for ref in frames:
        if ref.body is None:
            continue
        body = root.find("body", ref.body)
        if body is None:
            raise ConfigError(f"{mapping_file}: frame {str(ref)!r}: body {ref.body!r} is not in the robot model; "
                              f"bodies: {choices(body_names(root))}")
        body.add("site", name=ref.name, pos=list(ref.pos), size=[0.01], group=5)
