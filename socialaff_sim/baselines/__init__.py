"""Baselines the full model is compared with: the paper's multi-level HMM and Interaction ProMP, and the
learned causal baselines ``ridge`` and ``gru`` (the latter needs the ``[neural]`` extra, torch).

(The ablations V1/V2 are configurations of the full model, not baselines here.)
"""

from .hmm import HMMConfig, MultiLevelHMM
from .gru import GRUConfig, GRUReaction
from .promp import InteractionProMP, ProMPConfig
from .ridge import RidgeConfig, RidgeReaction

__all__ = ["GRUConfig", "GRUReaction", "HMMConfig", "InteractionProMP", "MultiLevelHMM", "ProMPConfig", "RidgeConfig",
           "RidgeReaction"]
