"""The social affordance model as an estimator: settings in the constructor, ``fit`` runs Algorithm 1.

:class:`SocialAffordanceModel` is the public model class. It is an
:class:`~socialaff_sim.model.affordance.AffordanceParameters` (the learned parameters and the
scoring hooks, one layer down) plus what needs the learner: :meth:`~SocialAffordanceModel.fit`
(Algorithm 1, :func:`~socialaff_sim.learning.algorithm.learn`), the atomic-interval cut of a new
instance with the learned K-means centroids, best parses, and the model file
(:mod:`~socialaff_sim.learning.model_io`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..data.interaction import Interaction
from ..errors import ModelError, choices
from ..model.affordance import AffordanceParameters
from ..model.config import AffordanceConfig, default_n_subevents
from ..model.handedness import fit_hand_coupling, hand_flags, relabel
from ..model.frame import CanonicalFrame
from ..model.joints import JOINT_NAMES, available_joints, canonical_joints
from ..model.type_stats import name_subevents
from .algorithm import FitProgress, learn
from .atomic import cut_atoms
from .config import LearningConfig
from .model_io import read_model, save_model

__all__ = ["SocialAffordanceModel", "load_model"]


class SocialAffordanceModel(AffordanceParameters):
    """Sub-events, joint groupings and potentials of one interaction, learned from examples.

    Parameters
    ----------
    config:
        Model settings (|S|, β, γ, floors, ablation switches); ``AffordanceConfig.paper()`` for the paper's model.
    learning:
        Algorithm 1 settings (:class:`~socialaff_sim.learning.config.LearningConfig`); ``LearningConfig.paper()`` for the paper's Algorithm 1.

    The learned attributes (trailing underscore) are listed in
    :class:`~socialaff_sim.model.affordance.AffordanceParameters`; reading one before :meth:`fit`
    or :meth:`load` raises :class:`~socialaff_sim.errors.NotFittedError`.
    """

    def __init__(self, config: AffordanceConfig | None = None, learning: LearningConfig | None = None) -> None:
        super().__init__(config)
        self.learning = learning if learning is not None else LearningConfig()
        if not isinstance(self.learning, LearningConfig):
            raise ModelError(f"learning: expected a LearningConfig, found {type(self.learning).__name__}")

    # -- fitting -----------------------------------------------------------------------------
    def fit(
        self,
        interactions: Sequence[Interaction],
        *,
        rng: np.random.Generator,
        progress: bool = False,
        callback: Callable[[FitProgress], None] | None = None,
    ) -> SocialAffordanceModel:
        """Learn the model from instances of one interaction with Algorithm 1; returns ``self``.

        ``progress`` shows a bar on stderr; ``callback`` receives a
        :class:`~socialaff_sim.learning.algorithm.FitProgress` after the initial parse and after
        every outer iteration, which the ``socialaff_sim.learning.algorithm`` logger also reports
        at INFO level (``logging.basicConfig(level=logging.INFO)`` shows it).
        """
        inters = list(interactions)
        if not inters:
            raise ModelError("fit: expected at least one interaction instance, found none")
        labels = sorted({i.label for i in inters})
        if len(labels) != 1:
            raise ModelError(f"fit: one model learns one interaction; found the labels {choices(labels)}")
        label = labels[0]
        n_sub = self.config.n_subevents or default_n_subevents(label)
        if not self.config.use_subevents:
            n_sub = 1
        raw = [canonical_joints(i) for i in inters]
        flags = np.array([hand_flags(x) for x in raw]).reshape(-1, 2)
        tracks = [relabel(x, f) if self.config.active_hand else x for x, f in zip(raw, flags, strict=True)]
        self.hand_coupling_ = fit_hand_coupling(flags)
        available = available_joints(tracks)
        fps = [i.fps for i in inters]
        res = learn(tracks, fps, available, n_sub, self.config, self.learning, rng=rng, progress=progress, desc=label,
                    callback=callback)

        spans = [sp.frame_spans(p) for sp, p in zip(res.spaces, res.parses, strict=True)]
        self._set_learned(
            label=label,
            available=available,
            grouping=res.grouping,
            spans=spans,
            tracks=tracks,
            fps=fps,
            centroids=res.atoms.centroids,
        )
        self.parses_ = [np.asarray(s, dtype=np.int64).reshape(-1, 3) for s in spans]
        self.instance_ids_ = [i.instance_id for i in inters]
        self.trace_ = res.trace
        self.acceptance_ = res.acceptance
        self.acceptance_rate_ = float(res.acceptance.mean()) if res.acceptance.size else 0.0
        self.log_posterior_ = res.log_posterior
        self.moves_ = dict(res.moves)
        self.history_ = dict(res.history)
        self.fit_seconds_ = dict(res.seconds)
        self.subevent_names_ = name_subevents(inters, spans, n_sub)
        return self

    # -- parsing and scoring --------------------------------------------------------------------
    def canonical_track(
        self, interaction: Interaction, frame: CanonicalFrame | None = None, hands: np.ndarray | None = None
    ) -> np.ndarray:
        """(T, 11, 3) float64, metres: the model joints in the (given or own) canonical frame.

        With ``config.active_hand`` each agent's key joints are relabelled by its flag in ``hands``
        (2,) bool (``None``: the instance's own :func:`~socialaff_sim.model.handedness.hand_flags`,
        which read both agents' whole tracks). Synthesis reads the recorded labels instead
        (:class:`~socialaff_sim.inference.observed.ObservedInteraction`) and relabels them with :meth:`reaction_hands`).
        """
        x = canonical_joints(interaction, frame)
        if not self.config.active_hand:
            return x
        return relabel(x, hand_flags(x) if hands is None else np.asarray(hands, bool))

    def atom_bounds(self, interaction: Interaction, track: np.ndarray | None = None) -> np.ndarray:
        """(A + 1,) int64: atomic-interval bounds of an instance from the learned K-means centroids."""
        self._check()
        x = self.canonical_track(interaction) if track is None else track
        if not np.isfinite(x[:, self.available_]).all():
            missing = [JOINT_NAMES[j] for j in np.flatnonzero(self.available_ & ~np.isfinite(x).all(axis=(0, 2)))]
            raise ModelError(f"instance {interaction.instance_id!r} lacks joints the model uses: {missing}")
        lc = self.learning
        return cut_atoms(
            x, interaction.fps, self.available_, self.centroids_,
            min_frames=lc.min_atomic_frames, max_seconds=lc.max_atomic_seconds, tau=lc.velocity_seconds,
        )

    def best_parse(self, interaction: Interaction) -> tuple[float, np.ndarray]:
        """Best parse over the instance's atomic intervals: (log probability, (K, 3) int64 rows start, stop, label)."""
        x = self.canonical_track(interaction)
        return self.parse_over(x, interaction.fps, self.atom_bounds(interaction, x), self.interval_log_score)

    def score(self, interactions: Sequence[Interaction]) -> float:
        """Mean per-frame log probability of the instances' best parses (Σ log p / Σ frames)."""
        self._check()
        inters = list(interactions)
        if not inters:
            raise ModelError("score: expected at least one interaction instance, found none")
        total = sum(self.best_parse(i)[0] for i in inters)
        return float(total / sum(i.n_frames for i in inters))

    # -- persistence ------------------------------------------------------------------------------
    def save(self, path: str | Path) -> Path:
        """Write the fitted model to ``path`` (npz + JSON metadata, atomically); returns the path."""
        self._check()
        return save_model(self, path)

    @classmethod
    def load(cls, path: str | Path) -> SocialAffordanceModel:
        """Read a model written by :meth:`save`; a bad file raises :class:`~socialaff_sim.errors.ModelFileError`."""
        config, learning, learned = read_model(path)
        model = cls(config, learning)
        model.__dict__.update(learned)
        return model

    def with_config(self, **changes: object) -> SocialAffordanceModel:
        """An unfitted model with some settings changed."""
        return SocialAffordanceModel(replace(self.config, **changes), self.learning)


def load_model(path: str | Path) -> SocialAffordanceModel:
    """Read a model file written by :func:`~socialaff_sim.learning.model_io.save_model` (see that module for the checks)."""
    return SocialAffordanceModel.load(path)
