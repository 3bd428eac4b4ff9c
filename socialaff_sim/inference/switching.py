"""The full model's reaction: a switching regression gated by the affordance model's sub-event belief.

The synthesizer (:class:`~socialaff_sim.inference.synthesis.OnlineSynthesizer`) runs as before and
gives, for every output frame t, its causal belief b_t (S,) over the running sub-event (the forward
filter's, from agent 0's and the object's frames before t), the elapsed fraction φ_t of the running
sub-event (from its start and predicted end), and its plan: agent 1's key joints synthesized by
Algorithm 2. Agent 1's pose at t is then agent 1's last observed pose plus a displacement of its whole
skeleton, in the anchor frame of :mod:`.reaction_features`, that is linear in

``agent0``, ``gap``, ``own_velocity``, ``agent0_velocity`` (49)
    the causal motion features of :mod:`.reaction_features` (those of the ``ridge`` baseline);
``subevent`` (S)
    b_t,s · r(s): a learned displacement per sub-event type, mixed by the belief, ramped from zero
    (r(s) = 1 − e^{−s/τ}, s seconds since agent 1's last observed frame);
``phase`` (S)
    b_t,s · φ_t · r(s): how that displacement grows as the sub-event runs (the phase of a ProMP, here the
    affordance model's);
``gated`` (S × the motion columns chosen)
    b_t,s · x_t: one linear map of the motion features per sub-event type, mixed by the belief — a mixture
    of linear experts gated by the model's causal sub-event belief, Σ_s b_t,s W_s x_t;
``plan`` (15)
    the plan's displacement of agent 1's key joints from their last observed position (anchor frame);
``from_plan`` (no columns)
    the prior: with it the displacement is the plan's (its whole skeleton, fitted to the planned key joints
    by the model's body fitter) plus the linear term, which the ridge penalty then shrinks toward the plan
    instead of toward ``hold``; alone, it is Algorithm 2's synthesis itself.

Which motion groups, which of these model-driven groups and the ridge penalty λ are chosen by an inner
cross-validation on the training instances (:mod:`.reaction_regression`; ``hold`` is a candidate and wins
ties), so a part of the affordance model is used only where it lowered the held-out error on the training
data; the same configuration (:class:`SwitchingConfig`) serves every dataset. The beliefs, phases and
plans of the training rows come from the synthesizer run causally over each training instance with the
model fitted on all of them (the inner CV therefore sees in-sample beliefs and plans: slightly optimistic
about the model-driven groups; refitting the model per inner fold would triple the fit's cost).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..data.interaction import Interaction
from ..data.skeletons import N_KEY
from ..errors import ConfigError, ModelError, NotFittedError
from .protocol import DEFAULT_N_OBSERVED
from .reaction_features import FEATURE_GROUPS, N_FEATURES, RAMP_COLUMN, Anchor, FeatureConfig, group_columns, training_rows
from .reaction_regression import HOLD, cv_errors, inner_folds, key_columns, ridge_solve, scale_of, select

__all__ = [
    "HOLD", "MODEL_GROUPS", "SwitchingConfig", "SwitchingRegression", "Trace", "instance_rows", "plan_displacement",
    "plan_offset", "switching_columns", "switching_rows",
]

MODEL_GROUPS: tuple[str, ...] = ("subevent", "phase", "gated", "plan", "from_plan")
"""The groups driven by the affordance model (the first four are columns, in order after the motion features;
``from_plan`` is the prior)."""


def _motion_subsets() -> tuple[tuple[str, ...], ...]:
    return tuple(c for r in range(1, len(FEATURE_GROUPS) + 1) for c in itertools.combinations(FEATURE_GROUPS, r))


_EXTRAS: tuple[tuple[str, ...], ...] = (
    (), ("subevent",), ("subevent", "phase"), ("subevent", "phase", "gated"), ("plan",),
    ("from_plan",), ("from_plan", "subevent", "phase"), ("from_plan", "subevent", "phase", "gated"),
)


@dataclass(frozen=True)
class SwitchingConfig:
    """Settings of the switching regression (fixed before any evaluation; the inner CV chooses among the
    candidates, each a set of motion groups joined with a set of model-driven groups)."""

    features: FeatureConfig = field(default_factory=FeatureConfig)
    """[—]: How the motion features are computed (as ``ridge``'s)."""
    motion: tuple[tuple[str, ...], ...] = field(default_factory=_motion_subsets)
    """[—]: Sets of motion groups (:data:`~.reaction_features.FEATURE_GROUPS`) the inner CV chooses among."""
    extras: tuple[tuple[str, ...], ...] = _EXTRAS
    """[—]: Sets of model-driven groups (:data:`MODEL_GROUPS`) joined to each motion set (and, when not empty,
    also used without motion features); ``()`` is the motion features alone (the ``ridge`` baseline's
    candidates)."""
    penalties: tuple[float, ...] = (1e-3, 1e-2, 0.1, 1.0, 10.0, 100.0)
    """λ [—]: Ridge penalties the inner CV chooses among (unit-RMS features, rows weighing one per instance)."""
    inner_folds: int = 3
    """[—]: Folds of the inner cross-validation on the training instances."""
    n_observed: int = DEFAULT_N_OBSERVED
    """T0 [frames]: agent 1's observed frames when the training rows are built (the evaluation's T0)."""
    fallback: tuple[tuple[str, ...], float] = (FEATURE_GROUPS + ("subevent",), 10.0)
    """[—]: (groups, λ) used when the training set has a single instance (no inner CV is possible)."""

    def __post_init__(self) -> None:
        if not self.penalties or not all(p > 0 and math.isfinite(p) for p in self.penalties):
            raise ConfigError(f"penalties: expected finite values > 0, found {self.penalties}")
        bad = {g for c in self.motion for g in c} - set(FEATURE_GROUPS)
        if bad or not self.motion or not all(self.motion):
            raise ConfigError(f"motion: expected non-empty sets of {FEATURE_GROUPS}, found unknown {sorted(bad)}")
        bad = {g for c in self.extras for g in c} - set(MODEL_GROUPS)
        if bad or not self.extras:
            raise ConfigError(f"extras: expected sets of {MODEL_GROUPS}, found unknown {sorted(bad)}")
        if self.inner_folds < 2:
            raise ConfigError(f"inner_folds: expected at least 2, found {self.inner_folds}")
        if self.n_observed < 1:
            raise ConfigError(f"n_observed: expected at least 1, found {self.n_observed}")

    def candidates(self) -> tuple[tuple[str, ...], ...]:
        """Every candidate's groups: each motion set joined with each set of model-driven groups, and each
        non-empty set of model-driven groups alone."""
        return tuple(m + e for e in self.extras for m in ((),) * bool(e) + self.motion)


@dataclass(frozen=True, eq=False)
class Trace:
    """What the synthesizer gave for every frame of one instance (frames < T0 unused)."""

    belief: np.ndarray
    """(T, S) float64: the step's belief over the running sub-event (sums to one)."""
    phase: np.ndarray
    """(T,) float64 in [0, 1]: elapsed fraction of the running sub-event (NaN while observed)."""
    plan: np.ndarray
    """(T, 5, 3) float64, metres, world: agent 1's key joints as Algorithm 2 synthesized them."""
    skeleton: np.ndarray
    """(T, J, 3) float64, metres, world: agent 1's skeleton fitted to ``plan`` (frames ≥ T0; NaN before)."""


def switching_columns(groups: Sequence[str], n_subevents: int) -> np.ndarray:
    """Column indices (int64) of ``groups`` in the rows of :func:`switching_rows` with S = ``n_subevents``;
    ``gated`` takes the gated copies of the motion groups in ``groups`` only."""
    S, F = n_subevents, N_FEATURES
    motion = group_columns([g for g in groups if g in FEATURE_GROUPS])
    out = [motion]
    if "subevent" in groups:
        out.append(F + np.arange(S))
    if "phase" in groups:
        out.append(F + S + np.arange(S))
    if "gated" in groups:
        out.append((F + 2 * S + F * np.arange(S)[:, None] + motion[None]).reshape(-1))
    if "plan" in groups:
        out.append(F + 2 * S + S * F + np.arange(3 * N_KEY))
    return np.concatenate(out).astype(np.int64)


def switching_rows(motion: np.ndarray, belief: np.ndarray, phase: np.ndarray, plan: np.ndarray) -> np.ndarray:
    """(N, F + 2S + S·F + 15) rows: the motion features (N, F), b·r (N, S), b·φ·r (N, S), the gated motion
    features b_s·x (N, S·F; column F + 2S + s·F + j is b_s·x_j) and the plan's displacement (N, 15), from the
    motion features (N, F), the belief (N, S), the phase (N,) (NaN counts as 0) and the plan's displacement
    (N, 15), metres, anchor frame."""
    x = np.asarray(motion, dtype=np.float64)
    b = np.asarray(belief, dtype=np.float64)
    ramp = x[:, RAMP_COLUMN]
    phi = np.nan_to_num(np.asarray(phase, dtype=np.float64))
    gated = (b[:, :, None] * x[:, None, :]).reshape(len(x), -1)
    return np.concatenate([x, b * ramp[:, None], b * (phi * ramp)[:, None], gated, np.nan_to_num(plan)], axis=1)


def plan_displacement(anchor: Anchor, plan: np.ndarray, interaction: Interaction) -> np.ndarray:
    """(N, 15) metres, anchor frame: the planned key joints (N, 5, 3) world minus agent 1's at the anchor
    (0 where either is unknown)."""
    keys = interaction.layout.key_joints(anchor.pose[None])[0]
    d = (np.asarray(plan, dtype=np.float64) - keys[None]) @ anchor.frame.rotation
    return np.nan_to_num(d).reshape(len(d), -1)


def plan_offset(anchor: Anchor, skeleton: np.ndarray) -> np.ndarray:
    """(N, J·3) metres, anchor frame: the plan's skeletons (N, J, 3) world minus agent 1's at the anchor (0 where
    either is unknown): the ``from_plan`` prior."""
    d = (np.asarray(skeleton, dtype=np.float64) - anchor.pose[None]) @ anchor.frame.rotation
    return np.nan_to_num(d).reshape(len(d), -1)


def instance_rows(
    interaction: Interaction, trace: Trace, n_observed: int, config: FeatureConfig
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows (N, ·) of :func:`switching_rows`, targets (N, J·3) (anchor-frame displacements, metres) and the
    ``from_plan`` prior (N, J·3) of frames T0 … T − 1 of a training instance."""
    X, Y, frames = training_rows(interaction, n_observed, config)
    anchor = Anchor.from_view(interaction.hide_agent_after(1, n_observed), n_observed, config)
    plan = plan_displacement(anchor, trace.plan[frames], interaction)
    rows = switching_rows(X, trace.belief[frames], trace.phase[frames], plan)
    return rows, Y, plan_offset(anchor, trace.skeleton[frames])


class SwitchingRegression:
    """The switching regression (module docstring). Learned attributes: ``n_subevents_`` (S), ``groups_``
    (selected groups; ``()`` is ``hold``), ``penalty_`` (λ, ``inf`` for ``hold``), ``cv_errors_``
    ({(groups, λ): mean held-out key-joint error, m}), ``columns_``, ``scale_`` (the columns' RMS),
    ``weights_`` (len(columns_), J·3)."""

    def __init__(self, config: SwitchingConfig | None = None) -> None:
        self.config = config or SwitchingConfig()

    def fit(
        self, interactions: Sequence[Interaction], traces: Sequence[Trace], *, n_subevents: int, rng: np.random.Generator
    ) -> SwitchingRegression:
        """Choose the groups and λ by inner CV on ``interactions`` (one class; ``traces`` their synthesizer
        traces), then refit on all of them."""
        cfg = self.config
        if len(traces) != len(interactions):
            raise ModelError(f"switching regression: {len(interactions)} interactions but {len(traces)} traces")
        xs, ys, os_, ws, ids = [], [], [], [], []
        for i, (inst, trace) in enumerate(zip(interactions, traces, strict=True)):
            if inst.n_frames <= cfg.n_observed:
                continue
            X, Y, O = instance_rows(inst, trace, cfg.n_observed, cfg.features)
            xs.append(X)
            ys.append(Y)
            os_.append(O)
            ws.append(np.full(len(X), 1.0 / len(X)))
            ids.append(np.full(len(X), i))
        if not xs:
            raise ModelError(f"switching regression: expected a training instance longer than T0 = {cfg.n_observed} frames")
        X, Y, w, row_ids = np.concatenate(xs), np.concatenate(ys), np.concatenate(ws), np.concatenate(ids)
        offset = np.concatenate(os_)
        self.n_subevents_ = int(n_subevents)
        self.scale_ = scale_of(X, w)
        Xs = X / self.scale_
        folds = inner_folds(interactions, np.unique(row_ids), cfg.inner_folds, rng)
        self.cv_errors_: dict[tuple[tuple[str, ...], float], float] = {}
        if len(folds) >= 2:
            candidates = {g: switching_columns(g, self.n_subevents_) for g in cfg.candidates()}
            kc = key_columns(interactions[0])
            self.cv_errors_ = cv_errors(Xs, Y[:, kc], w, row_ids, folds, candidates, cfg.penalties, offset=offset[:, kc],
                                        from_offset=[g for g in candidates if "from_plan" in g])
            self.groups_, self.penalty_ = select(self.cv_errors_)
        else:
            self.groups_, self.penalty_ = tuple(cfg.fallback[0]), float(cfg.fallback[1])
        self.from_plan_ = "from_plan" in self.groups_
        self.columns_ = switching_columns(self.groups_, self.n_subevents_)
        target = Y - offset if self.from_plan_ else Y
        if len(self.columns_) and math.isfinite(self.penalty_):
            wn = w / w.sum()
            Xc = Xs[:, self.columns_]
            self.weights_ = ridge_solve((Xc * wn[:, None]).T @ Xc, (Xc * wn[:, None]).T @ target, self.penalty_)
        else:
            self.columns_ = np.zeros(0, np.int64)
            self.weights_ = np.zeros((0, Y.shape[1]))
        return self

    def displacement(self, rows: np.ndarray, offset: np.ndarray) -> np.ndarray:
        """(N, J·3) anchor-frame displacements, metres, for rows (N, ·) of :func:`switching_rows` and the
        ``from_plan`` prior ``offset`` (N, J·3) (:func:`plan_offset`; read only if the prior was selected)."""
        if not hasattr(self, "weights_"):
            raise NotFittedError("switching regression: call fit(...) before displacement")
        base = np.asarray(offset, dtype=np.float64) if self.from_plan_ else np.zeros((len(rows), self.weights_.shape[1]))
        if not len(self.columns_):
            return base
        return base + (rows[:, self.columns_] / self.scale_[self.columns_]) @ self.weights_

    @property
    def uses_model(self) -> bool:
        """Whether the selected candidate reads the affordance model (a group of :data:`MODEL_GROUPS`)."""
        return any(g in MODEL_GROUPS for g in getattr(self, "groups_", ()))

