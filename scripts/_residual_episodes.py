"""Policies and episodes of ``scripts/train_residual.py``: the trained residual (deterministic, on normalized
observations), the zero residual (the affordance model alone), and the per-episode rows both are judged on."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecNormalize

__all__ = ["Policy", "held_out_episodes", "run_episodes", "trained_policy", "training_episodes", "zero_policy"]

Policy = Callable[[np.ndarray], np.ndarray]


def trained_policy(agent: PPO, norm: VecNormalize) -> Policy:
    """The deterministic policy on a raw flat observation (normalized with the training statistics)."""
    return lambda obs: agent.predict(norm.normalize_obs(obs), deterministic=True)[0]


def zero_policy(env: gym.Env) -> Policy:
    """The affordance model alone on ``env``: no residual (zeros of its action space's shape)."""
    zeros = np.zeros(env.action_space.shape, np.float32)
    return lambda obs: zeros.copy()


def training_episodes(instance_ids: Sequence[str], seed: int) -> list[tuple[str, int]]:
    """(instance, reset seed) of the zero residual's reference run on the training instances: seed + k for the
    k-th."""
    return [(i, seed + k) for k, i in enumerate(instance_ids)]


def held_out_episodes(instance_ids: Sequence[str], seed: int, base: int = 10_000) -> list[tuple[str, int]]:
    """(instance, reset seed) of the held-out evaluation, the same for every policy judged: base + 1000·seed + k
    for the k-th held-out instance (``base`` 10000 in the first five declared runs)."""
    return [(i, base + seed * 1_000 + k) for k, i in enumerate(instance_ids)]


def run_episodes(env: gym.Env, episodes: Sequence[tuple[str, int]], policy: Policy) -> list[dict[str, Any]]:
    """One episode per (instance id, reset seed); per-episode return (and its ``reward_<term>`` sums), success,
    sub-goals, failures, the termination reason and the mean |action| (policy units, [0, 1]). ``interaction``
    is the instance's label, ``task`` the interaction of its task file (``shaking_hands`` and ``handshake``
    are both ``shake_hands``)."""
    tasks = env.unwrapped.pool.tasks  # type: ignore[attr-defined]
    rows = []
    for instance, seed in episodes:
        obs, _ = env.reset(seed=seed, options={"instance": instance})
        total, steps, action_sum = 0.0, 0, 0.0
        terms: dict[str, float] = {}
        while True:
            action = policy(obs)
            obs, reward, terminated, truncated, info = env.step(action)
            total, steps = total + float(reward), steps + 1
            action_sum += float(np.mean(np.abs(action)))
            for key, value in info.items():
                if key.startswith("reward_"):
                    terms[key[len("reward_"):]] = terms.get(key[len("reward_"):], 0.0) + float(value)
            if terminated or truncated:
                break
        subgoals = dict(info["subgoals"])
        rows.append({"instance": instance, "seed": seed, "interaction": info["interaction"],
                     "task": tasks[info["interaction"]].interaction, "return": total,
                     "steps": steps, "success": bool(info["success"]), "failed": bool(info["failed"]),
                     "failures": sorted(k for k, hit in info["failures"].items() if hit),
                     "termination_reason": info["termination_reason"], "reward_terms": terms,
                     "mean_abs_action": action_sum / steps,
                     "subgoals": subgoals, "subgoals_met": float(np.mean(list(subgoals.values())))})
    return rows
