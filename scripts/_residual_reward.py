"""A training-only reward term of ``scripts/train_residual.py``: a penalty for falling.

The environment's reward (:mod:`socialaff_sim.environment.reward`) penalizes the task files' failures
(self-collision, contact force, dropped object) but not a fall: an episode that ends with
``termination_reason == "fell"`` only loses the steps it did not play, so late in a hand over a fall
costs the policy less than a dropped cup. :class:`FallPenalty` subtracts ``penalty`` once, on the step
such an episode ends, and reports it as ``info["reward_failure_fell"]`` (0 on every other step) so that
the ``reward_<term>`` entries still sum to the reward. The script wraps its TRAINING environments only
(``--train-fall-penalty``, 0 by default: no wrapper, the environment's reward unchanged); the held-out
evaluation keeps the environment's own reward.
"""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym

from socialaff_sim.errors import ConfigError

__all__ = ["FallPenalty"]


class FallPenalty(gym.Wrapper):
    """−``penalty`` (reward units, ≥ 0) on the step an episode ends because the robot fell."""

    def __init__(self, env: gym.Env, penalty: float) -> None:
        if not float(penalty) >= 0.0:
            raise ConfigError(f"--train-fall-penalty: expected a number >= 0, found {penalty!r}")
        super().__init__(env)
        self.penalty = float(penalty)

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        term = -self.penalty if info.get("termination_reason") == "fell" else 0.0
        info["reward_failure_fell"] = term
        return obs, float(reward) + term, terminated, truncated, info
