"""Evaluation (Experiment 1 of the paper): the method protocol, metrics, actor-disjoint cross-validation, reports."""

from .compare import PairedDifference, paired_differences
from .crossval import EvaluationConfig
from .metrics import joint_error, key_joint_error, matched_accuracy, parse_confusion
from ..inference.protocol import DEFAULT_N_OBSERVED, Prediction, ReactionMethod, observed_part, prediction_from_joints
from .registry import METHODS, available_methods, get_method, register_method
from .report import format_tables, write_results
from .runner import evaluate

__all__ = [
    "DEFAULT_N_OBSERVED",
    "METHODS",
    "EvaluationConfig",
    "PairedDifference",
    "Prediction",
    "ReactionMethod",
    "available_methods",
    "evaluate",
    "format_tables",
    "get_method",
    "joint_error",
    "key_joint_error",
    "matched_accuracy",
    "observed_part",
    "paired_differences",
    "parse_confusion",
    "prediction_from_joints",
    "register_method",
    "write_results",
]
