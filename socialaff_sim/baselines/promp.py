"""Interaction ProMP baseline (Maeda et al., "Probabilistic movement primitives for coordination of multiple human–robot collaborative tasks", Autonomous Robots 2017).

The primitive itself — the joint weight distribution of both agents' trajectories, its Gaussian conditioning
and the causal phase (duration) estimate — is :class:`~socialaff_sim.inference.interaction_primitive.InteractionPrimitive`
(shared with the full model's switching regression, whose ``primitive`` family reads it). This module makes it a
:class:`~socialaff_sim.inference.protocol.ReactionMethod`: a :class:`~socialaff_sim.inference.body_fit.BodyFitter`
trained on agent 1's skeletons turns the predicted key joints into a full skeleton.

Phase estimation: Maeda et al. estimate the phase speed from the observed prefix because the duration is
unknown online; so does this baseline under the ``causal`` and ``paper`` protocols (:meth:`InteractionProMP.start`,
:meth:`~socialaff_sim.inference.interaction_primitive.InteractionPrimitive.estimate_duration`). Under ``offline``
(and in :meth:`InteractionProMP.predict`) the whole track is given, so T is known and the phase is exactly t / (T − 1).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..data.interaction import Interaction
from ..errors import ModelError, NotFittedError
from ..inference.body_fit import BodyFitter, instance_frame
from ..inference.interaction_primitive import (
    InteractionPrimitive, ProMPConfig, condition_gaussian, condition_on_statistics, rbf_basis,
)
from ..inference.protocol import Prediction, prediction_from_joints

__all__ = ["InteractionProMP", "ProMPConfig", "rbf_basis", "condition_gaussian", "condition_on_statistics"]


class InteractionProMP(InteractionPrimitive):
    """Interaction ProMP as a :class:`~socialaff_sim.inference.protocol.ReactionMethod`.

    Learned attributes: those of :class:`~socialaff_sim.inference.interaction_primitive.InteractionPrimitive`
    (``keys_``, ``has_object_``, ``mean_``, ``cov_``, …) and ``body_``.
    """

    name = "promp"

    def fit(self, interactions: Sequence[Interaction], *, rng: np.random.Generator | None = None) -> InteractionProMP:
        """Learn the joint weight distribution and agent 1's body fit from one class's instances."""
        if rng is None:
            raise ModelError("ProMP: fit(...) needs rng= (the body fit's clustering draws from it)")
        super().fit(interactions, rng=rng)
        self.body_ = BodyFitter(self.config.body_fit).fit_interactions(interactions, agent=1, rng=rng)
        return self

    def start(self, *, n_observed: int, offline: bool, rng: np.random.Generator) -> _ProMPReactor:
        """A reactor for one instance: the known duration when ``offline``, else the phase estimate."""
        if not hasattr(self, "mean_"):
            raise NotFittedError("InteractionProMP: call fit(...) before start(...)")
        return _ProMPReactor(self, n_observed, offline)

    def predict(self, interaction: Interaction, *, n_observed: int, rng: np.random.Generator) -> Prediction:
        """Condition on the observation, then fit agent 1's full skeleton to the predicted key joints."""
        if hasattr(self, "layout_") and interaction.layout.name != self.layout_.name:
            raise ModelError(f"ProMP: trained on layout {self.layout_.name!r}, asked for {interaction.layout.name!r}")
        keys = self.predict_key_joints(interaction, n_observed=n_observed)
        frame = instance_frame(interaction)
        joints = frame.to_world(self.body_.fit_poses(keys))
        return prediction_from_joints(interaction, joints, n_observed=n_observed, key_joints=frame.to_world(keys))


class _ProMPReactor:
    """The Interaction ProMP on one instance, block by block: condition on the view, with the phase
    of the known (offline) or estimated duration."""

    def __init__(self, promp: InteractionProMP, n_observed: int, offline: bool) -> None:
        self.promp = promp
        self.n_observed = n_observed
        self.offline = offline

    def react(self, view: Interaction, start: int, stop: int) -> Prediction:
        """Agent 1's frames [start, stop)."""
        keys = self.promp.conditioned_keys(view, start, stop, n_observed=self.n_observed, offline=self.offline)
        frame = instance_frame(view)
        joints = frame.to_world(self.promp.body_.fit_poses(keys))
        return Prediction(joints=joints, key_joints=frame.to_world(keys), subevents=None, n_observed=0)
