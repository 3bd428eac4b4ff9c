"""Hostile and careless data: names that would become paths, implausible units, wrong types,
folders with unknown or empty files (lenient and strict), NuiSI and handover specifics."""

from __future__ import annotations

import io
import logging
import pickle
import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import shared_path

from socialaff_sim.data import LAYOUTS, Dataset, Interaction, load_dataset, load_interaction, load_npz_dataset
from socialaff_sim.data import save_dataset, save_interaction
from socialaff_sim.data.checks import body_sizes
from socialaff_sim.data.handover import load_handover
from socialaff_sim.data.names import MAX_NAME_LENGTH, check_file_stem
from socialaff_sim.data.nuisi import load_nuisi, read_nuisi_agent
from socialaff_sim.errors import DataError, UnsafePickleError

HOSTILE_NAMES = ["../../x", "../x", "/tmp/abs", "a/b", "a\\b", "a\x00b", "x" * (MAX_NAME_LENGTH + 1), "..", ".",
                 ".hidden", "-rf", "c:evil", "tab\tname", ""]


def person(rng: np.random.Generator, T: int = 12, scale: float = 1.0) -> np.ndarray:
    """(T, 2, 25, 3) two standing people about 1.6 m tall, 1.2 m apart (kinect_v2 layout), times ``scale``."""
    joints = rng.normal(scale=0.15, size=(T, 2, 25, 3))
    joints[..., 2] = np.linspace(0.0, 1.6, 25)  # feet to head
    joints[:, 1, :, 0] += 1.2
    return joints * scale


def make(rng: np.random.Generator, **kw: object) -> Interaction:
    args: dict[str, object] = dict(label="shake_hands", fps=15.0, joints=person(rng),
                                   joint_names=LAYOUTS["kinect_v2"].joint_names, actors=("a", "b"),
                                   instance_id="inst_0", source="test")
    args.update(kw)
    return Interaction(**args)  # type: ignore[arg-type]


def raw_npz(path: Path, inter: Interaction, **override: np.ndarray) -> Path:
    """Write ``inter`` as the npz format would, with some arrays replaced (bypassing Interaction's checks)."""
    arrays = dict(np.load(io.BytesIO(save_interaction(inter, path).read_bytes())))
    arrays.update(override)
    np.savez(path, **arrays)
    return path


# -- names that become paths ---------------------------------------------------------------------------
@pytest.mark.parametrize("name", HOSTILE_NAMES)
def test_hostile_names_are_not_file_stems(name: str) -> None:
    with pytest.raises(DataError):
        check_file_stem(name, field="instance_id")


@pytest.mark.parametrize("name", ["s01s02_05_001", "motion_normal_12", "handshake2_000", "Take 3 (b)"])
def test_ordinary_ids_are_file_stems(name: str) -> None:
    assert check_file_stem(name, field="instance_id") == name


@pytest.mark.parametrize("name", [n for n in HOSTILE_NAMES if n])
def test_npz_loader_refuses_hostile_instance_ids(tmp_path: Path, rng: np.random.Generator, name: str) -> None:
    path = raw_npz(tmp_path / "one.npz", make(rng), instance_id=np.array(name))
    with pytest.raises(DataError, match="instance_id"):
        load_interaction(path)


@pytest.mark.parametrize("name", [n for n in HOSTILE_NAMES if n])
def test_writer_refuses_hostile_ids_and_writes_nothing(tmp_path: Path, rng: np.random.Generator, name: str) -> None:
    good = make(rng, instance_id="fine")
    # An Interaction refuses such an id itself; a duck-typed one reaching save_dataset is refused there too.
    with pytest.raises(DataError, match="instance_id"):
        make(rng, instance_id=name)

    class Sneaky:
        instance_id = name
        source = "crafted"

    out = tmp_path / "deep" / "out"
    with pytest.raises(DataError, match="instance_id"):
        save_dataset([good, Sneaky()], out)  # type: ignore[arg-type]
    assert not out.exists()  # checked before the first file is written
    assert sorted(p.name for p in tmp_path.rglob("*")) == []


def test_model_label_from_file_is_checked_like_a_name() -> None:
    # (The model loader's own test, tests/test_hardening_model.py, covers meta.label = '../x'.)
    with pytest.raises(DataError):
        Interaction(label="../x", fps=1.0, joints=np.zeros((3, 2, 5, 3)), joint_names=("a",) * 5, actors=("a", "b"))


# -- values ------------------------------------------------------------------------------------------------
def test_body_size_matches_a_brute_force_loop(rng: np.random.Generator) -> None:
    inter = make(rng, valid=rng.random((12, 2, 25)) > 0.3)
    sizes, frames = body_sizes(inter)
    for a in range(2):
        ext = [np.ptp(inter.joints[t, a][inter.valid[t, a]], axis=0).max() for t in range(12)
               if inter.valid[t, a].sum() >= 2]
        assert frames[a] == len(ext)
        assert sizes[a] == pytest.approx(np.median(ext))


def test_int16_millimetres_read_as_metres_are_refused_with_the_unit_named(tmp_path: Path, rng) -> None:
    inter = make(rng)
    path = raw_npz(tmp_path / "mm.npz", inter, joints=np.round(inter.joints * 1000).astype(np.int16))
    with pytest.raises(DataError, match=r"units='mm'"):
        load_interaction(path)
    back = load_interaction(path, units="mm")
    np.testing.assert_allclose(back.joints, inter.joints, atol=1e-3)
    with pytest.raises(DataError, match="units"):
        load_interaction(path, units="furlong")


@pytest.mark.parametrize("change, match", [
    (lambda j: j * 1e300, "m across"),
    (lambda j: np.zeros_like(j), "one point"),
    (lambda j: j * 0.1, "m across"),   # a 16 cm "person"
])
def test_implausible_sizes_are_refused(tmp_path: Path, rng, change, match: str) -> None:
    inter = make(rng)
    path = raw_npz(tmp_path / "x.npz", inter, joints=change(inter.joints))
    with pytest.raises(DataError, match=match):
        load_interaction(path)


def test_a_never_tracked_agent_is_refused(tmp_path: Path, rng) -> None:
    inter = make(rng)
    valid = np.ones((12, 2, 25), bool)
    valid[:, 1] = False
    joints = inter.joints.copy()
    joints[:, 1] = np.nan
    path = raw_npz(tmp_path / "x.npz", inter, joints=joints, valid=valid)
    with pytest.raises(DataError, match="agent 1 has two or more valid joints in 0 frames"):
        load_interaction(path)


@pytest.mark.parametrize("arr, match", [
    (lambda j: j.astype(str), "dtype <U"),          # numeric strings: NumPy would parse them silently
    (lambda j: j.astype(complex), "complex"),       # NumPy would drop the imaginary part
])
def test_joint_dtypes_must_be_real_numbers(tmp_path: Path, rng, arr, match: str) -> None:
    inter = make(rng)
    path = raw_npz(tmp_path / "x.npz", inter, joints=arr(inter.joints))
    with pytest.raises(DataError, match=match):
        load_interaction(path)
    with pytest.raises(DataError, match="real numbers"):
        make(rng, joints=arr(inter.joints))


@pytest.mark.parametrize("names", [("approach", "Shake Hands"), ("approach", "approach"), ("", "x"), ("../up", "x")])
def test_unknown_subevent_names_are_refused(rng, names: tuple[str, str]) -> None:
    with pytest.raises(DataError, match="subevent_names"):
        make(rng, subevents=np.repeat([0, 1], 6), subevent_names=names)


# -- folders: lenient and strict ---------------------------------------------------------------------------
def _folder(tmp_path: Path, rng) -> Path:
    folder = tmp_path / "data"
    save_dataset(Dataset("x", (make(rng, instance_id="a"), make(rng, instance_id="b", actors=("c", "d")))), folder)
    (folder / "empty.npz").write_bytes(b"")
    (folder / "README.txt").write_text("notes")
    (folder / ".hidden.npz").write_bytes(b"junk")  # hidden files are not ours to judge
    return folder


def test_npz_folder_lenient_skips_unknown_and_empty_files_with_one_warning(tmp_path: Path, rng, caplog) -> None:
    folder = _folder(tmp_path, rng)
    with caplog.at_level(logging.WARNING, logger="socialaff_sim"):
        ds = load_npz_dataset(folder)
    assert [i.instance_id for i in ds] == ["a", "b"]
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1 and "skipped 2 file(s)" in warnings[0]
    assert "README.txt" in warnings[0] and "empty.npz" in warnings[0] and ".hidden" not in warnings[0]
    assert "README.txt" in ds.notes["skipped_files"]


def test_npz_folder_strict_stops_at_the_first_bad_file(tmp_path: Path, rng) -> None:
    folder = _folder(tmp_path, rng)
    with pytest.raises(DataError, match=r"README.txt: unknown file.*strict"):
        load_npz_dataset(folder, policy="strict")
    with pytest.raises(DataError, match="policy"):
        load_npz_dataset(folder, policy="sloppy")
    assert len(load_dataset(f"npz:{folder}", policy="lenient")) == 2
    with pytest.raises(DataError, match="README"):
        load_dataset(f"npz:{folder}", policy="strict")


def test_units_apply_to_npz_only() -> None:
    with pytest.raises(DataError, match="units"):
        load_dataset("synthetic", units="mm")


# -- NuiSI --------------------------------------------------------------------------------------------------
def test_nuisi_unknown_interaction_names_do_not_abort_the_load(tmp_path: Path, caplog) -> None:
    src = shared_path("nuisi_v1")
    for stem in ("wave1", "highfive1"):
        for k in (1, 2):
            shutil.copy(src / f"{stem}_agent{k}.bag.npz", tmp_path / f"{stem}_agent{k}.bag.npz")
    for alien in ("rocket1", "clapfist2"):
        for k in (1, 2):
            shutil.copy(src / f"wave1_agent{k}.bag.npz", tmp_path / f"{alien}_agent{k}.bag.npz")
    with caplog.at_level(logging.WARNING, logger="socialaff_sim"):
        ds = load_nuisi(tmp_path)
    assert set(ds.labels) == {"wave", "high_five"} and len(ds) > 10
    warning = " ".join(r.getMessage() for r in caplog.records)
    assert "rocket1_agent1.bag.npz: unknown interaction 'rocket'" in warning and "clapfist" in warning
    with pytest.raises(DataError, match="unknown interaction 'clapfist'"):
        load_nuisi(tmp_path, policy="strict")


def test_nuisi_file_with_zero_frames_is_a_data_error(tmp_path: Path) -> None:
    path = tmp_path / "clap1_agent1.bag.npz"
    np.savez(path, np.zeros((0, 10, 7)), np.zeros(0))
    with pytest.raises(DataError, match=r"'arr_0'.*at least 3 frames, found 0"):
        read_nuisi_agent(path)


# -- handover ----------------------------------------------------------------------------------------------
def test_handover_reads_variation_files_too(tmp_path: Path) -> None:
    src = shared_path("handover_h2h")
    shutil.copy(src / "motion_normal_1.pkl", tmp_path / "motion_normal_1.pkl")
    shutil.copy(src / "motion_normal_0.pkl", tmp_path / "motion_variation_3.pkl")
    (tmp_path / "notes.txt").write_text("x")
    ds = load_handover(tmp_path)
    assert [i.instance_id for i in ds] == ["motion_normal_1", "motion_variation_3"]
    assert ds[1].actors == ("motion_variation_3/giver", "motion_variation_3/receiver")
    assert [i.instance_id for i in load_handover(tmp_path, variations=False)] == ["motion_normal_1"]
    assert "notes.txt" in ds.notes["skipped_files"]


def test_a_forbidden_pickle_stops_even_a_lenient_load(tmp_path: Path) -> None:
    src = shared_path("handover_h2h")
    shutil.copy(src / "motion_normal_1.pkl", tmp_path / "motion_normal_1.pkl")
    (tmp_path / "motion_normal_2.pkl").write_bytes(pickle.dumps({"x": print}, protocol=4))
    with pytest.raises(UnsafePickleError, match="builtins.print"):
        load_handover(tmp_path)
    (tmp_path / "motion_normal_2.pkl").write_bytes(b"")
    assert len(load_handover(tmp_path)) == 1  # an empty file is only skipped


# -- names from file names in the other loaders --------------------------------------------------------------
def test_handover_overlong_file_name_is_skipped_not_written_anywhere(tmp_path: Path) -> None:
    src = shared_path("handover_h2h")
    shutil.copy(src / "motion_normal_1.pkl", tmp_path / "motion_normal_1.pkl")
    long_name = f"motion_normal_{'9' * 130}.pkl"  # a valid pattern whose stem (the id) is 144 characters
    shutil.copy(src / "motion_normal_0.pkl", tmp_path / long_name)
    ds = load_handover(tmp_path)
    assert [i.instance_id for i in ds] == ["motion_normal_1"]
    assert long_name in ds.notes["skipped_files"] and "instance_id" in ds.notes["skipped_files"]
    with pytest.raises(DataError, match="instance_id"):
        load_handover(tmp_path, policy="strict")


def test_nuisi_option_like_and_overlong_stems_are_skipped(tmp_path: Path) -> None:
    src = shared_path("nuisi_v1")
    for stem in ("wave1", f"wave{'1' * 130}", "-wave2"):
        for k in (1, 2):
            shutil.copy(src / f"wave1_agent{k}.bag.npz", tmp_path / f"{stem}_agent{k}.bag.npz")
    ds = load_nuisi(tmp_path)
    assert {i.instance_id.rsplit("_", 1)[0] for i in ds} == {"wave1"}
    skipped = ds.notes["skipped_files"]
    assert "-wave2_agent1.bag.npz: unknown interaction '-wave'" in skipped and "instance_id" in skipped
