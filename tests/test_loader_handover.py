"""The handover loader: real recordings (shapes, units, counts, giver legs) and corrupted copies."""

from __future__ import annotations

import os
import pickle
import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import shared_path

from socialaff_sim.data import actor_disjoint_folds, load_dataset
from socialaff_sim.data.handover import GIVER_UNRELIABLE_JOINTS, load_handover, read_handover_file
from socialaff_sim.data.skeletons import get_layout
from socialaff_sim.errors import DataError, UnsafePickleError

LAYOUT = get_layout("zed_body34")


@pytest.fixture(scope="module")
def real():
    root = shared_path("handover_h2h")
    return root, load_handover(root)


def test_real_counts_shapes_and_ids(real) -> None:
    root, ds = real
    assert ds.name == "handover" and len(ds) == 150
    assert [i.instance_id for i in ds] == [f"motion_normal_{k}" for k in range(150)]
    for inter in ds:
        T = inter.n_frames
        assert 60 <= T <= 300
        assert inter.joints.shape == (T, 2, 34, 3) and inter.object is not None and inter.object.shape == (T, 3)
        assert inter.fps == 30.0 and inter.label == "hand_over" and inter.layout.name == "zed_body34"
    # The arrays are the file's, unchanged: giver = agent 0, receiver = agent 1, object track.
    raw = read_handover_file(root / "motion_normal_7.pkl")
    np.testing.assert_array_equal(ds.by_id("motion_normal_7").joints[:, 0], raw["pose_giver"])
    np.testing.assert_array_equal(ds.by_id("motion_normal_7").joints[:, 1], raw["pose_receiver"])
    np.testing.assert_array_equal(ds.by_id("motion_normal_7").object, raw["pose_object"])


def test_real_units_match_the_documented_heights(real) -> None:
    _, ds = real
    pelvis = np.array([np.median(i.joints[:, 1, LAYOUT.index("pelvis"), 2]) for i in ds])
    head = np.array([np.median(i.joints[:, 1, LAYOUT.index("head"), 2]) for i in ds])
    # README: joint 0 about 0.8-0.95 m high, joint 26 about 1.55 m (metres, z up).
    assert np.all((pelvis > 0.8) & (pelvis < 1.0))
    np.testing.assert_allclose(np.median(head), 1.55, atol=0.05)


def test_real_object_goes_from_giver_to_receiver(real) -> None:
    _, ds = real
    pelvis = LAYOUT.index("pelvis")
    for inter in ds:
        d = np.linalg.norm(inter.object[:, None] - inter.joints[:, :, pelvis], axis=-1)  # (T, 2)
        assert d[0, 0] < d[0, 1], inter.instance_id  # starts nearer the giver
        assert d[-1, 1] < d[-1, 0], inter.instance_id  # ends nearer the receiver


def test_real_giver_legs_are_masked_for_the_reason_documented(real) -> None:
    _, ds = real
    bad = [LAYOUT.index(n) for n in GIVER_UNRELIABLE_JOINTS]
    good = [j for j in range(34) if j not in bad]
    for inter in ds:
        assert not inter.valid[:, 0, bad].any()
        assert inter.valid[:, 0, good].all() and inter.valid[:, 1].all()
    feet = [LAYOUT.index("left_foot"), LAYOUT.index("right_foot")]
    giver_feet = np.median([np.median(i.joints[:, 0, feet, 2]) for i in ds])
    receiver_feet = np.median([np.median(i.joints[:, 1, feet, 2]) for i in ds])
    assert giver_feet < -0.03 < 0.03 < receiver_feet  # the giver's feet are below the floor
    np.testing.assert_allclose(ds.notes["giver_foot_height_median_m"], giver_feet, atol=1e-12)
    # The two symptoms of the docstring, counted per recording: giver 146/150, receiver 0/150.
    low = [LAYOUT.index(n) for n in ("left_ankle", "left_foot", "right_ankle", "right_foot", "left_heel", "right_heel")]
    knees = [LAYOUT.index("left_knee"), LAYOUT.index("right_knee")]
    for agent, expected in ((0, (85, 61, 146)), (1, (0, 0, 0))):
        below = np.array([np.median(i.joints[:, agent, low, 2]) < -0.03 for i in ds])
        folded = np.array([np.mean((i.joints[:, agent, knees, 2] - i.joints[:, agent, [0], 2] > -0.15).any(axis=1)) > 0.1
                           for i in ds])
        assert (below.sum(), folded.sum(), (below | folded).sum()) == expected
    # Key joints follow the mask: the giver's ankles are not tracked.
    assert not ds[0].key_valid()[:, 0, 3:].any() and ds[0].key_valid()[:, 1].all()


def test_real_actor_ids_are_per_recording(real, rng: np.random.Generator) -> None:
    _, ds = real
    pairs = {i.actors for i in ds}
    assert len(pairs) == 150
    folds = actor_disjoint_folds(ds.interactions, 5, rng=rng)
    assert sorted(np.concatenate([test for _, test in folds]).tolist()) == list(range(150))
    assert "recording-disjoint" in str(ds.notes["actors"])


def test_dispatch_through_dataset_spec() -> None:
    root = shared_path("handover_h2h")
    assert len(load_dataset(f"handover:{root}")) == 150


# -- synthetic and corrupted copies ---------------------------------------------------------------------
def _recording(rng: np.random.Generator, T: int = 20) -> dict[str, np.ndarray]:
    base = np.array([0.0, 0.0, 0.9])
    return {
        "pose_giver": base + rng.normal(scale=0.3, size=(T, 34, 3)),
        "pose_receiver": base + [1.5, 0, 0] + rng.normal(scale=0.3, size=(T, 34, 3)),
        "pose_object": base + rng.normal(scale=0.1, size=(T, 3)),
        "quat_object": np.tile([1.0, 0, 0, 0], (T, 1)),
    }


def _write(folder: Path, name: str, obj: object, protocol: int = 4) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_bytes(pickle.dumps(obj, protocol=protocol))
    return path


def test_nan_and_zero_rows_become_invalid_and_object_gaps_are_interpolated(tmp_path: Path, rng) -> None:
    rec = _recording(rng)
    rec["pose_receiver"][4, 11] = np.nan
    rec["pose_receiver"][5, 12] = 0.0
    rec["pose_giver"][6, 0] = [np.nan, 1.0, 2.0]
    rec["pose_object"][9] = np.nan
    rec["pose_object"][10] = 0.0
    _write(tmp_path, "motion_normal_3.pkl", rec)
    ds = load_handover(tmp_path)
    inter = ds[0]
    assert not inter.valid[4, 1, 11] and not inter.valid[5, 1, 12] and not inter.valid[6, 0, 0]
    assert inter.valid[:, 1].sum() == 20 * 34 - 2
    # Gap of two frames (9, 10) filled linearly between frames 8 and 11.
    expected = rec["pose_object"][8] + np.outer([1 / 3, 2 / 3], rec["pose_object"][11] - rec["pose_object"][8])
    np.testing.assert_allclose(inter.object[9:11], expected, atol=1e-12)
    assert ds.notes["object_frames_interpolated"] == 2.0
    assert inter.actors == ("motion_normal_3/giver", "motion_normal_3/receiver")


def test_single_file_path_loads_one_recording(tmp_path: Path, rng) -> None:
    path = _write(tmp_path, "motion_normal_12.pkl", _recording(rng))
    assert [i.instance_id for i in load_handover(path)] == ["motion_normal_12"]


@pytest.mark.parametrize(
    "mutate, match",
    [
        (lambda r: r.pop("pose_object"), r"missing keys \['pose_object'\]"),
        (lambda r: r.update(pose_giver=r["pose_giver"][:, :33]), r"'pose_giver'.*expected shape \(T, 34, 3\), found \(20, 33, 3\)"),
        (lambda r: r.update(quat_object=r["quat_object"][:, :3]), r"'quat_object'.*expected shape \(T, 4\), found \(20, 3\)"),
        (lambda r: r.update(pose_receiver=r["pose_receiver"][:15]), r"'pose_receiver'.*expected T = 20 frames"),
        (lambda r: r.update(pose_object=r["pose_object"].tolist()), r"'pose_object'.*expected a NumPy array"),
        (lambda r: r.update(pose_object=r["pose_object"].astype(str)), r"'pose_object'.*expected a numeric array"),
    ],
)
def test_malformed_recordings_name_file_key_and_shapes(tmp_path: Path, rng, mutate, match: str) -> None:
    rec = _recording(rng)
    mutate(rec)
    path = _write(tmp_path, "motion_normal_0.pkl", rec)
    with pytest.raises(DataError, match=match) as info:
        load_handover(tmp_path, policy="strict")
    assert str(path) in str(info.value)


def test_all_nan_object_track_is_an_error(tmp_path: Path, rng) -> None:
    rec = _recording(rng)
    rec["pose_object"][:] = np.nan
    _write(tmp_path, "motion_normal_0.pkl", rec)
    with pytest.raises(DataError, match="pose_object"):
        load_handover(tmp_path, policy="strict")


def test_truncated_real_file_is_a_data_error(tmp_path: Path) -> None:
    src = shared_path("handover_h2h", "motion_normal_0.pkl")
    dst = tmp_path / "motion_normal_0.pkl"
    shutil.copyfile(src, dst)
    with open(dst, "r+b") as fh:
        fh.truncate(os.path.getsize(dst) // 2)
    with pytest.raises(DataError, match="not a readable pickle") as info:
        load_handover(tmp_path, policy="strict")
    assert str(dst) in str(info.value)


def test_wrong_top_level_object_is_rejected(tmp_path: Path, rng) -> None:
    _write(tmp_path, "motion_normal_0.pkl", list(_recording(rng).values()))
    with pytest.raises(DataError, match="expected a pickled dict at top level, found list"):
        load_handover(tmp_path, policy="strict")


def test_malicious_recording_is_refused_without_running(tmp_path: Path, rng) -> None:
    marker = tmp_path / "pwned"

    class Evil:
        def __reduce__(self):
            return (os.system, (f"touch {marker}",))

    rec = _recording(rng)
    rec["pose_object"] = Evil()  # type: ignore[assignment]
    _write(tmp_path, "motion_normal_0.pkl", rec)
    with pytest.raises(UnsafePickleError, match="forbidden global"):
        load_handover(tmp_path, policy="strict")
    assert not marker.exists()


def test_layout_errors(tmp_path: Path, rng) -> None:
    with pytest.raises(DataError, match="found none"):
        load_handover(tmp_path, policy="strict")
    _write(tmp_path, "motion_normal_x.pkl", _recording(rng))
    with pytest.raises(DataError, match="integer <i>"):
        load_handover(tmp_path, policy="strict")
    with pytest.raises(DataError, match="expected a folder"):
        load_handover(tmp_path / "absent", policy="strict")
