"""Where the robot's key-joint targets come from: a recording, or the affordance model's synthesis.

A :class:`KeyJointSource` yields, frame by frame, the five key joints of agent 1
(the agent the robot plays) in the interaction's own data frame, plus the name
of the current sub-event when it knows one. The simulator scales them onto the
robot (:class:`~socialaff_sim.retarget.scaling.KeyJointScaler`).

A source reacting to the person is causal: ``targets(t)`` uses the observed
human (agent 0) and object up to frame ``t`` only (the model's synthesis is, unless
asked to read the whole recording offline). The ground-truth
source reads agent 1's recorded track and is the reference every model is
compared with. The model's synthesis as a source is in :mod:`~socialaff_sim.retarget.model_source`.
"""

from __future__ import annotations

from typing import NamedTuple, Protocol, runtime_checkable

import numpy as np

from ..data.interaction import Interaction
from ..errors import SimulationError

__all__ = ["SourceFrame", "KeyJointSource", "GroundTruthSource"]


class SourceFrame(NamedTuple):
    """One frame of targets."""

    keys: np.ndarray
    """(5, 3) float64, metres, data frame: agent 1's base, left/right wrist, left/right ankle (NaN where unknown)."""
    subevent: str | None
    """The current sub-event's name, or ``None``."""
    contact: bool = False
    """Whether the source's model makes a hand contact in the current sub-event (its intent to touch, read by
    the simulator's contact completion; ``False`` for a source without a model, such as the recording)."""
    contact_inside: bool = False
    """Whether the current sub-event's contact falls inside it and is released before its end (a contact
    keyframe: a high five's strike), a touch the model's interpolated end configurations do not reach."""
    contact_inside_next: bool = False
    """Whether the current sub-event or its most likely successor has such a contact (the robot may move in
    toward it: a high five's raise and strike; ``False`` for a source without a model)."""


@runtime_checkable
class KeyJointSource(Protocol):
    """Anything that proposes agent 1's key joints frame by frame.

    A causal source may also have an ``placement_frames: int`` attribute, the number of agent 1's
    recorded frames it sees; the simulator then places the robot from those frames only
    (:meth:`~socialaff_sim.sim.simulator.Simulator.reset`).
    """

    def reset(self, interaction: Interaction) -> None:
        """Start on a new instance (agent 0, the object and the frame rate are known from it)."""

    def targets(self, t: int) -> SourceFrame:
        """Agent 1's key joints at frame ``t`` (0 ≤ t < T) and the current sub-event."""


class GroundTruthSource:
    """Agent 1's recorded key joints and the recorded sub-events."""

    def __init__(self) -> None:
        self._keys: np.ndarray | None = None
        self._sub: list[str | None] = []

    def reset(self, interaction: Interaction) -> None:
        self._keys = interaction.key_joints()[:, 1]
        names = interaction.subevent_names
        sub = interaction.subevents
        self._sub = [None] * interaction.n_frames if sub is None else [names[i] if i >= 0 else None for i in sub]

    def targets(self, t: int) -> SourceFrame:
        if self._keys is None:
            raise SimulationError("GroundTruthSource.targets called before reset(interaction)")
        if not 0 <= t < len(self._keys):
            raise SimulationError(f"frame {t} is outside the instance (0 ≤ t < {len(self._keys)})")
        return SourceFrame(self._keys[t].copy(), self._sub[t])
