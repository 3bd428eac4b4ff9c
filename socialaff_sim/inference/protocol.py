"""The protocol every reaction-synthesis method implements: its result type and what it may see.

A *method* learns, from the instances of one interaction class, how agent 1
reacts to agent 0, and then produces agent 1's track for a new instance of that
class. The full model, its ablations V1/V2, the HMM and Interaction-ProMP
baselines and the trivial ``hold`` and ``constvel`` baselines all implement
:class:`ReactionMethod`, so the evaluation treats them alike.

How the evaluation asks (:mod:`socialaff_sim.evaluation.streaming`; one protocol for every method of a run)
    A :class:`StreamingMethod`'s :meth:`~StreamingMethod.start` returns a :class:`Reactor` for one
    test instance; the evaluator then calls :meth:`Reactor.react` with a *view* — an
    :class:`Interaction` holding only what the protocol lets the method see at that moment
    (:func:`protocol_view`) — and the range of agent 1's frames it wants next. A view is the
    instance cut after its visible frames (later frames of agent 0 and of the object do not exist
    in it), with agent 1 hidden from frame T0 on and no sub-events. Under the ``causal`` protocol
    the view for frame t holds frames ``[0, t]``; a method asked for frames beyond its view
    lengthens it itself with :meth:`Interaction.extend_held` (unknown joints, held object). A
    method with only ``predict`` is run on each view by
    :class:`~socialaff_sim.evaluation.streaming.PrefixReactor`.

What ``predict`` may look at
    agent 0's whole track, the object's whole track, and agent 1's first
    ``n_observed`` frames (T0 = 10 by default) — never agent 1's later frames
    nor the ground-truth sub-events: the offline setting. :func:`observed_part`
    builds its input, in which agent 1's frames from ``n_observed`` on are NaN
    and marked invalid and the sub-events are removed.

The contract sits here, below the methods (:mod:`socialaff_sim.inference.methods`,
:mod:`socialaff_sim.baselines`) that implement it; the registry of methods by name and the
evaluation that runs them are one layer up (:mod:`socialaff_sim.evaluation.registry`).
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from ..data.interaction import MIN_FRAMES, Interaction, fill_key_joints
from ..data.skeletons import N_KEY
from ..errors import ConfigError, ModelError

if TYPE_CHECKING:
    if sys.version_info >= (3, 11):
        from typing import Self
    else:
        from typing_extensions import Self

__all__ = [
    "DEFAULT_N_OBSERVED",
    "MethodFactory",
    "PrefixViews",
    "Prediction",
    "ReactionMethod",
    "Reactor",
    "StreamingMethod",
    "observed_part",
    "prediction_from_joints",
    "prediction_from_reactor",
    "protocol_view",
]

DEFAULT_N_OBSERVED = 10
"""T0: frames of agent 1 observed before the synthesis starts (the paper's setting)."""


@dataclass(frozen=True, eq=False)
class Prediction:
    """A method's prediction of agent 1 for one instance.

    Arrays are validated and stored read-only on construction.
    """

    joints: np.ndarray
    """(T, J, 3) float64, metres, world frame of the instance: agent 1's full skeleton;
    frames ``t < n_observed`` equal the observation."""
    key_joints: np.ndarray
    """(T, 5, 3) float64, metres: the method's estimate of agent 1's five key joints
    (NaN where the layout lacks one)."""
    subevents: np.ndarray | None
    """(T,) int64: the inferred sub-event per frame (−1 where none), or ``None`` if the
    method does not parse sub-events. Labels are the method's own; the evaluation
    matches them to the ground truth."""
    n_observed: int
    """T0: how many of agent 1's frames the method saw."""

    def __post_init__(self) -> None:
        joints = np.array(self.joints, dtype=np.float64, copy=True)
        if joints.ndim != 3 or joints.shape[2] != 3:
            raise ModelError(f"Prediction.joints: expected shape (T, J, 3), found {joints.shape}")
        keys = np.array(self.key_joints, dtype=np.float64, copy=True)
        if keys.shape != (joints.shape[0], N_KEY, 3):
            raise ModelError(f"Prediction.key_joints: expected shape {(joints.shape[0], N_KEY, 3)}, found {keys.shape}")
        joints.setflags(write=False)
        keys.setflags(write=False)
        object.__setattr__(self, "joints", joints)
        object.__setattr__(self, "key_joints", keys)
        if self.subevents is not None:
            sub = np.asarray(self.subevents)
            if sub.shape != (joints.shape[0],) or (sub.size and not np.issubdtype(sub.dtype, np.integer)):
                raise ModelError(f"Prediction.subevents: expected ({joints.shape[0]},) integers, found {sub.dtype} {sub.shape}")
            sub = sub.astype(np.int64)
            sub.setflags(write=False)
            object.__setattr__(self, "subevents", sub)
        n_obs = int(self.n_observed)
        if not 0 <= n_obs <= joints.shape[0]:
            raise ModelError(f"Prediction.n_observed: expected 0..{joints.shape[0]}, found {self.n_observed}")
        object.__setattr__(self, "n_observed", n_obs)

    @property
    def n_frames(self) -> int:
        """Number of frames T."""
        return int(self.joints.shape[0])


@runtime_checkable
class ReactionMethod(Protocol):
    """A method that learns agent 1's reaction and synthesizes it for new instances.

    Implementations keep settings in the constructor, learn in :meth:`fit`
    (returning ``self``; learned attributes end in ``_``) and raise
    :class:`~socialaff_sim.errors.NotFittedError` if :meth:`predict` is called first.
    """

    name: str
    """Short name used in tables (e.g. ``"hmm"``)."""

    def fit(self, interactions: Sequence[Interaction], *, rng: np.random.Generator) -> Self:
        """Learn from the training instances of one interaction class (all share the label and layout)."""
        ...

    def predict(self, interaction: Interaction, *, n_observed: int, rng: np.random.Generator) -> Prediction:
        """Predict agent 1's whole track for ``interaction``.

        Uses agent 0's whole track, the object's track and agent 1's first
        ``n_observed`` frames only (see the module docstring).
        """
        ...


@runtime_checkable
class Reactor(Protocol):
    """A method running on one test instance, asked for agent 1's frames block by block."""

    def react(self, view: Interaction, start: int, stop: int) -> Prediction:
        """Agent 1's frames ``[start, stop)`` given ``view`` (see the module docstring).

        Returns a :class:`Prediction` of ``stop − start`` frames (``n_observed`` 0) in the world
        frame of the instance. Calls come in order with growing views and consecutive ranges.
        """
        ...


@runtime_checkable
class StreamingMethod(ReactionMethod, Protocol):
    """A :class:`ReactionMethod` that reacts block by block (what the evaluation uses when present)."""

    def start(self, *, n_observed: int, offline: bool, rng: np.random.Generator) -> Reactor:
        """A fresh reactor for one test instance; ``offline``: the first view will hold agent 0's whole
        track (the ``offline`` protocol), else views grow frame by frame or block by block."""
        ...


MethodFactory = Callable[..., ReactionMethod]
"""A picklable callable returning a fresh, unfitted method; it may take a keyword ``preset`` (str)."""


def observed_part(interaction: Interaction, n_observed: int) -> Interaction:
    """What a method may see: agent 1 after frame ``n_observed`` hidden (NaN, invalid), no sub-events."""
    T = interaction.n_frames
    if not 1 <= n_observed < T:
        raise ConfigError(
            f"n_observed: expected 1..{T - 1} for {interaction.instance_id or 'the instance'} (T = {T}), found {n_observed}"
        )
    return interaction.hide_agent_after(1, n_observed).replace(subevents=None)


def protocol_view(interaction: Interaction, visible: int, n_observed: int) -> Interaction:
    """What a method may see when agent 0 (and the object) are known up to frame ``visible − 1``:
    the instance cut to frames ``[0, visible)``, agent 1 hidden from ``n_observed`` on, no sub-events."""
    if not n_observed < visible <= interaction.n_frames:
        raise ConfigError(f"visible: expected {n_observed + 1}..{interaction.n_frames} frames, found {visible}")
    return observed_part(interaction.slice(0, visible), n_observed)


class PrefixViews:
    """The filled key joints and the object track of every :func:`protocol_view` of one instance (the causal
    protocol's views, frames [0, v) for v = T0 + 1 … T) without building the views.

    Bitwise what ``protocol_view(interaction, v, n_observed).key_joints()`` and ``.object`` give: agent 1's
    tracked frames in a view all lie before T0 < v, so its filled key joints in every view are the first v
    frames of those of the whole instance with agent 1 hidden from T0 on (:func:`numpy.interp` computes each
    frame from the same tracked frames alone); agent 0's equal its recorded frames where every key joint of
    it is tracked throughout, else they are filled on the view's own frames as the view would."""

    def __init__(self, interaction: Interaction, n_observed: int) -> None:
        hidden = observed_part(interaction, n_observed)
        self.n_observed = int(n_observed)
        self._joints = hidden.joints
        self._valid = np.asarray(hidden.valid, dtype=bool)
        self._key_indices = hidden.layout.key_indices
        self._object = hidden.object
        whole = fill_key_joints(self._joints, self._valid, self._key_indices)  # (T, 2, 5, 3)
        self._agent1 = whole[:, 1]
        cols = [i for i in self._key_indices if i is not None]
        self._agent0_tracked = bool(self._valid[:, 0, cols].all())
        self._agent0 = whole[:, 0]  # = the recorded key joints (NaN where the layout lacks one) when tracked

    def key_joints(self, visible: int) -> np.ndarray:
        """(v, 2, 5, 3) float64, metres, world: the filled key joints of the view of the first ``visible`` = v
        frames (T0 < v ≤ T)."""
        if not self.n_observed < visible <= self._joints.shape[0]:
            raise ConfigError(f"visible: expected {self.n_observed + 1}..{self._joints.shape[0]} frames, found {visible}")
        if not self._agent0_tracked:
            return fill_key_joints(self._joints[:visible], self._valid[:visible], self._key_indices)
        out = np.empty((visible, 2, N_KEY, 3))
        out[:, 0] = self._agent0[:visible]
        out[:, 1] = self._agent1[:visible]
        return out

    def object(self, visible: int) -> np.ndarray | None:
        """(v, 3) float64, metres, world: the object's track in that view, or ``None``."""
        return None if self._object is None else self._object[:visible]


def prediction_from_joints(
    observed: Interaction,
    joints: np.ndarray,
    *,
    n_observed: int,
    key_joints: np.ndarray | None = None,
    subevents: np.ndarray | None = None,
) -> Prediction:
    """Build a :class:`Prediction`, copying agent 1's observed prefix into the first frames.

    ``joints`` (T, J, 3), metres, world frame: the synthesized skeleton. Without
    ``key_joints`` they are read from the skeleton through the layout. The prefix
    (frames < ``n_observed``) of both arrays is replaced by the observation
    (gaps filled in time) wherever it is finite.
    """
    out = np.array(joints, dtype=np.float64, copy=True)
    layout = observed.layout
    if key_joints is None:
        keys = layout.key_joints(out)
    else:
        keys = np.array(key_joints, dtype=np.float64, copy=True)
    prefix = observed.slice(0, max(n_observed, MIN_FRAMES))  # filling gaps needs only the prefix
    seen = prefix.filled_joints()[:n_observed, 1]
    ok = np.isfinite(seen)
    out[:n_observed][ok] = seen[ok]
    seen_keys = prefix.key_joints()[:n_observed, 1]
    ok = np.isfinite(seen_keys)
    keys[:n_observed][ok] = seen_keys[ok]
    return Prediction(joints=out, key_joints=keys, subevents=subevents, n_observed=n_observed)


def prediction_from_reactor(reactor: Reactor, view: Interaction, *, n_observed: int) -> Prediction:
    """Agent 1's whole track from one ``react`` call over frames ``n_observed`` … end of ``view``.

    ``view`` is what the reactor may read (agent 1 hidden after ``n_observed``
    where the caller wants that); the block it returns fills frames
    ``n_observed`` onwards and the observed prefix is copied in as in
    :func:`prediction_from_joints`.
    """
    block = reactor.react(view, n_observed, view.n_frames)
    joints = np.full((view.n_frames, view.joints.shape[2], 3), np.nan)
    joints[n_observed:] = block.joints
    keys = np.full((view.n_frames, N_KEY, 3), np.nan)
    keys[n_observed:] = block.key_joints
    return prediction_from_joints(view, joints, n_observed=n_observed, key_joints=keys)
