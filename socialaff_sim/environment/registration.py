"""Gymnasium ids of the environment (defined in :mod:`socialaff_sim.gym_ids`, registered on ``import socialaff_sim``).

    import gymnasium as gym
    import socialaff_sim  # noqa: F401  (registers the ids)
    env = gym.make("socialaff_sim/ShakeHands-v0")

or, importing nothing of ours, name the package in the id and ``gymnasium.make`` imports it::

    env = gym.make("socialaff_sim:socialaff_sim/ShakeHands-v0")
"""

from __future__ import annotations

from ..gym_ids import ENTRY_POINT, ENV_IDS, LEGACY_IDS, MAX_EPISODE_STEPS, NAMESPACE, register_envs

__all__ = ["ENTRY_POINT", "MAX_EPISODE_STEPS", "NAMESPACE", "ENV_IDS", "LEGACY_IDS", "register_envs"]
