"""Where a residual policy acts, and from where it starts: ``scripts/train_residual.py``'s gate and bias.

The fourth declared run (docs/benchmarks.md) learned to reach on the handshakes too, where the affordance
model was already right on every training instance, and lost held-out handshakes; on the hand-overs a constant
reach did as well as the learned one. :class:`GatedResidual` lets a run say both things in the action:

* ``labels``: the interactions the residual acts on. On an episode of any other label every action is
  replaced by zeros (the affordance model alone, bitwise: the zero action of the wrapped environment);
* ``bias`` b (policy units): on an episode of an acting label the wrapped environment gets clip(b + a, −1, 1)
  for the policy's action a, so a policy whose mean is zero plays the constant action b and learns a
  correction to it;
* ``train_only``: a reset without options draws its instance among the acting labels' instances only
  (uniformly, with the wrapper's own generator, seeded by the reset's seed), so no training step is spent on
  an episode where the policy has no effect. A reset with options (the held-out evaluation names each
  instance) is passed through unchanged.

The wrapped environment's action space must be the policy's box [−1, 1]ⁿ (the reach residual's, or the
plain residual's after its rescaling).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from socialaff_sim.errors import ConfigError, SimulationError, choices

__all__ = ["GatedResidual", "check_gate"]


def check_gate(labels: Sequence[str], acting: Sequence[str], bias: Sequence[float], n: int) -> None:
    """Raise a :class:`ConfigError` naming the flag unless ``acting`` is a non-empty subset of the run's ``labels``
    and ``bias`` is empty or ``n`` numbers in [−1, 1] (``n``: the policy's action size)."""
    unknown = [lbl for lbl in acting if lbl not in labels]
    if not acting or unknown:
        raise ConfigError(f"--residual-labels: expected interactions of this run ({choices(sorted(labels))}), "
                          f"found {choices(list(acting)) if acting else 'none'}")
    if len(bias) not in (0, n):
        raise ConfigError(f"--action-bias: expected {n} numbers (one per action coordinate), found {len(bias)}")
    if any(not -1.0 <= float(b) <= 1.0 for b in bias):
        raise ConfigError(f"--action-bias: expected numbers in [-1, 1] (policy units), found {list(bias)}")


class GatedResidual(gym.Wrapper):
    """The policy's action, biased, on the episodes of ``labels`` only; zeros elsewhere (module docstring)."""

    def __init__(self, env: gym.Env, labels: Sequence[str], bias: Sequence[float] = (), train_only: bool = False) -> None:
        super().__init__(env)
        space = env.action_space
        if not isinstance(space, gym.spaces.Box) or not (np.all(space.low == -1.0) and np.all(space.high == 1.0)):
            raise ConfigError(f"--residual-labels: needs the policy's [-1, 1] action box, found {space}")
        pool = env.unwrapped.pool  # type: ignore[attr-defined]
        check_gate(pool.labels, labels, bias, int(np.prod(space.shape)))
        self.labels = tuple(labels)
        self.bias = np.zeros(space.shape, np.float32) if len(bias) == 0 else np.asarray(bias, np.float32).reshape(space.shape)
        self.train_only = bool(train_only)
        self._ids = [x.instance_id for x in pool.instances if x.label in self.labels]
        self._rng: np.random.Generator | None = None
        self._active: bool | None = None

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        if self.train_only and not options:
            if seed is not None or self._rng is None:
                self._rng = np.random.default_rng(seed)
            options = {"instance": self._ids[int(self._rng.integers(len(self._ids)))]}
        obs, info = self.env.reset(seed=seed, options=options)
        self._active = info["interaction"] in self.labels
        return obs, info

    def action(self, action: Any) -> np.ndarray:
        """What the wrapped environment gets for the policy's ``action`` on this episode."""
        if self._active is None:
            raise SimulationError("GatedResidual: call reset() before step()")
        a = np.asarray(action, np.float32).reshape(self.bias.shape)
        if not self._active:
            return np.zeros_like(self.bias)
        return np.clip(self.bias + a, -1.0, 1.0).astype(np.float32)

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        return self.env.step(self.action(action))
