"""Fuzzing the npz and model loaders (hypothesis): any bytes give a valid object or the package's own error.

Three kinds of input per loader: arbitrary bytes; a valid file with bytes flipped, inserted or cut
(so that the zip structure mostly survives and the damage reaches the arrays' headers and data); and,
structurally, valid archives in which one array is replaced by an arbitrary one (any dtype, shape,
values). Bounded (``max_examples``) so that the suite stays fast; no deadline (the machine is shared).
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from socialaff_sim.data import LAYOUTS, Interaction, load_interaction
from socialaff_sim.data.npz_format import _to_bytes
from socialaff_sim.errors import SocialAffError
from socialaff_sim.learning.estimator import SocialAffordanceModel

FUZZ = settings(max_examples=60, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


def _interaction_bytes() -> bytes:
    """A valid interaction file, uncompressed (so that damage reaches the arrays, not only the deflate stream)."""
    rng = np.random.default_rng(0)
    joints = rng.normal(scale=0.15, size=(6, 2, 25, 3))
    joints[..., 2] = np.linspace(0.0, 1.6, 25)
    inter = Interaction("shake_hands", 15.0, joints, LAYOUTS["kinect_v2"].joint_names, ("a", "b"),
                        subevents=np.repeat([0, 1], 3), subevent_names=("reach", "shake"), instance_id="i0")
    buf = io.BytesIO()
    np.savez(buf, **dict(np.load(io.BytesIO(_to_bytes(inter)))))
    return buf.getvalue()


VALID_NPZ = _interaction_bytes()


def _mutate(data: bytes, edits: list[tuple[int, int, int]]) -> bytes:
    """Apply (kind, position, byte) edits: 0 flip a byte, 1 insert one, 2 cut the rest."""
    out = bytearray(data)
    for kind, pos, value in edits:
        if not out:
            break
        pos %= len(out)
        if kind == 0:
            out[pos] = value
        elif kind == 1:
            out.insert(pos, value)
        else:
            del out[pos:]
    return bytes(out)


EDITS = st.lists(st.tuples(st.integers(0, 2), st.integers(0, 1 << 20), st.integers(0, 255)), min_size=1, max_size=6)


def _load_npz(tmp_path: Path, data: bytes) -> None:
    path = tmp_path / "fuzz.npz"
    path.write_bytes(data)
    try:
        inter = load_interaction(path)
    except SocialAffError:
        return
    assert isinstance(inter, Interaction) and np.isfinite(inter.joints[inter.valid]).all()


@FUZZ
@given(data=st.binary(max_size=2048))
def test_npz_loader_on_arbitrary_bytes(tmp_path: Path, data: bytes) -> None:
    _load_npz(tmp_path, data)


@FUZZ
@given(edits=EDITS)
def test_npz_loader_on_damaged_files(tmp_path: Path, edits: list[tuple[int, int, int]]) -> None:
    _load_npz(tmp_path, _mutate(VALID_NPZ, edits))


ANY_ARRAY = hnp.arrays(
    dtype=st.one_of(hnp.scalar_dtypes(), hnp.byte_string_dtypes(max_len=4), hnp.unicode_string_dtypes(max_len=4)),
    shape=hnp.array_shapes(min_dims=0, max_dims=4, max_side=4),
)


@FUZZ
@given(key=st.sampled_from(["format_version", "joints", "joint_names", "fps", "label", "actors", "object", "valid",
                            "subevents", "subevent_names", "source", "instance_id"]), value=ANY_ARRAY)
def test_npz_loader_with_one_array_replaced(tmp_path: Path, key: str, value: np.ndarray) -> None:
    arrays = dict(np.load(io.BytesIO(VALID_NPZ)))
    arrays[key] = value
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    _load_npz(tmp_path, buf.getvalue())


# -- the model loader ---------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def model_arrays(shake8_model, tmp_path_factory) -> dict[str, np.ndarray]:  # noqa: ANN001
    path = shake8_model.save(tmp_path_factory.mktemp("fuzz_model") / "model.npz")
    with np.load(path) as data:
        return {k: data[k] for k in data.files}


def _load_model(tmp_path: Path, data: bytes) -> None:
    path = tmp_path / "model.npz"
    path.write_bytes(data)
    try:
        model = SocialAffordanceModel.load(path)
    except SocialAffError:
        return
    assert np.isfinite(model.transitions_).all() and np.allclose(model.transitions_.sum(axis=1), 1.0)


@FUZZ
@given(data=st.binary(max_size=2048))
def test_model_loader_on_arbitrary_bytes(tmp_path: Path, data: bytes) -> None:
    _load_model(tmp_path, data)


@FUZZ
@given(edits=EDITS)
def test_model_loader_on_damaged_files(tmp_path: Path, model_arrays: dict[str, np.ndarray],
                                       edits: list[tuple[int, int, int]]) -> None:
    buf = io.BytesIO()
    np.savez(buf, **model_arrays)
    _load_model(tmp_path, _mutate(buf.getvalue(), edits))


@FUZZ
@given(key=st.sampled_from(["meta", "available", "grouping", "spatial_params", "transitions", "start_probs",
                            "centroids", "duration_params", "hand_coupling", "contact_mate", "parse_rows",
                            "parse_offsets", "end_ridge", "trace"]), value=ANY_ARRAY)
def test_model_loader_with_one_array_replaced(tmp_path: Path, model_arrays: dict[str, np.ndarray], key: str,
                                              value: np.ndarray) -> None:
    arrays = dict(model_arrays)
    arrays[key] = value
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    _load_model(tmp_path, buf.getvalue())
