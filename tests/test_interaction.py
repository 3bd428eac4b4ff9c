"""The Interaction data model, the skeleton layouts and the npz format."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from socialaff_sim.data import (
    FORMAT_VERSION,
    KEY_JOINTS,
    LAYOUTS,
    Dataset,
    Interaction,
    actor_disjoint_folds,
    get_layout,
    load_interaction,
    load_npz_dataset,
    save_dataset,
    save_interaction,
)
from socialaff_sim.errors import DataError, SocialAffError


def make(rng: np.random.Generator, T: int = 12, layout: str = "kinect_v2", **kw) -> Interaction:
    lay = LAYOUTS[layout]
    args = dict(
        label="shake_hands",
        fps=15.0,
        joints=0.3 * rng.normal(size=(T, 2, lay.n_joints, 3)),  # person-sized: loaders check 0.5-2.5 m
        joint_names=lay.joint_names,
        actors=("a01", "a02"),
        instance_id="inst_0",
        source="test",
    )
    args.update(kw)
    return Interaction(**args)


def test_layouts_are_trees_with_key_joints() -> None:
    for lay in LAYOUTS.values():
        roots = [j for j, p in enumerate(lay.parents) if p < 0]
        assert len(roots) == 1, lay.name
        # Every joint reaches the root without cycles.
        for j in range(lay.n_joints):
            seen, k = set(), j
            while lay.parents[k] >= 0:
                assert k not in seen, lay.name
                seen.add(k)
                k = lay.parents[k]
        for key, idx in zip(KEY_JOINTS, lay.key_indices, strict=True):
            if idx is not None and key not in lay.substitutes:
                assert lay.joint_names[idx] in (key, "pelvis", "spine_base"), (lay.name, key)
    assert get_layout("nuitrack10").key_available.tolist() == [True, True, True, False, False]
    with pytest.raises(DataError, match="known layouts"):
        get_layout("openpose")


def test_key_joints_pick_the_mapped_joints_and_nan_where_absent(rng: np.random.Generator) -> None:
    inter = make(rng)
    kj = inter.key_joints()
    assert kj.shape == (12, 2, 5, 3)
    np.testing.assert_array_equal(kj[:, :, 1], inter.joints[:, :, LAYOUTS["kinect_v2"].index("left_wrist")])
    nuisi = make(rng, layout="nuitrack10")
    kn = nuisi.key_joints()
    assert np.isnan(kn[:, :, 3:]).all() and np.isfinite(kn[:, :, :3]).all()


def test_invalid_joints_are_interpolated_in_time(rng: np.random.Generator) -> None:
    lay = LAYOUTS["sbu15"]
    T = 6
    joints = np.zeros((T, 2, lay.n_joints, 3))
    joints[:, 1, 5, 0] = np.arange(T, dtype=float)  # linear motion in x
    valid = np.ones((T, 2, lay.n_joints), dtype=bool)
    valid[2:4, 1, 5] = False
    joints[2:4, 1, 5] = np.nan
    inter = make(rng, T=T, layout="sbu15", joints=joints, valid=valid)
    filled = inter.filled_joints()
    np.testing.assert_allclose(filled[:, 1, 5, 0], np.arange(T, dtype=float), atol=1e-12)
    assert not inter.key_valid()[2, 1, 1] and inter.key_valid()[1, 1, 1]


@pytest.mark.parametrize(
    ("change", "field", "expected"),
    [
        ({"fps": 0.0}, "fps", "> 0"),
        ({"fps": float("nan")}, "fps", "finite"),
        ({"label": "Shake Hands"}, "label", "snake_case"),
        ({"joints": np.zeros((12, 2, 25))}, "joints", r"\(T, 2, J, 3\)"),
        ({"joints": np.zeros((0, 2, 25, 3))}, "joints", "empty"),
        ({"joints": np.zeros((2, 2, 25, 3))}, "joints", "too short"),
        ({"joint_names": ("a",) * 25}, "joint_names", "no known layout"),
        ({"object": np.zeros((11, 3))}, "object", r"\(12, 3\)"),
        ({"actors": ("a01",)}, "actors", "two non-empty"),
        ({"subevents": np.full(12, 3), "subevent_names": ("a", "b")}, "subevents", r"\[-1, 1\]"),
        ({"valid": np.ones((12, 2, 24), bool)}, "valid", "expected shape"),
    ],
)
def test_validation_names_the_field(rng: np.random.Generator, change: dict, field: str, expected: str) -> None:
    with pytest.raises(DataError, match=expected) as info:
        make(rng, **change)
    assert info.value.field == field
    assert isinstance(info.value, SocialAffError)


def test_nonfinite_outside_mask_is_rejected_inside_mask_accepted(rng: np.random.Generator) -> None:
    inter = make(rng)
    joints = inter.joints.copy()
    joints[3, 0, 7, 1] = np.nan
    with pytest.raises(DataError, match="frame 3, agent 0, joint 'left_hand'"):
        make(rng, joints=joints)
    valid = np.ones((12, 2, 25), bool)
    valid[3, 0, 7] = False
    ok = make(rng, joints=joints, valid=valid)
    assert np.isfinite(ok.filled_joints()).all()


def test_arrays_are_read_only_copies(rng: np.random.Generator) -> None:
    joints = rng.normal(size=(12, 2, 25, 3))
    inter = make(rng, joints=joints)
    joints[0, 0, 0, 0] = 99.0
    assert inter.joints[0, 0, 0, 0] != 99.0
    with pytest.raises(ValueError):
        inter.joints[0, 0, 0, 0] = 1.0


def test_npz_round_trip_is_identical(tmp_path: Path, rng: np.random.Generator) -> None:
    valid = rng.random((12, 2, 25)) > 0.1
    joints = 0.3 * rng.normal(size=(12, 2, 25, 3))
    joints[~valid] = np.nan
    inter = make(
        rng,
        joints=joints,
        valid=valid,
        object=rng.normal(size=(12, 3)),
        subevents=np.repeat(np.arange(3), 4),
        subevent_names=("approach", "reach", "shake"),
    )
    path = save_interaction(inter, tmp_path / "one.npz")
    back = load_interaction(path)
    assert back.same_as(inter)
    assert back.source == "test"
    with np.load(path, allow_pickle=False) as data:
        assert int(data["format_version"]) == FORMAT_VERSION


def test_dataset_folder_round_trip(tmp_path: Path, rng: np.random.Generator) -> None:
    items = tuple(make(rng, instance_id=f"i{k}", actors=(f"a{k}", "b")) for k in range(3))
    save_dataset(Dataset("x", items), tmp_path)
    back = load_npz_dataset(tmp_path)
    assert len(back) == 3
    assert all(a.same_as(b) for a, b in zip(items, back, strict=True))


def _rewrite(path: Path, **changes: np.ndarray) -> None:
    with np.load(path, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    for k, v in changes.items():
        if v is None:
            arrays.pop(k)
        else:
            arrays[k] = v
    np.savez(path, **arrays)


@pytest.mark.parametrize(
    ("changes", "field", "expected"),
    [
        ({"format_version": np.array(99)}, "format_version", "expected format_version 1, found 99"),
        ({"joints": None}, "joints", "missing required keys"),
        ({"fps": np.array(-1.0)}, "fps", "> 0"),
        ({"label": np.array("Bad Label")}, "label", "snake_case"),
        ({"actors": np.array(["a"])}, "actors", "2 strings"),
        ({"joints": np.zeros((12, 2, 25, 2))}, "joints", r"\(T, 2, J, 3\)"),
    ],
)
def test_bad_files_name_file_and_field(
    tmp_path: Path, rng: np.random.Generator, changes: dict, field: str, expected: str
) -> None:
    path = save_interaction(make(rng), tmp_path / "bad.npz")
    _rewrite(path, **changes)
    with pytest.raises(DataError, match=expected) as info:
        load_interaction(path)
    assert info.value.field == field
    assert str(path) in str(info.value)


def test_truncated_file_is_a_clear_error(tmp_path: Path, rng: np.random.Generator) -> None:
    path = save_interaction(make(rng), tmp_path / "t.npz")
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(DataError, match="not a readable .npz") as info:
        load_interaction(path)
    assert str(path) in str(info.value)


def test_failed_save_leaves_previous_file_intact(tmp_path: Path, rng: np.random.Generator, monkeypatch) -> None:
    inter = make(rng)
    path = save_interaction(inter, tmp_path / "keep.npz")
    before = path.read_bytes()

    def boom(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(np, "savez_compressed", boom)
    with pytest.raises(OSError, match="disk full"):
        save_interaction(make(rng, label="high_five"), path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["keep.npz"]


def test_actor_disjoint_folds(rng: np.random.Generator) -> None:
    pairs = [("a1", "a2"), ("a2", "a1"), ("a3", "a4"), ("a5", "a6"), ("a7", "a8"), ("a1", "a3")] * 3
    items = [make(rng, actors=p, instance_id=f"i{k}") for k, p in enumerate(pairs)]
    folds = actor_disjoint_folds(items, 4, rng=np.random.default_rng(0))
    assert len(folds) == 4
    tested = np.concatenate([test for _, test in folds])
    assert sorted(tested.tolist()) == list(range(len(items)))
    for train, test in folds:
        train_pairs = {tuple(sorted(items[i].actors)) for i in train}
        test_pairs = {tuple(sorted(items[i].actors)) for i in test}
        assert not train_pairs & test_pairs
        assert len(test) > 0
    with pytest.raises(DataError, match="actor pairs"):
        actor_disjoint_folds(items[:2], 4, rng=np.random.default_rng(0))


def test_saved_files_get_ordinary_permissions(tmp_path: Path, rng: np.random.Generator) -> None:
    import os

    mask = os.umask(0)
    os.umask(mask)
    path = save_interaction(make(rng), tmp_path / "perm.npz")
    assert path.stat().st_mode & 0o777 == 0o666 & ~mask


def test_hide_agent_after(rng: np.random.Generator) -> None:
    inter = make(rng, T=12)
    before = inter.joints.copy()
    hidden = inter.hide_agent_after(1, 5)
    assert np.isnan(hidden.joints[5:, 1]).all() and not hidden.valid[5:, 1].any()
    np.testing.assert_array_equal(hidden.joints[:5], inter.joints[:5])
    np.testing.assert_array_equal(hidden.joints[:, 0], inter.joints[:, 0])
    np.testing.assert_array_equal(hidden.valid[:, 0], inter.valid[:, 0])
    filled = hidden.filled_joints()
    np.testing.assert_allclose(filled[5:, 1], np.broadcast_to(inter.filled_joints()[4, 1], filled[5:, 1].shape), atol=0)
    np.testing.assert_array_equal(inter.joints, before)  # the original is untouched
