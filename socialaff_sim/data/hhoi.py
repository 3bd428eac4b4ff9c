"""Loader for the UCLA HHOI layout (Shu, Ryoo & Zhu, IJCAI 2016), for users with their own copy.

The layout is known from a third-party reader, not from the files, so every
assumption is checked and every error names the folder, file, line and column:

* ``<root>/<Interaction>/<scene>/Skeletons_<Interaction>/<trial>/`` holds one
  text file per skeleton per frame, ``<prefix>_<frame>_<skeletonid>.<ext>``: a
  header line, then 25 lines (Kinect v2 ``JointType`` order), x, y, z in
  columns 2-4 (whitespace or comma separated, extra columns ignored).
* ``<root>/<Interaction>/<scene>/Annotation_<Interaction>/`` holds
  ``Annotation_<trial>.txt`` (scene ``sc1``) or ``<trial>.txt`` (elsewhere;
  both names are accepted everywhere): one line per instance, ``instance id,
  start frame, end frame, role of agent 1, role of agent 2``.
* Interaction folders: Hand_Over, High_Five, Pull_Up, Shake_Hands, Wave_Hands
  -> labels hand_over, high_five, pull_up, shake_hands, wave_hands.

Conventions:

* **Agents.** Within an instance's frames the two skeleton ids seen most often
  are the agents; the annotation's agent 1 is the smaller id, agent 2 the
  larger. The Interaction's agent 0 (the observed human) is the annotated agent
  whose role is in ``agent0_roles`` (default :data:`HHOI_AGENT0_ROLES`; integer
  roles: the smaller number); when that does not decide (both or neither), it
  is the annotation's agent 1. The roles met are listed in ``notes``.
* **Frames.** An instance holds every frame number from start to end
  inclusive at ``fps``; a frame without a skeleton's file is invalid (NaN).
* **Frame.** Kinect v2 camera space (metres; X to the sensor's left, Y up, Z
  forward: right-handed) maps to world ``x = −X, y = Z, z = Y``; each trial is
  levelled (median spine_base→neck axis onto +z) and its floor put at z = 0 at
  the 5th percentile of the foot joints, as for SBU
  (:func:`~socialaff_sim.data.frames.level_rotation`).
* **Actors.** HHOI publishes no actor ids here, so the pair is taken from the
  scene (``"<scene>/agent1"``, ``"<scene>/agent2"``): folds are scene-disjoint,
  which is actor-disjoint only if each scene has its own actors.
"""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Collection
from pathlib import Path

import numpy as np

from ..errors import DataError, choices
from .dataset import Dataset
from .interaction import MIN_FRAMES, Interaction
from .policy import DEFAULT_POLICY, SkippedFiles
from .frames import floor_offset, level_rotation
from .skeletons import get_layout

__all__ = ["load_hhoi", "read_hhoi_skeleton", "read_hhoi_annotation", "HHOI_LABELS", "HHOI_AGENT0_ROLES", "HHOI_FPS"]

HHOI_FPS = 30.0
"""Default frame rate: the Kinect v2 body stream's 30 Hz."""

HHOI_LABELS: dict[str, str] = {
    "Hand_Over": "hand_over",
    "High_Five": "high_five",
    "Pull_Up": "pull_up",
    "Shake_Hands": "shake_hands",
    "Wave_Hands": "wave_hands",
}
"""Interaction folder -> label."""

HHOI_AGENT0_ROLES: frozenset[str] = frozenset({"giver", "initiator", "leader", "human", "observed"})
"""Role names (lower case) that make an annotated agent the Interaction's agent 0."""

_LAYOUT = get_layout("kinect_v2")
_N_JOINTS = 25
_FILE_RE = re.compile(r"^(?P<prefix>.*)_(?P<frame>\d+)_(?P<sid>\d+)\.[^.]+$")
_SPLIT = re.compile(r"[,\s]+")


def read_hhoi_skeleton(path: str | Path) -> np.ndarray:
    """(25, 3) float64: x, y, z (columns 2-4) of one skeleton file, Kinect camera space, metres."""
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8", errors="strict").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise DataError(f"cannot read skeleton file ({exc})", path=path) from None
    body = [(i, ln) for i, ln in enumerate(lines[1:], start=2) if ln.strip()]
    if len(body) != _N_JOINTS:
        raise DataError(f"expected a header line then {_N_JOINTS} joint lines, found {len(body)} non-empty "
                        f"lines after the header", path=path)
    out = np.empty((_N_JOINTS, 3))
    for j, (lineno, line) in enumerate(body):
        cols = _SPLIT.split(line.strip())
        if len(cols) < 4:
            raise DataError(f"line {lineno}: expected at least 4 columns (x, y, z in columns 2-4), "
                            f"found {len(cols)}: {line.strip()!r}", path=path)
        for c in (1, 2, 3):
            try:
                out[j, c - 1] = float(cols[c])
            except ValueError:
                raise DataError(f"line {lineno}, column {c + 1}: expected a number, found {cols[c]!r}",
                                path=path) from None
    if not np.isfinite(out).all():
        raise DataError("expected finite coordinates, found NaN or inf", path=path)
    return out


def read_hhoi_annotation(path: str | Path) -> list[tuple[str, int, int, str, str]]:
    """Instances ``(id, start, end, role1, role2)`` of one annotation file (blank and ``#`` lines skipped)."""
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise DataError(f"cannot read annotation file ({exc})", path=path) from None
    out = []
    for lineno, line in enumerate(lines, start=1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        cols = _SPLIT.split(line.strip())
        if len(cols) != 5:
            raise DataError(f"line {lineno}: expected 5 columns (instance id, start frame, end frame, role of "
                            f"agent 1, role of agent 2), found {len(cols)}: {line.strip()!r}", path=path)
        bounds = []
        for c in (1, 2):
            if not re.fullmatch(r"\d+", cols[c]):
                raise DataError(f"line {lineno}, column {c + 1}: expected a non-negative integer frame, "
                                f"found {cols[c]!r}", path=path)
            bounds.append(int(cols[c]))
        if bounds[1] - bounds[0] + 1 < MIN_FRAMES:
            raise DataError(f"line {lineno}: expected end frame >= start frame + {MIN_FRAMES - 1}, "
                            f"found start {bounds[0]}, end {bounds[1]}", path=path)
        out.append((cols[0], bounds[0], bounds[1], cols[3], cols[4]))
    if not out:
        raise DataError("expected at least one instance line, found none", path=path)
    ids = [o[0] for o in out]
    dup = [k for k, n in Counter(ids).items() if n > 1]
    if dup:
        raise DataError(f"duplicate instance ids {dup}", path=path)
    return out


def _subdirs(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if p.is_dir() and not p.name.startswith("."))


def _read_trial(trial_dir: Path) -> dict[int, dict[int, np.ndarray]]:
    """skeleton id -> frame -> (25, 3) camera-space joints, for one trial folder."""
    skeletons: dict[int, dict[int, np.ndarray]] = {}
    files = sorted(p for p in trial_dir.iterdir() if p.is_file() and not p.name.startswith("."))
    if not files:
        raise DataError("expected skeleton files <prefix>_<frame>_<skeletonid>.<ext>, found none", path=trial_dir)
    for f in files:
        m = _FILE_RE.match(f.name)
        if not m:
            raise DataError(f"expected a skeleton file named <prefix>_<frame>_<skeletonid>.<ext>, found {f.name!r}",
                            path=trial_dir)
        skeletons.setdefault(int(m["sid"]), {})[int(m["frame"])] = read_hhoi_skeleton(f)
    return skeletons


def _annotation_file(ann_dir: Path, trial: str) -> Path:
    candidates = [ann_dir / f"Annotation_{trial}.txt", ann_dir / f"{trial}.txt"]
    for c in candidates:
        if c.is_file():
            return c
    raise DataError(f"expected an annotation file {choices(c.name for c in candidates)} for trial {trial!r}, "
                    f"found none", path=ann_dir)


def _first_agent(roles: tuple[str, str], agent0_roles: Collection[str]) -> int:
    """0 or 1: which annotated agent becomes the Interaction's agent 0 (see the module docstring)."""
    if roles[0].isdigit() and roles[1].isdigit() and int(roles[0]) != int(roles[1]):
        return int(int(roles[1]) < int(roles[0]))
    chosen = [r.lower() in agent0_roles for r in roles]
    return 1 if chosen == [False, True] else 0


def _trial_instances(label: str, scene: str, trial_dir: Path, ann_path: Path, fps: float,
                     agent0_roles: Collection[str], roles_seen: set[str]) -> list[Interaction]:
    skeletons = _read_trial(trial_dir)
    # Trial-wide world frame: x = -X, y = Z, z = Y, levelled, floor at the feet.
    world = {sid: {f: np.stack([-p[:, 0], p[:, 2], p[:, 1]], axis=-1) for f, p in fr.items()}
             for sid, fr in skeletons.items()}
    every = np.stack([p for fr in world.values() for p in fr.values()])
    depth = float(np.median(every[:, 0, 1]))
    if not 0.3 < depth < 10.0:
        raise DataError(f"expected Kinect v2 camera-space metres (spine_base depth 0.3-10 m), found median depth "
                        f"{depth:.3g}", path=trial_dir)
    neck, feet = _LAYOUT.index("neck"), [_LAYOUT.index("left_foot"), _LAYOUT.index("right_foot")]
    rot = level_rotation(every[:, neck] - every[:, 0])
    floor = floor_offset((every @ rot.T)[:, feet, 2])
    frames_all = sorted({f for fr in world.values() for f in fr})
    out = []
    for inst_id, start, end, role1, role2 in read_hhoi_annotation(ann_path):
        if start < frames_all[0] or end > frames_all[-1]:
            raise DataError(f"instance {inst_id!r}: frames {start}-{end} outside the trial's frames "
                            f"{frames_all[0]}-{frames_all[-1]} in {trial_dir}", path=ann_path)
        counts = Counter({sid: sum(start <= f <= end for f in fr) for sid, fr in world.items()})
        top = [sid for sid, n in counts.most_common(2) if n > 0]
        if len(top) < 2:
            raise DataError(f"instance {inst_id!r}: expected two skeleton ids in frames {start}-{end}, found "
                            f"{top} in {trial_dir}", path=ann_path)
        sids = sorted(top)  # annotation agent 1 = smaller skeleton id
        first = _first_agent((role1, role2), agent0_roles)
        roles_seen.add(f"{role1}/{role2}")
        order = [sids[first], sids[1 - first]]
        T = end - start + 1
        joints = np.full((T, 2, _N_JOINTS, 3), np.nan)
        for a, sid in enumerate(order):
            for f, p in world[sid].items():
                if start <= f <= end:
                    joints[f - start, a] = p
        valid = np.isfinite(joints).all(axis=-1)
        joints = joints @ rot.T
        joints[..., 2] -= floor
        actor_ids = (f"{scene}/agent{first + 1}", f"{scene}/agent{2 - first}")
        safe_id = re.sub(r"[^A-Za-z0-9]+", "_", f"{label}_{scene}_{trial_dir.name}_{inst_id}")
        out.append(Interaction(label=label, fps=fps, joints=joints, joint_names=_LAYOUT.joint_names,
                               actors=actor_ids, valid=valid, source=f"{trial_dir} ({ann_path.name}, {inst_id})",
                               instance_id=safe_id))
    return out


def load_hhoi(root: str | Path, *, fps: float = HHOI_FPS,
              agent0_roles: Collection[str] = HHOI_AGENT0_ROLES, policy: str = DEFAULT_POLICY) -> Dataset:
    """Load every annotated instance under ``root`` (the folder holding Hand_Over, High_Five, ...) as ``"hhoi"``.

    Instances: joints (T, 2, 25, 3) float64, metres, z up, floor at z = 0,
    layout ``"kinect_v2"``, ``fps`` frames per second, NaN/invalid where a
    skeleton file is missing. ``policy``: what to do with unknown interaction folders and trials
    that fail to load (:mod:`~socialaff_sim.data.policy`).
    """
    root = Path(root)
    skipped = SkippedFiles(policy, root)
    if not root.is_dir():
        raise DataError(f"expected the HHOI root folder holding {choices(HHOI_LABELS)}", path=root)
    roles0 = frozenset(r.lower() for r in agent0_roles)
    folders = []
    for p in _subdirs(root):
        if p.name in HHOI_LABELS:
            folders.append(p)
        else:
            skipped.skip(p, f"unknown interaction folder {p.name!r}; known: {choices(HHOI_LABELS)}")
    if not folders:
        raise DataError(f"expected interaction folders {choices(HHOI_LABELS)}, found none", path=root)
    interactions: list[Interaction] = []
    notes: dict[str, float | str] = {}
    for inter_dir in folders:
        name, label = inter_dir.name, HHOI_LABELS[inter_dir.name]
        roles_seen: set[str] = set()
        scenes = _subdirs(inter_dir)
        if not scenes:
            raise DataError("expected scene folders (e.g. 'sc1'), found none", path=inter_dir)
        for scene_dir in scenes:
            skel_dir, ann_dir = scene_dir / f"Skeletons_{name}", scene_dir / f"Annotation_{name}"
            for d in (skel_dir, ann_dir):
                if not d.is_dir():
                    raise DataError(f"expected a folder {d.name!r} in scene {scene_dir.name!r}, found none",
                                    path=scene_dir)
            trials = _subdirs(skel_dir)
            if not trials:
                raise DataError("expected trial folders of skeleton files, found none", path=skel_dir)
            for trial_dir in trials:
                with skipped.guard(trial_dir):
                    interactions += _trial_instances(label, scene_dir.name, trial_dir,
                                                     _annotation_file(ann_dir, trial_dir.name), fps, roles0, roles_seen)
        notes[f"roles_{label}"] = ", ".join(sorted(roles_seen))
    notes["instances"] = float(len(interactions))
    notes["actors"] = "one id pair per scene (none published): folds are scene-disjoint"
    if not interactions:
        raise DataError("expected annotated instances, found no readable one", path=root)
    skipped.report(notes)
    return Dataset("hhoi", tuple(interactions), notes)
