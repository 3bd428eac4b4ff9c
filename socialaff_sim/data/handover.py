"""Loader for the dynamic human-to-human handover recordings (Kim et al., ICRA 2025).

Each recording ``motion_normal_<i>.pkl`` is a pickled dict of NumPy arrays:
``pose_giver`` and ``pose_receiver`` (T, 34, 3) in the ZED BODY_34 joint order,
``pose_object`` (T, 3) and ``quat_object`` (T, 4), in metres in one world frame
with z up, at 30 Hz. The pickles are read only through the restricted
unpickler (:mod:`socialaff_sim.data.safe_pickle`): dicts, arrays and dtypes.

Conventions of the returned :class:`~socialaff_sim.data.dataset.Dataset`:

* agent 0 is the giver (the observed human), agent 1 the receiver (the role
  the robot plays); the object track is ``pose_object``; the label is
  :data:`HANDOVER_LABEL` ``"hand_over"``, the name the synthetic and HHOI data
  use for the method's "hand over" interaction, so the datasets can be mixed; layout
  ``"zed_body34"``; 30 fps; instance ids are the file stems.
* **Giver legs.** The giver's lower legs are implausible in 146 of the 150
  recordings, in one of two ways: in 85 the straight legs (thigh + shank
  0.44 + 0.39 m, longer than the receiver's, under a pelvis at 0.78 m) put the
  median ankle/foot/heel height below −3 cm, i.e. under the floor (median
  −0.10 m; the receiver's feet are at +0.10 m); in 61 a knee rises to within
  0.15 m of the pelvis in over 10 % of the frames (a leg folded up while
  standing). The receiver shows neither in any recording. The giver's knees,
  ankles, feet and heels (:data:`GIVER_UNRELIABLE_JOINTS`) are therefore
  marked ``valid=False`` in all frames of all recordings; the hips stay valid
  (rigidly offset from the pelvis). Coordinates are kept; only the mask changes.
* Joints holding NaN or an exact (0, 0, 0) row are marked invalid too. Object
  frames with NaN or (0, 0, 0) are linearly interpolated from the valid ones
  (counted in ``notes["object_frames_interpolated"]``).
* **Actors.** The dataset publishes no actor ids, so each recording gets its
  own pair (``"motion_normal_<i>/giver"``, ``"motion_normal_<i>/receiver"``).
  Folds built on them are recording-disjoint, not truly actor-disjoint: the
  same people may appear in training and test.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import DataError
from .dataset import Dataset
from .checks import check_plausible
from .interaction import MIN_FRAMES, Interaction
from .policy import DEFAULT_POLICY, SkippedFiles
from .safe_pickle import NUMPY_ARRAY_GLOBALS, restricted_load
from .skeletons import get_layout

__all__ = ["load_handover", "read_handover_file", "HANDOVER_FPS", "HANDOVER_LABEL", "GIVER_UNRELIABLE_JOINTS"]

HANDOVER_FPS = 30.0
"""Frame rate of the recordings, frames per second."""

HANDOVER_LABEL = "hand_over"
"""Interaction label of every recording (as in the synthetic and HHOI datasets)."""

GIVER_UNRELIABLE_JOINTS: tuple[str, ...] = (
    "left_knee", "left_ankle", "left_foot", "right_knee", "right_ankle", "right_foot",
    "left_heel", "right_heel",
)
"""ZED BODY_34 joints of the giver marked invalid in every frame (see the module docstring)."""

_LAYOUT = "zed_body34"
_FILE_RE = re.compile(r"^motion_(normal|variation)_(\d+)\.pkl$")
_SHAPES: dict[str, tuple[int, ...]] = {
    "pose_giver": (34, 3),
    "pose_receiver": (34, 3),
    "pose_object": (3,),
    "quat_object": (4,),
}
"""Required keys and the shape of one frame of each."""


def read_handover_file(path: str | Path) -> dict[str, np.ndarray]:
    """Unpickle one recording (restricted) and validate its keys, dtypes and shapes.

    Returns float64 arrays: ``pose_giver``/``pose_receiver`` (T, 34, 3),
    ``pose_object`` (T, 3), ``quat_object`` (T, 4); metres, z up. Errors name the
    file, the key, and the expected and found shapes.
    """
    path = Path(path)
    raw = restricted_load(path, allowed=NUMPY_ARRAY_GLOBALS, expect=dict)
    missing = [k for k in _SHAPES if k not in raw]
    if missing:
        found = sorted(str(k) for k in raw)
        raise DataError(
            f"missing keys {missing}; a recording holds {list(_SHAPES)}, found {found}",
            path=path,
            field=missing[0],
        )
    out: dict[str, np.ndarray] = {}
    n_frames: int | None = None
    for key, frame_shape in _SHAPES.items():
        value = raw[key]
        expected = "(T, " + ", ".join(str(s) for s in frame_shape) + ")"
        if not isinstance(value, np.ndarray):
            raise DataError(f"expected a NumPy array {expected}, found {type(value).__name__}", path=path, field=key)
        if value.dtype.kind not in "fiu":
            raise DataError(f"expected a numeric array, found dtype {value.dtype}", path=path, field=key)
        if value.ndim != 1 + len(frame_shape) or value.shape[1:] != frame_shape:
            raise DataError(f"expected shape {expected}, found {value.shape}", path=path, field=key)
        if n_frames is None:
            n_frames = value.shape[0]
        elif value.shape[0] != n_frames:
            raise DataError(
                f"expected T = {n_frames} frames like 'pose_giver', found {value.shape[0]}", path=path, field=key
            )
        out[key] = value.astype(np.float64)
    if n_frames is None or n_frames < MIN_FRAMES:
        raise DataError(f"expected at least {MIN_FRAMES} frames, found {n_frames}", path=path, field="pose_giver")
    return out


def _missing_rows(a: np.ndarray) -> np.ndarray:
    """(...,) bool: rows (last axis) holding a NaN/inf or exactly (0, 0, 0)."""
    return ~np.isfinite(a).all(axis=-1) | (a == 0).all(axis=-1)


def _fill_object(obj: np.ndarray, path: Path) -> tuple[np.ndarray, int]:
    """Interpolate missing object frames linearly; returns (filled (T, 3), count filled)."""
    bad = _missing_rows(obj)
    if not bad.any():
        return obj, 0
    if bad.all():
        raise DataError("expected at least one valid object position, found none (all NaN or zero)", path=path,
                        field="pose_object")
    t = np.arange(len(obj))
    filled = obj.copy()
    for d in range(3):
        filled[bad, d] = np.interp(t[bad], t[~bad], obj[~bad, d])
    return filled, int(bad.sum())


def _recording_files(root: Path, variations: bool, skipped: SkippedFiles) -> list[Path]:
    """The recordings under ``root`` (or ``root`` itself), normal ones first, each kind by index."""
    if root.is_file():
        match = _FILE_RE.match(root.name)
        if not match:
            raise DataError("expected a file named motion_normal_<i>.pkl or motion_variation_<i>.pkl", path=root)
        return [root]
    if not root.is_dir():
        raise DataError("expected a folder of motion_normal_<i>.pkl (and motion_variation_<i>.pkl) files", path=root)
    files = []
    for p in SkippedFiles.visible(root):
        match = _FILE_RE.match(p.name)
        if not match or not p.is_file():
            skipped.skip(p, "unknown file: expected motion_normal_<i>.pkl or motion_variation_<i>.pkl with an integer <i>")
        elif match.group(1) == "normal" or variations:
            files.append((match.group(1) != "normal", int(match.group(2)), p))
    if not files:
        raise DataError("expected motion_normal_<i>.pkl recordings, found none", path=root)
    return [p for *_, p in sorted(files)]


def load_handover(root: str | Path, *, variations: bool = True, policy: str = DEFAULT_POLICY) -> Dataset:
    """Load every recording under ``root`` (or one such file) as a dataset named ``"handover"``.

    Each recording becomes one ``"hand_over"`` interaction, ``motion_normal_<i>.pkl`` in order of
    ``<i>``, then ``motion_variation_<i>.pkl`` (the dataset's handovers with varied object
    placement; the same file format, so the same treatment) unless ``variations=False``:
    joints (T, 2, 34, 3) float64, metres, z up (agent 0 giver, agent 1
    receiver), object (T, 3) metres, 30 fps. ``policy``: what to do with unknown or unreadable
    files (:mod:`~socialaff_sim.data.policy`); a forbidden pickle global always stops the load.
    """
    root = Path(root)
    skipped = SkippedFiles(policy, root.parent if root.is_file() else root)
    interactions = []
    n_interp = 0
    giver_feet, receiver_feet = [], []
    for path in _recording_files(root, variations, skipped):
        with skipped.guard(path):
            inter, filled, feet = _recording(path)
            check_plausible(inter, path=path)
            interactions.append(inter)
            n_interp += filled
            giver_feet.append(feet[0])
            receiver_feet.append(feet[1])
    if not interactions:
        raise DataError("expected readable motion_*_<i>.pkl recordings, found none "
                        f"({'; '.join(f'{p.name}: {r}' for p, r in skipped.files[:3])})", path=root)
    notes: dict[str, float | str] = {
        "recordings": float(len(interactions)),
        "giver_invalid_joints": ", ".join(GIVER_UNRELIABLE_JOINTS),
        "giver_foot_height_median_m": float(np.median(giver_feet)),
        "receiver_foot_height_median_m": float(np.median(receiver_feet)),
        "object_frames_interpolated": float(n_interp),
        "actors": "one id pair per recording (none published): folds are recording-disjoint, not actor-disjoint",
        "ignored": "quat_object (object orientation) is validated but not used",
    }
    skipped.report(notes)
    return Dataset("handover", tuple(interactions), notes)


def _recording(path: Path) -> tuple[Interaction, int, tuple[float, float]]:
    """One recording as an interaction; also the object frames filled and the median foot heights (m)."""
    layout = get_layout(_LAYOUT)
    unreliable = np.array([layout.index(n) for n in GIVER_UNRELIABLE_JOINTS])
    feet = np.array([layout.index(n) for n in ("left_foot", "right_foot")])
    rec = read_handover_file(path)
    joints = np.stack([rec["pose_giver"], rec["pose_receiver"]], axis=1)
    valid = ~_missing_rows(joints)
    valid[:, 0, unreliable] = False
    obj, filled = _fill_object(rec["pose_object"], path)
    stem = path.stem
    inter = Interaction(
        label=HANDOVER_LABEL,
        fps=HANDOVER_FPS,
        joints=joints,
        joint_names=layout.joint_names,
        actors=(f"{stem}/giver", f"{stem}/receiver"),
        object=obj,
        valid=valid,
        source=str(path),
        instance_id=stem,
    )
    foot_heights = (float(np.median(rec["pose_giver"][:, feet, 2])), float(np.median(rec["pose_receiver"][:, feet, 2])))
    return inter, filled, foot_heights
