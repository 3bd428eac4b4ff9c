"""The trivial baselines every table must include: ``hold`` and ``constvel``.

Both read only agent 1's first T0 observed frames (gap-filled within those frames) and ignore
agent 0, so they are causal under every protocol. A method that does not beat them has not shown
that it reacts to the person.

``hold``
    Agent 1 keeps its last observed pose (frame T0 − 1) for the rest of the instance.
``constvel``
    Agent 1 continues its last observed velocity. The velocity of every joint is the least-squares
    slope of its positions over the last ``window`` observed frames (a straight-line fit: a
    two-frame difference would pass the tracker's jitter straight through). Held without limit it
    would walk a person through the wall over a 10 s recording, so the velocity decays with time
    constant τ: frame T0 − 1 + k sits at x_{T0−1} + v·τ·(1 − e^{−k/τ}) (k frames, v in m/frame),
    at most v·τ from the last pose. τ = 1 s and ``window`` = 5 frames were fixed before any
    evaluation (a typical time over which people keep moving in one direction, and a few frames
    at 6–30 Hz), not tuned on any data; ``time_constant_s=inf`` gives the undamped extrapolation.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..data.interaction import Interaction
from ..errors import ConfigError, ModelError, NotFittedError
from ..inference.protocol import Prediction, prediction_from_reactor
from ..inference.reaction_features import velocity_estimate

__all__ = ["ConstantVelocity", "ConstVelConfig", "HoldPose", "damped_displacement", "velocity_estimate"]


@dataclass(frozen=True)
class ConstVelConfig:
    """Settings of the ``constvel`` baseline (fixed a priori, see the module docstring)."""

    window: int = 5
    """K [frames]: The last K observed frames give each joint's velocity (least-squares slope)."""
    time_constant_s: float = 1.0
    """τ [s]: Decay time of the continued velocity (``math.inf``: no decay)."""

    def __post_init__(self) -> None:
        if self.window < 2:
            raise ConfigError(f"window: expected at least 2 frames, found {self.window}")
        if not self.time_constant_s > 0:
            raise ConfigError(f"time_constant_s: expected seconds > 0, found {self.time_constant_s}")


def damped_displacement(velocity: np.ndarray, steps: np.ndarray, tau_frames: float) -> np.ndarray:
    """(F, …, 3) displacement after ``steps`` (F,) frames of a velocity (…, 3) m/frame decaying with
    time constant ``tau_frames``: v·τ·(1 − e^{−k/τ}), or v·k when τ is infinite."""
    k = np.asarray(steps, dtype=np.float64)
    gain = k if math.isinf(tau_frames) else tau_frames * -np.expm1(-k / tau_frames)
    v = np.asarray(velocity, dtype=np.float64)
    return gain.reshape((-1,) + (1,) * v.ndim) * v[None]


def _observed_agent1(view: Interaction, n_observed: int) -> np.ndarray:
    """(T0, J, 3) agent 1's observed frames (in a view agent 1 is unknown after T0, so gaps are filled
    from the observation only)."""
    return view.filled_joints()[:n_observed, 1]



class _Extrapolator:
    """Reactor of both baselines: agent 1's last observed pose plus a fixed displacement per frame."""

    def __init__(self, velocity_of: object, n_observed: int) -> None:
        self._velocity_of = velocity_of
        self.n_observed = n_observed
        self._state: tuple[np.ndarray, np.ndarray, float] | None = None

    def react(self, view: Interaction, start: int, stop: int) -> Prediction:
        """Frames [start, stop) from the observation (read at the first call)."""
        if self._state is None:
            seen = _observed_agent1(view, self.n_observed)
            v, tau = self._velocity_of(seen, view.fps)  # type: ignore[operator]
            self._state = (seen[-1], v, tau)
            self._layout = view.layout
        last, v, tau = self._state
        joints = last[None] + damped_displacement(v, np.arange(start, stop) - (self.n_observed - 1), tau)
        keys = self._layout.key_joints(joints)
        return Prediction(joints=joints, key_joints=keys, subevents=None, n_observed=0)


class _Simple:
    name = "simple"

    def fit(self, interactions: Sequence[Interaction], *, rng: np.random.Generator) -> _Simple:
        """Nothing to learn; checks the input and marks the method fitted."""
        if not interactions:
            raise ModelError(f"{self.name}: expected at least one training interaction, found none")
        self.fitted_ = True
        return self

    def _velocity(self, seen: np.ndarray, fps: float) -> tuple[np.ndarray, float]:
        raise NotImplementedError

    def start(self, *, n_observed: int, offline: bool, rng: np.random.Generator) -> _Extrapolator:
        """A reactor for one instance (the same under every protocol)."""
        if not hasattr(self, "fitted_"):
            raise NotFittedError(f"method {self.name!r}: call fit(interactions, rng=...) before start")
        return _Extrapolator(self._velocity, n_observed)

    def predict(self, interaction: Interaction, *, n_observed: int, rng: np.random.Generator) -> Prediction:
        """Agent 1's whole track (it reads only agent 1's first ``n_observed`` frames)."""
        return prediction_from_reactor(self.start(n_observed=n_observed, offline=True, rng=rng), interaction,
                                       n_observed=n_observed)


class HoldPose(_Simple):
    """``hold``: agent 1 keeps its last observed pose."""

    name = "hold"

    def _velocity(self, seen: np.ndarray, fps: float) -> tuple[np.ndarray, float]:
        return np.zeros_like(seen[-1]), math.inf


class ConstantVelocity(_Simple):
    """``constvel``: agent 1 continues its last observed velocity, decaying (:class:`ConstVelConfig`)."""

    name = "constvel"

    def __init__(self, config: ConstVelConfig | None = None) -> None:
        self.config = config or ConstVelConfig()

    def _velocity(self, seen: np.ndarray, fps: float) -> tuple[np.ndarray, float]:
        k = min(self.config.window, seen.shape[0])
        if k < 2:
            return np.zeros_like(seen[-1]), math.inf
        return velocity_estimate(seen[-k:]), self.config.time_constant_s * fps
