"""Causal per-frame features of the learned reactions (the full model's switching regression, ``ridge``, ``gru``).

Everything is expressed relative to the *anchor*: frame a = T0 − 1, agent 1's last observed frame.
The anchor frame's axes are those of :func:`~socialaff_sim.model.frame.canonical_frame` built from
both agents' bases at frame a (x horizontally from agent 0 toward agent 1, z up), so a recording's
position and heading on the floor do not matter. For an output frame t ≥ T0, with s = (t − a) / fps
seconds since the anchor and u = min(t, visible − 1) the newest frame of agent 0 the method may see,
the feature groups are (all in the anchor frame):

``agent0`` (15)
    agent 0's five key joints at u minus at a, metres: how the person moved since the last observation.
``gap`` (4)
    (agent 0's base at u − agent 1's base at a) · r(s), and r(s), with r(s) = 1 − e^{−s/τ}: lets agent 1
    close (or keep) the distance to the person, starting from zero displacement at s = 0.
``own_velocity`` (15)
    agent 1's observed key-joint velocity (least-squares slope over its last ``window`` observed frames,
    m/s) · τ·r(s), metres: the ``constvel`` extrapolation as a feature.
``agent0_velocity`` (15)
    agent 0's key-joint velocity at u (slope over the ``window`` frames ending at u), m/s.

The target is agent 1's whole skeleton at t minus its pose at a, in the anchor frame (metres); zero
displacement is ``hold``. Agent 0's frames are filled causally (a joint missing in a frame holds its last
tracked position); a key joint the layout lacks contributes zeros. Frames t ≥ visible (a forecast) hold
agent 0 at its last visible frame, and its velocity at its last visible value.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..data.interaction import Interaction, fill_gaps
from ..data.skeletons import N_KEY
from ..errors import ConfigError, ModelError, choices
from ..model.frame import CanonicalFrame, canonical_frame
from ..model.nan_fill import nan_to_zero
from . import feature_kernel
from .compiled import KERNELS

__all__ = [
    "FEATURE_GROUPS", "N_FEATURES", "RAMP_COLUMN", "Anchor", "FeatureConfig", "FeatureStream", "forward_fill", "group_columns", "nan_to_zero",
    "training_rows", "velocity_estimate",
]

FEATURE_GROUPS: tuple[str, ...] = ("agent0", "gap", "own_velocity", "agent0_velocity")
"""The feature groups, in column order."""
_WIDTH = {"agent0": 3 * N_KEY, "gap": 4, "own_velocity": 3 * N_KEY, "agent0_velocity": 3 * N_KEY}


@dataclass(frozen=True)
class FeatureConfig:
    """How the features are computed (fixed a priori, the same for every dataset)."""

    window: int = 5
    """K [frames]: frames of the least-squares velocity slopes (as ``constvel``)."""
    time_constant_s: float = 1.0
    """τ [s]: time constant of the ramp r(s) = 1 − e^{−s/τ} (as ``constvel``'s velocity decay)."""

    def __post_init__(self) -> None:
        if self.window < 2:
            raise ConfigError(f"window: expected at least 2 frames, found {self.window}")
        if not self.time_constant_s > 0:
            raise ConfigError(f"time_constant_s: expected seconds > 0, found {self.time_constant_s}")


def group_columns(groups: Sequence[str]) -> np.ndarray:
    """Column indices (int64) of the feature matrix that belong to ``groups``."""
    out, start = [], 0
    for g in FEATURE_GROUPS:
        if g in groups:
            out.extend(range(start, start + _WIDTH[g]))
        start += _WIDTH[g]
    return np.asarray(out, dtype=np.int64)


N_FEATURES = sum(_WIDTH.values())
RAMP_COLUMN = _WIDTH["agent0"] + 3
"""Column of r(s), the ramp of the ``gap`` group (its last column)."""


def velocity_estimate(positions: np.ndarray) -> np.ndarray:
    """Least-squares slope (…, 3) per frame of ``positions`` (K, …, 3) at consecutive frames (metres/frame)."""
    x = np.asarray(positions, dtype=np.float64)
    k = x.shape[0]
    if k < 2:
        raise ModelError(f"velocity: expected at least 2 frames, found {k}")
    t = np.arange(k, dtype=np.float64) - (k - 1) / 2.0
    return np.tensordot(t, x, axes=(0, 0)) / float(t @ t)


_SLOPE_WEIGHTS: dict[int, tuple[np.ndarray, float]] = {}


def _window_slope(x: np.ndarray) -> np.ndarray:
    """:func:`velocity_estimate` of ``x`` (K, 5, 3), bitwise: the same ``np.dot`` that ``np.tensordot`` makes of it,
    with the weights and their squared norm made once per K."""
    k = x.shape[0]
    if k not in _SLOPE_WEIGHTS:
        t = np.arange(k, dtype=np.float64) - (k - 1) / 2.0
        _SLOPE_WEIGHTS[k] = (t.reshape(1, k), float(t @ t))
    t, tt = _SLOPE_WEIGHTS[k]
    return np.dot(t, x.reshape(k, -1)).reshape(x.shape[1:]) / tt


def forward_fill(values: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """(T, …, 3) ``values`` with each entry invalid in ``valid`` (T, …) replaced by its last valid frame
    (by its first valid frame before that; NaN if never valid)."""
    x = np.array(values, dtype=np.float64, copy=True)
    ok = np.asarray(valid, dtype=bool) & np.isfinite(x).all(-1)
    T = x.shape[0]
    idx = np.where(ok, np.arange(T).reshape((T,) + (1,) * (ok.ndim - 1)), -1)
    last = np.maximum.accumulate(idx, axis=0)
    first = np.where(ok.any(0), ok.argmax(0), 0)
    last = np.where(last < 0, first[None], last)
    out = np.take_along_axis(x, last[..., None], axis=0)
    out[:, ~ok.any(0)] = np.nan
    return out


def _slopes(x: np.ndarray, window: int) -> np.ndarray:
    """(T, 5, 3) least-squares slope per frame over the ≤ ``window`` frames ending there (0 with one frame)."""
    T = x.shape[0]
    out = np.zeros_like(x)
    for u in range(1, min(window - 1, T)):
        out[u] = velocity_estimate(x[: u + 1])
    if T >= window:
        win = np.lib.stride_tricks.sliding_window_view(x, window, axis=0)  # (T−K+1, 5, 3, K)
        k = np.arange(window, dtype=np.float64) - (window - 1) / 2.0
        out[window - 1:] = win @ k / float(k @ k)
    return out


@dataclass(frozen=True)
class Anchor:
    """Agent 1 at its last observed frame a = T0 − 1, and the anchor frame."""

    pose: np.ndarray
    """(J, 3) metres, world: agent 1's skeleton at a (gap-filled within the observation)."""
    base0: np.ndarray
    """(3,) metres, world: agent 0's base at a."""
    keys0: np.ndarray
    """(5, 3) metres, world: agent 0's key joints at a (NaN where the layout has none)."""
    velocity1: np.ndarray
    """(5, 3) m/s, anchor frame: agent 1's observed key-joint velocity (zero where unknown)."""
    base1: np.ndarray
    """(3,) metres, world: agent 1's base at a."""
    frame: CanonicalFrame
    """The anchor frame (rotation about z; only its rotation is used)."""
    index: int
    """a [frames]."""
    fps: float
    """Frame rate, frames per second."""

    @classmethod
    def from_view(cls, view: Interaction, n_observed: int, config: FeatureConfig) -> Anchor:
        """The anchor of an instance from the frames a method may see (agent 1's first ``n_observed`` frames)."""
        valid = np.asarray(view.valid)[:n_observed]
        # Agent 1's joints of view.slice(0, T0).filled_joints(), filled alone (each joint is filled from its own
        # frames, so the same values, without filling agent 0's or validating a sliced instance).
        obs1 = fill_gaps(view.joints[:n_observed, 1:], valid[:, 1:])[:, 0]
        keys0 = view.layout.key_joints(forward_fill(view.joints[:n_observed, 0], valid[:, 0]))
        keys1 = view.layout.key_joints(obs1)
        a = n_observed - 1
        b0 = keys0[a, 0]
        b1 = keys1[a, 0]
        if np.isfinite(b0).all() and np.isfinite(b1).all():
            frame = canonical_frame(b0, b1)
        else:
            frame = CanonicalFrame(origin=np.zeros(3), heading=0.0)
        k = min(config.window, n_observed)
        v = velocity_estimate(keys1[-k:]) * view.fps if k >= 2 else np.zeros((N_KEY, 3))
        v = nan_to_zero(v @ frame.rotation)
        return cls(obs1[a], b0, keys0[a], v, b1, frame, a, float(view.fps))

    def features(self, keys0: np.ndarray, vel0: np.ndarray, frames: np.ndarray, config: FeatureConfig,
                 groups: Sequence[str] = FEATURE_GROUPS) -> np.ndarray:
        """(F, N_FEATURES) rows for output frames ``frames`` (F,), given agent 0's key joints (F, 5, 3)
        (world, metres, already taken at each row's u) and their velocity (F, 5, 3) (world, m/s). ``groups``: the
        groups computed; the columns of ``agent0``, ``own_velocity`` and ``agent0_velocity`` when not among them
        are zeros (``gap``, with the ramp, is always computed: the belief's columns read the ramp)."""
        R = self.frame.rotation
        s = (np.asarray(frames, dtype=np.float64) - self.index) / self.fps
        tau = config.time_constant_s
        ramp = -np.expm1(-s / tau)
        n = len(s)
        d0 = nan_to_zero((keys0 - self.keys0[None]) @ R).reshape(n, -1) if "agent0" in groups else np.zeros((n, 3 * N_KEY))
        gap = nan_to_zero((keys0[:, 0] - self.base1[None]) @ R) * ramp[:, None]
        if "own_velocity" in groups:
            own = (tau * ramp)[:, None] * self.velocity1.reshape(1, -1)
        else:
            own = np.zeros((n, 3 * N_KEY))
        v0 = nan_to_zero(vel0 @ R).reshape(n, -1) if "agent0_velocity" in groups else np.zeros((n, 3 * N_KEY))
        return np.concatenate([d0, gap, ramp[:, None], own, v0], axis=1)

    def to_world(self, displacement: np.ndarray) -> np.ndarray:
        """(F, J, 3) world skeletons from (F, J·3) displacements in the anchor frame."""
        d = np.asarray(displacement, dtype=np.float64).reshape(len(displacement), -1, 3)
        return self.pose[None] + d @ self.frame.rotation.T


def _agent0_tracks(interaction: Interaction, config: FeatureConfig) -> tuple[np.ndarray, np.ndarray]:
    """Agent 0's causally filled key joints (T, 5, 3), metres, and their velocity (T, 5, 3), m/s, world."""
    keys0 = interaction.layout.key_joints(forward_fill(interaction.joints[:, 0], np.asarray(interaction.valid)[:, 0]))
    return keys0, _slopes(keys0, config.window) * interaction.fps


def training_rows(
    interaction: Interaction, n_observed: int, config: FeatureConfig
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Features (F, N_FEATURES), targets (F, J·3) (anchor-frame displacements, metres; 0 where agent 1's
    joint is never tracked) and output frames (F,) for frames T0 … T − 1 of a training instance, each row
    computed from agent 0's frames ≤ t and agent 1's first T0 frames only."""
    T = interaction.n_frames
    anchor = Anchor.from_view(interaction.hide_agent_after(1, n_observed), n_observed, config)
    keys0, vel0 = _agent0_tracks(interaction, config)
    frames = np.arange(n_observed, T)
    X = anchor.features(keys0[frames], vel0[frames], frames, config)
    truth = interaction.filled_joints()[n_observed:, 1]
    Y = np.nan_to_num((truth - anchor.pose[None]) @ anchor.frame.rotation).reshape(len(frames), -1)
    return X, Y, frames


class FeatureStream:
    """Feature rows of one test instance as its views grow.

    Calls come in order with growing views (:class:`~socialaff_sim.inference.protocol.Reactor`). Rows of
    frames t ≥ visible − 1 need only agent 0's last ``window`` frames, which the stream keeps, so the work
    per frame is bounded whatever the stream's length; rows of earlier frames (the offline protocol's single
    call) are computed from the whole view at once.
    """

    def __init__(self, n_observed: int, config: FeatureConfig, kernel: str = "numpy") -> None:
        self.n_observed = n_observed
        self.config = config
        # kernel "numba": the row of the frame just seen in one compiled call (:mod:`.feature_kernel`), compiled now
        # (a missing numba is a ConfigError here, not at the first frame).
        if kernel not in KERNELS:
            raise ConfigError(f"FeatureStream kernel: expected {choices(KERNELS)}, found {kernel!r}")
        self._row_kernel = feature_kernel.kernels()["feature_row"] if kernel == "numba" else None
        self._anchor_args: tuple[Anchor, np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None
        self._anchor: Anchor | None = None
        self._window: list[np.ndarray] = []  # agent 0's last ≤ K causally filled key-joint frames (5, 3)
        self._last = np.full((N_KEY, 3), np.nan)  # last tracked position of each key joint
        self._seen = 0  # frames of the views consumed so far

    @property
    def anchor(self) -> Anchor:
        """The instance's anchor (read from the first view); an error before :meth:`rows` was called."""
        if self._anchor is None:
            raise ModelError("feature stream: no view seen yet (call rows(view, start, stop) first)")
        return self._anchor

    def _consume(self, view: Interaction) -> None:
        new = slice(self._seen, view.n_frames)
        idx = view.layout.key_indices
        if None in idx:
            keys = view.layout.key_joints(view.joints[new, 0])
            valid = np.zeros((keys.shape[0], N_KEY), dtype=bool)
            for k, i in enumerate(idx):
                if i is not None:
                    valid[:, k] = np.asarray(view.valid)[new, 0, i]
        else:  # every key joint in the layout: one gather each (the same values)
            keys = np.asarray(view.joints[new, 0][:, list(idx)], dtype=np.float64)
            valid = np.asarray(view.valid)[new, 0][:, list(idx)]
        for cur, ok in zip(keys, valid, strict=True):
            self._last = np.where(ok[:, None] & np.isfinite(cur), cur, self._last)
            self._window.append(self._last)
        self._window = self._window[-self.config.window:]
        self._seen = view.n_frames

    def rows(self, view: Interaction, start: int, stop: int, groups: Sequence[str] = FEATURE_GROUPS) -> np.ndarray:
        """(stop − start, N_FEATURES) rows of output frames [start, stop) given ``view``; ``groups``: those
        computed (:meth:`Anchor.features`; the others' columns are zeros)."""
        if self._anchor is None:
            self._anchor = Anchor.from_view(view, self.n_observed, self.config)
        if view.n_frames > self._seen:
            self._consume(view)
        last = view.n_frames - 1
        parts = []
        if start < last:  # frames inside the view: each from its own frame of agent 0
            keys0, vel0 = _agent0_tracks(view, self.config)
            inside = np.arange(start, min(stop, last))
            parts.append(self.anchor.features(keys0[inside], vel0[inside], inside, self.config, groups))
        if self._row_kernel is not None and start == last and stop == last + 1:  # the stream's usual call
            return self._kernel_row(view, last, groups)
        frames = np.arange(max(start, last), stop)
        if len(frames):
            win = np.stack(self._window)
            vel = _window_slope(win) * view.fps if len(win) >= 2 else np.zeros((N_KEY, 3))
            n = len(frames)
            keys0, vel0 = (win[-1][None], vel[None]) if n == 1 else (np.repeat(win[-1][None], n, 0), np.repeat(vel[None], n, 0))
            parts.append(self.anchor.features(keys0, vel0, frames, self.config, groups))
        return np.concatenate(parts, axis=0)

    def _kernel_row(self, view: Interaction, frame: int, groups: Sequence[str]) -> np.ndarray:
        """(1, N_FEATURES) :meth:`rows` of the one frame ``frame`` = the view's last, by the compiled kernel."""
        a = self.anchor
        if self._anchor_args is None or self._anchor_args[0] is not a:  # the anchor's arrays as the kernel reads them:
            # writable C-ordered copies (a read-only array, as cached values are, would be compiled for a second time)
            rot, keys0, base1, vel1 = (np.array(x, dtype=np.float64, order="C")
                                       for x in (a.frame.rotation, a.keys0, a.base1, a.velocity1))
            self._anchor_args = (a, rot, keys0, base1, vel1.reshape(-1))
        _, rot, keys0, base1, velocity1 = self._anchor_args
        out = np.empty((1, N_FEATURES))
        s = (float(frame) - a.index) / a.fps  # Anchor.features's s, one frame
        assert self._row_kernel is not None
        self._row_kernel(out[0], np.stack(self._window), float(view.fps), rot, keys0, base1, velocity1, s,
                         self.config.time_constant_s, "agent0" in groups, "own_velocity" in groups,
                         "agent0_velocity" in groups)
        return out
