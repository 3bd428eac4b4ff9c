"""Gymnasium ids of the environment, registered on ``import socialaff_sim.environment``.

Gymnasium 1.x loads no plugins by itself, so either import the package first::

    import gymnasium as gym
    import socialaff_sim.environment  # noqa: F401  (registers the ids)
    env = gym.make("SocialAffordance-ShakeHands-v0")

or name the module in the id, which ``gymnasium.make`` imports for you::

    env = gym.make("socialaff_sim.environment:SocialAffordance-ShakeHands-v0")
"""

from __future__ import annotations

import gymnasium as gym

__all__ = ["ENTRY_POINT", "MAX_EPISODE_STEPS", "ENV_IDS", "register_envs"]

ENTRY_POINT = "socialaff_sim.environment.env:SocialAffordanceEnv"
MAX_EPISODE_STEPS = 300
"""TimeLimit of every id: 300 steps (data frames), 20-30 s of a 10-15 fps recording."""

ENV_IDS: dict[str, str | None] = {
    "SocialAffordance-v0": None,
    "SocialAffordance-ShakeHands-v0": "shake_hands",
    "SocialAffordance-HighFive-v0": "high_five",
    "SocialAffordance-PullUp-v0": "pull_up",
    "SocialAffordance-ThrowCatch-v0": "throw_catch",
    "SocialAffordance-HandOver-v0": "hand_over",
}
"""Each id and the interaction it plays (``None``: every interaction of the data, the synthetic
dataset's five by default); the task comes from envs/<interaction>.toml."""


def register_envs() -> None:
    """Register :data:`ENV_IDS` with Gymnasium (ids already registered are left alone)."""
    for env_id, label in ENV_IDS.items():
        if env_id in gym.registry:
            continue
        gym.register(
            id=env_id,
            entry_point=ENTRY_POINT,
            max_episode_steps=MAX_EPISODE_STEPS,
            kwargs={} if label is None else {"interactions": label},
        )
