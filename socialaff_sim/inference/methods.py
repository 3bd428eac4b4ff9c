"""The full model and its ablations as evaluation methods.

``"full"`` is the social affordance model with Algorithm 2; ``"v1"`` drops joint selection and
grouping, ``"v2"`` drops latent sub-events (the paper's two ablations). The protocol gives every
method agent 0's whole recorded track, so these three synthesize with
:meth:`~socialaff_sim.inference.synthesis.SynthesisConfig.offline`; ``"full_online"`` is the full
model with the default causal Algorithm 2 (``SynthesisConfig()``), as the simulator runs it. All four implement
:class:`~socialaff_sim.inference.protocol.ReactionMethod`; :mod:`socialaff_sim.evaluation.registry` registers
them by name. The registered ``"full"``, ``"v1"`` and ``"v2"`` average :data:`REGISTERED_CHAINS` MCMC chains;
``"full_online"`` learns one model, as the simulator does.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from ..data.interaction import Interaction
from ..errors import ConfigError, NotFittedError, choices
from ..learning.estimator import SocialAffordanceModel
from ..model.config import AffordanceConfig
from ..model.joints import instance_frame
from .body_fit import BodyFitConfig, BodyFitter
from .protocol import Prediction
from .synthesis import OnlineSynthesizer, SynthesisConfig

__all__ = ["AffordanceMethod", "REGISTERED_CHAINS", "VARIANTS", "fit_skeleton", "synthesize"]

VARIANTS: dict[str, dict[str, bool]] = {
    "full": {},
    "v1": {"use_grouping": False},
    "v2": {"use_subevents": False},
}
"""Model-config changes of each variant."""

REGISTERED_CHAINS = 3
"""K, the independent MCMC chains the registered ``"full"``, ``"v1"`` and ``"v2"`` methods average.

One chain's parse depends on its seed: on the SBU handshakes the fit's seed alone moves the full model's
error from 0.127 to 0.136 m. Three chains cost three fits; they lowered the full model's error on all three
datasets of the accuracy benchmark (the history of docs/analysis.md, sessions 10 and 11; docs/design.md).
"""


def synthesize(
    model: SocialAffordanceModel,
    interaction: Interaction,
    *,
    rng: np.random.Generator,
    body: BodyFitter | None = None,
    config: SynthesisConfig | None = None,
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray, np.ndarray]:
    """Run the online synthesizer over a whole instance.

    Returns key joints (T, 5, 3) metres world, skeletons (T, J, 3) or ``None`` without a body
    fitter, sub-event per frame (T,) int64 (−1 while observed) and beliefs (T, S).
    """
    syn = OnlineSynthesizer(model, body, config)
    syn.reset(interaction, rng=rng)
    steps = [syn.step() for _ in range(interaction.n_frames)]
    keys = np.stack([s.key_joints for s in steps])
    subs = np.array([s.subevent for s in steps], dtype=np.int64)
    beliefs = np.stack([s.belief for s in steps])
    if body is None:
        return keys, None, subs, beliefs
    return keys, fit_skeleton(body, model, interaction, keys, syn.config.n_observed), subs, beliefs


def fit_skeleton(
    body: BodyFitter, model: SocialAffordanceModel, interaction: Interaction, keys: np.ndarray, n_observed: int
) -> np.ndarray:
    """(T, J, 3) metres world: agent 1's recorded skeleton for the first ``n_observed`` frames, then
    full-body poses fitted to the key joints ``keys`` (T, 5, 3) metres world."""
    skel = interaction.filled_joints()[:, 1].copy()
    skel[n_observed:] = body.fit_poses(keys[n_observed:], instance_frame(interaction))
    return skel


def _chain_generators(rng: np.random.Generator, k: int) -> list[np.random.Generator]:
    """One generator per chain: the caller's own for one chain (so K = 1 is the plain method), else K spawned."""
    return [rng] if k == 1 else rng.spawn(k)


class AffordanceMethod:
    """The social affordance model (or an ablation) as a :class:`ReactionMethod`.

    With ``chains`` K > 1 the model is learnt K times by independent MCMC chains (generators spawned
    from the caller's) and the prediction is the mean of the K syntheses' key joints: an estimate of
    the posterior-predictive mean over parses instead of one chain's parse. The full skeleton is fitted
    to that mean; the sub-events reported are the first chain's.
    """

    def __init__(
        self,
        variant: str = "full",
        *,
        model_config: AffordanceConfig | None = None,
        learning: object | None = None,
        synthesis: SynthesisConfig | None = None,
        body: BodyFitConfig | None = None,
        name: str | None = None,
        chains: int = 1,
    ) -> None:
        if variant not in VARIANTS:
            raise ConfigError(f"variant: expected {choices(VARIANTS)}, found {variant!r}")
        if isinstance(chains, bool) or not isinstance(chains, int) or chains < 1:
            raise ConfigError(f"chains: expected an integer >= 1, found {chains!r}")
        self.name = name or variant
        self.chains = chains
        self.variant = variant
        self.model_config = dataclasses.replace(model_config or AffordanceConfig(), **VARIANTS[variant])
        self.learning = learning
        self.synthesis = synthesis or SynthesisConfig.offline()
        self.body = body or BodyFitConfig()

    def fit(self, interactions: Sequence[Interaction], *, rng: np.random.Generator) -> AffordanceMethod:
        """Learn the model (Algorithm 1) and the body clusters of agent 1."""
        inters = list(interactions)
        self.models_ = [
            SocialAffordanceModel(self.model_config, self.learning).fit(inters, rng=r)
            for r in _chain_generators(rng, self.chains)
        ]
        self.model_ = self.models_[0]
        self.body_ = BodyFitter(self.body).fit_interactions(inters, agent=1, rng=rng)
        return self

    def predict(self, interaction: Interaction, *, n_observed: int, rng: np.random.Generator) -> Prediction:
        """Synthesize agent 1 after ``n_observed`` frames."""
        if not hasattr(self, "model_"):
            raise NotFittedError(f"method {self.name!r}: call fit(interactions, rng=...) before predict")
        cfg = dataclasses.replace(self.synthesis, n_observed=n_observed)
        rngs = _chain_generators(rng, len(self.models_))
        runs = [synthesize(m, interaction, rng=r, config=cfg) for m, r in zip(self.models_, rngs, strict=True)]
        keys = np.mean([r[0] for r in runs], axis=0)  # exactly the one synthesis when K = 1
        skel = fit_skeleton(self.body_, self.model_, interaction, keys, cfg.n_observed)
        return Prediction(joints=skel, key_joints=keys, subevents=runs[0][2], n_observed=n_observed)
