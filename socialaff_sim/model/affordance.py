"""The social affordance model of one interaction category (Shu, Ryoo & Zhu, IJCAI 2016).

A model object is configured in its constructor, learns with :meth:`SocialAffordanceModel.fit`
(Algorithm 1, :mod:`socialaff_sim.learning`) and then exposes its learned parameters (trailing
underscore) and the scoring hooks the synthesizer uses. Everything geometric is in the
canonical interaction frame of :mod:`socialaff_sim.model.frame`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..data.interaction import Interaction
from ..errors import ModelError, NotFittedError, choices
from .config import AffordanceConfig, default_n_subevents
from .densities import lognorm_logpdf
from .estimate import estimate_parameters
from .features import IntervalFeatures, interval_features
from .frame import CanonicalFrame
from .handedness import fit_hand_coupling, hand_flags, left_active, partner_flag, relabel
from .joints import JOINT_NAMES, available_joints, canonical_joints, instance_frame
from .path import path_loglik
from .potentials import TypePotentials, log_motion, log_spatial
from .segment_dp import best_segmentation
from .type_stats import name_subevents

if TYPE_CHECKING:
    from ..learning.algorithm import FitProgress
    from ..learning.config import LearningConfig

__all__ = ["SocialAffordanceModel"]


class SocialAffordanceModel:
    """Sub-events, joint groupings and potentials of one interaction, learned from examples.

    Parameters
    ----------
    config:
        Model settings (|S|, β, γ, floors, ablation switches); defaults are the paper's.
    learning:
        Algorithm 1 settings (:class:`~socialaff_sim.learning.config.LearningConfig`); defaults are the paper's.

    Attributes (after :meth:`fit` or :meth:`load`; S = |S|, 11 model joints)
    ----------------------------------------------------------------------
    label_ : str
        The interaction learned.
    n_subevents_ : int
        S.
    subevent_names_ : tuple[str, ...]
        Names of the learned types: the ground-truth sub-event each overlaps most in training
        (optimal one-to-one matching) when the data have them, else ``s0``, ``s1``, …
    available_ : (11,) bool
        Joints present in every training instance; the others are absent (grouping −1).
    grouping_ : (S, 11) int64
        Z^s: 0 Null, h ≥ 1 functional group (ids canonical per type); absent joints are 0 here
        and masked by ``available_``.
    spatial_params_, motion_params_ : (S, 11, 6) float64
        Rows (k_h, λ_h [m], k_v, λ_v [m], μ [rad], κ) of the Weibull/Weibull/von Mises factors
        (exponential = Weibull with k = 1 for Null motion); NaN where unused.
    duration_params_ : (S, 2) float64
        (μ, σ) of log duration in seconds; NaN for a type never used.
    transitions_ : (S, S) float64
        p(s_k | s_{k−1}), add-α smoothed, zero diagonal when consecutive labels must differ.
    start_probs_ : (S,) float64
        p(s_1).
    mean_end_ : (S, 11, 3) float64, metres
        Mean canonical configuration at the end of each type (display, template).
    vertical_up_ : (S, 2, 11) float64
        Frequency of dz > 0 of each joint's spatial offset (row 0) and displacement (row 1) per type,
        add-one smoothed: the potentials score |dz|, and synthesis needs to know up from down.
    path_sigma_ : (S, 11) float64, metres
        Path-noise σ per type and joint (NaN where unused or without ``config.path_noise``).
    end_regression_ : list of RidgeRegression or None
        Per type, agent 1's end configuration regressed on its context
        (:mod:`~socialaff_sim.model.end_regression`; ``None`` for a type with fewer than 3 intervals).
    frame_regression_ : list of RidgeRegression or None
        Per type, agent 1's configuration at each frame regressed on agent 0's at that frame
        (:mod:`~socialaff_sim.model.frame_regression`; ``None`` for a type seen in fewer than 3 instances).
    hand_coupling_ : (2, 2) float64
        p(agent 1 left-active | agent 0's flag), rows agent 0 right/left, add-one smoothed over the
        training instances (:mod:`~socialaff_sim.model.handedness`; used with ``config.active_hand``).
    contact_keys_ : ContactKeys
        Per type, agent 1's wrists' touches inside the sub-event (:mod:`~socialaff_sim.model.contact_keys`).
    centroids_ : (K, D) float64
        K-means centroids of the atomic intervals (new instances are cut with them).
    parses_ : list of (K_i, 3) int64
        Training parses, rows (start frame, stop frame exclusive, label).
    instance_ids_ : list[str]
        Ids of the training instances.
    trace_ : (I + 1,) float64
        log P* of the chain after each outer iteration (entry 0: initial state).
    acceptance_ : (I,) float64
        Fraction of proposals accepted per iteration; ``acceptance_rate_`` its mean.
    log_posterior_ : float
        log P* of the returned (best visited) state.
    moves_ : dict[str, tuple[int, int]]
        (proposed, accepted) per dynamics.
    fit_seconds_ : dict[str, float]
        Wall-clock seconds of the stages of :meth:`fit`.
    """

    def __init__(self, config: AffordanceConfig | None = None, learning: LearningConfig | None = None) -> None:
        from ..learning.config import LearningConfig  # noqa: PLC0415 (model does not depend on learning at import)

        self.config = config if config is not None else AffordanceConfig()
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
        from ..learning.algorithm import learn  # noqa: PLC0415

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
        self.fit_seconds_ = dict(res.seconds)
        self.subevent_names_ = name_subevents(inters, spans, n_sub)
        return self

    def _set_learned(self, *, label, available, grouping, spans, tracks, fps, centroids) -> None:  # noqa: ANN001
        for name, value in estimate_parameters(grouping, spans, tracks, fps, available, self.config).items():
            setattr(self, name, value)
        self.label_ = label
        self.n_subevents_ = grouping.shape[0]
        self.available_ = np.asarray(available, bool)
        self.grouping_ = np.asarray(grouping, np.int64)
        self.centroids_ = np.asarray(centroids, float)

    # -- learned views -------------------------------------------------------------------------
    def __getattr__(self, name: str) -> object:
        # Only called when normal lookup fails: a learned attribute read before fit.
        if name.endswith("_") and not name.startswith("__"):
            raise NotFittedError(
                f"SocialAffordanceModel is not fitted yet ({name} is learned): call fit(interactions, rng=...) or load(path) first"
            )
        raise AttributeError(name)

    def _check(self) -> None:
        if "grouping_" not in self.__dict__:
            raise NotFittedError(
                "SocialAffordanceModel is not fitted yet: call fit(interactions, rng=...) or load(path) first"
            )

    def _check_s(self, s: int) -> int:
        self._check()
        if not 0 <= int(s) < self.n_subevents_:
            raise ModelError(f"sub-event index: expected 0 .. {self.n_subevents_ - 1}, found {s}")
        return int(s)

    @property
    def joint_names_(self) -> tuple[str, ...]:
        """Names of the 11 model joints (agent0.*, agent1.*, object)."""
        self._check()
        return JOINT_NAMES

    @property
    def log_transitions_(self) -> np.ndarray:
        """(S, S) float64: log p(s_k = column | s_{k−1} = row); −inf where forbidden."""
        self._check()
        with np.errstate(divide="ignore"):
            return np.log(self.transitions_)

    @property
    def log_start_probs_(self) -> np.ndarray:
        """(S,) float64: log p(s_1)."""
        self._check()
        return np.log(self.start_probs_)

    @property
    def mean_durations_(self) -> np.ndarray:
        """(S,) float64, seconds: mean of each type's log-normal duration, exp(μ + σ²/2)."""
        self._check()
        mu, sig = self.duration_params_.T
        return np.exp(mu + 0.5 * sig**2)

    def potentials(self, s: int) -> TypePotentials:
        """The fitted potentials of sub-event type ``s``."""
        s = self._check_s(s)
        return TypePotentials(self.spatial_params_[s], self.motion_params_[s], float("nan"))

    # -- hooks for inference / synthesis -------------------------------------------------------
    @staticmethod
    def frame_of(interaction: Interaction) -> CanonicalFrame:
        """The canonical frame of an instance (world ↔ canonical), fixed by its first frame."""
        return instance_frame(interaction)

    def canonical_track(
        self, interaction: Interaction, frame: CanonicalFrame | None = None, hands: np.ndarray | None = None
    ) -> np.ndarray:
        """(T, 11, 3) float64, metres: the model joints in the (given or own) canonical frame.

        With ``config.active_hand`` each agent's key joints are relabelled by its flag in ``hands``
        (2,) bool (``None``: the instance's own :func:`~socialaff_sim.model.handedness.hand_flags`,
        which read both agents' whole tracks; synthesis passes :meth:`reaction_hands` instead).
        """
        x = canonical_joints(interaction, frame)
        if not self.config.active_hand:
            return x
        return relabel(x, hand_flags(x) if hands is None else np.asarray(hands, bool))

    def reaction_hands(self, track: np.ndarray, stop: int | None = None, margin: float = 0.0) -> np.ndarray:
        """(2,) bool: the relabelling flags when agent 1 is to be synthesized: agent 0's own flag from its
        frames ``[0, stop)`` of ``track`` (T, 11, 3, as recorded; left only by more than ``margin`` metres
        of wrist path), agent 1's the likeliest partner flag (``hand_coupling_``). All False without
        ``config.active_hand``."""
        self._check()
        if not self.config.active_hand:
            return np.zeros(2, bool)
        f0 = left_active(track, 0, stop, margin)
        return np.array([f0, partner_flag(self.hand_coupling_, f0)])

    def interval_features(self, track: np.ndarray, starts: np.ndarray, stops: np.ndarray, fps: float) -> IntervalFeatures:
        """Features of candidate intervals ``[starts, stops)`` of a canonical track (vectorized; with
        the path residuals when ``config.path_noise``)."""
        return interval_features(track, starts, stops, fps, self.config.feature_path_profile)

    def log_spatial(self, s: int, end: np.ndarray) -> np.ndarray:
        """Spatial log-potential of N key-joint configurations ``end`` (N, 11, 3) at a type-``s`` end → (N,)."""
        s = self._check_s(s)
        cfg = self.config
        pot = self.potentials(s)
        return _nan_to_neginf(log_spatial(
            pot, self._z(s), np.asarray(end, float), cfg.eps, other_side=cfg.other_side_reference,
            cartesian=cfg.vector_density == "cartesian",
        ))

    def log_motion(self, s: int, disp: np.ndarray) -> np.ndarray:
        """Motion log-potential of N displacement sets ``disp`` (N, 11, 3) over a type-``s`` interval → (N,)."""
        s = self._check_s(s)
        return _nan_to_neginf(log_motion(
            self.potentials(s), self._z(s), np.asarray(disp, float), self.config.eps,
            cartesian=self.config.vector_density == "cartesian",
        ))

    def log_duration(self, s: int, seconds: np.ndarray | float) -> np.ndarray:
        """Log-normal log-density of durations (seconds) of type ``s`` (of log seconds when
        ``config.duration_density == "log_seconds"``); −inf for a type never seen in training."""
        s = self._check_s(s)
        mu, sig = self.duration_params_[s]
        x = np.asarray(seconds, float)
        out = lognorm_logpdf(x, mu, sig)
        if self.config.duration_density == "log_seconds":
            with np.errstate(divide="ignore"):
                out = out + np.log(x)  # density of log seconds: x f(x)
        return _nan_to_neginf(out)

    def log_path(self, s: int, features: IntervalFeatures) -> np.ndarray:
        """(M,) path-noise log-likelihood of M intervals' interior frames under type ``s``
        (0 without ``config.path_noise`` or when the features carry no path residuals)."""
        s = self._check_s(s)
        if not self.config.path_noise or features.path_sq is None or features.path_n is None:
            return np.zeros(len(features))
        return path_loglik(features.path_sq, features.path_n, self.path_sigma_[s]).sum(axis=1)

    def interval_log_score(self, features: IntervalFeatures, s: int) -> np.ndarray:
        """(M,) log spatial + log motion + log duration (+ log path) of M candidate intervals labelled ``s``."""
        spatial = self.log_spatial(s, features.end)
        score = spatial + self.log_motion(s, features.disp) + self.log_duration(s, features.seconds)
        return score + self.log_path(s, features)

    def observed_log_score(self, features: IntervalFeatures, s: int, joints: np.ndarray) -> np.ndarray:
        """(M,) log motion (+ log path) of the ``joints`` (11,) bool only, plus log duration, of M
        candidate intervals labelled ``s``: the terms an observed subset of the joints can be scored by
        alone (spatial potentials need every member of a group)."""
        s = self._check_s(s)
        z = self._z(s)
        z[~np.asarray(joints, bool)] = -1
        cfg = self.config
        score = _nan_to_neginf(log_motion(
            self.potentials(s), z, np.asarray(features.disp, float), cfg.eps,
            cartesian=cfg.vector_density == "cartesian",
        )) + self.log_duration(s, features.seconds)
        if cfg.path_noise and features.path_sq is not None and features.path_n is not None:
            sigma = np.where(joints, self.path_sigma_[s], np.nan)
            score = score + path_loglik(features.path_sq, features.path_n, sigma).sum(axis=1)
        return score

    def _z(self, s: int) -> np.ndarray:
        z = self.grouping_[s].copy()
        z[~self.available_] = -1
        return z

    # -- parsing and scoring --------------------------------------------------------------------
    def atom_bounds(self, interaction: Interaction, track: np.ndarray | None = None) -> np.ndarray:
        """(A + 1,) int64: atomic-interval bounds of an instance from the learned K-means centroids."""
        from ..learning.atomic import cut_atoms  # noqa: PLC0415

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

    def parse_over(
        self, track: np.ndarray, fps: float, bounds: np.ndarray, score: Callable[[IntervalFeatures, int], np.ndarray]
    ) -> tuple[float, np.ndarray]:
        """Best parse of a canonical ``track`` (T, 11, 3) over the cut points ``bounds`` (B + 1,), every
        interval scored by ``score(features, s)`` → (M,): (log probability, (K, 3) int64 rows start, stop,
        label); (−inf, no rows) when no parse is allowed."""
        B = bounds.shape[0] - 1
        a, b = np.triu_indices(B + 1, k=1)
        feats = self.interval_features(track, bounds[a], bounds[b], fps)
        seg = np.full((B + 1, B + 1, self.n_subevents_), -np.inf)
        short = (bounds[b] - bounds[a]) < self.config.min_subevent_seconds * fps
        for s in range(self.n_subevents_):
            seg[a, b, s] = np.where(short, -np.inf, score(feats, s))
        cfg = self.config
        total, spans = best_segmentation(
            seg, self.log_start_probs_, self.log_transitions_,
            distinct=cfg.distinct_neighbours and self.n_subevents_ > 1, unique=cfg.unique_labels,
        )
        rows = np.array([(bounds[p], bounds[q], s) for p, q, s in spans], dtype=np.int64).reshape(-1, 3)
        return total, rows

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
        from .model_io import save_model  # noqa: PLC0415

        self._check()
        return save_model(self, path)

    @classmethod
    def load(cls, path: str | Path) -> SocialAffordanceModel:
        """Read a model written by :meth:`save`; a bad file raises :class:`~socialaff_sim.errors.ModelFileError`."""
        from .model_io import load_model  # noqa: PLC0415

        return load_model(path)

    def with_config(self, **changes: object) -> SocialAffordanceModel:
        """An unfitted model with some settings changed."""
        return SocialAffordanceModel(replace(self.config, **changes), self.learning)

    def __repr__(self) -> str:
        if "grouping_" not in self.__dict__:
            return "SocialAffordanceModel(unfitted)"
        return f"SocialAffordanceModel({self.label_!r}, |S|={self.n_subevents_}, {len(self.parses_)} training instances)"


def _nan_to_neginf(x: np.ndarray) -> np.ndarray:
    return np.where(np.isnan(x), -np.inf, x)
