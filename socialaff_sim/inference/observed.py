"""The observed interaction, canonicalised once: the value online synthesis reads.

Synthesis needs the instance in the model's canonical frame (:mod:`socialaff_sim.model.frame`,
fixed by the bases at the first frame), with the joints as recorded (the active-hand relabelling is
the model's, done by the synthesizer from :meth:`~socialaff_sim.model.affordance.AffordanceParameters.reaction_hands`),
and agent 1 hidden after the T0 frames it may observe. :meth:`ObservedInteraction.of` computes that once
per instance; the synthesizer and the simulator's model source read it instead of going back to the
interaction and the model for frames.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..data.interaction import Interaction
from ..errors import ModelError
from ..model.frame import CanonicalFrame, canonical_frame
from ..model.joints import N_JOINTS, canonical_joints
from .candidates import AGENT1

__all__ = ["ObservedInteraction"]


@dataclass(frozen=True, eq=False)
class ObservedInteraction:
    """What synthesis may read of an instance, in the canonical frame. Arrays are read-only."""

    frame: CanonicalFrame
    """World ↔ canonical frame of the instance (fixed by its first frame)."""
    track: np.ndarray
    """(T, 11, 3) float64, metres, canonical frame: the model joints as recorded (agent 0's five key
    joints, agent 1's, the object), agent 1 NaN from frame ``n_observed`` on; NaN where absent."""
    fps: float
    """Frames per second."""
    n_observed: int
    """T0: the frames of agent 1 that synthesis sees."""
    instance_id: str
    """The instance's id (for messages)."""
    label: str
    """The interaction class."""

    @classmethod
    def of(cls, interaction: Interaction, n_observed: int) -> ObservedInteraction:
        """Canonicalise ``interaction`` once; agent 1 is hidden from frame ``n_observed`` (T0) on."""
        if not 1 <= n_observed < interaction.n_frames:
            raise ModelError(
                f"instance {interaction.instance_id!r}: synthesis needs more than T0 = {n_observed} frames, "
                f"found {interaction.n_frames}"
            )
        keys = interaction.key_joints()  # filled once: instance_frame's frame and the track read the same
        frame = canonical_frame(keys[0, 0, 0], keys[0, 1, 0])
        track = canonical_joints(interaction, frame, keys=keys)
        track[n_observed:, AGENT1] = np.nan  # never read agent 1 beyond the observation
        track.setflags(write=False)
        return cls(frame, track, float(interaction.fps), int(n_observed), interaction.instance_id, interaction.label)

    @property
    def n_frames(self) -> int:
        """T, the instance's length."""
        return int(self.track.shape[0])

    def __post_init__(self) -> None:
        if self.track.ndim != 3 or self.track.shape[1:] != (N_JOINTS, 3):
            raise ModelError(f"ObservedInteraction.track: expected shape (T, {N_JOINTS}, 3), found {self.track.shape}")
