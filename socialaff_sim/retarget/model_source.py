"""The affordance model's online synthesis as the robot's key-joint source.

:class:`ModelSource` is a :class:`~socialaff_sim.retarget.sources.KeyJointSource`: it runs the online
synthesizer (:class:`~socialaff_sim.inference.synthesis.OnlineSynthesizer`, Algorithm 2) frame by frame,
so the simulator can drive the robot with the model's reaction. It lives here, at the bottom of the
robot side (retarget → sim → environment), above the learning and inference layers it uses.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..data.interaction import Interaction
from ..errors import SimulationError
from ..inference.synthesis import OnlineSynthesizer, SynthesisConfig
from ..learning.estimator import SocialAffordanceModel
from .intent import ContactIntent
from .sources import KeyJointSource, SourceFrame

__all__ = ["ModelSource", "key_joint_source", "model_source"]


class ModelSource:
    """The online synthesizer as the simulator's :class:`~socialaff_sim.retarget.sources.KeyJointSource`.

    Frames must be requested in order (``targets(0)``, ``targets(1)``, …), as a simulator does;
    agent 1's first T0 frames are the recording, the rest is synthesized causally.
    """

    def __init__(self, model: SocialAffordanceModel, *, seed: int = 0, config: SynthesisConfig | None = None) -> None:
        self.model = model
        self.seed = seed
        self.config = config or SynthesisConfig.reactive()
        self._syn: OnlineSynthesizer | None = None
        self._cache: list = []
        self._intent: ContactIntent | None = None  # read from the model when first used

    def reset(self, interaction: Interaction) -> None:
        """Start on an instance."""
        self._syn = OnlineSynthesizer(self.model, None, self.config)
        self._syn.reset(interaction, rng=np.random.default_rng(self.seed))
        self._cache = []

    def targets(self, t: int) -> SourceFrame:
        """Agent 1's key joints at frame ``t`` (data frame) and the current sub-event's name."""
        if self._syn is None:
            raise SimulationError("ModelSource.targets called before reset(interaction)")
        while len(self._cache) <= t:
            if self._syn.done:
                raise SimulationError(f"frame {t} is outside the instance (0 ≤ t < {len(self._cache)})")
            self._cache.append(self._syn.step())
        step = self._cache[t]
        return SourceFrame(step.key_joints.copy(), step.subevent_name, *self.intent.at(step.subevent))

    @property
    def intent(self) -> ContactIntent:
        """The model's intent to touch per sub-event type (:class:`~socialaff_sim.retarget.intent.ContactIntent`)."""
        if self._intent is None:
            self._intent = ContactIntent.of(self.model)
        return self._intent

    @property
    def contact_types(self) -> np.ndarray:
        """(S,) bool: the model's sub-event types that make a hand contact (:attr:`ContactIntent.touch`)."""
        return self.intent.touch

    @property
    def contact_inside_types(self) -> np.ndarray:
        """(S,) bool: the types whose contact is a keyframe inside the interval (released before its end)."""
        return self.intent.inside

    @property
    def contact_inside_next_types(self) -> np.ndarray:
        """(S,) bool: the types with such a contact or whose most likely successor (``transitions_``) has one."""
        return self.intent.inside_next

    @property
    def placement_frames(self) -> int:
        """Frames of agent 1's recording the source sees (T0): the simulator places the robot from these only."""
        return self.config.n_observed

    @property
    def belief(self) -> np.ndarray:
        """(S,) the latest sub-event belief."""
        if not self._cache:
            S = self.model.n_subevents_
            return np.full(S, 1.0 / S)
        return self._cache[-1].belief


def key_joint_source(
    model_path: str | Path, *, seed: int = 0, config: SynthesisConfig | None = None, offline: bool = False
) -> ModelSource:
    """A :class:`ModelSource` for the model saved at ``model_path``; ``offline`` (without ``config``) reads
    the human's whole recorded track (:meth:`SynthesisConfig.offline`), else the synthesis is causal
    (:meth:`SynthesisConfig.reactive`)."""
    if config is None and offline:
        config = SynthesisConfig.offline()
    return ModelSource(SocialAffordanceModel.load(model_path), seed=seed, config=config)


def model_source(model_path: str | Path | None, *, offline: bool = False) -> KeyJointSource:
    """The affordance model's online synthesis as a :class:`KeyJointSource`
    (:func:`key_joint_source`).

    ``offline``: the synthesis reads the replayed human's whole recorded track
    (``SynthesisConfig.offline()``, as ``evaluate --protocol offline`` does) instead of reacting causally.
    A clear :class:`SimulationError` says so when no model file is given or it does not exist.
    """
    if model_path is None:
        raise SimulationError("--source model needs --model MODEL.npz (a fitted affordance model); "
                              "use --source gt to replay the recorded agent 1 instead")
    path = Path(model_path)
    if not path.exists():
        raise SimulationError(f"{path}: no such model file (fit one with: socialaff-sim fit)")
    return key_joint_source(path, offline=offline)
