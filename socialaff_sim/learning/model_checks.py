"""Value checks of a model file's contents, run by :func:`~socialaff_sim.learning.model_io.read_model`
after the shape checks: the metadata's schema, finite values, probabilities in range and summing to 1.

A file that passes holds numbers the model's code can use: nothing NaN where the code does not
expect NaN, no infinities, no negative or unnormalised probabilities, a K-means centroid array as
wide as the frame descriptions it is compared with. Every error is a
:class:`~socialaff_sim.errors.ModelFileError` naming the file and the field.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..data.interaction import LABEL_PATTERN
from ..errors import ModelFileError

__all__ = ["check_meta", "check_values", "PROBABILITY_ATOL"]

PROBABILITY_ATOL = 1e-6
"""Tolerance on a probability vector's sum."""

_ALWAYS_FINITE = ("duration_params", "transitions", "start_probs", "centroids", "hand_coupling", "trace",
                  "acceptance")
"""Arrays the model reads everywhere: no NaN allowed. (The others hold NaN where a joint or type is unused.)"""


def _fail(path: Path, field: str, message: str) -> ModelFileError:
    return ModelFileError(f"{path}: field {field!r}: {message}")


def check_meta(path: Path, meta: object) -> dict[str, Any]:
    """The metadata object's schema (types of every key the loader reads)."""
    if not isinstance(meta, dict):
        raise _fail(path, "meta", f"expected a JSON object, found a JSON {type(meta).__name__}")
    kinds: Mapping[str, tuple[type, ...]] = {
        "label": (str,), "subevent_names": (list,), "instance_ids": (list,), "config": (dict,), "learning": (dict,),
    }
    for key, types in kinds.items():
        if key not in meta:
            raise _fail(path, key, "missing from meta")
        if not isinstance(meta[key], types):
            raise _fail(path, key, f"expected a JSON {types[0].__name__}, found {type(meta[key]).__name__}")
    if not LABEL_PATTERN.match(meta["label"]):
        raise _fail(path, "label", f"expected a snake_case interaction name, found {meta['label']!r}")
    names = meta["subevent_names"]
    if not names or not all(isinstance(n, str) and LABEL_PATTERN.match(n) for n in names) or len(set(names)) != len(names):
        raise _fail(path, "subevent_names", f"expected one or more distinct snake_case names, found {names!r}")
    if not all(isinstance(i, str) for i in meta["instance_ids"]):
        raise _fail(path, "instance_ids", "expected a list of strings")
    for key in ("log_posterior", "acceptance_rate"):
        if key in meta and (isinstance(meta[key], bool) or not isinstance(meta[key], (int, float))):
            raise _fail(path, key, f"expected a number, found {meta[key]!r}")
    for key in ("moves", "fit_seconds"):
        if key in meta and not isinstance(meta[key], dict):
            raise _fail(path, key, f"expected a JSON object, found {type(meta[key]).__name__}")
    moves = meta.get("moves", {})
    if not all(isinstance(v, list) and len(v) == 2 and all(isinstance(x, int) for x in v) for v in moves.values()):
        raise _fail(path, "moves", "expected {move: [accepted, proposed]} with integer counts")
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in meta.get("fit_seconds", {}).values()):
        raise _fail(path, "fit_seconds", "expected {stage: seconds} with numbers")
    return meta


def _probabilities(path: Path, field: str, p: np.ndarray) -> None:
    """Each row of ``p`` in [0, 1] and summing to 1."""
    if np.any(p < 0) or np.any(p > 1):
        raise _fail(path, field, f"expected probabilities in [0, 1], found values in [{p.min():.4g}, {p.max():.4g}]")
    sums = p.sum(axis=-1)
    if not np.allclose(sums, 1.0, rtol=0.0, atol=PROBABILITY_ATOL):
        worst = float(sums.flat[np.argmax(np.abs(sums - 1.0))])
        raise _fail(path, field, f"expected each row to sum to 1, found a sum of {worst:.6g}")


def check_values(path: Path, a: Mapping[str, np.ndarray], n_subevents: int, available: np.ndarray) -> None:
    """Finite values, ranges and normalisation of the arrays (shapes already checked)."""
    for name, arr in a.items():
        if arr.dtype.kind == "f" and np.isinf(arr).any():
            raise _fail(path, name, "expected finite values, found inf")
    for name in _ALWAYS_FINITE:
        if np.isnan(a[name]).any():
            raise _fail(path, name, "expected finite values, found NaN")
    J = available.shape[0]
    if not available.any():
        raise _fail(path, "available", "expected at least one available joint, found none")
    _probabilities(path, "start_probs", a["start_probs"])
    _probabilities(path, "transitions", a["transitions"])
    _probabilities(path, "hand_coupling", a["hand_coupling"])
    if np.any(a["duration_params"][:, 1] <= 0):
        raise _fail(path, "duration_params", "expected σ > 0 in column 1")
    width = 6 * int(available.sum())
    K, D = a["centroids"].shape
    if K < 1 or D != width:
        raise _fail(path, "centroids", f"expected (K >= 1, {width}) (6 per available joint), found {a['centroids'].shape}")
    g = a["grouping"]
    if np.any(g < -1) or np.any(g > J):
        raise _fail(path, "grouping", f"expected -1 (absent), 0 (Null) or a group 1..{J}, found [{g.min()}, {g.max()}]")
    if np.any((a["acceptance"] < 0) | (a["acceptance"] > 1)):
        raise _fail(path, "acceptance", "expected rates in [0, 1]")
    for name in ("path_sigma", "contact_spread"):
        if np.any(a[name] < 0):
            raise _fail(path, name, "expected values >= 0 (metres) or NaN")
    phase = a["contact_phase"]
    if np.any((phase < 0) | (phase > 1)):
        raise _fail(path, "contact_phase", "expected phases in [0, 1] or NaN")
    rows = a["parse_rows"]
    if rows.size and (np.any(rows[:, 0] < 0) or np.any(rows[:, 1] <= rows[:, 0]) or np.any(rows[:, 2] < 0)
                      or np.any(rows[:, 2] >= n_subevents)):
        raise _fail(path, "parse_rows", f"expected rows (start >= 0, stop > start, label in [0, {n_subevents}))")
