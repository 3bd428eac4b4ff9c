"""Saving and loading the affordance model: round trip and the errors on bad files."""

from __future__ import annotations

import copy
import io
import json
from pathlib import Path

import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.errors import ModelFileError
from socialaff_sim.learning.config import LearningConfig
from socialaff_sim.learning import SocialAffordanceModel
from socialaff_sim.model.contact_keys import ContactKeys
from socialaff_sim.learning.model_io import MODEL_FORMAT_VERSION

ARRAYS = (
    "available_", "grouping_", "spatial_params_", "motion_params_", "duration_params_", "transitions_",
    "start_probs_", "centroids_", "mean_end_", "vertical_up_", "hand_coupling_", "trace_", "acceptance_",
)


@pytest.fixture(scope="module")
def data():
    return list(generate_dataset(0, SyntheticConfig(interactions=("throw_catch",), instances_per_interaction=6)))


@pytest.fixture(scope="module")
def model(data) -> SocialAffordanceModel:  # noqa: ANN001
    return SocialAffordanceModel(learning=LearningConfig(iterations=2)).fit(data[:5], rng=np.random.default_rng(4))


@pytest.fixture
def saved(model: SocialAffordanceModel, tmp_path: Path) -> Path:
    return model.save(tmp_path / "m.npz")


def test_round_trip(model: SocialAffordanceModel, saved: Path, data) -> None:  # noqa: ANN001
    loaded = SocialAffordanceModel.load(saved)
    for name in ARRAYS:
        np.testing.assert_array_equal(getattr(loaded, name), getattr(model, name), err_msg=name)
    assert loaded.config == model.config and loaded.learning == model.learning
    assert loaded.label_ == model.label_ and loaded.subevent_names_ == model.subevent_names_
    assert loaded.instance_ids_ == model.instance_ids_
    assert loaded.log_posterior_ == model.log_posterior_ and loaded.moves_ == model.moves_
    for a, b in zip(loaded.parses_, model.parses_, strict=True):
        np.testing.assert_array_equal(a, b)
    assert loaded.score(data[5:]) == model.score(data[5:])
    with np.load(saved, allow_pickle=False) as npz:  # nothing pickled
        assert all(npz[k].dtype != object for k in npz.files)


def test_contact_keys_round_trip(model: SocialAffordanceModel, tmp_path: Path) -> None:
    m = copy.deepcopy(model)
    keys = ContactKeys.empty(m.n_subevents_)
    keys.phase[1, 2], keys.mate[1, 2], keys.offset[1, 2] = 0.45, 2, [0.12, 0.01, -0.02]
    keys.phase[0, 1], keys.mate[0, 1], keys.offset[0, 1] = 0.7, 10, [0.0, 0.05, 0.0]
    keys.pose[1, 2], keys.spread[1, 2] = [0.4, 0.0, 0.7], 0.13
    keys.pose[0, 1], keys.spread[0, 1] = [0.5, 0.1, 0.3], 0.1
    m.contact_keys_ = keys
    loaded = SocialAffordanceModel.load(m.save(tmp_path / "k.npz"))
    for field in ("phase", "mate", "offset", "pose", "spread"):
        np.testing.assert_array_equal(getattr(loaded.contact_keys_, field), getattr(keys, field), err_msg=field)
    assert loaded.contact_keys_.of_type(1)[0][:3] == (7, 2, 0.45)
    bad = keys.mate.copy()
    bad[1, 2] = -1  # a phase without a mate
    with pytest.raises(ModelFileError, match="'contact_mate': expected a joint index"):
        SocialAffordanceModel.load(_rewrite(tmp_path / "k.npz", tmp_path / "bad.npz", contact_mate=bad))


def _rewrite(src: Path, dst: Path, **changes) -> Path:  # noqa: ANN003
    with np.load(src, allow_pickle=False) as npz:
        arrays = {k: npz[k] for k in npz.files}
    meta = json.loads(str(arrays["meta"]))
    for k, v in changes.items():
        if k == "drop":
            arrays.pop(v)
        elif k in meta:
            meta[k] = v
        else:
            arrays[k] = v
    arrays["meta"] = np.array(json.dumps(meta))
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    dst.write_bytes(buf.getvalue())
    return dst


def test_other_format_version(saved: Path, tmp_path: Path) -> None:
    bad = _rewrite(saved, tmp_path / "v99.npz", format_version=MODEL_FORMAT_VERSION + 98)
    with pytest.raises(ModelFileError, match=rf"format_version.*expected {MODEL_FORMAT_VERSION}, found {MODEL_FORMAT_VERSION + 98}"):
        SocialAffordanceModel.load(bad)


def test_truncated_file(saved: Path, tmp_path: Path) -> None:
    data = saved.read_bytes()
    cut = tmp_path / "cut.npz"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(ModelFileError, match="truncated"):
        SocialAffordanceModel.load(cut)
    empty = tmp_path / "empty.npz"
    empty.write_bytes(b"")
    with pytest.raises(ModelFileError, match=str(empty.name)):
        SocialAffordanceModel.load(empty)


def test_missing_and_malformed_fields(saved: Path, tmp_path: Path) -> None:
    with pytest.raises(ModelFileError, match="'grouping': missing"):
        SocialAffordanceModel.load(_rewrite(saved, tmp_path / "a.npz", drop="grouping"))
    with pytest.raises(ModelFileError, match="'transitions': expected shape"):
        SocialAffordanceModel.load(_rewrite(saved, tmp_path / "b.npz", transitions=np.zeros((2, 3))))
    with pytest.raises(ModelFileError, match="format"):
        SocialAffordanceModel.load(_rewrite(saved, tmp_path / "c.npz", format="something_else"))
    with pytest.raises(ModelFileError, match="no such model file"):
        SocialAffordanceModel.load(tmp_path / "nothing.npz")
    other = tmp_path / "other.npz"
    np.savez(other, x=np.zeros(3))
    with pytest.raises(ModelFileError, match="missing"):
        SocialAffordanceModel.load(other)


def test_pickled_arrays_are_refused(saved: Path, tmp_path: Path) -> None:
    bad = _rewrite(saved, tmp_path / "p.npz", grouping=np.array([{"a": 1}], dtype=object))
    with pytest.raises(ModelFileError, match="not a readable model file"):
        SocialAffordanceModel.load(bad)


def test_save_is_atomic(model: SocialAffordanceModel, saved: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    before = saved.read_bytes()

    def boom(*args, **kwargs):  # noqa: ANN002, ANN003
        raise OSError("disk full")

    monkeypatch.setattr("socialaff_sim._atomic.os.replace", boom)  # fail at the final rename
    with pytest.raises(OSError, match="disk full"):
        model.save(saved)
    assert saved.read_bytes() == before
    assert [p.name for p in saved.parent.iterdir()] == [saved.name]



def test_an_offset_weight_other_than_0_or_1_is_rejected(saved: Path, tmp_path: Path) -> None:
    with np.load(saved, allow_pickle=False) as npz:
        w = npz["end_offset_weight"].copy()
    assert np.isfinite(w).any()
    w[np.isfinite(w)] = 0.5
    with pytest.raises(ModelFileError, match="'end_offset_weight': expected 0 or 1 where end_ridge is set, found \\[0.5\\]"):
        SocialAffordanceModel.load(_rewrite(saved, tmp_path / "w.npz", end_offset_weight=w))
