"""Model files are validated on load: schema, shapes, finite values, probabilities, version."""

from __future__ import annotations

import io
import json
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from numpy.lib import format as npy_format

from socialaff_sim.errors import ModelFileError
from socialaff_sim.learning.estimator import SocialAffordanceModel
from socialaff_sim.learning.model_io import MODEL_FORMAT_VERSION


@pytest.fixture(scope="module")
def arrays(shake8_model, tmp_path_factory) -> dict[str, np.ndarray]:  # noqa: ANN001
    path = shake8_model.save(tmp_path_factory.mktemp("model") / "model.npz")
    with np.load(path) as data:
        return {k: data[k] for k in data.files}


def _meta(a: dict[str, np.ndarray]) -> dict:
    return json.loads(str(a["meta"]))


def _with_meta(change: Callable[[dict], object]) -> Callable[[dict[str, np.ndarray]], None]:
    def apply(a: dict[str, np.ndarray]) -> None:
        meta = _meta(a)
        a["meta"] = np.array(json.dumps(change(meta)))
    return apply


def _set(key: str, fn: Callable[[np.ndarray], np.ndarray]) -> Callable[[dict[str, np.ndarray]], None]:
    def apply(a: dict[str, np.ndarray]) -> None:
        a[key] = fn(a[key].copy())
    return apply


def _nan_at(arr: np.ndarray, value: float = np.nan) -> np.ndarray:
    arr.flat[0] = value
    return arr


def _negative_start(p: np.ndarray) -> np.ndarray:
    p[0], p[1] = -0.2, p[1] + p[0] + 0.2  # still sums to 1
    return p


CASES = {
    "meta as a list": (_with_meta(lambda m: [m]), "'meta'.*JSON object, found a JSON list"),
    "meta label a path": (_with_meta(lambda m: {**m, "label": "../../x"}), "'label'.*snake_case"),
    "subevent names not a list": (_with_meta(lambda m: {**m, "subevent_names": "abc"}), "'subevent_names'"),
    "duplicate subevent names": (_with_meta(lambda m: {**m, "subevent_names": ["a"] * len(m["subevent_names"])}),
                                 "'subevent_names'.*distinct"),
    "older version": (_with_meta(lambda m: {**m, "format_version": MODEL_FORMAT_VERSION - 1}), "'format_version'"),
    "moves malformed": (_with_meta(lambda m: {**m, "moves": {"merge": "x"}}), "'moves'"),
    "NaN transitions": (_set("transitions", _nan_at), "'transitions'.*NaN"),
    "inf spatial": (_set("spatial_params", lambda x: _nan_at(x, np.inf)), "'spatial_params'.*inf"),
    "negative start probability": (_set("start_probs", _negative_start), r"'start_probs'.*\[0, 1\]"),
    "rows not summing to 1": (_set("transitions", lambda t: t * 0.5), "'transitions'.*sum to 1"),
    "hand coupling above 1": (_set("hand_coupling", lambda h: h * 2), "'hand_coupling'"),
    "wrong-width centroids": (_set("centroids", lambda c: c[:, :-1]), "'centroids'.*6 per available joint"),
    "no centroids": (_set("centroids", lambda c: c[:0]), "'centroids'"),
    "duration sigma 0": (_set("duration_params", lambda d: d * [1, 0]), "'duration_params'.*σ"),
    "grouping out of range": (_set("grouping", lambda g: g + 100), "'grouping'"),
    "transitions of the wrong shape": (_set("transitions", lambda t: t[:, :-1]), "'transitions'.*shape"),
    "acceptance above 1": (_set("acceptance", lambda x: x + 2), "'acceptance'"),
    "negative path sigma": (_set("path_sigma", lambda x: -np.abs(x)), "'path_sigma'"),
    "parse label out of range": (_set("parse_rows", lambda r: r + [0, 0, 99]), "'parse_rows'"),
    "string transitions": (_set("transitions", lambda t: t.astype(str)), "'transitions'.*kind"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_malformed_model_files_are_refused_naming_the_field(arrays, tmp_path: Path, case: str) -> None:
    change, match = CASES[case]
    a = dict(arrays)
    change(a)
    path = tmp_path / "bad.npz"
    np.savez(path, **a)
    with pytest.raises(ModelFileError, match=match) as info:
        SocialAffordanceModel.load(path)
    assert str(path) in str(info.value)


def test_the_unchanged_file_loads(arrays, tmp_path: Path) -> None:
    path = tmp_path / "ok.npz"
    np.savez(path, **arrays)
    model = SocialAffordanceModel.load(path)
    np.testing.assert_array_equal(model.transitions_, arrays["transitions"])


def test_a_header_claiming_terabytes_is_refused_before_allocation(arrays, tmp_path: Path) -> None:
    path = tmp_path / "huge.npz"
    np.savez(path, **{k: v for k, v in arrays.items() if k != "centroids"})
    member = io.BytesIO()
    npy_format.write_array_header_1_0(member, {"descr": "<f8", "fortran_order": False, "shape": (10**9, 1000)})
    member.write(b"\0" * 64)  # 8 TB declared, 64 bytes present
    with zipfile.ZipFile(path, "a") as zf:
        zf.writestr("centroids.npy", member.getvalue())
    with pytest.raises(ModelFileError, match=r"header declares 8000000000000 bytes.*'centroids'"):
        SocialAffordanceModel.load(path)
