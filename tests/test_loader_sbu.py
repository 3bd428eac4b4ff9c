"""The SBU loader: the documented facts on the real recordings, the conversion in closed form, and errors."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from conftest import shared_path

from socialaff_sim.data import load_dataset
from socialaff_sim.data.sbu import SBU_CLASSES, level_rotation, load_sbu
from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.errors import DataError

LAYOUT = get_layout("sbu15")
J = {n: i for i, n in enumerate(LAYOUT.joint_names)}


@pytest.fixture(scope="module")
def real():
    root = shared_path("sbu_kinect_interaction")
    return root, load_sbu(root)


def test_real_counts_match_the_folder_tree(real) -> None:
    root, ds = real
    files = sorted(root.glob("*/*/*/skeleton_pos.txt"))
    assert len(ds) == len(files) == 225
    expected = Counter(SBU_CLASSES[f.parent.parent.name] for f in files)
    assert Counter(i.label for i in ds) == expected
    assert len(ds.labels) == 7 and "hugging" not in ds.labels
    assert Counter(i.label for i in ds)["shaking_hands"] == 13  # README: 13 handshakes
    assert ds.by_id("s01s02_05_001").actors == ("s01", "s02")
    assert {i.actors for i in ds} == {(f.parts[-4][:3], f.parts[-4][3:]) for f in files}


def test_real_shapes_and_frame_counts(real) -> None:
    root, ds = real
    for inter in ds:
        src = Path(inter.source)
        n_lines = sum(1 for line in src.read_text().splitlines() if line.strip())
        assert inter.n_frames == n_lines and 10 <= n_lines <= 46  # README: 10-46 frames
        assert inter.joints.shape == (n_lines, 2, 15, 3) and inter.fps == 15.0 and inter.valid.all()


def test_real_handshakes_right_hands_meet_and_torsos_are_apart(real) -> None:
    _, ds = real
    for inter in ds.of_label("shaking_hands"):
        j = inter.joints
        right = np.linalg.norm(j[:, 0, J["right_hand"]] - j[:, 1, J["right_hand"]], axis=-1)
        left = np.linalg.norm(j[:, 0, J["left_hand"]] - j[:, 1, J["left_hand"]], axis=-1)
        torso = np.linalg.norm(j[:, 0, J["torso"]] - j[:, 1, J["torso"]], axis=-1)
        # README: right hands within 0.2-7 cm at closest; torsos 1.0-1.4 m apart.
        assert 0.001 < right.min() < 0.075, inter.instance_id
        assert left.min() > 0.4, inter.instance_id  # it is the right hands, not the left, that meet
        assert 0.9 < np.median(torso) < 1.5, inter.instance_id


def test_real_world_frame_is_z_up_with_floor_at_zero(real) -> None:
    _, ds = real
    heads = np.concatenate([np.median(i.joints[:, :, J["head"], 2], axis=0) for i in ds])
    feet = np.array([np.median(i.joints[:, :, [J["left_foot"], J["right_foot"]], 2]) for i in ds])
    assert np.all(heads > 1.1) and np.all(heads < 1.85)
    assert 1.35 < np.median(heads) < 1.7  # head joint above the foot joints
    assert np.all(feet > -0.02) and np.all(feet < 0.3)
    # Upright: the torso lies above the mid-hips and below the neck in nearly every frame.
    torso_z = np.concatenate([i.joints[:, :, J["torso"], 2].ravel() for i in ds])
    neck_z = np.concatenate([i.joints[:, :, J["neck"], 2].ravel() for i in ds])
    assert np.mean(neck_z > torso_z) > 0.99


def test_real_labels_are_not_mirrored(real) -> None:
    # With both people facing each other, each one's right shoulder is on their right.
    _, ds = real
    signs = []
    for inter in ds:
        j = inter.joints
        fwd0 = j[:, 1, J["torso"]] - j[:, 0, J["torso"]]
        fwd0[:, 2] = 0
        right0 = np.cross(fwd0, [0.0, 0.0, 1.0])
        right1 = -right0
        shoulders = j[:, :, J["right_shoulder"]] - j[:, :, J["left_shoulder"]]
        signs.append(np.median(np.sum(shoulders[:, 0] * right0, -1)) > 0)
        signs.append(np.median(np.sum(shoulders[:, 1] * right1, -1)) > 0)
    assert np.mean(signs) > 0.85


def test_dispatch_through_dataset_spec() -> None:
    root = shared_path("sbu_kinect_interaction")
    assert len(load_dataset(f"sbu:{root}")) == 225


# -- the conversion against the README's formula -----------------------------------------------------------
def _person(x0: float, depth: float, facing: float) -> np.ndarray:
    """(15, 3) upright person in a z-up world, feet on z = 0, neck straight above mid-feet."""
    s = np.sign(facing)  # faces s·x, so its right is −s·y (forward × up)
    body = {
        "head": (0, 0, 1.6), "neck": (0, 0, 1.45), "torso": (0, 0, 1.15),
        "left_shoulder": (0, 0.18 * s, 1.42), "left_elbow": (0.02, 0.2 * s, 1.15), "left_hand": (0.05, 0.2 * s, 0.9),
        "right_shoulder": (0, -0.18 * s, 1.42), "right_elbow": (0.02, -0.2 * s, 1.15), "right_hand": (0.05, -0.2 * s, 0.9),
        "left_hip": (0, 0.1 * s, 0.95), "left_knee": (0.03, 0.1 * s, 0.5), "left_foot": (0, 0.1 * s, 0.0),
        "right_hip": (0, -0.1 * s, 0.95), "right_knee": (0.03, -0.1 * s, 0.5), "right_foot": (0, -0.1 * s, 0.0),
    }
    pts = np.array([body[n] for n in LAYOUT.joint_names], dtype=float)
    pts[:, 0] = x0 + s * pts[:, 0]
    pts[:, 1] += depth
    return pts


def _to_normalised(world: np.ndarray) -> np.ndarray:
    """Inverse of the loader's mapping: world metres (x, y, z) = (−X, Z, Y)/1000 -> README's normalised x, y, z."""
    X, Y, Z = -1000 * world[..., 0], 1000 * world[..., 2], 1000 * world[..., 1]
    return np.stack([(1280 - X) / 2560, (960 - Y) / 1920, Z * 7.8125 / 10000], axis=-1)


def _write_seq(path: Path, coords: np.ndarray, first_frame: int = 100) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    rows = [",".join([str(first_frame + t)] + [f"{v:.10f}" for v in coords[t].ravel()]) for t in range(len(coords))]
    path.write_text("\n".join(rows) + "\n")


def _pitch(deg: float) -> np.ndarray:
    a = np.radians(deg)
    return np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])


@pytest.mark.parametrize("pitch_deg", [0.0, 9.0])
def test_conversion_levelling_and_floor_in_closed_form(tmp_path: Path, rng: np.random.Generator, pitch_deg: float) -> None:
    T = 12
    truth = np.stack([np.stack([_person(-0.55, 2.0, +1), _person(0.55, 2.1, -1)])] * T)  # (T, 2, 15, 3)
    truth[:, 0, J["right_hand"]] += np.linspace(0, 0.3, T)[:, None] * [1, 0, 0.3]  # some motion, feet fixed
    cam = truth @ _pitch(pitch_deg).T  # what a pitched camera would see (rotation about its x axis)
    _write_seq(tmp_path / "s03s05" / "05" / "002" / "skeleton_pos.txt", _to_normalised(cam))
    ds = load_sbu(tmp_path)
    inter = ds.by_id("s03s05_05_002")
    assert inter.actors == ("s03", "s05") and inter.label == "shaking_hands"
    np.testing.assert_allclose(inter.joints, truth, atol=1e-6)
    np.testing.assert_allclose(ds.notes["camera_tilt_deg_median"], pitch_deg, atol=1e-6)


def test_level_rotation_against_rodrigues_reference(rng: np.random.Generator) -> None:
    up = rng.normal(size=3)
    up /= np.linalg.norm(up)
    R = level_rotation(np.tile(up, (5, 1)))
    np.testing.assert_allclose(R @ up, [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-12)
    # The smallest rotation: its axis is perpendicular to both up and z (so it leaves up × z fixed).
    axis = np.cross(up, [0, 0, 1])
    np.testing.assert_allclose(R @ axis, axis, atol=1e-12)
    np.testing.assert_allclose(level_rotation(np.array([[0, 0, -1.0]])) @ [0, 0, -1], [0, 0, 1], atol=1e-12)


# -- errors ----------------------------------------------------------------------------------------------------
def _good(tmp_path: Path) -> Path:
    truth = np.stack([np.stack([_person(-0.5, 2.0, 1), _person(0.5, 2.0, -1)])] * 5)
    path = tmp_path / "s01s02" / "01" / "001" / "skeleton_pos.txt"
    _write_seq(path, _to_normalised(truth))
    return path


def test_wrong_column_count_names_line_and_count(tmp_path: Path) -> None:
    path = _good(tmp_path)
    lines = path.read_text().splitlines()
    lines[2] = lines[2].rsplit(",", 1)[0]
    path.write_text("\n".join(lines))
    with pytest.raises(DataError, match=r"line 3: expected 91 comma-separated values .* found 90") as info:
        load_sbu(tmp_path, policy="strict")
    assert str(path) in str(info.value)


def test_non_number_names_line_and_column(tmp_path: Path) -> None:
    path = _good(tmp_path)
    lines = path.read_text().splitlines()
    fields = lines[1].split(",")
    fields[4] = "abc"
    lines[1] = ",".join(fields)
    path.write_text("\n".join(lines))
    with pytest.raises(DataError, match=r"line 2, column 5: expected a number, found 'abc'"):
        load_sbu(tmp_path, policy="strict")


def test_truncated_file_is_rejected(tmp_path: Path) -> None:
    path = _good(tmp_path)
    text = path.read_text()
    path.write_text(text[: len(text) // 3])  # cut mid-line: short last line, too few frames
    with pytest.raises(DataError, match=str(path)):
        load_sbu(tmp_path, policy="strict")
    path.write_text("\n".join(text.splitlines()[:2]))
    with pytest.raises(DataError, match="at least 3 frames, found 2"):
        load_sbu(tmp_path, policy="strict")


def test_frame_indices_must_increase(tmp_path: Path) -> None:
    path = _good(tmp_path)
    lines = path.read_text().splitlines()
    lines[1], lines[2] = lines[2], lines[1]
    path.write_text("\n".join(lines))
    with pytest.raises(DataError, match="strictly increasing integer frame indices"):
        load_sbu(tmp_path, policy="strict")


def test_unknown_class_folder_lists_known_classes(tmp_path: Path) -> None:
    _good(tmp_path)
    (tmp_path / "s01s02" / "09" / "001").mkdir(parents=True)
    with pytest.raises(DataError, match=r"unknown class folder '09'; known classes: .*'05 \(shaking_hands\)'"):
        load_sbu(tmp_path, policy="strict")


@pytest.mark.parametrize("setup, match", [
    (lambda root: (root / "subject1").mkdir(), r"set folders named like 's01s02', found 'subject1'"),
    (lambda root: (root / "s01s02" / "02" / "004").mkdir(parents=True), r"expected a skeleton_pos.txt"),
])
def test_layout_errors(tmp_path: Path, setup, match: str) -> None:
    _good(tmp_path)
    setup(tmp_path)
    with pytest.raises(DataError, match=match):
        load_sbu(tmp_path, policy="strict")


def test_empty_or_missing_root(tmp_path: Path) -> None:
    with pytest.raises(DataError, match="found none"):
        load_sbu(tmp_path, policy="strict")
    with pytest.raises(DataError, match="expected the SBU root"):
        load_sbu(tmp_path / "absent", policy="strict")


def test_untracked_joints_are_invalid(tmp_path: Path) -> None:
    path = _good(tmp_path)
    lines = path.read_text().splitlines()
    fields = lines[0].split(",")
    fields[1 + 3 * J["left_hand"]: 4 + 3 * J["left_hand"]] = ["0", "0", "0"]
    lines[0] = ",".join(fields)
    path.write_text("\n".join(lines))
    inter = load_sbu(tmp_path)[0]
    assert not inter.valid[0, 0, J["left_hand"]] and inter.valid.sum() == inter.valid.size - 1
