"""The affordance model's file format: one ``.npz`` holding arrays plus a JSON metadata string.

Layout (format ``socialaff_sim.affordance_model``, version :data:`MODEL_FORMAT_VERSION`):

``meta``
    0-d unicode array: JSON object with ``format``, ``format_version``, ``package_version``,
    ``label``, ``subevent_names``, ``joint_names``, ``instance_ids``, ``config``
    (:class:`~socialaff_sim.model.config.AffordanceConfig` fields), ``learning``
    (:class:`~socialaff_sim.learning.config.LearningConfig` fields), ``log_posterior``,
    ``acceptance_rate``, ``moves`` and ``fit_seconds``.
``available`` (11,) bool; ``grouping`` (S, 11) int64; ``spatial_params`` and ``motion_params``
    (S, 11, 6) float64; ``duration_params`` (S, 2) float64 (μ, σ of log seconds); ``transitions``
    (S, S) and ``start_probs`` (S,) float64; ``centroids`` (K, D) float64 (K-means of the atoms);
``mean_end`` (S, 11, 3) float64, metres: mean canonical key-joint configuration at each type's end;
``vertical_up`` (S, 2, 11) float64: frequency of dz > 0 of spatial offsets and displacements;
``path_sigma`` (S, 11) float64, metres: path-noise σ per type and joint (NaN where unused or
    without ``path_noise``);
``end_context_mean``, ``end_context_scale`` (S, C), ``end_target_mean`` (S, 15), ``end_coef`` (S, C, 15),
    ``end_cov`` (S, 15, 15), ``end_ridge`` and ``end_offset_weight`` (S,) float64: the end-configuration
    regressions (:mod:`~socialaff_sim.model.end_regression`), all NaN for a type without one;
``frame_context_mean``, ``frame_context_scale`` (S, C'), ``frame_target_mean`` (S, 15), ``frame_coef`` (S, C', 15),
    ``frame_cov`` (S, 15, 15), ``frame_ridge`` and ``frame_offset_weight`` (S,) float64: the frame regressions
    (:mod:`~socialaff_sim.model.frame_regression`), likewise;
``hand_coupling`` (2, 2) float64: p(agent 1 left-active | agent 0's flag) (:mod:`~socialaff_sim.model.handedness`);
``contact_phase`` (S, 5) float64, ``contact_mate`` (S, 5) int64, ``contact_offset`` and ``contact_pose`` (S, 5, 3)
    float64, metres, and ``contact_spread`` (S, 5) float64, metres: agent 1's contact keyframes
    (:mod:`~socialaff_sim.model.contact_keys`; NaN / −1 where none);
``trace`` (I + 1,) and ``acceptance`` (I,) float64;
``parse_rows`` (R, 3) int64 (start frame, stop frame, label) of all training parses, split per
    instance by ``parse_offsets`` (n + 1,) int64.

Files are written atomically and read with ``allow_pickle=False``; no code objects are stored.
A missing, truncated or malformed file, or one of another format version, raises
:class:`~socialaff_sim.errors.ModelFileError` naming the file and the field.
"""

from __future__ import annotations

import io
import json
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from .. import __version__
from .._atomic import atomic_write_bytes
from ..data.npz_reader import read_npz
from ..errors import ConfigError, DataError, ModelFileError
from ..data.skeletons import N_KEY
from ..model.affordance import AffordanceParameters
from ..model.config import AffordanceConfig
from ..model.contact_keys import ContactKeys
from ..model.end_regression import n_context, offset_columns
from ..model.frame_regression import frame_offset_columns, n_frame_context
from ..model.ridge import RidgeRegression
from ..model.joints import JOINT_NAMES, N_JOINTS
from .config import LearningConfig
from .model_checks import check_meta, check_values

__all__ = ["MODEL_FORMAT", "MODEL_FORMAT_VERSION", "save_model", "read_model"]

MODEL_FORMAT = "socialaff_sim.affordance_model"
MODEL_FORMAT_VERSION = 8
"""Version written into every model file; readers reject other versions."""

_ARRAYS = (
    "available", "grouping", "spatial_params", "motion_params", "duration_params", "transitions",
    "start_probs", "centroids", "mean_end", "vertical_up", "path_sigma", "end_context_mean", "end_context_scale", "end_target_mean", "end_coef", "end_cov", "end_ridge", "end_offset_weight",
    "frame_context_mean", "frame_context_scale", "frame_target_mean", "frame_coef", "frame_cov", "frame_ridge", "frame_offset_weight", "hand_coupling",
    "contact_phase", "contact_mate", "contact_offset", "contact_pose", "contact_spread", "trace", "acceptance", "parse_rows", "parse_offsets",
)


def save_model(model: AffordanceParameters, path: str | Path) -> Path:
    """Write a fitted model (a :class:`~socialaff_sim.learning.SocialAffordanceModel`) to ``path``
    atomically; returns the path."""
    path = Path(path)
    parses = model.parses_
    rows = np.concatenate(parses) if parses else np.zeros((0, 3), np.int64)
    offsets = np.concatenate([[0], np.cumsum([len(p) for p in parses])]).astype(np.int64)
    meta = {
        "format": MODEL_FORMAT,
        "format_version": MODEL_FORMAT_VERSION,
        "package_version": __version__,
        "label": model.label_,
        "subevent_names": list(model.subevent_names_),
        "joint_names": list(JOINT_NAMES),
        "instance_ids": list(model.instance_ids_),
        "config": model.config.to_dict(),
        "learning": model.learning.to_dict(),  # type: ignore[attr-defined]  # the estimator's settings
        "log_posterior": float(model.log_posterior_),
        "acceptance_rate": float(model.acceptance_rate_),
        "moves": {k: list(v) for k, v in model.moves_.items()},
        "fit_seconds": dict(model.__dict__.get("fit_seconds_", {})),
    }
    arrays = {
        "meta": np.array(json.dumps(meta)),
        "available": model.available_,
        "grouping": model.grouping_,
        "spatial_params": model.spatial_params_,
        "motion_params": model.motion_params_,
        "duration_params": model.duration_params_,
        "transitions": model.transitions_,
        "start_probs": model.start_probs_,
        "centroids": model.centroids_,
        "mean_end": model.mean_end_,
        "vertical_up": model.vertical_up_,
        "path_sigma": model.path_sigma_,
        **_ridge_arrays("end", model.end_regression_, n_context(model.available_)),
        **_ridge_arrays("frame", model.frame_regression_, n_frame_context(model.available_)),
        "hand_coupling": model.hand_coupling_,
        "contact_phase": model.contact_keys_.phase,
        "contact_mate": model.contact_keys_.mate.astype(np.int64),
        "contact_offset": model.contact_keys_.offset,
        "contact_pose": model.contact_keys_.pose,
        "contact_spread": model.contact_keys_.spread,
        "trace": np.asarray(model.trace_, float),
        "acceptance": np.asarray(model.acceptance_, float),
        "parse_rows": rows.astype(np.int64).reshape(-1, 3),
        "parse_offsets": offsets,
    }
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)  # type: ignore[arg-type]
    atomic_write_bytes(path, buf.getvalue())
    return path


def _ridge_shapes(C: int) -> dict[str, tuple[int, ...]]:
    """Shape of each field of one type's regression with a context of length C (target: 15)."""
    return {
        "context_mean": (C,), "context_scale": (C,), "target_mean": (15,), "coef": (C, 15), "cov": (15, 15), "ridge": (),
        "offset_weight": (),
    }


_RIDGE_FIELDS = tuple(_ridge_shapes(0))


def _ridge_arrays(prefix: str, regs: list[RidgeRegression | None], C: int) -> dict[str, np.ndarray]:
    """The regressions stacked per type, NaN for a type without one, keys ``<prefix>_<field>``."""
    S = len(regs)
    out = {k: np.full((S, *shp), np.nan) for k, shp in _ridge_shapes(C).items()}
    for s, reg in enumerate(regs):
        if reg is not None:
            for k in _RIDGE_FIELDS:
                out[k][s] = getattr(reg, k)
    return {f"{prefix}_{k}": v for k, v in out.items()}


def _ridge_regressions(prefix: str, a: dict[str, np.ndarray], S: int, columns: np.ndarray) -> list[RidgeRegression | None]:
    """The regressions of the arrays ``<prefix>_<field>``; ``columns`` (15,): their offset columns."""
    regs: list[RidgeRegression | None] = []
    for s in range(S):
        if np.isnan(a[f"{prefix}_ridge"][s]):
            regs.append(None)
            continue
        fields: dict[str, Any] = {k: a[f"{prefix}_{k}"][s].astype(float) for k in _RIDGE_FIELDS}
        fields["ridge"], fields["offset_weight"] = float(fields["ridge"]), float(fields["offset_weight"])
        regs.append(RidgeRegression(**fields, offset_columns=columns.copy()))
    return regs


def _check_shape(path: Path, name: str, arr: np.ndarray, shape: tuple[int | None, ...], kinds: str) -> np.ndarray:
    ok = arr.ndim == len(shape) and all(want is None or got == want for got, want in zip(arr.shape, shape))
    if not ok or arr.dtype.kind not in kinds:
        want = "(" + ", ".join("*" if s is None else str(s) for s in shape) + ")"
        raise ModelFileError(f"{path}: field {name!r}: expected shape {want} of kind {kinds!r}, found {arr.shape} {arr.dtype}")
    return arr


def read_model(path: str | Path) -> tuple[AffordanceConfig, LearningConfig, dict[str, Any]]:
    """Read a model file written by :func:`save_model` (see the module doc for the checks): the model's
    settings, the learning settings and the learned attributes by name
    (:meth:`socialaff_sim.learning.SocialAffordanceModel.load` builds the model from them)."""
    path = Path(path)
    if not path.is_file():
        raise ModelFileError(f"{path}: no such model file")
    try:
        raw = read_npz(path, keys=("meta", *_ARRAYS))
    except DataError as exc:
        raise ModelFileError(f"{path}: not a readable model file (truncated or not an .npz): {exc.detail}"
                             + (f" in {exc.field!r}" if exc.field else "")) from None
    missing = [k for k in ("meta", *_ARRAYS) if k not in raw]

    def check_missing() -> None:
        if missing:
            raise ModelFileError(
                f"{path}: field {missing[0]!r}: missing (a model file holds 'meta' and {list(_ARRAYS)}); "
                "is this a model written by 'socialaff-sim fit'?"
            )

    if "meta" in missing:
        check_missing()
    meta_arr = raw["meta"]
    if meta_arr.shape != () or meta_arr.dtype.kind != "U":
        raise ModelFileError(f"{path}: field 'meta': expected a JSON string, found {meta_arr.dtype} {meta_arr.shape}")
    try:
        meta_obj = json.loads(str(meta_arr))
    except (json.JSONDecodeError, RecursionError) as exc:
        raise ModelFileError(f"{path}: field 'meta': not valid JSON ({exc})") from None
    if not isinstance(meta_obj, dict):
        raise ModelFileError(f"{path}: field 'meta': expected a JSON object, found a JSON {type(meta_obj).__name__}")
    meta: dict[str, Any] = meta_obj
    if meta.get("format") != MODEL_FORMAT:
        raise ModelFileError(f"{path}: field 'format': expected {MODEL_FORMAT!r}, found {meta.get('format')!r}")
    if meta.get("format_version") != MODEL_FORMAT_VERSION:
        raise ModelFileError(
            f"{path}: field 'format_version': expected {MODEL_FORMAT_VERSION}, found {meta.get('format_version')!r} "
            f"(written by socialaff_sim {meta.get('package_version', '?')}); re-fit the model with this version"
        )
    check_missing()
    check_meta(path, meta)
    try:
        config = AffordanceConfig.from_dict(meta["config"])
        learning = LearningConfig.from_dict(meta["learning"])
        label = str(meta["label"])
        names = tuple(str(n) for n in meta["subevent_names"])
        ids = [str(i) for i in meta["instance_ids"]]
    except (KeyError, TypeError, ValueError, AttributeError, ConfigError) as exc:
        raise ModelFileError(f"{path}: field 'meta': malformed metadata ({exc})") from None
    S = len(names)
    J = N_JOINTS
    a = raw
    _check_shape(path, "available", a["available"], (J,), "b")
    _check_shape(path, "grouping", a["grouping"], (S, J), "iu")
    _check_shape(path, "spatial_params", a["spatial_params"], (S, J, 6), "f")
    _check_shape(path, "motion_params", a["motion_params"], (S, J, 6), "f")
    _check_shape(path, "duration_params", a["duration_params"], (S, 2), "f")
    _check_shape(path, "transitions", a["transitions"], (S, S), "f")
    _check_shape(path, "start_probs", a["start_probs"], (S,), "f")
    _check_shape(path, "centroids", a["centroids"], (None, None), "f")
    _check_shape(path, "mean_end", a["mean_end"], (S, J, 3), "f")
    _check_shape(path, "vertical_up", a["vertical_up"], (S, 2, J), "f")
    _check_shape(path, "path_sigma", a["path_sigma"], (S, J), "f")
    avail = a["available"].astype(bool)
    for prefix, C in (("end", n_context(avail)), ("frame", n_frame_context(avail))):
        for name, shape in _ridge_shapes(C).items():
            _check_shape(path, f"{prefix}_{name}", a[f"{prefix}_{name}"], (S, *shape), "f")
        have, w = np.isfinite(a[f"{prefix}_ridge"]), a[f"{prefix}_offset_weight"]
        if not np.all(np.isin(w[have], (0.0, 1.0))):
            raise ModelFileError(
                f"{path}: field '{prefix}_offset_weight': expected 0 or 1 where {prefix}_ridge is set, found {np.unique(w[have]).tolist()}"
            )
    _check_shape(path, "hand_coupling", a["hand_coupling"], (2, 2), "f")
    _check_shape(path, "contact_phase", a["contact_phase"], (S, N_KEY), "f")
    mates = _check_shape(path, "contact_mate", a["contact_mate"], (S, N_KEY), "iu")
    _check_shape(path, "contact_offset", a["contact_offset"], (S, N_KEY, 3), "f")
    _check_shape(path, "contact_pose", a["contact_pose"], (S, N_KEY, 3), "f")
    _check_shape(path, "contact_spread", a["contact_spread"], (S, N_KEY), "f")
    if np.any((mates < -1) | (mates >= J)) or np.any(np.isfinite(a["contact_phase"]) != (mates >= 0)):
        raise ModelFileError(f"{path}: field 'contact_mate': expected a joint index in [0, {J}) where contact_phase is set, -1 elsewhere")
    _check_shape(path, "trace", a["trace"], (None,), "f")
    _check_shape(path, "acceptance", a["acceptance"], (None,), "f")
    _check_shape(path, "parse_rows", a["parse_rows"], (None, 3), "iu")
    offsets = _check_shape(path, "parse_offsets", a["parse_offsets"], (len(ids) + 1,), "iu")
    if offsets[0] != 0 or np.any(np.diff(offsets) < 0) or offsets[-1] != a["parse_rows"].shape[0]:
        raise ModelFileError(f"{path}: field 'parse_offsets': expected increasing offsets from 0 to {a['parse_rows'].shape[0]}")

    check_values(path, a, S, avail)

    model = SimpleNamespace()  # the learned attributes, by name
    model.label_ = label
    model.n_subevents_ = S
    model.subevent_names_ = names
    model.instance_ids_ = ids
    model.available_ = a["available"].astype(bool)
    model.grouping_ = a["grouping"].astype(np.int64)
    model.spatial_params_ = a["spatial_params"].astype(float)
    model.motion_params_ = a["motion_params"].astype(float)
    model.duration_params_ = a["duration_params"].astype(float)
    model.transitions_ = a["transitions"].astype(float)
    model.start_probs_ = a["start_probs"].astype(float)
    model.centroids_ = a["centroids"].astype(float)
    model.mean_end_ = a["mean_end"].astype(float)
    model.vertical_up_ = a["vertical_up"].astype(float)
    model.path_sigma_ = a["path_sigma"].astype(float)
    model.end_regression_ = _ridge_regressions("end", a, S, offset_columns(avail))
    model.frame_regression_ = _ridge_regressions("frame", a, S, frame_offset_columns(avail))
    model.hand_coupling_ = a["hand_coupling"].astype(float)
    model.contact_keys_ = ContactKeys(
        a["contact_phase"].astype(float), a["contact_mate"].astype(np.int64), a["contact_offset"].astype(float),
        a["contact_pose"].astype(float), a["contact_spread"].astype(float),
    )
    model.trace_ = a["trace"].astype(float)
    model.acceptance_ = a["acceptance"].astype(float)
    rows = a["parse_rows"].astype(np.int64)
    model.parses_ = [rows[offsets[i] : offsets[i + 1]] for i in range(len(ids))]
    model.log_posterior_ = float(meta.get("log_posterior", np.nan))
    model.acceptance_rate_ = float(meta.get("acceptance_rate", np.nan))
    model.moves_ = {str(k): (int(v[0]), int(v[1])) for k, v in meta.get("moves", {}).items()}
    model.fit_seconds_ = {str(k): float(v) for k, v in meta.get("fit_seconds", {}).items()}
    return config, learning, vars(model)
