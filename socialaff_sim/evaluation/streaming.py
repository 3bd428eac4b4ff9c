"""Evaluation protocols: what a method sees when it produces each frame of agent 1, enforced.

Three protocols, the same for every method of a run (T0 = ``n_observed``, T the instance's length):

``causal`` (the default)
    Frame t ≥ T0 of agent 1 is asked for on its own, with a view of frames ``[0, t]``: agent 0's
    and the object's frames ≤ t, agent 1's first T0 frames. The method may keep its own earlier
    output (a reactor is stateful). A robot reacting to a person works like this.
``paper``
    Algorithm 2 of the paper as written: after T0 observed frames, at t = T0, T0 + ΔT, T0 + 2ΔT, …
    (ΔT = :data:`PAPER_DELTA_T` = 5) the method sees agent 0 (and the object) up to the current
    frame t, i.e. the view ``[0, t]``, and synthesizes the next ΔT frames ``[t, t + ΔT)`` at once;
    frames t + 1 … t + ΔT − 1 are therefore produced from agent 0's frames ≤ t (older than causal).
``offline``
    One call with agent 0's and the object's whole track (agent 1 hidden after T0) for frames
    ``[T0, T)``. An *upper bound*: no robot knows the person's future; every table of an offline
    run says so.

Enforcement: the view handed to the method is a new :class:`Interaction` cut after its visible
frames (:func:`~socialaff_sim.evaluation.protocol.protocol_view`), so agent 0's later frames do
not exist in anything the method receives; its length is the number of visible frames, so the
instance's duration is not revealed either. The evaluator checks every block's shape and
assembles the track; frames < T0 are the observation.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from ..data.interaction import Interaction
from ..errors import ConfigError, ModelError, choices
from ..inference.protocol import (
    Prediction,
    ReactionMethod,
    Reactor,
    StreamingMethod,
    observed_part,
    prediction_from_joints,
    protocol_view,
)

__all__ = ["PAPER_DELTA_T", "PROTOCOLS", "PrefixReactor", "run_protocol", "schedule"]

PROTOCOLS: tuple[str, ...] = ("causal", "paper", "offline")
"""Evaluation protocols; the first is the default."""

PAPER_DELTA_T = 5
"""ΔT of Algorithm 2 (frames synthesized per step under the ``paper`` protocol)."""


def schedule(protocol: str, n_frames: int, n_observed: int, delta_t: int = PAPER_DELTA_T) -> Iterator[tuple[int, int, int]]:
    """The calls of a protocol on an instance of ``n_frames`` frames: (visible, start, stop) — the
    view holds frames ``[0, visible)`` and the method returns agent 1's frames ``[start, stop)``."""
    if protocol not in PROTOCOLS:
        raise ConfigError(f"protocol: expected {choices(PROTOCOLS)}, found {protocol!r}")
    if not 1 <= n_observed < n_frames:
        raise ConfigError(f"n_observed: expected 1..{n_frames - 1}, found {n_observed}")
    if protocol == "offline":
        yield n_frames, n_observed, n_frames
        return
    step = 1 if protocol == "causal" else delta_t
    for t in range(n_observed, n_frames, step):
        yield t + 1, t, min(t + step, n_frames)


class PrefixReactor:
    """Runs a method that only has ``predict`` under a protocol: each call predicts the whole view
    (lengthened to ``stop`` by :meth:`Interaction.extend_held`) and returns frames [start, stop).

    Exactly causal for any method, since the view is all it gets; the cost grows with the square of
    the instance's length, and a stochastic method redraws its past at every call."""

    def __init__(self, method: ReactionMethod, n_observed: int, rng: np.random.Generator) -> None:
        self.method = method
        self.n_observed = n_observed
        self.rng = rng

    def react(self, view: Interaction, start: int, stop: int) -> Prediction:
        """Frames [start, stop) of ``method.predict`` on the view."""
        pred = self.method.predict(view.extend_held(stop), n_observed=self.n_observed, rng=self.rng)
        sub = None if pred.subevents is None else pred.subevents[start:stop]
        return Prediction(pred.joints[start:stop], pred.key_joints[start:stop], sub, 0)


def _reactor(method: ReactionMethod, *, n_observed: int, offline: bool, rng: np.random.Generator) -> Reactor:
    if isinstance(method, StreamingMethod):
        return method.start(n_observed=n_observed, offline=offline, rng=rng)
    return PrefixReactor(method, n_observed, rng)


def run_protocol(
    method: ReactionMethod,
    interaction: Interaction,
    *,
    protocol: str,
    n_observed: int,
    rng: np.random.Generator,
    delta_t: int = PAPER_DELTA_T,
) -> Prediction:
    """Agent 1's whole track for ``interaction`` (T frames) produced by a fitted ``method`` under
    ``protocol``; frames < ``n_observed`` are the observation. Raises
    :class:`~socialaff_sim.errors.ModelError` when a block has the wrong shape or is not finite."""
    T = interaction.n_frames
    J = interaction.joints.shape[2]
    reactor = _reactor(method, n_observed=n_observed, offline=protocol == "offline", rng=rng)
    joints = np.full((T, J, 3), np.nan)
    keys = np.full((T, 5, 3), np.nan)
    subs: np.ndarray | None = np.full(T, -1, dtype=np.int64)
    name = getattr(method, "name", type(method).__name__)
    for visible, start, stop in schedule(protocol, T, n_observed, delta_t):
        block = reactor.react(protocol_view(interaction, visible, n_observed), start, stop)
        if not isinstance(block, Prediction) or block.n_frames != stop - start or block.joints.shape[1] != J:
            raise ModelError(
                f"method {name!r}: asked for frames [{start}, {stop}) of {interaction.instance_id or 'an instance'}, "
                f"expected a Prediction of {stop - start} frames × {J} joints, found "
                f"{block.joints.shape if isinstance(block, Prediction) else type(block).__name__}"
            )
        joints[start:stop] = block.joints
        keys[start:stop] = block.key_joints
        if subs is not None and block.subevents is not None:
            subs[start:stop] = block.subevents
        else:
            subs = None
    return prediction_from_joints(
        observed_part(interaction, n_observed), joints, n_observed=n_observed, key_joints=keys, subevents=subs
    )
