"""What an observation shows of the person and the object over one episode.

The replayed person's key joints are known for the whole recording, so their
track is put into the robot's frame once per episode; the object is simulated, so
its last ``history`` positions are kept as the frames go by.
:class:`~socialaff_sim.environment.observation.ObservationLayout` reads both
(``human_keys``, ``human_mask``, ``object``).
"""

from __future__ import annotations

import numpy as np

from ..data.interaction import Interaction
from ..data.skeletons import N_KEY
from ..sim.simulator import Simulator

__all__ = ["EpisodeTracks"]


class EpisodeTracks:
    """The person's key-joint track and the object's recent positions (robot frame, m); :meth:`reset` per
    episode, :meth:`push_object` per data frame."""

    def __init__(self, history: int) -> None:
        self.history = history
        """H: how many of the object's positions are kept."""
        self.human = np.zeros((0, N_KEY, 3))
        """(T, N_KEY, 3) the person's key joints, robot frame, m (zeros where the layout has no such joint)."""
        self.mask = np.zeros(N_KEY, dtype=np.float32)
        """(N_KEY,) float32: 1 for a key joint the person's skeleton layout has, else 0."""
        self.object = np.zeros((history, 3))
        """(H, 3) the object's last positions, oldest first, robot frame, m (zeros without an object)."""

    def reset(self, sim: Simulator, inter: Interaction) -> None:
        """A new episode of ``inter`` in ``sim`` (reset and settled): the person's whole track, and the object's
        history filled with where it is now."""
        idx = inter.layout.key_indices
        self.mask = np.array([i is not None for i in idx], dtype=np.float32)
        track = np.zeros((inter.n_frames, N_KEY, 3))
        for k, i in enumerate(idx):
            if i is not None:
                track[:, k] = sim.frame_R.to_robot(sim.pose.joints[:, i])
        self.human = track
        obj = sim.object_position()
        self.object = np.zeros((self.history, 3)) if obj is None else np.tile(obj, (self.history, 1))

    def push_object(self, position: np.ndarray) -> None:
        """Append the object's position (3,) (robot frame, m) of a frame just simulated, dropping the oldest."""
        self.object = np.vstack([self.object[1:], position[None]])
