"""Baselines the full model is compared with: the paper's multi-level HMM and Interaction ProMP.

(The ablations V1/V2 are configurations of the full model, not baselines here.)
"""

from .hmm import HMMConfig, MultiLevelHMM
from .promp import InteractionProMP, ProMPConfig

__all__ = ["HMMConfig", "InteractionProMP", "MultiLevelHMM", "ProMPConfig"]
