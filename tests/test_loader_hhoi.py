"""The HHOI loader on a small fixture in the documented layout: geometry in closed form, roles, and errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from socialaff_sim.data import load_dataset
from socialaff_sim.data.hhoi import load_hhoi
from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.errors import DataError

LAYOUT = get_layout("kinect_v2")
J = {n: i for i, n in enumerate(LAYOUT.joint_names)}
N_FRAMES = 40
PITCH_DEG = 7.0

# (lateral: + = the person's right, forward, up) in metres; feet on the floor, neck above spine_base.
BODY = {
    "spine_base": (0, 0, 0.95), "spine_mid": (0, 0, 1.2), "neck": (0, 0, 1.5), "head": (0, 0, 1.65),
    "spine_shoulder": (0, 0, 1.42),
    "left_shoulder": (-0.18, 0, 1.42), "left_elbow": (-0.2, 0, 1.15), "left_wrist": (-0.2, 0.02, 0.9),
    "left_hand": (-0.2, 0.03, 0.85), "left_hand_tip": (-0.2, 0.04, 0.78), "left_thumb": (-0.17, 0.05, 0.85),
    "right_shoulder": (0.18, 0, 1.42), "right_elbow": (0.2, 0, 1.15), "right_wrist": (0.2, 0.02, 0.9),
    "right_hand": (0.2, 0.03, 0.85), "right_hand_tip": (0.2, 0.04, 0.78), "right_thumb": (0.17, 0.05, 0.85),
    "left_hip": (-0.1, 0, 0.93), "left_knee": (-0.1, 0.02, 0.5), "left_ankle": (-0.1, 0, 0.08), "left_foot": (-0.1, 0.08, 0),
    "right_hip": (0.1, 0, 0.93), "right_knee": (0.1, 0.02, 0.5), "right_ankle": (0.1, 0, 0.08), "right_foot": (0.1, 0.08, 0),
}
TEMPLATE = np.array([BODY[n] for n in LAYOUT.joint_names], dtype=float)
REACHING = [J[n] for n in ("right_elbow", "right_wrist", "right_hand", "right_hand_tip", "right_thumb")]


def truth(sid: int, frame: int) -> np.ndarray:
    """(25, 3) world joints (x right of the camera, y depth, z up) of skeleton ``sid`` at ``frame``."""
    body = TEMPLATE.copy()
    body[REACHING, 1] += 0.3 * frame / (N_FRAMES - 1) * (1 if sid != 5 else 0)
    facing = +1.0 if sid == 1 else -1.0  # skeleton 1 at the left faces +x, the others face −x
    x0 = {1: -0.6, 3: 0.6, 5: 1.5}[sid]
    lateral, forward, up = body.T
    return np.stack([x0 + facing * forward, 2.5 - facing * lateral, up], axis=-1)


def to_kinect(world: np.ndarray, scale: float = 1.0) -> np.ndarray:
    """World -> Kinect v2 camera space (X left, Y up, Z forward) of a camera pitched by ``PITCH_DEG``."""
    a = np.radians(PITCH_DEG)
    pitch = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    cam = world @ pitch.T
    return scale * np.stack([-cam[..., 0], cam[..., 2], cam[..., 1]], axis=-1)


def write_skeleton(path: Path, xyz: np.ndarray, sep: str = " ") -> None:
    lines = ["Joint X Y Z State"] + [sep.join([name, *(f"{v:.9f}" for v in p), "2"])
                                     for name, p in zip(LAYOUT.joint_names, xyz, strict=True)]
    path.write_text("\n".join(lines) + "\n")


def build(root: Path, *, scale: float = 1.0) -> Path:
    """Hand_Over/sc1 (skeletons 1, 3, a ghost 5; sid 3 missing at frame 15) and Shake_Hands/sc2."""
    trial = root / "Hand_Over" / "sc1" / "Skeletons_Hand_Over" / "trial_01"
    trial.mkdir(parents=True)
    for f in range(N_FRAMES):
        for sid in (1, 3):
            if not (sid == 3 and f == 15):
                write_skeleton(trial / f"body_{f}_{sid}.txt", to_kinect(truth(sid, f), scale))
        if f in (10, 11):
            write_skeleton(trial / f"body_{f}_5.txt", to_kinect(truth(5, f), scale))
    ann = root / "Hand_Over" / "sc1" / "Annotation_Hand_Over"
    ann.mkdir(parents=True)
    (ann / "Annotation_trial_01.txt").write_text("1 2 18 receiver giver\n\n2 20 37 giver receiver\n")
    trial2 = root / "Shake_Hands" / "sc2" / "Skeletons_Shake_Hands" / "t3"
    trial2.mkdir(parents=True)
    for f in range(30):
        for sid in (1, 3):
            write_skeleton(trial2 / f"s_{f:04d}_{sid}.csv", to_kinect(truth(sid, f), scale), sep=",")
    ann2 = root / "Shake_Hands" / "sc2" / "Annotation_Shake_Hands"
    ann2.mkdir(parents=True)
    (ann2 / "t3.txt").write_text("# id start end role1 role2\na,0,29,2,1\n")
    return root


def test_fixture_loads_with_exact_geometry(tmp_path: Path) -> None:
    ds = load_hhoi(build(tmp_path))
    assert ds.name == "hhoi" and len(ds) == 3 and ds.notes["instances"] == 3
    assert [i.instance_id for i in ds] == ["hand_over_sc1_trial_01_1", "hand_over_sc1_trial_01_2", "shake_hands_sc2_t3_a"]
    assert ds.labels == ("hand_over", "shake_hands")
    first = ds[0]
    assert first.n_frames == 17 and first.fps == 30.0 and first.layout.name == "kinect_v2"
    # Roles "receiver giver": the giver (annotation agent 2 = skeleton 3) is agent 0.
    for k, frame in enumerate(range(2, 19)):
        if frame != 15:
            np.testing.assert_allclose(first.joints[k, 0], truth(3, frame), atol=1e-6)
        np.testing.assert_allclose(first.joints[k, 1], truth(1, frame), atol=1e-6)
    assert first.actors == ("sc1/agent2", "sc1/agent1")
    # Roles "giver receiver": skeleton 1 is agent 0.
    np.testing.assert_allclose(ds[1].joints[:, 0], np.stack([truth(1, f) for f in range(20, 38)]), atol=1e-6)
    # Integer roles "2 1": the agent with the smaller number (annotation agent 2 = skeleton 3) is agent 0.
    np.testing.assert_allclose(ds[2].joints[:, 0], np.stack([truth(3, f) for f in range(30)]), atol=1e-6)
    assert ds.notes["roles_hand_over"] == "giver/receiver, receiver/giver"


def test_missing_frame_is_invalid_and_ghost_skeleton_ignored(tmp_path: Path) -> None:
    inter = load_hhoi(build(tmp_path))[0]
    k = 15 - 2
    assert not inter.valid[k, 0].any() and np.isnan(inter.joints[k, 0]).all()
    assert inter.valid.sum() == inter.valid.size - 25
    # The ghost skeleton 5 (frames 10-11) is not one of the two agents.
    assert np.all(np.abs(inter.joints[:, :, J["spine_base"], 0][inter.valid[:, :, 0]]) < 1.0)


def test_world_frame_is_z_up_with_floor_at_zero(tmp_path: Path) -> None:
    ds = load_hhoi(build(tmp_path))
    for inter in ds:
        feet = inter.joints[:, :, [J["left_foot"], J["right_foot"]], 2]
        np.testing.assert_allclose(np.nanmin(feet), 0.0, atol=1e-6)
        head = np.nanmedian(inter.joints[:, :, J["head"], 2])
        np.testing.assert_allclose(head, 1.65, atol=1e-6)


def test_fps_and_dispatch(tmp_path: Path) -> None:
    root = build(tmp_path)
    assert {i.fps for i in load_hhoi(root, fps=15.0)} == {15.0}
    assert len(load_dataset(f"hhoi:{root}")) == 3


# -- errors: every message names the folder/file, the line and the column -------------------------------------
ANN = Path("Hand_Over/sc1/Annotation_Hand_Over/Annotation_trial_01.txt")
SKEL = Path("Hand_Over/sc1/Skeletons_Hand_Over/trial_01/body_7_1.txt")


@pytest.mark.parametrize("content, match", [
    ("1 2 18 giver\n", r"line 1: expected 5 columns \(instance id, start frame, end frame, role of agent 1, "
                       r"role of agent 2\), found 4"),
    ("1 2 18 a b\n2 two 30 a b\n", r"line 2, column 2: expected a non-negative integer frame, found 'two'"),
    ("1 18 2 a b\n", r"line 1: expected end frame >= start frame \+ 2, found start 18, end 2"),
    ("1 30 60 a b\n", r"instance '1': frames 30-60 outside the trial's frames 0-39"),
    ("1 2 8 a b\n1 9 18 a b\n", r"duplicate instance ids \['1'\]"),
    ("\n# nothing\n", r"expected at least one instance line, found none"),
])
def test_bad_annotation_lines(tmp_path: Path, content: str, match: str) -> None:
    root = build(tmp_path)
    (root / ANN).write_text(content)
    with pytest.raises(DataError, match=match) as info:
        load_hhoi(root, policy="strict")
    assert str(root / ANN) in str(info.value)


def test_missing_annotation_file_names_both_candidates(tmp_path: Path) -> None:
    root = build(tmp_path)
    (root / ANN).unlink()
    with pytest.raises(DataError, match=r"'Annotation_trial_01.txt' or 'trial_01.txt' for trial 'trial_01'") as info:
        load_hhoi(root, policy="strict")
    assert str(root / ANN.parent) in str(info.value)


def _edit_joint_line(path: Path, joint: int, new: str) -> None:
    lines = path.read_text().splitlines()
    lines[1 + joint] = new
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("new, match", [
    ("Head 0.1 0.2", r"line 5: expected at least 4 columns \(x, y, z in columns 2-4\), found 3"),
    ("Head 0.1 abc 0.3 2", r"line 5, column 3: expected a number, found 'abc'"),
])
def test_bad_skeleton_lines(tmp_path: Path, new: str, match: str) -> None:
    root = build(tmp_path)
    _edit_joint_line(root / SKEL, J["head"], new)
    with pytest.raises(DataError, match=match) as info:
        load_hhoi(root, policy="strict")
    assert str(root / SKEL) in str(info.value)


def test_truncated_skeleton_file(tmp_path: Path) -> None:
    root = build(tmp_path)
    path = root / SKEL
    path.write_text("\n".join(path.read_text().splitlines()[:25]))  # header + 24 joints
    with pytest.raises(DataError, match="expected a header line then 25 joint lines, found 24") as info:
        load_hhoi(root, policy="strict")
    assert str(path) in str(info.value)


def test_bad_skeleton_file_name(tmp_path: Path) -> None:
    root = build(tmp_path)
    (root / SKEL).rename(root / SKEL.parent / "body_seven_1.txt")
    with pytest.raises(DataError, match=r"<prefix>_<frame>_<skeletonid>.<ext>, found 'body_seven_1.txt'"):
        load_hhoi(root, policy="strict")


def test_unknown_interaction_folder_lists_known(tmp_path: Path) -> None:
    root = build(tmp_path)
    (root / "Hug").mkdir()
    with pytest.raises(DataError, match=r"unknown interaction folder 'Hug'; known: 'Hand_Over', .*'Wave_Hands'"):
        load_hhoi(root, policy="strict")


def test_missing_skeletons_folder(tmp_path: Path) -> None:
    root = build(tmp_path)
    (root / "Hand_Over" / "sc1" / "Skeletons_Hand_Over").rename(root / "Hand_Over" / "sc1" / "Skeletons")
    with pytest.raises(DataError, match=r"expected a folder 'Skeletons_Hand_Over' in scene 'sc1'"):
        load_hhoi(root, policy="strict")


def test_instance_with_a_single_skeleton(tmp_path: Path) -> None:
    root = build(tmp_path)
    for f in range(30, N_FRAMES):
        (root / SKEL.parent / f"body_{f}_3.txt").unlink()
    (root / ANN).write_text("4 30 39 a b\n")
    with pytest.raises(DataError, match=r"instance '4': expected two skeleton ids in frames 30-39, found \[1\]"):
        load_hhoi(root, policy="strict")


def test_millimetres_are_rejected(tmp_path: Path) -> None:
    with pytest.raises(DataError, match="expected Kinect v2 camera-space metres"):
        load_hhoi(build(tmp_path, scale=1000.0), policy="strict")


def test_empty_root(tmp_path: Path) -> None:
    with pytest.raises(DataError, match="found none"):
        load_hhoi(tmp_path, policy="strict")
    with pytest.raises(DataError, match="expected the HHOI root"):
        load_hhoi(tmp_path / "absent", policy="strict")
