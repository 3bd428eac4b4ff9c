"""Declarative task files (``envs/<interaction>.toml``): sub-goals and failures scored by physics.

The format is documented in docs/task_format.md. :func:`load_task` reads and
validates one file; every error names the file, the key, what was expected and
the valid choices.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..data.interaction import LABEL_PATTERN
from ..errors import ConfigError, choices
from ..resources import envs_dir, task_file_path
from ..retarget._toml import Table, read_toml
from .scene import ObjectSpec

__all__ = [
    "ROBOT_GROUPS",
    "HUMAN_GROUPS",
    "SUBGOAL_KINDS",
    "ABOVE_CHOICES",
    "FAILURE_KINDS",
    "ObjectTask",
    "SubgoalSpec",
    "FailureSpec",
    "TaskSpec",
    "load_task",
    "task_for_label",
    "available_tasks",
]

ROBOT_GROUPS = ("left_hand", "right_hand", "hands", "arms", "body")
"""Contact groups of the robot (``arms``: both forearms and hands)."""
HUMAN_GROUPS = ("left_hand", "right_hand", "hands", "left_wrist", "right_wrist", "wrists", "body")
"""Contact groups of the replayed human (agent 0); see :func:`socialaff_sim.sim.human.human_body`."""
SUBGOAL_KINDS = ("contact", "object_in_hand", "catch")
FAILURE_KINDS = ("self_collision", "contact_force", "object_dropped")
ABOVE_CHOICES = ("none", "robot_shoulders")
"""Height conditions of a ``contact`` sub-goal's contacts (``above``)."""
OBJECT_SHAPES = {"sphere": 1, "cylinder": 2, "box": 3}
CARRIERS = ("auto", "left_hand", "right_hand")


@dataclass(frozen=True)
class ObjectTask:
    """The task's object and how the human carries it."""

    spec: ObjectSpec
    carried_by: str
    """Which of the human's hands holds the object before release (``auto``: the nearer one)."""
    release_distance: float
    """The human holds the object while its distance to that hand stays within this much of the
    distance at the start (the hold offset), metres."""


@dataclass(frozen=True)
class SubgoalSpec:
    """One sub-goal scored by physics."""

    name: str
    kind: str
    """``contact``: robot group touches human group for ``min_duration`` s in total;
    ``object_in_hand``: the object rests in a robot hand over the last ``min_duration`` s
    and never touched the floor after release; ``catch``: after release the object
    touches a robot hand before touching the floor."""
    robot: str
    """Robot contact group."""
    human: str | None
    """Human contact group (``contact`` only)."""
    min_duration: float
    """Seconds."""
    subevents: tuple[str, ...]
    """Count contact only during these sub-events (empty: always)."""
    above: str = "none"
    """``contact`` only: ``robot_shoulders`` counts a contact only when its point (MuJoCo contact ``pos``)
    is at or above the mean height z (m) of the robot's two shoulder bodies at that physics step;
    ``none``: at any height."""


@dataclass(frozen=True)
class FailureSpec:
    """One failure condition."""

    kind: str
    """``self_collision``: two robot geoms interpenetrate by more than ``threshold`` m;
    ``contact_force``: the robot pushes on the human with more than ``threshold`` N in total;
    ``object_dropped``: the object touches the floor after release."""
    threshold: float


@dataclass(frozen=True)
class TaskSpec:
    """A validated task file."""

    path: Path
    interaction: str
    aliases: tuple[str, ...]
    description: str
    object: ObjectTask | None
    subgoals: tuple[SubgoalSpec, ...]
    failures: tuple[FailureSpec, ...]
    chair: bool = False
    """Whether the scene has a chair under the person at the first frame (:mod:`~socialaff_sim.sim.chair`)."""

    @property
    def labels(self) -> tuple[str, ...]:
        """The interaction name and its aliases."""
        return (self.interaction, *self.aliases)

    @property
    def counts_above(self) -> bool:
        """Whether a sub-goal counts its contact only above a height (``SubgoalSpec.above`` not ``none``: the high
        five's palms above the robot's shoulders)."""
        return any(sg.above != "none" for sg in self.subgoals)

    @property
    def has_catch(self) -> bool:
        """Whether a sub-goal is a ``catch`` (an object thrown to the robot)."""
        return any(sg.kind == "catch" for sg in self.subgoals)


def available_tasks() -> tuple[str, ...]:
    """Names of the shipped task files."""
    return tuple(sorted(p.stem for p in envs_dir().glob("*.toml")))


def _object(t: Table) -> ObjectTask:
    t.check_keys(["shape", "size", "mass", "carried_by", "release_distance"])
    shape = t.get_str("shape", valid=OBJECT_SHAPES)
    n = OBJECT_SHAPES[shape]
    size = t.get_float_list("size", n)
    if min(size) <= 0:
        raise t.error("size", f"{n} positive sizes in metres", size)
    mass = t.get_float("mass", lo=1e-3, hi=50.0)
    return ObjectTask(
        spec=ObjectSpec(shape, tuple(size), mass),
        carried_by=t.get_str("carried_by", "auto", valid=CARRIERS),
        release_distance=t.get_float("release_distance", 0.15, lo=0.0, hi=2.0),
    )


def _subgoal(t: Table, has_object: bool) -> SubgoalSpec:
    t.check_keys(["name", "kind", "robot", "human", "min_duration", "subevents", "above"])
    name = t.get_str("name")
    if not LABEL_PATTERN.match(name):
        raise t.error("name", "a snake_case name like 'hands_touch'", name)
    kind = t.get_str("kind", valid=SUBGOAL_KINDS)
    robot = t.get_str("robot", "hands", valid=ROBOT_GROUPS)
    human = None
    if kind != "contact" and "above" in t:
        raise ConfigError(f"{t.path}: key {t.key('above')!r} only applies to kind 'contact', not {kind!r}")
    if kind == "contact":
        human = t.get_str("human", valid=HUMAN_GROUPS)
    elif "human" in t:
        raise ConfigError(f"{t.path}: key {t.key('human')!r} only applies to kind 'contact', not {kind!r}")
    elif not has_object:
        raise ConfigError(f"{t.path}: sub-goal {name!r} of kind {kind!r} needs an [object] table in the file")
    default = 0.2 if kind != "catch" else 0.0
    return SubgoalSpec(
        name=name, kind=kind, robot=robot, human=human,
        min_duration=t.get_float("min_duration", default, lo=0.0, hi=60.0),
        subevents=tuple(t.get_str_list("subevents", [])),
        above=t.get_str("above", "none", valid=ABOVE_CHOICES),
    )


_DEFAULT_THRESHOLD = {"self_collision": 0.02, "contact_force": 280.0, "object_dropped": 0.0}


def _failure(t: Table, has_object: bool) -> FailureSpec:
    t.check_keys(["kind", "threshold"])
    kind = t.get_str("kind", valid=FAILURE_KINDS)
    if kind == "object_dropped" and not has_object:
        raise ConfigError(f"{t.path}: failure 'object_dropped' needs an [object] table in the file")
    return FailureSpec(kind, t.get_float("threshold", _DEFAULT_THRESHOLD[kind], lo=0.0))


def load_task(task: str | Path) -> TaskSpec:
    """Read a task file: a shipped name (``"shake_hands"``) or a path to a ``.toml`` file."""
    path = Path(task) if str(task).endswith(".toml") else task_file_path(str(task))
    top = Table(read_toml(path), path)
    top.check_keys(["interaction", "aliases", "description", "object", "chair", "subgoal", "failure"])
    interaction = top.get_str("interaction")
    if not LABEL_PATTERN.match(interaction):
        raise top.error("interaction", "a snake_case label like 'shake_hands'", interaction)
    aliases = tuple(top.get_str_list("aliases", []))
    obj = _object(top.get_table("object")) if "object" in top else None
    subgoals = tuple(_subgoal(t, obj is not None) for t in top.get_tables("subgoal"))
    if not subgoals:
        raise top.error("subgoal", "at least one [[subgoal]] table")
    names = [s.name for s in subgoals]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ConfigError(f"{path}: sub-goal names must be unique; repeated: {choices(dup)}")
    failures = tuple(_failure(t, obj is not None) for t in top.get_tables("failure"))
    chair = top.get_bool("chair", False)
    return TaskSpec(path, interaction, aliases, top.get_str("description", ""), obj, subgoals, failures, chair)


def task_for_label(label: str) -> TaskSpec:
    """The shipped task whose interaction name or alias is ``label``."""
    tasks = [load_task(name) for name in available_tasks()]
    for t in tasks:
        if label in t.labels:
            return t
    known = sorted(lbl for t in tasks for lbl in t.labels)
    raise ConfigError(f"no task file in {envs_dir()} handles interaction {label!r}; known: {choices(known)}")
