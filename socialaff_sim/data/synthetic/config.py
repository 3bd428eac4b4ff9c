"""Settings of the synthetic dataset: interactions, their sub-events, and :class:`SyntheticConfig`."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ...errors import ConfigError, choices

__all__ = ["INTERACTIONS", "SUBEVENTS", "SyntheticConfig"]

INTERACTIONS: tuple[str, ...] = ("shake_hands", "high_five", "pull_up", "throw_catch", "hand_over")
"""The five interaction classes c the generator scripts, in a fixed order (part of the seeding scheme)."""

SUBEVENTS: dict[str, tuple[str, ...]] = {
    "shake_hands": ("approach", "reach", "shake", "retract"),
    "high_five": ("approach", "raise", "strike", "retract"),
    "pull_up": ("approach", "reach", "pull", "release"),
    "throw_catch": ("wind_up", "throw", "flight", "catch", "hold"),
    "hand_over": ("approach", "reach", "transfer", "retract"),
}
"""Ground-truth sub-event names per interaction, in scripted order.

Their count is also the default dictionary size |S| per interaction for the model.
"""


def _pair(value: object) -> tuple[float, float] | None:
    try:
        lo, hi = (float(v) for v in value)  # type: ignore[union-attr]
    except (TypeError, ValueError):
        return None
    return (lo, hi)


@dataclass(frozen=True)
class SyntheticConfig:
    """How the embedded synthetic HHOI-like dataset is generated.

    Change fields with :func:`dataclasses.replace`; ``noise=False`` gives the
    clean kinematic data (the motion is the same for a given seed either way).

    Fields by concept
    -----------------
    - Dataset size: interactions, instances_per_interaction, n_actors, pairs_per_interaction
    - Actors and timing: height_range, proportion_jitter, fps_range, duration_range, tempo_range,
      room_half_extent, left_hand_probability
    - Sensor noise: noise, jitter_sd, jitter_correlation, occluded_jitter_sd, dropout, occluded_dropout,
      object_jitter_sd
    """

    interactions: tuple[str, ...] = INTERACTIONS
    """c [—]: Interaction classes c to generate (any subset of :data:`INTERACTIONS`)."""
    instances_per_interaction: int = 24
    """N [—]: instances generated per interaction."""
    n_actors: int = 8
    """A [—]: number of distinct actors (ids ``a01``, ``a02``, ...)."""
    pairs_per_interaction: int = 8
    """P [—]: distinct unordered actor pairs used per interaction (capped at A(A-1)/2 and N)."""
    height_range: tuple[float, float] = (1.50, 1.95)
    """(H_min, H_max) [m]: range of the actors' statures H."""
    proportion_jitter: float = 0.04
    """δ_p [—]: relative spread (uniform ±δ_p) of an actor's arm and leg lengths around average proportions."""
    fps_range: tuple[float, float] = (10.0, 15.0)
    """(f_min, f_max) [Hz]: each instance's frame rate is drawn uniformly in this range."""
    duration_range: tuple[float, float] = (2.0, 7.0)
    """(D_min, D_max) [s]: instance lengths are kept inside this range."""
    tempo_range: tuple[float, float] = (0.85, 1.2)
    """(τ_min, τ_max) [—]: per-instance factor on all scripted phase durations (slow or brisk pairs)."""
    room_half_extent: float = 1.5
    """E [m]: the pair is shifted by a uniform offset in [-E, E]² and turned by a uniform yaw."""
    left_hand_probability: float = 0.3
    """p_L [—]: probability that a one-handed action (high five, pull-up grip, cup receiver, throw) uses the left hand."""
    noise: bool = True
    """[—]: Whether to add Kinect-like corruption; ``False`` keeps the clean forward-kinematics data."""
    jitter_sd: float = 0.015
    """σ_j [m]: per-axis standard deviation of the joint jitter."""
    jitter_correlation: float = 0.5
    """ρ [—]: lag-one autocorrelation of the jitter (an AR(1) process in time; 0 = white)."""
    occluded_jitter_sd: float = 0.04
    """σ_o [m]: per-axis jitter of hand joints occluded during contact (replaces σ_j there)."""
    dropout: float = 0.01
    """p_d [—]: probability that a joint is untracked in a frame (NaN coordinates, ``valid`` False)."""
    occluded_dropout: float = 0.08
    """p_o [—]: dropout probability of hand joints occluded during contact."""
    object_jitter_sd: float = 0.005
    """σ_b [m]: per-axis white jitter of the object track (never dropped)."""

    def __post_init__(self) -> None:
        def bad(field: str, expected: str) -> ConfigError:
            return ConfigError(f"SyntheticConfig.{field}: expected {expected}, found {getattr(self, field)!r}")

        inter = tuple(self.interactions) if not isinstance(self.interactions, str) else (self.interactions,)
        unknown = [c for c in inter if c not in INTERACTIONS]
        if unknown or not inter or len(set(inter)) != len(inter):
            raise ConfigError(
                f"SyntheticConfig.interactions: expected distinct names from {choices(INTERACTIONS)}, "
                f"found {self.interactions!r}"
            )
        object.__setattr__(self, "interactions", inter)
        for name, lo in (("instances_per_interaction", 1), ("n_actors", 2), ("pairs_per_interaction", 1)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < lo:
                raise bad(name, f"an integer >= {lo}")
        limits = {
            "height_range": (1.2, 2.2),
            "fps_range": (1.0, 240.0),
            "duration_range": (0.5, 120.0),
            "tempo_range": (0.3, 3.0),
        }
        for name, (lo, hi) in limits.items():
            pair = _pair(getattr(self, name))
            if pair is None or not (lo <= pair[0] <= pair[1] <= hi):
                raise bad(name, f"(low, high) with {lo} <= low <= high <= {hi}")
            object.__setattr__(self, name, pair)
        lo_d, hi_d = self.duration_range
        if hi_d * self.fps_range[0] < 3:
            raise bad("duration_range", "a longest duration giving at least 3 frames at the lowest fps")
        for name in ("proportion_jitter", "left_hand_probability", "dropout", "occluded_dropout"):
            value = getattr(self, name)
            top = 0.2 if name == "proportion_jitter" else 0.5 if "dropout" in name else 1.0
            if not isinstance(value, (int, float)) or not (0.0 <= value <= top):
                raise bad(name, f"a number in [0, {top}]")
        for name in ("room_half_extent", "jitter_sd", "occluded_jitter_sd", "object_jitter_sd"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
                raise bad(name, "a finite number >= 0 (metres)")
        if not isinstance(self.jitter_correlation, (int, float)) or not (0.0 <= self.jitter_correlation < 1.0):
            raise bad("jitter_correlation", "a number in [0, 1)")
        if not isinstance(self.noise, bool):
            raise bad("noise", "True or False")
