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

Horizons and latency (:func:`run_protocol_measured`)
    At *forecast times* — the calls of the schedule whose first frame t lies on the grid
    T0, T0 + S, T0 + 2S, … (S = ``horizon_every`` frames; the first call at or after each grid frame) —
    the evaluator also asks a *copy* of the method's reactor, with the same view (frames ≤ t under
    ``causal``), for frames ``[t, t + L)``, L = the longest horizon in frames + 1. The copy's frame
    t + k is the method's forecast k frames ahead of its newest observation; the original reactor then
    carries on as if nothing happened (the copy has its own random state), so the protocol's own
    output is unchanged. Under ``offline`` there is no forecast (every frame is seen); it records none.
    The wall time of every call of the original reactor is recorded (its latency; under ``causal``
    one call is one frame), not that of the copies.

Enforcement: the view handed to the method is an :class:`Interaction` cut after its visible
frames (what :func:`~socialaff_sim.inference.protocol.protocol_view` builds), made without a copy from a
:class:`~socialaff_sim.data.growing.GrowingInteraction` that the evaluator fills with each frame only when it
becomes visible: agent 0's later frames do not exist in anything the method can reach when it runs (O(1)
work per view instead of O(t)); its length is the number of visible frames, so the instance's duration is
not revealed either. The evaluator checks every block's shape and
assembles the track; frames < T0 are the observation.
"""

from __future__ import annotations

import copy
import time
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from ..data.growing import GrowingInteraction
from ..data.interaction import Interaction
from ..errors import ConfigError, ModelError, choices
from ..inference.protocol import (
    Prediction,
    ReactionMethod,
    Reactor,
    StreamingMethod,
    observed_part,
    prediction_from_joints,
)

__all__ = ["PAPER_DELTA_T", "PROTOCOLS", "PrefixReactor", "ProtocolRun", "run_protocol", "run_protocol_measured", "schedule"]

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


@dataclass(frozen=True, eq=False)
class ProtocolRun:
    """What :func:`run_protocol_measured` returns for one instance."""

    prediction: Prediction
    """Agent 1's whole track under the protocol (as :func:`run_protocol`)."""
    call_seconds: np.ndarray
    """(C,) float64, seconds: wall time of each call of the method's reactor, in order."""
    call_frames: np.ndarray
    """(C,) int64: frames produced by each of those calls."""
    forecast_times: np.ndarray
    """(A,) int64: the forecast times t (frames)."""
    forecasts: np.ndarray
    """(A, L, 5, 3) float64, metres: key joints of the forecast of frames t … t + L − 1 made at each t
    (NaN where the instance ends); (0, 0, 5, 3) when there is none."""


def _fork(reactor: Reactor, method: ReactionMethod) -> Reactor:
    """An independent copy of ``reactor`` that shares the fitted method and its learned attributes (read
    only) but not its random generators."""
    memo: dict[int, object] = {id(method): method}
    for value in vars(method).values() if hasattr(method, "__dict__") else ():
        if not isinstance(value, np.random.Generator):
            memo[id(value)] = value
    return copy.deepcopy(reactor, memo)


def run_protocol_measured(
    method: ReactionMethod,
    interaction: Interaction,
    *,
    protocol: str,
    n_observed: int,
    rng: np.random.Generator,
    delta_t: int = PAPER_DELTA_T,
    horizon_frames: int = 0,
    horizon_every: int = 1,
) -> ProtocolRun:
    """:func:`run_protocol` plus the reactor's per-call wall times and, when ``horizon_frames`` > 0 and the
    protocol is not ``offline``, forecasts ``horizon_frames`` frames ahead every ``horizon_every`` frames
    (module docstring). Raises :class:`~socialaff_sim.errors.ModelError` as :func:`run_protocol` does."""
    if horizon_frames < 0 or horizon_every < 1:
        raise ConfigError(f"horizons: expected horizon_frames ≥ 0 and horizon_every ≥ 1, found {horizon_frames}, {horizon_every}")
    T = interaction.n_frames
    J = interaction.joints.shape[2]
    reactor = _reactor(method, n_observed=n_observed, offline=protocol == "offline", rng=rng)
    joints = np.full((T, J, 3), np.nan)
    keys = np.full((T, 5, 3), np.nan)
    subs: np.ndarray | None = np.full(T, -1, dtype=np.int64)
    name = getattr(method, "name", type(method).__name__)
    seconds: list[float] = []
    frames: list[int] = []
    times: list[int] = []
    forecasts: list[np.ndarray] = []
    length = horizon_frames + 1
    next_forecast = n_observed if horizon_frames > 0 and protocol != "offline" else T
    hidden = observed_part(interaction, n_observed)  # = protocol_view(interaction, visible, n_observed) cut at visible
    views = GrowingInteraction(hidden)
    for visible, start, stop in schedule(protocol, T, n_observed, delta_t):
        views.append_from(hidden, visible)
        view = views.view()
        if start >= next_forecast:
            ahead = _check(_fork(reactor, method).react(view, start, start + length), name, interaction, start,
                           start + length, J)
            block = np.full((length, 5, 3), np.nan)
            keep = min(length, T - start)
            block[:keep] = ahead.key_joints[:keep]
            times.append(start)
            forecasts.append(block)
            next_forecast += horizon_every * (1 + (start - next_forecast) // horizon_every)
        tic = time.perf_counter()
        block_pred = reactor.react(view, start, stop)
        seconds.append(time.perf_counter() - tic)
        frames.append(stop - start)
        block_pred = _check(block_pred, name, interaction, start, stop, J)
        joints[start:stop] = block_pred.joints
        keys[start:stop] = block_pred.key_joints
        if subs is not None and block_pred.subevents is not None:
            subs[start:stop] = block_pred.subevents
        else:
            subs = None
    prediction = prediction_from_joints(
        hidden, joints, n_observed=n_observed, key_joints=keys, subevents=subs
    )
    return ProtocolRun(
        prediction=prediction,
        call_seconds=np.asarray(seconds, dtype=np.float64),
        call_frames=np.asarray(frames, dtype=np.int64),
        forecast_times=np.asarray(times, dtype=np.int64),
        forecasts=np.stack(forecasts) if forecasts else np.zeros((0, 0, 5, 3)),
    )


def _check(block: object, name: str, interaction: Interaction, start: int, stop: int, J: int) -> Prediction:
    if not isinstance(block, Prediction) or block.n_frames != stop - start or block.joints.shape[1] != J:
        raise ModelError(
            f"method {name!r}: asked for frames [{start}, {stop}) of {interaction.instance_id or 'an instance'}, "
            f"expected a Prediction of {stop - start} frames × {J} joints, found "
            f"{block.joints.shape if isinstance(block, Prediction) else type(block).__name__}"
        )
    return block


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
    return run_protocol_measured(method, interaction, protocol=protocol, n_observed=n_observed, rng=rng,
                                 delta_t=delta_t).prediction
