"""Inference: DP parsing of a running interaction, online synthesis (Algorithm 2) and full-body fit.

Importing this package registers the methods ``"full"``, ``"v1"`` and ``"v2"`` with
:func:`socialaff_sim.evaluation.register_method`.
"""

from .body_fit import BodyFitConfig, BodyFitter, instance_frame, kmeans, two_bone_ik
from .methods import VARIANTS, AffordanceMethod, ModelSource, key_joint_source, synthesize
from .online_parse import PrefixParse, parse_prefix
from .synthesis import OnlineSynthesizer, SynthesisConfig, SynthesisStep

__all__ = [
    "VARIANTS",
    "AffordanceMethod",
    "BodyFitConfig",
    "BodyFitter",
    "ModelSource",
    "OnlineSynthesizer",
    "PrefixParse",
    "SynthesisConfig",
    "SynthesisStep",
    "instance_frame",
    "key_joint_source",
    "kmeans",
    "parse_prefix",
    "synthesize",
    "two_bone_ik",
]
