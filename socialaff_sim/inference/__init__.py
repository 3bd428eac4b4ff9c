"""Inference: DP parsing of a running interaction, online synthesis (Algorithm 2) and full-body fit.

Also the contract every reaction method implements (:mod:`.protocol`: :class:`Prediction`,
:class:`ReactionMethod`, :func:`observed_part`) and the full model as such a method
(:class:`AffordanceMethod`); :mod:`socialaff_sim.evaluation` registers the methods by name.
"""

from .body_fit import BodyFitConfig, BodyFitter, instance_frame, kmeans, two_bone_ik
from .methods import VARIANTS, AffordanceMethod, synthesize
from .online_parse import PrefixParse, parse_prefix
from .protocol import DEFAULT_N_OBSERVED, Prediction, ReactionMethod, observed_part, prediction_from_joints
from .synthesis import OnlineSynthesizer, SynthesisConfig, SynthesisStep

__all__ = [
    "DEFAULT_N_OBSERVED",
    "Prediction",
    "ReactionMethod",
    "observed_part",
    "prediction_from_joints",
    "VARIANTS",
    "AffordanceMethod",
    "BodyFitConfig",
    "BodyFitter",
    "OnlineSynthesizer",
    "PrefixParse",
    "SynthesisConfig",
    "SynthesisStep",
    "instance_frame",
    "kmeans",
    "parse_prefix",
    "synthesize",
    "two_bone_ik",
]
