"""The Gymnasium environment: a humanoid robot plays agent 1 of an interaction, facing a replayed person.

Importing ``socialaff_sim`` registers the ids of :data:`~socialaff_sim.gym_ids.ENV_IDS`
(``socialaff_sim/SocialAffordance-v0`` and one per interaction, e.g. ``socialaff_sim/ShakeHands-v0``,
also under their earlier names ``SocialAffordance-ShakeHands-v0`` …);
see docs/environment.md.
"""

from .action_limits import EnvelopeConfig, FeasibleTargets
from .adapters import AdapterFrame, AffordanceAdapter, AffordanceScore, GroundTruthAdapter, RobotPose
from .config import ACTION_MODES, PHYSICS_PRESETS, EnvConfig, physics_config
from .env import SocialAffordanceEnv
from .episode_end import TERMINATION_REASONS
from .model_adapter import ModelAdapter, ModelScorer, load_models
from .registration import ENV_IDS, MAX_EPISODE_STEPS, register_envs
from .reward import RewardConfig, RewardTracker

__all__ = [
    "ACTION_MODES",
    "PHYSICS_PRESETS",
    "ENV_IDS",
    "MAX_EPISODE_STEPS",
    "AdapterFrame",
    "AffordanceAdapter",
    "AffordanceScore",
    "EnvConfig",
    "EnvelopeConfig",
    "FeasibleTargets",
    "GroundTruthAdapter",
    "ModelAdapter",
    "ModelScorer",
    "RewardConfig",
    "RewardTracker",
    "RobotPose",
    "SocialAffordanceEnv",
    "TERMINATION_REASONS",
    "load_models",
    "physics_config",
    "register_envs",
]
