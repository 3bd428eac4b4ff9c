"""Model selection on the TRAINING side for ``scripts/train_residual.py`` (``--select-every``).

The fifth declared run (docs/benchmarks.md) left a deterministic policy worse than its own start, on the
held-out pairs and on the training hand-overs alike. With ``--select-every E`` the run keeps the start unless
training beats it on the training side:

* the *selection episodes*: every training instance of the labels the residual acts on, each with the reset
  seed of the ``--reference-only`` run (``seed + k`` for the k-th training instance), played through the run's
  gate and bias with the training reward;
* the *start*: the zero policy output on those episodes (through the gate: the bias alone; without a gate:
  the affordance model alone), played once before training;
* a *checkpoint* after every E-th PPO update (and after the last update if that is not one): the policy
  played deterministically on the same episodes, its weights and observation statistics kept;
* the choice (:func:`select`): the checkpoint with the most successes if it has strictly more than the start
  (ties between checkpoints: the earliest); otherwise the start. A run that keeps the start has trained nothing.

Evaluating a checkpoint neither samples from the policy nor updates the observation statistics, so the
training itself is the same with or without the selection.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.vec_env import VecNormalize

from _residual_episodes import Policy, run_episodes, trained_policy

__all__ = ["CheckpointSelector", "score", "select"]


def score(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Successes, episodes and mean return (training reward) and mean |policy output| of selection episodes."""
    return {"successes": int(sum(bool(r["success"]) for r in rows)), "episodes": len(rows),
            "mean_return": float(np.mean([r["return"] for r in rows])),
            "mean_abs_action": float(np.mean([r["mean_abs_action"] for r in rows]))}


def select(start_successes: int, checkpoint_successes: Sequence[int]) -> int | None:
    """Index of the chosen checkpoint, or ``None`` for the start: the most successes, if strictly more than the
    start's; among equal counts the earliest checkpoint."""
    if not checkpoint_successes:
        return None
    best = int(np.argmax(np.asarray(checkpoint_successes)))  # argmax: the first of equal maxima
    return best if checkpoint_successes[best] > start_successes else None


class CheckpointSelector(BaseCallback):
    """Plays the policy deterministically on the selection episodes after every ``every``-th PPO update
    (at the start of the next rollout, when ``n_updates`` updates are done) and keeps a copy of its weights and
    observation statistics (module docstring)."""

    def __init__(self, env: gym.Env, episodes: Sequence[tuple[str, int]], norm: VecNormalize, every: int,
                 rollout: int, log: Callable[[str], None] | None = None) -> None:
        super().__init__()
        if every < 1:
            raise ValueError(f"every: expected >= 1 updates, found {every}")
        self.env, self.episodes, self.norm, self.every, self.rollout = env, list(episodes), norm, every, rollout
        self._log = log
        self.start: dict[str, Any] | None = None
        self.checkpoints: list[dict[str, Any]] = []
        self._snapshots: list[tuple[dict[str, Any], Any]] = []
        self.chosen: int | None = None
        """After :meth:`finish`: the chosen index into :attr:`checkpoints`, ``None`` for the start."""

    def play_start(self, start: Policy) -> dict[str, Any]:
        """Score the start (``start``: the zero policy output on the selection environment)."""
        self.start = score(run_episodes(self.env, self.episodes, start))
        if self._log is not None:
            self._log(f"  selection: start {self.start['successes']}/{self.start['episodes']}")
        return self.start

    def evaluate(self, agent: PPO, updates: int) -> dict[str, Any]:
        """Score the agent's current policy as the checkpoint after ``updates`` updates and keep its weights."""
        row = {"updates": int(updates), "timesteps": int(updates * self.rollout),
               **score(run_episodes(self.env, self.episodes, trained_policy(agent, self.norm)))}
        self.checkpoints.append(row)
        self._snapshots.append((copy.deepcopy(agent.policy.state_dict()), copy.deepcopy(self.norm.obs_rms)))
        if self._log is not None:
            self._log(f"  selection: after {updates} updates {row['successes']}/{row['episodes']}, "
                      f"mean |output| {row['mean_abs_action']:.3f}")
        return row

    def _on_rollout_start(self) -> None:
        updates = int(self.num_timesteps) // self.rollout
        if updates > 0 and updates % self.every == 0:
            self.evaluate(self.model, updates)

    def _on_step(self) -> bool:
        return True

    def finish(self, agent: PPO, updates: int) -> int | None:
        """After training (``updates`` done): score the final policy unless already scored, choose, and load the
        chosen checkpoint's weights and statistics into ``agent`` and the normalizer. Returns the chosen index
        into :attr:`checkpoints`, ``None`` for the start (the agent is then left as trained)."""
        if self.start is None:
            raise ValueError("CheckpointSelector.finish: play_start() was not called")
        if updates > 0 and not any(c["updates"] == updates for c in self.checkpoints):
            self.evaluate(agent, updates)
        chosen = self.chosen = select(self.start["successes"], [c["successes"] for c in self.checkpoints])
        if chosen is not None:
            weights, obs_rms = self._snapshots[chosen]
            agent.policy.load_state_dict(weights)
            self.norm.obs_rms = copy.deepcopy(obs_rms)
        return chosen
