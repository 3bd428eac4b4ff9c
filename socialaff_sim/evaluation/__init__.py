"""Evaluation (Experiment 1 of the paper): cross-validation (pair-, actor-, recording- or block-disjoint folds) under a causal, paper or offline protocol, metrics, paired comparisons, reports."""

from ..inference.protocol import (
    DEFAULT_N_OBSERVED,
    Prediction,
    ReactionMethod,
    Reactor,
    StreamingMethod,
    observed_part,
    prediction_from_joints,
)
from .compare import PairedDifference, paired_differences
from .crossval import EvaluationConfig
from .metrics import joint_error, key_joint_error, matched_accuracy, parse_confusion
from .registry import METHODS, available_methods, get_method, register_method
from .report import format_tables, write_results
from .runner import evaluate
from .splits import SPLITS, make_folds
from .streaming import PROTOCOLS, PrefixReactor, run_protocol

__all__ = [
    "DEFAULT_N_OBSERVED",
    "METHODS",
    "PROTOCOLS",
    "SPLITS",
    "EvaluationConfig",
    "PairedDifference",
    "Prediction",
    "PrefixReactor",
    "ReactionMethod",
    "Reactor",
    "StreamingMethod",
    "available_methods",
    "evaluate",
    "format_tables",
    "get_method",
    "joint_error",
    "key_joint_error",
    "make_folds",
    "matched_accuracy",
    "observed_part",
    "paired_differences",
    "parse_confusion",
    "prediction_from_joints",
    "register_method",
    "run_protocol",
    "write_results",
]
