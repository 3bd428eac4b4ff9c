"""The package's Gymnasium ids, registered when ``socialaff_sim`` (any part of it) is imported.

Namespaced ids, ``socialaff_sim/<Name>-v0``, and the older un-namespaced ``SocialAffordance-…-v0``
ids name the same environments. Registration only records entry-point strings: the environment's
module (MuJoCo, mink) is imported when ``gymnasium.make`` builds one.

Gymnasium 1.x reads no package entry points (its 0.26–0.29 plugin loader was removed in 1.0), so
a script that imports nothing of ours names the package in the id and Gymnasium imports it::

    env = gym.make("socialaff_sim:socialaff_sim/ShakeHands-v0")
"""

from __future__ import annotations

import gymnasium as gym

__all__ = ["ENTRY_POINT", "MAX_EPISODE_SECONDS", "MAX_EPISODE_STEPS", "NAMESPACE", "ENV_IDS", "LEGACY_IDS",
           "register_envs"]

ENTRY_POINT = "socialaff_sim.environment.env:SocialAffordanceEnv"
MAX_EPISODE_SECONDS = 30.0
"""The time limit of every id in simulated seconds (longer than every synthetic instance, 2-7 s)."""
MAX_EPISODE_STEPS = 2000
"""TimeLimit of every id, steps: :data:`MAX_EPISODE_SECONDS` at the default control period of 0.015 s
(``EnvConfig.control_dt``; a test keeps the two consistent). With ``control_dt=None`` (one step per data
frame) pass ``max_episode_steps`` to ``gymnasium.make`` (e.g. 300 frames: 20-30 s of a 10-15 fps recording)."""
NAMESPACE = "socialaff_sim"

ENV_IDS: dict[str, str | None] = {
    "socialaff_sim/SocialAffordance-v0": None,
    "socialaff_sim/ShakeHands-v0": "shake_hands",
    "socialaff_sim/HighFive-v0": "high_five",
    "socialaff_sim/PullUp-v0": "pull_up",
    "socialaff_sim/ThrowCatch-v0": "throw_catch",
    "socialaff_sim/HandOver-v0": "hand_over",
}
"""Each id and the interaction it plays (``None``: every interaction of the data, the synthetic
dataset's five by default); the task comes from envs/<interaction>.toml."""

LEGACY_IDS: dict[str, str] = {
    "SocialAffordance-v0": "socialaff_sim/SocialAffordance-v0",
    "SocialAffordance-ShakeHands-v0": "socialaff_sim/ShakeHands-v0",
    "SocialAffordance-HighFive-v0": "socialaff_sim/HighFive-v0",
    "SocialAffordance-PullUp-v0": "socialaff_sim/PullUp-v0",
    "SocialAffordance-ThrowCatch-v0": "socialaff_sim/ThrowCatch-v0",
    "SocialAffordance-HandOver-v0": "socialaff_sim/HandOver-v0",
}
"""The ids of earlier releases and the namespaced id each equals."""


def register_envs() -> None:
    """Register :data:`ENV_IDS` and :data:`LEGACY_IDS` with Gymnasium (ids already registered are left alone)."""
    every = {**ENV_IDS, **{old: ENV_IDS[new] for old, new in LEGACY_IDS.items()}}
    for env_id, label in every.items():
        if env_id in gym.registry:
            continue
        gym.register(
            id=env_id,
            entry_point=ENTRY_POINT,
            max_episode_steps=MAX_EPISODE_STEPS,
            kwargs={} if label is None else {"interactions": label},
        )
