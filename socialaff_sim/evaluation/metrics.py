"""The paper's metrics: average joint distance over the synthesized frames, and sub-event parse accuracy."""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..data.interaction import Interaction
from ..errors import ModelError
from ..inference.protocol import Prediction

__all__ = [
    "HORIZONS_S",
    "METRICS",
    "horizon_key_joint_error",
    "horizon_metric",
    "is_horizon_metric",
    "joint_error",
    "key_joint_error",
    "matched_accuracy",
    "mean_joint_distance",
    "parse_confusion",
]

METRICS: tuple[str, ...] = ("key_joint_error_m", "joint_error_m")
"""The two errors every evaluated instance, class and method carries (results.json keys, metres)."""


HORIZONS_S: tuple[float, ...] = (0.2, 0.5, 1.0)
"""Forecast horizons h, seconds, of the horizon errors (docs/evaluation.md, "Horizons and latency")."""


def horizon_metric(horizon_s: float) -> str:
    """The results.json key of the key-joint error at horizon ``horizon_s`` seconds, e.g. ``key_joint_error_0.5s_m``."""
    return f"key_joint_error_{horizon_s:g}s_m"


def is_horizon_metric(name: str) -> bool:
    """Whether ``name`` is a key made by :func:`horizon_metric`."""
    if not (name.startswith("key_joint_error_") and name.endswith("s_m")):
        return False
    try:
        return horizon_metric(float(name[len("key_joint_error_"):-3])) == name
    except ValueError:
        return False


def horizon_key_joint_error(forecast_times: np.ndarray, forecasts: np.ndarray, truth: Interaction, steps: int) -> float:
    """Key-joint error, metres, of the forecasts ``steps`` frames ahead: for each forecast time t (A,) with
    t + steps inside the instance, the mean distance over agent 1's tracked key joints at t + steps between
    the forecast (``forecasts[a, steps]``, (A, L, 5, 3)) and the ground truth; then the mean over those t.
    NaN when no forecast reaches a tracked frame."""
    times = np.asarray(forecast_times, dtype=np.int64)
    if times.size == 0 or steps >= np.asarray(forecasts).shape[1]:
        return float("nan")
    target = times + steps
    inside = target < truth.n_frames
    if not inside.any():
        return float("nan")
    gt = truth.key_joints()[target[inside], 1]
    mask = truth.key_valid()[target[inside], 1] & truth.key_available()[None]
    pred = np.asarray(forecasts, dtype=np.float64)[inside, steps]
    per_time = [mean_joint_distance(pred[i:i + 1], gt[i:i + 1], mask[i:i + 1]) for i in range(len(pred))]
    finite = [v for v in per_time if not np.isnan(v)]
    return float(np.mean(finite)) if finite else float("nan")


def mean_joint_distance(pred: np.ndarray, truth: np.ndarray, mask: np.ndarray) -> float:
    """Mean Euclidean distance, metres, between (T, J, 3) ``pred`` and ``truth`` over the (T, J) ``mask``.

    Raises :class:`~socialaff_sim.errors.ModelError` if a masked prediction is not finite;
    returns NaN if the mask is empty.
    """
    pred = np.asarray(pred, dtype=np.float64)
    truth = np.asarray(truth, dtype=np.float64)
    mask = np.asarray(mask, dtype=bool)
    if pred.shape != truth.shape or mask.shape != pred.shape[:-1]:
        raise ModelError(f"metric: shapes differ: prediction {pred.shape}, truth {truth.shape}, mask {mask.shape}")
    if not mask.any():
        return float("nan")
    p, g = pred[mask], truth[mask]
    if not np.isfinite(p).all():
        t, j = np.argwhere(mask & ~np.isfinite(pred).all(-1))[0]
        raise ModelError(f"metric: the prediction is not finite at frame {t}, joint {j}, where the ground truth is valid")
    return float(np.linalg.norm(p - g, axis=-1).mean())


def key_joint_error(prediction: Prediction, truth: Interaction) -> float:
    """Average distance, metres, of agent 1's five key joints (those the layout has and that were
    tracked) over the synthesized frames t ≥ ``prediction.n_observed``."""
    start = prediction.n_observed
    gt = truth.key_joints()[start:, 1]
    mask = truth.key_valid()[start:, 1] & truth.key_available()[None]
    return mean_joint_distance(prediction.key_joints[start:], gt, mask)


def joint_error(prediction: Prediction, truth: Interaction) -> float:
    """Average distance, metres, over agent 1's valid joints of the full skeleton, frames t ≥ ``n_observed``."""
    start = prediction.n_observed
    if prediction.joints.shape != truth.joints[:, 1].shape:
        raise ModelError(
            f"metric: prediction skeleton has shape {prediction.joints.shape}, the instance's agent 1 "
            f"{truth.joints[:, 1].shape}"
        )
    valid = np.asarray(truth.valid)[start:, 1]
    return mean_joint_distance(prediction.joints[start:], truth.joints[start:, 1], valid)


def parse_confusion(predicted: np.ndarray, truth: np.ndarray, n_truth: int) -> np.ndarray:
    """(n_truth, P) counts of frames with ground-truth label i (≥ 0) and predicted label j (≥ 0).

    Frames unlabelled in the ground truth (−1) are left out; frames the method left
    without a label (−1) count as wrong (they are not in the matrix). ``P`` is the
    largest predicted label + 1.
    """
    pred = np.asarray(predicted, dtype=np.int64)
    gt = np.asarray(truth, dtype=np.int64)
    if pred.shape != gt.shape:
        raise ModelError(f"parse: predicted labels {pred.shape} and ground truth {gt.shape} differ in length")
    n_pred = int(pred.max(initial=-1)) + 1
    both = (gt >= 0) & (pred >= 0)
    out = np.zeros((n_truth, n_pred), dtype=np.int64)
    np.add.at(out, (gt[both], pred[both]), 1)
    return out


def matched_accuracy(confusion: np.ndarray, n_labelled: int) -> float:
    """Frame accuracy under the one-to-one label matching that maximizes it (Hungarian method).

    ``n_labelled``: frames with a ground-truth label (the denominator, including
    frames the method left unlabelled).
    """
    c = np.asarray(confusion)
    if n_labelled <= 0:
        return float("nan")
    if c.size == 0:
        return 0.0
    rows, cols = linear_sum_assignment(c, maximize=True)
    return float(c[rows, cols].sum() / n_labelled)
