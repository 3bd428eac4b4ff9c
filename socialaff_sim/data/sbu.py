"""Loader for the SBU Kinect Interaction dataset (Yun et al., CVPRW 2012).

Layout: ``<root>/<set>/<class>/<seq>/skeleton_pos.txt``. A set such as
``s01s02`` names the two actors (agent 0 = person 1 = ``s01``, agent 1 =
person 2 = ``s02``), so actor-disjoint folds come from sets. Each line holds a
frame index and then 15 joints × (x, y, z) of person 1 and of person 2, in the
dataset's normalised coordinates; 15 fps (:data:`SBU_FPS`).

**Units and axes.** The dataset's documentation converts to millimetres by
``X = 1280 − 2560·x``, ``Y = 960 − 1920·y``, ``Z = z·10000/7.8125``. With the
normalised image coordinate ``x`` growing to the right and ``y`` growing
downwards, ``X`` points to the image's left, ``Y`` up and ``Z`` away from the
camera: a right-handed frame (X × Y = Z). (The head has the larger ``Y``, so
"up" is +Y, not −Y.) The loader maps it to a z-up world in metres by

    world x = −X / 1000   (image right)
    world y =  Z / 1000   (depth, away from the camera)
    world z =  Y / 1000   (up)

a proper rotation. In the result the labelled right shoulder lies on each
person's geometric right (checked on the data: persons facing each other) and
in the handshakes the two right hands meet, so the labels are not mirrored.

**Levelling and floor.** The Kinect is pitched by 5-13° in these recordings,
so camera "up" is not vertical. For every set (one recording session, the
camera assumed fixed within it) :func:`level_rotation` rotates the median body
axis (mid-feet → neck, pooled over both people and all frames of the set) onto
+z. Then, per sequence, :func:`floor_offset` puts z = 0 at the 5th percentile
of the two people's foot-joint heights over the whole sequence, so the feet
stand on the floor (robust to a raised kicking foot). Horizontal position is
left in the camera's frame (x image right, y depth).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import DataError, choices
from .dataset import Dataset
from .frames import floor_offset, level_rotation
from .interaction import MIN_FRAMES, Interaction
from .policy import DEFAULT_POLICY, SkippedFiles
from .skeletons import get_layout

__all__ = ["load_sbu", "read_skeleton_file", "SBU_CLASSES", "SBU_FPS"]

SBU_FPS = 15.0
"""Frame rate stated by the dataset's documentation, frames per second."""

SBU_CLASSES: dict[str, str] = {
    "01": "approaching",
    "02": "departing",
    "03": "kicking",
    "04": "pushing",
    "05": "shaking_hands",
    "06": "hugging",
    "07": "exchanging_object",
    "08": "punching",
}
"""Class folder -> interaction label (06 hugging is absent from some copies)."""

_N_JOINTS = 15
_N_COLS = 1 + 2 * _N_JOINTS * 3
_SET_RE = re.compile(r"^(s\d+)(s\d+)$")
_FILE = "skeleton_pos.txt"


def read_skeleton_file(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Parse one ``skeleton_pos.txt``.

    Returns ``frames`` (T,) int64 and ``coords`` (T, 2, 15, 3) float64 in the
    dataset's normalised units. Errors name the file, the line and the column.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="ascii")
    except (OSError, UnicodeDecodeError) as exc:
        raise DataError(f"cannot read file ({exc})", path=path) from None
    rows = []
    for lineno, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        fields = line.split(",")
        if len(fields) != _N_COLS:
            raise DataError(
                f"line {lineno}: expected {_N_COLS} comma-separated values "
                f"(frame index, then 2 people × {_N_JOINTS} joints × x, y, z), found {len(fields)}",
                path=path,
            )
        try:
            rows.append([float(f) for f in fields])
        except ValueError:
            col = next(i for i, f in enumerate(fields, start=1) if not _is_float(f))
            raise DataError(f"line {lineno}, column {col}: expected a number, found {fields[col - 1]!r}",
                            path=path) from None
    if len(rows) < MIN_FRAMES:
        raise DataError(f"expected at least {MIN_FRAMES} frames, found {len(rows)}", path=path)
    data = np.array(rows)
    if not np.isfinite(data).all():
        lineno = int(np.argwhere(~np.isfinite(data))[0, 0]) + 1
        raise DataError(f"data row {lineno}: expected finite numbers, found NaN or inf", path=path)
    frames = data[:, 0]
    if (frames != np.round(frames)).any() or (np.diff(frames) <= 0).any():
        raise DataError(f"column 1: expected strictly increasing integer frame indices, found {frames[:6].tolist()}...",
                        path=path)
    return frames.astype(np.int64), data[:, 1:].reshape(-1, 2, _N_JOINTS, 3)


def _is_float(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return False
    return True


def _to_world(coords: np.ndarray) -> np.ndarray:
    """(…, 3) normalised SBU coordinates -> (…, 3) metres: (−X, Z, Y) / 1000, before levelling."""
    X = 1280.0 - 2560.0 * coords[..., 0]
    Y = 960.0 - 1920.0 * coords[..., 1]
    Z = coords[..., 2] * 10000.0 / 7.8125
    return np.stack([-X, Z, Y], axis=-1) / 1000.0


def _sequences(root: Path, skipped: SkippedFiles) -> list[tuple[str, str, str, Path]]:
    """(set, class folder, sequence folder, file) in sorted order; unknown folders go to ``skipped``."""
    if not root.is_dir():
        raise DataError("expected the SBU root folder holding set folders like 's01s02'", path=root)
    found = []
    set_dirs = sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith("."))
    if not set_dirs:
        raise DataError("expected set folders like 's01s02', found none", path=root)
    for set_dir in set_dirs:
        if not _SET_RE.match(set_dir.name):
            skipped.skip(set_dir, f"unknown folder: expected set folders named like 's01s02', found {set_dir.name!r}")
            continue
        for cls_dir in sorted(p for p in set_dir.iterdir() if p.is_dir() and not p.name.startswith(".")):
            if cls_dir.name not in SBU_CLASSES:
                known = [f"{k} ({v})" for k, v in SBU_CLASSES.items()]
                skipped.skip(cls_dir, f"unknown class folder {cls_dir.name!r}; known classes: {choices(known)}")
                continue
            for seq_dir in sorted(p for p in cls_dir.iterdir() if p.is_dir() and not p.name.startswith(".")):
                f = seq_dir / _FILE
                if not f.is_file():
                    skipped.skip(seq_dir, f"expected a {_FILE} in every sequence folder, found none")
                    continue
                found.append((set_dir.name, cls_dir.name, seq_dir.name, f))
    if not found:
        raise DataError(f"expected <set>/<class>/<seq>/{_FILE} files, found none", path=root)
    return found


def load_sbu(root: str | Path, *, policy: str = DEFAULT_POLICY) -> Dataset:
    """Load every sequence under ``root`` as a dataset named ``"sbu"``.

    Instances are in sorted (set, class, sequence) order with ids like
    ``"s01s02_05_001"``; joints (T, 2, 15, 3) float64, metres, z up, floor at
    z = 0, layout ``"sbu15"``, 15 fps. Joints whose normalised coordinates are
    all exactly zero (untracked) are marked invalid. ``policy``: what to do with unknown folders and
    unreadable files (:mod:`~socialaff_sim.data.policy`).
    """
    root = Path(root)
    skipped = SkippedFiles(policy, root)
    layout = get_layout("sbu15")
    feet = [layout.index("left_foot"), layout.index("right_foot")]
    neck = layout.index("neck")
    parsed: dict[str, list[tuple[str, str, Path, np.ndarray, np.ndarray]]] = {}
    for set_name, cls, seq, path in _sequences(root, skipped):
        with skipped.guard(path):
            _, coords = read_skeleton_file(path)
        if skipped.files and skipped.files[-1][0] == path:
            continue
        valid = ~(coords == 0).all(axis=-1)
        world = np.where(valid[..., None], _to_world(coords), np.nan)
        parsed.setdefault(set_name, []).append((cls, seq, path, world, valid))

    if not parsed:
        raise DataError(f"expected <set>/<class>/<seq>/{_FILE} files, found no readable one "
                        f"({'; '.join(f'{p.name}: {r}' for p, r in skipped.files[:3])})", path=root)
    interactions = []
    tilts = []
    for set_name, seqs in parsed.items():
        axes = np.concatenate([w[:, :, neck] - w[:, :, feet].mean(axis=2) for _, _, _, w, _ in seqs])
        rot = level_rotation(axes)
        tilts.append(np.degrees(np.arccos(np.clip(rot[2, 2], -1.0, 1.0))))
        actors = _SET_RE.match(set_name).groups()  # type: ignore[union-attr]
        for cls, seq, path, world, valid in seqs:
            joints = world @ rot.T
            joints[..., 2] -= floor_offset(joints[:, :, feet, 2])
            interactions.append(
                Interaction(
                    label=SBU_CLASSES[cls],
                    fps=SBU_FPS,
                    joints=joints,
                    joint_names=layout.joint_names,
                    actors=(actors[0], actors[1]),
                    valid=valid,
                    source=str(path),
                    instance_id=f"{set_name}_{cls}_{seq}",
                )
            )
    notes: dict[str, float | str] = {
        "sequences": float(len(interactions)),
        "camera_tilt_deg_median": float(np.median(tilts)),
        "camera_tilt_deg_max": float(np.max(tilts)),
        "frame": "x image right, y depth, z up (levelled per set); floor z=0 at the feet's 5th percentile",
    }
    skipped.report(notes)
    return Dataset("sbu", tuple(interactions), notes)
