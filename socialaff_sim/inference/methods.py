"""The full model and its ablations as evaluation methods.

``"full"`` is the social affordance model with Algorithm 2; ``"v1"`` drops joint selection and
grouping, ``"v2"`` drops latent sub-events (the paper's two ablations). All implement
:class:`~socialaff_sim.inference.protocol.ReactionMethod` and its streaming ``start``: under the
``causal`` and ``paper`` evaluation protocols the online synthesizer is fed the growing view
(:meth:`~socialaff_sim.inference.synthesis.OnlineSynthesizer.observe`) and runs with
:attr:`AffordanceMethod.synthesis` (default :meth:`SynthesisConfig.reactive`); under ``offline`` it
gets agent 0's whole track and runs with :attr:`AffordanceMethod.offline_synthesis` (default
:meth:`SynthesisConfig.offline`, lookahead). The registered methods learn one MCMC chain each, like
every other method (one fit per fold); ``chains`` > 1 averages several chains' syntheses (a 3-chain
ensemble lowered the offline error in the history of docs/analysis.md, sessions 10–11, at three times the
cost — not like for like against one-fit baselines, so it is not the default). ``"full_online"`` is the
full model with ``SynthesisConfig()`` under every protocol, as the simulator runs it.
:mod:`socialaff_sim.evaluation.registry` registers them by name; a factory's ``preset`` (``"default"``
or ``"paper"``) selects the model, learning and synthesis configurations (:func:`preset_configs`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from ..data.interaction import Interaction
from ..errors import ConfigError, NotFittedError, choices
from ..learning.config import LearningConfig
from ..learning.estimator import SocialAffordanceModel
from ..model.config import AffordanceConfig
from ..model.joints import instance_frame
from .blend_kernel import Blend
from .body_fit import BodyFitConfig, BodyFitter
from .interaction_primitive import InteractionPrimitive
from .primitive_stream import PrimitiveStream, stream_key_joints
from .presets import PRESETS
from .presets import preset as named_preset
from .protocol import Prediction
from .reaction_features import FeatureStream
from .reaction_regression import inner_folds
from .switching import SwitchingConfig, SwitchingRegression
from .switching_rows import Trace, plan_displacement, plan_offset, switching_rows
from .synthesis import OnlineSynthesizer, SynthesisConfig
from .synthesis_step import SynthesisStep


__all__ = [
    "AffordanceMethod", "PRESETS", "REGISTERED_CHAINS", "VARIANTS", "fit_skeleton", "preset_configs", "primitive_trace",
    "synthesize", "trace",
]

VARIANTS: dict[str, dict[str, bool]] = {
    "full": {},
    "v1": {"use_grouping": False},
    "v2": {"use_subevents": False},
}
"""Model-config changes of each variant."""

REGISTERED_CHAINS = 1
"""K, the MCMC chains the registered ``"full"``, ``"v1"`` and ``"v2"`` methods learn: one, as every other
method fits once per fold. One chain's parse depends on its seed (on the SBU handshakes the fit's seed
alone moved the offline error from 0.127 to 0.136 m); ``AffordanceMethod(chains=3)`` is the ensemble that
lowered the offline errors (the history of docs/analysis.md, sessions 10 and 11; docs/design.md) at three
times the fit cost.
"""

def preset_configs(name: str) -> tuple[AffordanceConfig, LearningConfig, SynthesisConfig]:
    """(model, learning, causal synthesis) configurations of preset ``name``
    (:func:`~socialaff_sim.inference.presets.preset`), except that the ``"default"`` preset synthesizes
    causally with :meth:`SynthesisConfig.reactive` (what the simulator and the environment run)."""
    chosen = named_preset(name)  # the error lists the presets
    synthesis = SynthesisConfig.reactive() if name == "default" else chosen.synthesis
    return chosen.affordance, chosen.learning, synthesis


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


def trace(
    model: SocialAffordanceModel, body: BodyFitter, interaction: Interaction, config: SynthesisConfig, rng: np.random.Generator,
    *, stride: int = 1,
) -> Trace:
    """The synthesizer's belief, phase and plan (key joints, and the skeleton ``body`` fits to them) at every frame
    of ``interaction``, run causally with ``config`` (what the switching regression learns from; :mod:`.switching`).
    An instance no longer than T0 frames has nothing to synthesize: its trace is all NaN (the regression skips it).
    ``stride`` k > 1: the skeleton only at frames T0, T0 + k, … (NaN at the others; ``SwitchingConfig.row_stride``);
    the synthesizer still steps every frame."""
    T = interaction.n_frames
    if T <= config.n_observed:
        return Trace(belief=np.full((T, model.n_subevents_), np.nan), phase=np.full(T, np.nan),
                     plan=np.full((T, 5, 3), np.nan), skeleton=np.full((T, interaction.joints.shape[2], 3), np.nan))
    syn = OnlineSynthesizer(model, None, config)
    syn.reset(interaction, rng=rng)
    steps = [syn.step() for _ in range(interaction.n_frames)]
    plan = np.stack([st.key_joints for st in steps])
    skeleton = np.full((interaction.n_frames, interaction.joints.shape[2], 3), np.nan)
    skeleton[config.n_observed::stride] = body.fit_poses(plan[config.n_observed::stride], instance_frame(interaction))
    return Trace(belief=np.stack([st.belief for st in steps]), phase=np.array([st.phase for st in steps]), plan=plan,
                 skeleton=skeleton)


def primitive_trace(
    primitive: InteractionPrimitive, body: BodyFitter, trace_: Trace, interaction: Interaction, n_observed: int,
    *, stride: int = 1,
) -> Trace:
    """``trace_`` with the interaction primitive's causal key joints of every frame ≥ T0 = ``n_observed``
    (:meth:`~.interaction_primitive.InteractionPrimitive.causal_key_joints`, or with ``ProMPConfig.training_stream``
    :func:`~.primitive_stream.stream_key_joints`) and the skeletons ``body`` fits to them. ``stride`` k > 1: the
    skeletons (and the stream's key joints) only at frames T0, T0 + k, … (``SwitchingConfig.row_stride``)."""
    T = interaction.n_frames
    keys = np.full((T, 5, 3), np.nan)
    skeleton = np.full((T, interaction.joints.shape[2], 3), np.nan)
    if T > n_observed:
        keys = (stream_key_joints(primitive, interaction, n_observed, stride=stride) if primitive.config.training_stream
                else primitive.causal_key_joints(interaction, n_observed))
        skeleton[n_observed::stride] = body.fit_poses(keys[n_observed::stride], instance_frame(interaction))
    return dataclasses.replace(trace_, primitive=keys, primitive_skeleton=skeleton)


def fit_skeleton(
    body: BodyFitter, model: SocialAffordanceModel, interaction: Interaction, keys: np.ndarray, n_observed: int
) -> np.ndarray:
    """(T, J, 3) metres world: agent 1's recorded skeleton for the first ``n_observed`` frames, then
    full-body poses fitted to the key joints ``keys`` (T, 5, 3) metres world."""
    skel = interaction.filled_joints()[:, 1].copy()
    skel[n_observed:] = body.fit_poses(keys[n_observed:], instance_frame(interaction))
    return skel


def chains_mean(blocks: Sequence[Sequence[SynthesisStep]]) -> np.ndarray:
    """(F, 5, 3) the mean over the chains (K lists of F steps each) of their key joints, ``np.mean``'s values bitwise:
    with one chain (the registered methods; every frame of a stream) its key joints as ``np.mean`` makes them, 0 + x
    (its sum starts from 0, so −0 becomes +0) divided by 1, without its set-up."""
    if len(blocks) == 1:
        return np.array([st.key_joints for st in blocks[0]]) + 0.0
    return np.mean([[st.key_joints for st in steps] for steps in blocks], axis=0)


def _chain_generators(rng: np.random.Generator, k: int) -> list[np.random.Generator]:
    """One generator per chain: the caller's own for one chain (so K = 1 is the plain method), else K spawned."""
    return [rng] if k == 1 else rng.spawn(k)


class AffordanceMethod:
    """The social affordance model (or an ablation) as a :class:`ReactionMethod`.

    With ``chains`` K > 1 the model is learnt K times by independent MCMC chains (generators spawned
    from the caller's) and the prediction is the mean of the K syntheses' key joints: an estimate of
    the posterior-predictive mean over parses instead of one chain's parse. The full skeleton is fitted
    to that mean; the sub-events reported are the first chain's.

    ``synthesis`` is used when agent 0 is seen causally (default :meth:`SynthesisConfig.reactive`),
    ``offline_synthesis`` when agent 0's whole track is given (default :meth:`SynthesisConfig.offline`).
    """

    def __init__(
        self,
        variant: str = "full",
        *,
        model_config: AffordanceConfig | None = None,
        learning: object | None = None,
        synthesis: SynthesisConfig | None = None,
        offline_synthesis: SynthesisConfig | None = None,
        body: BodyFitConfig | None = None,
        name: str | None = None,
        chains: int = 1,
        reaction: SwitchingConfig | None = None,
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
        self.synthesis = synthesis or SynthesisConfig.reactive()
        self.offline_synthesis = offline_synthesis or SynthesisConfig.offline()
        self.body = body or BodyFitConfig()
        self.reaction = reaction

    @classmethod
    def from_preset(cls, variant: str = "full", preset: str = "default", **kwargs: object) -> AffordanceMethod:
        """The method with the configurations of ``preset`` (:func:`preset_configs`). The paper has no
        offline synthesis, so under the paper preset the offline protocol runs the paper's too."""
        model, learning, synthesis = preset_configs(preset)
        offline = SynthesisConfig.offline() if preset == "default" else synthesis
        reaction = SwitchingConfig() if preset == "default" else None
        return cls(variant, model_config=model, learning=learning, synthesis=synthesis, offline_synthesis=offline,
                   **{"reaction": reaction, **kwargs})  # type: ignore[arg-type]

    def fit(self, interactions: Sequence[Interaction], *, rng: np.random.Generator) -> AffordanceMethod:
        """Learn the model (Algorithm 1) and the body clusters of agent 1."""
        inters = list(interactions)
        self.models_ = [
            SocialAffordanceModel(self.model_config, self.learning).fit(inters, rng=r)
            for r in _chain_generators(rng, self.chains)
        ]
        self.model_ = self.models_[0]
        self.body_ = BodyFitter(self.body).fit_interactions(inters, agent=1, rng=rng)
        if self.reaction is not None:
            if self.reaction.needs_primitive:
                self.primitive_ = InteractionPrimitive(self.reaction.primitive).fit(inters)
            traces = self._training_traces(inters, self.reaction, rng)
            self.reaction_ = SwitchingRegression(self.reaction).fit(
                inters, traces, n_subevents=self.model_.n_subevents_, rng=rng)
        return self

    def _training_traces(self, inters: list[Interaction], reaction: SwitchingConfig, rng: np.random.Generator) -> list[Trace]:
        """The switching regression's training traces: plans (and the interaction primitive's predictions, when a
        family reads them) from models fitted on the other parts of a ``reaction.cross_fit``-part split (out of
        sample), beliefs and phases from ``model_`` (module :mod:`.switching`)."""
        cfg = dataclasses.replace(self.synthesis, n_observed=reaction.n_observed)
        k = reaction.row_stride  # the rows read only frames T0, T0 + k, …: nothing else is fitted to a plan
        parts = (inner_folds(inters, np.arange(len(inters)), reaction.cross_fit, rng, contiguous=reaction.contiguous)
                 if reaction.cross_fit > 1 else [])
        crossed = len(parts) >= 2 and all(len(inters) - len(p) >= 2 for p in parts)
        if not crossed or reaction.needs_belief:
            own = [trace(self.model_, self.body_, inst, cfg, rng, stride=k) for inst in inters]
            if not crossed:
                if reaction.needs_primitive:  # in sample, as the plans
                    own = [primitive_trace(self.primitive_, self.body_, tr, inst, cfg.n_observed, stride=k)
                           for tr, inst in zip(own, inters, strict=True)]
                return own
        out: dict[int, Trace] = {}
        learning = self.learning
        if reaction.cross_fit_type_passes is not None:  # cheaper cross-fitted models (issue 24)
            learning = dataclasses.replace(learning or LearningConfig(), init_type_passes=reaction.cross_fit_type_passes)
        for part in parts:
            rest = [inst for i, inst in enumerate(inters) if i not in set(part)]
            model = SocialAffordanceModel(self.model_config, learning).fit(rest, rng=rng)
            primitive = InteractionPrimitive(reaction.primitive).fit(rest) if reaction.needs_primitive else None
            for i in part:
                out[i] = trace(model, self.body_, inters[i], cfg, rng, stride=k)
                if primitive is not None:  # out of sample: fitted without instance i, as the plan
                    out[i] = primitive_trace(primitive, self.body_, out[i], inters[i], cfg.n_observed, stride=k)
        if reaction.needs_belief:  # the plans out of sample, the beliefs in the labels of model_
            return [dataclasses.replace(own[i], plan=out[i].plan, skeleton=out[i].skeleton, primitive=out[i].primitive,
                                        primitive_skeleton=out[i].primitive_skeleton) for i in range(len(inters))]
        return [out[i] for i in range(len(inters))]

    def _check(self) -> None:
        if not hasattr(self, "model_"):
            raise NotFittedError(f"method {self.name!r}: call fit(interactions, rng=...) before predict")

    def predict(self, interaction: Interaction, *, n_observed: int, rng: np.random.Generator) -> Prediction:
        """Synthesize agent 1 after ``n_observed`` frames, reading agent 0's whole track (offline)."""
        self._check()
        cfg = dataclasses.replace(self.offline_synthesis, n_observed=n_observed)
        rngs = _chain_generators(rng, len(self.models_))
        runs = [synthesize(m, interaction, rng=r, config=cfg) for m, r in zip(self.models_, rngs, strict=True)]
        keys = np.mean([r[0] for r in runs], axis=0)  # exactly the one synthesis when K = 1
        skel = fit_skeleton(self.body_, self.model_, interaction, keys, cfg.n_observed)
        return Prediction(joints=skel, key_joints=keys, subevents=runs[0][2], n_observed=n_observed)

    def start(self, *, n_observed: int, offline: bool, rng: np.random.Generator) -> _AffordanceReactor:
        """A reactor for one test instance (see the module docstring)."""
        self._check()
        cfg = dataclasses.replace(self.offline_synthesis if offline else self.synthesis, n_observed=n_observed)
        return _AffordanceReactor(self, cfg, rng, offline)


class _AffordanceReactor:
    """One online synthesizer per chain, fed the protocol's views as they grow."""

    def __init__(self, method: AffordanceMethod, config: SynthesisConfig, rng: np.random.Generator, offline: bool) -> None:
        self.method = method
        self.offline = offline
        self.config = config
        self.rngs = _chain_generators(rng, len(method.models_))
        self.synths: list[OnlineSynthesizer] = []
        # The switching regression, under the causal protocols (its rows are those of a causal synthesis).
        reaction = getattr(method, "reaction_", None)
        self.reaction = None if offline else reaction
        self.stream = None if self.reaction is None else FeatureStream(config.n_observed, self.reaction.config.features,
                                                                           config.kernel)
        # Which skeletons the blend reads as priors: a body fit nobody reads is skipped (it runs every frame).
        priors = {m.prior for m in self.reaction.members_} if self.reaction is not None else set()
        self._plan_prior = self.reaction is None or "from_plan" in priors
        self._primitive_prior = "from_primitive" in priors
        # The interaction primitive's causal prediction, from running sums (bounded work per frame). Its compiled
        # factor update only where no body fit reads it: the two-bone IK near a straight limb magnifies the update's
        # 1e-15 m differences past the 1e-9 m declared for kernel "numba" (docs/design.md §7).
        kernel = "numpy" if self._primitive_prior else config.kernel
        self.primitive = (PrimitiveStream(method.primitive_, config.n_observed, kernel)
                          if self.reaction is not None and self.reaction.uses_primitive else None)
        if self.primitive is not None:  # its fixed conditioning parts, once per fitted primitive (not per recording)
            self.primitive.warm()
        self._anchor_keys: np.ndarray | None = None  # agent 1's key joints at the anchor (world), once per instance
        # The groups the blend reads: the rows' other columns are not computed (zeros; no member reads them).
        self._groups = self.reaction.groups_ if self.reaction is not None else ()
        # kernel "numba": the blend of one row in one compiled call (:mod:`.blend_kernel`).
        self._blend = Blend(self.reaction) if self.reaction is not None and config.kernel == "numba" else None

    def react(self, view: Interaction, start: int, stop: int) -> Prediction:
        """Agent 1's frames [start, stop): step every chain's synthesizer up to ``stop``.

        Streaming, the synthesizer gets the view lengthened by ΔT held frames past ``stop``, so that it
        plans ΔT frames ahead as it does on a whole track (the held frames carry no information), and reads
        only the frames new since the last call; offline, the view is the whole instance."""
        n_frames = stop if self.offline else stop + self.config.delta_t
        if not self.synths:
            self.synths = [OnlineSynthesizer(m, None, self.config) for m in self.method.models_]
            for syn, r in zip(self.synths, self.rngs, strict=True):
                syn.reset(view, rng=r, n_frames=n_frames)
            # The instance's frame is read by the body fits of the priors only (a gap filling of the view: skipped
            # when no member reads a prior; the synthesizer's reset builds the same frame and raises as it would).
            self._frame = instance_frame(view) if self._plan_prior or self._primitive_prior else None
        else:
            for syn in self.synths:
                syn.observe(view, n_frames)
        blocks = []
        for syn in self.synths:
            steps = []
            while syn.t < stop:
                step = syn.step()
                if step.t >= start:
                    steps.append(step)
            blocks.append(steps)
        keys = chains_mean(blocks)
        subs = np.array([st.subevent for st in blocks[0]], dtype=np.int64)
        joints = self.method.body_.fit_poses(keys, self._frame) if self._plan_prior else None
        if self.reaction is None or self.stream is None:
            return Prediction(joints=joints, key_joints=keys, subevents=subs, n_observed=0)
        # The switching regression: the first chain's belief and phase, the chains' mean plan.
        motion = self.stream.rows(view, start, stop, self._groups)
        anchor = self.stream.anchor
        if self._anchor_keys is None:
            self._anchor_keys = view.layout.key_joints(anchor.pose[None])[0]
        prim, prim_offset = None, None
        if self.primitive is not None:  # the interaction primitive conditioned on the same view
            prim_keys = self.primitive.react_keys(view, start, stop)
            prim = plan_displacement(anchor, prim_keys, view, keys=self._anchor_keys)
            if self._primitive_prior:
                prim_offset = plan_offset(anchor, self.method.body_.fit_poses(prim_keys, self._frame))
        rows = switching_rows(motion, np.stack([st.belief for st in blocks[0]]), np.array([st.phase for st in blocks[0]]),
                              plan_displacement(anchor, keys, view, keys=self._anchor_keys), prim, self._groups)
        offset = plan_offset(anchor, joints) if joints is not None else None
        if self._blend is not None and len(rows) == 1:  # the compiled blend (one row: the reactor's usual call)
            joints = anchor.to_world(self._blend.displacement(rows, offset, prim_offset))
        else:
            joints = anchor.to_world(self.reaction.displacement(rows, offset, prim_offset))
        return Prediction(joints=joints, key_joints=view.layout.key_joints(joints), subevents=subs, n_observed=0)
