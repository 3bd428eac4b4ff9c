"""A task-frame residual for ``scripts/train_residual.py``: the base's offset and one reach per hand.

The plain residual moves each key joint's target by a free (3,) offset in the robot frame. On the shared
hand-over recordings most failures of the affordance model that a residual can reach are cups the robot's
hands never touch (docs/benchmarks.md, "fourth declared run"): what helps is a hand moved *toward the cup*,
a direction that changes from instance to instance and over an episode. :class:`ReachResidual` gives the
policy that direction instead of asking it to learn it:

* action a ∈ [−1, 1]⁵ (policy units): a[0:3] the base's offset, ``base_scale`` m per coordinate;
  a[3] the reach of the hand nearer its target, a[4] that of the other hand (nearer: the proposal's wrist
  closer to its target on this step; the left hand on a tie);
* a hand's wrist offset is ``reach_scale`` · reach · d̂, d̂ the unit vector from the proposal's wrist (the
  base of the residual, ``obs["proposal"]``) to that hand's target: the object's centre when the episode
  has one (``obs["object"]``, latest frame), otherwise the nearer of the person's wrists the recording
  provides (``obs["human_keys"]``, the frame the action is for). A positive reach moves the hand toward
  its target, a negative one away; the ankles get no offset.

Ordering the hands by distance rather than by side makes "the hand that takes the cup reaches for it" one
constant action whichever hand the proposal brings to the cup (the scripted rule that rescued training
hand-overs), so a policy has that much less to learn.

The offsets go to the wrapped environment's (5, 3) ``residual`` action (robot frame, metres), which adds
them to the proposal (through its ``residual_tau`` filter when one is set). Every coordinate stays inside
``max(base_scale, reach_scale)``, which must not exceed the environment's ``residual_bound``.
"""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from socialaff_sim.errors import ConfigError, SimulationError

__all__ = ["ReachResidual", "reach_offsets", "hand_targets"]

BASE, LEFT, RIGHT = 0, 1, 2
"""Rows of the key joints in the (5, 3) residual (``KEY_JOINTS`` order)."""


def hand_targets(obs: dict[str, np.ndarray]) -> np.ndarray | None:
    """(2, 3) m, robot frame: the left and right hand's targets in one observation (the module docstring's
    rule); ``None`` when there is none (no object and no wrist of the person)."""
    if float(obs["object_present"][0]) > 0.5:
        cup = np.asarray(obs["object"][-1], dtype=np.float64)
        return np.stack([cup, cup])
    human = np.asarray(obs["human_keys"][-1], dtype=np.float64)
    present = [k for k in (LEFT, RIGHT) if float(obs["human_mask"][k]) > 0.5]
    if not present:
        return None
    proposal = np.asarray(obs["proposal"], dtype=np.float64)
    out = np.empty((2, 3))
    for h, row in enumerate((LEFT, RIGHT)):
        dist = [np.linalg.norm(human[k] - proposal[row]) for k in present]
        out[h] = human[present[int(np.argmin(dist))]]
    return out


def reach_offsets(obs: dict[str, np.ndarray], action: np.ndarray, base_scale: float, reach_scale: float) -> np.ndarray:
    """(5, 3) m: the residual offsets of a (5,) ``action`` in [−1, 1] (clipped) given the observation the
    action answers (see the module docstring)."""
    a = np.clip(np.asarray(action, dtype=np.float64).reshape(5), -1.0, 1.0)
    out = np.zeros((5, 3))
    out[BASE] = base_scale * a[0:3]
    targets = hand_targets(obs)
    if targets is None:
        return out
    proposal = np.asarray(obs["proposal"], dtype=np.float64)
    d = targets - proposal[[LEFT, RIGHT]]
    n = np.linalg.norm(d, axis=1)
    order = (0, 1) if n[0] <= n[1] else (1, 0)  # (nearer hand, other hand)
    for k, h in enumerate(order):
        if n[h] > 1e-9:
            out[(LEFT, RIGHT)[h]] = reach_scale * a[3 + k] * d[h] / n[h]
    return out


class ReachResidual(gym.Wrapper):
    """The (5,) base-and-reach action over a ``residual``-mode :class:`~socialaff_sim.environment.SocialAffordanceEnv`
    with one offset per key joint (its (5, 3) action); observations pass through unchanged."""

    def __init__(self, env: gym.Env, base_scale: float, reach_scale: float) -> None:
        super().__init__(env)
        bound = float(env.unwrapped.config.residual_bound)  # type: ignore[attr-defined]
        if env.action_space.shape != (5, 3):
            raise ConfigError(f"--reach-scale: needs one residual row per key joint (no --residual-groups), "
                              f"found an action of shape {env.action_space.shape}")
        for name, v in (("--action-scale", base_scale), ("--reach-scale", reach_scale)):
            if not 0.0 < float(v) <= bound:
                raise ConfigError(f"{name}: expected a residual in (0, {bound}] m, found {v!r}")
        self.base_scale, self.reach_scale = float(base_scale), float(reach_scale)
        self.action_space = gym.spaces.Box(-1.0, 1.0, shape=(5,), dtype=np.float32)
        self._obs: dict[str, np.ndarray] | None = None

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        self._obs = obs
        return obs, info

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict[str, Any]]:
        if self._obs is None:
            raise SimulationError("ReachResidual: call reset() before step()")
        offsets = reach_offsets(self._obs, action, self.base_scale, self.reach_scale).astype(np.float32)
        obs, reward, terminated, truncated, info = self.env.step(offsets)
        self._obs = obs
        return obs, reward, terminated, truncated, info
