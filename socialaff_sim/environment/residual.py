"""How a ``residual`` action becomes the offset added to the proposal: grouped rows and a slow filter.

By default a residual action is the (5, 3) offset itself, one free row per key joint, changed at will every
control step. Two options of :class:`~socialaff_sim.environment.config.EnvConfig` give a policy fewer and
slower numbers to learn, the kind of correction a fixed offset held over an episode already makes (docs/benchmarks.md,
"second declared run": a base moved back, wrists moved forward or toward the cup):

* ``residual_groups`` (G groups of key joints): the action is (G, 3), one offset per group, shared by the
  group's rows; rows in no group get none. With E the (5, G) 0/1 membership matrix, the action's offset is
  u = E a (metres, robot frame).
* ``residual_tau`` (τ, s): the offset sent is not u but the output o of a first-order low-pass filter driven
  by it, τ ȯ = u − o, o = 0 at reset. Over a control step of Δt seconds with the action held (zero-order hold)
  the exact update is o ← o + (1 − e^(−Δt/τ)) (u − o). The policy sets where the offset goes; it gets there
  with time constant τ, so per-step exploration noise averages out and what remains is a slowly varying offset.
  The filter's state is part of the environment's state: the observation then carries it
  (``residual_offset``).

Either way the offset stays inside [−ρ, ρ] per coordinate (a group's offset is clipped to the box, and the
filter's output is a convex combination of such offsets and 0).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..data.skeletons import KEY_JOINTS, N_KEY
from ..errors import ConfigError, choices

__all__ = ["ResidualMap", "group_matrix"]


def group_matrix(groups: Sequence[Sequence[str]] | None) -> np.ndarray:
    """E, the (5, G) 0/1 matrix with E[k, g] = 1 when key joint k (:data:`KEY_JOINTS` order) is in group g;
    ``None``: the (5, 5) identity (every key joint its own group). :class:`~socialaff_sim.errors.ConfigError`
    on an unknown name, an empty group or a key joint in two groups."""
    if groups is None:
        return np.eye(N_KEY)
    if len(groups) == 0:
        raise ConfigError("residual_groups: expected None or at least one group of key joints, found none")
    E = np.zeros((N_KEY, len(groups)))
    for g, group in enumerate(groups):
        if isinstance(group, str) or len(group) == 0:
            raise ConfigError(f"residual_groups: group {g}: expected a non-empty list of key joints "
                              f"({choices(KEY_JOINTS)}), found {group!r}")
        for name in group:
            if name not in KEY_JOINTS:
                raise ConfigError(f"residual_groups: group {g}: expected key joints among {choices(KEY_JOINTS)}, "
                                  f"found {name!r}")
            k = KEY_JOINTS.index(name)
            if E[k].any():
                raise ConfigError(f"residual_groups: key joint {name!r} is in more than one group")
            E[k, g] = 1.0
    return E


class ResidualMap:
    """The offset of each control step from the (clipped) residual action (see the module docstring).

    ``groups``: ``EnvConfig.residual_groups``; ``tau``: ``EnvConfig.residual_tau`` (s, ``None``: no filter).
    """

    def __init__(self, groups: Sequence[Sequence[str]] | None, tau: float | None) -> None:
        self.matrix = group_matrix(groups)
        """E (5, G)."""
        self._identity = groups is None
        self.tau = tau
        """τ [s], or ``None``."""
        self.offset = np.zeros((N_KEY, 3))
        """o (5, 3) metres: the offset sent on the latest step (the filter's state when ``tau`` is set)."""

    @property
    def n_groups(self) -> int:
        """G, the rows of the action."""
        return int(self.matrix.shape[1])

    def reset(self) -> None:
        """Start an episode: the filter at rest (o = 0)."""
        self.offset = np.zeros((N_KEY, 3))

    def step(self, action: np.ndarray, seconds: float) -> np.ndarray:
        """o (5, 3) metres for a control step of ``seconds`` simulated seconds with the (G, 3) ``action`` held."""
        u = action if self._identity else self.matrix @ action
        if self.tau is None:
            self.offset = np.array(u, dtype=np.float64)
        else:
            alpha = -np.expm1(-float(seconds) / self.tau)  # 1 − e^(−Δt/τ), accurate for Δt ≪ τ
            self.offset = self.offset + alpha * (u - self.offset)
        return self.offset
