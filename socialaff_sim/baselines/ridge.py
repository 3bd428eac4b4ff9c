"""``ridge``: a causal linear regression of agent 1's displacement on agent 0's motion, shrunk toward ``hold``.

For every output frame t ≥ T0 the prediction is agent 1's pose at its last observed frame a = T0 − 1 plus a
displacement of its whole skeleton that is linear in the causal features of
:mod:`~socialaff_sim.inference.reaction_features` (agent 0's motion since a, the gap between the agents,
agent 1's own observed velocity, agent 0's current velocity; all in the frame of the two agents at a).
Zero displacement is ``hold``, and there is no intercept, so the ridge penalty λ‖W‖² pulls the prediction
toward ``hold``; λ = ∞ *is* ``hold``.

Which feature groups and which λ: chosen by an inner cross-validation on the training instances only
(``inner_folds`` folds, pair-disjoint where the training set holds at least two actor pairs, else
instance-disjoint), scored with the evaluation's metric (mean key-joint distance per instance, averaged over
instances). ``hold`` is one of the candidates and wins ties: the regression is used only where it beat
``hold`` on held-out training instances. Rows are weighted 1 / (frames of their instance), as the metric
weighs instances, and the features are scaled to unit weighted RMS (no centring: zero features mean
``hold``). One configuration (:class:`RidgeConfig`) for every dataset; nothing is tuned on a test fold.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..data.interaction import Interaction
from ..errors import ConfigError, ModelError, NotFittedError
from ..inference.protocol import DEFAULT_N_OBSERVED, Prediction, prediction_from_reactor
from ..inference.reaction_regression import (
    HOLD, cv_errors, inner_folds, key_columns, ridge_solve, scale_of, select, stack_instances,
)
from ..inference.reaction_features import FEATURE_GROUPS, FeatureConfig, FeatureStream, group_columns, training_rows

__all__ = ["HOLD", "RidgeConfig", "RidgeReaction", "key_columns", "ridge_solve", "select", "training_set"]


def _all_subsets() -> tuple[tuple[str, ...], ...]:
    return tuple(c for r in range(1, len(FEATURE_GROUPS) + 1) for c in itertools.combinations(FEATURE_GROUPS, r))


@dataclass(frozen=True)
class RidgeConfig:
    """Settings of ``ridge`` (fixed before any evaluation; the inner CV chooses among the candidates)."""

    features: FeatureConfig = field(default_factory=FeatureConfig)
    """[—]: How the features are computed."""
    candidates: tuple[tuple[str, ...], ...] = field(default_factory=_all_subsets)
    """[—]: Feature-group sets the inner CV chooses among (``hold`` is always one more candidate)."""
    penalties: tuple[float, ...] = (1e-3, 1e-2, 0.1, 1.0, 10.0, 100.0)
    """λ [—]: Ridge penalties the inner CV chooses among (features scaled to unit RMS, rows weighted to one
    per instance, so λ = 1 weighs like one instance's worth of data)."""
    inner_folds: int = 3
    """[—]: Folds of the inner cross-validation on the training instances."""
    n_observed: int = DEFAULT_N_OBSERVED
    """T0 [frames]: observed frames of agent 1 when the training rows are built (the evaluation's T0)."""
    fallback: tuple[tuple[str, ...], float] = (FEATURE_GROUPS, 10.0)
    """[—]: (groups, λ) used when the training set has a single instance (no inner CV is possible)."""

    def __post_init__(self) -> None:
        if not self.penalties or not all(p > 0 and math.isfinite(p) for p in self.penalties):
            raise ConfigError(f"penalties: expected finite values > 0, found {self.penalties}")
        unknown = {g for c in self.candidates for g in c} - set(FEATURE_GROUPS)
        if unknown or not self.candidates:
            raise ConfigError(f"candidates: expected non-empty sets of {FEATURE_GROUPS}, found unknown {sorted(unknown)}")
        if self.inner_folds < 2:
            raise ConfigError(f"inner_folds: expected at least 2, found {self.inner_folds}")
        if self.n_observed < 1:
            raise ConfigError(f"n_observed: expected at least 1, found {self.n_observed}")


def training_set(
    interactions: Sequence[Interaction], n_observed: int, config: FeatureConfig
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Stacked rows of the usable training instances: X (N, F), Y (N, J·3), row weights (N,) summing to one per
    instance, and each row's instance index (N,) into ``interactions``."""
    (X, Y), w, ids = stack_instances(
        interactions, n_observed, lambda i, inst: training_rows(inst, n_observed, config)[:2], "ridge")
    return X, Y, w, ids


class RidgeReaction:
    """``ridge``: causal ridge regression of agent 1's displacement, shrunk toward ``hold`` (module docstring).

    Learned attributes: ``groups_`` (selected feature groups; ``()`` is ``hold``), ``penalty_`` (λ, ``inf``
    for ``hold``), ``cv_errors_`` ({(groups, λ): mean held-out key-joint error, m}, ``hold`` under
    ``((), inf)``), ``columns_`` (feature columns used), ``scale_`` (their RMS), ``weights_`` (F, J·3).
    """

    name = "ridge"

    def __init__(self, config: RidgeConfig | None = None) -> None:
        self.config = config or RidgeConfig()

    def fit(self, interactions: Sequence[Interaction], *, rng: np.random.Generator) -> RidgeReaction:
        """Choose groups and λ by inner CV on ``interactions`` (one class), then refit on all of them."""
        if not interactions:
            raise ModelError("ridge: expected at least one training interaction, found none")
        cfg = self.config
        X, Y, w, ids = training_set(interactions, cfg.n_observed, cfg.features)
        self.scale_ = scale_of(X, w)
        Xs = X / self.scale_
        kc = key_columns(interactions[0])
        folds = inner_folds(interactions, np.unique(ids), cfg.inner_folds, rng)
        cv: dict[tuple[tuple[str, ...], float], float] = {}
        if len(folds) >= 2:
            cv = cv_errors(Xs, Y[:, kc], w, ids, folds, {g: group_columns(g) for g in cfg.candidates}, cfg.penalties)
            best = select(cv)
        else:
            best = (tuple(cfg.fallback[0]), float(cfg.fallback[1]))
        self.cv_errors_ = cv
        self.groups_, self.penalty_ = best
        self.columns_ = group_columns(self.groups_)
        if self.groups_:
            wn = w / w.sum()
            gram = (Xs[:, self.columns_] * wn[:, None]).T @ Xs[:, self.columns_]
            cross = (Xs[:, self.columns_] * wn[:, None]).T @ Y
            self.weights_ = ridge_solve(gram, cross, self.penalty_)
        else:
            self.weights_ = np.zeros((0, Y.shape[1]))
        return self

    def _check(self) -> None:
        if not hasattr(self, "weights_"):
            raise NotFittedError("method 'ridge': call fit(interactions, rng=...) before start or predict")

    def displacement(self, rows: np.ndarray) -> np.ndarray:
        """(F, J·3) anchor-frame displacements, metres, for feature rows (F, N_FEATURES)."""
        self._check()
        if not self.groups_:
            return np.zeros((len(rows), self.weights_.shape[1]))
        return (rows[:, self.columns_] / self.scale_[self.columns_]) @ self.weights_

    def start(self, *, n_observed: int, offline: bool, rng: np.random.Generator) -> RidgeReactor:
        """A reactor for one instance (the same under every protocol: it uses only what each view holds)."""
        self._check()
        return RidgeReactor(self, n_observed)

    def predict(self, interaction: Interaction, *, n_observed: int, rng: np.random.Generator) -> Prediction:
        """Agent 1's whole track from one view of the whole instance (agent 1 after ``n_observed`` unused)."""
        view = interaction.hide_agent_after(1, n_observed).replace(subevents=None)
        return prediction_from_reactor(self.start(n_observed=n_observed, offline=True, rng=rng), view,
                                       n_observed=n_observed)


class RidgeReactor:
    """``ridge`` on one instance: feature rows of the requested frames, mapped to agent 1's skeleton."""

    def __init__(self, method: RidgeReaction, n_observed: int) -> None:
        self.method = method
        self.stream = FeatureStream(n_observed, method.config.features)

    def react(self, view: Interaction, start: int, stop: int) -> Prediction:
        """Agent 1's frames [start, stop) from ``view``."""
        rows = self.stream.rows(view, start, stop)
        joints = self.stream.anchor.to_world(self.method.displacement(rows))
        return Prediction(joints=joints, key_joints=view.layout.key_joints(joints), subevents=None, n_observed=0)
