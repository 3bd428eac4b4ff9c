"""The affordance model behind the environment's adapter protocol.

:class:`ModelScorer` turns a fitted :class:`~socialaff_sim.learning.SocialAffordanceModel`
into the environment's affordance reward: the robot's agent-1-equivalent key
joints, with agent 0's observed key joints and the object, form one configuration
of the model's 11 joints in the instance's canonical frame, scored by the current
sub-event's spatial log-potential (``model.log_spatial``). Its upper bound is the
sum over the sub-event's affordable joints of each factor's maximum (Weibull modes
of the horizontal and vertical distances, floored at ε, and the von Mises mean), so
that the reward can be normalised per joint.

:class:`ModelAdapter` adds the online synthesizer (Algorithm 2, run one observed
frame at a time) for the proposal and the sub-event belief.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..data.interaction import Interaction
from ..data.skeletons import N_KEY
from ..errors import ConfigError, ModelError, SimulationError, choices
from ..inference.synthesis import OnlineSynthesizer, SynthesisConfig
from ..learning.estimator import SocialAffordanceModel
from ..model.densities import vonmises_logpdf, weibull_logpdf
from ..model.handedness import KEY_SWAP, relabel
from ..model.joints import OBJECT, canonical_joints, instance_frame
from ..retarget.intent import ContactIntent
from .adapters import AdapterFrame, AffordanceScore, RobotPose

__all__ = ["ModelSpec", "load_models", "weibull_max_logpdf", "spatial_upper_bound", "ModelScorer", "ModelAdapter"]

ModelSpec = str | Path | SocialAffordanceModel | Mapping[str, str | Path | SocialAffordanceModel]
"""A model file, a fitted model, or one of either per interaction label."""


def _load_one(label: str | None, spec: str | Path | SocialAffordanceModel) -> SocialAffordanceModel:
    model = spec if isinstance(spec, SocialAffordanceModel) else SocialAffordanceModel.load(spec)
    if not hasattr(model, "label_"):
        raise ModelError(f"model for {label or 'the environment'}: expected a fitted SocialAffordanceModel, found an unfitted one")
    if label is not None and model.label_ != label:
        raise ModelError(f"model given for interaction {label!r} was fitted on {model.label_!r}")
    return model


def load_models(spec: ModelSpec, labels: Sequence[str]) -> dict[str, SocialAffordanceModel]:
    """One fitted model per interaction label of ``labels`` (a mapping must cover them all)."""
    if isinstance(spec, Mapping):
        missing = [lbl for lbl in labels if lbl not in spec]
        if missing:
            raise ConfigError(f"model: no model for the interactions {choices(missing)}; the mapping has {choices(spec)}")
        return {lbl: _load_one(lbl, spec[lbl]) for lbl in labels}
    model = _load_one(None, spec)
    if set(labels) != {model.label_}:
        raise ConfigError(
            f"model: one model of {model.label_!r} was given but the environment plays {choices(labels)}; "
            "pass a mapping {label: model file} or choose interactions=" + repr(model.label_)
        )
    return {model.label_: model}


def weibull_max_logpdf(k: np.ndarray, lam: np.ndarray, eps: float) -> np.ndarray:
    """max over x ≥ ε of log f(x; k, λ) of the Weibull (mode λ((k−1)/k)^{1/k} for k > 1, else x = ε)."""
    k = np.asarray(k, float)
    lam = np.asarray(lam, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        mode = np.where(k > 1.0, lam * ((k - 1.0) / k) ** (1.0 / k), 0.0)
    return weibull_logpdf(np.maximum(mode, eps), k, lam)


def spatial_upper_bound(model: SocialAffordanceModel, s: int) -> tuple[float, int]:
    """(Σ of the factors' maxima, number of affordable joints) of sub-event ``s``'s spatial potential."""
    z = model.grouping_[s].copy()
    z[~model.available_] = -1
    aff = np.flatnonzero(z > 0)
    if aff.size == 0:
        return 0.0, 0
    kh, lh, kv, lv, mu, kap = model.spatial_params_[s][aff].T
    eps = model.config.eps
    total = weibull_max_logpdf(kh, lh, eps) + weibull_max_logpdf(kv, lv, eps) + vonmises_logpdf(mu, mu, kap)
    return float(np.sum(total)), int(aff.size)


class ModelScorer:
    """The affordance reward term of fitted models (one per interaction label)."""

    def __init__(self, models: Mapping[str, SocialAffordanceModel]) -> None:
        if not models:
            raise ConfigError("ModelScorer: expected at least one fitted model")
        self.models = dict(models)
        self._bounds = {lbl: [spatial_upper_bound(m, s) for s in range(m.n_subevents_)] for lbl, m in self.models.items()}
        self.model: SocialAffordanceModel | None = None

    def subevent_names(self, label: str) -> tuple[str, ...]:
        return tuple(self._model_of(label).subevent_names_)

    def _model_of(self, label: str) -> SocialAffordanceModel:
        if label not in self.models:
            raise ConfigError(f"no affordance model for interaction {label!r}; models are given for {choices(self.models)}")
        return self.models[label]

    def reset(self, interaction: Interaction) -> None:
        self.model = m = self._model_of(interaction.label)
        self.label = interaction.label
        self.frame = instance_frame(interaction)
        raw = canonical_joints(interaction, self.frame)  # as recorded
        # Agent 1's labels follow the model's partner rule (as in synthesis), not the recording's own flag.
        self.hands = m.reaction_hands(raw)
        self.track = relabel(raw, self.hands)  # (T, 11, 3): agent 0 is the observed human

    def configuration(self, keys: np.ndarray, t: int, obj: np.ndarray | None) -> np.ndarray:
        """(11, 3) canonical model joints: agent 0 and the object at frame ``t``, agent 1 = ``keys`` (data frame)."""
        if self.model is None:
            raise SimulationError("ModelScorer: call reset(interaction) first")
        x = self.track[t].copy()
        keys_c = self.frame.to_canonical(np.asarray(keys, float))
        x[N_KEY : 2 * N_KEY] = keys_c[KEY_SWAP] if self.hands[1] else keys_c
        if obj is not None:
            x[OBJECT] = self.frame.to_canonical(np.asarray(obj, float))
        return x

    def log_likelihood(self, subevent: int, keys: np.ndarray, t: int, obj: np.ndarray | None) -> AffordanceScore:
        x = self.configuration(keys, t, obj)
        if subevent < 0:
            return AffordanceScore(0.0, 0.0, 0)
        model = self.model
        assert model is not None
        bound, n = self._bounds[self.label][subevent]
        ll = float(model.log_spatial(subevent, x[None])[0])
        return AffordanceScore(ll, bound, n)


class ModelAdapter:
    """A fitted model's online synthesis (proposal, belief) and spatial potentials (reward).

    The synthesizer (:class:`~socialaff_sim.inference.synthesis.OnlineSynthesizer`, Algorithm 2,
    without the full-body fit; by default ``SynthesisConfig.reactive()``, causal) copies agent 1's first T0 frames from the recording and then plans
    every ΔT frames from agent 0 and the object observed so far; its belief is uniform and its
    sub-event unknown (−1) over those T0 frames. Instances must be longer than T0. Each frame carries the
    model's intent to touch in its current sub-event (:class:`~socialaff_sim.retarget.intent.ContactIntent`), read
    as ``socialaff-sim simulate``'s :class:`~socialaff_sim.retarget.model_source.ModelSource` reads it.
    """

    def __init__(self, models: Mapping[str, SocialAffordanceModel], config: SynthesisConfig | None = None) -> None:
        config = config or SynthesisConfig.reactive()
        self.scorer = ModelScorer(models)
        self._synth = {lbl: OnlineSynthesizer(m, None, config) for lbl, m in self.scorer.models.items()}
        self._intents = {lbl: ContactIntent.of(m) for lbl, m in self.scorer.models.items()}
        self._current: Any = None
        self._intent: ContactIntent | None = None
        self._steps: list[Any] = []

    @property
    def kind(self) -> str:
        return "model"

    @property
    def placement_frames(self) -> int:
        """Frames of agent 1's recording the synthesis sees (T0): the simulator places the robot from these only."""
        return next(iter(self._synth.values())).config.n_observed

    def subevent_names(self, label: str, instances: Sequence[Interaction]) -> tuple[str, ...]:
        return self.scorer.subevent_names(label)

    def reset(self, interaction: Interaction, *, rng: np.random.Generator | None = None) -> None:
        """Start on an instance; ``rng`` drives the synthesizer's sampling (required)."""
        if rng is None:
            raise ModelError("ModelAdapter.reset: the synthesizer samples; pass rng=numpy.random.Generator")
        self.scorer.reset(interaction)
        self._current = self._synth[interaction.label]
        self._current.reset(interaction, rng=rng)
        self._intent = self._intents[interaction.label]
        self._steps = []

    def observe(self, t: int) -> AdapterFrame:
        if self._current is None:
            raise SimulationError("ModelAdapter: call reset(interaction, rng=...) first")
        while len(self._steps) <= t:
            self._steps.append(self._current.step())
        st = self._steps[t]
        assert self._intent is not None
        s = int(st.subevent)
        return AdapterFrame(np.array(st.key_joints, dtype=np.float64), np.array(st.belief, dtype=np.float64),
                            s, st.subevent_name, self._intent.at(s))

    def log_likelihood(self, subevent: int, pose: RobotPose) -> AffordanceScore:
        if subevent < 0:
            return AffordanceScore(0.0, 0.0, 0)
        return self.scorer.log_likelihood(subevent, pose.agent_keys(), pose.t, pose.obj)
