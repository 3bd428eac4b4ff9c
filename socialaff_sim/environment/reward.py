"""The environment's reward: an affordance term plus physics-scored sub-goal terms from the task files.

Per step (one data frame), with the terms named as in ``info["reward_<name>"]``:

* ``affordance``: w_a · (1 + max(ℓ̄, −L) / L) ∈ [0, w_a], where
  ℓ̄ = (log φ − log φ̂) / n ≤ 0 is the adapter's log-likelihood of the robot's
  (agent-1-equivalent) key joints under the current sub-event, minus its upper
  bound, per scored joint (:class:`~socialaff_sim.environment.adapters.AffordanceScore`).
  With a model: the sub-event's spatial log-potential; without one: the ground-truth
  adapter's Gaussian proxy. 0 when nothing is scored (n = 0, unknown sub-event).
* ``progress_<subgoal>`` (``contact`` and ``object_in_hand`` sub-goals with a
  ``min_duration`` > 0): w_p · Δ min(c, d) / d, c the sub-goal's qualifying contact
  time so far and d its ``min_duration``, so at most w_p per episode;
* ``success_<subgoal>``: w_s once, at the step the sub-goal is met (``object_in_hand``
  is judged at the end of the track);
* ``failure_<kind>``: −w_f once, at the step the failure condition triggers.

The reward is ``math.fsum`` of the terms (an exact, order-independent sum), and
every term is present in every step's ``info``, zero when inactive; the names are
the union over the environment's tasks.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError
from ..sim.scoring import SubgoalScorer
from ..sim.tasks import TaskSpec
from .adapters import AffordanceScore

__all__ = ["RewardConfig", "RewardTracker", "affordance_term"]


@dataclass(frozen=True)
class RewardConfig:
    """Weights of the reward terms (the environment's, not the paper's)."""

    affordance_weight: float = 1.0
    """w_a [reward/step]: reward per step for a perfect affordance fit."""
    affordance_clip: float = 10.0
    """L [nats]: nats per scored joint: ℓ̄ is clipped to [−L, 0], so the affordance term is 0 at or beyond it."""
    progress_weight: float = 5.0
    """w_p [reward]: reward for accumulating a sub-goal's whole ``min_duration`` of contact."""
    success_bonus: float = 10.0
    """w_s [reward]: reward once a sub-goal is met."""
    failure_penalty: float = 20.0
    """w_f [reward]: penalty (subtracted) once a failure condition triggers."""

    def __post_init__(self) -> None:
        for name in ("affordance_weight", "progress_weight", "success_bonus", "failure_penalty"):
            if not float(getattr(self, name)) >= 0:
                raise ConfigError(f"RewardConfig.{name}: expected a number >= 0, found {getattr(self, name)!r}")
        if not float(self.affordance_clip) > 0:
            raise ConfigError(f"RewardConfig.affordance_clip: expected a number > 0, found {self.affordance_clip!r}")


def affordance_term(score: AffordanceScore, config: RewardConfig) -> float:
    """w_a · (1 + max(ℓ̄, −L)/L) with ℓ̄ = min(0, (log φ − bound)/n); 0 when n = 0."""
    if score.n_terms <= 0:
        return 0.0
    ll = score.log_likelihood
    if not np.isfinite(ll):
        return 0.0
    per = min(0.0, (ll - score.upper_bound) / score.n_terms)
    L = config.affordance_clip
    return float(config.affordance_weight * (1.0 + max(per, -L) / L))


class RewardTracker:
    """Turns the scorer's running state into per-step reward terms for one episode at a time."""

    def __init__(self, tasks: Sequence[TaskSpec], config: RewardConfig | None = None) -> None:
        self.config = config or RewardConfig()
        names = ["affordance"]
        for task in tasks:
            for sg in task.subgoals:
                if sg.kind in ("contact", "object_in_hand") and sg.min_duration > 0:
                    names.append(f"progress_{sg.name}")
        for task in tasks:
            names += [f"success_{sg.name}" for sg in task.subgoals]
        for task in tasks:
            names += [f"failure_{f.kind}" for f in task.failures]
        self.term_names: tuple[str, ...] = tuple(dict.fromkeys(names))
        """Every term name the environment reports (info key ``reward_<name>``)."""
        self.subgoal_names: tuple[str, ...] = tuple(dict.fromkeys(sg.name for t in tasks for sg in t.subgoals))
        """Every sub-goal name of the tasks, in order."""
        self.task: TaskSpec | None = None

    def reset(self, task: TaskSpec) -> None:
        """Start an episode of ``task``."""
        self.task = task
        # Per sub-goal: its progress term's name (None when it has none) and its success term's, computed once.
        names = set(self.term_names)
        self._names = [(f"progress_{sg.name}" if f"progress_{sg.name}" in names and sg.kind != "catch" else None,
                        f"success_{sg.name}") for sg in task.subgoals]
        self._progress = {sg.name: 0.0 for sg in task.subgoals}
        self._success = {sg.name: False for sg in task.subgoals}
        self._failed = {f.kind: False for f in task.failures}

    def progress(self, scorer: SubgoalScorer) -> dict[str, float]:
        """Per sub-goal of the current task: min(c, d)/d (1 once met; for d = 0, 1 when met else 0)."""
        assert self.task is not None
        out = {}
        for sg, res in zip(self.task.subgoals, scorer.subgoals, strict=True):
            if res.success:
                out[sg.name] = 1.0
            elif sg.min_duration > 0 and sg.kind != "catch":
                out[sg.name] = min(res.contact_time, sg.min_duration) / sg.min_duration
            else:
                out[sg.name] = 0.0
        return out

    def step(self, score: AffordanceScore, scorer: SubgoalScorer) -> dict[str, float]:
        """The terms of the step just simulated (every name of :attr:`term_names`)."""
        if self.task is None:
            raise ConfigError("RewardTracker.step called before reset(task)")
        c = self.config
        terms = dict.fromkeys(self.term_names, 0.0)
        terms["affordance"] = affordance_term(score, c)
        for sg, res, (progress, success) in zip(self.task.subgoals, scorer.subgoals, self._names, strict=True):
            if progress is not None:
                now = min(res.contact_time, sg.min_duration) / sg.min_duration
                terms[progress] += c.progress_weight * (now - self._progress[sg.name])
                self._progress[sg.name] = now
            if res.success and not self._success[sg.name]:
                terms[success] += c.success_bonus
                self._success[sg.name] = True
        for f in scorer.failures:
            if f.triggered and not self._failed[f.kind]:
                terms[f"failure_{f.kind}"] -= c.failure_penalty
                self._failed[f.kind] = True
        return terms

    @staticmethod
    def total(terms: dict[str, float]) -> float:
        """The reward: the exact (``math.fsum``) sum of the terms."""
        return math.fsum(terms.values())
