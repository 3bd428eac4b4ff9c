"""The learned parameters of the social affordance model of one interaction (Shu, Ryoo & Zhu, IJCAI 2016).

:class:`AffordanceParameters` holds what Algorithm 1 learned (attributes with a trailing underscore)
and the scoring hooks that parsing and synthesis use. It does not learn: the estimator
:class:`socialaff_sim.learning.SocialAffordanceModel` (a subclass, one layer up) adds ``fit``,
the atomic-interval cut of new instances, parsing and persistence. Everything geometric is in the
canonical interaction frame of :mod:`socialaff_sim.model.frame`.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..errors import ModelError, NotFittedError
from .config import AffordanceConfig
from .densities import lognorm_logpdf
from .estimate import estimate_parameters
from .features import IntervalFeatures, interval_features
from .handedness import left_active, partner_flag
from .joints import JOINT_NAMES
from .path import path_loglik
from .potentials import TypePotentials, log_motion, log_spatial
from .segment_dp import best_segmentation

__all__ = ["AffordanceParameters"]


class AffordanceParameters:
    """Sub-events, joint groupings and potentials of one interaction, as learned from examples.

    Parameters
    ----------
    config:
        Model settings (|S|, β, γ, floors, ablation switches); ``AffordanceConfig.paper()`` for the paper's model.

    Attributes (set by :meth:`socialaff_sim.learning.SocialAffordanceModel.fit` or ``load``;
    S = |S|, 11 model joints)
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
        (proposed, accepted) per dynamics (proposals with no admissible choice count as rejected).
    history_ : dict[str, ndarray]
        Per outer iteration: ``"log_posterior"`` (I + 1,), ``"temperature"`` (I,), and per dynamics m
        ``"proposed_<m>"`` / ``"accepted_<m>"`` (I,) int64 (:func:`~socialaff_sim.learning.history.new_history`).
        Set by ``fit`` only; a loaded model has ``trace_``, ``acceptance_`` and ``moves_`` but no history.
    fit_seconds_ : dict[str, float]
        Wall-clock seconds of the stages of ``fit``.
    """

    def __init__(self, config: AffordanceConfig | None = None) -> None:
        self.config = config if config is not None else AffordanceConfig()

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
                f"{type(self).__name__} is not fitted yet ({name} is learned): call fit(interactions, rng=...) or load(path) first"
            )
        raise AttributeError(name)

    def _check(self) -> None:
        if "grouping_" not in self.__dict__:
            raise NotFittedError(
                f"{type(self).__name__} is not fitted yet: call fit(interactions, rng=...) or load(path) first"
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
    def reaction_hands(self, track: np.ndarray, stop: int | None = None, margin: float = 0.0) -> np.ndarray:
        """(2,) bool: the relabelling flags (:func:`~socialaff_sim.model.handedness.relabel`) when agent 1 is
        to be synthesized: agent 0's own flag from its frames ``[0, stop)`` of ``track`` (T, 11, 3, as
        recorded; left only by more than ``margin`` metres of wrist path), agent 1's the likeliest partner
        flag (``hand_coupling_``). All False without ``config.active_hand``."""
        self._check()
        if not self.config.active_hand:
            return np.zeros(2, bool)
        f0 = left_active(track, 0, stop, margin)
        return np.array([f0, partner_flag(self.hand_coupling_, f0)])

    def reaction_hands_at(self, paths: np.ndarray, stop: int, margin: float = 0.0) -> np.ndarray:
        """:meth:`reaction_hands` from agent 0's cumulative wrist paths ``paths`` (T, 2)
        (:func:`~socialaff_sim.model.handedness.wrist_paths`) over frames ``[0, stop)``: O(1) per call."""
        self._check()
        if not self.config.active_hand:
            return np.zeros(2, bool)
        k = min(max(int(stop), 1), paths.shape[0]) - 1
        f0 = bool(paths[k, 0] - paths[k, 1] > margin)
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
            pot, self._z(s), np.asarray(end, float), cfg.eps, other_side=cfg.other_side_reference, include_self=cfg.reference_self,
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

    # -- parsing ---------------------------------------------------------------------------------
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

    def __repr__(self) -> str:
        name = type(self).__name__
        if "grouping_" not in self.__dict__:
            return f"{name}(unfitted)"
        return f"{name}({self.label_!r}, |S|={self.n_subevents_}, {len(self.parses_)} training instances)"


def _nan_to_neginf(x: np.ndarray) -> np.ndarray:
    return np.where(np.isnan(x), -np.inf, x)
